"""``handeye watch``: watch a cell's calibration on a recording; notice a moved camera, recalibrate, keep versions.

Example
-------
::

    handeye watch data/stream --truth-start --sensor d435 --history cell.jsonl --current cell.json
    handeye watch data/stream --camera-start guess.json --rate 30 --false-alarms-per-hour 0.1
    handeye watch rollback --history cell.jsonl 3
    handeye watch BAG --sensor d435 --camera-start start.json --history cell.jsonl    # a ROS 2 bag, at its rate
    handeye watch --ros2 --sensor d435 --history cell.jsonl --current cell.json        # live (needs rclpy)

Replays the dataset's data frames as one stream (its shards in order; times from ``stream.json``, else
``--rate``) through :class:`handeye.watch.CellWatcher` and prints one line per event: ``learning`` (the
first ``--null-seconds``: "nothing moved" is learnt), ``ok``, ``drift``, ``occluded``, ``out_of_view``,
``dropout``, ``moved`` (the change test alarmed with a consistent direction; its threshold allows at most
``--false-alarms-per-hour`` false alarms while the frames follow the null learnt, more where frames are
correlated: docs/benchmarks/running-cell.md measures it on simulated streams), ``recalibrated`` (a validated
markerless answer committed), ``refused`` or ``replaced`` (a rollback by another process, taken). From ``moved``
until a commit every line says "calibration stale since t", and so does ``--current``'s JSON (``stale_since``,
null while valid); a watch started again on that history and JSON stays stale (no transform published) and
recalibrates before it calls any pose valid. The start: ``--camera-start`` (JSON, as
``handeye markerless --start`` reads), ``--truth-start`` (the first segment's truth, simulated data, with the
sensor's true depth scale and offset where the dataset has them), else the history's latest version. Until the first
recalibration estimates it, the depth is otherwise taken as exact. ``rollback`` appends to the history a new
version equal to an older one (``--publish-tf`` also publishes it as the static transform); a watcher running on
that history takes it at its next frame (its event ``replaced``), publishing it itself.
A ROS 2 bag (a path with ``metadata.yaml``, or its ``.db3``/``.mcap``) is replayed at its recorded rate
(``--fast``: as fast as possible), live topics are watched with ``--ros2``, the calibration is published as a
static transform and the continual learner fed (``--learner``): :mod:`handeye.commands.watch_sources`.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from handeye.commands import command_parser
from handeye.commands.watch_sources import add_source_arguments
from handeye.core.numbers import cli_float, cli_int

__all__ = ["add_parser", "run", "watch_options"]


def add_parser(sub) -> argparse.ArgumentParser:
    """Register the command."""
    p = command_parser(
        sub,
        "watch",
        "watch a cell's calibration on a recording: detect a moved camera, recalibrate, keep versions",
        __doc__,
    )
    p.add_argument(
        "dataset", nargs="?", help="dataset directory or ROS 2 bag (a stream), or 'rollback' followed by a VERSION"
    )
    p.add_argument("version", nargs="?", type=cli_int, help="with 'rollback': the version to roll back to")
    start = p.add_mutually_exclusive_group()
    start.add_argument("--camera-start", type=Path, help="JSON start T_base_cam")
    start.add_argument("--truth-start", action="store_true", help="start from the first segment's truth")
    p.add_argument("--sensor", default=None, help="depth sensor profile (default: the dataset's simulated one)")
    p.add_argument("--history", type=Path, help="the versions' history, JSON lines (append-only)")
    p.add_argument("--current", type=Path, help="the current calibration, JSON (replaced atomically)")
    p.add_argument(
        "--rate", type=cli_float, default=None, help="frame rate, Hz (default: stream.json's; a bag's median; live 30)"
    )
    p.add_argument(
        "--false-alarms-per-hour",
        type=cli_float,
        default=0.1,
        help="the change test's bound under its null (default 0.1)",
    )
    p.add_argument("--null-seconds", type=cli_float, default=10.0, help="'nothing moved' learnt from (default 10)")
    p.add_argument("--relearn-seconds", type=cli_float, default=3.0, help="after a recalibration (default 3)")
    p.add_argument("--recal-frames", type=cli_int, default=30, help="frames per recalibration (default 30)")
    p.add_argument("--urdf", type=Path, help="robot URDF with visual meshes (default: the dataset's UR)")
    add_source_arguments(p)
    p.set_defaults(run=run)
    p.__class__ = _IntermixedParser  # "rollback --history PATH VERSION": the version after the options
    return p


class _IntermixedParser(argparse.ArgumentParser):
    """A parser that takes positionals between and after options (``parse_known_intermixed_args``)."""

    _inside = False

    def parse_known_args(self, args=None, namespace=None):
        if self._inside:  # the intermixed parse's own two passes
            return super().parse_known_args(args, namespace)
        self._inside = True
        try:
            return self.parse_known_intermixed_args(args, namespace)
        finally:
            self._inside = False


def run(args: argparse.Namespace) -> int:
    """Run ``handeye watch`` (or ``handeye watch rollback``)."""
    from handeye.core.errors import HandEyeInputError

    if args.dataset == "rollback":
        return _rollback(args)
    if args.version is not None:
        raise HandEyeInputError(f"a version ({args.version}) is for 'handeye watch rollback' only")
    return _watch(args)


def _rollback(args: argparse.Namespace) -> int:
    from handeye.core.errors import HandEyeInputError
    from handeye.watch.history import History

    if args.history is None or args.version is None:
        raise HandEyeInputError("handeye watch rollback --history PATH VERSION: both are needed")
    if not args.history.is_file():
        raise HandEyeInputError(f"{args.history}: no such history")
    tf = None
    if args.publish_tf or args.ros2:  # before the append: a refused frame leaves the history as it was
        from handeye.commands.watch_sources import tf_publisher

        tf = tf_publisher(args)
    v = History(args.history, args.current).rollback(args.version)
    print(f"version {v.version}: {v.reason} (replaces {v.replaces})")
    print("a handeye watch running on this history takes it at its next frame (event 'replaced') and publishes it")
    if tf is not None:
        from handeye.commands.watch_sources import hold

        tf.publish(v.T_base_cam, v.version)
        print(f"published {tf.parent_frame} -> {tf.child_frame}; held until Ctrl-C", flush=True)
        hold(tf)
    return 0


def _watch(args: argparse.Namespace) -> int:
    from handeye.commands.watch_sources import is_bag
    from handeye.core.errors import HandEyeInputError

    if args.current is not None and args.history is None:
        raise HandEyeInputError("--current is published from the versions' history: give --history too")
    if args.ros2 or (args.dataset is not None and is_bag(args.dataset)):
        return _watch_ros(args)
    if args.dataset is None:
        raise HandEyeInputError("nothing to watch: give a dataset or a ROS 2 bag, or --ros2 for live topics")
    return _watch_dataset(args)


def _watch_dataset(args: argparse.Namespace) -> int:
    import numpy as np

    from handeye.commands.watch_sources import outputs
    from handeye.core.dataset import Dataset
    from handeye.core.errors import HandEyeInputError
    from handeye.core.metrics import pose_error
    from handeye.markerless import read_start, robot_surface_for
    from handeye.robot.depth_sensors import DepthSensor, sensor_profile
    from handeye.robot_model import dataset_robot
    from handeye.watch import CellWatcher, dataset_frames
    from handeye.watch.source import stream_rate
    from handeye.watch.wiring import WatchFiles, WatchHooks

    ds = Dataset.open(args.dataset)
    cameras = ds.complete_shards()
    if not cameras:
        raise HandEyeInputError(f"{args.dataset}: no complete shard to replay")
    truth = ds.truth()
    T_start, depth_correction = None, None  # None: the started version's own
    if args.camera_start is not None:
        T_start = read_start(args.camera_start)
    elif args.truth_start:
        if not np.isfinite(truth[cameras[0]]).all():
            raise HandEyeInputError(f"{ds.cameras_path}: camera {cameras[0]} has no truth for --truth-start")
        T_start = truth[cameras[0]]
        depth_correction = _truth_depth(ds, cameras[0])
    elif args.history is None or not args.history.is_file():
        raise HandEyeInputError("no start: give --camera-start FILE, --truth-start, or a --history with a version")
    if args.sensor is not None:
        sensor = sensor_profile(args.sensor)
    else:
        recorded = ds.meta.get("recipe", {}).get("sensor")
        if not isinstance(recorded, dict):
            raise HandEyeInputError(f"{args.dataset}: no sensor recorded in meta.json: give --sensor (d435, ...)")
        sensor = DepthSensor.from_dict(recorded)
    rate = stream_rate(args.dataset, args.rate)
    surface, stride = robot_surface_for(ds, args.urdf)
    K = np.array(ds.meta["intrinsics"]["K"], dtype=float)
    robot = dataset_robot(ds, args.urdf) if args.learner is not None else None
    hooks, starts, learner, tf = outputs(args, robot, K)
    watcher = CellWatcher(
        surface,
        K,
        T_start,
        sensor,
        _options(args, rate, stride),
        WatchFiles(args.history, args.current),
        depth_correction=depth_correction,
        hooks=WatchHooks(on_commit=hooks, extra_starts=starts, on_stale=() if tf is None else [tf.stale]),
    )
    if tf is not None:
        tf.start(watcher.T_base_cam, watcher.version, watcher.stale_since)
    frames = dataset_frames(args.dataset, args.rate, colour=learner is not None)
    last = _replay(watcher, frames, learner)
    if last is not None and np.isfinite(truth[last.segment]).all():
        rot_deg, trans_mm = pose_error(watcher.T_base_cam, truth[last.segment])
        print(f"calibration in use vs the last segment's truth: {rot_deg:.3f} deg, {trans_mm:.2f} mm")
    return 0


def _watch_ros(args: argparse.Namespace) -> int:
    """A ROS 2 bag replayed, or live topics (:mod:`handeye.commands.watch_sources`)."""
    from handeye.commands.watch_sources import bag_inputs, outputs, ros2_inputs
    from handeye.core.errors import HandEyeInputError
    from handeye.markerless import read_start
    from handeye.robot.depth_sensors import sensor_profile
    from handeye.watch import CellWatcher
    from handeye.watch.wiring import WatchFiles, WatchHooks

    what = "live ROS 2 topics" if args.ros2 else "a bag"
    if args.truth_start:
        raise HandEyeInputError(f"--truth-start is for simulated datasets; for {what} give --camera-start or --history")
    if args.camera_start is None and (args.history is None or not args.history.is_file()):
        raise HandEyeInputError(f"no start for {what}: give --camera-start FILE or a --history with a version")
    if args.sensor is None:
        raise HandEyeInputError(f"{what} records no sensor profile: give --sensor (d435, ...)")
    sensor = sensor_profile(args.sensor)
    T_start = None if args.camera_start is None else read_start(args.camera_start)
    inputs = ros2_inputs(args) if args.ros2 else bag_inputs(args)
    try:
        rate = inputs.rate_hz if args.rate is None else args.rate
        hooks, starts, learner, tf = outputs(args, inputs.robot, inputs.K, inputs.node)
        watcher = CellWatcher(
            inputs.surface,
            inputs.K,
            T_start,
            sensor,
            _options(args, rate, inputs.stride),
            WatchFiles(args.history, args.current),
            hooks=WatchHooks(on_commit=hooks, extra_starts=starts, on_stale=() if tf is None else [tf.stale]),
        )
        if tf is not None:
            tf.start(watcher.T_base_cam, watcher.version, watcher.stale_since)
        _replay(watcher, inputs.frames, learner)
    finally:
        if inputs.source is not None:
            inputs.source.close()
    return 0


def _options(args: argparse.Namespace, rate: float, stride: int):
    """The watcher's options from the command line at the stream's rate (:func:`watch_options`)."""
    return watch_options(
        rate,
        stride,
        false_alarms_per_hour=args.false_alarms_per_hour,
        null_seconds=args.null_seconds,
        relearn_seconds=args.relearn_seconds,
        recal_frames=args.recal_frames,
    )


def watch_options(
    rate_hz: float,
    zbuffer_stride: int,
    *,
    false_alarms_per_hour: float,
    null_seconds: float,
    relearn_seconds: float,
    recal_frames: int,
):
    """The watcher's options as ``handeye watch`` builds them (benchmarks/running_cell.py builds its own here too).

    Parameters
    ----------
    rate_hz : float
        The stream's frame rate.
    zbuffer_stride : int
        The z-buffer stride the robot surface was sampled for (:func:`handeye.markerless.robot_surface_for`'s
        second value): the check's, and so the default recalibration's (:class:`handeye.watch.CellWatcher`). A
        finer z-buffer than the surface's sampling lets hidden points show through.
    false_alarms_per_hour : float
    null_seconds, relearn_seconds : float
        Seconds "nothing moved" is learnt from, and its bias relearnt over after a commit: as frames at
        ``rate_hz``, at least 6.
    recal_frames : int
        Frames per recalibration.

    Returns
    -------
    handeye.watch.WatchOptions
    """
    from handeye.watch import WatchOptions
    from handeye.watch.check import CheckOptions

    return WatchOptions(
        rate_hz=rate_hz,
        false_alarms_per_hour=false_alarms_per_hour,
        null_frames=max(6, round(null_seconds * rate_hz)),
        relearn_frames=max(6, round(relearn_seconds * rate_hz)),
        recal_frames=recal_frames,
        check=CheckOptions(zbuffer_stride=zbuffer_stride),
    )


def _replay(watcher, frames, learner=None):
    """Feed every frame, printing each event (and the learner's reports) as one line; the last frame."""
    n, spent, last, ended = 0, 0.0, None, False
    try:
        for frame in frames:
            t0 = time.perf_counter()
            for event in watcher.feed(frame):
                print(event.line(), flush=True)
            spent += time.perf_counter() - t0
            n, last = n + 1, frame
            _print_reports(learner)
        ended = True
    except KeyboardInterrupt:
        print("interrupted")
    finally:  # a frame that raises too: no training outlives the command
        print(f"{n} frames, {1e3 * spent / max(n, 1):.1f} ms per frame on average (recalibrations included)")
        if learner is not None:
            _close_learner(learner, ended)
    if watcher.stale_since is not None:
        print(f"calibration stale since {watcher.stale_since:.3f}s: no validated answer yet")
    return last


def _close_learner(learner, ended: bool) -> None:
    """At the stream's end, wait for the queued offers to be learnt; else drop them, end a child's training and
    wait for the thread's (:meth:`handeye.watch.learner.BackgroundLearner.close`)."""
    if ended:
        print("waiting for the learner's training to end ...", flush=True)
    else:
        print("stopping the learner: queued offers dropped; a training under way in its thread ends first", flush=True)
    learner.close(wait=ended)
    _print_reports(learner)


def _print_reports(learner) -> None:
    while learner is not None and learner.reports:
        print(learner.reports.pop(0), flush=True)


def _truth_depth(ds, camera: int) -> tuple:
    """``(k, c)`` of the simulated sensor's true depth scale and offset (``cameras.csv``), ``(1, 0)`` without them."""
    import numpy as np

    from handeye.watch.check import unit_correction

    cams = ds.cameras()
    if "depth_scale_true" not in cams or "depth_offset_mm_true" not in cams:
        return (1.0, 0.0)
    scale, offset_m = float(cams["depth_scale_true"][camera]), float(cams["depth_offset_mm_true"][camera]) * 1e-3
    if not (np.isfinite(scale) and np.isfinite(offset_m) and scale > 0):
        return (1.0, 0.0)
    return unit_correction(scale, offset_m)
