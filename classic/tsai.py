"""Tsai-Lenz AX=XB solver."""

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
from handeye.core.se3 import make_transform, matrix_from_quat_xyzw

__all__ = ["tsai", "tsai_stats", "tsai_finish"]


def tsai(A: np.ndarray, B: np.ndarray) -> np.ndarray:
    r"""Solve ``A_k X = X B_k`` by Tsai and Lenz (1989).

    With the modified Rodrigues vectors ``P = 2 sin(theta / 2) n`` of the
    motions, the rotation satisfies

    .. math:: [P_A + P_B]_\times P'_X = P_B - P_A, \qquad
              P_X = 2 P'_X / \sqrt{1 + |P'_X|^2},

    solved in least squares over all motions; then
    ``(R_A - I) t_X = R_X t_B - t_A``.

    The equation holds only when ``q_A`` and ``q_B`` of a motion carry the same sign
    (``q_A = q_X q_B q_X^-1``; near a half turn: :mod:`classic.registry`). OpenCV's ``CALIB_HAND_EYE_TSAI``
    solves the same equation but differs twice: it leaves out the motions with small rotations
    (so it is not the least-squares minimiser over all of them; the two agree to 0.05 of the
    noise on motions below 120 degrees, tests/classic/test_opencv_agreement.py), and beyond 120
    degrees it takes each side's sign from the largest of ``x, y, z`` (``rot2quatMinimal``),
    which can pair opposite signs: on motions near a half turn it can be many degrees off where
    this one is not (docs/benchmarks/classic.md, "Motions near a half turn").

    Parameters and return: those of every AX=XB solver (:mod:`classic.registry`): motions ``A``, ``B`` of
    shape ``(K, 4, 4)``, ``X`` of shape ``(4, 4)``.

    References
    ----------
    R. Y. Tsai, R. K. Lenz, "A new technique for fully autonomous and efficient
    3D robotics hand/eye calibration", IEEE Trans. Robotics and Automation
    5(3), 1989.
    """
    A, B = check_motions(A, B, 2, "tsai")
    return tsai_finish(tsai_stats(motions_from_transforms(A, B)))


def _tsai_core(m: Motions) -> dict:
    """A chunk's statistics for :func:`tsai_finish` (:mod:`classic.registry`)."""
    s = 2.0 * (m.q_A[:, :3] + m.q_B[:, :3])
    d = 2.0 * (m.q_B[:, :3] - m.q_A[:, :3])
    # normal equations of [s]x x = d: sum [s]x^T [s]x = sum(|s|^2) I - s^T s, sum [s]x^T d = -sum s x d
    s_x_d = np.stack(
        [
            s[:, 1] * d[:, 2] - s[:, 2] * d[:, 1],
            s[:, 2] * d[:, 0] - s[:, 0] * d[:, 2],
            s[:, 0] * d[:, 1] - s[:, 1] * d[:, 0],
        ],
        axis=1,
    )
    sTs = s.T @ s
    return {"G": np.trace(sTs) * np.eye(3) - sTs, "rhs": -(np.ones(len(m)) @ s_x_d), **translation_stats(m)}


tsai_stats = split_near_half_turns(_tsai_core)


def tsai_finish(st: dict) -> np.ndarray:
    """``X`` from the summed :func:`tsai_stats` (:mod:`classic.registry`)."""
    st = resolve_near_half_turns(_tsai_core, st)
    x = np.linalg.lstsq(st["G"], st["rhs"], rcond=None)[0]
    P_X = 2.0 * x / np.sqrt(1.0 + x @ x)
    q_v = 0.5 * P_X
    R_X = matrix_from_quat_xyzw(np.append(q_v, np.sqrt(max(0.0, 1.0 - q_v @ q_v))))
    return make_transform(R_X, translation_from_stats(st, R_X))


register(Solver("tsai", "AX=XB", "Tsai-Lenz 1989: modified Rodrigues vectors", 10, tsai_stats, tsai_finish))
