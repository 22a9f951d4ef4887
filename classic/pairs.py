"""Motion pairs ``(A_ij, B_ij)`` of AX=XB from absolute poses."""

from __future__ import annotations

import numpy as np

from handeye.se3 import make_transform
from handeye.setups import robot_side_poses

__all__ = ["PAIRINGS", "pair_indices", "relative_motions", "motion_pairs"]

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


def relative_motions(T: np.ndarray, i: np.ndarray, j: np.ndarray) -> np.ndarray:
    """Relative motions ``T_j T_i^-1`` for index pairs ``(i, j)``.

    Parameters
    ----------
    T : array, shape (N, 4, 4)
    i, j : array of int, shape (K,)

    Returns
    -------
    M : array, shape (K, 4, 4)
    """
    R, t = T[:, :3, :3], T[:, :3, 3]
    R_ij = R[j] @ np.swapaxes(R[i], 1, 2)
    t_ij = t[j] - np.einsum("kab,kb->ka", R_ij, t[i])
    return make_transform(R_ij, t_ij)


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
    i, j = pair_indices(len(T_base_ee), pairs)
    A = relative_motions(robot_side_poses(T_base_ee, setup), i, j)
    B = relative_motions(T_cam_target, i, j)
    return A, B
