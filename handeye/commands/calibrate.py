"""``handeye calibrate``: hand-eye calibration from a pose file.

Example
-------
::

    handeye calibrate handeye/data/example_eye_to_hand.csv --setup eye-to-hand \\
        --truth handeye/data/example_eye_to_hand_truth.json -o result.json

reads paired ``T_base_ee`` / ``T_cam_target`` poses (CSV or JSON, format in
:mod:`handeye.core.posefile`), solves, refines, prints a summary and writes the full
result (poses by frame name, per-pose residuals, covariance, diagnostics) as
JSON. From images instead::

    handeye calibrate --detections detections.json --robot-poses robot.csv --setup eye-in-hand

takes the views accepted by ``handeye detect``, solves on their PnP poses,
then refines X and Y on the corners' reprojection error and reports the pixel RMS
per view, flagging outlier views. The intrinsics are refined with them, with the given
ones as a prior of their one-sigma (the file's ``std``, which ``handeye intrinsics``
writes, or a stated default: :data:`classic.vision.camera.DEFAULT_STD_RULE`), so that
the sigma counts their error; ``--refine-intrinsics`` refines them from the corners
alone, ``--fixed-intrinsics`` takes them as exact (the sigma then leaves their error
out). The line ``intrinsics:`` says which.

The pose file may also be an easy_handeye / easy_handeye2 sample list
(``.yaml``, ``.yml``, ``.samples``; :mod:`handeye.core.easy_handeye`), read for
``--setup``, or OpenCV FileStorage YAML pose pairs (``%YAML:1.0``, camodocal's
``TransformPairsInput.yml``; :mod:`handeye.core.opencv_pose_pairs`). Two text
files of 4x4 matrices, robot poses in one and camera poses in the other
(:mod:`handeye.core.matrix_poses`)::

    handeye calibrate --robot-poses robot.txt --camera-poses camera.txt --setup eye-in-hand --units mm

(``--robot-inverse`` / ``--camera-inverse`` where a file holds the inverse poses).
Camera poses in a ROS body frame (``camera_link``, x forward) are refused unless
``--camera-frame ros-body`` converts them (:mod:`handeye.core.camera_frame`).
After a successful calibration the camera pose can be written for ROS (:mod:`handeye.ros_exports`)::

    handeye calibrate my_eob_calib.samples --setup eye-to-hand --frames base_link camera_color_optical_frame \\
        --export-easy-handeye my_eob_calib.calib --export-launch handeye_tf.launch.py --export-urdf camera_joint.urdf

The pose-file refinement is maximum likelihood under a noise model: by default
camera noise only, its scales estimated from the residuals (the translation's across
and along the line of sight apart when the residuals say they differ); with
``--camera-noise DEG MM [MM MM]`` and ``--robot-noise DEG MM`` under both (PnP
poses: give the optical axis its own, larger, millimetres).

Outliers: every pose is tested against a least-squares fit without it, each of its six
residual components against Student's t with that component's spread over the other
poses (Bonferroni over the set: a clean set of any size has a pose named with
probability 0.1 %; the bound is 6-15 sigma at 8 poses, 5-7 at 15, 5 at 40). The
poses beyond it are printed with their index and file row (or image). When leaving
them out moves the answer by more than 2 of its sigmas, the answer is refused (exit
2, the poses named) if one of them is gross (6 times its bound), else the fit without
them is printed; within 2 sigmas it is printed with them, its sigma widened to reach
the fit without them. (The 0.1 % holds for Gaussian noise; on clean PnP poses, whose
grazing views are several times noisier, a pose is named in 7-45 % of sets, none refused.)
``--robust`` instead leaves out exactly the poses beyond the bound and fits the rest.
"""

from __future__ import annotations

import argparse
import json
import re
import sys
import warnings
from pathlib import Path

import numpy as np

from handeye.commands import GLOSSARY_WHERE, command_parser
from handeye.core.safe_write import write_text_atomic
from handeye.noise_args import add_noise_arguments, describe_noise, noise_model_from_args

__all__ = ["add_parser", "run"]


