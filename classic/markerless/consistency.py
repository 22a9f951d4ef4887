"""Do the frames agree with themselves? The registration solved again on halves of the frames.

The frame-clustered covariance (:mod:`classic.markerless.point_to_plane`) trusts that what one frame gets
wrong, another does not. An error the frames share escapes it. A stereo matcher's pull toward whole
disparities (pixel locking) is the same at one depth in every frame; the matcher's window on a slanted or
curved link errs the same way whenever the arm shows that side. Such errors move the answer by millimetres
while the covariance sees tenths: on the simulated active stereo (OpenCV's SGBM on a projected dot pattern,
:mod:`sim.stereo`) the errors were 2.1 times the sigma (RMS), with the depth scale and offset estimated.

The check splits the frames in two by what such an error depends on:

- ``near/far``: the frame's median depth of its matched points;
- ``left/right``: the arm's median image column in the frame.

Each half is solved again from the final matches, starting from the full answer (a few Gauss-Newton steps,
no new association). Without a shared error the halves differ by their own noise only,
``E |d|^2 = tr(C_a + C_b)``. With one, each half carries its own part of it. For an error that varies
over depth (or image position) as a random function, the two halves' errors are two draws of one spread.
Half their difference then has the spread of their mean, which is the full answer's error. The excess
``max(0, |d|^2 - tr(C_a + C_b)) / 4`` of the split with the larger excess is added to the variance, for
rotation and translation apart.

This is a floor, not a bound: an error the same in both halves of every split (a sensor that shifts
every point alike) leaves the halves in agreement and the sigma as it was.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from handeye.core.se3 import so3_log

__all__ = ["frame_splits", "split_excess"]

#: Fewer frames than this in either half: that split is not tried (a half's clustered covariance needs frames).
MIN_FRAMES_PER_HALF = 4


def frame_splits(frame: np.ndarray, q_cam: np.ndarray, n_frames: int) -> dict[str, np.ndarray]:
    """The frames' halves by depth and by image position.

    Parameters
    ----------
    frame : array of int, shape (M,)
        Frame of each matched point.
    q_cam : array, shape (M, 3)
        The matched points as observed, camera frame (``z > 0``).
    n_frames : int

    Returns
    -------
    dict of str -> array of bool, shape (n_frames,)
        ``near/far`` and ``left/right``: True for the first half's frames. A split whose halves would hold
        fewer than :data:`MIN_FRAMES_PER_HALF` frames with matches is left out.
    """
    count = np.bincount(frame, minlength=n_frames)
    seen = np.flatnonzero(count > 0)
    out = {}
    for name, value in (("near/far", q_cam[:, 2]), ("left/right", q_cam[:, 0] / q_cam[:, 2])):
        per_frame = np.full(n_frames, np.nan)
        for i in seen:
            per_frame[i] = np.median(value[frame == i])
        first = per_frame <= np.nanmedian(per_frame)
        if min(int(first[seen].sum()), int((~first[seen]).sum())) >= MIN_FRAMES_PER_HALF:
            out[name] = first
    return out


def split_excess(
    solve: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]],
    frame: np.ndarray,
    splits: dict[str, np.ndarray],
) -> dict:
    """The halves' disagreement beyond their own noise, as a variance to add to the full answer's.

    Parameters
    ----------
    solve : callable
        ``solve(mask) -> (T_base_cam, covariance)`` for the matched points ``mask`` (bool, shape (M,)); the
        covariance of the right perturbation ``(omega, v)`` in the camera frame (rad, m), shape (6, 6).
    frame : array of int, shape (M,)
        Frame of each matched point.
    splits : dict of str -> array of bool
        From :func:`frame_splits`.

    Returns
    -------
    dict
        ``rotation_deg`` and ``translation_mm``: the added sigma (0 without splits); ``splits``: for each
        split the halves' difference and the difference their noise explains (``difference_mm``,
        ``expected_mm``, ``difference_deg``, ``expected_deg``).
    """
    excess_rot, excess_trans, report = 0.0, 0.0, {}
    for name, first in splits.items():
        (T_a, C_a), (T_b, C_b) = solve(first[frame]), solve(~first[frame])
        # the difference as a right perturbation of T_a, camera frame (the covariances' frame)
        d_rot = so3_log(T_a[:3, :3].T @ T_b[:3, :3])
        d_trans = T_a[:3, :3].T @ (T_b[:3, 3] - T_a[:3, 3])
        C = C_a + C_b
        rot2, trans2 = float(d_rot @ d_rot), float(d_trans @ d_trans)
        exp_rot2, exp_trans2 = float(np.trace(C[:3, :3])), float(np.trace(C[3:, 3:]))
        excess_rot = max(excess_rot, (rot2 - exp_rot2) / 4)
        excess_trans = max(excess_trans, (trans2 - exp_trans2) / 4)
        report[name] = {
            "difference_mm": float(np.sqrt(trans2) * 1e3),
            "expected_mm": float(np.sqrt(exp_trans2) * 1e3),
            "difference_deg": float(np.degrees(np.sqrt(rot2))),
            "expected_deg": float(np.degrees(np.sqrt(exp_rot2))),
        }
    return {
        "rotation_deg": float(np.degrees(np.sqrt(max(excess_rot, 0.0)))),
        "translation_mm": float(np.sqrt(max(excess_trans, 0.0)) * 1e3),
        "splits": report,
    }
