"""Motion pairs ``(A_ij, B_ij)`` of AX=XB from absolute poses, bounded in number.

``pairs="all"`` takes every pair ``(i, j)``, ``i < j``, while there are at most :data:`MAX_PAIRS` of
them (up to 707 poses): the answers on ordinary sets are those of all pairs. Beyond, all pairs would
grow with the square of the poses (10,000 poses: 50 million pairs, 11.5 GB), so each pose ``i`` is
paired with the poses ``(i + d) mod n`` for ``k = max(1, MAX_PAIRS // n)`` strides ``d``
(:func:`bounded_strides`): ``d = 1`` (the recording's neighbours) and ``k - 1`` strides spread over
``[2, n / 2]`` by the golden-ratio sequence, ``d_m = 2 + floor(frac(m phi) (n // 2 - 1))``. The index
gaps then cover the whole recording, short and long, without repeating a period of the trajectory, so
the pairs keep the rotation diversity of the set (a pose pairs with ones recorded far from it, not only
with its neighbours); every pose is in at least two pairs, and the rule is deterministic. The pairs serve
the closed-form starts and the motion and consistency checks; the refinement, the outlier test and the
covariance work on the poses themselves, so the answer's accuracy does not depend on the pairs.
"""

from __future__ import annotations

import numpy as np

from classic.motions import motions_from_poses
from handeye.core.se3 import make_transform
from handeye.core.setups import robot_side_poses

__all__ = [
    "PAIRINGS",
    "MAX_PAIRS",
    "pair_indices",
    "bounded_strides",
    "unique_sorted",
    "describe_pairs",
    "motion_pairs",
]

PAIRINGS = ("all", "consecutive")

#: Most motion pairs ``pairs="all"`` takes: all pairs of up to 707 poses; beyond, :func:`bounded_strides`.
#: The motions of 250,000 pairs take about 100 MB and 0.5 s; the closed forms' statistics and the
#: checks' quantiles over them have long settled.
MAX_PAIRS = 250_000

_GOLDEN = (1.0 + 5.0**0.5) / 2.0


def bounded_strides(n: int, max_pairs: int = MAX_PAIRS) -> np.ndarray:
    """The index strides of the bounded ``all`` rule: ``1`` and golden-ratio spread strides in ``[2, n / 2]``.

    Parameters
    ----------
    n : int
        Number of poses.
    max_pairs : int

    Returns
    -------
    array of int, shape (k,)
        Distinct strides, ``k <= max(1, max_pairs // n)``, ascending.
    """
    k = max(1, max_pairs // max(n, 1))
    half = max(n // 2, 1)
    m = np.arange(1, k)
    spread = 2 + np.floor(np.mod(m * _GOLDEN, 1.0) * max(half - 1, 0)).astype(np.int64)
    return np.unique(np.concatenate([[1], np.minimum(spread, half)])).astype(np.int64)


def pair_indices(n: int, pairs: str = "all", max_pairs: int = MAX_PAIRS) -> tuple[np.ndarray, np.ndarray]:
    """Indices ``(i, j)``, ``i < j``, of the motion pairs taken from ``n`` poses.

    Parameters
    ----------
    n : int
        Number of poses.
    pairs : {"all", "consecutive"}
        All ``n (n - 1) / 2`` pairs while at most ``max_pairs`` (beyond, each pose with the poses
        :func:`bounded_strides` away, see the module), or the ``n - 1`` pairs ``(k, k + 1)``.
    max_pairs : int

    Returns
    -------
    i, j : array of int, shape (K,)
        Each pair once, sorted by ``i`` then ``j``.
    """
    if pairs == "all":
        if n * (n - 1) // 2 <= max_pairs:
            return np.triu_indices(n, k=1)
        strides = bounded_strides(n, max_pairs)
        k = np.repeat(np.arange(n, dtype=np.int64), len(strides))
        other = (k + np.tile(strides, n)) % n
        code = unique_sorted(np.minimum(k, other) * n + np.maximum(k, other))  # each pair once, in (i, j) order
        return code // n, code % n
    if pairs == "consecutive":
        return np.arange(n - 1), np.arange(1, n)
    raise ValueError(f"unknown pairs {pairs!r}: use one of {PAIRINGS}")


def unique_sorted(codes: np.ndarray) -> np.ndarray:
    """The distinct values of an integer array, ascending: ``np.unique`` by one sort (numpy 2's hashing
    ``np.unique`` took 7 s on 2.4 million pair codes, a sort 0.1 s).

    Parameters
    ----------
    codes : array of int, shape (K,)

    Returns
    -------
    array of int, shape (K',)
    """
    c = np.sort(np.asarray(codes).ravel())
    if len(c) == 0:
        return c
    return c[np.concatenate([[True], c[1:] != c[:-1]])]


def describe_pairs(n: int, pairs: str = "all", max_pairs: int = MAX_PAIRS) -> dict:
    """The pairs :func:`pair_indices` takes, as a JSON-ready record for a result's diagnostics.

    Parameters
    ----------
    n : int
    pairs : {"all", "consecutive"}
    max_pairs : int

    Returns
    -------
    dict
        ``pairs`` (the option), ``rule`` (``all``, ``bounded`` or ``consecutive``), ``n_pairs``,
        ``all_pairs`` (``n (n - 1) / 2``), and for ``bounded`` the ``strides`` and ``max_pairs``.
    """
    total = n * (n - 1) // 2
    if pairs == "consecutive":
        return {"pairs": pairs, "rule": "consecutive", "n_pairs": max(n - 1, 0), "all_pairs": total}
    if total <= max_pairs:
        return {"pairs": pairs, "rule": "all", "n_pairs": total, "all_pairs": total}
    strides = bounded_strides(n, max_pairs)
    return {
        "pairs": pairs,
        "rule": "bounded",
        "n_pairs": int(len(pair_indices(n, pairs, max_pairs)[0])),
        "all_pairs": total,
        "max_pairs": max_pairs,
        "strides": [int(d) for d in strides],
        "text": f"each pose paired with the poses {len(strides)} index strides away (mod n): 1 and "
        f"golden-ratio spread strides in [2, n/2], as all {total} pairs exceed {max_pairs}",
    }


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
        ``all`` is bounded by :data:`MAX_PAIRS` (see the module).

    Returns
    -------
    A, B : array, shape (K, 4, 4)
    """
    m = motions_from_poses(robot_side_poses(T_base_ee, setup), T_cam_target, *pair_indices(len(T_base_ee), pairs))
    return make_transform(m.R_A, m.t_A), make_transform(m.R_B, m.t_B)
