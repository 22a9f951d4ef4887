"""Markerless calibration of a dataset's camera placements: learned or given start, then the robot's surface.

Composes the engines: the dataset's depth frames and joints (:mod:`handeye.core.dataset`),
the robot's surface posed at each frame (:mod:`handeye.robot.surface`, a UR of the simulator or any
URDF), an optional learned start (:mod:`learned.experiment`), and the registration
(:func:`classic.markerless.register_robot`). Starts, in order: the learned prediction
(``model_dir``), the user's (``T_base_cam_start``), and always the start from the moving
pixels' centroids, which needs no prior.

Example
-------
>>> from handeye.markerless import markerless_dataset          # doctest: +SKIP
>>> out = markerless_dataset("data/small", cameras=[0, 1])     # doctest: +SKIP
>>> out.results[0].T_base_cam, out.results[0].sigma            # doctest: +SKIP
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from classic.markerless import MarkerlessOptions, MarkerlessResult, register_robot
from handeye.core.dataset import Dataset
from handeye.core.errors import DatasetError, HandEyeInputError, ShapeError
from handeye.core.metrics import pose_error
from handeye.core.se3 import transform_from_pos_quat_xyzw
from handeye.core.tables import markdown_table

__all__ = [
    "MarkerlessRun",
    "RobotURDF",
    "markerless_dataset",
    "calibrate_camera",
    "robot_surface_for",
    "read_start",
    "write_markerless_labels",
]


@dataclass
class MarkerlessRun:
    """Markerless results of a dataset's camera placements.

    Attributes
    ----------
    results : dict of int -> MarkerlessResult
    seconds : dict of int -> float
        Wall time per camera placement (registration, surface posing and image reading included).
    errors : dict of int -> (float, float)
        Against the truth, ``(deg, mm)``, where the truth is known and the result accepted.
    label_errors : dict of int -> (float, float)
        The classic label against the truth, same cameras, for comparison.
    starts : dict of int -> dict of str -> array (4, 4)
    intrinsics_priors : dict of int -> dict
        Where the camera's intrinsics were shared by its placements (:func:`share_intrinsics`): per camera, the
        prior its second pass took from the others
        (:meth:`classic.markerless.shared_intrinsics.SharedIntrinsicsPrior.to_dict`).
    """

    results: dict = field(default_factory=dict)
    seconds: dict = field(default_factory=dict)
    errors: dict = field(default_factory=dict)
    label_errors: dict = field(default_factory=dict)
    starts: dict = field(default_factory=dict)
    intrinsics_priors: dict = field(default_factory=dict)

    def record(self, c: int, res: MarkerlessResult, seconds: float, starts: dict, truth: np.ndarray) -> None:
        """Keep camera ``c``'s result, its wall time and starts, and its error against ``truth`` (4, 4; NaN where
        unknown) when accepted."""
        self.results[c], self.seconds[c], self.starts[c] = res, seconds, starts
        self.errors.pop(c, None)
        if res.ok and np.all(np.isfinite(truth)):
            self.errors[c] = tuple(float(x) for x in pose_error(res.T_base_cam, truth))

    def to_dict(self) -> dict:
        """JSON-serialisable: per camera, the result, its error against the truth and the label's."""
        out = {}
        for c, res in self.results.items():
            d = res.to_dict()
            d["seconds"] = self.seconds[c]
            if c in self.errors:
                d["error_vs_truth"] = {"deg": self.errors[c][0], "mm": self.errors[c][1]}
            if c in self.label_errors:
                d["label_error_vs_truth"] = {"deg": self.label_errors[c][0], "mm": self.label_errors[c][1]}
            if c in self.intrinsics_priors:
                d["intrinsics_prior"] = self.intrinsics_priors[c]
            out[str(c)] = d
        return {"cameras": out}

    def summary(self) -> str:
        """One line: accepted placements, and the median and worst error against the truth where it is known."""
        n_ok = sum(r.ok for r in self.results.values())
        line = f"accepted {n_ok} of {len(self.results)} placements in {sum(self.seconds.values()):.0f} s"
        for what, errs in (("markerless", self.errors), ("classic label", self.label_errors)):
            if errs:
                e = np.array(list(errs.values()))  # (deg, mm) per camera
                med, worst = np.median(e, axis=0), e.max(axis=0)
                line += (
                    f"; {what} vs truth over {len(e)}: median {med[1]:.3f} mm / {med[0]:.4f} deg, "
                    f"worst {worst[1]:.3f} mm / {worst[0]:.4f} deg"
                )
        return line

    def registration_note(self) -> str | None:
        """One line: how the depth-to-colour registration was treated (estimated or bounded), None without an
        accepted result."""
        reg = next((r.registration for r in self.results.values() if r.ok and r.registration), None)
        if not reg:
            return None
        shift, rot, trans = reg["shift_px"], reg["rotation"], reg["translation"]
        how = "estimated with the principal point" if shift["treatment"].startswith("estimated") else "taken as 0"
        return (
            f"depth-to-colour registration: image shift {how}; rotation bounded at {rot['sigma_deg']:g} deg and "
            f"translation at {trans['sigma_mm']:g} mm per axis, in the sigma (the depth cannot see them)"
        )

    def table(self) -> str:
        """Markdown: per camera, status, error against truth, sigma, the classic label's error."""
        rows = []
        for c, r in self.results.items():
            err = self.errors.get(c)
            lab = self.label_errors.get(c)
            rows.append(
                [
                    c,
                    "ok" if r.ok else "refused: " + r.refused,
                    r.start or "-",
                    f"{err[1]:.3f} / {err[0]:.4f}" if err else "-",
                    f"{r.sigma['translation_mm']:.3f} / {r.sigma['rotation_deg']:.4f}",
                    _depth_cell(r.depth),
                    _intrinsics_cell(r.intrinsics),
                    _joint_offsets_cell(r.joint_offsets),
                    f"{r.matched_fraction:.2f}",
                    f"{lab[1]:.3f} / {lab[0]:.4f}" if lab else "-",
                    f"{self.seconds[c]:.1f}",
                ]
            )
        return "\n".join(
            markdown_table(
                [
                    "camera",
                    "status",
                    "start",
                    "hybrid vs truth (mm / deg)",
                    "sigma (mm / deg)",
                    "depth scale, offset mm",
                    "intrinsics change px (fx fy cx cy)",
                    "joint offsets deg ± sigma",
                    "matched",
                    "classic label vs truth",
                    "s",
                ],
                rows,
            )
        )


