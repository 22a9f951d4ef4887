"""Andreff linear AX=XB solver (Kronecker product)."""

from __future__ import annotations

import numpy as np

from classic._linear import check_motions, normalize_rotation
from classic.motions import Motions, motions_from_transforms
from classic.registry import Solver, register
from handeye.core.se3 import make_transform

__all__ = ["andreff", "andreff_stats", "andreff_finish"]


def andreff(A: np.ndarray, B: np.ndarray, translation: str = "resolve") -> np.ndarray:
    r"""Solve ``A_k X = X B_k`` by Andreff, Horaud and Espiau (1999).

    Rotation and translation in one linear least-squares system (row-major
    ``vec``):

    .. math::
        \begin{bmatrix} I_9 - R_A \otimes R_B & 0 \\
                        I_3 \otimes t_B^T & I_3 - R_A \end{bmatrix}
        \begin{bmatrix} \mathrm{vec}(R_X) \\ t_X \end{bmatrix}
        = \begin{bmatrix} 0 \\ t_A \end{bmatrix},

    then ``R_X`` is projected on SO(3). The joint solve's ``t_X`` (the paper's and OpenCV's
    ``CALIB_HAND_EYE_ANDREFF``) absorbs the rotation's error before projection and is several times
    worse than solving the translation again once the rotation is fixed,
    ``(R_A - I) t_X = R_X t_B - t_A`` (least squares): that is the default.

    Parameters
    ----------
    A, B : array, shape (K, 4, 4)
        Robot and camera motions, as for every AX=XB solver (:mod:`classic.registry`).
    translation : {"resolve", "joint"}
        Solve ``t_X`` again after the rotation (default), or keep the joint solve's (OpenCV's).

    Returns
    -------
    X : array, shape (4, 4)

    References
    ----------
    N. Andreff, R. Horaud, B. Espiau, "On-line hand-eye calibration", 3DIM 1999.
    """
    A, B = check_motions(A, B, 2, "andreff")
    if translation not in ("resolve", "joint"):
        raise ValueError(f"translation must be 'resolve' or 'joint', got {translation!r}")
    return andreff_finish(andreff_stats(motions_from_transforms(A, B)), resolve=translation == "resolve")


def andreff_stats(m: Motions) -> dict:
    """A chunk's statistics for :func:`andreff_finish` (:mod:`classic.registry`)."""
    # Normal equations of the stacked (12K x 12) system, summed block by block over motions
    # with matrix products over k (no per-motion 9x9 Kronecker products are formed).
    K = len(m)
    R_A, R_B, t_A, t_B = m.R_A, m.R_B, m.t_A, m.t_B
    return {
        "n": np.array(float(K)),
        "RA_RB": R_A.reshape(K, 9).T @ R_B.reshape(K, 9),
        "tB_tB": t_B.T @ t_B,
        "tB_RA": np.tensordot(t_B, R_A, axes=(0, 0)),
        "tA_tB": t_A.T @ t_B,
        "sum_R_A": R_A.sum(axis=0),
        "sum_t_A": t_A.sum(axis=0),
        "sum_t_B": t_B.sum(axis=0),
        "sum_RAt_tA": np.tensordot(R_A, t_A, axes=([0, 1], [0, 1])),
    }


def andreff_finish(st: dict, resolve: bool = True) -> np.ndarray:
    """``X`` from the summed :func:`andreff_stats` (:mod:`classic.registry`); ``resolve=False`` keeps the joint
    solve's translation (:func:`andreff`'s ``translation="joint"``)."""
    K = st["n"]
    I3 = np.eye(3)
    kron_sum = st["RA_RB"].reshape(3, 3, 3, 3).transpose(0, 2, 1, 3).reshape(9, 9)
    S = st["sum_R_A"]
    G = np.zeros((12, 12))
    G[:9, :9] = 2.0 * K * np.eye(9) - kron_sum - kron_sum.T + np.kron(I3, st["tB_tB"])
    # (I3 kron t_B)(I3 - R_A): entry [(a, b), c] = t_B[b] (delta_ac - R_A[a, c])
    C = np.einsum("ac,b->abc", I3, st["sum_t_B"]) - st["tB_RA"].transpose(1, 0, 2)
    G[:9, 9:] = C.reshape(9, 3)
    G[9:, :9] = G[:9, 9:].T
    G[9:, 9:] = 2.0 * K * I3 - S - S.T
    rhs = np.concatenate([st["tA_tB"].reshape(9), st["sum_t_A"] - st["sum_RAt_tA"]])
    x = np.linalg.lstsq(G, rhs, rcond=None)[0]
    R_X = normalize_rotation(x[:9].reshape(3, 3))
    if not resolve:
        return make_transform(R_X, x[9:])
    # sum_k (I - R_A)^T (t_A - R_X t_B), with R_X fixed: the translation rows' normal equations
    RAt_RX_tB = np.einsum("bc,cba->a", R_X, st["tB_RA"])  # sum_k R_A^T R_X t_B
    rhs_t = st["sum_t_A"] - st["sum_RAt_tA"] - R_X @ st["sum_t_B"] + RAt_RX_tB
    return make_transform(R_X, np.linalg.lstsq(G[9:, 9:], rhs_t, rcond=None)[0])


register(Solver("andreff", "AX=XB", "Andreff-Horaud-Espiau 1999: Kronecker product", 40, andreff_stats, andreff_finish))
