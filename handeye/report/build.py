"""Write the report: the figures as PNG files, then one self-contained ``index.html`` that embeds them.

Every file is written whole or not at all (:mod:`handeye.core.safe_write`); a failed write raises
:class:`handeye.core.errors.OutputFileError` naming the file.
"""

from __future__ import annotations

import datetime
import json
import platform
from dataclasses import dataclass, field
from html import escape
from pathlib import Path
from typing import Callable

import numpy as np

from handeye.core.errors import OutputFileError
from handeye.core.safe_write import check_output_folder, write_text_atomic
from handeye.core.setups import robot_side_poses
from handeye.report import html
from handeye.report import sections as sec

__all__ = ["ImagesPart", "ReportData", "write_report"]


@dataclass
class ImagesPart:
    """A calibration from images: the views, every view's robot pose, the result.

    Attributes
    ----------
    views : classic.vision.views.Views
    T_base_ee : array, shape (len(views.views), 4, 4)
    calibration : handeye.image_calibration.ImageCalibration
    """

    views: object
    T_base_ee: np.ndarray
    calibration: object


@dataclass
class ReportData:
    """Everything the report shows.

    Attributes
    ----------
    result : classic.CalibrationResult
        The pose-based calibration (from images: on the accepted views' PnP poses).
    T_base_ee, T_cam_target : array, shape (N, 4, 4)
        Its poses, metres.
    setup : {"eye_to_hand", "eye_in_hand"}
    command : str
        The command that made the calibration, shown in the captions.
    source : str
        The input, in words.
    fit : callable
        ``fit(keep)`` refits on the poses of a boolean mask with the same options (hold-out check).
    pairs : {"all", "consecutive"}
    labels : list of str, optional
        Per-pose tick labels (image names); default the pose index.
    warnings : list of str
        Warnings raised by the calibration.
    camera_covariance : array, shape (N, 6, 6), optional
        Per-pose camera covariances of the noise model, when it has them.
    images : ImagesPart, optional
    holdout_k : int, optional
        Poses held out per fold; default :func:`handeye.report.holdout.default_k`.
    truth : dict of str -> array, shape (4, 4), optional
        True poses by frame name (``calibrate --truth``, metres); the report shows the error against them.
    """

    result: object
    T_base_ee: np.ndarray
    T_cam_target: np.ndarray
    setup: str
    command: str
    source: str
    fit: Callable
    pairs: str = "all"
    labels: list | None = None
    warnings: list = field(default_factory=list)
    camera_covariance: np.ndarray | None = None
    images: ImagesPart | None = None
    holdout_k: int | None = None
    truth: dict | None = None


def _final(data: ReportData):
    """The calibration the report leads with: the reprojection refinement when there is one."""
    rep = data.images.calibration.reprojection if data.images is not None else None
    if rep is not None:
        return rep.X, rep.Y, rep.sigma, "refined on corner reprojection error"
    return data.result.X, data.result.Y, data.result.sigma, "calibrated on the poses"


def _run_holdout(data: ReportData):
    from handeye.report.holdout import hold_out_check

    try:
        return hold_out_check(
            data.T_base_ee,
            data.T_cam_target,
            data.setup,
            data.fit,
            k=data.holdout_k,
            use=data.result.residuals.inliers,
            camera_covariance=data.camera_covariance,
        ), None
    except ValueError as exc:
        return None, str(exc)


def _versions() -> str:
    from importlib import metadata

    parts = []
    for name in ("handeye", "numpy", "scipy", "matplotlib"):
        try:
            parts.append(f"{name} {metadata.version(name)}")
        except metadata.PackageNotFoundError:
            pass
    return f"python {platform.python_version()}, " + ", ".join(parts)


def write_report(folder: str | Path, data: ReportData) -> Path:
    """Write ``index.html`` and its PNGs (and ``report.json`` with the numbers) into a folder.

    Parameters
    ----------
    folder : str or Path
        Created if missing; files of the same names are replaced.
    data : ReportData

    Returns
    -------
    Path
        The page, ``folder / "index.html"``.
    """
    from handeye.report.figures import holdout_figure, motion_figure, residuals_figure
    from handeye.report.frames3d import frames_figure

    folder = check_output_folder(folder)
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise OutputFileError(f"{folder}: cannot create the report folder ({exc.strerror or exc})") from None
    res, setup = data.result, data.setup
    inl = res.residuals.inliers
    final = _final(data)
    board = data.images.views.spec.size_m if data.images is not None else None
    pngs = {
        "residuals": residuals_figure(
            folder / "residuals.png", res.residuals.rotation_deg, res.residuals.translation_mm, inl, data.labels
        ),
        "frames": frames_figure(folder / "frames.png", setup, final[0], final[1], data.T_base_ee[inl], board),
        "motion": motion_figure(
            folder / "motion.png", robot_side_poses(data.T_base_ee[inl], setup), res.diagnostics["motion"], data.pairs
        ),
    }
    check, error = _run_holdout(data)
    if check is not None and len(check.indices):
        pngs["holdout"] = holdout_figure(folder / "holdout.png", check)
    overlays = None
    if data.images is not None:
        from handeye.report.overlays import overlay_grid_figure, rms_figure, view_overlays

        part = data.images
        overlays = view_overlays(part.views, part.T_base_ee, part.calibration, setup)
        pngs["reprojection_rms"] = rms_figure(folder / "reprojection_rms.png", overlays)
        pngs["overlays"] = overlay_grid_figure(folder / "overlays.png", overlays, part.views.image_folder)
    sections = [
        ("result", "Result", sec.result_section(data, final, check)),
        ("method", "Method and noise model", sec.method_section(data)),
        ("residuals", "Residual per pose", sec.residuals_section(data, pngs["residuals"])),
        ("frames", "Frames in 3-D", sec.frames_section(data, pngs["frames"])),
        ("motion", "Motion diversity", sec.motion_section(data, pngs["motion"])),
        ("holdout", "Hold-out check", sec.holdout_section(data, check, error, pngs.get("holdout"))),
    ]
    if overlays is not None:
        sections.append(
            (
                "reprojection",
                "Reprojection per image",
                sec.reprojection_section(data, overlays, pngs["reprojection_rms"], pngs["overlays"]),
            )
        )
    now = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    sub = (
        f"{escape(setup.replace('_', '-'))} &middot; {len(inl)} poses &middot; method {escape(res.method)} "
        f"&middot; {now}<br><code>{escape(data.command)}</code>"
    )
    foot = f"Written by <code>handeye calibrate --report</code>; {escape(_versions())}."
    page = html.page("Hand-eye calibration report", sub, sections, foot)
    index = folder / "index.html"
    write_text_atomic(index, page)
    doc = {
        "command": data.command,
        "source": data.source,
        "final": final[3],
        "result": res.to_dict(),
        "holdout": None if check is None else check.to_dict(),
        "holdout_error": error,
        "figures": sorted(p.name for p in pngs.values()),
        "truth_error": sec.truth_errors(data, final),
    }
    if overlays is not None:
        doc["views"] = [
            {
                "image": o.image,
                "status": o.status,
                "rms_px": None if np.isnan(o.rms_px) else o.rms_px,
                "reason": o.reason,
            }
            for o in overlays
        ]
    write_text_atomic(folder / "report.json", json.dumps(doc, indent=1) + "\n")
    return index
