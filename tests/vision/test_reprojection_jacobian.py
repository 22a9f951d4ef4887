"""The reprojection refinement's analytic Jacobian against central differences, with distortion and intrinsics."""

from __future__ import annotations

import numpy as np

from classic.vision.reprojection import _pose, _reprojection_jacobian, project
from handeye.core.se3 import invert_transform, make_transform, so3_exp
from tests.tolerances import JACOBIAN_RTOL
from tests.vision._helpers import SPEC


def test_reprojection_jacobian_matches_central_differences():
    rng = np.random.default_rng(0)
    m = 40
    A = make_transform(so3_exp(rng.normal(size=(m, 3))), rng.normal(scale=0.3, size=(m, 3)))
    X = make_transform(so3_exp(rng.normal(size=3)), rng.normal(scale=0.5, size=3))
    Y = make_transform(so3_exp(rng.normal(size=3)), rng.normal(scale=0.05, size=3))
    # put every corner in front of the camera: choose X so that the target is ~0.6 m ahead
    A = (
        X
        @ make_transform(
            so3_exp(rng.normal(scale=0.3, size=(m, 3))), [0.0, 0.0, 0.6] + rng.normal(scale=0.05, size=(m, 3))
        )
        @ invert_transform(Y)
    )
    p = SPEC.corners_target()[rng.integers(0, len(SPEC.corners_target()), m)]
    intr = np.array([600.0, 590.0, 320.0, 240.0, -0.2, 0.1, 0.002, -0.001, -0.02])

    def pixels(params):
        Xp, Yp = _pose(X, params[0:3], params[3:6]), _pose(Y, params[6:9], params[9:12])
        it = intr + params[12:]
        T = invert_transform(Xp) @ A @ Yp
        p_cam = np.einsum("mab,mb->ma", T[:, :3, :3], p) + T[:, :3, 3]
        return project(p_cam, *it[:4], it[4:9]).ravel()

    J = _reprojection_jacobian(A, X, Y, p, intr, True)
    h = np.r_[np.full(12, 1e-6), 1e-4, 1e-4, 1e-4, 1e-4, np.full(5, 1e-6)]
    J_num = np.stack([(pixels(hk * e) - pixels(-hk * e)) / (2 * hk) for hk, e in zip(h, np.eye(21))], axis=1)
    np.testing.assert_allclose(J, J_num, atol=JACOBIAN_RTOL * np.abs(J_num).max())
    np.testing.assert_allclose(_reprojection_jacobian(A, X, Y, p, intr, False), J[:, :12])
