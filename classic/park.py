"""Park-Martin AX=XB solver."""

from __future__ import annotations

import numpy as np

from classic._linear import (
    check_motions,
    resolve_near_half_turns,
    split_near_half_turns,
    translation_from_stats,
    translation_stats,
)
from classic.motions import Motions, motions_from_transforms
from classic.registry import Solver, register
from handeye.core.se3 import make_transform, project_to_so3

__all__ = ["park", "park_stats", "park_finish"]


def park(A: np.ndarray, B: np.ndarray) -> np.ndarray:
    r"""Solve ``A_k X = X B_k`` by Park and Martin (1994).

    With ``alpha_k = log R_A``, ``beta_k = log R_B`` (rotation vectors),
    ``alpha_k = R_X beta_k``, and

    .. math:: M = \sum_k \beta_k \alpha_k^T, \qquad R_X = (M^T M)^{-1/2} M^T,

    the orthogonal polar factor of ``M^T`` (computed by SVD); then
    ``(R_A - I) t_X = R_X t_B - t_A``. Same algebra as OpenCV's
    ``CALIB_HAND_EYE_PARK`` (agreement to 1e-3 of the noise on motions below 120 degrees,
    tests/classic/test_opencv_agreement.py).

    Near a half turn ``alpha_k = R_X beta_k`` needs both logs on the same branch: noise can
    put a rotation of ``pi - e`` about ``n`` on one side and ``pi - e'`` about ``-n`` on the
    other, and the pair then pulls ``R_X`` the wrong way. Beyond 150 degrees the camera side's
    quaternion sign is aligned to the robot side's (:mod:`classic._linear`) and its log taken
    on that branch (an angle past ``pi`` where needed).

    Parameters and return: those of every AX=XB solver (:mod:`classic.registry`): motions ``A``, ``B`` of
    shape ``(K, 4, 4)``, ``X`` of shape ``(4, 4)``.

    References
    ----------
    F. C. Park, B. J. Martin, "Robot sensor calibration: solving AX = XB on the
    Euclidean group", IEEE Trans. Robotics and Automation 10(5), 1994.
    """
    A, B = check_motions(A, B, 2, "park")
    return park_finish(park_stats(motions_from_transforms(A, B)))


def _park_core(m: Motions) -> dict:
    """A chunk's statistics for :func:`park_finish` (:mod:`classic.registry`)."""
    return {"M": m.rotvec_B.T @ m.rotvec_A, **translation_stats(m)}


park_stats = split_near_half_turns(_park_core)


def park_finish(st: dict) -> np.ndarray:
    """``X`` from the summed :func:`park_stats` (:mod:`classic.registry`)."""
    st = resolve_near_half_turns(_park_core, st)
    R_X = project_to_so3(st["M"].T)
    return make_transform(R_X, translation_from_stats(st, R_X))


register(Solver("park", "AX=XB", "Park-Martin 1994: rotation logs, polar factor", 20, park_stats, park_finish))
