"""Pair camera samples with robot poses by time, within a stated tolerance.

Each camera sample at ``t`` gets the robot's pose at ``t``:

* ``method="interpolate"`` (default): a robot sample stamped ``t`` as it is; otherwise the two robot
  samples around ``t``, both within ``tolerance_s`` of it, interpolated (rotation along the geodesic,
  translation linear: :class:`classic.RobotStream`), so that a gap in the robot's stream is never
  bridged;
* ``method="nearest"``: the nearest robot sample, within ``tolerance_s``.

A camera sample with no robot pose so found is dropped and counted. To estimate a time offset
between the two clocks instead, give the raw streams to :func:`classic.calibrate_stream`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from handeye.core.errors import HandEyeInputError, NoPairsError

__all__ = ["METHODS", "PairedPoses", "pair_by_time"]

METHODS = ("interpolate", "nearest")


@dataclass
class PairedPoses:
    """Camera samples with the robot pose at their time.

    Attributes
    ----------
    T_base_ee : array, shape (K, 4, 4)
        Robot flange pose at each kept camera sample's time, metres.
    T_cam_target : array, shape (K, 4, 4)
        The kept camera samples.
    camera_times_s : array, shape (K,)
    camera_index : array of int, shape (K,)
        Index of each kept sample among the camera samples given.
    dropped_index : array of int, shape (D,)
        Camera samples with no robot pose within the tolerance.
    gap_s : array, shape (K,)
        Time from each kept sample to the farthest robot sample used for it.
    tolerance_s : float
    method : str
    """

    T_base_ee: np.ndarray
    T_cam_target: np.ndarray
    camera_times_s: np.ndarray
    camera_index: np.ndarray
    dropped_index: np.ndarray
    gap_s: np.ndarray
    tolerance_s: float
    method: str

    @property
    def kept(self) -> int:
        """Number of pairs."""
        return len(self.camera_index)

    @property
    def dropped(self) -> int:
        """Number of camera samples dropped."""
        return len(self.dropped_index)


def pair_by_time(
    robot_times_s: np.ndarray,
    T_base_ee: np.ndarray,
    camera_times_s: np.ndarray,
    T_cam_target: np.ndarray,
    tolerance_s: float,
    method: str = "interpolate",
    source: str = "",
) -> PairedPoses:
    """Pair every camera sample with the robot pose at its time (module docstring).

    Parameters
    ----------
    robot_times_s : array, shape (M,)
        Strictly increasing, seconds, on the same clock as the camera times.
    T_base_ee : array, shape (M, 4, 4)
    camera_times_s : array, shape (N,)
    T_cam_target : array, shape (N, 4, 4)
    tolerance_s : float
        Largest time between a camera sample and a robot sample used for it, seconds (>= 0).
    method : {"interpolate", "nearest"}
    source : str
        Where the samples come from (bag, topic), for messages.

    Returns
    -------
    PairedPoses

    Raises
    ------
    NoPairsError
        No camera sample has a robot pose within the tolerance; the message gives the closest gap
        and both time spans.
    HandEyeInputError
        Bad times, shapes, tolerance or method.
    """
    where = f"{source}: " if source else ""
    t_r = np.asarray(robot_times_s, dtype=float).reshape(-1)
    t_c = np.asarray(camera_times_s, dtype=float).reshape(-1)
    A = np.asarray(T_base_ee, dtype=float)
    B = np.asarray(T_cam_target, dtype=float)
    _check_options(tolerance_s, method)
    _check_samples(t_r, A, t_c, B, where)
    gap, index, interpolated = _gaps(t_r, t_c, method)
    keep = gap <= tolerance_s
    keep_idx, drop_idx = np.flatnonzero(keep), np.flatnonzero(~keep)
    if not len(keep_idx):
        raise _no_pairs(t_r, t_c, tolerance_s, method, where)
    T = _robot_poses(t_r, A, t_c[keep_idx], index[keep_idx], interpolated[keep_idx])
    return PairedPoses(T, B[keep_idx], t_c[keep_idx], keep_idx, drop_idx, gap[keep_idx], float(tolerance_s), method)


def _check_options(tolerance_s: float, method: str) -> None:
    """Refuse an unknown method, a tolerance not finite or below 0."""
    if method not in METHODS:
        raise HandEyeInputError(f"unknown pairing method {method!r}: use one of {METHODS}")
    if not (np.isfinite(tolerance_s) and tolerance_s >= 0):
        raise HandEyeInputError(f"the time tolerance must be finite and >= 0 s, got {tolerance_s!r}")


def _check_samples(t_r: np.ndarray, A: np.ndarray, t_c: np.ndarray, B: np.ndarray, where: str) -> None:
    """Refuse poses of another count than their times, robot times not finite and strictly increasing (or none),
    camera times not finite."""
    if A.shape != (len(t_r), 4, 4) or B.shape != (len(t_c), 4, 4):
        raise HandEyeInputError(
            f"{where}{len(t_r)} robot times need poses of shape ({len(t_r)}, 4, 4), got "
            f"{A.shape}; {len(t_c)} camera times need ({len(t_c)}, 4, 4), got {B.shape}"
        )
    if not len(t_r) or not np.all(np.isfinite(t_r)) or np.any(np.diff(t_r) <= 0) or not np.all(np.isfinite(t_c)):
        raise HandEyeInputError(
            f"{where}robot times must be finite and strictly increasing (at least one), camera times finite"
        )


def _bracket(t_r: np.ndarray, t_c: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """For each camera time, ``k`` with ``t_r[k - 1] < t_c <= t_r[k]`` and the robot samples before and after it
    (``lo``, ``hi``: clipped to the robot samples), each shape (N,)."""
    k = np.searchsorted(t_r, t_c)
    return k, np.maximum(k - 1, 0), np.minimum(k, len(t_r) - 1)


def _gaps(t_r: np.ndarray, t_c: np.ndarray, method: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Each camera time's gap ``(N,)`` to the farthest robot sample used for it (inf: none), the robot sample
    taken as it is (``(N,)`` indices: the nearest, or the one stamped at the time) and where the pose is
    interpolated instead (``(N,)`` bool)."""
    k, lo, hi = _bracket(t_r, t_c)
    exact = t_r[hi] == t_c
    gap_before, gap_after = t_c - t_r[lo], t_r[hi] - t_c
    if method == "nearest":
        gap_before = np.where(k > 0, gap_before, np.inf)
        gap_after = np.where(k < len(t_r), gap_after, np.inf)
        gap = np.minimum(gap_before, gap_after)
        gap[exact] = 0.0
        return gap, np.where(gap_before < gap_after, lo, hi), np.zeros(len(t_c), dtype=bool)
    inside = (k > 0) & (k < len(t_r))
    return np.where(exact, 0.0, np.where(inside, np.maximum(gap_before, gap_after), np.inf)), hi, ~exact


