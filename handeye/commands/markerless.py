"""``handeye markerless``: the camera pose of each placement from the robot's own surface in depth, no board.

Example
-------
::

    handeye markerless data/paper-sim --camera 14 15 -o markerless.json
    handeye markerless data/paper-sim --model runs/sim/reservoir -o markerless.json
    handeye markerless data/my-cell --start guess.json --urdf my_robot.urdf --package-dir ~/ws/src

Per camera placement of the dataset: the robot's surface posed at every data
frame's joints is registered to the depth of all frames at once (coarse to
fine, robust point-to-plane). Starts: the learned networks' prediction
(``--model``), a start of yours (``--start``: JSON with ``T_base_cam`` as a 4x4
matrix, or ``translation_m`` and ``quaternion_xyzw``), and always one found from
the moving pixels alone. Prints per camera the result, its sigma, and the
error against the truth and the classic label's where the dataset has them; a
placement where the registration cannot answer is reported as refused, with
the reason, and counts in the exit status (1 when any was refused).
"""

from __future__ import annotations

import argparse
from dataclasses import replace
from pathlib import Path

from handeye.commands import GLOSSARY_WHERE, command_parser
from handeye.core.numbers import cli_float, cli_int, parse_float
from handeye.robot.depth_sensors import FACTORY_ROLL_BOUND_DEG

__all__ = ["add_parser", "run"]


def add_parser(sub) -> argparse.ArgumentParser:
    """Register the command."""
    p = command_parser(sub, "markerless", "camera pose from the robot's surface in depth (no board)", __doc__)
    _add_input_arguments(p)
    _add_depth_arguments(p)
    _add_estimated_arguments(p)
    _add_output_arguments(p)
    p.set_defaults(run=run)
    return p


def _add_input_arguments(p: argparse.ArgumentParser) -> None:
    """The dataset and its placements, the start, the robot's model."""
    p.add_argument("dataset", type=Path, help="dataset directory")
    p.add_argument("--camera", type=cli_int, nargs="+", help="camera placements (default all)")
    start = p.add_mutually_exclusive_group()
    start.add_argument("--model", type=Path, help="learned model directory (translation.pt, orientation.pt)")
    start.add_argument("--start", type=Path, help="JSON start T_base_cam (a rough guess)")
    p.add_argument("--urdf", type=Path, help="robot URDF with visual meshes (default: the dataset's UR)")
    p.add_argument(
        "--package-dir", type=Path, action="append", default=[], help="folder for package:// mesh paths (repeatable)"
    )


def _add_depth_arguments(p: argparse.ArgumentParser) -> None:
    """The depth's noise and unit, the sensor and its depth-to-colour registration and matcher."""
    p.add_argument(
        "--depth-noise",
        type=cli_float,
        default=None,
        help="depth sigma at 1 m, metres, growing with depth squared (default: measured on the static background)",
    )
    p.add_argument(
        "--depth-model",
        choices=("scale-offset", "fixed"),
        default="scale-offset",
        help="estimate the sensor's depth scale and offset with the pose (default), or take the depth as exact",
    )
    p.add_argument(
        "--sensor",
        default=None,
        help="the depth camera's profile (d435, d455, l515, azure-kinect, zivid): its depth-to-colour extrinsic "
        "uncertainty enters the sigma, and a stereo camera's matcher bias is modelled with its f B (default: the "
        "dataset's simulated sensor; a real recording without it: the d435-real-cell profile's registration "
        "uncertainty, without a matcher model)",
    )
    p.add_argument(
        "--registration-sigma",
        type=cli_float,
        default=None,
        metavar="DEG",
        help="uncertainty of the depth-to-colour rotation per axis, degrees: depth aligned through a turned "
        "extrinsic is a turned camera's, which no registration can tell apart, so it is added to the rotation "
        "sigma (default: the sensor profile's bound for a real unit, at least "
        f"{FACTORY_ROLL_BOUND_DEG:g} where depth and colour come from separate imagers; a simulated dataset's own "
        "draw; a shift of the depth image is estimated with the principal point)",
    )
    p.add_argument(
        "--stereo-fb",
        type=cli_float,
        default=None,
        metavar="PX_M",
        help="an active-stereo camera's disparity constant: its depth stream's focal length in pixels times the "
        "baseline in metres (a D435 at 848x480: 447 x 0.050 = 22.35); its matcher's pull toward whole "
        "disparities is estimated with the depth (default: the sensor profile's; 0: not modelled)",
    )


