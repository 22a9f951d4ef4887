"""Pose planning (``handeye plan``): the greedy design on the predicted covariance, views in sight, joints, advice."""

from __future__ import annotations

import numpy as np
import pytest

from classic.noise_model import NoiseModel
from classic.planning import (
    STOP_EXHAUSTED,
    STOP_SMALL_GAIN,
    PlanOptions,
    plan_poses,
    pose_information,
    predicted_sigmas,
)
from classic.refine import cramer_rao_bound
from classic.target_views import ViewLimits, flange_poses, sample_views, target_in_view, views_of
from handeye.cli import main
from handeye.core.posefile import read_robot_poses
from handeye.core.se3 import make_transform, so3_exp, so3_log
from handeye.core.setups import robot_side_poses
from handeye.core.synthetic import make_problem
from tests.tolerances import EXACT, SCALE_RTOL

NOISE = NoiseModel(
    camera_rot_rad=np.radians(0.1), camera_trans_m=1e-3, robot_rot_rad=np.radians(0.01), robot_trans_m=0.2e-3
)
NONE = np.zeros((0, 4, 4))
ALL_N = PlanOptions(min_gain=0.0)  # plan all n poses: no gain is too small


def _cell(rng, setup="eye_to_hand", n_views=300):
    """A make_problem truth and candidate robot-side poses with the target in view."""
    p = make_problem(3, setup, rng)
    views = sample_views(rng, n_views)
    A = robot_side_poses(flange_poses(views, p.X_true, p.Y_true, setup), setup)
    return p, A


def _information(A, X, Y, setup="eye_to_hand"):
    G = pose_information(A, X, Y, NOISE, setup)
    return np.einsum("nji,njk->ik", G, G)


def test_information_is_the_cramer_rao_bound(rng):
    """The per-pose factors sum to the information whose inverse refine.cramer_rao_bound returns."""
    p, A = _cell(rng, n_views=10)
    C = np.linalg.inv(_information(A, p.X_true, p.Y_true))
    bound = cramer_rao_bound(A, p.X_true, p.Y_true, NOISE)
    assert np.abs(C - bound).max() <= SCALE_RTOL * np.abs(bound).max()


@pytest.mark.parametrize("setup", ["eye_to_hand", "eye_in_hand"])
def test_greedy_never_increases_the_predicted_sigma(rng, setup):
    """Every added pose adds information: rotation, translation and workspace sigma never grow."""
    p, A = _cell(rng, setup)
    plan = plan_poses(A[:4], A[4:], p.X_true, p.Y_true, NOISE, setup, n=10, options=ALL_N)
    assert len(plan.chosen) == 10
    for s in (plan.sigma_rotation_deg, plan.sigma_translation_mm, plan.sigma_workspace_mm):
        assert np.all(np.isfinite(s))
        assert np.all(s[1:] <= s[:-1] * (1 + SCALE_RTOL)), s
    assert np.all(plan.gain > 0)
    # the per-step sigmas are those of the bound of the recorded poses plus the plan's first k
    full = np.concatenate([A[:4], A[4:][plan.chosen]])
    bound = np.sqrt(np.trace(cramer_rao_bound(full, p.X_true, p.Y_true, NOISE, setup)[:3, :3]))
    assert np.isclose(np.radians(plan.sigma_rotation_deg[-1]), bound, rtol=SCALE_RTOL)


def test_planned_beats_random_on_its_criterion(rng):
    """Eight planned poses predict a smaller workspace sigma than eight random ones of the same candidates."""
    p, A = _cell(rng)
    plan = plan_poses(NONE, A, p.X_true, p.Y_true, NOISE, n=8, options=ALL_N)
    M_points = views_of(A, p.X_true, p.Y_true, "eye_to_hand")[:, :3, 3]
    from classic.planning import workspace_weight

    M = workspace_weight(p.X_true, M_points)
    random = [
        predicted_sigmas(_information(A[rng.choice(len(A), 8, replace=False)], p.X_true, p.Y_true), M)
        for _ in range(20)
    ]
    assert plan.sigma_workspace_mm[-1] < min(r["X_workspace_mm"] for r in random)


