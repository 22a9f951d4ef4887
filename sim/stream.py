"""A simulated running cell: one camera watching the arm work for minutes, bumped, occluded, drifting.

``handeye sim stream`` renders a stream preset (:data:`STREAM_PRESETS`, data in :mod:`sim.stream_events`)
into the dataset format (:mod:`handeye.core.dataset`), so that a cell watcher can replay it and a benchmark
can score the watcher against the truth:

- one shard per segment (the frames between two camera changes: a bump or a drift step), its camera's true
  pose ``T_base_cam`` in ``cameras.csv`` (with the depth unit's systematic errors, the same in every row: one
  camera), frames in time order, the ``frame`` column the global frame number, so ``t = frame / rate_hz``;
- ``stream.json`` in the root, written last: the rate, each segment's first frame and time, and the event
  list with times and sizes (``bump``, ``drift``, ``occlusion_start`` / ``occlusion_end``, ``lighting``,
  ``dropout``), and per occlusion the share of the arm's pixels hidden in each of its frames. A frame whose
  depth was lost has an empty ``depth`` cell.

Example
-------
::

    handeye sim stream --preset bumps --out data/stream-bumps --sensor d435
    handeye sim stream --preset static --out data/stream-static --minutes 60 --rate 2

The timeline (:mod:`sim.stream_timeline`) is drawn in this process; the segments are rendered in worker
processes (:mod:`sim.stream_render`: pyrender's OpenGL context never lives in the caller's process).
"""

from __future__ import annotations

import json
import time
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from handeye.core.dataset import dataset_lock, poses_to_columns, write_json_atomic
from handeye.core.engines import EngineOptions, run_tasks
from handeye.core.errors import DatasetError, HandEyeInputError
from handeye.robot.depth_sensors import DepthSensor, sensor_profile
from sim.cameras import CameraPreset
from sim.generate import DEPTH_SCALE_M, NoiseModel, dataset_folder, dataset_meta, write_camera_table
from sim.recording import camera_matrix
from sim.sensors import draw_systematic, truth_columns
from sim.stream_events import STREAM_PRESETS, StreamPreset, get_stream_preset
from sim.stream_timeline import Timeline, build_timeline

__all__ = [
    "STREAM_PRESETS",
    "STREAM_FORMAT",
    "StreamOverrides",
    "StreamReport",
    "generate_stream",
    "stream_meta",
    "read_stream",
]

STREAM_FORMAT = "handeye-stream"
STREAM_VERSION = 1


@dataclass(frozen=True)
class StreamOverrides:
    """A stream preset's length, rate and image size, changed for one :func:`generate_stream` (None: the preset's).

    Attributes
    ----------
    minutes, rate_hz : float, optional
        Events past the end are left out; repeated ones repeat.
    image_size : (int, int), optional
        ``(width, height)``.
    """

    minutes: float | None = None
    rate_hz: float | None = None
    image_size: tuple[int, int] | None = None


@dataclass
class StreamReport:
    """What :func:`generate_stream` did.

    Attributes
    ----------
    out : Path
    frames, segments : int
    events : int
    wall_s : float
    """

    out: Path
    frames: int = 0
    segments: int = 0
    events: int = 0
    wall_s: float = 0.0
    counts: dict = field(default_factory=dict)

    def summary(self) -> str:
        fps = self.frames / self.wall_s if self.wall_s > 0 else float("nan")
        kinds = ", ".join(f"{n} {k}" for k, n in sorted(self.counts.items()))
        return (
            f"{self.out}: {self.frames} frames in {self.segments} segments ({self.wall_s:.1f} s, {fps:.1f} "
            f"frames/s); events: {kinds or 'none'}; the truth in {self.out / 'stream.json'}"
        )


def _camera_preset(preset: StreamPreset, segments: int) -> CameraPreset:
    """The dataset's camera preset: every segment a placement of one region (for ``meta.json``)."""
    return CameraPreset(
        preset.name,
        preset.robot,
        ((preset.azimuth_deg, preset.azimuth_deg),),
        (segments,),
        (0,),
        preset.n_frames,
        calibration_views=0,
        radius_m=(preset.radius_m, preset.radius_m),
        elevation_deg=(preset.elevation_deg, preset.elevation_deg),
        look_at_m=tuple(preset.look_at_m),
        image_size=tuple(preset.image_size),
        calibration_image_size=tuple(preset.image_size),
        fov_deg=preset.fov_deg,
    )


