"""Benchmark: one placement's markerless registration, timed (issue 41's <= 10 s per placement on one core).

One test placement of a band dataset, one case of :mod:`benchmarks.markerless_errors` (default 1: the d435 as
is), the front's defaults, as :func:`benchmarks.markerless_sensors.run_profile` calls it: the sensor's frames
drawn, the surface posed, then ``register_robot`` timed ``--repeat`` times (wall seconds and this process's CPU
seconds, which other processes' load does not inflate). Prints the answer (``T_base_cam``, sigma) so that a
change meant to be faster only can be checked to give the same one (``--save`` / ``--compare``)::

    OPENBLAS_NUM_THREADS=1 OMP_NUM_THREADS=1 taskset -c 0 python benchmarks/markerless_placement_time.py \\
        --data data/sensor-bands/paper-real-1.2 --placement 0 --repeat 2

``--pixel-effect-px N`` and ``--option key=value`` change the options as :mod:`benchmarks.markerless_errors` does
(its ``--pixel-effect-px``, ``--option``), to time an option against the defaults on the same placement::

    OPENBLAS_NUM_THREADS=1 OMP_NUM_THREADS=1 python benchmarks/markerless_placement_time.py \\
        --data data/sensor-bands/paper-real-1.2 --placement 0 --case 10 --repeat 1 --pixel-effect-px 2

``--second-pass``: the shared-intrinsics second pass timed instead (the first pass run and its CPU seconds printed
first), started from the first's answer under a prior a third of the given sigmas wide, as
:func:`classic.markerless.shared_intrinsics.second_passes` runs it; the two together are a placement's time in
``handeye markerless``'s default with four or more placements.

``--profile out.prof``: a cProfile of the last repeat (read it with ``python -m pstats``).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from benchmarks.markerless_errors import cases, diagnostic_cases, parse_option  # noqa: E402
from benchmarks.markerless_sensors import front_options, observe, placements, told_intrinsics, told_posed  # noqa: E402
from classic.markerless.register import register_robot  # noqa: E402
from classic.markerless.shared_intrinsics import (  # noqa: E402
    SharedIntrinsicsPrior,
    first_pass_options,
    second_pass_options,
)
from handeye.core.dataset import Dataset  # noqa: E402
from handeye.markerless import robot_surface_for  # noqa: E402


def answer(res) -> np.ndarray:
    """The registration's answer as one vector: ``T_base_cam`` (16) and its sigma (rotation deg, translation mm)."""
    if not res.ok:
        return np.full(18, np.nan)
    return np.concatenate([res.T_base_cam.ravel(), [res.sigma["rotation_deg"], res.sigma["translation_mm"]]])


def second_pass(first, K, opts):
    """The starts and options of a second pass after ``first`` under a prior a third of the given sigmas wide."""
    if not first.ok:
        raise SystemExit(f"the first pass was refused ({first.refused}): no second pass to time")
    prior = SharedIntrinsicsPrior(
        K=K,
        prior_sigma=tuple(np.asarray(opts.intrinsics_prior_sigma, dtype=float) / 3),
        pooled=(True,) * 4,
        others=4,
        birge=(1.0,) * 4,
        reason="",
    )
    return {"first pass": first.T_base_cam}, second_pass_options(opts, prior, started_near=True)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--data", type=Path, default=Path("data/sensor-bands/paper-real-1.2"), help="a band dataset")
    ap.add_argument("--placement", type=int, default=0, help="which test placement (0-based, in the split's order)")
    ap.add_argument("--case", type=int, default=1, help="markerless_errors.py's case number (1: d435 as is)")
    ap.add_argument("--seed", type=int, default=0, help="seed of the sensor's draws")
    ap.add_argument("--repeat", type=int, default=2, help="time the registration this many times")
    ap.add_argument(
        "--pixel-effect-px",
        type=int,
        help="MarkerlessOptions.pixel_effect_px of the run (default: the front's default)",
    )
    ap.add_argument(
        "--option",
        type=parse_option,
        action="append",
        default=[],
        help="key=value: a further MarkerlessOptions field of the run, as markerless_errors.py's --option; repeatable",
    )
    ap.add_argument(
        "--second-pass",
        action="store_true",
        help="time the shared-intrinsics second pass instead: started from a first pass's answer, under a prior "
        "whose sigmas are a third of the given ones (as five pooled placements give)",
    )
    ap.add_argument("--profile", type=Path, help="write a cProfile of the last repeat here")
    ap.add_argument("--save", type=Path, help="write the answer (T_base_cam, sigma) here (.npy)")
    ap.add_argument("--compare", type=Path, help="print the answer's largest difference from one --save wrote")
    args = ap.parse_args()
    case = (cases() + diagnostic_cases())[args.case - 1]
    ds = Dataset.open(args.data)
    surface, stride = robot_surface_for(ds)
    c = placements(ds, "test")[args.placement]
    K = told_intrinsics(ds.meta["intrinsics"]["K"], case.get("intrinsics"))
    depth, q, _ = observe(ds, c, case["sensor"], args.seed, case.get("registration"))
    posed, _ = told_posed(surface, q, ds.truth()[c], case.get("joints"))
    options = dict(args.option)
    if args.pixel_effect_px is not None:
        options["pixel_effect_px"] = args.pixel_effect_px
    opts = front_options(case["sensor"], stride, **options)
    print(
        f"{ds.root.name}, camera {c}, case {args.case} ({case['name']}): {depth.shape[0]} frames "
        f"{depth.shape[2]}x{depth.shape[1]}, z-buffer stride {stride}, pixel_effect_px {opts.pixel_effect_px}"
        + "".join(f", {k}={v}" for k, v in args.option)
    )
    starts, analysis = None, None
    if args.second_pass:
        cpu = time.process_time()
        first = register_robot(depth, K, posed, options=first_pass_options(opts))  # as a pooled placement's
        print(f"first pass: {time.process_time() - cpu:.2f} s CPU, {first.refused or 'accepted'}", flush=True)
        starts, opts = second_pass(first, K, opts)
        analysis = first.depth_analysis
    for i in range(args.repeat):
        profiler = None
        if args.profile and i == args.repeat - 1:
            import cProfile

            profiler = cProfile.Profile(time.process_time)  # CPU seconds: load does not inflate them
            profiler.enable()
        wall, cpu = time.perf_counter(), time.process_time()
        res = register_robot(depth, K, posed, starts=starts, options=opts, depth_analysis=analysis)
        wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
        if profiler is not None:
            profiler.disable()
            profiler.dump_stats(str(args.profile))
        print(f"repeat {i + 1}: {wall:.2f} s wall, {cpu:.2f} s CPU, {res.refused or 'accepted'}", flush=True)
    vec = answer(res)
    np.set_printoptions(precision=12, suppress=True)
    print("T_base_cam:\n", vec[:16].reshape(4, 4))
    print(f"sigma: {vec[16]:.9f} deg, {vec[17]:.9f} mm")
    if args.save:
        np.save(args.save, vec)
    if args.compare:
        ref = np.load(args.compare)
        dT = np.abs(vec[:16] - ref[:16]).max()
        print(
            f"vs {args.compare}: T_base_cam {dT:.3g} (largest element), sigma {abs(vec[16] - ref[16]):.3g} deg "
            f"{abs(vec[17] - ref[17]):.3g} mm"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
