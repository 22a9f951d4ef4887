"""Benchmark: the markerless calibration against the truth and beside the classic ChArUco labels.

Run from the repository root, on datasets rendered with the default sensor noise and labelled::

    handeye sim generate --preset paper-sim --out data/paper-sim-noisy --noise default
    handeye label data/paper-sim-noisy
    handeye sim generate --preset small --out data/small-noisy --noise default && handeye label data/small-noisy
    python benchmarks/markerless.py --data data/paper-sim-noisy --basin-data data/small-noisy

1. Accuracy: every test camera placement of ``--data``, from no start at all (the start
   from the moving pixels' centroids); error against the truth beside the classic label's,
   time per placement (all frames at the dataset's resolution).
2. Sensitivity (same placements, ``--sensitivity``): twice the depth noise (added to the
   recorded depth), a quarter of each frame's depth missing in random blocks, 10 frames
   instead of all, the left 40 % of every image blank (the arm partly out of view); accuracy
   and success rate per case.
3. Basin (``--basin-data``): starts perturbed from the truth by (mm, deg), success
   meaning an accepted answer within 1 mm / 0.1 deg; an accepted answer outside that is a
   wrong answer, counted apart from refusals, and among those the ones also beyond 3 predicted
   sigmas (a wrong basin, where the others lie outside the fixed bound but within the method's
   own precision). Once with the centroid start tried beside the
   given one (the default), once with the given start alone (the coarse stage's own basin).
   ``--basin-cells 50:5,100:10`` lists the offsets; ``--basin-grid 0,50,100:0,2.5,5`` maps every
   translation against every rotation.

``--option key=value`` sets a :class:`classic.markerless.MarkerlessOptions` field for every run, e.g.
``--option intrinsics_model=fixed``: the depth camera's matrix taken as exact (a user who calibrated it), where
the default estimates it with the pose.

Prints markdown tables, and writes them to ``--results`` when it names a file (printed only without it).
"""

from __future__ import annotations

import argparse
import datetime
import os
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

from benchmarks._machine import machine  # noqa: E402
from benchmarks._report import Report  # noqa: E402
from benchmarks.markerless_errors import parse_option  # noqa: E402
from classic.markerless import MarkerlessOptions, register_robot  # noqa: E402
from classic.markerless.shared_intrinsics import MIN_OTHERS, first_pass_options, second_passes  # noqa: E402
from handeye.core.dataset import Dataset  # noqa: E402
from handeye.core.metrics import pose_error  # noqa: E402
from handeye.core.numbers import parse_float, parse_int  # noqa: E402
from handeye.core.se3 import make_transform, so3_exp  # noqa: E402
from handeye.markerless import robot_surface_for  # noqa: E402
from handeye.markerless_shared import shared_options  # noqa: E402

SUCCESS_MM, SUCCESS_DEG = 1.0, 0.1


def load_camera(ds, c):
    t = ds.select(c, "data")
    depth = np.stack([ds.depth_m(c, r) for r in t["depth"]])
    return depth, ds.joints(t)


def accuracy(ds, cams, surface, opts, perturb=None, rng=None, shared=False):
    """Per camera: (status, err_deg, err_mm, sigma_deg, sigma_mm, seconds, e_cam_mm, sd_cam_mm).

    ``shared``: each placement registered again under the intrinsics prior the others give it (``handeye
    markerless``'s default with four or more placements, both passes under its options:
    :func:`handeye.markerless_shared.shared_options`); the seconds are both passes'.
    """
    K = np.array(ds.meta["intrinsics"]["K"])
    truth = ds.truth()
    shared = shared and len(cams) > MIN_OTHERS  # too few to share: each placement alone, as handeye markerless
    if shared:
        opts = shared_options(opts, len(cams))
    results, seconds, frames = {}, {}, {}
    for c in cams:
        depth, q = load_camera(ds, c)
        if perturb is not None:
            depth, q = perturb(depth, q, rng)
        t0 = time.perf_counter()
        first_opts = first_pass_options(opts) if shared else opts
        results[c] = register_robot(depth, K, surface.posed(q), options=first_opts)
        seconds[c] = time.perf_counter() - t0
        if shared:
            frames[c] = (depth, q)
    if shared:

        def register(c, K_prior, starts, second_opts):
            depth, q = frames[c]
            t0 = time.perf_counter()
            posed, analysis = surface.posed(q), results[c].depth_analysis
            res = register_robot(depth, K_prior, posed, starts=starts, options=second_opts, depth_analysis=analysis)
            seconds[c] += time.perf_counter() - t0
            return res

        for c, (_, res) in second_passes(results, K, opts, register).items():
            results[c] = res  # each again, under the pooled prior or, where nothing pooled, the stated one
    return [_accuracy_row(results[c], truth[c], seconds[c]) for c in cams]