def _most_all_pairs(max_pairs: int) -> int:
    """The most poses whose pairs are all taken under ``max_pairs``."""
    return int((1 + (1 + 8 * max_pairs) ** 0.5) // 2)


def add_parser(sub) -> argparse.ArgumentParser:
    """Register the command."""
    p = command_parser(sub, "calibrate", "hand-eye calibration from a pose file, or from board detections", __doc__)
    _add_input_arguments(p)
    _add_image_arguments(p)
    _add_solver_arguments(p)
    _add_format_arguments(p)
    _add_output_arguments(p)
    p.set_defaults(run=run, command_parser=p)  # the report retypes the command from it
    return p


def _add_input_arguments(p: argparse.ArgumentParser) -> None:
    """The pose file, or the detections and robot poses, or the two matrix files, and how to read them."""
    p.add_argument(
        "poses",
        type=Path,
        nargs="?",
        help="pose file: CSV or JSON of T_base_ee and T_cam_target, or an easy_handeye sample list "
        "(.yaml, .yml, .samples)",
    )
    p.add_argument("--detections", type=Path, help="detections.json from 'handeye detect' (instead of a pose file)")
    p.add_argument(
        "--robot-poses",
        type=Path,
        help="with --detections: CSV/JSON of T_base_ee per image (an 'image' column pairs them by name)",
    )
    p.add_argument(
        "--camera-poses",
        type=Path,
        help="with --robot-poses: a text file of 4x4 matrices T_cam_target (16 numbers a line, or 4 lines "
        "each), paired in order with the robot file's T_base_ee, also 4x4 matrices (handeye.core.matrix_poses)",
    )
    p.add_argument(
        "--robot-inverse",
        action="store_true",
        help="with --camera-poses: the robot file holds T_ee_base (the base in the flange, as Tabb's "
        "robot_cali.txt), not T_base_ee",
    )
    p.add_argument(
        "--camera-inverse",
        action="store_true",
        help="with --camera-poses: the camera file holds T_target_cam, not T_cam_target",
    )
    p.add_argument(
        "--camera-units",
        choices=["m", "mm"],
        help="with --camera-poses: translation units of the camera file, where they differ from --units",
    )
    p.add_argument(
        "--camera-frame",
        choices=["optical", "ros-body"],
        help="frame of the file's camera poses: optical (z forward, OpenCV), or ros-body (camera_link, x "
        "forward), converted to optical; default optical, refused when the targets say ros-body",
    )


def _add_image_arguments(p: argparse.ArgumentParser) -> None:
    """With ``--detections``: the refinement on the corners' reprojection error and the intrinsics in it."""
    p.add_argument(
        "--no-reprojection",
        action="store_true",
        help="with --detections: skip the refinement on corner reprojection error",
    )
    intrinsics = p.add_mutually_exclusive_group()
    intrinsics.add_argument(
        "--refine-intrinsics",
        action="store_true",
        help="with --detections: refine the camera intrinsics from the corners alone, without the prior of "
        "their one-sigma that the refinement otherwise takes (the intrinsics file's std, or a stated default)",
    )
    intrinsics.add_argument(
        "--fixed-intrinsics",
        action="store_true",
        help="with --detections: take the intrinsics as exact; the sigma then leaves their error out (only for "
        "intrinsics known far better than the corners determine them)",
    )


def _add_solver_arguments(p: argparse.ArgumentParser) -> None:
    """The setup, the closed form and its motion pairs, the refinement and its noise model, the outliers."""
    from classic.calibrate import DEFAULT_METHOD, METHODS
    from classic.pairs import MAX_PAIRS

    p.add_argument(
        "--setup",
        required=True,
        choices=["eye-to-hand", "eye-in-hand", "eye_to_hand", "eye_in_hand"],
        help="eye-to-hand: static camera, target on the flange; eye-in-hand: camera on the flange",
    )
    p.add_argument("--method", default=DEFAULT_METHOD, choices=METHODS, help=f"closed form (default {DEFAULT_METHOD})")
    p.add_argument(
        "--pairs",
        default="all",
        choices=["all", "consecutive"],
        help="motion pairs for the AX=XB starts and the motion checks: all (default) takes every pair up to "
        f"{MAX_PAIRS:,} ({_most_all_pairs(MAX_PAIRS)} poses); beyond, each pose is paired with the poses k index "
        f"strides away (mod N), k = {MAX_PAIRS:,} // N: stride 1 and golden-ratio spread strides in [2, N/2], "
        "so the pairs keep the set's rotation diversity and memory stays linear (the result's "
        "diagnostics['pairs'] states them); "
        "consecutive: the N-1 pairs of neighbouring rows",
    )
    p.add_argument(
        "--no-refine", action="store_true", help="skip the refinement (maximum likelihood under the noise model)"
    )
    p.add_argument(
        "--robust",
        action="store_true",
        help="leave out the poses beyond the outlier bound (a clean set loses one with probability 0.1 %%) and fit "
        "the rest; without it such poses are named, and when they move the answer by over 2 sigma it is refused if one "
        "is gross (6 times the bound), else fitted without them",
    )
    p.add_argument(
        "--loss", choices=["linear", "huber", "cauchy"], help="refinement loss (default linear, cauchy if --robust)"
    )
    add_noise_arguments(
        p,
        "with --robot-noise the refinement is maximum likelihood under both (default: "
        "camera-only, estimated from the residuals)",
    )
    p.add_argument(
        "--estimate-scale",
        action="store_true",
        help="also estimate a metric scale of the camera translations (monocular SLAM poses)",
    )


def _add_format_arguments(p: argparse.ArgumentParser) -> None:
    """The pose file's units and quaternion order."""
    p.add_argument(
        "--units",
        choices=["m", "mm"],
        help="translation units of the file, for every pose (default m, or the JSON's 'units'; mm for "
        "poses in KUKA .a .b .c, Fanuc .w .p .r or ABB .q1-.q4 columns)",
    )
    p.add_argument(
        "--quat-order",
        choices=["xyzw", "wxyz"],
        help="order of positional quaternions (JSON lists, CSV .q0-.q3 columns); default xyzw",
    )


def _add_output_arguments(p: argparse.ArgumentParser) -> None:
    """The truth to compare with, the JSON result, the HTML report and the ROS exports."""
    p.add_argument("--truth", type=Path, help="JSON with the true X (and Y) by frame name: prints the error")
    p.add_argument("-o", "--output", type=Path, help="write the result as JSON here ('-' for stdout)")
    p.add_argument(
        "--report",
        type=Path,
        metavar="DIR",
        help="write an HTML report (index.html and its PNGs) into DIR: residuals, frames in 3-D, motion, "
        "a hold-out check, reprojection overlays with --detections (needs matplotlib)",
    )
    from handeye.ros_exports import add_export_arguments

    add_export_arguments(p)


def _truth_lines(path: Path | None, named: tuple) -> list[str]:
    """Error of each named pose against a truth JSON (frame name -> 4x4), when one is given."""
    from handeye.core.metrics import pose_error

    if path is None:
        return []
    from handeye.truthfile import read_truth

    truth = read_truth(path, tuple(name for name, _ in named))  # checked: rotations, metres, strict numbers
    lines = []
    for name, T in named:
        if name in truth:
            rot, trans = pose_error(T, truth[name])
            lines.append(f"  error vs truth {name}: {float(rot):.4f} deg, {float(trans):.3f} mm")
    return lines


def _fmt_pose(name: str, T: np.ndarray) -> str:
    from handeye.core.se3 import pos_quat_xyzw_from_transform

    t, q = pos_quat_xyzw_from_transform(T)
    return (
        f"  {name}: translation [m] = [{t[0]:+.5f}, {t[1]:+.5f}, {t[2]:+.5f}]"
        f"  quaternion xyzw = [{q[0]:+.6f}, {q[1]:+.6f}, {q[2]:+.6f}, {q[3]:+.6f}]"
    )


def run(args: argparse.Namespace) -> int:
    """Run the command; returns the exit status."""
    from handeye.core.errors import HandEyeInputError
    from handeye.ros_exports import check_export_arguments

    check_export_arguments(args)
    _check_outputs(args)
    if args.camera_poses is not None:
        if args.poses is not None or args.detections is not None or args.robot_poses is None:
            raise HandEyeInputError("give --camera-poses with --robot-poses (two matrix files), without a pose file")
        return _run_poses(args)
    if args.robot_inverse or args.camera_inverse or args.camera_units:
        raise HandEyeInputError(
            "--robot-inverse, --camera-inverse and --camera-units go with --robot-poses and --camera-poses"
        )
    if args.detections is not None and args.camera_frame is not None:
        raise HandEyeInputError("--camera-frame is for pose files; detections are in the optical frame already")
    if args.detections is not None or args.robot_poses is not None:
        if args.poses is not None or args.detections is None or args.robot_poses is None:
            raise HandEyeInputError("give either a pose file, or --detections with --robot-poses")
        return _run_detections(args)
    if args.poses is None:
        raise HandEyeInputError("give a pose file, or --detections with --robot-poses")
    return _run_poses(args)


def _check_outputs(args: argparse.Namespace) -> None:
    """Refuse an ``-o`` or ``--report`` target that cannot take the files before calibrating, not after."""
    from handeye.core.safe_write import check_output_folder, check_output_path

    if args.output is not None and str(args.output) != "-":
        check_output_path(args.output)
    if args.report is not None:
        check_output_folder(args.report)
        for name in ("index.html", "report.json"):
            if (args.report / name).exists() or (args.report / name).is_symlink():
                check_output_path(args.report / name)


#: The 1-sigma's meaning, printed once after the first one.
SIGMA_MEANS = "(predicted RMS error of the rotation angle and of the position, all axes together)"
#: The motion line's two figures, printed once under it.
MOTION_MEANS = [
    "    axis diversity: how spread the rotation axes are (0 = one axis, 1 = all directions)",
    "    angle mismatch: robot vs camera rotation angle of the same motions (near the noise when paired right)",
]


def _robot_noise_lines(rep) -> list[str]:
    """The robot pose error the image path estimated from the residuals, and its warning."""
    d = rep.diagnostics.get("robot_noise")
    if d is None:
        return [f"  robot pose error: not modelled ({rep.diagnostics.get('robot_noise_reason')})"]
    lines = [
        f"  robot pose error (estimated from the residuals): {d['robot_rotation_deg']:.4f} deg, "
        f"{d['robot_translation_mm']:.3f} mm per axis; corners {d['corner_sigma_px']:.3f} px per axis "
        "(in the 1-sigma above)"
    ]
    return lines + [f"  warning: {w}" for w in rep.warnings]


def _detections_command(args: argparse.Namespace, setup: str) -> str:
    """The command as run, with the options that change the result or what is printed."""
    flags = [name for name in ("no_reprojection", "refine_intrinsics", "fixed_intrinsics") if getattr(args, name)]
    return " ".join(
        [
            f"handeye calibrate --detections {args.detections} --robot-poses {args.robot_poses}",
            f"--setup {setup.replace('_', '-')}",
            *(f"--{name.replace('_', '-')}" for name in flags),
            *([f"--truth {args.truth}"] if args.truth is not None else []),
        ]
    )


def _intrinsics_line(args: argparse.Namespace, intrinsics, refined: bool) -> str:
    """How the camera's intrinsics enter the result and its 1-sigma."""
    if not refined:
        return "  intrinsics: taken as exact (no reprojection refinement); the 1-sigma leaves their error out"
    if args.fixed_intrinsics:
        return "  intrinsics: taken as exact (--fixed-intrinsics); the 1-sigma leaves their error out"
    if args.refine_intrinsics:
        return "  intrinsics: refined from the corners alone (--refine-intrinsics); their error is in the 1-sigma"
    _, source = intrinsics.std_vector()
    return (
        "  intrinsics: refined with the given ones as a prior of their one-sigma "
        f"({source}); their error is in the 1-sigma"
    )


def _run_detections(args: argparse.Namespace) -> int:
    from classic.vision.reprojection import ReprojectionOptions
    from classic.vision.views import Views
    from handeye.core.posefile import read_robot_poses
    from handeye.core.setups import UNKNOWN_NAMES, normalize_setup
    from handeye.image_calibration import calibrate_from_views, pair_robot_poses
    from handeye.ros_exports import write_exports

    setup = normalize_setup(args.setup)
    views = Views.load(args.detections)
    robot = read_robot_poses(args.robot_poses, quat_order=args.quat_order, units=args.units)
    T_base_ee = pair_robot_poses([v.image for v in views.views], robot.images, robot.T_base_ee, robot.source)
    from classic.vision.robot_noise import RobotPoseErrorWarning

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RobotPoseErrorWarning)  # printed below, with the robot's error
        out = calibrate_from_views(
            views,
            T_base_ee,
            setup,
            method=args.method,
            robust=args.robust,
            reprojection=not args.no_reprojection,
            refinement=ReprojectionOptions(
                refine_intrinsics=args.refine_intrinsics,
                intrinsics_prior=not (args.refine_intrinsics or args.fixed_intrinsics),
            ),
        )
    x_name, y_name = UNKNOWN_NAMES[setup]
    res = out.pose_based
    lines = [
        _detections_command(args, setup),
        f"{len(views.views)} images, {len(views.accepted)} with a pose; method {res.method}",
        "pose-based:",
        _fmt_pose(x_name, res.X),
        f"    1-sigma: {res.sigma['X_rotation_deg']:.4f} deg, {res.sigma['X_translation_mm']:.3f} mm {SIGMA_MEANS}",
    ]
    for image, reason in out.rejected.items():
        lines.append(f"  rejected {image}: {reason}")
    lines += _suspect_lines(res.diagnostics, list(out.images))  # the pose-based fit's outliers, by image
    rep = out.reprojection
    if rep is not None:
        lines += [
            "refined on corner reprojection error:",
            _fmt_pose(x_name, rep.X),
            f"    1-sigma: {rep.sigma['X_rotation_deg']:.4f} deg, {rep.sigma['X_translation_mm']:.3f} mm (the "
            "result's; each fit's sigma is scaled by its own residuals, poses above, corners here, so the two "
            "may differ either way)",
            _fmt_pose(y_name, rep.Y),
            f"  pixel RMS {rep.rms_px:.3f} px; per view:",
        ]
        for k, (image, rms) in enumerate(zip(out.images, rep.per_view_rms_px)):
            flag = "  <- outlier" if k in rep.outlier_views else ""
            lines.append(f"    {image}: {rms:.3f} px{flag}")
        lines += _robot_noise_lines(rep)
    lines.append(_intrinsics_line(args, views.intrinsics, rep is not None))
    lines += _truth_lines(args.truth, ((x_name, out.X), (y_name, out.Y)))
    lines.append(f"  terms: {GLOSSARY_WHERE}")
    lines += write_exports(args, setup, out.X)
    print("\n".join(lines))
    if args.output is not None:
        doc = res.to_dict()
        doc["images"] = out.images
        doc["rejected"] = out.rejected
        if rep is not None:
            doc["reprojection"] = {
                x_name: rep.X.tolist(),
                y_name: rep.Y.tolist(),
                "rms_px": rep.rms_px,
                "per_view_rms_px": dict(zip(out.images, map(float, rep.per_view_rms_px))),
                "outlier_views": [out.images[k] for k in rep.outlier_views],
                "sigma": rep.sigma,
                "intrinsics": rep.intrinsics.to_dict(),
                "robot_noise": rep.diagnostics.get("robot_noise"),
                "warnings": rep.warnings,
            }
        text = json.dumps(doc, indent=2)
        if str(args.output) == "-":
            print(text)
        else:
            write_text_atomic(args.output, text + "\n")
            print(f"  written: {args.output}")
    if args.report is not None:
        from handeye.report.from_command import report_images

        print(f"  report: {report_images(args, views, T_base_ee, out)}")
    return 0


