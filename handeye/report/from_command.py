"""``handeye calibrate ... --report DIR``: the report of the command's calibration, pose file or images."""

from __future__ import annotations

import argparse
import shlex
from pathlib import Path

import numpy as np

__all__ = ["command_line", "report_poses", "report_images"]


def _truth(args: argparse.Namespace) -> dict | None:
    """The true poses of ``--truth`` (frame name -> 4x4, checked), or None without one."""
    if getattr(args, "truth", None) is None:
        return None
    from handeye.core.setups import UNKNOWN_NAMES, normalize_setup
    from handeye.truthfile import read_truth

    return read_truth(args.truth, UNKNOWN_NAMES[normalize_setup(args.setup)])


def command_line(args: argparse.Namespace, command: str = "calibrate") -> str:
    """The command as it could be typed again, from its parsed arguments.

    Parameters
    ----------
    args : argparse.Namespace
        Parsed by :func:`handeye.cli.build_parser`; ``args.command_parser`` is the sub-command's parser (its
        ``set_defaults``), whose options and defaults are read back.
    command : str
        The sub-command that parsed them.

    Returns
    -------
    str
        ``handeye calibrate POSES --setup ... --report DIR``: the positionals, then every option whose
        value differs from its default, under its long name.
    """
    words = ["handeye", command]
    for action in args.command_parser._actions:
        value = getattr(args, action.dest, None)
        if isinstance(action, argparse._HelpAction) or value is None:
            continue
        if not action.option_strings:
            words += list(map(str, value)) if isinstance(value, (list, tuple)) else [str(value)]
            continue
        if value == action.default:
            continue
        flag = max(action.option_strings, key=len)
        if isinstance(action, (argparse._StoreTrueAction, argparse._StoreFalseAction)):
            words.append(flag)
        elif isinstance(value, (list, tuple)):
            words += [flag, *map(str, value)]
        else:
            words += [flag, str(value)]
    return " ".join(shlex.quote(w) for w in words)


def report_poses(
    args: argparse.Namespace, T_base_ee: np.ndarray, T_cam_target: np.ndarray, result, noise, warnings: list[str]
) -> Path:
    """Write the report of a calibration from a pose file.

    Parameters
    ----------
    args : argparse.Namespace
        The ``calibrate`` command's arguments (``args.report`` is the folder).
    T_base_ee, T_cam_target : array, shape (N, 4, 4)
    result : classic.CalibrationResult
    noise : classic.NoiseModel or None
        The noise model the calibration was given.
    warnings : list of str

    Returns
    -------
    Path
        The page.
    """
    import classic
    from handeye.core.setups import normalize_setup
    from handeye.report.build import ReportData, write_report

    setup = normalize_setup(args.setup)
    loss = args.loss or ("cauchy" if args.robust else "linear")

    def fit(keep):
        # the held-out fits run on the inliers already: the robust sampling's loss is kept, not the sampling
        return classic.calibrate(
            T_base_ee[keep],
            T_cam_target[keep],
            setup=setup,
            method=args.method,
            noise=(None if noise is None else noise.subset(keep)),
            options=classic.CalibrateOptions(
                pairs=args.pairs, refine=not args.no_refine, loss=loss, estimate_scale=args.estimate_scale
            ),
        )

    cov = None if noise is None or noise.camera_covariance is None else np.asarray(noise.camera_covariance)
    data = ReportData(
        result,
        T_base_ee,
        T_cam_target,
        setup,
        command_line(args),
        f"pose file {args.poses}"
        if getattr(args, "camera_poses", None) is None
        else f"pose files {args.robot_poses} (robot) and {args.camera_poses} (camera)",
        fit,
        pairs=args.pairs,
        warnings=list(warnings),
        camera_covariance=cov,
        truth=_truth(args),
    )
    return write_report(args.report, data)


def report_images(args: argparse.Namespace, views, T_base_ee: np.ndarray, calibration) -> Path:
    """Write the report of a calibration from board detections.

    Parameters
    ----------
    args : argparse.Namespace
        The ``calibrate`` command's arguments (``args.report`` is the folder).
    views : classic.vision.views.Views
    T_base_ee : array, shape (len(views.views), 4, 4)
        Robot pose of every view, paired.
    calibration : handeye.image_calibration.ImageCalibration

    Returns
    -------
    Path
        The page.
    """
    import classic
    from handeye.core.setups import normalize_setup
    from handeye.image_calibration import pnp_noise_model
    from handeye.report.build import ImagesPart, ReportData, write_report

    setup = normalize_setup(args.setup)
    accepted = [k for k, v in enumerate(views.views) if v.pose.ok]
    T_ee = T_base_ee[accepted]
    T_ct = np.array([views.views[k].pose.T_cam_target for k in accepted]).reshape(-1, 4, 4)
    # the pose-based fit of handeye.image_calibration.calibrate_from_views, refit per fold
    noise = pnp_noise_model(views, accepted, T_ct)
    loss = "cauchy" if (not args.no_reprojection or args.robust) else "linear"

    def fit(keep):
        return classic.calibrate(
            T_ee[keep],
            T_ct[keep],
            setup=setup,
            method=args.method,
            noise=noise.subset(keep),
            options=classic.CalibrateOptions(loss=loss),
        )

    data = ReportData(
        calibration.pose_based,
        T_ee,
        T_ct,
        setup,
        command_line(args),
        f"detections {args.detections} with robot poses {args.robot_poses}",
        fit,
        labels=[Path(views.views[k].image).stem for k in accepted],
        camera_covariance=noise.camera_covariance,
        images=ImagesPart(views, T_base_ee, calibration),
        truth=_truth(args),
    )
    return write_report(args.report, data)
