"""Pieces shared by the closed-form solvers: stacked least squares, rotation clean-up."""

from __future__ import annotations

import numpy as np

from classic.motions import Motions
from handeye.errors import LengthMismatchError
from handeye.se3 import project_to_so3
from handeye.validation import check_transforms

__all__ = ["check_motions", "translation_axxb", "normalize_rotation"]


def check_motions(A: np.ndarray, B: np.ndarray, min_count: int, what: str) -> tuple[np.ndarray, np.ndarray]:
    """Validate the inputs of a plain solver: paired ``(K, 4, 4)`` rigid transforms."""
    A = check_transforms(A, "A")
    B = check_transforms(B, "B")
    if len(A) != len(B):
        raise LengthMismatchError(f"A has {len(A)} transforms but B has {len(B)}: they must pair one to one")
    if len(A) < min_count:
        from handeye.errors import TooFewPosesError

        raise TooFewPosesError(f"{what} needs at least {min_count} transforms, got {len(A)}")
    return A, B


def translation_axxb(m: Motions, R_X: np.ndarray) -> np.ndarray:
    """Translation of X from ``(R_A - I) t_X = R_X t_B - t_A`` over all motions.

    Least squares through the normal equations
    ``sum (2 I - R_A - R_A^T) t_X = sum (R_A - I)^T (R_X t_B - t_A)``.

    Parameters
    ----------
    m : Motions
    R_X : array, shape (3, 3)

    Returns
    -------
    t_X : array, shape (3,)
    """
    S = m.R_A.sum(axis=0)
    G = 2.0 * len(m) * np.eye(3) - S - S.T
    u = m.t_B @ R_X.T - m.t_A
    rhs = np.tensordot(m.R_A, u, axes=([0, 1], [0, 1])) - u.sum(axis=0)
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