def _pose_names(poses) -> list[str]:
    """How the output names each pose of a file: its row, and its image where the file has an image column."""
    rows = list(getattr(poses, "rows", None) or [])
    images = list(getattr(poses, "images", None) or [])
    names = []
    for k in range(len(poses.T_base_ee)):
        where = [f"row {rows[k]}"] if k < len(rows) else []
        where += [str(images[k])] if k < len(images) and images[k] else []
        names.append(", ".join(where))
    return names


def _suspect_lines(diagnostics: dict, names: list[str]) -> list[str]:
    """One line per pose beyond the outlier bound (``diagnostics["suspect_poses"]``), with its file row or image."""
    suspects = diagnostics.get("suspect_poses") or []
    if not suspects:
        return []
    test = diagnostics["outlier_test"]
    if diagnostics.get("outliers"):
        what = "left out of the fit"
    else:
        what = (
            f"leaving them out moves the answer by {test['shift_sigma']:.1f} sigma (at most 2): returned with them, "
            f"its sigma widened up to {test.get('sigma_widened_by', 1.0):.2f}x"
            if "shift_sigma" in test
            else "named only"
        )
    lines = [f"  poses beyond the outlier bound (alpha {test['alpha']:g} for the set; {what}):"]
    for d in suspects:
        k = d["index"]
        where = f" ({names[k]})" if k < len(names) and names[k] else ""
        lines.append(
            f"    pose {k}{where}: {d['block']} off, residual {d['translation_mm']:.2f} mm, "
            f"{d['rotation_deg']:.3f} deg; {max(d['n_sigma_rotation'], d['n_sigma_translation']):.1f} sigma "
            f"(bound {d['bound_n_sigma']:.1f})"
        )
    return lines


