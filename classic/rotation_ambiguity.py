"""Rotations of X that fit the camera's motions equally well: half turns the motions commute with.

``A_k X = X B_k`` fixes ``R_X`` only up to a rotation ``R_s`` that commutes with every camera motion
``R_B``: ``R_A (R_X R_s) = (R_X R_s) R_B`` whenever ``R_s R_B = R_B R_s``. Motions about one axis leave a
whole circle of such ``R_s`` (refused by :func:`classic.diagnostics.diagnose_motion`), but a set whose
motions are all half turns about a few axes leaves a finite set: half turns about two axes commute with a
half turn about their common normal, half turns about three perpendicular axes with half turns about each
of them. A robot that flips its wrist by 180 degrees between poses records such a set. Every rotation-based
closed form then picks one of the equally good rotations by its own arithmetic (this project's and OpenCV's
alike), and the refinement, which is local, keeps it: a 180-degree error with a sigma of hundredths of a
degree.

:func:`commuting_half_turns` finds the half turns that commute with the camera's motions from the absolute
poses (``R_B_j R_B_i^T`` commutes with ``R_s`` for every pair exactly when the axis of ``R_s`` seen in the
target frame, ``R_B_i^T c``, is the same line for every pose); the translations, which the rotations do not
see, then decide between the candidate rotations (:func:`classic.starts.best_start`).

Written here because no library offers it: it is a property of the hand-eye equations.
"""

from __future__ import annotations

import numpy as np

from classic.shah import translations_axyb
from handeye.core.se3 import make_transform, project_to_so3

__all__ = ["AMBIGUITY_TOLERANCE_RAD", "commuting_half_turns", "half_turn", "solve_translations"]

#: A half turn is taken to commute with the motions when its axis, carried into the target frame by every
#: camera pose, stays within this angle (RMS over the poses) of one line. Far above a camera's rotation noise
#: (0.01-0.5 deg) and far below the spread of any set that determines X (tens of degrees).
AMBIGUITY_TOLERANCE_RAD = np.radians(2.0)


def half_turn(axis: np.ndarray) -> np.ndarray:
    """The rotation by 180 degrees about ``axis``: ``2 a a^T - I``, shape (3, 3)."""
    a = np.asarray(axis, dtype=float)
    a = a / np.linalg.norm(a)
    return 2.0 * np.outer(a, a) - np.eye(3)


def commuting_half_turns(R_cam_target: np.ndarray, tolerance_rad: float = AMBIGUITY_TOLERANCE_RAD) -> np.ndarray:
    """Axes (camera frame) of the half turns that commute with every camera motion, within ``tolerance_rad``.

    The symmetric matrix ``U = u u^T`` of an axis ``u`` in the target frame must satisfy
    ``Q_i U Q_i^T = U`` for ``Q_i = R_B_0^T R_B_i``, a linear condition on ``U``; the identity always
    satisfies it, so a second solution (a null space of dimension two or more) means an ambiguity. Each
    eigenvector of a null solution's traceless part is a candidate axis; those whose lines ``R_B_i u`` stay
    within the tolerance are returned, carried into the camera frame of pose 0.

    Parameters
    ----------
    R_cam_target : array, shape (N, 3, 3)
        Rotations of the camera's target poses.
    tolerance_rad : float

    Returns
    -------
    axes : array, shape (M, 3)
        Unit axes in the camera frame (M = 0 when the motions fix the rotation).
    """
    R = np.asarray(R_cam_target, dtype=float)
    Q = np.einsum("ji,njk->nik", R[0], R)  # R_0^T R_i
    # vec(Q U Q^T - U) = (Q kron Q - I) vec(U), on symmetric U: stack and find the near-null directions
    K = np.einsum("nij,nkl->nikjl", Q, Q).reshape(len(Q), 9, 9) - np.eye(9)
    _, s, Vt = np.linalg.svd(K.reshape(-1, 9), full_matrices=False)
    scale = np.sqrt(len(Q))
    axes = []
    for k in np.flatnonzero(s <= 2.0 * tolerance_rad * scale):
        U = Vt[k].reshape(3, 3)
        U = 0.5 * (U + U.T)
        U -= np.trace(U) / 3.0 * np.eye(3)
        if np.linalg.norm(U) < 1e-9:  # the identity's direction
            continue
        for u in np.linalg.eigh(U)[1].T:
            lines = R @ u  # the axis seen from every pose's camera frame, as the target carries it
            c = np.linalg.eigh(np.einsum("ni,nj->ij", lines, lines))[1][:, -1]
            off = np.sqrt(np.mean(1.0 - np.clip(np.abs(lines @ c), 0.0, 1.0) ** 2))
            if off <= np.sin(tolerance_rad) and not any(abs(c @ a) > np.cos(tolerance_rad) for a in axes):
                axes.append(c)
    return np.asarray(axes).reshape(-1, 3)


def solve_translations(A: np.ndarray, B: np.ndarray, R_X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``X`` and ``Y`` of ``A_i Y = X B_i`` for a given ``R_X``: ``R_Y`` the chordal mean, the translations by
    :func:`classic.shah.translations_axyb`.

    Parameters
    ----------
    A, B : array, shape (N, 4, 4)
    R_X : array, shape (3, 3)

    Returns
    -------
    X, Y : array, shape (4, 4)
    """
    R_Y = project_to_so3(np.einsum("nji,jk,nkl->il", A[:, :3, :3], R_X, B[:, :3, :3]))  # sum R_A^T R_X R_B
    # A_i Y = X B_i is Shah's A_i X' = Y' B_i with X' = Y, Y' = X: R_A t_Y - t_X = R_X t_B - t_A
    t_Y, t_X = translations_axyb(A, B, R_X)
    return make_transform(R_X, t_X), make_transform(R_Y, t_Y)
