"""Benchmark of the outlier test: one gross outlier per set, and clean sets, through ``classic.calibrate``.

Run from the repository root::

    python benchmarks/outliers.py --out benchmarks/results/outliers.md   # the documentation's table (50 trials)
    python benchmarks/outliers.py --trials 5 --clean-trials 100           # a quick look

Each trial: ``make_problem(N, setup)`` with camera noise 0.1 deg / 1 mm and robot noise 0.01 deg / 0.2 mm
per axis (the robot's noise is not in the default noise model: real cells have some), one pose made a gross
outlier (:mod:`handeye.core.synthetic_outliers`: a robot or camera translation moved 0.05 to 1.8 m, a camera
rotation of 20 deg, a board flipped about its normal), the setup alternating. Each answer of the default
(``classic.calibrate`` with no options) is counted as

* **named**: returned within 2 sigma (the larger of X's and Y's Mahalanobis distance) of the fit of the same
  poses without the outlier, the outlier in ``diagnostics["suspect_poses"]`` with a ``SuspectPosesWarning``;
* **left out**: a named pose not beyond :data:`classic.outlier_screen.GROSS_FACTOR` times its bound that moves
  the answer by more than 2 sigma: the fit without it returned (so within 2 sigma of that fit), the pose named;
* **refused**: ``ContaminatedPosesError`` naming the outlier's index (``error.poses``);
* **silent**: anything else (returned without naming it, or beyond 2 sigma, or refused naming another pose):
  the target is 0.

Then ``robust=True`` on the same set: the count of answers that left out exactly the outlier.

Clean sets (no outlier), default and ``robust=True``: the sets where some pose was named (default) or left
out (robust), against the stated rate ``alpha = 0.001`` (:data:`classic.outlier_screen.OUTLIER_ALPHA`).

Clean PnP sets (the most common real input): ``make_problem``'s truth with the board tilted up to 45 deg about
each of two axes (up to about 60 deg in all), a 7 x 5 board of 4 cm squares projected through a 640 x 480
camera with 0.1-0.3 px corner noise (drawn per set), each ``T_cam_target`` from PnP
(:func:`classic.vision.detect.estimate_pose`: heteroscedastic, a grazing view's rotation several times a
frontal one's), the robot exact in half the sets and off by 0.05 deg / 0.5 mm per axis in the other half. The
default's action on each: nothing named; named and returned with them; left out (named, not gross, moving
the answer by more than 2 sigma); refused. Target: 0 refused.
"""

from __future__ import annotations

import argparse
import os
import sys
import warnings
from concurrent.futures import ProcessPoolExecutor

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

import classic  # noqa: E402
from benchmarks._report import Report  # noqa: E402
from classic.contamination import x_shift_sigma  # noqa: E402
from classic.outlier_screen import ACCEPT_SHIFT_SIGMA, OUTLIER_ALPHA  # noqa: E402
from handeye.core.errors import ContaminatedPosesError  # noqa: E402
from handeye.core.synthetic import make_problem  # noqa: E402
from handeye.core.synthetic_outliers import inject_outlier  # noqa: E402

CASES = [
    ("robot_translation", 0.05, "robot translation 0.05 m"),
    ("robot_translation", 0.3, "robot translation 0.3 m"),
    ("robot_translation", 1.0, "robot translation 1 m"),
    ("robot_translation", 1.8, "robot translation 1.8 m"),
    ("camera_translation", 0.05, "camera translation 0.05 m"),
    ("camera_translation", 0.3, "camera translation 0.3 m"),
    ("camera_translation", 1.0, "camera translation 1 m"),
    ("camera_translation", 1.8, "camera translation 1.8 m"),
    ("camera_rotation", 20.0, "camera rotation 20 deg"),
    ("board_flip", 0.0, "board flipped 180 deg"),
]
SIZES = (8, 15, 40)
SETUPS = ("eye_to_hand", "eye_in_hand")
NOISE = dict(camera_noise=(0.1, 1.0), robot_noise=(0.01, 0.2))