class _rows_of_named_poses:
    """Adds the file rows (or images) of the poses a :class:`ContaminatedPosesError` names to its message."""

    def __init__(self, poses):
        self.names = _pose_names(poses)

    def __enter__(self):
        return self

    def __exit__(self, kind, error, tb):
        from handeye.core.errors import ContaminatedPosesError

        if isinstance(error, ContaminatedPosesError) and getattr(error, "poses", None):
            text = str(error)
            for k in error.poses:
                if k < len(self.names) and self.names[k]:
                    text = re.sub(rf"\bpose {k}:", f"pose {k} ({self.names[k]}):", text, count=1)
            if text != str(error):
                raise ContaminatedPosesError(text) from error
        return False


def _run_poses(args: argparse.Namespace) -> int:
    from handeye.core.setups import normalize_setup

    setup = normalize_setup(args.setup)
    poses, source = _read_poses(args, setup)
    res, caught = _calibrate_poses(args, poses, setup)
    out = sys.stderr if args.output is not None and str(args.output) == "-" else sys.stdout
    print("\n".join(_poses_lines(args, source, setup, poses, res, caught)), file=out)
    _write_poses_outputs(args, poses, res, caught, out)
    return 0


def _read_poses(args: argparse.Namespace, setup: str):
    """The pose pairs (the two matrix files', or the pose file's) and how the command line names them."""
    from handeye.checked_poses import load_poses

    if args.camera_poses is not None:
        from handeye.core.matrix_poses import read_matrix_pose_pairs

        poses = read_matrix_pose_pairs(
            args.robot_poses,
            args.camera_poses,
            units=args.units,
            invert_robot=args.robot_inverse,
            invert_camera=args.camera_inverse,
            camera_frame=args.camera_frame,
            camera_units=args.camera_units,
        )
        return poses, f"--robot-poses {args.robot_poses} --camera-poses {args.camera_poses}"
    poses = load_poses(args.poses, setup, quat_order=args.quat_order, units=args.units, camera_frame=args.camera_frame)
    return poses, str(args.poses)