def _depth_cell(depth: dict) -> str:
    """The estimated depth scale and offset with their sigmas, or '-' where not estimated."""
    if "scale" not in depth:
        return "-"
    return (
        f"{depth['scale']:.4f} ± {depth['scale_sigma']:.4f}, {depth['offset_mm']:+.2f} ± {depth['offset_sigma_mm']:.2f}"
    )


def _intrinsics_cell(intrinsics: dict) -> str:
    """The estimated change of fx, fy, cx, cy from the camera matrix given, pixels, with how many the frames
    determined (the others held near the given values by their prior, their uncertainty in the sigma); '-' where
    the intrinsics were taken as exact."""
    names = ("fx", "fy", "cx", "cy")
    if intrinsics.get("model") != "estimated" or not all(n in intrinsics for n in names):
        return "-"
    changes = " ".join(f"{intrinsics[n]['change']:+.1f}" for n in names)
    determined = sum(bool(intrinsics[n]["determined"]) for n in names)
    return f"{changes} ({determined} of 4 determined)"


def _joint_offsets_cell(joint_offsets: dict) -> str:
    """Each joint's estimated zero offset, degrees, with its sigma: ``*`` where the frames determined it, ``abs``
    where it is part of the pose (the base rotation: the pose is then the camera in the kinematic base frame),
    ``-`` where no fitted part moves with it; '-' where the joints were taken as exact."""
    if joint_offsets.get("model") != "estimated":
        return "-"
    cells = []
    for row in joint_offsets.get("joints", []):
        if row["status"] == "absorbed":
            cells.append(f"J{row['joint']} abs")
        elif row["status"] != "estimated":
            cells.append(f"J{row['joint']} -")
        else:
            mark = "*" if row["determined"] else ""
            cells.append(f"J{row['joint']} {row['estimate_deg']:+.3f}±{row['sigma_deg']:.3f}{mark}")
    return " ".join(cells)


