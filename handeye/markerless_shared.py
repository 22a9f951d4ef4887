"""A dataset's placements share one camera: each registered again with the others' intrinsics as its prior.

A dataset has one camera matrix for all its placements (``meta.json``); the camera was moved, its lens was not.
:func:`share_intrinsics` takes a first markerless run (:func:`handeye.markerless.markerless_dataset`), pools the
other placements' intrinsics estimates into each placement's prior
(:func:`classic.markerless.shared_intrinsics.pooled_prior`: leave one out, widened where they disagree, a
parameter that disagrees with the placement's own estimate not pooled) and registers the placement again from its
first answer. ``handeye markerless`` does this by default with four or more placements.

Example
-------
>>> from classic.markerless import MarkerlessOptions                         # doctest: +SKIP
>>> from classic.markerless.shared_intrinsics import first_pass_options     # doctest: +SKIP
>>> from handeye.markerless import markerless_dataset                       # doctest: +SKIP
>>> from handeye.markerless_shared import share_intrinsics, shared_options  # doctest: +SKIP
>>> opts = shared_options(MarkerlessOptions(), 24)                          # doctest: +SKIP
>>> first = markerless_dataset("data/small", options=first_pass_options(opts))  # doctest: +SKIP
>>> run = share_intrinsics("data/small", first, options=opts)               # doctest: +SKIP
"""

from __future__ import annotations

import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from classic.markerless import MarkerlessOptions
from classic.markerless.intrinsics import NAMES
from classic.markerless.shared_intrinsics import (
    MIN_OTHERS,
    SHARED_PIXEL_EFFECT_PX,
    against_given,
    second_passes,
)
from handeye.core.dataset import Dataset
from handeye.markerless import MarkerlessRun, RobotURDF, calibrate_camera, robot_surface_for

__all__ = ["share_intrinsics", "shared_note", "shared_options"]


def shared_options(options: MarkerlessOptions, placements: int) -> MarkerlessOptions:
    """The options of both passes where ``placements`` will share their intrinsics: a depth error per 2 px image
    cell marginalised (:data:`classic.markerless.shared_intrinsics.SHARED_PIXEL_EFFECT_PX`) unless the options set
    one; ``options`` as they are with fewer than ``MIN_OTHERS + 1`` placements or the intrinsics taken as exact.
    """
    if placements <= MIN_OTHERS or options.intrinsics_model != "estimate" or options.pixel_effect_px:
        return options
    return replace(options, pixel_effect_px=SHARED_PIXEL_EFFECT_PX)


def share_intrinsics(
    root: str | Path,
    run: MarkerlessRun,
    *,
    urdf: RobotURDF | None = None,
    options: MarkerlessOptions | None = None,
    progress: bool = False,
    frames=None,
) -> MarkerlessRun:
    """Each placement of ``run`` registered again under the intrinsics prior the other placements give it.

    Parameters
    ----------
    root : str or Path
        The dataset ``run`` was made from.
    run : MarkerlessRun
        The first pass (:func:`handeye.markerless.markerless_dataset`, with the same ``urdf`` and ``frames``, and
        :func:`classic.markerless.shared_intrinsics.first_pass_options` of ``options``: the pool takes that wider
        prior out of each estimate).
    urdf : RobotURDF, optional
    options : MarkerlessOptions, optional
        As stated. With ``intrinsics_model="fixed"`` nothing is shared and ``run`` is returned; with fewer than
        ``MIN_OTHERS + 1`` placements that estimated the intrinsics
        (:data:`classic.markerless.shared_intrinsics.MIN_OTHERS`) nothing is pooled, and each placement is
        registered again under the stated prior.
    progress : bool
    frames : index, optional

    Returns
    -------
    MarkerlessRun
        A new run: per camera the second pass's result (its wall time the two passes' sum);
        ``intrinsics_priors`` says per camera what its prior was, where there were placements enough to pool.
    """
    opts = options or MarkerlessOptions()
    if opts.intrinsics_model != "estimate":
        return run
    ds = Dataset.open(root)
    K_given = np.array(ds.meta["intrinsics"]["K"], dtype=float)
    surface, stride = robot_surface_for(ds, *((urdf.path, urdf.package_dirs) if urdf else ()))
    opts = replace(opts, zbuffer_stride=stride)
    truth = ds.truth()
    cameras = list(run.results)
    if progress:
        from tqdm import tqdm

        cameras = tqdm(cameras, desc=f"shared intrinsics {ds.root.name}", unit="camera")
    seconds, tried = {}, {}

    def register(c, K, starts, second_opts):
        tried[c] = {**(starts or {}), **run.starts[c]}
        t0 = time.perf_counter()
        analysis = run.results[c].depth_analysis  # the frames' noise, mixed and moving pixels: found once
        res = calibrate_camera(ds, c, surface, tried[c], second_opts, frames, K=K, depth_analysis=analysis)
        seconds[c] = time.perf_counter() - t0
        return res

    out = MarkerlessRun(label_errors=dict(run.label_errors))
    for c, (prior, res) in second_passes(run.results, K_given, opts, register, only=cameras).items():
        if prior is not None:
            out.intrinsics_priors[c] = prior.to_dict()
        if prior is not None and prior.any_pooled:  # else the second pass's prior is the stated one already
            res.intrinsics = against_given(
                res.intrinsics, K_given, opts.intrinsics_prior_sigma, opts.intrinsics_determined_share
            )
        # the frames' findings (a few MB a placement at 848x480) are no longer needed: not kept in the run
        out.record(c, replace(res, depth_analysis=None), run.seconds[c] + seconds[c], tried[c], truth[c])
    return out


def shared_note(run: MarkerlessRun, pixel_effect_px: int = 0) -> str | None:
    """One line: how many placements took a pooled prior, and of which parameters; None when none was tried (too
    few placements, or the intrinsics taken as exact). ``pixel_effect_px``: the runs' per-cell depth error
    (:func:`shared_options`), named when above 0."""
    if not run.intrinsics_priors:
        return None
    priors = run.intrinsics_priors.values()
    counts = {name: sum(p[name]["pooled"] for p in priors) for name in NAMES}
    n = len(run.intrinsics_priors)
    if not any(counts.values()):
        reason = next(iter(priors))["reason"]
        return f"intrinsics not shared by the placements: {reason}"
    per = ", ".join(f"{name} {k}/{n}" for name, k in counts.items())
    return (
        f"intrinsics shared by the placements: each registered again with the others' estimates as its prior "
        f"(pooled: {per}; a parameter the placement's own estimate disagrees with keeps the given prior)"
        + (f"; a depth error per {pixel_effect_px} px image cell marginalised in both passes" * bool(pixel_effect_px))
    )
