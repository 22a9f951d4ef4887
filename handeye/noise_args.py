"""The command line's noise model: ``--camera-noise`` and ``--robot-noise``, for ``calibrate`` and ``plan``."""

from __future__ import annotations

import argparse

from handeye.core.numbers import cli_float

__all__ = ["add_noise_arguments", "noise_model_from_args", "describe_noise"]


def add_noise_arguments(p: argparse.ArgumentParser, default_help: str) -> None:
    """Register ``--camera-noise DEG MM [MM MM]`` and ``--robot-noise DEG MM`` on a command's parser.

    Parameters
    ----------
    p : argparse.ArgumentParser
    default_help : str
        What the command assumes when neither is given.
    """
    p.add_argument(
        "--camera-noise",
        nargs="+",
        type=cli_float,
        metavar="V",
        help="camera pose noise per axis: DEG MM, or DEG MM_X MM_Y MM_Z (PnP: worse along the optical "
        f"axis, z); {default_help}",
    )
    p.add_argument(
        "--robot-noise",
        nargs=2,
        type=cli_float,
        metavar=("DEG", "MM"),
        help="robot flange pose noise per axis (the arm's repeatability)",
    )


def noise_model_from_args(args: argparse.Namespace):
    """The :class:`classic.noise_model.NoiseModel` of ``--camera-noise`` / ``--robot-noise``, or None.

    Raises
    ------
    HandEyeInputError
        ``--robot-noise`` without ``--camera-noise``, or a wrong count of camera numbers.
    """
    import numpy as np

    import classic
    from handeye.core.errors import HandEyeInputError

    if args.camera_noise is None and args.robot_noise is None:
        return None
    if args.camera_noise is None:
        raise HandEyeInputError("--robot-noise needs --camera-noise too (the camera's noise is never zero)")
    cam = args.camera_noise
    if len(cam) not in (2, 4):
        raise HandEyeInputError(f"--camera-noise takes DEG MM or DEG MM_X MM_Y MM_Z, got {len(cam)} numbers")
    trans = np.array(cam[1:]) / 1000.0
    robot = args.robot_noise or (0.0, 0.0)
    return classic.NoiseModel(
        np.radians(cam[0]),
        trans if len(trans) == 3 else float(trans[0]),
        np.radians(robot[0]),
        robot[1] / 1000.0,
        name="given on the command line",
    )


def describe_noise(d: dict) -> str:
    """One line for a result's ``diagnostics["noise_model"]``."""
    if d.get("estimated"):
        across, _, along = d["camera_translation_mm"]
        trans = (
            f"{across:.3f} mm per axis"
            if across == along
            else f"{across:.3f} mm across and {along:.3f} mm along the line of sight"
        )
        return f"camera only, estimated from the residuals ({d['camera_rotation_deg'][0]:.4f} deg, {trans})"
    parts = [d["name"]]
    for side in ("camera", "robot"):
        if f"{side}_rotation_deg" in d:
            deg, mm = (", ".join(f"{v:.4g}" for v in d[f"{side}_{k}"]) for k in ("rotation_deg", "translation_mm"))
            parts.append(f"{side} {deg} deg / {mm} mm")
    return "; ".join(parts)
