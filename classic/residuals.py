"""The measurement model ``B_i = X^-1 A_i Y`` and its residuals per pose."""

from __future__ import annotations

import numpy as np

from handeye.core.se3 import invert_transform, make_transform, project_to_so3, so3_log

__all__ = ["predict_cam_target", "pose_residuals", "residuals_of_prediction", "estimate_target_pose"]


def predict_cam_target(A: np.ndarray, X: np.ndarray, Y: np.ndarray) -> np.ndarray:
    """Predicted camera measurement ``T_cam_target = X^-1 A_i Y``.

    Parameters
    ----------
    A : array, shape (N, 4, 4)
        Robot-side poses of :mod:`handeye.core.setups` (``T_base_ee`` or ``T_ee_base``).
    X, Y : array, shape (4, 4)
        Camera pose and target pose of the setup.

    Returns
    -------
    T_cam_target : array, shape (N, 4, 4)
    """
    return invert_transform(X) @ A @ Y


def pose_residuals(A: np.ndarray, B: np.ndarray, X: np.ndarray, Y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Residuals of the measured ``B_i = T_cam_target(i)`` against the prediction.

    ``r_rot = log(R_pred^T R_B)`` (radians, in the target frame) and
    ``r_trans = t_B - t_pred`` (metres, in the camera frame): the noise model
    of :mod:`handeye.core.synthetic`.

    Parameters
    ----------
    A, B : array, shape (N, 4, 4)
    X, Y : array, shape (4, 4)

    Returns
    -------
    r_rot : array, shape (N, 3)
    r_trans : array, shape (N, 3)
    """
    return residuals_of_prediction(predict_cam_target(A, X, Y), B)


def residuals_of_prediction(P: np.ndarray, B: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:func:`pose_residuals` from the predicted ``P_i = X^-1 A_i Y`` (shape (N, 4, 4)) and the measured ``B_i``."""
    r_rot = so3_log(np.swapaxes(P[:, :3, :3], 1, 2) @ B[:, :3, :3])
    r_trans = B[:, :3, 3] - P[:, :3, 3]
    return r_rot, r_trans


def estimate_target_pose(A: np.ndarray, B: np.ndarray, X: np.ndarray, weights: np.ndarray | None = None) -> np.ndarray:
    """Least-squares ``Y`` given ``X``: the chordal mean of ``A_i^-1 X B_i``.

    Parameters
    ----------
    A, B : array, shape (N, 4, 4)
    X : array, shape (4, 4)
    weights : array, shape (N,), optional

    Returns
    -------
    Y : array, shape (4, 4)
    """
    Y_i = invert_transform(A) @ X @ B
    w = np.ones(len(A)) if weights is None else np.asarray(weights, dtype=float)
    w = w / w.sum()
    R = project_to_so3(np.einsum("k,kab->ab", w, Y_i[:, :3, :3]))
    return make_transform(R, w @ Y_i[:, :3, 3])