def _no_pairs(t_r: np.ndarray, t_c: np.ndarray, tolerance_s: float, method: str, where: str) -> NoPairsError:
    """The error of no camera sample paired: the closest gap and both time spans."""
    _, lo, hi = _bracket(t_r, t_c)
    closest = np.min(np.minimum(np.abs(t_c - t_r[lo]), np.abs(t_r[hi] - t_c))) if len(t_c) else np.nan
    return NoPairsError(
        f"{where}none of {len(t_c)} camera samples has a robot pose within {tolerance_s} s "
        f"({method}); the closest robot sample is {closest:.6f} s away; robot samples span "
        f"[{t_r[0]:.6f}, {t_r[-1]:.6f}] s, camera samples "
        + (f"[{t_c.min():.6f}, {t_c.max():.6f}] s" if len(t_c) else "none")
        + "; raise the tolerance, or estimate a clock offset with classic.calibrate_stream"
    )


def _robot_poses(t_r: np.ndarray, A: np.ndarray, t_kept: np.ndarray, index: np.ndarray, interpolated: np.ndarray):
    """The robot poses ``(K, 4, 4)`` at the kept camera times: ``A[index]``, or interpolated where marked."""
    from classic.robot_stream import RobotStream

    T = np.empty((len(t_kept), 4, 4))
    T[~interpolated] = A[index[~interpolated]]
    if interpolated.any():
        T[interpolated] = RobotStream(t_r, A).at(t_kept[interpolated])[0]
    return T
