"""The foundation's point-set geometry: rigid fit (Kabsch/Umeyama) and PnP refinement recover known poses."""

from __future__ import annotations

import numpy as np
import pytest

from handeye.core.errors import ShapeError
from handeye.core.pnp import refine_pnp
from handeye.core.rigid import rigid_transform
from handeye.core.se3 import make_transform, so3_exp


def _pose(rng):
    return make_transform(so3_exp(rng.normal(size=3)), rng.normal(size=3))


def test_rigid_transform_exact_batched_and_weighted(rng):
    T = np.stack([_pose(rng) for _ in range(4)])
    p = rng.normal(size=(4, 10, 3))
    q = np.einsum("bij,bmj->bmi", T[:, :3, :3], p) + T[:, None, :3, 3]
    np.testing.assert_allclose(rigid_transform(p, q), T, atol=1e-12)
    # a point with weight 0 or NaN takes no part
    q_bad = q.copy()
    q_bad[:, 0] += 5.0
    w = np.ones((4, 10))
    w[:, 0] = 0
    np.testing.assert_allclose(rigid_transform(p, q_bad, w), T, atol=1e-12)
    q_bad[:, 0] = np.nan
    np.testing.assert_allclose(rigid_transform(p, q_bad), T, atol=1e-12)
    # a reflection is never returned (Umeyama's fix) and fewer than 3 points give NaN
    assert np.linalg.det(rigid_transform(p[0], -q[0])[:3, :3]) == pytest.approx(1.0)
    assert np.isnan(rigid_transform(p[0, :2], q[0, :2])).all()
    with pytest.raises(ShapeError):
        rigid_transform(p[0], q[0, :5])


def test_pnp_refinement_recovers_the_pose_from_a_rough_start(rng):
    T = make_transform(so3_exp(np.array([2.0, 0.3, 0.1])), [1.0, 0.5, 1.2])
    p_base = rng.uniform(-0.5, 0.5, (400, 3)) + [0, 0, 0.3]
    p_cam = (p_base - T[:3, 3]) @ T[:3, :3]
    k = np.array([300.0, 300.0, 128.0, 128.0])  # pixels
    x = np.stack([k[0] * p_cam[:, 0] / p_cam[:, 2] + k[2], k[1] * p_cam[:, 1] / p_cam[:, 2] + k[3]], axis=1)
    T0 = T @ make_transform(so3_exp([0.03, -0.02, 0.01]), [0.03, 0.02, -0.04])
    T_hat, w = refine_pnp(T0, p_base, x, k)
    np.testing.assert_allclose(T_hat, T, atol=1e-9)
    # gross outliers in a fifth of the observations are weighted out
    x_bad = x.copy()
    out = rng.random(len(x)) < 0.2
    x_bad[out] += rng.uniform(-80, 80, (out.sum(), 2))
    T_hat, w = refine_pnp(T0, p_base, x_bad, k, iterations=30)
    np.testing.assert_allclose(T_hat, T, atol=1e-9)  # exact inliers: the Cauchy scale shrinks to them
    assert w[out].mean() < 0.2 * w[~out].mean()
