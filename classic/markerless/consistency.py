"""Do the frames agree with themselves? The registration solved again on groups of the frames.

The frame-clustered covariance (:mod:`classic.markerless.point_to_plane`) trusts that what one frame gets
wrong, another does not. An error the frames share escapes it. A stereo matcher's pull toward whole
disparities (pixel locking) is the same at one depth in every frame; the matcher's window on a slanted or
curved link errs the same way whenever the arm shows that side. Such errors move the answer by millimetres
while the covariance sees tenths: on the simulated active stereo (OpenCV's SGBM on a projected dot pattern,
:mod:`sim.stereo`) the errors were 2.1 times the sigma (RMS over six placements at 1.2 m), with the depth
scale and offset estimated.

The check groups the frames by what such an error depends on:

- ``depth``: each frame's median depth of its matched points;
- ``column``: the arm's median image column in the frame;

into up to four groups of at least four frames each, by quantiles, and solves each group again from the
final matches, starting from the full answer (a few Gauss-Newton steps, no new association). Without a
shared error the groups scatter by their own noise only. With one, each group carries its own part of it:
for an error that varies over depth (or image position) as a random function, the groups' errors are draws
of one spread, and their scatter beyond their noise measures it (:func:`split_excess`). The full answer's
share of it is added to the variance, for rotation and translation apart, from the split with the larger
excess. Four groups rather than two: a split in two measures the spread from one difference, which by chance
is often small (its square is a one-degree-of-freedom chi-square); on the six placements the RMS error over
sigma came to 1.19 with halves and 1.03 with four groups.

The same holds for the sensor's depth scale and offset, which a shared depth-dependent error pulls first: each
group's own ``(k, c)``, from the same fits, with the depth noise's own bias taken out of it (a group spans less
depth than the whole, so that bias is larger in it and differs between groups: left in, the excess the groups
showed in the scale was 1.6 to 3.6 times the whole's RMS error on the d435 benchmark's 20 to 60 frames, taken out
0.8 to 1.5 times), and the excess of their scatter, for ``k`` and ``c`` apart, added to the depth unit's
covariance (``depth_variance``). For a split by depth this is a model, not the geometry: the whole's scale comes
from the depth between the groups more than from each group's own, so an error that is constant within each depth
group and differs between them is held only as far as the groups' own units scatter.

This is a floor, not a bound: an error every group shares (a sensor that shifts every point alike, a
matcher's bias at the arm's edges that does not depend on where or how far the arm is) leaves the groups in
agreement and the sigma as it was.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from handeye.core.se3 import so3_log

__all__ = ["frame_splits", "split_excess"]

#: Frames per group at the least: a group's clustered covariance needs frames, and its fit the depth's range.
MIN_FRAMES_PER_GROUP = 4

#: Groups per split at the most: more groups give the spread between them more degrees of freedom (a split
#: in two measures it from one difference, which by chance is often small), fewer frames each.
MAX_GROUPS = 4


def frame_splits(frame: np.ndarray, q_cam: np.ndarray, n_frames: int) -> dict[str, np.ndarray]:
    """The frames in groups by depth and by image position.

    Parameters
    ----------
    frame : array of int, shape (M,)
        Frame of each matched point.
    q_cam : array, shape (M, 3)
        The matched points as observed, camera frame (``z > 0``).
    n_frames : int

    Returns
    -------
    dict of str -> array of int, shape (n_frames,)
        ``depth`` (each frame's median depth) and ``column`` (the arm's median image column, ``x / z``): each
        frame's group, by quantiles of that value, nearest first (leftmost first); -1 for a frame without
        matches. As many groups as :data:`MAX_GROUPS` allows with :data:`MIN_FRAMES_PER_GROUP` frames each;
        no split with fewer than two groups.
    """
    count = np.bincount(frame, minlength=n_frames)
    seen = np.flatnonzero(count > 0)
    groups = min(MAX_GROUPS, len(seen) // MIN_FRAMES_PER_GROUP)
    if groups < 2:
        return {}
    out = {}
    for name, value in (("depth", q_cam[:, 2]), ("column", q_cam[:, 0] / q_cam[:, 2])):
        per_frame = np.array([np.median(value[frame == i]) for i in seen])
        rank = np.argsort(np.argsort(per_frame, kind="stable"), kind="stable")
        label = np.full(n_frames, -1)
        label[seen] = rank * groups // len(seen)
        out[name] = label
    return out


def split_excess(
    solve: Callable[[np.ndarray], tuple],
    frame: np.ndarray,
    splits: dict[str, np.ndarray],
) -> dict:
    """The groups' scatter beyond their own noise, as a variance to add to the full answer's.

    For ``G`` groups whose answers ``x_g`` carry a shared error of variance ``v`` each (independent between
    groups) and noise of covariance ``C_g``, ``E sum |x_g - mean x|^2 = (1 - 1/G) sum (v + tr C_g)``. So
    ``v = max(0, S / (1 - 1/G) - sum tr C_g) / G`` from the scatter ``S``, and the full answer, about the
    groups' mean, carries ``v / G`` of it. For two groups this is a quarter of what their difference's
    noise does not explain. The split with the larger excess counts, rotation and translation apart.

    Parameters
    ----------
    solve : callable
        ``solve(mask) -> (T_base_cam, covariance)`` or ``(T_base_cam, covariance, unit)`` for the matched points
        ``mask`` (bool, shape (M,)); the covariance of the right perturbation ``(omega, v)`` in the camera frame
        (rad, m), shape (6, 6); ``unit``: None, or the group's depth correction ``(k, c)`` (shape (2,)) and its
        covariance (shape (2, 2)).
    frame : array of int, shape (M,)
        Frame of each matched point.
    splits : dict of str -> array of int
        Each frame's group per split (:func:`frame_splits`; -1: in none).

    Returns
    -------
    dict
        ``rotation_deg`` and ``translation_mm``: the added sigma (0 without splits); ``splits``: for each
        split the groups' RMS distance from their mean and what their noise explains of it
        (``scatter_mm``, ``expected_mm``, ``scatter_deg``, ``expected_deg``), and the number of ``groups``;
        where every group gave a ``unit``, ``depth_variance``: the variance added to ``k`` and to ``c``
        (2 floats, the split with the larger excess for each), and per split ``scatter_k``, ``expected_k``.
    """
    excess_rot, excess_trans, excess_unit, report = 0.0, 0.0, np.zeros(2), {}
    with_unit = bool(splits)
    for name, label in splits.items():
        groups = [g for g in np.unique(label) if g >= 0]
        answers = [solve(label[frame] == g) for g in groups]
        G = len(answers)
        R_base_cam_0, t_base_cam_0 = answers[0][0][:3, :3], answers[0][0][:3, 3]
        # each answer as a right perturbation of the first, camera frame (the covariances' frame)
        d = np.array(
            [
                np.r_[so3_log(R_base_cam_0.T @ a[0][:3, :3]), R_base_cam_0.T @ (a[0][:3, 3] - t_base_cam_0)]
                for a in answers
            ]
        )
        d -= d.mean(axis=0)
        C = sum(a[1] for a in answers)
        scatter_rot, scatter_trans = float(np.sum(d[:, :3] ** 2)), float(np.sum(d[:, 3:] ** 2))
        noise_rot, noise_trans = float(np.trace(C[:3, :3])), float(np.trace(C[3:, 3:]))
        excess_rot = max(excess_rot, (scatter_rot / (1 - 1 / G) - noise_rot) / G**2)
        excess_trans = max(excess_trans, (scatter_trans / (1 - 1 / G) - noise_trans) / G**2)
        expected = 1 - 1 / G  # the scatter the noise alone would give, per unit of sum tr C_g
        report[name] = {
            "groups": G,
            "scatter_mm": float(np.sqrt(scatter_trans / G) * 1e3),
            "expected_mm": float(np.sqrt(expected * noise_trans / G) * 1e3),
            "scatter_deg": float(np.degrees(np.sqrt(scatter_rot / G))),
            "expected_deg": float(np.degrees(np.sqrt(expected * noise_rot / G))),
        }
        units = [a[2] if len(a) > 2 else None for a in answers]
        with_unit = with_unit and all(u is not None for u in units)
        if with_unit:  # the depth unit (k, c) alike, each apart: their sigmas are what is reported
            kc = np.array([u[0] for u in units], dtype=float)
            scatter = np.sum((kc - kc.mean(axis=0)) ** 2, axis=0)
            noise = np.sum([np.diag(u[1]) for u in units], axis=0)
            excess_unit = np.maximum(excess_unit, (scatter / (1 - 1 / G) - noise) / G**2)
            report[name]["scatter_k"] = float(np.sqrt(scatter[0] / G))
            report[name]["expected_k"] = float(np.sqrt(expected * noise[0] / G))
    out = {
        "rotation_deg": float(np.degrees(np.sqrt(max(excess_rot, 0.0)))),
        "translation_mm": float(np.sqrt(max(excess_trans, 0.0)) * 1e3),
        "splits": report,
    }
    if with_unit:
        out["depth_variance"] = [float(v) for v in np.maximum(excess_unit, 0.0)]
    return out
