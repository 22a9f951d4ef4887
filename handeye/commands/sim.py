"""``handeye sim generate``: render a simulated, labelled-ready dataset.

Example
-------
::

    handeye sim generate --preset paper-sim --out data/paper-sim
    handeye sim generate --preset small --out data/small --noise default
    handeye sim generate --preset paper-real --out data/paper-real-d435 --noise default --sensor d435
    handeye sim generate --preset dense-sim --out /shared/dense-sim --engine ray --address auto

Per camera pose of the preset: a calibration recording (the ChArUco board on
the flange in reachable views facing the camera) and a data recording (RGB,
depth, joints, ``T_base_ee``, ``T_base_ref``). Run it again on the same
``--out`` to resume: complete shards are kept, half-written ones are rendered
again. Then ``handeye label`` the result.

``--sensor`` renders the depth as a real camera reports it (``ideal``, ``d435``, ``d455``, ``l515``,
``azure-kinect``, ``zivid``, or a JSON file of :class:`handeye.robot.depth_sensors.DepthSensor` parameters): a depth
scale, offset and depth-to-colour extrinsic error drawn per placement (recorded in ``cameras.csv``), noise
as the sensing principle grows it, correlated noise, flying pixels and holes. It replaces the depth term
of ``--noise``.

``handeye sim bag`` writes a generated dataset's placements as ROS 2 bags, as a real cell records them
(:mod:`sim.bag_export`), so that ``handeye import bag`` can be checked against the truth::

    handeye sim bag data/small --out bags/ --storage mcap
    handeye import bag bags/cam_0000_data --calibration bags/cam_0000_calibration --robot ur5 \
        --board board.json --out data/small-imported

``handeye sim stream`` renders a running cell (:mod:`sim.stream`): one camera watching the arm work for
minutes, bumped at known times and sizes, occluded, its lights changed, its depth lost for moments, drifting;
one shard per segment between camera changes and the truth of every event in ``stream.json``::

    handeye sim stream --preset bumps --out data/stream-bumps --sensor d435
    handeye sim stream --preset static --out data/stream-static --minutes 60 --rate 2
"""

from __future__ import annotations

import argparse
from pathlib import Path

from handeye.commands import command_parser
from handeye.core.engines import add_engine_arguments
from handeye.core.numbers import cli_float, cli_int

__all__ = ["add_parser", "run"]


