"""Label a dataset: the classic eye-to-hand calibration of every camera pose from its calibration recording.

Per camera pose: ChArUco detection and PnP on each calibration image (with
the recorded calibration intrinsics), the pose-based eye-to-hand solve
(closed form, Levenberg-Marquardt) and the corner-reprojection refinement
(:func:`handeye.image_calibration.calibrate_from_views`). The label
``T_base_cam``, its diagnostics and, where the truth is known, its error are
written to ``cameras.csv``; a report (``labels.md``) and a plot
(``label_errors.png``) next to it.

This is a pipeline module of the front: it imports ``classic`` lazily.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from handeye.core.dataset import (
    CAMERA_COLUMNS,
    LABEL_COLUMNS,
    LABEL_LOCK_WAIT_S,
    Dataset,
    camera_table_columns,
    dataset_lock,
    poses_to_columns,
    write_table,
)
from handeye.core.engines import EngineOptions, check_engine, require_visible, run_tasks
from handeye.core.errors import DatasetError, HandEyeInputError
from handeye.core.metrics import pose_error
from handeye.core.safe_write import check_output_path, write_figure_atomic, write_text_atomic
from handeye.core.tables import markdown_table

__all__ = [
    "LabelReport",
    "PAPER_REPEAT_SHARE",
    "paper_label",
    "label_camera",
    "LabelRunOptions",
    "label_dataset",
    "label_summary",
    "label_table_markdown",
    "plot_label_errors",
]


def _board_and_intrinsics(ds: Dataset):
    from classic.vision.board import BoardSpec
    from classic.vision.camera import CameraIntrinsics

    if "board" not in ds.meta:
        raise DatasetError(f"{ds.root / 'meta.json'}: no 'board' entry; labelling needs the calibration board")
    intr = ds.meta.get("calibration_intrinsics", ds.meta["intrinsics"])
    return BoardSpec(**ds.meta["board"]), CameraIntrinsics.from_dict(intr)


#: The share of the detected views each of the paper's repeated calibrations uses (:func:`paper_label`).
PAPER_REPEAT_SHARE = 0.8


def paper_label(T_base_ee: np.ndarray, T_cam_target: np.ndarray, method: str, repeats: int, seed: int = 0):
    """The seed paper's label: the closed form alone, "repeated at least five times", the repeats averaged.

    The paper calibrates each camera pose with Tsai's method repeated at least five times and does not say
    how the repeats differ or are combined. The reading here: each repeat solves the closed form (no
    refinement) on a random :data:`PAPER_REPEAT_SHARE` of the detected views, as another session of the same
    board would, and the label is their mean (translations averaged, rotations by the chordal mean).

    Parameters
    ----------
    T_base_ee, T_cam_target : array, shape (N, 4, 4)
        The detected views' flange and board poses.
    method : str
        The closed form (``"tsai"`` for the paper's).
    repeats : int
    seed : int

    Returns
    -------
    X : array, shape (4, 4)
        ``T_base_cam``.
    spread : tuple of float
        The repeats' RMS distance from their mean, degrees and millimetres (what the paper's repeats show).
    """
    import classic
    from handeye.core.se3 import make_transform, project_to_so3

    rng = np.random.default_rng(seed)
    n = len(T_base_ee)
    k = max(3, int(round(PAPER_REPEAT_SHARE * n)))
    Xs, no_refinement = [], classic.CalibrateOptions(refine=False)
    for _ in range(repeats):
        pick = np.sort(rng.choice(n, min(k, n), replace=False))
        res = classic.calibrate(
            T_base_ee[pick], T_cam_target[pick], setup="eye_to_hand", method=method, options=no_refinement
        )
        Xs.append(res.X)
    Xs = np.array(Xs)
    X = make_transform(project_to_so3(Xs[:, :3, :3].mean(axis=0)), Xs[:, :3, 3].mean(axis=0))  # chordal mean
    rot, trans = np.sqrt(np.mean(np.array([pose_error(x, X) for x in Xs]) ** 2, axis=0))
    return X, (float(rot), float(trans))


def label_camera(ds: Dataset, camera_id: int, method: str = "park", repeats: int = 0) -> tuple[dict, object]:
    """Calibrate one camera pose from its calibration recording.

    Parameters
    ----------
    ds : Dataset
    camera_id : int
    method : str
        Closed form of the pose-based solve.
    repeats : int
        0: this project's label (closed form, maximum likelihood, corner reprojection). At least 1: the seed
        paper's (:func:`paper_label`): the closed form alone, repeated, averaged; no sigma (the repeats share
        most of their views, so their spread says little of the error).

    Returns
    -------
    row : dict
        The :data:`handeye.core.dataset.LABEL_COLUMNS` values (NaN pose and a ``failed: ...`` status
        when the calibration is refused).
    calibration : handeye.image_calibration.ImageCalibration or None
    """
    from classic.vision.detect import detect_board, estimate_pose
    from classic.vision.views import View, Views
    from handeye.image_calibration import calibrate_from_views

    spec, intr = _board_and_intrinsics(ds)
    rows = ds.select(camera_id, "calibration")
    n = len(rows["frame"])
    views = []
    for rel in rows["rgb"]:
        det = detect_board(ds.rgb(camera_id, rel), spec)
        views.append(View(rel, det, estimate_pose(det, spec, intr)))
    out = {c: np.nan for c in LABEL_COLUMNS}
    out.update(label_views_total=n, label_views_used=0)
    try:
        if n == 0:
            raise HandEyeInputError("no calibration recording")
        if repeats:
            ok = [k for k, v in enumerate(views) if v.pose.ok]
            if len(ok) < 3:
                raise HandEyeInputError(f"{len(ok)} views with a board pose; at least 3 are needed")
            T_cam_target = np.array([views[k].pose.T_cam_target for k in ok])
            X, spread = paper_label(ds.poses(rows, "T_base_ee")[ok], T_cam_target, method, repeats, seed=camera_id)
            out.update(poses_to_columns("T_base_cam_label", X))
            out = {key: (v[0] if isinstance(v, np.ndarray) else v) for key, v in out.items()}
            # no sigma: the repeats share most of their views, so their spread says little of the error
            out.update(label_status="ok", label_views_used=len(ok))
            return _with_truth_error(out, ds, camera_id, X), None
        cal = calibrate_from_views(
            Views(views, spec, intr, ds.shard_dir(camera_id), "recorded"),
            ds.poses(rows, "T_base_ee"),
            "eye_to_hand",
            method=method,
        )
    except HandEyeInputError as exc:
        out["label_status"] = f"failed: {exc}".replace("\n", " ")
        return out, None
    out.update(poses_to_columns("T_base_cam_label", cal.X))
    out = {k: (v[0] if isinstance(v, np.ndarray) else v) for k, v in out.items()}
    rep = cal.reprojection
    out.update(
        label_status="ok",
        label_views_used=len(cal.images),
        label_rms_px=rep.rms_px,
        label_sigma_rot_deg=rep.sigma["X_rotation_deg"],
        label_sigma_trans_mm=rep.sigma["X_translation_mm"],
    )
    return _with_truth_error(out, ds, camera_id, cal.X), cal


def _with_truth_error(out: dict, ds: Dataset, camera_id: int, T_base_cam: np.ndarray) -> dict:
    """The label's error columns against the dataset's truth, where it has one."""
    T_base_cam_true = ds.truth()[camera_id]
    if np.isfinite(T_base_cam_true).all():
        rot, trans = pose_error(T_base_cam, T_base_cam_true)
        out.update(label_error_rot_deg=float(rot), label_error_trans_mm=float(trans))
    return out


@dataclass
class LabelReport:
    """What :func:`label_dataset` wrote.

    Attributes
    ----------
    root : Path
    table : dict
        The camera table with its label columns.
    wall_s : float
    """

    root: Path
    table: dict
    wall_s: float

    def summary(self) -> str:
        """Median and worst label error, failures."""
        return label_summary(self.table)

    def failed(self) -> list[tuple[int, str]]:
        """The camera placements whose label failed, with the reason: ``[(camera_id, status), ...]``."""
        return [(int(c), str(s)) for c, s in zip(self.table["camera_id"], self.table["label_status"]) if s != "ok"]


def _label_one(args):
    import cv2

    cv2.setNumThreads(1)
    root, camera_id, method, repeats = args
    require_visible(Path(root) / "meta.json")  # a Ray worker on a machine that does not share the folder
    return camera_id, label_camera(Dataset.open(root), camera_id, method, repeats)[0]


def _describe(args) -> str:
    root, camera_id, *_ = args
    return f"label camera {camera_id} of {root}"


@dataclass(frozen=True, kw_only=True)
class LabelRunOptions:
    """Where :func:`label_dataset` runs and how long it waits for the dataset.

    Attributes
    ----------
    engine : {"pool", "ray"}
        Where the camera poses are labelled, one task each (:func:`handeye.core.engines.run_tasks`).
    address : str, optional
        A running Ray cluster; None starts a local one. Every node must see the dataset at the same path.
    lock_wait_s : float
        How long to wait for another writer of the dataset (``handeye markerless --write-labels``) before
        refusing (:func:`handeye.core.dataset.dataset_lock`); the labels are computed first, then
        ``cameras.csv`` is read, updated and written under the lock.
    """

    engine: str = "pool"
    address: str | None = None
    lock_wait_s: float = LABEL_LOCK_WAIT_S


def label_dataset(
    root: str | Path,
    workers: int | None = None,
    method: str = "park",
    progress: bool = True,
    plot: bool = True,
    *,
    repeats: int = 0,
    options: LabelRunOptions | None = None,
) -> LabelReport:
    """Label every camera pose of a dataset and write the labels, a report and a plot.

    Parameters
    ----------
    root : str or Path
    workers : int, optional
        Processes (1: in this process), or Ray tasks in flight; None: 2, or every CPU of the cluster at
        ``options.address``.
    method : str
    progress : bool
        A progress bar on stderr.
    plot : bool
        Write ``label_errors.png`` (needs matplotlib).
    repeats : int
        0: this project's label; at least 1: the seed paper's, ``method``'s closed form repeated and averaged
        (:func:`paper_label`; ``method="tsai", repeats=5`` is the paper's).
    options : LabelRunOptions, optional
        The engine (this machine's processes or a Ray cluster), the cluster's address and the wait for another
        writer of the dataset; None: :class:`LabelRunOptions`' defaults.

    Returns
    -------
    LabelReport

    Raises
    ------
    DatasetError
        An invalid or incomplete dataset (checked before any work).
    """
    t0 = time.perf_counter()
    options = options or LabelRunOptions()
    engine, address = options.engine, options.address
    check_engine(engine, address, workers)
    ds = Dataset.open(root)
    outputs = [ds.cameras_path, ds.root / "labels.md"] + ([ds.root / "label_errors.png"] if plot else [])
    for path in outputs:  # a target that cannot take a file is refused before the work, not after it
        check_output_path(path)
    ds.cameras()
    for c in range(len(ds)):
        ds.frames(c)  # validate every shard up front: fail before an hour of work, not after
    if repeats < 0:
        raise HandEyeInputError(f"repeats must be >= 0, got {repeats}")
    jobs = [(str(ds.root.resolve()), c, method, repeats) for c in range(len(ds))]
    results = dict(
        run_tasks(
            _label_one,
            jobs,
            EngineOptions(
                workers=workers, progress=progress, desc=f"label {ds.root.name}", unit="camera", describe=_describe
            ),
            engine,
            address,
        )
    )
    labels = {
        col: np.array([results[c][col] for c in range(len(ds))], dtype=object if col == "label_status" else float)
        for col in LABEL_COLUMNS
    }
    for col in ("label_views_used", "label_views_total"):
        labels[col] = labels[col].astype(int)
    # cameras.csv read again under the lock and written before it is released: another writer's columns
    # (markerless labels written while this labelled) are kept, never lost
    with dataset_lock(ds.root, "handeye label", wait_s=options.lock_wait_s):
        table = _merge_labels(Dataset.open(ds.root), ds, labels)
        write_table(ds.cameras_path, table, camera_table_columns(table))
        write_text_atomic(ds.root / "labels.md", label_table_markdown(table) + "\n")
        if plot:
            plot_label_errors(table, ds.root / "label_errors.png")
    return LabelReport(ds.root, table, time.perf_counter() - t0)


def _merge_labels(now: Dataset, before: Dataset, labels: dict) -> dict:
    """The camera table as it is now, with the label columns replaced; refused if its placements changed."""
    table = dict(now.cameras())
    old = before.cameras()
    same = len(now) == len(before) and all(
        np.array_equal(np.asarray(table[c]), np.asarray(old[c]), equal_nan=np.asarray(old[c]).dtype.kind == "f")
        for c in CAMERA_COLUMNS
    )
    if not same:
        raise DatasetError(
            f"{now.cameras_path}: the camera placements changed while labelling (another process rewrote the "
            "dataset); no labels written, rerun handeye label"
        )
    table.update(labels)
    return table


def label_summary(table: dict) -> str:
    """One paragraph: how many camera poses were labelled, median and worst error against truth."""
    ok = np.array([s == "ok" for s in table["label_status"]])
    text = f"{ok.sum()} of {len(ok)} camera poses labelled"
    rot, trans = table["label_error_rot_deg"][ok], table["label_error_trans_mm"][ok]
    if np.isfinite(rot).any():
        text += (
            f"; label error against truth: median {np.nanmedian(rot):.4f} deg / {np.nanmedian(trans):.3f} mm, "
            f"worst {np.nanmax(rot):.4f} deg / {np.nanmax(trans):.3f} mm"
        )
    failed = [(int(c), s) for c, s in zip(table["camera_id"], table["label_status"]) if s != "ok"]
    for c, s in failed:
        text += f"\ncamera {c}: {s}"
    return text


def label_table_markdown(table: dict) -> str:
    """Per camera pose: split, region, views used, RMS, predicted sigma and error against truth."""

    def f(x, d):
        return "" if not np.isfinite(x) else f"{x:.{d}f}"

    rows = []
    for i in range(len(table["camera_id"])):
        status = table["label_status"][i]
        rows.append(
            [
                table["camera_id"][i],
                table["region"][i],
                table["split"][i],
                f"{table['label_views_used'][i]}/{table['label_views_total'][i]}",
                f(table["label_rms_px"][i], 3),
                f(table["label_sigma_rot_deg"][i], 4),
                f(table["label_sigma_trans_mm"][i], 3),
                f(table["label_error_rot_deg"][i], 4),
                f(table["label_error_trans_mm"][i], 3),
                status if status == "ok" else status[:60],
            ]
        )
    lines = markdown_table(
        [
            "camera",
            "region",
            "split",
            "views used",
            "RMS px",
            "sigma deg",
            "sigma mm",
            "error deg",
            "error mm",
            "status",
        ],
        rows,
    )
    return "\n".join(lines) + "\n\n" + label_summary(table)


def plot_label_errors(table: dict, path: str | Path) -> None:
    """Bar plot of each camera pose's label error (rotation, translation), with its predicted 3-sigma."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    ids = np.asarray(table["camera_id"])
    colours = plt.get_cmap("tab10")(np.asarray(table["region"]) % 10)
    fig, axes = plt.subplots(2, 1, figsize=(max(6.0, 0.12 * len(ids) + 2), 5.5), sharex=True)
    for ax, err, sig, unit in (
        (axes[0], "label_error_rot_deg", "label_sigma_rot_deg", "deg"),
        (axes[1], "label_error_trans_mm", "label_sigma_trans_mm", "mm"),
    ):
        ax.bar(ids, np.nan_to_num(table[err]), color=colours, width=0.8)
        ax.plot(ids, 3 * np.asarray(table[sig]), "k_", markersize=8, label="predicted 3 sigma")
        ax.set_ylabel(f"label error ({unit})")
        ax.grid(axis="y", alpha=0.3)
    failed = [i for i, s in zip(ids, table["label_status"]) if s != "ok"]
    for i in failed:
        axes[0].axvline(i, color="r", alpha=0.4)
    axes[0].legend(loc="upper right", fontsize=8)
    axes[0].set_title("classic label against truth per camera pose (colour: region; red line: failed)")
    axes[1].set_xlabel("camera pose")
    fig.tight_layout()
    try:
        write_figure_atomic(fig, path, dpi=110)
    finally:
        plt.close(fig)