def _add_estimated_arguments(p: argparse.ArgumentParser) -> None:
    """What is estimated with the pose: the camera matrix, the joint offsets, the static parts."""
    p.add_argument(
        "--intrinsics",
        choices=("estimate", "fixed"),
        default="estimate",
        help="estimate the depth camera's fx, fy, cx, cy with the pose under a prior of the camera matrix given "
        "(default; each reported with its sigma and whether the frames determined it), or take them as exact",
    )
    p.add_argument(
        "--intrinsics-sigma",
        default=None,
        metavar="FX,FY,CX,CY",
        help="the camera matrix's stated uncertainty, one sigma: focal lengths relative, principal point in pixels "
        "(default: the --sensor profile's, else a factory calibration's 0.007,0.007,3,3)",
    )
    p.add_argument(
        "--no-shared-intrinsics",
        action="store_true",
        help="register each placement on its own; by default, with 4 or more placements, each is registered again "
        "with the intrinsics the others estimated as its prior (one camera, moved: its lens did not change; a "
        "parameter a placement disagrees with is not pooled for it), both passes marginalising a depth error per "
        "2 px image cell (a fixed pattern)",
    )
    p.add_argument(
        "--joint-offsets",
        choices=("estimate", "fixed"),
        default="estimate",
        help="estimate the robot's joint zero offsets with the pose under a prior about 0 (default; each reported in "
        "degrees with its sigma and whether the frames determined it; the base rotation's offset is part of the "
        "pose, which is then the camera in the robot's kinematic base frame), or take the recorded joints as exact",
    )
    p.add_argument(
        "--joint-offset-sigma",
        type=cli_float,
        default=None,
        metavar="DEG",
        help="one sigma of every joint's zero offset, degrees (default: the dataset's robot family's, 0.2 for a "
        "UR-class arm and any other; see classic.markerless.kinematics.JOINT_OFFSET_PRIORS_DEG)",
    )
    p.add_argument(
        "--static-parts",
        action="store_true",
        help="fit the robot's parts that do not move over the recording as well (the base; default: the moving "
        "parts only, since a static part's depth error is the same in every frame and the frames cannot reveal it)",
    )


def _add_output_arguments(p: argparse.ArgumentParser) -> None:
    """The JSON results, the dataset's labels, the progress bar."""
    p.add_argument("-o", "--out", type=Path, help="write the results as JSON")
    p.add_argument(
        "--write-labels",
        action="store_true",
        help="write the results into the dataset's cameras.csv as markerless labels (for "
        "'handeye learned run --labels markerless')",
    )
    p.add_argument("--quiet", action="store_true", help="no progress bar")


