"""``handeye plan``: where to move next, the robot poses that shrink the predicted sigma of X most.

Example
-------
::

    handeye plan --setup eye-to-hand --robot ur5 --camera-guess 1.1 0.4 0.9 --n 8 -o plan.csv
    handeye plan recorded.csv --setup eye-to-hand --robot ur5 --n 4 -o next.csv

takes the poses recorded so far (a pose file as for ``handeye calibrate``, or none), the X and Y to plan
with (a calibration of the recorded poses, or the guesses: ``--camera-guess`` eye-to-hand, the camera's
position in the base frame, looking at ``--look-at``; ``--target-guess`` eye-in-hand, the board's centre
in the base frame, lying face up), samples views with the target in the camera's field of view and turns
them into flange poses, keeps with ``--robot ur5|ur3`` those the inverse kinematics reaches, and plans
greedily (:mod:`classic.planning`): each step adds the pose that shrinks the predicted workspace sigma of
X (the RMS error of X at the target positions, mm) most. Prints per step the predicted sigma of X
(rotation deg, translation mm, workspace mm), the pose and the joints, and says when more poses will no
longer help (one more shrinks the sigma by less than ``--min-gain`` percent). ``-o`` writes the plan as
CSV: ``T_base_ee`` columns (readable by ``--robot-poses`` and the pose readers), the joints in radians,
the expected view ``expected_T_cam_target`` and the predicted sigmas.

The prediction assumes the noise of ``--camera-noise`` / ``--robot-noise`` (default camera 0.1 deg / 1 mm,
robot 0.01 deg / 0.2 mm per axis): the sigmas scale with it, the choice of poses barely does.
"""

from __future__ import annotations

import argparse
import shlex
from pathlib import Path

import numpy as np

from handeye.commands import command_parser
from handeye.core.numbers import cli_float, cli_int
from handeye.core.safe_write import write_text_atomic
from handeye.noise_args import add_noise_arguments

__all__ = ["add_parser", "run"]

#: The three-number arguments, points in metres: the flag and its help.
_POINT_ARGUMENTS = (
    (
        "--camera-guess",
        "eye-to-hand: the camera's position in the base frame (m); eye-in-hand: in the flange frame "
        "(default 0 0.08 0.04, looking along the flange's z)",
    ),
    (
        "--look-at",
        "eye-to-hand: the point the camera guess looks at (default 0.35 m from the base towards the camera, 0.3 m up)",
    ),
    (
        "--target-guess",
        "eye-in-hand: the board's centre in the base frame, face up (m); eye-to-hand: in the flange "
        "frame (default 0 0 0.01, facing out)",
    ),
)


def add_parser(sub) -> argparse.ArgumentParser:
    """Register the command."""
    p = command_parser(sub, "plan", "the next robot poses that shrink the predicted sigma of X most", __doc__)
    p.add_argument("poses", type=Path, nargs="?", help="pose file of the poses recorded so far (CSV or JSON)")
    p.add_argument(
        "--setup",
        required=True,
        choices=["eye-to-hand", "eye-in-hand", "eye_to_hand", "eye_in_hand"],
        help="eye-to-hand: static camera, target on the flange; eye-in-hand: camera on the flange",
    )
    p.add_argument(
        "--robot",
        default="none",
        choices=["none", "ur5", "ur3"],
        help="robot model for reachability and joint targets (needs handeye[robot]); none: any flange pose",
    )
    for flag, text in _POINT_ARGUMENTS:
        p.add_argument(flag, nargs=3, type=cli_float, metavar=("X", "Y", "Z"), help=text)
    p.add_argument("--n", type=cli_int, default=8, help="most poses to plan (default 8)")
    p.add_argument(
        "--min-gain",
        type=cli_float,
        default=5.0,
        metavar="PERCENT",
        help="stop when one more pose shrinks the predicted sigma by less than this (default 5)",
    )
    p.add_argument("--candidates", type=cli_int, default=1500, help="views sampled in the field of view (default 1500)")
    p.add_argument(
        "--distance",
        nargs=2,
        type=cli_float,
        metavar=("MIN", "MAX"),
        help="depth range of the views (m; default: the recorded views' +-0.1 m, or around the look-at "
        "point, or 0.3-0.6 eye-in-hand)",
    )
    p.add_argument(
        "--fov",
        nargs=2,
        type=cli_float,
        metavar=("HX", "HY"),
        default=(20.0, 15.0),
        help="half-angles (deg) within which the target's centre stays (default 20 15)",
    )
    p.add_argument("--max-tilt", type=cli_float, default=40.0, help="largest tilt from facing the camera, deg (40)")
    p.add_argument(
        "--guess-margin",
        type=cli_float,
        default=5.0,
        metavar="DEG",
        help="planning from a guess: keep the views this far inside the field of view and the tilt limit (default 5)",
    )
    add_noise_arguments(p, "the noise the prediction assumes (default camera 0.1 deg / 1 mm, robot 0.01 deg / 0.2 mm)")
    p.add_argument("--units", choices=["m", "mm"], help="translation units of the pose file (default m)")
    p.add_argument("--quat-order", choices=["xyzw", "wxyz"], help="order of positional quaternions (default xyzw)")
    p.add_argument("--seed", type=cli_int, default=0, help="seed of the sampled views (default 0)")
    p.add_argument("-o", "--output", type=Path, help="write the plan as CSV here")
    p.set_defaults(run=run)
    return p


