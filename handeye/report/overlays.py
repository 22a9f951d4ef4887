"""Reprojection overlays for a calibration from images: detected corners against those the calibration predicts.

For view ``i`` the calibration predicts ``T_cam_target(i) = X^-1 A_i Y`` from the robot pose alone;
its board corners are projected with the (refined) intrinsics and drawn over the image with the
detected ones, and the per-view RMS of their distance is the view's reprojection error.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from handeye.core.se3 import invert_transform
from handeye.core.setups import robot_side_poses
from handeye.report.style import COLORS, pyplot, save_figure

__all__ = ["ViewOverlay", "view_overlays", "residual_gain", "rms_figure", "overlay_grid_figure"]

#: Residual vectors are magnified so that the median one is drawn about this long, in image pixels.
ARROW_TARGET_PX = 8.0


def residual_gain(overlays: list) -> float:
    """A round magnification (1, 2 or 5 times a power of ten, 1 to 1000) of the residual vectors."""
    r = [np.linalg.norm(o.predicted_px - o.detected_px, axis=1) for o in overlays if len(o.detected_px)]
    med = float(np.median(np.concatenate(r))) if r else 0.0
    if med <= 0:
        return 1.0
    raw = ARROW_TARGET_PX / med
    exp = np.floor(np.log10(raw))
    nice = max(m for m in (1, 2, 5) if m * 10**exp <= raw) * 10**exp
    return float(np.clip(nice, 1, 1000))


@dataclass
class ViewOverlay:
    """One image's corners, detected and predicted.

    Attributes
    ----------
    image : str
        Path relative to the image folder.
    status : str
        ``used``, ``outlier`` (flagged by the reprojection refinement), ``excluded`` (a pose-based
        outlier, left out of the refinement) or ``rejected`` (no pose: ``reason`` says why).
    detected_px : array, shape (M, 2)
    predicted_px : array, shape (M, 2) or (K, 2)
        The detected corners' predictions; every board corner when none was detected.
    rms_px : float
        RMS distance of detected and predicted corners; NaN without detections.
    reason : str or None
    """

    image: str
    status: str
    detected_px: np.ndarray
    predicted_px: np.ndarray
    rms_px: float
    reason: str | None = None


def view_overlays(views, T_base_ee: np.ndarray, calibration, setup: str) -> list[ViewOverlay]:
    """Detected and predicted corners of every view.

    Parameters
    ----------
    views : classic.vision.views.Views
    T_base_ee : array, shape (len(views.views), 4, 4)
        Robot pose of every view, paired (:func:`handeye.image_calibration.pair_robot_poses`).
    calibration : handeye.image_calibration.ImageCalibration
    setup : {"eye_to_hand", "eye_in_hand"}

    Returns
    -------
    list of ViewOverlay
        In the order of ``views.views``.
    """
    from classic.vision.detect import project_points

    rep = calibration.reprojection
    intr = rep.intrinsics if rep is not None else views.intrinsics
    used = {name: j for j, name in enumerate(calibration.images)}
    pose_outliers = set()
    if rep is None:
        pose_outliers = {
            name for name, ok in zip(calibration.images, calibration.pose_based.residuals.inliers) if not ok
        }
    flagged = {calibration.images[j] for j in (rep.outlier_views if rep is not None else [])}
    T_cam_target = invert_transform(calibration.X) @ robot_side_poses(T_base_ee, setup) @ calibration.Y
    corners = views.spec.corners_target()
    out = []
    for v, T in zip(views.views, T_cam_target):
        ids = v.detection.ids
        predicted = project_points(corners[ids] if len(ids) else corners, T, intr)
        detected = v.detection.corners_px
        rms = float(np.sqrt(np.mean(np.sum((predicted - detected) ** 2, axis=1)))) if len(ids) else float("nan")
        if not v.pose.ok:
            status = "rejected"
        elif v.image not in used or v.image in pose_outliers:
            status = "excluded"
        elif v.image in flagged:
            status = "outlier"
        else:
            status = "used"
        out.append(ViewOverlay(v.image, status, detected, predicted, rms, v.pose.reason))
    return out


_STATUS_COLOR = {
    "used": COLORS["inlier"],
    "outlier": COLORS["outlier"],
    "excluded": COLORS["outlier"],
    "rejected": COLORS["muted"],
}


def rms_figure(path: str | Path, overlays: list[ViewOverlay]) -> Path:
    """Bar chart of the reprojection RMS per view, outliers in their own colour.

    Parameters
    ----------
    path : str or Path
    overlays : list of ViewOverlay

    Returns
    -------
    Path
    """
    plt = pyplot()
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    shown = [o for o in overlays if np.isfinite(o.rms_px)]
    fig, ax = plt.subplots(figsize=(max(6.5, 0.34 * len(shown) + 2), 3.3))
    x = np.arange(len(shown))
    ax.bar(
        x,
        [o.rms_px for o in shown],
        color=[_STATUS_COLOR[o.status] for o in shown],
        width=0.72,
        edgecolor="white",
        hatch=None,
    )
    used = [o.rms_px for o in shown if o.status == "used"]
    rms = float(np.sqrt(np.mean(np.square(used)))) if used else float("nan")
    if used:
        ax.axhline(rms, color=COLORS["ink"], lw=1, ls="--")
    ax.set_xticks(x)
    ax.set_xticklabels([Path(o.image).stem for o in shown], rotation=90, fontsize=8)
    ax.set_xlim(-0.7, len(shown) - 0.3)
    ax.set_ylabel("reprojection RMS [px]")
    ax.grid(axis="x", visible=False)
    handles = [
        Patch(color=_STATUS_COLOR[s], label=label)
        for s, label in (("used", "used"), ("outlier", "outlier or excluded"))
    ]
    handles.append(Line2D([], [], color=COLORS["ink"], lw=1, ls="--", label=f"RMS of used views ({rms:.3g} px)"))
    fig.legend(handles=handles, loc="upper right", ncol=3, bbox_to_anchor=(1.0, 1.0))
    fig.tight_layout(rect=(0, 0, 1, 0.9))
    return save_figure(fig, path)


def _tile(ax, image: np.ndarray, o: ViewOverlay, gain: float) -> None:
    ax.imshow(image, cmap="gray", vmin=0, vmax=255, interpolation="antialiased")
    pts = np.concatenate([o.detected_px, o.predicted_px]) if len(o.detected_px) else o.predicted_px
    h, w = image.shape[:2]
    if len(pts):  # crop to the board, with a margin
        lo, hi = pts.min(axis=0), pts.max(axis=0)
        pad = 0.12 * float(np.max(hi - lo)) + 10
        ax.set_xlim(max(lo[0] - pad, -0.5), min(hi[0] + pad, w - 0.5))
        ax.set_ylim(min(hi[1] + pad, h - 0.5), max(lo[1] - pad, -0.5))
    if len(o.detected_px):
        d, p = o.detected_px, o.predicted_px
        tips = d + gain * (p - d)
        ax.plot(np.stack([d[:, 0], tips[:, 0]]), np.stack([d[:, 1], tips[:, 1]]), color=COLORS["accent"], lw=1.4)
        ax.plot(d[:, 0], d[:, 1], "o", mfc="none", mec=COLORS["detected"], ms=6, mew=1.3)
    ax.plot(o.predicted_px[:, 0], o.predicted_px[:, 1], "+", color=COLORS["reprojected"], ms=7, mew=1.3)
    label = f"{o.rms_px:.2f} px" if np.isfinite(o.rms_px) else "no corners"
    title = f"{Path(o.image).name}: {label}" + ("" if o.status == "used" else f"  [{o.status.upper()}]")
    ax.set_title(title, fontsize=8.5, color=COLORS["ink"] if o.status == "used" else COLORS["outlier"])
    ax.set_xticks([])
    ax.set_yticks([])
    ax.grid(False)
    edge = _STATUS_COLOR[o.status] if o.status != "used" else "#c5ccd3"
    for spine in ax.spines.values():
        spine.set_visible(True)
        spine.set_color(edge)
        spine.set_linewidth(3.0 if o.status != "used" else 0.8)


def overlay_grid_figure(
    path: str | Path, overlays: list[ViewOverlay], image_folder: str | Path, most: int = 24, columns: int = 4
) -> Path:
    """A grid of the views, cropped to the board: detected corners, predicted corners, their residuals.

    Outlier, excluded and rejected views come first (framed in red or grey), then the used views.

    Parameters
    ----------
    path : str or Path
    overlays : list of ViewOverlay
    image_folder : str or Path
        The folder the views' image paths are relative to.
    most : int
        Views drawn at most.
    columns : int

    Returns
    -------
    Path
    """
    from classic.vision.images import read_image

    plt = pyplot()
    from matplotlib.lines import Line2D

    gain = residual_gain(overlays)
    order = sorted(overlays, key=lambda o: (o.status == "used", overlays.index(o)))[:most]
    rows = int(np.ceil(len(order) / columns))
    fig, axes = plt.subplots(rows, columns, figsize=(3.1 * columns, 2.55 * rows + 0.5), squeeze=False)
    for ax in axes.ravel():
        ax.axis("off")
    for ax, o in zip(axes.ravel(), order):
        ax.axis("on")
        _tile(ax, read_image(Path(image_folder) / o.image), o, gain)
    handles = [
        Line2D([], [], ls="none", marker="o", mfc="none", mec=COLORS["detected"], label="detected corner"),
        Line2D([], [], ls="none", marker="+", color=COLORS["reprojected"], label="predicted (X, Y, robot pose)"),
        Line2D([], [], color=COLORS["accent"], label=f"residual, magnified {gain:g}x"),
    ]
    fig.legend(handles=handles, loc="upper center", ncol=3, bbox_to_anchor=(0.5, 1.0))
    fig.tight_layout(rect=(0, 0, 1, 1 - 0.45 / (2.55 * rows + 0.5)))
    return save_figure(fig, path, dpi=100)
