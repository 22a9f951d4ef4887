"""Generate a dataset: per camera pose a calibration recording and a data recording, in shards.

Each camera pose is one shard, rendered by one worker process
(:class:`handeye.core.pool.PoolEngine`) and written by
:class:`handeye.core.shard_writer.ShardWriter` into ``cam_XXXX.partial``,
renamed when complete (:mod:`handeye.core.dataset`).
Everything a shard holds is drawn from ``default_rng([seed, camera_id])``, so
a shard regenerated on resume is identical to the one a crash interrupted,
whichever worker renders it. Resuming skips complete shards and regenerates
half-written ones.

Noise (optional, a sensor model applied to what is recorded, never to the
truth): Gaussian pixel noise on colour, depth noise growing with the square
of the depth, joint-encoder noise on the recorded joint angles (the recorded
``T_base_ee`` and ``T_base_ref`` are the forward kinematics of the noisy
readings, as a controller reports them; the rendering uses the true joints).
"""

from __future__ import annotations

import json
import os
import time
from collections.abc import Sequence
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path

import numpy as np

from handeye.core.dataset import (
    FORMAT,
    FORMAT_VERSION,
    camera_table_columns,
    dataset_lock,
    poses_to_columns,
    write_json_atomic,
    write_table,
)
from handeye.core.engines import EngineOptions, check_engine, require_visible, run_tasks
from handeye.core.errors import DatasetError, HandEyeInputError
from handeye.core.jsonfile import read_json_file
from handeye.core.se3 import invert_transform
from handeye.core.shard_writer import ShardWriter
from handeye.robot.depth_sensors import DepthSensor, sensor_profile
from sim.cameras import CameraPreset, get_preset, place_cameras
from sim.recording import DEFAULT_BOARD, board_mount, camera_matrix, sample_calibration_view, sample_data_configuration
from sim.sensors import apply_sensor, draw_systematic, truth_columns

__all__ = [
    "NoiseModel",
    "DEFAULT_NOISE",
    "DEPTH_SCALE_M",
    "GenerationReport",
    "Recipe",
    "ShardRenderer",
    "generate",
    "dataset_meta",
    "write_camera_table",
    "dataset_folder",
    "recorded_robot_columns",
]

#: Depth PNG unit: 0.1 mm, so 16 bits cover 6.5 m.
DEPTH_SCALE_M = 1e-4
#: A board corner counts as visible when the rendered depth at its pixel is this close to the board's.
OCCLUSION_TOLERANCE_M = 0.005


@dataclass(frozen=True)
class NoiseModel:
    """Sensor noise applied to what is recorded.

    Attributes
    ----------
    pixel_sigma : float
        Gaussian noise on each colour channel, grey levels (0-255).
    depth_sigma_m_at_1m : float
        Depth noise sigma at 1 m; it grows with the square of the depth (structured-light and
        stereo sensors).
    joint_sigma_deg : float
        Joint-encoder noise on each recorded joint angle, degrees.
    """

    pixel_sigma: float = 0.0
    depth_sigma_m_at_1m: float = 0.0
    joint_sigma_deg: float = 0.0

    def __post_init__(self):
        for name, value in asdict(self).items():
            if not np.isfinite(value) or value < 0:
                raise HandEyeInputError(f"noise {name} must be a finite value >= 0, got {value}")


#: The default noise options: an 8-bit camera's noise, a 1 mm-at-1 m depth sensor, 0.01 deg encoders.
DEFAULT_NOISE = NoiseModel(pixel_sigma=2.0, depth_sigma_m_at_1m=0.001, joint_sigma_deg=0.01)


@dataclass
class GenerationReport:
    """What :func:`generate` did.

    Attributes
    ----------
    out : Path
    rendered : list of int
        Camera ids rendered by this call.
    skipped : list of int
        Complete shards found and kept.
    regenerated : list of int
        Shards found half-written and rendered again (a subset of ``rendered``).
    frames : int
        Frames rendered by this call.
    wall_s : float
    left : int
        Camera poses of the preset still without a complete shard (a call with ``cameras`` renders a part).
    """

    out: Path
    rendered: list = field(default_factory=list)
    skipped: list = field(default_factory=list)
    regenerated: list = field(default_factory=list)
    frames: int = 0
    wall_s: float = 0.0
    left: int = 0

    def summary(self) -> str:
        fps = self.frames / self.wall_s if self.wall_s > 0 else float("nan")
        text = (
            f"{self.out}: rendered {len(self.rendered)} camera poses ({self.frames} frames, {self.wall_s:.1f} s, "
            f"{fps:.1f} frames/s), kept {len(self.skipped)} complete"
        )
        if self.regenerated:
            text += f", regenerated half-written {self.regenerated}"
        if self.left:
            text += f"; {self.left} camera poses still to render (run again without --cameras)"
        return text