def stream_meta(preset: StreamPreset, seed: int, sensor: DepthSensor, segments: int) -> dict:
    """The ``meta.json`` of a stream: the dataset's, its recipe the stream's (preset, seed, sensor).

    Returns
    -------
    dict
    """
    noise = NoiseModel(pixel_sigma=preset.pixel_sigma, joint_sigma_deg=preset.joint_sigma_deg)
    meta = dataset_meta(_camera_preset(preset, segments), seed, noise, ("data",), None, sensor)
    meta["recipe"] = {
        "generator": "handeye sim stream",
        "stream": json.loads(json.dumps(preset.to_dict())),
        "seed": int(seed),
        "sensor": sensor.to_dict(),
    }
    return meta


def _write_cameras(out: Path, preset: StreamPreset, timeline: Timeline, sensor: DepthSensor, truth) -> None:
    """``cameras.csv``: per segment the camera's true pose, where it stands, and the unit's errors."""
    n = len(timeline.T_base_cam)
    offset = timeline.T_base_cam[:, :3, 3] - np.asarray(preset.look_at_m, dtype=float)
    radius = np.linalg.norm(offset, axis=1)
    table = {
        "camera_id": np.arange(n),
        "region": np.zeros(n, dtype=int),
        "split": np.array(["train"] * n, dtype=object),
        "azimuth_deg": np.degrees(np.arctan2(offset[:, 1], offset[:, 0])),
        "elevation_deg": np.degrees(np.arcsin(offset[:, 2] / radius)),
        "radius_m": radius,
    }
    table.update(poses_to_columns("T_base_cam_true", timeline.T_base_cam))
    table.update(truth_columns(sensor, [truth] * n))  # one camera: the same unit in every segment's row
    write_camera_table(out / "cameras.csv", table)


def _tasks(timeline: Timeline):
    """One rendering task per segment."""
    ends = list(timeline.segment_first[1:]) + [len(timeline)]
    for s, (k0, k1) in enumerate(zip(timeline.segment_first, ends)):
        sl = slice(int(k0), int(k1))
        yield {
            "segment": s,
            "frames": np.arange(k0, k1),
            "T_base_cam": timeline.T_base_cam[s],
            "q": timeline.q[sl],
            "q_recorded": timeline.q_recorded[sl],
            "light": timeline.light[sl],
            "depth_lost": timeline.depth_lost[sl],
            "occluder": timeline.occluder[sl],
            "T_base_occluder": timeline.T_base_occluder[sl],
        }


def _render(out: Path, config: dict, timeline: Timeline, workers: int, progress: bool) -> dict:
    """Render every segment in worker processes (:func:`handeye.core.engines.run_tasks`, the package's pool: its
    workers die with this process, a failure names its segment); the occluded frames' hidden shares."""
    from sim.stream_render import describe_segment, init_worker, render_segment

    options = EngineOptions(
        workers=workers,
        progress=progress,
        desc=f"render {out.name}",
        unit="segment",
        initializer=init_worker,
        initargs=(config,),
        describe=describe_segment,
        isolate=True,  # pyrender's OpenGL context never lives in this process
    )
    hidden = {}
    for _, _, shares in run_tasks(render_segment, list(_tasks(timeline)), options):
        hidden.update(shares)
    return hidden


def _stream_doc(preset: StreamPreset, seed: int, sensor: DepthSensor, timeline: Timeline, hidden: dict) -> dict:
    ends = list(timeline.segment_first[1:]) + [len(timeline)]
    occlusions = [
        {**o, "arm_hidden_fraction": [hidden.get(k) for k in range(o["first_frame"], o["end_frame"])]}
        for o in timeline.occlusions
    ]
    return {
        "format": STREAM_FORMAT,
        "version": STREAM_VERSION,
        "time": "frame k (frames.csv's frame column) is at t = k / rate_hz seconds",
        "preset": preset.name,
        "seed": int(seed),
        "sensor": sensor.name,
        "rate_hz": preset.rate_hz,
        "frames": len(timeline),
        "duration_s": len(timeline) / preset.rate_hz,
        "segments": [
            {
                # the dataset's camera id of the segment, and its first frame's time: handeye.watch.source reads
                # these (a segment's frame i at start_s + i / rate_hz); files of version 1 before this also
                # held them as camera_id and t0_s, which nothing reads
                "camera": s,
                "first_frame": int(k0),
                "start_s": float(k0) / preset.rate_hz,
                "frames": int(k1 - k0),
            }
            for s, (k0, k1) in enumerate(zip(timeline.segment_first, ends))
        ],
        "events": json.loads(json.dumps(timeline.events, default=float)),
        "occlusions": json.loads(json.dumps(occlusions, default=float)),
    }