def _about(axis_angle, t):
    return make_transform(so3_exp(np.asarray(axis_angle, dtype=float)), t)


def test_adds_the_pose_that_rotates_about_another_axis(rng):
    """Recorded views all turn about the optical axis (X undetermined); the planner takes the one tilted view."""
    p = make_problem(3, "eye_to_hand", rng)
    base = _about([0.3, -0.2, 0.0], [0.02, -0.01, 0.6])
    recorded = np.array([base @ _about([0, 0, a], [0, 0, 0]) for a in np.radians([-50, -20, 10, 40])])
    same_axis = [base @ _about([0, 0, a], [0, 0, 0]) for a in np.radians([-60, -35, 25, 55, 70])]
    other_axis = [base @ _about([np.radians(30), 0, 0], [0, 0, 0])]
    candidates = np.array(same_axis + other_axis)
    A_rec = flange_poses(recorded, p.X_true, p.Y_true, "eye_to_hand")
    A_cand = flange_poses(candidates, p.X_true, p.Y_true, "eye_to_hand")
    plan = plan_poses(A_rec, A_cand, p.X_true, p.Y_true, NOISE, n=1, options=ALL_N)
    assert not np.isfinite(plan.sigma_workspace_mm[0])  # one axis: X is not determined
    assert plan.chosen.tolist() == [len(same_axis)]
    assert np.isfinite(plan.sigma_workspace_mm[1])


def test_no_poses_yet_starts_with_rotations_about_distinct_axes(rng):
    """From nothing, three planned poses determine X: their two motions turn about axes far apart."""
    p, A = _cell(rng)
    plan = plan_poses(NONE, A, p.X_true, p.Y_true, NOISE, n=3, options=ALL_N)
    assert np.isfinite(plan.sigma_workspace_mm[3]) and not np.isfinite(plan.sigma_workspace_mm[2])
    T = A[plan.chosen]
    axes = so3_log(np.linalg.inv(T[0])[None, :3, :3] @ T[1:, :3, :3])
    cos = abs(axes[0] @ axes[1]) / np.linalg.norm(axes, axis=1).prod()
    assert np.degrees(np.arccos(cos)) > 20.0
    assert np.all(np.degrees(np.linalg.norm(axes, axis=1)) > 20.0)


@pytest.mark.parametrize("setup", ["eye_to_hand", "eye_in_hand"])
def test_planned_poses_keep_the_target_in_view(rng, setup):
    """Through the X and Y planned with, every planned flange pose shows the target within the limits."""
    from handeye.planning import plan_next_poses, sample_candidates, unknowns_for_plan

    limits = ViewLimits(0.5, 0.9, 18.0, 12.0, 35.0)
    unknowns = unknowns_for_plan(
        setup,
        NONE,
        NONE,
        camera_guess=(1.1, 0.4, 0.9) if setup == "eye_to_hand" else None,
        target_guess=(0.45, 0.1, 0.0) if setup == "eye_in_hand" else None,
    )
    cands = sample_candidates(setup, unknowns, rng, 400, limits)
    assert target_in_view(cands.T_cam_target, limits).all()
    planned = plan_next_poses(setup, NONE, NONE, unknowns, cands, n=8, noise=NOISE, min_gain=0.0)
    seen = views_of(planned.T_base_ee, unknowns.X, unknowns.Y, setup)
    assert len(seen) == 8 and target_in_view(seen, limits).all()
    assert np.abs(seen - planned.T_cam_target).max() < EXACT


def test_target_in_view_refuses_each_violation():
    """Too far, outside the field of view, too tilted: each alone fails the test."""
    limits = ViewLimits()
    ok = _about([0, 0, 0], [0.0, 0.0, 0.6])
    bad = [
        _about([0, 0, 0], [0.0, 0.0, 1.2]),
        _about([0, 0, 0], [0.4, 0.0, 0.6]),
        _about([np.radians(50), 0, 0], [0.0, 0.0, 0.6]),
        _about([np.pi, 0, 0], [0.0, 0.0, 0.6]),
    ]
    assert target_in_view(np.array([ok] + bad), limits).tolist() == [True, False, False, False, False]