def _recorded(args, setup: str):
    """The recorded poses (N, 4, 4) twice, N may be 0; the quaternion-order check when there are enough."""
    from handeye.checked_poses import load_poses
    from handeye.core.posefile import read_pose_file

    if args.poses is None:
        return np.zeros((0, 4, 4)), np.zeros((0, 4, 4))
    poses = read_pose_file(args.poses, quat_order=args.quat_order, units=args.units)
    if len(poses.T_base_ee) >= 3:
        poses = load_poses(args.poses, setup, quat_order=args.quat_order, units=args.units)
    return poses.T_base_ee, poses.T_cam_target


def _noise(args):
    from handeye.noise_args import noise_model_from_args
    from handeye.planning import DEFAULT_NOISE

    if args.camera_noise is None and args.robot_noise is None:
        return DEFAULT_NOISE
    return noise_model_from_args(args)


def _fmt(value: float, digits: int) -> str:
    return "-" if not np.isfinite(value) else f"{value:.{digits}f}"


def _table(planned) -> list[str]:
    from handeye.core.se3 import pos_quat_xyzw_from_transform

    plan = planned.plan
    joints = planned.q is not None
    head = "| step | sigma rot deg | sigma trans mm | workspace mm | gain % | T_base_ee x, y, z [m] | quaternion xyzw |"
    lines = [head + (" joints [deg] |" if joints else ""), "|---" * (7 + joints) + "|"]
    lines.append(
        f"| 0 ({planned.n_recorded} recorded) | {_fmt(plan.sigma_rotation_deg[0], 4)} | "
        f"{_fmt(plan.sigma_translation_mm[0], 3)} | {_fmt(plan.sigma_workspace_mm[0], 3)} | | | |"
        + (" |" if joints else "")
    )
    t, q = pos_quat_xyzw_from_transform(planned.T_base_ee.reshape(-1, 4, 4))
    # a gain means something once X is determined; before, it is the weak prior's (classic.planning)
    gain = np.where(np.isfinite(plan.sigma_workspace_mm[:-1]), plan.gain, np.nan)
    for k in range(len(plan.chosen)):
        row = (
            f"| {k + 1} | {_fmt(plan.sigma_rotation_deg[k + 1], 4)} | {_fmt(plan.sigma_translation_mm[k + 1], 3)} | "
            f"{_fmt(plan.sigma_workspace_mm[k + 1], 3)} | {_fmt(100 * gain[k], 1)} | "
            f"{t[k, 0]:+.4f}, {t[k, 1]:+.4f}, {t[k, 2]:+.4f} | "
            f"{q[k, 0]:+.4f}, {q[k, 1]:+.4f}, {q[k, 2]:+.4f}, {q[k, 3]:+.4f} |"
        )
        if joints:
            row += " " + ", ".join(f"{v:+.1f}" for v in np.degrees(planned.q[k])) + " |"
        lines.append(row)
    return lines


