"""The point-to-plane residual's Jacobian (pose, depth scale and offset, stereo pixel locking) is its derivative."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from classic.markerless.point_to_plane import MatchedModel, PlaneFitOptions, _linearise, _Unknowns, apply_right
from handeye.core.se3 import make_transform
from tests.tolerances import ABSOLUTE_ONLY, JACOBIAN_RTOL


@pytest.mark.parametrize("locking", [False, True])
def test_jacobian_matches_central_differences(locking):
    rng = np.random.default_rng(5)
    n = 40
    q_obs = np.c_[rng.uniform(-0.3, 0.3, (n, 2)), rng.uniform(0.6, 1.9, n)]
    m_base = rng.normal(size=(n, 3))
    n_base = rng.normal(size=(n, 3))
    n_base /= np.linalg.norm(n_base, axis=1, keepdims=True)
    T = make_transform(Rotation.from_rotvec([0.3, -0.2, 0.5]).as_matrix(), [0.4, -0.1, 1.2])
    fb = 22.4 if locking else None  # a D435's f B at 448 px (pixels x metres)
    depth = np.array([1.01, -0.004, 0.12, -0.07]) if locking else np.array([1.01, -0.004])

    def linearise(T, depth):  # the residuals and Jacobian at the pose T and the depth correction depth
        unknowns = _Unknowns(PlaneFitOptions(scale_m=1.0, depth_start=depth, stereo_fb_px_m=fb), None)
        return _linearise(q_obs, MatchedModel(m_base, n_base), T, unknowns)

    r0, J = linearise(T, depth)
    assert J.shape == (n, 6 + len(depth))
    h = 1e-6
    for j in range(J.shape[1]):
        e = np.zeros(J.shape[1])
        e[j] = h
        up = linearise(apply_right(T, e[:6]), depth + e[6:])[0]
        down = linearise(apply_right(T, -e[:6]), depth - e[6:])[0]
        np.testing.assert_allclose(
            J[:, j],
            (up - down) / (2 * h),
            rtol=ABSOLUTE_ONLY,
            atol=JACOBIAN_RTOL * np.abs(J).max(),
            err_msg=f"column {j}",
        )
