"""Did the camera move while a recalibration's frames were collected? Its first and second halves, compared.

The watcher collects a recalibration's frames after an alarm, over some seconds of distinct arm poses. A second
move in that time (a bump right after a bump, a camera still settling after a re-mount) leaves frames of two
camera poses, and one registration of all of them lands between the two, at neither. The registration's split
check groups the frames by depth and image position, not time, so it widens the answer's sigma only as far as
those groups happen to separate the two poses. Here the frames are split in time: each half registered alone from
the whole's answer. Halves of one camera pose agree within their sigmas; halves of two differ by the move. Beyond
:data:`HALVES_SIGMAS` combined sigmas (rotation or translation) the answer is not committed.

The halves' sigmas share the bounded terms (the depth-to-colour extrinsic's, the same in both), so their
combination overstates the sigma of their difference: the check errs towards committing. It costs two
registrations of half the frames.
"""

from __future__ import annotations

import numpy as np

from handeye.core.metrics import pose_error

__all__ = ["HALVES_SIGMAS", "MIN_HALF_FRAMES", "halves_disagree"]

#: Combined sigmas of the two halves beyond which their answers disagree: 3, as the benchmarks' 'beyond 3 sigma'.
HALVES_SIGMAS = 3.0
#: Frames each half needs at the least (the watcher takes 30 by default: halves of 15).
MIN_HALF_FRAMES = 6


def halves_disagree(recalibrate, frames: list, whole) -> str | None:
    """Why the collected ``frames`` are of two camera poses, or None where their halves agree (or cannot tell).

    Parameters
    ----------
    recalibrate : callable
        ``recalibrate(frames, T_start) -> result`` (the watcher's, :func:`handeye.watch.cell.markerless_recalibration`).
    frames : list of Frame
        In time order, as collected.
    whole : result
        The registration of all of them (accepted): its ``T_base_cam`` starts the halves.

    Returns
    -------
    str or None
        The reason, naming the halves' difference and their combined sigma; None where they agree within
        :data:`HALVES_SIGMAS` of it, where there are fewer than ``2 * MIN_HALF_FRAMES`` frames, or where a half's
        registration is refused (too little to judge: the whole's own checks stand).
    """
    half = len(frames) // 2
    if half < MIN_HALF_FRAMES:
        return None
    first, second = (recalibrate(part, whole.T_base_cam) for part in (frames[:half], frames[half:]))
    if not (getattr(first, "ok", False) and getattr(second, "ok", False)):
        return None
    rot_deg, trans_mm = (float(v) for v in pose_error(first.T_base_cam, second.T_base_cam))
    s_rot = float(np.hypot(first.sigma["rotation_deg"], second.sigma["rotation_deg"]))
    s_trans = float(np.hypot(first.sigma["translation_mm"], second.sigma["translation_mm"]))
    if rot_deg <= HALVES_SIGMAS * s_rot and trans_mm <= HALVES_SIGMAS * s_trans:
        return None
    return (
        f"its first and second {half} frames give cameras {trans_mm:.2f} mm / {rot_deg:.3f} deg apart, beyond "
        f"{HALVES_SIGMAS:g} of their combined sigmas ({s_trans:.2f} mm / {s_rot:.3f} deg): the camera moved while "
        "the frames were collected"
    )