def outcome(A, B, setup: str, index: int) -> str:
    """``named``, ``left out``, ``refused`` or ``silent`` for the default on a set whose pose ``index`` is off."""
    keep = np.arange(len(A)) != index
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        unchecked = classic.CalibrateOptions(check=False)
        clean = classic.calibrate(A[keep], B[keep], setup=setup, options=unchecked)  # the reference: just the fit
        try:
            res = classic.calibrate(A, B, setup=setup)
        except ContaminatedPosesError as err:
            return "refused" if getattr(err, "poses", None) and index in err.poses else "silent"
    named = [d["index"] for d in res.diagnostics.get("suspect_poses", [])]
    shift = max(
        x_shift_sigma(res.X, clean.X, clean.covariance[:6, :6]), x_shift_sigma(res.Y, clean.Y, clean.covariance[6:, 6:])
    )
    if index not in named or shift > ACCEPT_SHIFT_SIGMA:
        return "silent"
    return "left out" if res.diagnostics["outlier_test"].get("action") == "left out" else "named"


def robust_exact(A, B, setup: str, index: int) -> bool:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = classic.calibrate(A, B, setup=setup, robust=True)
    return res.diagnostics["outliers"] == [index]


def trial(job) -> tuple:
    case, n, seed = job
    kind, size, _ = CASES[case]
    rng = np.random.default_rng(seed)
    setup = SETUPS[seed % 2]
    p = make_problem(n, setup, rng, **NOISE)
    index = int(rng.integers(n))
    A, B = inject_outlier(p.T_base_ee, p.T_cam_target, kind, size, index, rng)
    return case, n, outcome(A, B, setup, index), robust_exact(A, B, setup, index)


def clean_trial(job) -> tuple:
    n, seed = job
    rng = np.random.default_rng(seed)
    setup = SETUPS[seed % 2]
    p = make_problem(n, setup, rng, **NOISE)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            res = classic.calibrate(p.T_base_ee, p.T_cam_target, setup=setup)
            default = "named" if res.diagnostics.get("suspect_poses") else "clean"
        except ContaminatedPosesError:
            default = "refused"
        robust = classic.calibrate(p.T_base_ee, p.T_cam_target, setup=setup, robust=True)
    return n, default, len(robust.diagnostics["outliers"]) > 0


def pnp_poses(n: int, setup: str, rng: np.random.Generator, robot=(0.0, 0.0)):
    """``(T_base_ee, T_cam_target)`` of ``n`` views whose camera poses come from PnP on noisy corners."""
    from classic.vision import BoardSpec
    from classic.vision.detect import Detection, estimate_pose, project_points
    from classic.vision.synthetic import default_intrinsics
    from handeye.core.se3 import invert_transform, make_transform

    spec, intr = BoardSpec(7, 5, 0.04, 0.03, "5X5_100"), default_intrinsics()
    centre = make_transform(np.eye(3), [-spec.size_m[0] / 2, -spec.size_m[1] / 2, 0.0])
    p = make_problem(3 * n, setup, rng, robot_noise=robot, max_tilt_deg=45.0)
    sigma_px = rng.uniform(0.1, 0.3)
    P = spec.corners_target()
    T_be, B = [], []
    for T, T_ee in zip(p.T_cam_target, p.T_base_ee):
        uv = project_points(P, T @ centre, intr) + rng.normal(scale=sigma_px, size=(len(P), 2))
        inside = np.all((uv >= 0) & (uv <= [intr.width - 1, intr.height - 1]), axis=1)
        if inside.sum() < 8:
            continue
        view = estimate_pose(Detection(np.flatnonzero(inside), uv[inside], 0, (intr.width, intr.height)), spec, intr)
        if view.T_cam_target is None:
            continue
        T_be.append(T_ee)
        B.append(view.T_cam_target @ invert_transform(centre))
        if len(B) == n:
            break
    return np.array(T_be), np.array(B)