def test_ur5_joint_targets_reproduce_the_flange_poses():
    """With the UR5, each planned pose comes with joints whose forward kinematics gives it to 1e-9."""
    pytest.importorskip("pinocchio", reason="needs handeye[sim] (pinocchio) for the UR5 model")
    pytest.importorskip("example_robot_data", reason="needs handeye[sim] (example-robot-data) for the UR5 model")
    from handeye.planning import plan_next_poses, sample_candidates, unknowns_for_plan, view_distances
    from handeye.robot.model import load_robot

    robot = load_robot("ur5")
    unknowns = unknowns_for_plan("eye_to_hand", NONE, NONE, camera_guess=(1.1, 0.4, 0.9))
    limits = ViewLimits(*view_distances("eye_to_hand", unknowns, NONE))
    cands = sample_candidates("eye_to_hand", unknowns, np.random.default_rng(0), 300, limits, robot)
    assert len(cands) >= 6
    planned = plan_next_poses("eye_to_hand", NONE, NONE, unknowns, cands, n=6, noise=NOISE, min_gain=0.0)
    assert planned.q.shape == (6, robot.nq)
    assert np.abs(robot.fk(planned.q) - planned.T_base_ee).max() < EXACT
    assert np.all(planned.q >= robot.model.lowerPositionLimit) and np.all(planned.q <= robot.model.upperPositionLimit)


def test_stop_advice_when_more_poses_no_longer_help(rng):
    """After 40 recorded poses one more shrinks sigma by ~1 %: the plan stops at once and says so."""
    p, A = _cell(rng)
    plan = plan_poses(A[:40], A[40:], p.X_true, p.Y_true, NOISE, n=5)
    assert plan.stop_reason == STOP_SMALL_GAIN and len(plan.chosen) == 0
    assert 0 < plan.next_gain < 0.05
    assert "no longer help" in plan.advice


def test_stop_advice_when_the_candidates_run_out(rng):
    """Two candidates for five requested poses: both are planned and the advice says the candidates are exhausted."""
    p, A = _cell(rng)
    plan = plan_poses(A[:4], A[4:6], p.X_true, p.Y_true, NOISE, n=5, options=ALL_N)
    assert plan.stop_reason == STOP_EXHAUSTED and sorted(plan.chosen.tolist()) == [0, 1]
    assert "exhausted" in plan.advice


def test_cli_plan_from_a_guess_writes_robot_poses(tmp_path, capsys):
    """``handeye plan`` with a camera guess: a table, the advice, and a CSV the pose readers take."""
    out = tmp_path / "plan.csv"
    rc = main(
        [
            "plan",
            "--setup",
            "eye-to-hand",
            "--camera-guess",
            "1.1",
            "0.4",
            "0.9",
            "--n",
            "5",
            "--candidates",
            "300",
            "-o",
            str(out),
        ]
    )
    assert rc == 0
    printed = capsys.readouterr().out
    assert "| step | sigma rot deg" in printed and "advice:" in printed
    robot = read_robot_poses(out)
    assert robot.T_base_ee.shape == (5, 4, 4)


def test_cli_plan_after_recorded_poses_says_stop(tmp_path, capsys):
    """Planning after the example file's 15 poses: X from their calibration, and the advice to stop."""
    from pathlib import Path

    data = Path(__file__).resolve().parents[1] / "handeye" / "data" / "example_eye_to_hand.csv"
    rc = main(["plan", str(data), "--setup", "eye-to-hand", "--n", "4", "--candidates", "300", "--min-gain", "10"])
    assert rc == 0
    printed = capsys.readouterr().out
    assert "calibration of the 15 recorded poses" in printed
    assert "no longer help" in printed


def test_cli_plan_needs_a_guess_without_poses(capsys):
    """No poses and no camera guess: a one-line error naming the option."""
    assert main(["plan", "--setup", "eye-to-hand"]) == 2
    assert "--camera-guess" in capsys.readouterr().err
