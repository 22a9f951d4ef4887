"""Benchmark of ``handeye plan``: planned poses against random ones from the same candidates, predicted and actual.

Run from the repository root::

    python benchmarks/plan_poses.py --out benchmarks/results/plan_poses.md   # the README's figures (100 trials)
    python benchmarks/plan_poses.py --trials 10                              # a quick look

Each trial is a UR5 cell, eye-to-hand (:mod:`handeye.robot.model`, inverse kinematics through Pinocchio):

* the truth: a camera 1.0-1.4 m from the base horizontally (azimuth within 60 deg of the base's x axis),
  0.6-1.1 m up, looking at the default workspace point (:func:`handeye.planning.camera_looking_at`) moved
  up to 10 cm; a board on the flange 1 cm out, turned up to 5 deg and moved up to 1 cm from the default
  mount;
* what the planner is told: the camera's position within 3 cm (``--camera-guess``), the default look-at
  point and board mount, the noise model (camera 0.1 deg / 1 mm, robot 0.01 deg / 0.2 mm per axis);
* candidates: 1500 views sampled in the field of view around the guess, kept where the UR5's inverse
  kinematics reaches them (:func:`handeye.planning.sample_candidates`, what ``handeye plan --robot ur5``
  does);
* for each pose count: the poses ``plan`` chooses (from no recorded pose, ``min_gain=0``) and as many drawn
  at random from the same candidates;
* the robot goes to each chosen flange pose; the camera sees the board through the *true* X and Y; both
  measurements get Gaussian noise of the model; ``classic.calibrate`` (maximum likelihood, told the noise
  model) estimates X.

Reported, RMS over the trials: the predicted 1-sigma of X (the Cramér–Rao bound at the guess, what ``plan``
prints) and the actual error of ``calibrate`` against the true X: rotation (deg), translation (mm) and the
workspace error (RMS displacement of the candidates' target positions mapped through X, mm; the planner's
criterion). Target: the planned poses reach the random poses' 15-pose workspace sigma with at most 8
poses, predicted and actual.
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
from classic.planning import pose_information, predicted_sigmas, workspace_weight  # noqa: E402
from classic.target_views import ViewLimits, target_in_view, views_of  # noqa: E402
from handeye.core.errors import HandEyeInputError  # noqa: E402
from handeye.core.metrics import pose_error  # noqa: E402
from handeye.core.se3 import make_transform, so3_exp  # noqa: E402
from handeye.core.setups import robot_side_poses  # noqa: E402
from handeye.core.synthetic import perturb  # noqa: E402
from handeye.planning import (  # noqa: E402
    DEFAULT_NOISE,
    LOOK_AT_HEIGHT_M,
    LOOK_AT_REACH_M,
    camera_looking_at,
    limits_for,
    plan_next_poses,
    sample_candidates,
    target_on_flange,
    unknowns_for_plan,
    view_distances,
)

SETUP = "eye_to_hand"
POSE_COUNTS = (6, 8, 10, 15)
KINDS = ("planned", "random")
QUANTITIES = ("rot", "trans", "ws")
NOISE = DEFAULT_NOISE
_ROBOT = None


def _robot():
    global _ROBOT
    if _ROBOT is None:
        from handeye.robot.model import load_robot

        _ROBOT = load_robot("ur5")
    return _ROBOT


def _cell(rng: np.random.Generator) -> dict:
    """The truth and the guesses of one trial."""
    az = np.radians(rng.uniform(-60.0, 60.0))
    position = np.array([np.cos(az), np.sin(az), 0.0]) * rng.uniform(1.0, 1.4) + [0.0, 0.0, rng.uniform(0.6, 1.1)]
    toward = position[:2] / np.linalg.norm(position[:2])
    look_at = np.r_[LOOK_AT_REACH_M * toward, LOOK_AT_HEIGHT_M] + rng.uniform(-0.05, 0.05, 3)
    X_true = camera_looking_at(position, look_at)
    Y0 = target_on_flange()
    axis = rng.normal(size=3)
    Y_true = make_transform(
        Y0[:3, :3] @ so3_exp(axis / np.linalg.norm(axis) * np.radians(rng.uniform(0, 5))),
        Y0[:3, 3] + rng.uniform(-0.01, 0.01, 3),
    )
    return {"X": X_true, "Y": Y_true, "camera_guess": position + rng.uniform(-0.03, 0.03, 3)}


def _errors(T_base_ee: np.ndarray, cell: dict, p_cam: np.ndarray, rng: np.random.Generator) -> dict | None:
    """Measure at the poses through the truth with noise, calibrate, the errors of X (None when refused)."""
    B_true = views_of(T_base_ee, cell["X"], cell["Y"], SETUP)
    B = perturb(B_true, rng, NOISE.camera_rot_rad, NOISE.camera_trans_m)
    T = perturb(T_base_ee, rng, NOISE.robot_rot_rad, NOISE.robot_trans_m)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            X = classic.calibrate(T, B, setup=SETUP, noise=NOISE).X
    except HandEyeInputError:
        return None
    rot, trans = pose_error(X, cell["X"])
    p_true = p_cam @ cell["X"][:3, :3].T + cell["X"][:3, 3]  # the workspace points mapped by the true X
    p_est = p_cam @ X[:3, :3].T + X[:3, 3]
    ws = 1000.0 * np.sqrt(np.mean(np.sum((p_est - p_true) ** 2, axis=1)))
    return {"rot": float(rot), "trans": float(trans), "ws": float(ws)}


def trial(seed: int) -> dict:
    """One cell: predicted and actual sigmas of planned and random poses per pose count."""
    rng = np.random.default_rng(seed)
    cell = _cell(rng)
    none = np.zeros((0, 4, 4))
    unknowns = unknowns_for_plan(SETUP, none, none, camera_guess=cell["camera_guess"])
    limits = ViewLimits(*view_distances(SETUP, unknowns, none))  # the camera's; planned with the guess margin
    cands = sample_candidates(SETUP, unknowns, rng, 1500, limits_for(limits, unknowns), _robot())
    out = {"candidates": len(cands), "predicted": {}, "actual": {}, "refused": 0, "in_view": [], "planned": 0}
    if len(cands) < max(POSE_COUNTS):
        out["skipped"] = True
        return out
    p_cam = cands.T_cam_target[:, :3, 3]
    M = workspace_weight(unknowns.X, p_cam)
    G = pose_information(robot_side_poses(cands.T_base_ee, SETUP), unknowns.X, unknowns.Y, NOISE, SETUP)
    for n in POSE_COUNTS:
        planned = plan_next_poses(SETUP, none, none, unknowns, cands, n=n, noise=NOISE, min_gain=0.0)
        chosen = {"planned": planned.plan.chosen, "random": rng.choice(len(cands), n, replace=False)}
        truth_views = views_of(planned.T_base_ee, cell["X"], cell["Y"], SETUP)
        out["in_view"].append(float(np.mean(target_in_view(truth_views, limits))))
        for kind, idx in chosen.items():
            s = predicted_sigmas(np.einsum("nji,njk->ik", G[idx], G[idx]), M)
            out["predicted"][(kind, n)] = {
                "rot": s["X_rotation_deg"],
                "trans": s["X_translation_mm"],
                "ws": s["X_workspace_mm"],
            }
            err = _errors(cands.T_base_ee[idx], cell, p_cam, rng)
            if err is None:
                out["refused"] += 1
            else:
                out["actual"][(kind, n)] = err
    return out


def _rms(values) -> float:
    v = np.asarray(list(values), dtype=float)
    return float(np.sqrt(np.mean(v**2))) if len(v) else float("nan")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--trials", type=int, default=100, help="cells (default 100)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--workers", type=int, default=min(2, os.cpu_count() or 1), help="processes (default 2)")
    ap.add_argument("--out", help="also write the report to this file")
    args = ap.parse_args(argv)
    report = Report(
        "Pose planning: planned against random poses from the same candidates",
        "benchmarks/plan_poses.py",
        argv,
        f"numpy {np.__version__}",
    )
    say = report.say
    seeds = [args.seed * 100003 + k for k in range(args.trials)]
    with ProcessPoolExecutor(max_workers=args.workers) as pool:
        results = list(pool.map(trial, seeds))
    used = [r for r in results if not r.get("skipped")]
    median = np.median([r["candidates"] for r in results])
    say(
        f"UR5 eye-to-hand, {len(used)} of {len(results)} cells used (the others had fewer than {max(POSE_COUNTS)} "
        f"reachable candidates); reachable candidates per cell: median {median:.0f} of 1500 sampled; noise camera "
        "0.1 deg / 1 mm, robot 0.01 deg / 0.2 mm per axis; calibrate() told the noise model"
    )
    say(
        f"calibrations refused: {sum(r['refused'] for r in used)} of {len(used) * len(POSE_COUNTS) * len(KINDS)}; "
        f"planned views still in the field of view under the true X: "
        f"{100 * np.mean([v for r in used for v in r['in_view']]):.1f} %"
    )
    say()
    say("RMS over the cells, rotation deg / translation mm / workspace mm (the planner's criterion):")
    say()
    say("| poses | planned predicted | random predicted | planned actual | random actual |")
    say("|---|---|---|---|---|")
    table = {}
    for n in POSE_COUNTS:
        row = []
        for which in ("predicted", "actual"):
            for kind in KINDS:
                vals = [_rms(r[which][(kind, n)][q] for r in used if (kind, n) in r[which]) for q in QUANTITIES]
                table[(which, kind, n)] = vals
        for which, kind in (
            ("predicted", "planned"),
            ("predicted", "random"),
            ("actual", "planned"),
            ("actual", "random"),
        ):
            v = table[(which, kind, n)]
            row.append(f"{v[0]:.4f} / {v[1]:.3f} / {v[2]:.3f}")
        say(f"| {n} | " + " | ".join(row) + " |")
    say()
    for which in ("predicted", "actual"):
        ref = table[(which, "random", 15)]
        reach = [n for n in POSE_COUNTS if table[(which, "planned", n)][2] <= ref[2]]
        first = min(reach) if reach else None
        both = [n for n in POSE_COUNTS if all(table[(which, "planned", n)][k] <= ref[k] for k in range(3))]
        verdict = "met" if first is not None and first <= 8 else "not met"
        say(
            f"target ({which}): planned poses reach the random 15-pose workspace sigma ({ref[2]:.3f} mm) with at "
            f"most 8 -> {verdict} (first at {first if first else '> 15'} of {POSE_COUNTS}); rotation, translation and "
            f"workspace all at or below random-15 from {min(both) if both else '> 15'} poses"
        )
    report.write(args.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