def _accuracy_row(res, T_true, seconds) -> tuple:
    """One placement's row of :func:`accuracy`."""
    if not res.ok:
        return ("refused", np.nan, np.nan, np.nan, np.nan, seconds, None, None)
    rot, tr = pose_error(res.T_base_cam, T_true)
    # the translation error along the true camera's axes (z: the optical axis), and the noise part of the
    # predicted sigma on the same axes (the noise's covariance of the camera-frame right perturbation;
    # res.covariance is the whole sigma's, its bounded terms spread evenly over the axes)
    e_cam_mm = T_true[:3, :3].T @ (res.T_base_cam[:3, 3] - T_true[:3, 3]) * 1e3
    sd_cam_mm = np.sqrt(np.diag(res.diagnostics["covariance_noise"])[3:]) * 1e3
    return ("ok", rot, tr, res.sigma["rotation_deg"], res.sigma["translation_mm"], seconds, e_cam_mm, sd_cam_mm)


def summarise(rows):
    ok = [r for r in rows if r[0] == "ok"]
    e = np.array([[r[1], r[2]] for r in ok]) if ok else np.full((1, 2), np.nan)
    good = sum(1 for r in ok if r[1] <= SUCCESS_DEG and r[2] <= SUCCESS_MM)
    return {
        "n": len(rows),
        "ok": len(ok),
        "good": good,
        "median_mm": np.median(e[:, 1]),
        "median_deg": np.median(e[:, 0]),
        "worst_mm": np.max(e[:, 1]),
        "worst_deg": np.max(e[:, 0]),
        "seconds": np.median([r[5] for r in rows]),
    }


def double_noise(sigma_1m):
    def f(depth, q, rng):
        z = depth + rng.normal(size=depth.shape) * sigma_1m * depth**2
        return np.where(depth > 0, np.maximum(z, 0), 0), q

    return f


def missing_blocks(depth, q, rng, fraction=0.25, block=16):
    depth = depth.copy()
    n, h, w = depth.shape
    for i in range(n):
        gone = np.zeros((h, w), bool)
        while gone.mean() < fraction:
            r, c = rng.integers(0, h - block), rng.integers(0, w - block)
            gone[r : r + block, c : c + block] = True
        depth[i][gone] = 0
    return depth, q


def out_of_view(fraction=0.4):
    """The left part of every image blank: the sensor's field of view cut, the arm partly outside it."""

    def f(depth, q, rng):
        depth = depth.copy()
        depth[..., : int(fraction * depth.shape[-1])] = 0
        return depth, q

    return f


def first_frames(k):
    return lambda depth, q, rng: (depth[:k], q[:k])