def pnp_clean_trial(job) -> tuple:
    n, seed = job
    rng = np.random.default_rng(seed)
    setup = SETUPS[seed % 2]
    robot = (0.05, 0.5) if (seed // 2) % 2 else (0.0, 0.0)
    A, B = pnp_poses(n, setup, rng, robot)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            res = classic.calibrate(A, B, setup=setup)
        except ContaminatedPosesError:
            return n, "refused"
    return n, res.diagnostics["outlier_test"].get("action", "clean")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--trials", type=int, default=50, help="trials per outlier case and set size (default 50)")
    ap.add_argument("--clean-trials", type=int, default=1000, help="clean sets per set size (default 1000)")
    ap.add_argument("--pnp-trials", type=int, default=200, help="clean PnP sets per set size (default 200)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--workers", type=int, default=min(2, os.cpu_count() or 1), help="processes (default 2)")
    ap.add_argument("--out", help="also write the report to this file")
    args = ap.parse_args(argv)
    Report.cut(args, trials=2, clean_trials=4, pnp_trials=4)
    report = Report(
        "Outliers: one gross outlier per set, and clean sets, through classic.calibrate's default",
        "benchmarks/outliers.py",
        argv,
        f"numpy {np.__version__}",
    )
    say = report.say
    jobs = [
        (c, n, args.seed * 1000003 + 1009 * c + 101 * n + k)
        for c in range(len(CASES))
        for n in SIZES
        for k in range(args.trials)
    ]
    clean_jobs = [(n, args.seed * 1000003 + 7919 * n + k) for n in SIZES for k in range(args.clean_trials)]
    with ProcessPoolExecutor(max_workers=args.workers) as pool:
        results = list(pool.map(trial, jobs, chunksize=8))
        clean = list(pool.map(clean_trial, clean_jobs, chunksize=16))
        pnp_jobs = [(n, args.seed * 1000003 + 6007 * n + k) for n in SIZES for k in range(args.pnp_trials)]
        pnp = list(pool.map(pnp_clean_trial, pnp_jobs, chunksize=8))
    say(f"One gross outlier, {args.trials} trials per cell (setups alternating); default: named, returned within 2")
    say("sigma / named and left out (not gross) / refused naming it / silent (target 0); robust=True: left out")
    say("exactly the outlier")
    say()
    say("| outlier | poses | named | left out | refused | silent | robust: exactly it |")
    say("|---|---|---|---|---|---|---|")
    for c, (_, _, label) in enumerate(CASES):
        for n in SIZES:
            rows = [r for r in results if r[0] == c and r[1] == n]
            count = {k: sum(r[2] == k for r in rows) for k in ("named", "left out", "refused", "silent")}
            say(
                f"| {label} | {n} | {count['named']} | {count['left out']} | {count['refused']} | {count['silent']} | "
                f"{sum(r[3] for r in rows)}/{len(rows)} |"
            )
    total_silent = sum(r[2] == "silent" for r in results)
    say()
    say(f"silent in all: {total_silent} of {len(results)}")
    say()
    say(f"Clean sets, {args.clean_trials} per size: sets with a pose named or refused (default), a pose left out")
    say(f"(robust); the stated rate is alpha = {OUTLIER_ALPHA:g} per set")
    say()
    say("| poses | default: named | default: refused | robust: a pose left out | expected at alpha |")
    say("|---|---|---|---|---|")
    for n in SIZES:
        rows = [r for r in clean if r[0] == n]
        say(
            f"| {n} | {sum(r[1] == 'named' for r in rows)} | {sum(r[1] == 'refused' for r in rows)} | "
            f"{sum(r[2] for r in rows)} | {OUTLIER_ALPHA * len(rows):.1f} |"
        )
    say()
    say(f"Clean PnP sets, {args.pnp_trials} per size (setups alternating, the robot exact in half, 0.05 deg / 0.5 mm")
    say("per axis in the other half): the default's action; target 0 refused")
    say()
    say("| poses | nothing named | named, returned with them | left out (not gross, > 2 sigma) | refused |")
    say("|---|---|---|---|---|")
    for n in SIZES:
        rows = [r[1] for r in pnp if r[0] == n]
        say(
            f"| {n} | {rows.count('clean')} | {rows.count('named')} | {rows.count('left out')} | "
            f"{rows.count('refused')} |"
        )
    return report.write(args.out)


if __name__ == "__main__":
    sys.exit(main())