def robot_surface_for(
    ds: Dataset,
    urdf: str | Path | None = None,
    package_dirs=(),
    ee_frame: str = "tool0",
    zbuffer_stride: int | None = None,
):
    """The robot surface sampler for a dataset's camera, and the z-buffer stride it was sampled for.

    The spacing is 0.7 of the pixel footprint at 0.8 m times the stride; the stride is 1 up to
    160 pixels of width and 2 beyond (the fine stage then uses a quarter of the pixels).
    """
    from handeye.robot.surface import RobotSurface, spacing_for_camera
    from handeye.robot_model import dataset_robot

    robot = dataset_robot(ds, urdf, package_dirs, ee_frame)
    K = np.array(ds.meta["intrinsics"]["K"], dtype=float)
    width = int(ds.meta["intrinsics"]["width"])
    stride = zbuffer_stride or (1 if width <= 160 else 2)
    return RobotSurface(robot, spacing_m=spacing_for_camera(K, 0.8) * stride), stride


def read_start(path: str | Path) -> np.ndarray:
    """A start ``T_base_cam`` from JSON: ``{"T_base_cam": 4x4}`` or translation (m) and quaternion (x, y, z, w).

    Raises
    ------
    HandEyeInputError
        Missing or unreadable file, or neither form (naming the file).
    """
    from handeye.core.jsonfile import read_json_file
    from handeye.core.numbers import float_array
    from handeye.core.validation import check_transforms

    path = Path(path)
    if not path.exists():
        raise HandEyeInputError(f"{path}: no such start file")
    doc = read_json_file(path, HandEyeInputError, "start file")  # a FIFO or device is named as such there
    doc = doc.get("T_base_cam", doc) if isinstance(doc, dict) else doc
    expected = (
        f'{path}: expected {{"T_base_cam": 4x4 matrix}} or {{"translation_m": [x, y, z], '
        f'"quaternion_xyzw": [x, y, z, w]}}'
    )
    if isinstance(doc, dict):
        if "translation_m" not in doc or "quaternion_xyzw" not in doc:
            raise HandEyeInputError(expected)
        t = float_array(doc["translation_m"], f"{path}: translation_m", HandEyeInputError)
        q = float_array(doc["quaternion_xyzw"], f"{path}: quaternion_xyzw", HandEyeInputError)
        if t.shape != (3,) or q.shape != (4,):
            raise HandEyeInputError(expected)
        norm = float(np.linalg.norm(q))
        if norm < 1e-6:  # normalising would divide by zero: it is no rotation at all, not "NaN or infinity"
            raise HandEyeInputError(f"{path}: quaternion_xyzw {q.tolist()} is a zero quaternion, not a rotation")
        T = transform_from_pos_quat_xyzw(t, q)  # normalised there, as before
    else:
        T = float_array(doc, f"{path}: T_base_cam", HandEyeInputError)
        if T.shape != (4, 4):
            raise HandEyeInputError(expected)
    return check_transforms(T, f"{path}: T_base_cam")[0]


def calibrate_camera(
    ds: Dataset,
    camera_id: int,
    surface,
    starts: dict | None = None,
    options: MarkerlessOptions | None = None,
    frames: slice | np.ndarray | None = None,
    K: np.ndarray | None = None,
    depth_analysis=None,
) -> MarkerlessResult:
    """Markerless ``T_base_cam`` of one camera placement from its data recording.

    Parameters
    ----------
    ds : Dataset
    camera_id : int
    surface : handeye.robot.surface.RobotSurface
    starts : dict of str -> array (4, 4), optional
    options : MarkerlessOptions, optional
    frames : index into the data frames, optional
        A subset (for example the first 10).
    K : array, shape (3, 3), optional
        The camera matrix the intrinsics' prior is centred on; the dataset's (``meta.json``) by default.
    depth_analysis : classic.markerless.depth_analysis.DepthAnalysis, optional
        An earlier registration's of the same frames (``register_robot``'s).

    Raises
    ------
    DatasetError
        No data frames with depth in this camera's shard.
    """
    t = ds.select(camera_id, "data")
    rel = t["depth"] if frames is None else t["depth"][frames]
    q = ds.joints(t) if frames is None else ds.joints(t)[frames]
    if len(rel) == 0 or any(not r for r in rel):
        raise DatasetError(f"{ds.shard_dir(camera_id) / 'frames.csv'}: no data frames with depth")
    if not np.isfinite(q).all():
        raise DatasetError(
            f"{ds.shard_dir(camera_id) / 'frames.csv'}: data frames without joint angles (imported from tf?); the "
            "robot's surface is posed from them: import the joint states too"
        )
    depth = np.stack([ds.depth_m(camera_id, r) for r in rel])
    K = np.array(ds.meta["intrinsics"]["K"] if K is None else K, dtype=float)
    w, h = int(ds.meta["intrinsics"]["width"]), int(ds.meta["intrinsics"]["height"])
    if depth.shape[1:] != (h, w):
        raise ShapeError(
            f"{ds.shard_dir(camera_id) / rel[0]}: depth is {depth.shape[2]}x{depth.shape[1]}, the "
            f"intrinsics in meta.json are for {w}x{h}"
        )
    return register_robot(depth, K, surface.posed(q), starts=starts, options=options, depth_analysis=depth_analysis)


