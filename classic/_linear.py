"""Pieces shared by the closed-form solvers: stacked least squares, rotation clean-up."""

from __future__ import annotations

import numpy as np

from classic.motions import Motions
from handeye.core.errors import LengthMismatchError
from handeye.core.se3 import project_to_so3
from handeye.core.validation import check_transforms

__all__ = ["check_motions", "translation_stats", "translation_from_stats", "normalize_rotation"]


def check_motions(A: np.ndarray, B: np.ndarray, min_count: int, what: str) -> tuple[np.ndarray, np.ndarray]:
    """Validate the inputs of a plain solver: paired ``(K, 4, 4)`` rigid transforms."""
    A = check_transforms(A, "A")
    B = check_transforms(B, "B")
    if len(A) != len(B):
        raise LengthMismatchError(f"A has {len(A)} transforms but B has {len(B)}: they must pair one to one")
    if len(A) < min_count:
        from handeye.core.errors import TooFewPosesError

        raise TooFewPosesError(f"{what} needs at least {min_count} transforms, got {len(A)}")
    return A, B


def translation_stats(m: Motions) -> dict:
    """Sums over motions that determine ``t_X`` once ``R_X`` is known.

    ``(R_A - I) t_X = R_X t_B - t_A`` has normal equations
    ``sum (2 I - R_A - R_A^T) t_X = sum R_A^T R_X t_B - sum R_A^T t_A - R_X sum t_B + sum t_A``;
    the first term of the right side is ``T[a, b, c] R_X[b, c]`` with
    ``T[a, b, c] = sum R_A[b, a] t_B[c]``, so a single pass over the motions suffices.

    Parameters
    ----------
    m : Motions

    Returns
    -------
    dict of arrays
        ``n``, ``sum_R_A``, ``T``, ``sum_RAt_tA``, ``sum_t_A``, ``sum_t_B``.
    """
    R_A = m.R_A
    K = len(m)
    ones = np.ones(K)  # sums over motions as matrix products: BLAS, faster than axis-0 reductions
    R_flat = R_A.reshape(K, 9)
    return {
        "n": np.array(float(K)),
        "sum_R_A": (ones @ R_flat).reshape(3, 3),
        "T": (R_flat.T @ m.t_B).reshape(3, 3, 3).transpose(1, 0, 2),
        "sum_RAt_tA": np.einsum("bab->a", (R_flat.T @ m.t_A).reshape(3, 3, 3)),
        "sum_t_A": ones @ m.t_A,
        "sum_t_B": ones @ m.t_B,
    }


def translation_from_stats(st: dict, R_X: np.ndarray) -> np.ndarray:
    """Least-squares ``t_X`` from :func:`translation_stats` and ``R_X``.

    Parameters
    ----------
    st : dict
    R_X : array, shape (3, 3)

    Returns
    -------
    t_X : array, shape (3,)
    """
    S = st["sum_R_A"]
    G = 2.0 * st["n"] * np.eye(3) - S - S.T
    rhs = np.einsum("abc,bc->a", st["T"], R_X) - st["sum_RAt_tA"] - R_X @ st["sum_t_B"] + st["sum_t_A"]
    return np.linalg.lstsq(G, rhs, rcond=None)[0]


def normalize_rotation(M: np.ndarray) -> np.ndarray:
    """Rotation nearest to ``sign(det M) M``: the clean-up of a linear estimate of R.

    A linear solve returns a rotation up to scale and sign; the sign is the one
    that makes the determinant positive, then the SVD projection (as in
    OpenCV's ``normalizeRotation``) gives the nearest rotation.

    Parameters
    ----------
    M : array, shape (3, 3)

    Returns
    -------
    R : array, shape (3, 3)
    """
    d = np.linalg.det(M)
    return project_to_so3(M if d >= 0 else -M)