def _calibrate_poses(args: argparse.Namespace, poses, setup: str):
    """:func:`classic.calibrate` on the poses as the options say, and the warnings it gave (a list)."""
    import classic

    with warnings.catch_warnings(record=True) as caught, _rows_of_named_poses(poses):
        warnings.simplefilter("always")
        res = classic.calibrate(
            poses.T_base_ee,
            poses.T_cam_target,
            setup=setup,
            method=args.method,
            robust=args.robust,
            noise=noise_model_from_args(args),
            options=classic.CalibrateOptions(
                pairs=args.pairs, refine=not args.no_refine, loss=args.loss, estimate_scale=args.estimate_scale
            ),
        )
    return res, caught


def _poses_lines(args: argparse.Namespace, source: str, setup: str, poses, res, caught: list) -> list[str]:
    """The printed summary: the command, the answer and its sigma, the fit's diagnostics, truth and exports."""
    from handeye.core.setups import UNKNOWN_NAMES
    from handeye.ros_exports import write_exports

    x_name, y_name = UNKNOWN_NAMES[setup]
    sig = res.sigma
    lines = [
        f"handeye calibrate {source} --setup {setup.replace('_', '-')} --method {args.method}",
        f"{len(poses.T_base_ee)} poses, method {res.method}",
        _fmt_pose(x_name, res.X),
        f"    1-sigma: {sig['X_rotation_deg']:.4f} deg, {sig['X_translation_mm']:.3f} mm {SIGMA_MEANS}",
        _fmt_pose(y_name, res.Y),
        f"    1-sigma: {sig['Y_rotation_deg']:.4f} deg, {sig['Y_translation_mm']:.3f} mm",
        f"  residual RMS per pose: {res.residuals.rms_rotation_deg:.4f} deg, {res.residuals.rms_translation_mm:.3f} mm "
        "(measured camera pose vs the one the result predicts)",
    ]
    if res.diagnostics.get("outliers"):
        lines.append(f"  outlier poses (excluded): {res.diagnostics['outliers']}")
    lines += _suspect_lines(res.diagnostics, _pose_names(poses))
    lines += _fit_diagnostics_lines(res.diagnostics)
    for w in caught:
        if w.category.__name__ != "SuspectPosesWarning":  # the lines above name those poses
            lines.append(f"  warning: {w.message}")
    lines += _truth_lines(args.truth, ((x_name, res.X), (y_name, res.Y)))
    lines.append(f"  terms: {GLOSSARY_WHERE}")
    return lines + write_exports(args, setup, res.X, poses.frames)