def add_parser(sub) -> argparse.ArgumentParser:
    """Register the command group."""
    p = command_parser(sub, "sim", "the simulator: render datasets of a UR robot seen by many camera poses", __doc__)
    simsub = p.add_subparsers(dest="sim_command", required=True, metavar="SIM_COMMAND")
    g = command_parser(simsub, "generate", "render a dataset (resumable)", __doc__)
    g.add_argument(
        "--preset", default="small", help="small (default), demo, paper-sim, paper-real or dense-sim (1,000 poses)"
    )
    g.add_argument("--out", type=Path, required=True, help="dataset directory")
    g.add_argument("--seed", type=cli_int, default=0)
    add_engine_arguments(g, "rendering")
    g.add_argument(
        "--cameras",
        default=None,
        help="render only these camera poses: FIRST:STOP (a part of a large preset; run again without it to "
        "complete the dataset)",
    )
    g.add_argument(
        "--noise",
        default="none",
        help="'none', 'default' (pixel 2 grey levels, depth 1 mm at 1 m, joints 0.01 deg) or "
        "PIXEL,DEPTH_M_AT_1M,JOINT_DEG",
    )
    g.add_argument(
        "--sensor",
        default=None,
        help="depth sensor profile: ideal, d435, d455, l515, azure-kinect, zivid, or a JSON file of its parameters "
        "(replaces the depth term of --noise)",
    )
    g.add_argument("--recordings", default="calibration,data", help="calibration,data (default) or one of them")
    g.add_argument("--quiet", action="store_true", help="no progress bar")
    g.set_defaults(run=run)
    b = command_parser(
        simsub, "bag", "write a dataset's placements as ROS 2 bags, as a real cell records them", __doc__
    )
    b.add_argument("dataset", type=Path)
    b.add_argument("--out", type=Path, required=True, help="folder for the bags")
    b.add_argument("--camera", type=cli_int, nargs="+", help="placements (default all)")
    b.add_argument("--storage", choices=("sqlite3", "mcap"), default="sqlite3")
    b.add_argument("--depth-encoding", choices=("16UC1", "32FC1"), default="16UC1", help="millimetres or metres")
    b.add_argument("--color", choices=("raw", "jpeg", "png"), default="raw", help="Image or CompressedImage")
    b.add_argument("--board-out", type=Path, help="also write the dataset's board spec here (for --board)")
    b.set_defaults(run=run_bag)
    s = command_parser(
        simsub,
        "stream",
        "render a running cell: the arm working for minutes, the camera bumped, occluded, drifting",
        STREAM_DOC,
    )
    s.add_argument("--preset", default="bumps", help="bumps (default), static or smoke (sim.stream_events)")
    s.add_argument("--out", type=Path, required=True, help="a new dataset folder")
    s.add_argument("--sensor", default=None, help="depth sensor profile (default the preset's, d435)")
    s.add_argument("--seed", type=cli_int, default=0)
    s.add_argument("--minutes", type=cli_float, default=None, help="the stream's length (default the preset's)")
    s.add_argument("--rate", type=cli_float, default=None, help="frames per second (default the preset's)")
    s.add_argument("--size", default=None, help="image WIDTHxHEIGHT (default the preset's, 256x256)")
    s.add_argument("--workers", type=cli_int, default=2, help="rendering processes (default 2)")
    s.add_argument("--quiet", action="store_true", help="no progress bar")
    s.set_defaults(run=run_stream)
    return p


#: ``handeye sim stream``'s description (the module's docstring is ``sim generate``'s and ``sim bag``'s).
STREAM_DOC = """``handeye sim stream``: render a running cell, the stream ``handeye watch`` replays.

Example
-------
::

    handeye sim stream --preset bumps --out data/stream --sensor d435
    handeye watch data/stream --truth-start --history cell.jsonl --current cell.json

The arm works before a fixed camera for minutes while things happen at known times (``sim.stream_events``):
``bumps`` (3 minutes at 5 Hz, 256x256: a bump of 0.5 mm / 0.05 deg, 2 mm / 0.2 deg, 5, 20 and 50 mm every 25 s
from 17 s, then a re-mount of 200 mm / 20 deg; a box and a person in front of the arm, the lights dimmed, two
depth dropouts, a slow drift of 0.1 mm per minute), ``static`` (no move: people and boxes passing, the lights
dimmed, dropouts, repeating for as long as ``--minutes``; the false-alarm measurement) and ``smoke`` (30 s at
2 Hz, 96x96, one of each, for tests). The camera's true pose is in the dataset's ``cameras.csv`` (one shard per
segment between two camera changes), the frames' times and the events with their times and sizes in its
``stream.json`` (``sim.stream``).
"""


def run_stream(args: argparse.Namespace) -> int:
    """Run ``handeye sim stream``."""
    from handeye.core.errors import HandEyeInputError
    from handeye.core.numbers import parse_int
    from handeye.core.optional import require_package

    require_package("pyrender", extra="sim", purpose="rendering")
    from sim.stream import StreamOverrides, generate_stream

    size = None
    if args.size is not None:
        parts = args.size.lower().split("x")
        if len(parts) != 2:
            raise HandEyeInputError(f"--size {args.size!r}: use WIDTHxHEIGHT, e.g. 256x256")
        size = tuple(parse_int(v, "--size", HandEyeInputError) for v in parts)  # the number grammar, not int()
    report = generate_stream(
        args.out,
        args.preset,
        seed=args.seed,
        sensor=parse_sensor(args.sensor),
        overrides=StreamOverrides(minutes=args.minutes, rate_hz=args.rate, image_size=size),
        workers=args.workers,
        progress=not args.quiet,
    )
    print(report.summary())
    return 0


