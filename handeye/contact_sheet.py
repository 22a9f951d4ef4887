"""A contact sheet of one camera pose: data views, calibration views with detections, label against truth."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from handeye.core.dataset import Dataset
from handeye.core.errors import DatasetError
from handeye.core.metrics import pose_error
from handeye.core.safe_write import write_figure_atomic
from handeye.core.se3 import invert_transform

__all__ = ["contact_sheet"]


def _label_text(ds: Dataset, camera_id: int) -> tuple[str, np.ndarray | None]:
    """The sheet's title and the camera pose's label ``T_base_cam`` (None when there is none)."""
    cams = ds.cameras()
    T_base_cam_true = ds.truth()[camera_id]
    head = f"camera {camera_id}: region S{cams['region'][camera_id] + 1}, {cams['split'][camera_id]}"
    if "T_base_cam_label.x" not in cams:
        return head + "; not labelled (run 'handeye label')", None
    T_base_cam_label = ds.labels()[camera_id]
    status = cams["label_status"][camera_id]
    if status != "ok":
        return head + f"; labelling {status[:80]}", None
    text = head + (
        f"; label from {cams['label_views_used'][camera_id]}/{cams['label_views_total'][camera_id]} "
        f"views, RMS {cams['label_rms_px'][camera_id]:.2f} px"
    )
    if np.isfinite(T_base_cam_true).all():
        rot, trans = pose_error(T_base_cam_label, T_base_cam_true)
        text += f"; label vs truth {float(rot):.4f} deg / {float(trans):.3f} mm"
    return text, T_base_cam_label


def contact_sheet(root: str | Path, camera_id: int, path: str | Path, n_data: int = 4, n_calibration: int = 4) -> str:
    """Draw the contact sheet of a camera pose to a PNG.

    Parameters
    ----------
    root : str or Path
        Dataset directory.
    camera_id : int
    path : str or Path
        Output PNG.
    n_data, n_calibration : int
        Frames shown per row.

    Returns
    -------
    str
        The sheet's title (label against truth).

    Raises
    ------
    DatasetError
        No such camera, an incomplete shard, a missing image.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    ds = Dataset.open(root)
    data = ds.select(camera_id, "data")  # validates the camera id and its shard first
    cal = ds.select(camera_id, "calibration")
    title, T_base_cam_label = _label_text(ds, camera_id)
    if len(data["frame"]) == 0 and len(cal["frame"]) == 0:
        raise DatasetError(f"{ds.shard_dir(camera_id)}: no frames")
    ncols = max(n_data + 1, n_calibration, 1)
    fig, axes = plt.subplots(2, ncols, figsize=(2.6 * ncols, 5.6))
    for ax in axes.ravel():
        ax.axis("off")
    for k in range(min(n_data, len(data["frame"]))):
        axes[0, k].imshow(ds.rgb(camera_id, data["rgb"][k]))
        axes[0, k].set_title(f"data {data['frame'][k]}", fontsize=8)
    if len(data["frame"]):
        depth = ds.depth_m(camera_id, data["depth"][0])
        im = axes[0, n_data].imshow(np.where(depth > 0, depth, np.nan), cmap="viridis")
        axes[0, n_data].set_title("depth (m)", fontsize=8)
        fig.colorbar(im, ax=axes[0, n_data], fraction=0.046)
    if len(cal["frame"]):
        from classic.vision.board import BoardSpec
        from classic.vision.camera import CameraIntrinsics
        from classic.vision.detect import detect_board, project_points

        spec = BoardSpec(**ds.meta["board"])
        intr = CameraIntrinsics.from_dict(ds.meta.get("calibration_intrinsics", ds.meta["intrinsics"]))
        T_base_ee = ds.poses(cal, "T_base_ee")
        T_ee_target = None
        if T_base_cam_label is not None and "T_ee_target_true" in ds.meta:
            T_ee_target = np.array(ds.meta["T_ee_target_true"])
        for k in range(min(n_calibration, len(cal["frame"]))):
            img = ds.rgb(camera_id, cal["rgb"][k])
            det = detect_board(img, spec)
            ax = axes[1, k]
            ax.imshow(img)
            if len(det.ids):
                ax.plot(det.corners_px[:, 0], det.corners_px[:, 1], "o", mfc="none", mec="lime", ms=4)
            if T_ee_target is not None:
                # corners where the label (and the nominal board mount) put them
                T_cam_target = invert_transform(T_base_cam_label) @ T_base_ee[k] @ T_ee_target
                uv = project_points(spec.corners_target(), T_cam_target, intr)
                ax.plot(uv[:, 0], uv[:, 1], "r+", ms=4)
            ax.set_title(f"calibration {cal['frame'][k]}: {len(det.ids)} corners", fontsize=8)
    fig.suptitle(title, fontsize=9)
    fig.tight_layout()
    try:
        write_figure_atomic(fig, path, dpi=100)
    finally:
        plt.close(fig)
    return title
