"""Error metrics between estimated and true poses, in degrees and millimetres."""

from __future__ import annotations

import numpy as np

from handeye.core.se3 import rotation_angle

__all__ = ["rotation_error_deg", "translation_error_mm", "pose_error"]


def rotation_error_deg(T_est: np.ndarray, T_true: np.ndarray) -> np.ndarray:
    """Angle of the relative rotation ``R_est^T R_true``, in degrees.

    Parameters
    ----------
    T_est, T_true : array, shape (..., 4, 4) or (..., 3, 3)
        Poses (or rotations) of the same frames, e.g. two ``T_base_cam``.

    Returns
    -------
    error_deg : array, shape (...)
        In ``[0, 180]``.
    """
    R_est = np.asarray(T_est, dtype=float)[..., :3, :3]
    R_true = np.asarray(T_true, dtype=float)[..., :3, :3]
    return np.degrees(rotation_angle(np.swapaxes(R_est, -1, -2) @ R_true))


def translation_error_mm(T_est: np.ndarray, T_true: np.ndarray) -> np.ndarray:
    """Euclidean distance between the translations, in millimetres.

    Parameters
    ----------
    T_est, T_true : array, shape (..., 4, 4)
        Poses in metres.

    Returns
    -------
    error_mm : array, shape (...)
    """
    t_est = np.asarray(T_est, dtype=float)[..., :3, 3]
    t_true = np.asarray(T_true, dtype=float)[..., :3, 3]
    return 1000.0 * np.linalg.norm(t_est - t_true, axis=-1)


def pose_error(T_est: np.ndarray, T_true: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Rotation error (degrees) and translation error (millimetres).

    Parameters
    ----------
    T_est, T_true : array, shape (..., 4, 4)

    Returns
    -------
    rotation_deg : array, shape (...)
    translation_mm : array, shape (...)
    """
    return rotation_error_deg(T_est, T_true), translation_error_mm(T_est, T_true)
