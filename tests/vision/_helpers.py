"""Shared geometry for the vision tests: the board, the camera, poses, Jacobians, bias floors.

Parametrisation of pose perturbations, as in :mod:`classic.refine` and
:mod:`classic.vision.reprojection`: ``R <- so3_exp(w) R``, ``t <- t + v``, so a
rotation error is ``|w|`` (radians) and a translation error ``|v|`` (metres).
"""

from __future__ import annotations

import numpy as np

from classic.vision import BoardSpec
from classic.vision.detect import project_points
from classic.vision.synthetic import default_intrinsics
from handeye.core.se3 import invert_transform, make_transform, so3_exp, so3_log
from handeye.core.setups import robot_side_poses

SPEC = BoardSpec(7, 5, 0.04, 0.03, "5X5_100")
INTR = default_intrinsics()
#: Moves the target origin from the board's corner to its centre (as make_image_dataset does).
CENTRE = make_transform(np.eye(3), [-SPEC.size_m[0] / 2, -SPEC.size_m[1] / 2, 0.0])


def board_pose(rng: np.random.Generator, depth=(0.4, 0.8), tilt_deg=(10.0, 40.0)) -> np.ndarray:
    """``T_cam_target`` of a board whose centre is near the optical axis, tilted and turned."""
    z = rng.uniform(*depth)
    tilt = np.radians(rng.uniform(*tilt_deg))
    axis = rng.normal(size=2)
    axis /= np.linalg.norm(axis)
    R = so3_exp(np.array([axis[0] * tilt, axis[1] * tilt, rng.uniform(-0.5, 0.5)]))
    centre = np.array([rng.uniform(-0.08, 0.08) * z, rng.uniform(-0.06, 0.06) * z, z])
    return make_transform(R, centre) @ CENTRE


def perturbed(T: np.ndarray, d: np.ndarray) -> np.ndarray:
    """``T`` moved by ``d = (w, v)``: ``R <- so3_exp(w) R``, ``t <- t + v``."""
    return make_transform(so3_exp(d[:3]) @ T[:3, :3], T[:3, 3] + d[3:6])


def rotation_error_rad(T_est: np.ndarray, T_true: np.ndarray) -> float:
    return float(np.linalg.norm(so3_log(T_est[:3, :3] @ T_true[:3, :3].T)))


def translation_error_m(T_est: np.ndarray, T_true: np.ndarray) -> float:
    return float(np.linalg.norm(T_est[:3, 3] - T_true[:3, 3]))


def numeric_jacobian(f, n_params: int, h: float = 1e-6) -> np.ndarray:
    """Central differences of ``f(params) -> (m,)`` at zero; truncation error ~h^2."""
    cols = []
    for i in range(n_params):
        d = np.zeros(n_params)
        d[i] = h
        cols.append((f(d) - f(-d)) / (2 * h))
    return np.column_stack(cols)


def per_axis_sigma_px(rms_px: float, n_points: int, n_params: int) -> float:
    """Per-axis pixel noise from an RMS (over 2-D points) of residuals left by ``n_params`` parameters."""
    return float(rms_px * np.sqrt(n_points / (2 * n_points - n_params)))


def view_jacobian(T: np.ndarray, ids: np.ndarray, intr=INTR) -> np.ndarray:
    """d(projected corners, flattened (u0, v0, u1, ...)) / d(w, v) of one view's pose."""
    P = SPEC.corners_target()[ids]
    return numeric_jacobian(lambda d: project_points(P, perturbed(T, d), intr).ravel(), 6)


def handeye_jacobian(T_base_ee, corner_ids, X, Y, setup, intr=INTR) -> np.ndarray:
    """d(all projected corners) / d(wX, vX, wY, vY), the reprojection refinement's model."""
    A = robot_side_poses(np.asarray(T_base_ee), setup)

    def f(d):
        Xd, Yd = perturbed(X, d[:6]), perturbed(Y, d[6:])
        return np.concatenate(
            [
                project_points(SPEC.corners_target()[ids], invert_transform(Xd) @ A[k] @ Yd, intr).ravel()
                for k, ids in enumerate(corner_ids)
                if len(ids)
            ]
        )

    return numeric_jacobian(f, 12)


def common_shift_floor(J: np.ndarray, view_of_point: np.ndarray, shift_px: float) -> np.ndarray:
    """Worst-case parameter error, per 3-vector block, of a shift common to each view's corners.

    A least-squares fit moves by ``pinv(J) @ delta`` for a residual change
    ``delta``. A view-wide shift ``(bx, by)`` with ``|bx|, |by| <= shift_px`` is
    ``bx e_x + by e_y`` (``e_x`` the unit shift of that view's u's), so its
    effect on a block is at most ``shift_px (|pinv e_x| + |pinv e_y|)``, summed
    over views (shifts of different views may add up).

    Returns
    -------
    floor : array, shape (n_params // 3,)
        One bound per block (w, v, ...), in the parameters' units.
    """
    pinv = np.linalg.pinv(J)
    floor = np.zeros(J.shape[1] // 3)
    for v in np.unique(view_of_point):
        for axis in (0, 1):
            delta = np.zeros(J.shape[0])
            delta[2 * np.flatnonzero(view_of_point == v) + axis] = 1.0
            e = pinv @ delta
            floor += shift_px * np.linalg.norm(e.reshape(-1, 3), axis=1)
    return floor


def predicted_block_sigma(J: np.ndarray, sigma_px: float) -> np.ndarray:
    """``sqrt(trace)`` of each 3x3 block of ``sigma^2 (J^T J)^-1``."""
    C = sigma_px**2 * np.linalg.inv(J.T @ J)
    return np.sqrt([np.trace(C[k : k + 3, k : k + 3]) for k in range(0, J.shape[1], 3)])


def corners_in_image(T_cam_target: np.ndarray, intr=INTR, sigma_px: float = 0.0, rng=None):
    """Ids and projections (plus Gaussian pixel noise) of the corners that land inside the image."""
    P = SPEC.corners_target()
    uv = project_points(P, T_cam_target, intr)
    if sigma_px > 0:
        uv = uv + rng.normal(scale=sigma_px, size=uv.shape)
    z = P @ T_cam_target[:3, :3].T[:, 2] + T_cam_target[2, 3]
    inside = (z > 0) & np.all((uv >= 0) & (uv <= [intr.width - 1, intr.height - 1]), axis=1)
    return np.flatnonzero(inside), uv[inside]
