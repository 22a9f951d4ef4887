"""Pieces shared by the closed-form solvers: stacked least squares, rotation clean-up, quaternion signs.

Quaternion signs near a half turn (:mod:`classic.motions`): the quaternion closed forms take their
statistics through :func:`split_near_half_turns`, which sums those of the motions below
:data:`classic.motions.NEAR_HALF_TURN_DEG` as they come (``w >= 0`` pairs their signs right) and
keeps the others aside; :func:`resolve_near_half_turns` then aligns the signs of those to a
reference rotation that no sign can spoil, Andreff's linear solve of ``R_A R_X = R_X R_B`` on
rotation matrices (:func:`sign_free_rotation`), and adds their statistics. One pass over the
motions, in chunks, as before; the motions near a half turn are held until the end (14 numbers
each).
"""

from __future__ import annotations

import numpy as np

from classic.motions import Motions, align_signs, near_half_turn
from handeye.core.errors import LengthMismatchError
from handeye.core.se3 import matrix_from_quat_xyzw, project_to_so3
from handeye.core.validation import check_transforms

__all__ = [
    "check_motions",
    "translation_stats",
    "translation_from_stats",
    "normalize_rotation",
    "sign_free_rotation_stats",
    "sign_free_rotation",
    "split_near_half_turns",
    "resolve_near_half_turns",
]

#: Motions per chunk that enter the sign-free reference rotation (every k-th, plus all of those
#: near a half turn): a rotation good to well under a degree from a few hundred motions, where the
#: sign alignment needs it within tens of degrees.
REFERENCE_ROWS = 512


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


def sign_free_rotation_stats(m: Motions, max_rows: int | None = None) -> np.ndarray:
    """``sum_k vec(R_A) vec(R_B)^T`` (row-major ``vec``): the rotation block of Andreff's system.

    Built from rotation matrices, so no quaternion sign enters.

    Parameters
    ----------
    m : Motions
    max_rows : int, optional
        Use every ``ceil(K / max_rows)``-th motion only (all when None).

    Returns
    -------
    array, shape (9, 9)
    """
    K = len(m)
    step = 1 if max_rows is None else max(1, -(-K // max_rows))
    R_A = matrix_from_quat_xyzw(m.q_A[::step], normalize=False).reshape(-1, 9)
    R_B = matrix_from_quat_xyzw(m.q_B[::step], normalize=False).reshape(-1, 9)
    return R_A.T @ R_B


def sign_free_rotation(RA_RB: np.ndarray) -> np.ndarray:
    r"""``R_X`` of ``R_A R_X = R_X R_B`` by Andreff's linear form, from :func:`sign_free_rotation_stats`.

    .. math:: \min_{|x| = 1} \sum_k |(I_9 - R_A \otimes R_B)\, x|^2
              = \max_{|x| = 1} x^T \big(\textstyle\sum_k R_A \otimes R_B + (\cdot)^T\big) x,

    ``x = vec(R_X)`` (row-major), projected on SO(3) (:func:`normalize_rotation`).

    Parameters
    ----------
    RA_RB : array, shape (9, 9)

    Returns
    -------
    R : array, shape (3, 3)
    """
    kron_sum = RA_RB.reshape(3, 3, 3, 3).transpose(0, 2, 1, 3).reshape(9, 9)
    _, vecs = np.linalg.eigh(kron_sum + kron_sum.T)
    return normalize_rotation(vecs[:, -1].reshape(3, 3))


def split_near_half_turns(core_stats):
    """Statistics of a chunk's motions with those near a half turn kept aside for sign alignment.

    Parameters
    ----------
    core_stats : callable
        ``Motions -> dict of arrays``: a solver's statistics, correct for motions whose
        quaternion signs pair right.

    Returns
    -------
    callable
        ``Motions -> dict``: ``core_stats`` of the motions below
        :data:`classic.motions.NEAR_HALF_TURN_DEG`, plus ``"near_half_turn"`` (the others, a
        :class:`Motions`) and ``"sign_free"`` (:func:`sign_free_rotation_stats` of a sample of
        the first); finish with :func:`resolve_near_half_turns`.
    """

    def stats(m: Motions) -> dict:
        near = near_half_turn(m)
        far = m if not near.any() else m.subset(~near)
        st = core_stats(far)
        st["near_half_turn"] = m.subset(near)
        st["sign_free"] = sign_free_rotation_stats(far, REFERENCE_ROWS)
        return st

    stats.__doc__ = core_stats.__doc__
    return stats


def resolve_near_half_turns(core_stats, st: dict) -> dict:
    """Add the statistics of the motions kept aside, with their signs aligned; see the module.

    Parameters
    ----------
    core_stats : callable
        The same ``Motions -> dict`` given to :func:`split_near_half_turns`.
    st : dict
        Its statistics summed over all chunks (:func:`classic.motions.accumulate`).

    Returns
    -------
    dict
        ``core_stats`` over all motions, signs paired.
    """
    st = dict(st)
    near = st.pop("near_half_turn")
    reference = st.pop("sign_free")
    if len(near) == 0:
        return st
    R_ref = sign_free_rotation(reference + sign_free_rotation_stats(near))
    near_st = core_stats(align_signs(near, R_ref))
    return {k: v + near_st[k] for k, v in st.items()}
