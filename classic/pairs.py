"""Motion pairs ``(A_ij, B_ij)`` of AX=XB from absolute poses."""

from __future__ import annotations

import numpy as np

from classic.motions import motions_from_poses
from handeye.core.se3 import make_transform
from handeye.core.setups import robot_side_poses

__all__ = ["PAIRINGS", "pair_indices", "motion_pairs"]

PAIRINGS = ("all", "consecutive")


def pair_indices(n: int, pairs: str = "all") -> tuple[np.ndarray, np.ndarray]:
    """Indices ``(i, j)``, ``i < j``, of the motion pairs taken from ``n`` poses.

    Parameters
    ----------
    n : int
        Number of poses.
    pairs : {"all", "consecutive"}
        All ``n (n - 1) / 2`` pairs, or the ``n - 1`` pairs ``(k, k + 1)``.

    Returns
    -------
    i, j : array of int, shape (K,)
    """
    if pairs == "all":
        return np.triu_indices(n, k=1)
    if pairs == "consecutive":
        return np.arange(n - 1), np.arange(1, n)
    raise ValueError(f"unknown pairs {pairs!r}: use one of {PAIRINGS}")


def motion_pairs(
    T_base_ee: np.ndarray, T_cam_target: np.ndarray, setup: str, pairs: str = "all"
) -> tuple[np.ndarray, np.ndarray]:
    """Robot and camera motions ``(A, B)`` with ``A_k X = X B_k``.

    ``X`` is ``T_base_cam`` (eye-to-hand) or ``T_ee_cam`` (eye-in-hand). For
    pair ``(i, j)``: eye-to-hand ``A = T_base_ee(j) T_base_ee(i)^-1``,
    eye-in-hand ``A = T_base_ee(j)^-1 T_base_ee(i)`` (OpenCV's ``Hg_ij``);
    both ``B = T_cam_target(j) T_cam_target(i)^-1``.

    Parameters
    ----------
    T_base_ee : array, shape (N, 4, 4)
    T_cam_target : array, shape (N, 4, 4)
    setup : {"eye_to_hand", "eye_in_hand"}
    pairs : {"all", "consecutive"}

    Returns
    -------
    A, B : array, shape (K, 4, 4)
    """
    m = motions_from_poses(robot_side_poses(T_base_ee, setup), T_cam_target, *pair_indices(len(T_base_ee), pairs))
    return make_transform(m.R_A, m.t_A), make_transform(m.R_B, m.t_B)