def dataset_meta(
    preset: CameraPreset,
    seed: int,
    noise: NoiseModel,
    recordings: tuple[str, ...],
    marker_radius_m: float | None = None,
    sensor: DepthSensor | None = None,
) -> dict:
    """The ``meta.json`` of a simulated dataset (everything needed to regenerate it).

    Parameters
    ----------
    preset : CameraPreset
    seed : int
    noise : NoiseModel
    recordings : tuple of str
    marker_radius_m : float, optional
        A debugging sphere on the flange origin in data recordings (robot hidden).
    sensor : DepthSensor, optional
        The depth sensor profile (:mod:`sim.sensors`); its depth errors replace the noise's depth term.

    Returns
    -------
    dict
    """
    from classic.vision.board import BoardSpec
    from classic.vision.camera import CameraIntrinsics
    from handeye.robot.model import load_robot

    robot = load_robot(preset.robot)

    def intrinsics(size):  # the simulated camera: a pinhole without distortion
        return CameraIntrinsics(camera_matrix(*size, preset.fov_deg), np.zeros(5), *size).to_dict()

    meta = {
        "format": FORMAT,
        "version": FORMAT_VERSION,
        "robot": preset.robot,
        "n_joints": robot.nq,
        "joint_names": [str(n) for n in list(robot.model.names)[1:]],
        "T_ee_ref": robot.T_ee_ref.tolist(),
        "intrinsics": intrinsics(preset.image_size),
        "calibration_intrinsics": intrinsics(preset.calibration_image_size),
        "depth": {
            "format": "png16",
            "scale_m": DEPTH_SCALE_M,
            "invalid": 0,
            "quantity": "z coordinate in the camera frame (not the ray length)",
        },
        "board": dict(DEFAULT_BOARD),
        "T_ee_target_true": board_mount(BoardSpec(**DEFAULT_BOARD).size_m).tolist(),
        "cameras": preset.n_cameras,
        "regions": len(preset.region_azimuths_deg),
        "recordings": list(recordings),
        "conventions": "T_a_b maps frame b to frame a; metres, radians; quaternions x,y,z,w; camera frame OpenCV "
        "(x right, y down, z forward); eye-to-hand: label X = T_base_cam",
        "recipe": {
            "generator": "handeye sim generate",
            "preset": preset.to_dict(),
            "seed": int(seed),
            "noise": asdict(noise),
            "marker_radius_m": marker_radius_m,
            "sensor": None if sensor is None else sensor.to_dict(),
        },
    }
    return json.loads(json.dumps(meta))  # as it reads back from the file (tuples become lists)


def _camera_table(cams, sensor: DepthSensor | None = None, seed: int = 0) -> dict:
    table = {
        "camera_id": np.arange(len(cams)),
        "region": cams.region,
        "split": cams.split,
        "azimuth_deg": cams.azimuth_deg,
        "elevation_deg": cams.elevation_deg,
        "radius_m": cams.radius_m,
    }
    table.update(poses_to_columns("T_base_cam_true", cams.T_base_cam))
    if sensor is not None:
        table.update(truth_columns(sensor, [draw_systematic(sensor, seed, c) for c in range(len(cams))]))
    return table


def write_camera_table(path: Path, table: dict) -> None:
    """``cameras.csv`` of a simulated dataset, in :func:`handeye.core.dataset.camera_table_columns`' order."""
    write_table(path, table, camera_table_columns(table))


# ------------------------------------------------------------------ worker