def basin(ds, surface, opts, cells, trials, centroid, rng):
    """Trial k of a cell starts placement ``k mod P`` off by the cell's offset about a random axis and direction.

    The offsets are drawn first, cell by cell, then the trials run placement by placement, so that one
    placement's frames are in memory at a time (all 108 of ``paper-sim`` take about 18 GB).
    """
    K = np.array(ds.meta["intrinsics"]["K"])
    truth = ds.truth()
    cams = list(range(len(ds)))
    draws = {cell: [(rng.normal(size=3), rng.normal(size=3)) for _ in range(trials)] for cell in cells}
    counts = {cell: [0, 0, 0, 0] for cell in cells}  # good, wrong, refused, wrong and beyond 3 sigma
    for c in cams:
        mine = [k for k in range(trials) if k % len(cams) == c]
        if not mine:
            continue
        depth, q = load_camera(ds, c)
        posed = surface.posed(q)
        for mm, deg in cells:
            for k in mine:
                axis, direction = draws[(mm, deg)][k]
                T0 = truth[c] @ make_transform(
                    so3_exp(np.radians(deg) * axis / np.linalg.norm(axis)),
                    mm / 1000 * direction / np.linalg.norm(direction),
                )
                res = register_robot(depth, K, posed, starts={"user": T0}, options=opts, centroid_start=centroid)
                if not res.ok:
                    counts[(mm, deg)][2] += 1
                    continue
                rot, tr = pose_error(res.T_base_cam, truth[c])
                good = rot <= SUCCESS_DEG and tr <= SUCCESS_MM
                counts[(mm, deg)][0 if good else 1] += 1
                far = rot > 3 * res.sigma["rotation_deg"] or tr > 3 * res.sigma["translation_mm"]
                counts[(mm, deg)][3] += int(not good and far)
    return {cell: (*counts[cell], trials) for cell in cells}


def _offset(mm: str, deg: str) -> tuple[int, float]:
    """One start offset: whole millimetres, degrees (fractions allowed), both >= 0, in the strict number grammar."""
    what = f"start offset {mm}:{deg}"
    out = (
        parse_int(mm.strip(), what, argparse.ArgumentTypeError),
        parse_float(deg.strip(), what, argparse.ArgumentTypeError),
    )
    if min(out) < 0:
        raise argparse.ArgumentTypeError(f"{what}: offsets are sizes >= 0 (the direction is drawn)")
    return out


def parse_basin_cells(text: str) -> list[tuple[int, float]]:
    """``"50:5,100:10"`` -> ``[(50, 5.0), (100, 10.0)]``: the basin's start offsets (mm, deg)."""
    cells = [item.partition(":") for item in text.split(",")]
    if any(not sep for _, sep, _ in cells):
        raise argparse.ArgumentTypeError(f"{text!r} is not comma-separated mm:deg pairs")
    return [_offset(mm, deg) for mm, _, deg in cells]


