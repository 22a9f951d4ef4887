"""The foundation's point-set geometry: the rigid fit (Kabsch/Umeyama), plain and robust, recovers known poses."""

from __future__ import annotations

import numpy as np
import pytest

from handeye.core.errors import ShapeError
from handeye.core.rigid import rigid_transform, robust_rigid_transform
from handeye.core.se3 import make_transform, so3_exp
from tests.tolerances import EXACT, FLOAT


def _pose(rng):
    return make_transform(so3_exp(rng.normal(size=3)), rng.normal(size=3))


def test_rigid_transform_exact_batched_and_weighted(rng):
    T = np.stack([_pose(rng) for _ in range(4)])
    p = rng.normal(size=(4, 10, 3))
    q = np.einsum("bij,bmj->bmi", T[:, :3, :3], p) + T[:, None, :3, 3]
    np.testing.assert_allclose(rigid_transform(p, q), T, atol=FLOAT)
    # a point with weight 0 or NaN takes no part
    q_bad = q.copy()
    q_bad[:, 0] += 5.0
    w = np.ones((4, 10))
    w[:, 0] = 0
    np.testing.assert_allclose(rigid_transform(p, q_bad, w), T, atol=FLOAT)
    q_bad[:, 0] = np.nan
    np.testing.assert_allclose(rigid_transform(p, q_bad), T, atol=FLOAT)
    # a reflection is never returned (Umeyama's fix) and fewer than 3 points give NaN
    assert np.linalg.det(rigid_transform(p[0], -q[0])[:3, :3]) == pytest.approx(1.0)
    assert np.isnan(rigid_transform(p[0, :2], q[0, :2])).all()
    with pytest.raises(ShapeError):
        rigid_transform(p[0], q[0, :5])


def test_robust_rigid_transform_ignores_outliers(rng):
    T = _pose(rng)
    p = rng.normal(size=(200, 3))
    q = p @ T[:3, :3].T + T[:3, 3]
    out = rng.random(200) < 0.25
    q[out] += rng.uniform(-1, 1, (out.sum(), 3))
    q[0] = np.nan
    T_hat, w = robust_rigid_transform(p, q, floor_m=1e-9)
    np.testing.assert_allclose(T_hat, T, atol=EXACT)  # exact inliers: the Cauchy scale shrinks to them
    assert w[0] == 0 and w[out].max() < 1e-6