class ShardRenderer:
    """One process's robot and renderers (the OpenGL context lives and dies with the process).

    :func:`generate`'s workers hold one each; ``benchmarks/dense_sim_cost.py`` times one in its own process.

    Parameters
    ----------
    meta : dict
        The dataset's metadata (:func:`dataset_meta`), its recipe included.
    """

    def __init__(self, meta: dict):
        from classic.vision.board import BoardSpec
        from classic.vision.camera import CameraIntrinsics
        from handeye.robot.model import load_robot
        from sim.lab import T_base_lab, camera_scene
        from sim.render import Renderer, SceneContents

        self._T_base_lab, self._camera_scene = T_base_lab, camera_scene
        self.meta = meta
        recipe = meta["recipe"]
        self.preset = CameraPreset.from_dict(recipe["preset"])
        self.noise = NoiseModel(**recipe["noise"])
        self.sensor = None if recipe.get("sensor") is None else DepthSensor.from_dict(recipe["sensor"])
        self.robot = load_robot(meta["robot"])
        self.cams = place_cameras(self.preset, np.random.default_rng(recipe["seed"]))
        self.spec = BoardSpec(**meta["board"])
        self.T_ee_target = np.array(meta["T_ee_target_true"])
        self.K_data = np.array(meta["intrinsics"]["K"])
        self.intr_cal = CameraIntrinsics.from_dict(meta["calibration_intrinsics"])
        self.K_cal = self.intr_cal.K
        self.size_data = self.preset.image_size
        self.size_cal = self.preset.calibration_image_size
        marker = recipe.get("marker_radius_m")
        self.renderers = {}
        if "data" in meta["recordings"]:
            drawn = SceneContents(marker_radius_m=marker, robot_visible=marker is None, gripper=marker is None)
            self.renderers["data"] = Renderer(self.robot, self.K_data, *self.size_data, drawn)
        if "calibration" in meta["recordings"]:
            drawn = SceneContents(gripper=False, board=(self.spec, self.T_ee_target))
            self.renderers["calibration"] = Renderer(self.robot, self.K_cal, *self.size_cal, drawn)

    def _board_visible(self, depth_m: np.ndarray, T_base_cam: np.ndarray, T_base_target: np.ndarray) -> bool:
        """Whether the rendered depth shows the board (not the arm) at every projected corner."""
        from classic.vision.detect import project_points

        T_cam_target = invert_transform(T_base_cam) @ T_base_target
        p_target = self.spec.corners_target()
        z_cam = (p_target @ T_cam_target[:3, :3].T + T_cam_target[:3, 3])[:, 2]
        u, v = np.rint(project_points(p_target, T_cam_target, self.intr_cal)).astype(int).T
        inside = (u >= 0) & (u < depth_m.shape[1]) & (v >= 0) & (v < depth_m.shape[0])
        if not inside.all():
            return False
        return bool(np.all(np.abs(depth_m[v, u] - z_cam) < OCCLUSION_TOLERANCE_M))

    def _noisy_rgb(self, rgb: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        if self.noise.pixel_sigma == 0:
            return rgb
        return np.clip(np.rint(rgb + rng.normal(scale=self.noise.pixel_sigma, size=rgb.shape)), 0, 255).astype(np.uint8)

    def _noisy_depth(self, depth: np.ndarray, rng: np.random.Generator, camera_id: int, rgb: np.ndarray) -> np.ndarray:
        if self.sensor is not None:
            truth = draw_systematic(self.sensor, self.meta["recipe"]["seed"], camera_id)
            return apply_sensor(depth, self.K_data, self.sensor, truth, rng, rgb=rgb)
        if self.noise.depth_sigma_m_at_1m == 0:
            return depth
        noisy = depth + rng.normal(size=depth.shape) * self.noise.depth_sigma_m_at_1m * depth**2
        return np.where(depth > 0, np.maximum(noisy, 0.0), 0.0)

    def _recorded_joints(self, q: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        return q + rng.normal(scale=np.radians(self.noise.joint_sigma_deg), size=q.shape)

    def render_shard(self, camera_id: int, out: Path) -> int:
        """Render one camera pose's shard into ``out`` atomically; returns the number of frames."""
        with ShardWriter(out, camera_id, n_joints=self.robot.nq, depth_scale_m=DEPTH_SCALE_M) as shard:
            return self._render_into(shard, camera_id)

    def _render_into(self, shard: ShardWriter, camera_id: int) -> int:
        rng = np.random.default_rng([self.meta["recipe"]["seed"], camera_id])
        noise_rng = np.random.default_rng([self.meta["recipe"]["seed"], camera_id, 1])
        T_base_cam = self.cams.T_base_cam[camera_id]
        T_base_lab = self._T_base_lab(self._camera_scene(camera_id, self.preset.scenes))  # identity: one scene
        for renderer in self.renderers.values():
            renderer.set_environment_pose(T_base_lab)
        rows = []  # (recording, q_true, rgb_rel, depth_rel)
        counts = {}
        if "calibration" in self.renderers:
            renderer = self.renderers["calibration"]
            n, tries = 0, 0
            while n < self.preset.calibration_views and tries < 4 * self.preset.calibration_views:
                tries += 1
                view = sample_calibration_view(
                    self.robot, T_base_cam, self.K_cal, self.size_cal, self.T_ee_target, self.spec.size_m, rng
                )
                rgb, depth = renderer.render(view.q, T_base_cam)
                if not self._board_visible(depth, T_base_cam, view.T_base_target):
                    continue  # the arm hides part of the board: draw another view
                rel = shard.write_rgb(f"calibration_{n:03d}", self._noisy_rgb(rgb, noise_rng))
                rows.append(("calibration", view.q, rel, ""))
                n += 1
            counts["calibration"] = n
        if "data" in self.renderers:
            renderer = self.renderers["data"]
            for k in range(self.preset.configurations):
                q = sample_data_configuration(self.robot, T_base_cam, self.K_data, self.size_data, rng)
                rgb, depth = renderer.render(q, T_base_cam)
                rel_rgb = shard.write_rgb(f"data_{k:03d}", self._noisy_rgb(rgb, noise_rng))
                rel_depth = shard.write_depth(f"data_{k:03d}", self._noisy_depth(depth, noise_rng, camera_id, rgb))
                rows.append(("data", q, rel_rgb, rel_depth))
            counts["data"] = self.preset.configurations
        q_rec = np.array([self._recorded_joints(r[1], noise_rng) for r in rows]).reshape(-1, self.robot.nq)
        table = {
            "frame": np.arange(len(rows)),
            "camera_id": np.full(len(rows), camera_id),
            "region": np.full(len(rows), self.cams.region[camera_id]),
            "split": np.array([self.cams.split[camera_id]] * len(rows), dtype=object),
            "recording": np.array([r[0] for r in rows], dtype=object),
            "rgb": np.array([r[2] for r in rows], dtype=object),
            "depth": np.array([r[3] for r in rows], dtype=object),
        }
        table.update(recorded_robot_columns(self.robot, q_rec))
        shard.write_frames(table, counts)
        return len(rows)


def recorded_robot_columns(robot, q_recorded: np.ndarray) -> dict:
    """A shard's robot columns as a controller reports them: the recorded joints, their forward kinematics.

    Parameters
    ----------
    robot : handeye.robot.model.Robot
    q_recorded : array, shape (N, nq)
        The encoders' readings (noise included), radians.

    Returns
    -------
    dict
        ``q0`` ... ``q{nq-1}`` and the pose columns of ``T_base_ee`` and ``T_base_ref`` (metres).
    """
    table = {f"q{j}": q_recorded[:, j] for j in range(robot.nq)}
    T_base_ee = robot.fk(q_recorded)
    table.update(poses_to_columns("T_base_ee", T_base_ee))
    table.update(poses_to_columns("T_base_ref", T_base_ee @ robot.T_ee_ref))
    return table


_WORKER: ShardRenderer | None = None


def _init_worker(meta: dict) -> None:
    global _WORKER
    os.environ.setdefault("PYOPENGL_PLATFORM", "egl")
    _WORKER = ShardRenderer(meta)


def _work(args) -> tuple[int, int]:
    camera_id, out = args
    require_visible(Path(out) / "meta.json")  # a Ray worker on a machine that does not share the folder
    return camera_id, _WORKER.render_shard(camera_id, Path(out))


def _describe(args) -> str:
    camera_id, out = args
    return f"render camera {camera_id} of {out}"


# ------------------------------------------------------------------ driver


def _check_or_write_meta(out: Path, meta: dict) -> None:
    path = out / "meta.json"
    if path.exists():
        old = read_json_file(path, DatasetError, "dataset meta file (remove it or choose another --out)")
        if not isinstance(old, dict):
            raise DatasetError(
                f"{path}: not a dataset meta file (a JSON object is needed); remove it or choose another --out"
            )
        if old.get("recipe") != meta["recipe"] or old.get("recordings") != meta["recordings"]:
            recipe = old.get("recipe", {})
            differ = [k for k in meta["recipe"] if recipe.get(k) != meta["recipe"][k]]
            if old.get("recordings") != meta["recordings"]:
                differ.append("recordings")
            raise DatasetError(
                f"{path}: a dataset generated with other options (preset "
                f"{recipe.get('preset', {}).get('name')!r}, seed {recipe.get('seed')!r}; differing: "
                f"{', '.join(differ)}); resume it with the same options or choose another --out"
            )
        return
    write_json_atomic(path, meta)


@dataclass(frozen=True)
class Recipe:
    """What a simulated dataset is made of: everything :func:`generate` needs to make it again.

    ``meta.json`` records it (its ``recipe`` and ``recordings``); a dataset is resumed only with the same one.

    Attributes
    ----------
    preset : str or CameraPreset
        ``"paper-sim"``, ``"paper-real"``, ``"small"`` or a custom preset.
    seed : int
    noise : NoiseModel, optional
        None for none.
    recordings : tuple of {"calibration", "data"}
    marker_radius_m : float, optional
        Debugging: data recordings show only a sphere on the flange origin (and the lab).
    sensor : DepthSensor or str, optional
        A depth sensor profile (:data:`handeye.robot.depth_sensors.PROFILES` by name, or a
        :class:`handeye.robot.depth_sensors.DepthSensor`):
        the depth as that camera would report it, with a scale, offset and extrinsic error drawn per placement
        and recorded in ``cameras.csv`` (``depth_scale_true`` ...). It replaces the noise's depth term, which
        must then be 0. None: the noise's depth term alone.
    """

    preset: str | CameraPreset = "small"
    seed: int = 0
    noise: NoiseModel | None = None
    recordings: tuple[str, ...] = ("calibration", "data")
    marker_radius_m: float | None = None
    sensor: DepthSensor | str | None = None

    def resolved(self) -> Recipe:
        """The same recipe with the preset and the sensor looked up by name and the noise given; checked.

        Raises
        ------
        HandEyeInputError
            Depth noise given twice (a sensor and the noise's depth term); recordings other than calibration
            and/or data.
        """
        preset = get_preset(self.preset) if isinstance(self.preset, str) else self.preset
        noise = self.noise or NoiseModel()
        sensor = sensor_profile(self.sensor) if isinstance(self.sensor, str) else self.sensor
        if sensor is not None and noise.depth_sigma_m_at_1m > 0:
            raise HandEyeInputError(
                f"depth noise given twice: the sensor {sensor.name!r} and depth_sigma_m_at_1m="
                f"{noise.depth_sigma_m_at_1m}; set the noise's depth term to 0"
            )
        bad = [r for r in self.recordings if r not in ("calibration", "data")]
        if bad or not self.recordings:
            raise HandEyeInputError(f"recordings must be calibration and/or data, got {list(self.recordings)}")
        return Recipe(preset, self.seed, noise, tuple(self.recordings), self.marker_radius_m, sensor)

    def meta(self) -> dict:
        """The dataset's ``meta.json`` (:func:`dataset_meta`) of a resolved recipe."""
        return dataset_meta(self.preset, self.seed, self.noise, self.recordings, self.marker_radius_m, self.sensor)


def generate(
    out: str | Path,
    recipe: Recipe | None = None,
    cameras: Sequence[int] | None = None,
    options: EngineOptions | None = None,
    engine: str = "pool",
    address: str | None = None,
) -> GenerationReport:
    """Render a dataset (or resume one): one shard per camera pose, one task per shard.

    Parameters
    ----------
    out : str or Path
        Dataset directory (created; an existing one with the same recipe is resumed).
    recipe : Recipe, optional
        Preset, seed, noise, recordings, marker and depth sensor; None: :class:`Recipe`'s defaults.
    cameras : sequence of int, optional
        Render only these camera poses (a part of a large preset; the rest stays to do, and a later call
        without ``cameras`` completes it). None: all.
    options : EngineOptions, optional
        Its ``workers`` (rendering processes, or Ray tasks in flight; None: 2, or every CPU of the Ray cluster at
        ``address``) and ``progress`` (a progress bar on stderr); the rest is set here (the tasks always run in
        worker processes). None: :class:`handeye.core.engine_protocol.EngineOptions`' defaults.
    engine : {"pool", "ray"}
        ``pool`` (default): processes on this machine; ``ray``: tasks on a Ray cluster (``handeye[cluster]``),
        each retried when its worker dies. Either way a shard is published whole or not at all, and the
        dataset is byte-identical.
    address : str, optional
        A running Ray cluster (``auto``, ``HOST:6379``, ``ray://HOST:10001``); None starts a local one.
        On several machines ``out`` must be a folder every node sees at the same path.

    Returns
    -------
    GenerationReport

    Raises
    ------
    HandEyeInputError
        A recipe :meth:`Recipe.resolved` refuses; an engine, worker count or camera out of range.
    DatasetError
        ``out`` holds a dataset made with other options, or cannot be created or written (a read-only
        folder, a full disk, an unopenable lock file): the path and the cause named; a rerun resumes.

    Notes
    -----
    The rendering workers die with this process, however it ends (``kill -9`` included: see
    :mod:`handeye.core.pool`), so none writes into ``out`` after the dataset's lock is released. With
    ``engine="ray"`` and a local cluster started for the call, Ray's own processes share this process's
    fate and its workers end with their raylet; on a standing cluster (``address``) Ray ends the tasks of
    a driver that died.
    """
    t0 = time.perf_counter()
    recipe = (recipe or Recipe()).resolved()
    options = options or EngineOptions()
    check_engine(engine, address, options.workers)
    cameras = _checked_cameras(cameras, recipe.preset)
    out = dataset_folder(Path(out))
    try:
        with dataset_lock(out, "handeye sim generate"):
            meta = recipe.meta()
            _check_or_write_meta(out, meta)
            _write_camera_table(out, recipe.preset, recipe.seed, recipe.sensor)
            report = _render(out, recipe.preset, meta, cameras, options, engine, address)
            report.wall_s = time.perf_counter() - t0
            return report
    except OSError as exc:  # a read or write the system refused (full disk, permissions, a vanished folder)
        raise _io_failure(out, exc) from None


def _checked_cameras(cameras: Sequence[int] | None, preset: CameraPreset) -> list[int] | None:
    """The camera ids asked for, sorted and without repeats, each checked to be one of the preset's."""
    if cameras is None:
        return None
    cameras = sorted({int(c) for c in cameras})
    if cameras and not (0 <= cameras[0] and cameras[-1] < preset.n_cameras):
        raise HandEyeInputError(
            f"cameras must lie in 0..{preset.n_cameras - 1} (preset {preset.name}), got {cameras[0]}..{cameras[-1]}"
        )
    return cameras


def dataset_folder(out: Path) -> Path:
    """``out`` created (with its parents) as the dataset's folder, or a :class:`DatasetError` saying why not."""
    if out.exists() and not out.is_dir():
        raise DatasetError(f"{out}: exists and is not a directory; choose another --out")
    blocking = next((p for p in out.parents if p.exists()), None)
    if blocking is not None and not blocking.is_dir():
        raise DatasetError(f"{out}: cannot be created, {blocking} is a file; choose another --out")
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise DatasetError(
            f"{out}: cannot create the dataset folder ({exc.strerror or exc}); choose a writable --out"
        ) from None
    return out


def _io_failure(out: Path, exc: OSError) -> DatasetError:
    """A failed read or write of a generation as one :class:`DatasetError` naming the path, cause and fix."""
    where = exc.filename if exc.filename is not None else out
    notes = "".join(f" ({note})" for note in getattr(exc, "__notes__", ()))
    return DatasetError(
        f"{where}: {exc.strerror or exc}{notes}; the complete shards of {out} are kept: fix the cause and run "
        "the same command again to resume"
    )


def _write_camera_table(out: Path, preset: CameraPreset, seed: int, sensor: DepthSensor | None) -> None:
    """``cameras.csv`` of the placements and their truths, unless a resumed generation wrote it already."""
    if not (out / "cameras.csv").exists():
        cams = place_cameras(preset, np.random.default_rng(seed))
        write_camera_table(out / "cameras.csv", _camera_table(cams, sensor, seed))


def _render(
    out: Path,
    preset: CameraPreset,
    meta: dict,
    cameras: Sequence[int] | None,
    options: EngineOptions,
    engine: str,
    address: str | None,
) -> GenerationReport:
    """The shards :func:`generate` renders under the dataset's lock: every missing or incomplete one of
    ``cameras`` (default all); ``wall_s`` is left to the caller."""
    report = GenerationReport(out)
    pending = []
    for c in range(preset.n_cameras) if cameras is None else cameras:
        shard = ShardWriter(out, c)
        if shard.complete:
            report.skipped.append(c)
            continue
        if shard.final.exists() or shard.partial.exists():
            report.regenerated.append(c)
        pending.append(c)
    # always in worker processes, even one (isolate): pyrender's EGL teardown (eglTerminate) breaks any other
    # context of the process, so the caller's process never holds one
    options = replace(
        options,
        desc=f"render {out.name}",
        unit="camera",
        initializer=_init_worker,
        initargs=(meta,),
        describe=_describe,
        isolate=True,
    )
    for c, n in run_tasks(_work, [(c, str(out.resolve())) for c in pending], options, engine, address):
        report.rendered.append(c)
        report.frames += n
    report.rendered.sort()
    if cameras is not None:
        report.left = sum(not ShardWriter(out, c).complete for c in range(preset.n_cameras))
    return report
