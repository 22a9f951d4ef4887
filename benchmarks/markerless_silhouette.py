"""Does the arm's outline in the colour image pin the focal length that depth leaves loose? (issue 41, a prototype)

With a real cell's errors all together at about 1.2 m the markerless registration's error is mostly the focal
length's: estimated from the depth it is 0.16 % off, which is 1.9 mm along the optical axis, and depth alone
cannot separate it from a depth offset (``benchmarks/results/markerless_intrinsics_oracle.md``). This script
measures whether the colour image's sharp outline of the arm breaks that tie, in three stages per placement:

1. **depth**: the registration with the front's defaults (``run_profile``'s ``self-calibrated``: depth scale
   and offset, the camera matrix and the joint offsets estimated with the pose);
2. **outline**: :func:`classic.markerless.silhouette.refine_silhouette` fits ``(f_x, f_y, c_x, c_y)`` and the
   pose to the arm's outline in the colour frames from stage 1's answer (its joint offsets applied to the model);
3. **depth + outline**: the registration again, told stage 2's focal lengths with stage 2's sigma as their prior
   (the principal point as given, with the factory prior: the depth image may be shifted against the colour one).

The colour frames are the dataset's own (the colour camera is the true camera; the depth is misregistered
against it by the profile's draw). Rows: error against the truth (the camera in the kinematic base frame with
joint offsets), sigma, beyond 3 sigma, the focal lengths' error; and time. Keep runs small::

    OPENBLAS_NUM_THREADS=1 taskset -c 0 python benchmarks/markerless_silhouette.py \\
        --data data/sensor-bands/paper-real-1.2 data/sensor-bands/paper-sim-1.2 --max-placements 3

(the bands as ``benchmarks/markerless_errors.py`` renders them).
"""

from __future__ import annotations

import argparse
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from benchmarks._report import Report  # noqa: E402
from benchmarks.markerless_errors import cases  # noqa: E402
from benchmarks.markerless_sensors import (  # noqa: E402
    front_options,
    observe,
    placements,
    told_intrinsics,
    told_posed,
    versions,
)
from classic.markerless import register_robot  # noqa: E402
from classic.markerless.kinematics import moved_surface  # noqa: E402
from classic.markerless.silhouette import SilhouetteOptions, refine_silhouette  # noqa: E402
from handeye.core.dataset import Dataset  # noqa: E402
from handeye.core.metrics import pose_error  # noqa: E402
from handeye.markerless import robot_surface_for  # noqa: E402

WRONG_SIGMAS = 3.0


def moving_samples(surface) -> np.ndarray:
    """Whether each sample's part moves over the frames: its centroid's RMS spread above 2 cm."""
    n_parts = int(surface.part.max()) + 1
    moving = np.zeros(n_parts, dtype=bool)
    for k in range(n_parts):
        sel = surface.part == k
        fr = surface.frame[sel]
        cent = np.stack(
            [np.bincount(fr, surface.points_base[sel, i]) / np.maximum(np.bincount(fr), 1) for i in range(3)], 1
        )
        cent = cent[np.bincount(fr) > 0]
        moving[k] = np.sqrt(((cent - cent.mean(0)) ** 2).sum(1).mean()) > 0.02
    return moving[surface.part]


def offsets_rad(res) -> np.ndarray | None:
    """The joint offsets the registration estimated (radians; 0 where absorbed or not seen), None when fixed."""
    jo = res.joint_offsets
    if jo.get("model") != "estimated":
        return None
    return np.radians([j["estimate_deg"] if j["status"] == "estimated" else 0.0 for j in jo["joints"]])


def theta_of(res, K) -> np.ndarray:
    """``(f_x, f_y, c_x, c_y)`` the registration ended with (the given ones when fixed)."""
    if res.intrinsics.get("model") == "estimated":
        return np.array([res.intrinsics[k]["estimate"] for k in ("fx", "fy", "cx", "cy")])
    return np.array([K[0, 0], K[1, 1], K[0, 2], K[1, 2]])


def outcome(res, T_truth, dt) -> tuple:
    """(accepted, err mm, err deg, sigma mm, sigma deg, s)."""
    if not res.ok:
        return (False, np.nan, np.nan, np.nan, np.nan, dt)
    rot, mm = pose_error(res.T_base_cam, T_truth)
    return (True, mm, rot, res.sigma["translation_mm"], res.sigma["rotation_deg"], dt)