def parse_basin_grid(text: str) -> list[tuple[int, float]]:
    """``"MM_LIST:DEG_LIST"`` -> every pair, translation the outer loop: ``"0,50:0,2.5"`` -> ``[(0, 0.0), (0, 2.5),
    (50, 0.0), (50, 2.5)]``."""
    mm_list, sep, deg_list = text.partition(":")
    if not sep:
        raise argparse.ArgumentTypeError(f"{text!r} is not MM_LIST:DEG_LIST")
    return [_offset(mm, deg) for mm in mm_list.split(",") for deg in deg_list.split(",")]


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--data", type=Path, required=True, help="labelled dataset for accuracy (test cameras)")
    ap.add_argument("--split", default="test")
    ap.add_argument("--sensitivity", action="store_true")
    ap.add_argument("--basin-data", type=Path, help="dataset for the basin (all cameras)")
    ap.add_argument("--basin-trials", type=int, default=200, help="trials per cell, centroid start beside")
    ap.add_argument(
        "--basin-trials-alone", type=int, default=50, help="trials per cell, the given start alone (0: skip)"
    )
    ap.add_argument(
        "--basin-cells",
        type=parse_basin_cells,
        default="50:5,100:10,200:20,300:30",
        help="start offsets, mm:deg, comma-separated (degrees may be fractions)",
    )
    ap.add_argument(
        "--basin-grid",
        metavar="MM_LIST:DEG_LIST",
        type=parse_basin_grid,
        help="a map instead of --basin-cells: every translation with every rotation, e.g. 0,50,100:0,2.5,5",
    )
    ap.add_argument(
        "--option",
        type=parse_option,
        action="append",
        default=[],
        help="key=value: a MarkerlessOptions field beside the defaults, for every run (intrinsics_model=fixed: "
        "the camera matrix taken as exact, as for a user who calibrated it); repeatable",
    )
    ap.add_argument(
        "--shared-intrinsics",
        action="store_true",
        help="the accuracy and sensitivity runs as handeye markerless makes them from four placements: each "
        "placement registered again under the intrinsics the others estimated, a depth error per 2 px cell "
        "marginalised in both passes; the s column both passes' time",
    )
    Report.add_out(ap, "--results")
    args = ap.parse_args(argv)
    rng = np.random.default_rng(0)
    lines = [
        f"command: python benchmarks/markerless.py {' '.join(argv if argv is not None else sys.argv[1:])}",
        f"machine: {machine()}",
        f"date: {datetime.datetime.now(datetime.UTC):%Y-%m-%d %H:%M} UTC",
        "",
    ]

    def emit(s=""):
        print(s, flush=True)
        lines.append(s)

    for line in lines[:3]:
        print(line)
    ds = Dataset.open(args.data)
    surface, stride = robot_surface_for(ds)
    sigma_1m = ds.meta.get("recipe", {}).get("noise", {}).get("depth_sigma_m_at_1m", 0.001) or 0.001
    opts = MarkerlessOptions(depth_sigma_m_at_1m=sigma_1m, zbuffer_stride=stride, **dict(args.option))
    cams_table = ds.cameras()
    cams = [c for c in range(len(ds)) if args.split == "all" or cams_table["split"][c] == args.split]
    w, h = ds.meta["intrinsics"]["width"], ds.meta["intrinsics"]["height"]
    n_frames = len(ds.select(cams[0], "data")["depth"])
    emit(
        f"## Accuracy: {ds.root.name}, {len(cams)} {args.split} camera placements, {n_frames} frames at {w}x{h}, "
        f"depth noise {sigma_1m * 1e3:g} mm at 1 m, no start given"
    )
    emit()
    if args.option:
        emit("Options beside the defaults: " + ", ".join(f"{k}={v}" for k, v in args.option) + ".")
        emit()
    if args.shared_intrinsics:
        emit(
            "Intrinsics shared by the placements (--shared-intrinsics): each registered again under the others' "
            "pooled estimates, a depth error per 2 px cell marginalised in both passes; s: both passes."
        )
        emit()
    rows = accuracy(ds, cams, surface, opts, shared=args.shared_intrinsics)
    truth, labels = ds.truth(), ds.labels()
    lab = np.array([pose_error(labels[c], truth[c]) for c in cams])
    emit("| camera | hybrid vs truth mm / deg | predicted sigma mm / deg | classic label vs truth mm / deg | s |")
    emit("|---|---|---|---|---|")
    for c, r, (ld, lm) in zip(cams, rows, lab):
        hy = f"{r[2]:.3f} / {r[1]:.4f}" if r[0] == "ok" else "refused"
        sg = f"{r[4]:.3f} / {r[3]:.4f}" if r[0] == "ok" else "-"
        emit(f"| {c} | {hy} | {sg} | {lm:.3f} / {ld:.4f} | {r[5]:.1f} |")
    s = summarise(rows)
    emit()
    emit("| method | accepted | median mm | median deg | worst mm | worst deg | median s per placement |")
    emit("|---|---|---|---|---|---|---|")
    emit(
        f"| markerless (no start) | {s['ok']}/{s['n']} | {s['median_mm']:.3f} | {s['median_deg']:.4f} | "
        f"{s['worst_mm']:.3f} | {s['worst_deg']:.4f} | {s['seconds']:.1f} |"
    )
    emit(
        f"| classic ChArUco label | {len(lab)}/{len(lab)} | {np.median(lab[:, 1]):.3f} | {np.median(lab[:, 0]):.4f} | "
        f"{lab[:, 1].max():.3f} | {lab[:, 0].max():.4f} | - |"
    )
    ok = [r for r in rows if r[0] == "ok"]
    if ok:
        e = np.array([[r[1], r[2], r[3], r[4]] for r in ok])
        emit()
        emit(
            "RMS error / RMS predicted sigma: translation "
            f"{np.sqrt(np.mean(e[:, 1] ** 2) / np.mean(e[:, 3] ** 2)):.2f}, "
            f"rotation {np.sqrt(np.mean(e[:, 0] ** 2) / np.mean(e[:, 2] ** 2)):.2f}"
        )
        e_cam = np.array([r[6] for r in ok])
        sd_cam = np.array([r[7] for r in ok])
        emit()
        emit("Translation error along the true camera's axes (z: the optical axis), mm, over the accepted placements:")
        emit()
        emit("| axis | mean (a bias) | RMS | RMS predicted sigma, noise part |")
        emit("|---|---|---|---|")
        for k, axis in enumerate("xyz"):
            emit(
                f"| {axis} | {e_cam[:, k].mean():+.3f} | {np.sqrt(np.mean(e_cam[:, k] ** 2)):.3f} | "
                f"{np.sqrt(np.mean(sd_cam[:, k] ** 2)):.3f} |"
            )
    if args.sensitivity:
        emit()
        emit("## Sensitivity (same placements)")
        emit()
        emit("| case | accepted | within 1 mm / 0.1 deg | median mm | median deg | worst mm | worst deg | median s |")
        emit("|---|---|---|---|---|---|---|---|")
        cases = [
            ("twice the depth noise", double_noise(sigma_1m), replace(opts, depth_sigma_m_at_1m=2 * sigma_1m)),
            ("a quarter of the depth missing (16 px blocks)", missing_blocks, opts),
            ("10 frames", first_frames(10), opts),
            ("arm partly out of view (left 40 % of each image blank)", out_of_view(0.4), opts),
        ]
        for name, f, o in cases:
            s = summarise(accuracy(ds, cams, surface, o, f, rng, shared=args.shared_intrinsics))
            emit(
                f"| {name} | {s['ok']}/{s['n']} | {s['good']}/{s['n']} | {s['median_mm']:.3f} | "
                f"{s['median_deg']:.4f} | {s['worst_mm']:.3f} | {s['worst_deg']:.4f} | {s['seconds']:.1f} |"
            )
    if args.basin_data:
        bds = Dataset.open(args.basin_data)
        bsurface, bstride = robot_surface_for(bds)
        bsigma = bds.meta.get("recipe", {}).get("noise", {}).get("depth_sigma_m_at_1m", 0.001) or 0.001
        bopts = replace(opts, depth_sigma_m_at_1m=bsigma, zbuffer_stride=bstride)
        cells = args.basin_grid or args.basin_cells
        for centroid, trials in ((True, args.basin_trials), (False, args.basin_trials_alone)):
            if trials <= 0:
                continue
            emit()
            emit(
                f"## Basin: {bds.root.name}, {trials} trials per cell over its {len(bds)} placements; "
                f"{'centroid start tried beside the given one' if centroid else 'the given start alone'}"
            )
            emit()
            emit("| start off by | success | wrong answer | of which beyond 3 sigma | refused |")
            emit("|---|---|---|---|---|")
            for (mm, deg), (g, wr, rf, w3, n) in basin(bds, bsurface, bopts, cells, trials, centroid, rng).items():
                emit(f"| {mm} mm, {deg:g} deg | {g}/{n} ({100 * g / n:.0f} %) | {wr} | {w3} | {rf} |")
    if args.results:
        args.results.parent.mkdir(parents=True, exist_ok=True)
        args.results.write_text("\n".join(lines) + "\n")
        print(f"written: {args.results}")


if __name__ == "__main__":
    main()