def run_bag(args: argparse.Namespace) -> int:
    """Run ``handeye sim bag``."""
    from handeye.core.dataset import Dataset
    from sim.bag_export import write_placement_bags

    ds = Dataset.open(args.dataset)
    for c in args.camera if args.camera is not None else range(len(ds)):
        written = write_placement_bags(ds, c, args.out, args.storage, args.depth_encoding, args.color)
        print(f"camera {c}: " + ", ".join(str(p) for p in written.values()))
    if args.board_out is not None:
        from classic.vision.board import BoardSpec

        BoardSpec(**ds.meta["board"]).save(args.board_out)
        print(f"written: {args.board_out}")
    return 0


def parse_noise(text: str):
    """``none``, ``default`` or three comma-separated numbers -> NoiseModel."""
    from handeye.core.errors import HandEyeInputError
    from sim.generate import DEFAULT_NOISE, NoiseModel

    if text == "none":
        return NoiseModel()
    if text == "default":
        return DEFAULT_NOISE
    try:
        pixel, depth, joint = (float(v) for v in text.split(","))
    except ValueError:
        raise HandEyeInputError(f"--noise {text!r}: use none, default, or PIXEL,DEPTH_M_AT_1M,JOINT_DEG") from None
    return NoiseModel(pixel, depth, joint)


def parse_sensor(text: str | None):
    """A profile name or a JSON parameter file -> DepthSensor; None -> None."""
    from handeye.core.errors import HandEyeInputError
    from handeye.core.jsonfile import read_json_file
    from handeye.robot.depth_sensors import PROFILES, sensor_profile

    if text is None:
        return None
    if text in PROFILES:
        return PROFILES[text]
    if not text.endswith(".json"):
        raise HandEyeInputError(f"--sensor {text!r}: use one of {', '.join(PROFILES)}, or a .json parameter file")
    params = read_json_file(Path(text), HandEyeInputError, "sensor parameter file")
    if not isinstance(params, dict):
        raise HandEyeInputError(f"{text}: sensor parameters must be a JSON object")
    return sensor_profile(params)


def parse_cameras(text: str | None):
    """``FIRST:STOP`` -> ``range(FIRST, STOP)``; None -> None."""
    from handeye.core.errors import HandEyeInputError

    if text is None:
        return None
    try:
        first, stop = (int(v) for v in text.split(":"))
    except ValueError:
        raise HandEyeInputError(f"--cameras {text!r}: use FIRST:STOP, e.g. 0:100") from None
    if not 0 <= first < stop:
        raise HandEyeInputError(f"--cameras {text!r}: need 0 <= FIRST < STOP")
    return range(first, stop)


def run(args: argparse.Namespace) -> int:
    """Run the command."""
    from handeye.core.optional import require_package

    require_package("pyrender", extra="sim", purpose="rendering")
    from dataclasses import replace

    from handeye.core.engine_protocol import EngineOptions
    from sim.generate import Recipe, generate

    sensor = parse_sensor(args.sensor)
    noise = parse_noise(args.noise)
    if sensor is not None:
        noise = replace(noise, depth_sigma_m_at_1m=0.0)  # the sensor's depth errors replace the noise's depth term
    recordings = tuple(r.strip() for r in args.recordings.split(","))
    recipe = Recipe(args.preset, args.seed, noise, recordings, sensor=sensor)
    options = EngineOptions(workers=args.workers, progress=not args.quiet)
    report = generate(args.out, recipe, parse_cameras(args.cameras), options, args.engine, args.address)
    print(report.summary())
    if report.left:
        print(f"next: the same command without --cameras completes {args.out}; then handeye label {args.out}")
    else:
        print(f"next: handeye label {args.out}")
    return 0