def _write_csv(path: Path, planned, command: str) -> None:
    """The plan: step, T_base_ee, joints (rad), the expected view, the predicted sigmas after the step."""
    from handeye.core.se3 import pos_quat_xyzw_from_transform

    plan = planned.plan
    header = ["step"] + [f"T_base_ee.{c}" for c in ("x", "y", "z", "qx", "qy", "qz", "qw")]
    nq = 0 if planned.q is None else planned.q.shape[1]
    header += [f"q{j}" for j in range(nq)]
    header += [f"expected_T_cam_target.{c}" for c in ("x", "y", "z", "qx", "qy", "qz", "qw")]
    header += ["sigma_rotation_deg", "sigma_translation_mm", "sigma_workspace_mm", "gain"]
    t1, q1 = pos_quat_xyzw_from_transform(planned.T_base_ee.reshape(-1, 4, 4))
    t2, q2 = pos_quat_xyzw_from_transform(planned.T_cam_target.reshape(-1, 4, 4))
    gain = np.where(np.isfinite(plan.sigma_workspace_mm[:-1]), plan.gain, np.nan)  # the prior's while undetermined
    lines = [
        f"# {command}",
        "# T_base_ee: flange in robot base (m, quaternion xyzw); q: joint targets (rad); "
        "expected_T_cam_target: the view predicted through the X and Y planned with",
        f"# {plan.advice}",
        ",".join(header),
    ]
    for k in range(len(plan.chosen)):
        values = [
            *t1[k],
            *q1[k],
            *([] if planned.q is None else planned.q[k]),
            *t2[k],
            *q2[k],
            plan.sigma_rotation_deg[k + 1],
            plan.sigma_translation_mm[k + 1],
            plan.sigma_workspace_mm[k + 1],
            gain[k],
        ]
        lines.append(",".join([str(k + 1)] + [f"{v:.12g}" for v in values]))
    # a file name that is not UTF-8 lands in the comment escaped, not as a crash after the file was opened
    write_text_atomic(path, "\n".join(lines) + "\n", errors="backslashreplace")


def run(args: argparse.Namespace) -> int:
    """Run the command; returns the exit status."""
    from classic.target_views import ViewLimits
    from handeye.core.errors import HandEyeInputError
    from handeye.core.safe_write import check_output_path
    from handeye.core.setups import normalize_setup
    from handeye.planning import limits_for, plan_next_poses, sample_candidates, unknowns_for_plan, view_distances

    if args.output is not None:
        check_output_path(args.output)  # refused before the planning, not after it
    setup = normalize_setup(args.setup)
    if args.n < 1:
        raise HandEyeInputError(f"--n must be at least 1, got {args.n}")
    if args.candidates < 1:
        raise HandEyeInputError(f"--candidates must be at least 1, got {args.candidates}")
    T_base_ee, T_cam_target = _recorded(args, setup)
    try:
        unknowns = unknowns_for_plan(setup, T_base_ee, T_cam_target, args.camera_guess, args.target_guess, args.look_at)
    except HandEyeInputError as exc:
        if args.poses is None:
            raise
        raise type(exc)(f"{args.poses}: {exc}") from None
    d_min, d_max = args.distance or view_distances(setup, unknowns, T_cam_target)
    limits = limits_for(ViewLimits(d_min, d_max, args.fov[0], args.fov[1], args.max_tilt), unknowns, args.guess_margin)
    robot = None
    if args.robot != "none":
        from handeye.robot.model import load_robot

        robot = load_robot(args.robot)
    candidates = sample_candidates(setup, unknowns, np.random.default_rng(args.seed), args.candidates, limits, robot)
    noise = _noise(args)
    planned = plan_next_poses(
        setup, T_base_ee, T_cam_target, unknowns, candidates, n=args.n, noise=noise, min_gain=args.min_gain / 100.0
    )
    reach = (
        f"{len(candidates)} reachable by the {args.robot} (inverse kinematics, within joint limits, above the floor)"
        if robot is not None
        else "no robot model: reachability not checked"
    )
    command = "handeye plan " + " ".join(shlex.quote(a) for a in _argv(args))
    lines = [
        command,
        f"X and Y from: {unknowns.source}",
        f"noise assumed: {noise.name}",
        f"candidates: {candidates.n_sampled} views {d_min:.2f}-{d_max:.2f} m in front of the camera, within "
        f"{limits.half_fov_x_deg:g} x {limits.half_fov_y_deg:g} deg of its axis, tilted <= "
        f"{limits.max_tilt_deg:g} deg{' (less the guess margin)' if unknowns.guessed else ''}; {reach}",
        "predicted 1-sigma of X after each pose (workspace: RMS error of X at the target positions):",
        "",
    ]
    lines += _table(planned)
    lines += ["", f"advice: {planned.plan.advice}"]
    print("\n".join(lines))
    if args.output is not None:
        _write_csv(args.output, planned, command)
        print(f"  written: {args.output}")
    return 0


def _argv(args: argparse.Namespace) -> list[str]:
    """The command line that reproduces this plan (options as given or defaulted)."""
    out = [] if args.poses is None else [str(args.poses)]
    out += ["--setup", args.setup.replace("_", "-"), "--robot", args.robot, "--n", str(args.n)]
    for flag, value in (
        ("--camera-guess", args.camera_guess),
        ("--look-at", args.look_at),
        ("--target-guess", args.target_guess),
        ("--distance", args.distance),
        ("--camera-noise", args.camera_noise),
        ("--robot-noise", args.robot_noise),
    ):
        if value is not None:
            out += [flag] + [f"{v:g}" for v in value]
    if args.seed:
        out += ["--seed", str(args.seed)]
    return out