def learned_starts(ds_root: Path, model_dir: Path, cameras: list[int]) -> dict:
    """The learned ``T_base_cam`` of each camera (``handeye learned run``'s saved networks).

    A directory with ``keypoints.pt`` holds the keypoint model (its cross-frame fit is the start);
    otherwise ``translation.pt`` and ``orientation.pt`` (the frames' predictions averaged).
    """
    from learned.experiment import camera_pose_prediction, load_model

    model_dir = Path(model_dir)
    out = {}
    if (model_dir / "keypoints.pt").is_file():
        from handeye.learned_frames import load_keypoint_frames
        from learned.keypoints import camera_pose, model_residual_stats
        from learned.trainer import predict

        model = load_model(model_dir / "keypoints.pt")
        stats = model_residual_stats(model)
        frames = load_keypoint_frames(ds_root, model.config.image_size, "none", progress=False)
        for c in cameras:
            idx = np.flatnonzero(frames.camera == c)
            out[c], _ = camera_pose(
                predict(model, frames, idx), frames.keypoints_base[idx], frames.intrinsics_norm[idx], stats=stats
            )
        return out
    from learned.data import load_frames

    t_model = load_model(model_dir / "translation.pt")
    q_model = load_model(model_dir / "orientation.pt")
    frames = load_frames(ds_root, t_model.config.image_size, "none", progress=False)
    for c in cameras:
        t_mm, q = camera_pose_prediction(t_model, q_model, frames, c)
        out[c] = transform_from_pos_quat_xyzw(t_mm / 1000.0, q)
    return out


@dataclass(frozen=True)
class RobotURDF:
    """Another robot than the dataset's own (``meta["robot"]``): a URDF with meshes.

    Attributes
    ----------
    path : str or Path
        The URDF file.
    package_dirs : sequence of str or Path
        Folders its ``package://`` mesh paths resolve in.
    """

    path: str | Path
    package_dirs: tuple = ()


def markerless_dataset(
    root: str | Path,
    cameras: list[int] | None = None,
    model_dir: str | Path | None = None,
    T_base_cam_start: np.ndarray | None = None,
    *,
    urdf: RobotURDF | None = None,
    options: MarkerlessOptions | None = None,
    progress: bool = False,
    frames=None,
) -> MarkerlessRun:
    """Markerless calibration of camera placements of a dataset.

    Parameters
    ----------
    root : str or Path
        Dataset directory.
    cameras : list of int, optional
        Camera placements; all by default.
    model_dir : path, optional
        A learned model (``translation.pt``, ``orientation.pt``): its prediction is the first start.
    T_base_cam_start : array, shape (4, 4), optional
        A start of the user's (a tape-measure guess).
    urdf : RobotURDF, optional
        Another robot than the dataset's UR: its URDF and mesh folders.
    options : MarkerlessOptions, optional
    progress : bool
    frames : index, optional
        Use only these data frames of each camera.

    Returns
    -------
    MarkerlessRun
    """
    ds = Dataset.open(root)
    cameras = list(range(len(ds))) if cameras is None else [int(c) for c in cameras]
    for c in cameras:
        if not 0 <= c < len(ds):
            raise DatasetError(f"{ds.root}: no camera {c} (the dataset has 0..{len(ds) - 1})")
    surface, stride = robot_surface_for(ds, *((urdf.path, urdf.package_dirs) if urdf else ()))
    opts = options or MarkerlessOptions()
    if opts.zbuffer_stride != stride:
        from dataclasses import replace

        opts = replace(opts, zbuffer_stride=stride)
    learned = learned_starts(ds.root, Path(model_dir), cameras) if model_dir else {}
    truth = ds.truth()
    labels = ds.labels() if "T_base_cam_label.x" in ds.cameras() else None
    run = MarkerlessRun()
    iterator = cameras
    if progress:
        from tqdm import tqdm

        iterator = tqdm(cameras, desc=f"markerless {ds.root.name}", unit="camera")
    for c in iterator:
        starts = {}
        if c in learned:
            starts["learned"] = learned[c]
        if T_base_cam_start is not None:
            starts["user"] = np.asarray(T_base_cam_start, dtype=float)
        t0 = time.perf_counter()
        res = calibrate_camera(ds, c, surface, starts, opts, frames)
        run.record(c, res, time.perf_counter() - t0, starts, truth[c])
        if labels is not None and np.all(np.isfinite(labels[c])) and np.all(np.isfinite(truth[c])):
            run.label_errors[c] = tuple(float(x) for x in pose_error(labels[c], truth[c]))
    return run


