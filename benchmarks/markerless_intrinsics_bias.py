"""Benchmark: the bias of the depth camera's intrinsics that one markerless registration estimates.

Each of a band dataset's placements (every ``--every``-th) registered alone, the front's first pass, as
:mod:`benchmarks.markerless_errors` runs it (its case ``--case``, 2 px cells marginalised); per intrinsic
parameter ``(f_x, f_y, c_x, c_y)`` the inverse-variance weighted mean of the estimates' errors against the
truth (pixels) with its sigma and the Birge ratio (the scatter's root chi-square per degree of freedom), and the
mean error of the camera's position in its own frame (mm). A mean several of its sigmas from 0 is a bias the
placements share, which pooling their estimates (``handeye markerless``'s shared intrinsics) does not average
away. Two rows each: the fit's estimates, and those the placements pool, with the depth noise's own bias taken out
(:mod:`classic.markerless.noise_debias`, as the front's first pass gives them to the pool)::

    OPENBLAS_NUM_THREADS=1 taskset -c 0 python benchmarks/markerless_intrinsics_bias.py \\
        --data data/sensor-bands/paper-real-1.2-with-train --every 2 --case 4

``--sensor ideal --noise-at-1m 0.00358``: the simulator's ideal sensor (no scale, offset, holes, flying pixels or
correlated noise) with a white depth noise of that many metres at 1 m, growing with depth squared: which of the
sensor's errors the bias comes from. ``--option key=value`` (repeatable): a further ``MarkerlessOptions`` field
(``max_incidence_deg=65``, ``depth_model=fixed``, ...), to see which part of the fit a bias comes from. The last
line is the depth unit's mean error against the sensor's drawn scale and offset (as reported: its own noise bias
taken out).
"""

from __future__ import annotations

import argparse
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from benchmarks._report import Report  # noqa: E402
from benchmarks.markerless_errors import cases, parse_option  # noqa: E402
from benchmarks.markerless_sensors import front_options, observe, placements, told_intrinsics, told_posed  # noqa: E402
from classic.markerless import register_robot  # noqa: E402
from classic.markerless.intrinsics import NAMES, intrinsics_vector  # noqa: E402
from classic.markerless.shared_intrinsics import estimate_and_sigma, inverse_variance_mean  # noqa: E402
from handeye.core.dataset import Dataset  # noqa: E402
from handeye.markerless import robot_surface_for  # noqa: E402
from handeye.robot.depth_sensors import PROFILES  # noqa: E402


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--data", type=Path, default=Path("data/sensor-bands/paper-real-1.2-with-train"))
    ap.add_argument("--every", type=int, default=2, help="every this many placements (of all the dataset's)")
    ap.add_argument("--case", type=int, default=1, help="markerless_errors.py's case number (1: d435 as is)")
    ap.add_argument("--sensor", choices=sorted(PROFILES), help="this profile instead of the case's")
    ap.add_argument("--noise-at-1m", type=float, help="the profile's depth noise at 1 m (m, quadratic in depth)")
    ap.add_argument("--seed", type=int, default=0, help="seed of the sensors' draws")
    ap.add_argument(
        "--option",
        type=parse_option,
        action="append",
        default=[],
        help="key=value: a further MarkerlessOptions field (max_incidence_deg=60, depth_model=fixed, ...); repeatable",
    )
    Report.add_out(ap)
    args = ap.parse_args()
    case = cases()[args.case - 1]
    sensor = PROFILES[args.sensor] if args.sensor else case["sensor"]
    if args.noise_at_1m is not None:
        sensor = replace(sensor, noise_quadratic_per_m=args.noise_at_1m)
    ds = Dataset.open(args.data)
    surface, stride = robot_surface_for(ds)
    K_true = np.array(ds.meta["intrinsics"]["K"], dtype=float)
    K = told_intrinsics(K_true, case.get("intrinsics"))
    opts = front_options(
        sensor, stride, **{"pixel_effect_px": 2, "intrinsics_noise_debiased": True, **dict(args.option)}
    )
    versions = f"numpy {np.__version__}"
    report = Report(
        "Markerless: the intrinsics' bias over placements", "benchmarks/markerless_intrinsics_bias.py", None, versions
    )
    report.say(
        f"{ds.root.name}, case {args.case} ({case['name']}), sensor {sensor.name}, noise at 1 m "
        f"{sensor.noise_quadratic_per_m * 1e3:.2f} mm" + "".join(f", {k}={v}" for k, v in args.option)
    )
    errors, sigmas, offsets, units = [], [], [], []
    errors_fit, sigmas_fit = [], []  # the fit's own, before the noise's bias is taken out
    T_true = ds.truth()
    for c in placements(ds, "all")[:: args.every]:
        depth, q, unit = observe(ds, c, sensor, args.seed, case.get("registration"))
        posed, T_c = told_posed(surface, q, T_true[c], case.get("joints"))
        res = register_robot(depth, K, posed, options=opts)
        estimate = estimate_and_sigma(res.intrinsics) if res.ok else None
        if estimate is None:
            report.say(f"placement {c}: {res.refused or 'intrinsics not estimated'}")
            continue
        truth = intrinsics_vector(K_true) + np.r_[0.0, 0.0, unit.registration_px]  # a shifted image moves c
        errors.append(estimate[0] - truth)
        sigmas.append(estimate[1])
        fitted = estimate_and_sigma(res.intrinsics, debiased=False)
        errors_fit.append(fitted[0] - truth)
        sigmas_fit.append(fitted[1])
        offsets.append((np.linalg.inv(T_c) @ res.T_base_cam)[:3, 3] * 1e3)
        if "scale" in res.depth:  # the depth unit's error: scale (%), offset (mm)
            units.append([(res.depth["scale"] - unit.scale) * 100, res.depth["offset_mm"] - unit.offset_m * 1e3])
        report.say(
            f"placement {c}: error {np.round(errors[-1], 2)} px, sigma {np.round(sigmas[-1], 2)} px, "
            f"camera off {np.round(offsets[-1], 2)} mm (its frame)"
        )
    if len(errors) < 2:
        report.say("too few placements estimated the intrinsics")
        return 1
    report.say()
    report.say(f"| {len(errors)} placements | " + " | ".join(NAMES) + " |")
    report.say("|---|" + "---|" * len(NAMES))
    for label, e, sd in (("the fit's", errors_fit, sigmas_fit), ("as pooled (noise's bias out)", errors, sigmas)):
        mean, sigma, birge = inverse_variance_mean(e, sd)
        report.say(
            f"| {label}: weighted mean error, px | "
            + " | ".join(f"{m:+.3f} +- {s:.3f}" for m, s in zip(mean, sigma))
            + " |"
        )
        report.say(f"| {label}: Birge ratio | " + " | ".join(f"{b:.2f}" for b in birge) + " |")
    report.say(f"mean camera offset in its own frame (x, y, z): {np.round(np.mean(offsets, axis=0), 2)} mm")
    if len(units) > 1:
        u = np.array(units)
        report.say(
            f"depth unit's mean error: scale {u[:, 0].mean():+.3f} +- {u[:, 0].std(ddof=1) / np.sqrt(len(u)):.3f} %, "
            f"offset {u[:, 1].mean():+.2f} +- {u[:, 1].std(ddof=1) / np.sqrt(len(u)):.2f} mm"
        )
    return report.write(args.out)


if __name__ == "__main__":
    sys.exit(main())
