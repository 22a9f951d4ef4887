"""Markerless calibration against a real cell's errors, each alone and all together: the table of error sources.

Each case tells the registration less than the truth in one way (the camera matrix, the depth image's
registration to it, the robot's joint zeros, a noise field repeated in every frame) and runs it with the
front's defaults (the depth scale and offset, the intrinsics and the joint offsets estimated with the pose;
the depth-to-colour rotation bounded by the profile's spread). The last case has them all together, drawn per
placement from the ``d435-real-cell`` profile. The rows: accepted, median and worst error against the truth,
how many were accepted beyond 3 predicted sigmas, and the wall time per placement (run it under
``taskset -c N`` for one core). ``--seed 0 1 2 3`` runs several draws of the sensors: each row over all their
placements, and each draw's median beside (with the intrinsics shared, one draw's pool is one estimate of the
camera matrix that moves all its placements alike).

    taskset -c 0 python benchmarks/markerless_errors.py --data data/sensor-bands/paper-real-1.2 --max-placements 5 \\
        --out /tmp/err/real.md

Without ``--data`` it renders the datasets first, without depth noise, as ``benchmarks/markerless_sensors.py
--presets paper-real paper-sim --bands 1.2`` does (kept in ``data/sensor-bands``, reused when there):
``python benchmarks/markerless_errors.py`` alone prints both tables (``--out FILE`` writes them there too;
``benchmarks/results/markerless_errors.md`` is put together from several such runs, not one to write over). The
joint offsets' truth is the camera in the robot's kinematic base frame
(:func:`benchmarks.markerless_sensors.kinematic_truth`).
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from dataclasses import fields, replace
from pathlib import Path
from typing import NamedTuple

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from benchmarks._report import Report  # noqa: E402
from benchmarks.markerless_sensors import (  # noqa: E402
    front_options,
    observe,
    placements,
    render_band,
    run_profile,
    told_intrinsics,
    told_posed,
    versions,
    with_errors,
)
from classic.markerless import MarkerlessOptions, register_robot  # noqa: E402
from classic.markerless.shared_intrinsics import (  # noqa: E402
    FIRST_PASS_PRIOR_TIMES,
    first_pass_options,
    second_passes,
)
from handeye.core.dataset import Dataset  # noqa: E402
from handeye.core.metrics import pose_error  # noqa: E402
from handeye.core.numbers import NONFINITE_WORDS, number_problem, parse_float, parse_int  # noqa: E402
from handeye.markerless import robot_surface_for  # noqa: E402
from handeye.robot.depth_sensors import PROFILES  # noqa: E402

#: Joint zero offsets of a real arm, degrees (0.1-0.3 per joint, signs mixed).
JOINT_OFFSETS_DEG = np.array([0.2, -0.3, 0.15, -0.1, 0.25, -0.2])
#: A factory camera matrix's error: focal lengths relative, principal point in pixels.
INTRINSICS_ERROR = {"fx": 0.007, "fy": 0.007, "cx": 3.0, "cy": 0.0}
#: The same camera-matrix error with the other sign: a factory calibration is off either way.
INTRINSICS_ERROR_OTHER_SIGN = {k: -v for k, v in INTRINSICS_ERROR.items()}


def cases() -> list[dict]:
    """The error sources: a name and what run_profile is given (sensor, intrinsics, registration, joints)."""
    d435 = PROFILES["d435"]
    real = PROFILES["d435-real-cell"]
    bounded = replace(d435, registration_roll_sigma_deg=real.registration_roll_sigma_deg)  # the roll's bound told
    no = {"du": 0.0, "dv": 0.0, "roll": 0.0}
    return [
        {"name": "none (d435 as is)", "sensor": d435},
        {"name": "fx, fy +0.7 %, cx +3 px", "sensor": d435, "intrinsics": INTRINSICS_ERROR},
        {"name": "fx +0.7 %", "sensor": d435, "intrinsics": {**INTRINSICS_ERROR, "fy": 0.0, "cx": 0.0}},
        {"name": "cx +3 px", "sensor": d435, "intrinsics": {**INTRINSICS_ERROR, "fx": 0.0, "fy": 0.0}},
        {"name": "depth image 1 px off", "sensor": d435, "registration": {**no, "du": 1.0}},
        {"name": "depth image 2 px off", "sensor": d435, "registration": {**no, "du": 2.0}},
        {"name": "depth image turned 0.2 deg (bound 0.2 deg)", "sensor": bounded, "registration": {**no, "roll": 0.2}},
        {"name": "joint zeros 0.1-0.3 deg", "sensor": d435, "joints": JOINT_OFFSETS_DEG},
        {"name": "fixed pattern 3.6 mm at 1 m", "sensor": with_errors(d435, 3.6)},
        {
            "name": "all together (d435-real-cell, intrinsics, joints)",
            "sensor": real,
            "intrinsics": INTRINSICS_ERROR,
            "joints": JOINT_OFFSETS_DEG,
        },
    ]


#: The cases run when --cases names none: the table's (the diagnostic ones after them only on request).
TABLE_CASES = 10


#: A registration told every systematic error it could estimate as exact (the depth unit, the camera matrix, the
#: joint zeros; no stereo pixel locking modelled): what is left of the error is the frames' own noise and what
#: depth cannot see (the depth camera's offset from the colour camera whose pose is the answer).
TOLD_EXACT = {
    "depth_model": "fixed",
    "stereo_fb_px_m": None,
    "intrinsics_model": "fixed",
    "joint_offsets_model": "fixed",
}


def diagnostic_cases() -> list[dict]:
    """Cases 11-14, run only when named.

    11, 12: the fixed pattern with no other noise or error (the d435's noise near 0, no scale or offset error),
    correlated over the d435's matching window as in the table, and white. 13, 14: the floor of the table's
    errors: the d435 without a scale or offset error, the registration told the depth unit, the camera matrix and
    the joints as exact (:data:`TOLD_EXACT`); 13 with the profile's depth-to-colour extrinsic error (0.5 mm per
    axis, which depth cannot see and every other row has too), 14 without it (the frames' noise alone). 15, 16:
    held out, the table's camera-matrix error with the other sign (:data:`INTRINSICS_ERROR_OTHER_SIGN`), alone and
    all together: nothing was tuned on them.
    """
    quiet = {"noise_quadratic_per_m": 1e-6, "scale_sigma": 0.0, "offset_sigma_m": 0.0}
    d435 = PROFILES["d435"]
    exact_unit = replace(d435, scale_sigma=0.0, offset_sigma_m=0.0)
    return [
        {"name": "fixed pattern 3.6 mm at 1 m alone", "sensor": replace(with_errors(d435, 3.6), **quiet)},
        {"name": "fixed pattern 3.6 mm at 1 m alone, white", "sensor": replace(with_errors(d435, 3.6, 0.0), **quiet)},
        {
            "name": "floor: all told exact but the depth-to-colour extrinsic",
            "sensor": exact_unit,
            "options": TOLD_EXACT,
        },
        {
            "name": "floor: all told exact, no depth-to-colour extrinsic",
            "sensor": replace(exact_unit, extrinsic_sigma_m=0.0),
            "options": TOLD_EXACT,
        },
        {"name": "fx, fy -0.7 %, cx -3 px (held out)", "sensor": d435, "intrinsics": INTRINSICS_ERROR_OTHER_SIGN},
        {
            "name": "all together, the camera matrix -0.7 %, cx -3 px (held out)",
            "sensor": PROFILES["d435-real-cell"],
            "intrinsics": INTRINSICS_ERROR_OTHER_SIGN,
            "joints": JOINT_OFFSETS_DEG,
        },
    ]


#: MarkerlessOptions' fields, the keys --option takes.
OPTION_FIELDS = tuple(f.name for f in fields(MarkerlessOptions))


def parse_option(text: str) -> tuple[str, object]:
    """``key=value`` of a MarkerlessOptions field: an int, a finite float (the project's number grammar),
    true/false, none, or else the text. A key that is no field is refused here, before anything is rendered or
    registered, and so is a value that starts as a number and is none (``nan``, ``1_0``)."""
    key, sep, value = (part.strip() for part in text.partition("="))
    if not sep or not key:
        raise argparse.ArgumentTypeError(f"--option: {text!r} is not key=value")
    if key not in OPTION_FIELDS:
        known = ", ".join(OPTION_FIELDS)
        raise argparse.ArgumentTypeError(f"--option: {key!r} is not a MarkerlessOptions field ({known})")
    if value.lower() in ("true", "false"):
        return key, value.lower() == "true"
    if value.lower() == "none":
        return key, None
    if value[:1] in tuple("+-.0123456789") or value.lower() in NONFINITE_WORDS:
        number = parse_int if number_problem(value, integer=True) is None else parse_float
        return key, number(value, f"--option {key}", argparse.ArgumentTypeError)
    return key, value


def row(name: str, rows: list) -> str:
    ok = [r for r in rows if r[0] == "ok"]
    n = len(rows)
    if not ok:
        return f"| {name} | 0/{n} | - | - | - | {np.median([r[5] for r in rows]):.1f} |"
    e = np.array([[r[1], r[2], r[3], r[4]] for r in ok])
    wrong = int(np.sum((e[:, 0] > 3 * e[:, 2]) | (e[:, 1] > 3 * e[:, 3])))
    return (
        f"| {name} | {len(ok)}/{n} | {np.median(e[:, 1]):.2f} / {np.median(e[:, 0]):.3f} | "
        f"{e[:, 1].max():.2f} / {e[:, 0].max():.3f} | {wrong} | {np.median([r[5] for r in rows]):.1f} |"
    )


def per_draw(name: str, draws: dict) -> str:
    """A line of ``name``'s median translation error per draw of the sensors (seed -> :func:`row`'s tuples), mm;
    ``-`` where a draw accepted none."""

    def median(rows):
        mm = [r[2] for r in rows if r[0] == "ok"]
        return f"{np.median(mm):.2f}" if mm else "-"

    return f"- {name}: " + ", ".join(f"seed {s} {median(rows)}" for s, rows in draws.items())


def run_case(ds, surface, stride, cams, case: dict, seed: int, options=None) -> list:
    """One error source of :func:`cases` on the placements ``cams``: :func:`run_profile`'s rows for the front's
    defaults (its ``"self-calibrated"`` mode), told the case's intrinsics, registration and joint errors, with the
    case's ``options`` over ``options``."""
    rows = run_profile(
        ds,
        surface,
        stride,
        cams,
        case["sensor"],
        seed,
        intrinsics_error=case.get("intrinsics"),
        modes=("self-calibrated",),
        registration=case.get("registration"),
        joint_offsets=case.get("joints"),
        options={**(options or {}), **case.get("options", {})},
    )
    return rows["self-calibrated"]


def _outcome(res, T_true, seconds) -> tuple:
    """A registration as :func:`row` reads it: status, errors, sigmas, seconds."""
    if not res.ok:
        return ("refused", np.nan, np.nan, np.nan, np.nan, seconds)
    rot, mm = pose_error(res.T_base_cam, T_true)
    return ("ok", rot, mm, res.sigma["rotation_deg"], res.sigma["translation_mm"], seconds)


def _floor_note(res) -> str:
    """Where the stated prior floored a shared answer's sigma: the sigma under the pooled prior alone, and the
    floor's (mm)."""
    floor = res.diagnostics.get("sigma_shared_floor") if res.ok else None
    if not floor:
        return ""
    own = np.sqrt(max(res.sigma["translation_mm"] ** 2 - floor["translation_mm"] ** 2, 0.0))
    return f", sigma under the pooled prior {own:.2f} mm, under the stated {floor['floor']['translation_mm']:.2f} mm"


class Pooling(NamedTuple):
    """How :func:`run_case_shared` pools: ``one_unit``, every placement's sensor errors the first placement's draw
    (one camera moved between placements, as in a cell; else each placement draws its own unit, as the table's
    other rows do); ``pool``, further placements of the same camera whose first pass joins the others' estimates (as
    every placement of a dataset does in ``handeye markerless``), their own errors not counted; ``floor``, each
    pooled answer's sigma no narrower than under the stated prior
    (:attr:`MarkerlessOptions.intrinsics_floor_prior_sigma`)."""

    one_unit: bool = False
    pool: tuple = ()
    floor: bool = False


def run_case_shared(ds, surface, stride, cams, case: dict, seed: int, options=None, pooling=Pooling()) -> tuple:
    """The case twice on the same frames: each placement alone (the front's first pass, under
    :func:`classic.markerless.shared_intrinsics.first_pass_options`), then again with the
    intrinsics the other placements estimated as its prior (``handeye markerless``'s default with 4 or more
    placements: :func:`handeye.markerless_shared.share_intrinsics`'s steps, on the benchmark's sensor frames).

    ``pooling``: which unit, which further placements pool, whether the stated prior floors the sigma
    (:class:`Pooling`).
    Returns the two lists of :func:`row`'s tuples for ``cams`` (the second's seconds both passes'), and a line
    per placement of what was pooled.
    """
    K = told_intrinsics(ds.meta["intrinsics"]["K"], case.get("intrinsics"))
    T_true = ds.truth()
    opts = front_options(case["sensor"], stride, **{**(options or {}), **case.get("options", {})})
    one_unit, pool, floor = pooling
    unit = cams[0] if one_unit else None
    frames, first, alone = {}, {}, []
    for c in [*cams, *(p for p in pool if p not in cams)]:
        depth, q, _ = observe(ds, c, case["sensor"], seed, case.get("registration"), unit)
        posed, T_c = told_posed(surface, q, T_true[c], case.get("joints"))
        t0 = time.process_time()
        first[c] = register_robot(depth, K, posed, options=first_pass_options(opts))
        outcome = _outcome(first[c], T_c, time.process_time() - t0)
        print(f"  camera {c}, alone{'' if c in cams else ' (pool only)'}: {outcome}", file=sys.stderr, flush=True)
        if c in cams:
            frames[c] = (depth, posed, T_c)
            alone.append(outcome)
    seconds = {}

    def register(c, K_prior, starts, second_opts):
        depth, posed, _ = frames[c]
        t0 = time.process_time()
        analysis = first[c].depth_analysis
        if floor and second_opts.intrinsics_prior_sigma != opts.intrinsics_prior_sigma:  # a pooled prior
            second_opts = replace(second_opts, intrinsics_floor_prior_sigma=opts.intrinsics_prior_sigma)
        res = register_robot(depth, K_prior, posed, starts=starts, options=second_opts, depth_analysis=analysis)
        seconds[c] = time.process_time() - t0
        return res

    shared, notes = [], []
    for (c, (prior, res)), one in zip(second_passes(first, K, opts, register, only=cams).items(), alone):
        if prior is None:
            notes.append(f"{c}: too few placements estimated the intrinsics")
        else:
            spread = ", ".join(f"{n} {v:.2f}" for n, v in zip(("fx", "fy", "cx", "cy"), prior.spread) if v > 0)
            spread = f" (spread px: {spread})" if spread else ""
            notes.append(f"{c}: {''.join('x' if u else '.' for u in prior.pooled)}{spread} {prior.reason}".rstrip())
        shared.append(_outcome(res, frames[c][2], one[5] + seconds[c]))  # each registered again (second_passes)
        print(f"  camera {c}, shared: {shared[-1]}{_floor_note(res)}", file=sys.stderr, flush=True)
    return alone, shared, notes


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--data", type=Path, nargs="+", help="datasets rendered without depth noise (default: --presets)")
    ap.add_argument(
        "--presets",
        nargs="+",
        default=["paper-real", "paper-sim"],
        help="without --data: these presets' test "
        "placements at --band, rendered as benchmarks/markerless_sensors.py renders them (kept in --work)",
    )
    ap.add_argument("--band", default="1.2", help="distance band of the rendered placements, metres")
    ap.add_argument("--work", type=Path, default=Path("data/sensor-bands"), help="where --presets renders")
    ap.add_argument("--max-placements", type=int, default=5, help="at most this many test placements per dataset")
    ap.add_argument(
        "--cases",
        help=f"comma-separated case numbers (1-based) to run, default the table's 1-{TABLE_CASES}; "
        "11 and 12: the fixed pattern alone, correlated and white; 13 and 14: the floor, all told exact, with and "
        "without the depth-to-colour extrinsic error; 15 and 16 (held out): the camera matrix off the other way, "
        "alone and all together",
    )
    ap.add_argument(
        "--seed",
        type=int,
        nargs="+",
        default=[0],
        help="seed of the sensors' draws; several (--seed 0 1 2 3): each row over every draw's placements, and "
        "a line per case with each draw's median (one draw's pool is one estimate of the camera matrix, shared by "
        "its placements)",
    )
    ap.add_argument(
        "--pixel-effect-px",
        type=int,
        default=0,
        help="MarkerlessOptions.pixel_effect_px: marginalise a depth error per image cell this many pixels square, "
        "the same in every frame (a fixed pattern); 0, the default, off",
    )
    ap.add_argument(
        "--option",
        type=parse_option,
        action="append",
        default=[],
        help="key=value: a further MarkerlessOptions field of the run (intrinsics_model=fixed, static_parts=true, "
        "...); repeatable",
    )
    ap.add_argument(
        "--shared-intrinsics",
        action="store_true",
        help="each case twice: each placement alone, then with the other placements' intrinsics as its prior "
        "(handeye markerless's default with 4 or more placements); the s column CPU seconds of one thread",
    )
    ap.add_argument(
        "--one-unit",
        action="store_true",
        help="with --shared-intrinsics: one sensor unit for all placements (the first placement's draw: a camera "
        "moved between placements), else each placement draws its own",
    )
    ap.add_argument(
        "--sigma-floor",
        action="store_true",
        help="with --shared-intrinsics: each pooled answer's sigma kept no narrower than under the stated intrinsics "
        "prior (MarkerlessOptions.intrinsics_floor_prior_sigma); each shared placement's line on stderr gives both",
    )
    ap.add_argument(
        "--pool-train",
        action="store_true",
        help="with --shared-intrinsics: the datasets' train placements join the pool (their first pass only, their "
        "errors not counted), as every placement of a dataset does in handeye markerless; without --data the "
        "presets are rendered with their train placements too",
    )
    Report.add_out(ap)
    args = ap.parse_args()
    if (args.one_unit or args.pool_train or args.sigma_floor) and not args.shared_intrinsics:
        ap.error("--one-unit, --pool-train and --sigma-floor need --shared-intrinsics")
    Report.cut(args, max_placements=1)
    title = "Markerless calibration against a real cell's errors"
    rep = Report(title, "benchmarks/markerless_errors.py", None, versions())
    options = {"pixel_effect_px": args.pixel_effect_px, **dict(args.option)}
    if args.pixel_effect_px:
        rep.say(f"With a depth error per {args.pixel_effect_px} px image cell marginalised (--pixel-effect-px).\n")
    if args.shared_intrinsics:
        rep.say(
            "Each case twice on the same frames: each placement alone (its first pass, under an intrinsics prior "
            f"{FIRST_PASS_PRIOR_TIMES:g} times the stated one, as a pooled placement's first pass is), then each "
            "again with the intrinsics the other placements estimated as its prior (--shared-intrinsics"
            + (", one sensor unit for all placements: --one-unit" if args.one_unit else ", a unit per placement")
            + "); s: CPU seconds of one thread, both passes in the shared rows.\n"
        )
    if args.sigma_floor:
        rep.say("Each pooled answer's sigma kept no narrower than under the stated intrinsics prior (--sigma-floor).\n")
    if args.pool_train:
        rep.say(
            "The pool: every placement of the dataset (--pool-train), the train placements' first pass joining "
            "the estimates; the rows count the test placements only.\n"
        )
    if args.option:
        rep.say("Options beside the front's defaults: " + ", ".join(f"{k}={v}" for k, v in args.option) + ".\n")
    cores = len(os.sched_getaffinity(0))
    load = os.getloadavg()[0]
    rep.say(
        "Each row: one error the method is not told (the last, all together), the front's defaults. Wrong: "
        "accepted more than 3 predicted sigmas from the truth (translation or rotation). "
        + (
            "Time: CPU seconds of one thread per placement (time.process_time; the machine's load does not "
            f"inflate it; load {load:.1f} at the start)."
            if args.shared_intrinsics
            else f"Time: wall seconds per placement (the registration), on {cores} core{'s' if cores > 1 else ''} "
            f"this process may use, the machine's load {load:.1f} at the start: wall time under load is not one "
            "core's time."
        )
    )
    # the bands markerless_sensors.py renders with its default seed (render seed 1): the same datasets
    data = args.data or [render_band(args.work, preset, args.band, 1, args.pool_train) for preset in args.presets]
    chosen = cases() + diagnostic_cases()
    chosen = [chosen[int(i) - 1] for i in args.cases.split(",")] if args.cases else chosen[:TABLE_CASES]
    for root in data:
        ds = Dataset.open(root)
        surface, stride = robot_surface_for(ds)
        cams = placements(ds, "test", args.max_placements)
        pool = placements(ds, "train") if args.pool_train else []
        more = f", {len(pool)} more in the pool" if pool else ""
        pooling = Pooling(args.one_unit, tuple(pool), args.sigma_floor)
        rep.say(f"\n## {ds.root.name}: {len(cams)} test placements{more}\n")
        rep.say("| error the method is not told | accepted | median mm / deg | worst mm / deg | beyond 3 sigma | s |")
        rep.say("|---|---|---|---|---|---|")
        pooled_lines, draw_lines = [], []
        for case in chosen:
            if not args.shared_intrinsics:
                draws = {s: run_case(ds, surface, stride, cams, case, s, options) for s in args.seed}
                rep.say(row(case["name"], sum(draws.values(), [])))
                draw_lines.append(per_draw(case["name"], draws))
                continue
            runs = {s: run_case_shared(ds, surface, stride, cams, case, s, options, pooling) for s in args.seed}
            rep.say(row(case["name"] + ", alone", sum((r[0] for r in runs.values()), [])))
            rep.say(row(case["name"] + ", intrinsics shared", sum((r[1] for r in runs.values()), [])))
            draw_lines.append(per_draw(case["name"] + ", intrinsics shared", {s: r[1] for s, r in runs.items()}))
            for s, (_, _, notes) in runs.items():
                draw = f" (seed {s})" if len(args.seed) > 1 else ""
                pooled_lines.append(f"- {case['name']}{draw}: pooled fx fy cx cy per placement, " + "; ".join(notes))
        if len(args.seed) > 1:
            rep.say(
                f"\nEach draw's median, mm (--seed {' '.join(map(str, args.seed))}; the rows above: every draw's "
                "placements together):\n"
            )
            for line in draw_lines:
                rep.say(line)
            rep.say("")
        for line in pooled_lines:
            rep.say(line)
    return rep.write(args.out)


if __name__ == "__main__":
    sys.exit(main())