def write_markerless_labels(root: str | Path, run: MarkerlessRun, lock_wait_s: float | None = None) -> Path:
    """Write the accepted results as the dataset's markerless labels (``cameras.csv``, other columns kept).

    Cameras not in ``run`` keep the markerless label they had (or get none); a refused camera gets a NaN
    pose and ``markerless_status`` ``refused: <reason>``. ``cameras.csv`` is read, updated and written
    under the dataset's lock (:func:`handeye.core.dataset.dataset_lock`), so the label columns another
    writer wrote meanwhile are kept.

    Parameters
    ----------
    root : str or Path
    run : MarkerlessRun
    lock_wait_s : float, optional
        How long to wait for another writer (``handeye label``) before refusing; None:
        :data:`handeye.core.dataset.LABEL_LOCK_WAIT_S`.

    Returns
    -------
    Path
        The camera table written.
    """
    from handeye.core.dataset import LABEL_LOCK_WAIT_S, dataset_lock

    root = Dataset.open(root).root
    # read, changed and written under the lock: a label run writing cameras.csv meanwhile keeps its columns
    wait_s = LABEL_LOCK_WAIT_S if lock_wait_s is None else lock_wait_s
    with dataset_lock(root, "handeye markerless --write-labels", wait_s=wait_s):
        return _write_markerless_columns(Dataset.open(root), run)


def _write_markerless_columns(ds: Dataset, run: MarkerlessRun) -> Path:
    """The camera table read now, its markerless columns replaced by ``run``'s, written (under the lock)."""
    from handeye.core.dataset import (
        MARKERLESS_COLUMNS,
        camera_table_columns,
        pose_columns,
        poses_to_columns,
        write_table,
    )

    cams = dict(ds.cameras())
    n = len(ds)
    if "T_base_cam_markerless.x" not in cams:
        for col in MARKERLESS_COLUMNS:
            cams[col] = np.array([""] * n, dtype=object) if col == "markerless_status" else np.full(n, np.nan)
    cols = {c: np.array(cams[c], dtype=object if c == "markerless_status" else float) for c in MARKERLESS_COLUMNS}
    for c, res in run.results.items():
        pose = (
            poses_to_columns("T_base_cam_markerless", res.T_base_cam[None])
            if res.ok
            else {k: [np.nan] for k in pose_columns("T_base_cam_markerless")}
        )
        for k, v in pose.items():
            cols[k][c] = v[0]
        cols["markerless_status"][c] = "ok" if res.ok else f"refused: {res.refused}"
        cols["markerless_sigma_rot_deg"][c] = res.sigma["rotation_deg"] if res.ok else np.nan
        cols["markerless_sigma_trans_mm"][c] = res.sigma["translation_mm"] if res.ok else np.nan
        err = run.errors.get(c, (np.nan, np.nan))
        cols["markerless_error_rot_deg"][c], cols["markerless_error_trans_mm"][c] = err
    cams.update(cols)
    write_table(ds.cameras_path, cams, camera_table_columns(cams))
    return ds.cameras_path