def _fit_diagnostics_lines(diagnostics: dict) -> list[str]:
    """The noise model and how the residuals fit it, the scale, the motion and its pairs."""
    lines = [f"  noise model: {describe_noise(diagnostics['noise_model'])}"]
    if not diagnostics["noise_model"].get("estimated"):
        vf = diagnostics["refinement"]["variance_factor"]
        lines.append(
            f"    residuals / model: variance factor {vf:.2f} (1 when the stated noise fits the data; the "
            "sigmas above assume the stated noise)"
        )
    if "scale" in diagnostics:
        sc = diagnostics["scale"]
        lines.append(f"  camera translation scale: {sc['value']:.6f} +- {sc['sigma']:.6f}")
    motion = diagnostics["motion"]
    lines.append(
        f"  motion: max rotation {motion['max_rotation_deg']:.1f} deg, axis diversity "
        f"{motion['axis_diversity']:.2f}, angle mismatch {motion['angle_mismatch_deg']:.3f} deg"
    )
    lines += MOTION_MEANS
    pairs = diagnostics.get("pairs", {})
    if pairs.get("rule") == "bounded":
        lines.append(
            f"  motion pairs: {pairs['n_pairs']:,} of {pairs['all_pairs']:,} (bounded: each pose with the poses "
            f"{len(pairs['strides'])} index strides away; --pairs help)"
        )
    return lines


def _write_poses_outputs(args: argparse.Namespace, poses, res, caught: list, out) -> None:
    """``-o``'s JSON (stdout for ``-``) and ``--report``'s page; what was written said on ``out``."""
    if args.output is not None:
        text = json.dumps(res.to_dict(), indent=2)
        if str(args.output) == "-":
            print(text)
        else:
            write_text_atomic(args.output, text + "\n")
            print(f"  written: {args.output}", file=out)
    if args.report is not None:
        from handeye.report.from_command import report_poses

        page = report_poses(
            args,
            poses.T_base_ee,
            poses.T_cam_target,
            res,
            noise_model_from_args(args),
            [str(w.message) for w in caught],
        )
        print(f"  report: {page}", file=out)