def run(args: argparse.Namespace) -> int:
    """Run the command."""
    from handeye.core.optional import require_package

    require_package("pinocchio", extra="robot", purpose="the robot model")
    from classic.markerless import MarkerlessOptions
    from classic.markerless.shared_intrinsics import MIN_OTHERS, first_pass_options
    from handeye.core.dataset import write_json_atomic
    from handeye.markerless import markerless_dataset, read_start, write_markerless_labels
    from handeye.markerless_shared import share_intrinsics, shared_note, shared_options

    if args.model is not None:
        require_package("torch", extra="learned", purpose="the learned start")
    from handeye.core.dataset import Dataset
    from handeye.core.safe_write import check_output_path

    if args.out:  # a target that cannot take a file is refused before the work, not after it
        check_output_path(args.out)
    if args.write_labels:
        check_output_path(Dataset.open(args.dataset).cameras_path)
    start = read_start(args.start) if args.start else None
    extrinsic_m, extrinsic_deg, stereo_fb = _sensor_terms(args)
    options = MarkerlessOptions(
        depth_sigma_m_at_1m=args.depth_noise,
        depth_model=args.depth_model,
        depth_extrinsic_sigma_m=extrinsic_m,
        depth_extrinsic_sigma_deg=extrinsic_deg,
        stereo_fb_px_m=stereo_fb,
        static_parts=args.static_parts,
        intrinsics_model=args.intrinsics,
        intrinsics_prior_sigma=_intrinsics_sigma(args),
        **_joint_offset_options(args),
    )
    urdf = _robot_urdf(args)
    first_options = options
    if not args.no_shared_intrinsics:
        n = len(args.camera) if args.camera else len(Dataset.open(args.dataset))
        options = shared_options(options, n)
        first_options = first_pass_options(options) if n > MIN_OTHERS else options
    out = markerless_dataset(
        args.dataset,
        args.camera,
        model_dir=args.model,
        T_base_cam_start=start,
        urdf=urdf,
        options=first_options,
        progress=not args.quiet,
    )
    if not args.no_shared_intrinsics:
        out = share_intrinsics(args.dataset, out, urdf=urdf, options=options, progress=not args.quiet)
    print(out.table())
    print(out.summary())
    for note in (out.registration_note(), shared_note(out, options.pixel_effect_px)):
        if note:
            print(note)
    print(f"terms (sigma, matched, depth scale and offset): {GLOSSARY_WHERE}")
    if args.out:
        write_json_atomic(args.out, out.to_dict())
        print(f"written: {args.out}")
    if args.write_labels:
        print(f"written: {write_markerless_labels(args.dataset, out)} (markerless label columns)")
    return 0 if all(r.ok for r in out.results.values()) else 1


def _robot_urdf(args: argparse.Namespace):
    """``--urdf`` and ``--package-dir`` as a :class:`handeye.markerless.RobotURDF`; None without ``--urdf``."""
    from handeye.markerless import RobotURDF

    return RobotURDF(args.urdf, tuple(args.package_dir)) if args.urdf else None


def _joint_offset_options(args: argparse.Namespace) -> dict:
    """``--joint-offsets`` and ``--joint-offset-sigma`` as :class:`classic.markerless.MarkerlessOptions` fields."""
    from handeye.core.errors import HandEyeInputError

    out = {"joint_offsets_model": args.joint_offsets}
    if args.joint_offset_sigma is not None and not 0 < args.joint_offset_sigma < float("inf"):
        raise HandEyeInputError(
            f"--joint-offset-sigma must be a positive angle in degrees, got {args.joint_offset_sigma}"
        )
    if args.joint_offsets != "estimate":
        return out
    if args.joint_offset_sigma is None:  # the dataset's robot family's prior
        from classic.markerless.kinematics import joint_offset_prior_deg
        from handeye.core.dataset import Dataset

        dataset = getattr(args, "dataset", None)
        robot = Dataset.open(dataset).meta.get("robot") if dataset is not None else None
        out["joint_offset_prior_deg"] = joint_offset_prior_deg(robot)
        return out
    out["joint_offset_prior_deg"] = float(args.joint_offset_sigma)
    return out


def _intrinsics_sigma(args: argparse.Namespace) -> tuple:
    """``--intrinsics-sigma``, else the ``--sensor`` profile's stated uncertainty of the camera matrix."""
    from classic.markerless.intrinsics import INTRINSICS_PRIORS
    from handeye.core.errors import HandEyeInputError

    if args.intrinsics_sigma is None:
        return INTRINSICS_PRIORS.get(args.sensor or "factory", INTRINSICS_PRIORS["factory"])
    try:
        values = tuple(parse_float(x.strip(" "), "--intrinsics-sigma") for x in args.intrinsics_sigma.split(","))
    except HandEyeInputError:
        values = ()
    if len(values) != 4 or not all(0 < v < float("inf") for v in values):
        raise HandEyeInputError(
            f"--intrinsics-sigma must be four positive numbers FX,FY,CX,CY, got {args.intrinsics_sigma!r}"
        )
    return values


