"""A dataset's placements share one camera: each registered again with the others' intrinsics as its prior.

A dataset has one camera matrix for all its placements (``meta.json``); the camera was moved, its lens was not.
:func:`share_intrinsics` takes a first markerless run (:func:`handeye.markerless.markerless_dataset`), pools the
other placements' intrinsics estimates into each placement's prior
(:func:`classic.markerless.shared_intrinsics.pooled_prior`: leave one out, widened where they disagree, a
parameter that disagrees with the placement's own estimate not pooled) and registers the placement again from its
first answer. ``handeye markerless`` does this by default with four or more placements.

Example
-------
>>> from handeye.markerless import markerless_dataset          # doctest: +SKIP
>>> from handeye.markerless_shared import share_intrinsics      # doctest: +SKIP
>>> run = share_intrinsics("data/small", markerless_dataset("data/small"))  # doctest: +SKIP
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
    intrinsics_estimates,
    second_passes,
)
from handeye.core.dataset import Dataset
from handeye.markerless import MarkerlessRun, RobotURDF, calibrate_camera, robot_surface_for

__all__ = ["share_intrinsics", "shared_note", "shared_options"]


def shared_options(options: MarkerlessOptions, placements: int) -> MarkerlessOptions:
    """The options of both passes where ``placements`` will share their intrinsics: a depth error per 2 px image
    cell marginalised (:data:`classic.markerless.shared_intrinsics.SHARED_PIXEL_EFFECT_PX`) unless the options set
    one, and the intrinsics each first pass gives the pool with the depth noise's own bias taken out
    (``intrinsics_noise_debiased``; the second pass turns it off again); ``options`` as they are with fewer than
    ``MIN_OTHERS + 1`` placements or the intrinsics taken as exact.
    """
    if placements <= MIN_OTHERS or options.intrinsics_model != "estimate":
        return options
    return replace(
        options, pixel_effect_px=options.pixel_effect_px or SHARED_PIXEL_EFFECT_PX, intrinsics_noise_debiased=True
    )


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
        The first pass (:func:`handeye.markerless.markerless_dataset`, with the same ``urdf``, ``options`` and
        ``frames``).
    urdf : RobotURDF, optional
    options : MarkerlessOptions, optional
        The first pass's. With ``intrinsics_model="fixed"``, or fewer than ``MIN_OTHERS + 1`` placements that
        estimated the intrinsics (:data:`classic.markerless.shared_intrinsics.MIN_OTHERS`), nothing is shared and
        ``run`` is returned.
    progress : bool
    frames : index, optional

    Returns
    -------
    MarkerlessRun
        A new run: per camera the second pass's result where a parameter was pooled (its wall time the two
        passes' sum), else the first's; ``intrinsics_priors`` says per camera what its prior was.
    """
    opts = options or MarkerlessOptions()
    if opts.intrinsics_model != "estimate" or len(intrinsics_estimates(run.results)) <= MIN_OTHERS:
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
        out.intrinsics_priors[c] = prior.to_dict()
        if res is None:
            # the frames' findings (a few MB a placement at 848x480) are no longer needed: not kept in the run
            out.record(c, replace(run.results[c], depth_analysis=None), run.seconds[c], run.starts[c], truth[c])
            continue
        res.intrinsics = against_given(
            res.intrinsics, K_given, opts.intrinsics_prior_sigma, opts.intrinsics_determined_share
        )
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