def run_placement(ds, surface, stride, c, case, seed, opts_sil) -> dict:
    """The three stages on one placement: outcomes, focal errors (relative) and the outline fit's diagnostics."""
    sensor = case["sensor"]
    K_true = np.array(ds.meta["intrinsics"]["K"], dtype=float)
    K = told_intrinsics(K_true, case.get("intrinsics"))
    depth, q, _ = observe(ds, c, sensor, seed, case.get("registration"))
    posed, T_truth = told_posed(surface, q, ds.truth()[c], case.get("joints"))
    opts = front_options(sensor, stride)
    f_true = K_true[[0, 1], [0, 1]]
    t0 = time.perf_counter()
    first = register_robot(depth, K, posed, options=opts)
    out = {"depth": outcome(first, T_truth, time.perf_counter() - t0)}
    th1 = theta_of(first, K)
    out["f_depth"] = th1[:2] / f_true - 1
    if not first.ok:
        return out
    pts, nrm = posed.points_base, posed.normals_base
    d = offsets_rad(first)
    if d is not None:
        pts, nrm = moved_surface(pts, nrm, posed.frame, posed.part, posed.joint_twists_base, d)
    t = ds.select(c, "data")
    rgb = np.stack([ds.rgb(c, r) for r in t["rgb"]])
    t0 = time.perf_counter()
    sil = refine_silhouette(rgb, th1, first.T_base_cam, pts, nrm, posed.frame, moving_samples(posed), opts_sil)
    t_sil = time.perf_counter() - t0
    rot, mm = pose_error(sil.T_base_cam, T_truth)
    out["outline"] = (True, mm, rot, np.nan, np.nan, t_sil)
    out["f_outline"] = sil.theta[:2] / f_true - 1
    out["f_outline_sigma"] = sil.sigma_theta[:2] / sil.theta[:2]
    out["outline_rms_px"] = sil.rms_px
    K3 = K.copy()
    K3[0, 0], K3[1, 1] = sil.theta[:2]
    prior = (*out["f_outline_sigma"], opts.intrinsics_prior_sigma[2], opts.intrinsics_prior_sigma[3])
    t0 = time.perf_counter()
    third = register_robot(depth, K3, posed, options=replace(opts, intrinsics_prior_sigma=prior))
    out["depth + outline"] = outcome(third, T_truth, time.perf_counter() - t0 + t_sil + out["depth"][5])
    out["f_fused"] = theta_of(third, K3)[:2] / f_true - 1
    return out


def stage_row(name: str, rows: list, stage: str) -> str:
    got = [r[stage] for r in rows if stage in r]
    ok = np.array([g[1:5] for g in got if g[0]])
    n = len(rows)
    if not len(ok):
        return f"| {name} | 0/{n} | - | - | - | - | - |"
    wrong = int(np.sum((ok[:, 0] > WRONG_SIGMAS * ok[:, 2]) | (ok[:, 1] > WRONG_SIGMAS * ok[:, 3])))
    sig = "-" if np.isnan(ok[:, 2]).all() else f"{np.median(ok[:, 2]):.2f}"
    wrong_cell = "-" if np.isnan(ok[:, 2]).all() else str(wrong)
    f_key = {"depth": "f_depth", "outline": "f_outline", "depth + outline": "f_fused"}[stage]
    f_err = np.array([np.abs(r[f_key]).max() for r in rows if f_key in r]) * 100
    times = np.median([g[5] for g in got])
    return (
        f"| {name} | {len(ok)}/{n} | {np.median(ok[:, 0]):.2f} / {np.median(ok[:, 1]):.3f} | "
        f"{ok[:, 0].max():.2f} | {sig} | {wrong_cell} | {np.median(f_err):.3f} / {f_err.max():.3f} | {times:.1f} |"
    )


def section(rep: Report, ds: Dataset, chosen: list, max_placements: int, seed: int, opts_sil) -> None:
    """One dataset's table: every chosen case's three stages over its test placements."""
    cams = placements(ds, "test", max_placements)
    surface, stride = robot_surface_for(ds)
    rep.say(f"\n## {ds.root.name}: {len(cams)} test placements ({', '.join(map(str, cams))})\n")
    rep.say("| case, stage | accepted | median mm / deg | worst mm | sigma mm | beyond 3 sigma | f error % | s |")
    rep.say("|---|---|---|---|---|---|---|---|")
    for case in chosen:
        rows = []
        for c in cams:
            rows.append(run_placement(ds, surface, stride, c, case, seed, opts_sil))
            print(f"  camera {c}: {rows[-1]}", file=sys.stderr, flush=True)
        for stage in ("depth", "outline", "depth + outline"):
            rep.say(stage_row(f"{case['name']}, {stage}", rows, stage))
        rms = [r["outline_rms_px"] for r in rows if "outline_rms_px" in r]
        sd = [np.max(r["f_outline_sigma"]) * 100 for r in rows if "f_outline_sigma" in r]
        if rms:
            rep.say(
                f"\n- {case['name']}: outline residual RMS (inliers) median {np.median(rms):.3f} px; "
                f"outline's focal sigma median {np.median(sd):.3f} %\n"
            )


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--data", type=Path, nargs="+", required=True, help="bands rendered without depth noise")
    ap.add_argument("--max-placements", type=int, default=3, help="at most this many test placements per dataset")
    ap.add_argument("--cases", default="10", help="comma-separated case numbers of markerless_errors.py (1-based)")
    ap.add_argument("--seed", type=int, default=0, help="seed of the sensors' draws")
    ap.add_argument("--rim-cos", type=float, default=SilhouetteOptions.rim_cos, help="rim selection |n . r| below")
    ap.add_argument("--out", type=Path, help="results file")
    args = ap.parse_args()
    Report.cut(args, max_placements=1)
    rep = Report(
        "Markerless: the arm's outline in the colour image", "benchmarks/markerless_silhouette.py", None, versions()
    )
    rep.say(
        "Stages: depth (the front's defaults), outline (the colour outline alone, from depth's answer; no sigma "
        "of the pose), depth + outline (depth again, its focal lengths' prior the outline's estimate and sigma). "
        "f error: the worse of |f_x|, |f_y| relative error, median / worst over the placements, %. Time: s per "
        "placement (depth + outline: all three stages)."
    )
    chosen = [cases()[int(i) - 1] for i in args.cases.split(",")]
    opts_sil = SilhouetteOptions(rim_cos=args.rim_cos)
    for root in args.data:
        section(rep, Dataset.open(root), chosen, args.max_placements, args.seed, opts_sil)
    return rep.write(str(args.out) if args.out else None)


if __name__ == "__main__":
    sys.exit(main())