#: The profile whose depth-to-colour registration uncertainty a real recording gets without ``--sensor`` (0.5 mm
#: per axis, 0.2 deg): taking it as exact made the sigma too small on a real camera.
UNNAMED_CAMERA_PRIOR = "d435-real-cell"


def rendered(recipe: dict) -> bool:
    """Whether a dataset's recipe (``meta["recipe"]``) says the simulator rendered it (else a real recording)."""
    return str(recipe.get("generator", "")).startswith("handeye sim")


def sensor_of(name: str | None, recipe: dict):
    """The depth camera whose registration uncertainty enters the sigma: ``--sensor``'s profile, else the one a
    simulated dataset was rendered with (None: exact registration), else, for a real recording, the
    :data:`UNNAMED_CAMERA_PRIOR` profile without its matcher model, said on stdout."""
    from handeye.robot.depth_sensors import DepthSensor, sensor_profile

    if name is not None:
        return sensor_profile(name)
    if rendered(recipe):
        recorded = recipe.get("sensor")
        return DepthSensor.from_dict(recorded) if isinstance(recorded, dict) else None
    sensor = replace(sensor_profile(UNNAMED_CAMERA_PRIOR), stereo_baseline_m=0.0)
    print(
        f"no --sensor: the depth-to-colour registration taken as uncertain by {sensor.extrinsic_sigma_m * 1e3:g}"
        f" mm and {sensor.registration_roll_bound_deg:g} deg per axis (the {UNNAMED_CAMERA_PRIOR} profile's); "
        "name your camera with --sensor"
    )
    return sensor


def _sensor_terms(args: argparse.Namespace) -> tuple[float, float, float | None]:
    """The depth-to-colour extrinsic's sigmas per axis (metres, degrees) and a stereo camera's ``f B`` (None: not
    modelled).

    Of ``--sensor``, else of the dataset's simulated sensor, else (a real recording) of
    :data:`UNNAMED_CAMERA_PRIOR` without its matcher model; ``--registration-sigma`` overrides the rotation's,
    ``--stereo-fb`` the ``f B`` (0: None). The matcher's bias is modelled only with the depth self-calibrated
    (``--depth-model scale-offset``).
    """
    from handeye.core.dataset import Dataset
    from handeye.core.errors import HandEyeInputError

    recipe = {} if args.sensor is not None else Dataset.open(args.dataset).meta.get("recipe", {})
    sensor = sensor_of(args.sensor, recipe)
    extrinsic_m = sensor.extrinsic_sigma_m if sensor is not None else 0.0
    # a camera named, or a real recording's unnamed one: a real unit's bound (naming a camera whose profile draws no
    # turn must not make the sigma tighter than naming none); a simulated dataset's own sensor: its drawn spread
    simulated = args.sensor is None and rendered(recipe)
    extrinsic_deg = 0.0
    if sensor is not None:
        extrinsic_deg = sensor.registration_roll_sigma_deg if simulated else sensor.registration_roll_bound_deg
    if args.registration_sigma is not None:
        if not 0 <= args.registration_sigma < 180:
            raise HandEyeInputError(
                f"--registration-sigma must be an angle in degrees >= 0, got {args.registration_sigma}"
            )
        extrinsic_deg = args.registration_sigma
    fb = sensor.stereo_fb_px_m if sensor is not None else None
    if args.stereo_fb is not None:
        if not args.stereo_fb >= 0:
            raise HandEyeInputError(
                f"--stereo-fb must be a disparity constant >= 0 (0: not modelled), got {args.stereo_fb}"
            )
        fb = args.stereo_fb or None
    return extrinsic_m, extrinsic_deg, (fb if args.depth_model == "scale-offset" else None)