def generate_stream(
    out: str | Path,
    preset: str | StreamPreset = "bumps",
    seed: int = 0,
    sensor: str | DepthSensor | None = None,
    overrides: StreamOverrides | None = None,
    workers: int = 2,
    progress: bool = True,
) -> StreamReport:
    """Render a stream preset into a new dataset folder.

    Parameters
    ----------
    out : str or Path
        A new (or empty) folder.
    preset : str or StreamPreset
        ``"bumps"``, ``"static"``, ``"smoke"`` or a custom preset.
    seed : int
    sensor : str or DepthSensor, optional
        A depth sensor profile (:data:`handeye.robot.depth_sensors.PROFILES`); None: the preset's.
    overrides : StreamOverrides, optional
        The preset's length, rate and image size changed (events past the end are left out; repeated ones
        repeat); None: the preset's.
    workers : int
        Rendering processes.
    progress : bool
        A progress bar of the rendered segments on stderr.

    Returns
    -------
    StreamReport

    Raises
    ------
    DatasetError
        ``out`` exists and is not empty, or cannot be written.
    HandEyeInputError
        A bad preset, size or worker count; events that collide (:func:`sim.stream_timeline.build_timeline`).
    """
    from handeye.robot.model import load_robot

    t0 = time.perf_counter()
    preset = get_stream_preset(preset) if isinstance(preset, str) else preset
    overrides = overrides or StreamOverrides()
    size = None if overrides.image_size is None else tuple(overrides.image_size)
    changes = {"minutes": overrides.minutes, "rate_hz": overrides.rate_hz, "image_size": size}
    changes = {k: v for k, v in changes.items() if v is not None}
    if sensor is not None:
        changes["sensor"] = sensor if isinstance(sensor, str) else sensor.name
    preset = replace(preset, **changes)
    sensor = sensor_profile(preset.sensor) if sensor is None or isinstance(sensor, str) else sensor
    if isinstance(workers, bool) or not isinstance(workers, int) or workers < 1:
        raise HandEyeInputError(f"workers must be an integer >= 1, got {workers!r}")
    out = Path(out)
    if out.is_dir() and any(out.iterdir()):
        raise DatasetError(f"{out}: exists and is not an empty folder; choose a new --out")
    out = dataset_folder(out)
    timeline = build_timeline(preset, seed, load_robot(preset.robot))
    truth = draw_systematic(sensor, seed, 0)
    meta = stream_meta(preset, seed, sensor, len(timeline.T_base_cam))
    config = {
        "robot": preset.robot,
        "K": camera_matrix(*preset.image_size, preset.fov_deg).tolist(),
        "image_size": tuple(preset.image_size),
        "sensor": sensor,
        "sensor_truth": truth,
        "pixel_sigma": preset.pixel_sigma,
        "seed": int(seed),
        "depth_scale_m": DEPTH_SCALE_M,
        "out": str(out.resolve()),
    }
    with dataset_lock(out, "handeye sim stream"):
        write_json_atomic(out / "meta.json", meta)
        _write_cameras(out, preset, timeline, sensor, truth)
        hidden = _render(out, config, timeline, min(workers, len(timeline.T_base_cam)), progress)
        doc = _stream_doc(preset, seed, sensor, timeline, hidden)
        write_json_atomic(out / "stream.json", doc)
    report = StreamReport(out, len(timeline), len(timeline.T_base_cam), len(doc["events"]))
    for event in doc["events"]:
        report.counts[event["type"]] = report.counts.get(event["type"], 0) + 1
    report.wall_s = time.perf_counter() - t0
    return report


def read_stream(root: str | Path) -> dict:
    """A stream dataset's ``stream.json`` (the truth a benchmark scores against).

    Raises
    ------
    DatasetError
        Missing (the stream was not finished) or not a stream file.
    """
    from handeye.core.jsonfile import read_json_file

    path = Path(root) / "stream.json"
    if not path.is_file():
        raise DatasetError(f"{path}: missing; not a finished stream (render one with 'handeye sim stream')")
    doc = read_json_file(path, DatasetError, "stream truth file")
    if not isinstance(doc, dict) or doc.get("format") != STREAM_FORMAT or doc.get("version") != STREAM_VERSION:
        raise DatasetError(f"{path}: not a {STREAM_FORMAT} version {STREAM_VERSION} file")
    return doc
