"""A folder of board images turned into per-view detections and poses, and the file that keeps them.

``handeye detect`` writes ``detections.json`` (everything, including the
corners that the reprojection refinement needs) and ``detections.csv`` (one
row per image: corners found, RMS, pose or the rejection reason). Image
paths are relative to the image folder, which is stored relative to the
detections file, so the pair can be moved together.
"""

from __future__ import annotations

import csv
import io
import json
import sys
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from classic.vision.board import BoardSpec
from classic.vision.camera import CameraIntrinsics
from classic.vision.detect import Detection, ViewPose, detect_board, estimate_pose
from classic.vision.images import list_images, read_image
from classic.vision.intrinsics import IntrinsicsResult, calibrate_intrinsics
from handeye.core.errors import HandEyeInputError
from handeye.core.safe_write import write_text_atomic
from handeye.core.se3 import pos_quat_xyzw_from_transform, transform_from_pos_quat_xyzw

__all__ = ["View", "Views", "DetectionsFileError", "detect_folder"]


class DetectionsFileError(HandEyeInputError):
    """A detections file cannot be read."""


@dataclass
class View:
    """One image: its detection and pose (or rejection reason).

    Attributes
    ----------
    image : str
        Path relative to the image folder.
    detection : Detection
    pose : ViewPose
    """

    image: str
    detection: Detection
    pose: ViewPose

    def to_dict(self) -> dict:
        """JSON-serialisable dictionary."""
        out = {
            "image": self.image,
            "n_corners": int(len(self.detection.ids)),
            "rms_px": None if np.isnan(self.pose.rms_px) else float(self.pose.rms_px),
            "reason": self.pose.reason,
            "ids": self.detection.ids.tolist(),
            "corners_px": self.detection.corners_px.tolist(),
            "image_size": list(self.detection.image_size),
            "n_markers": int(self.detection.n_markers),
        }
        if self.pose.ok:
            t, q = pos_quat_xyzw_from_transform(self.pose.T_cam_target)
            out["T_cam_target"] = {"translation_m": t.tolist(), "quaternion_xyzw": q.tolist()}
        return out


@dataclass
class Views:
    """All views of a folder, with the board and the intrinsics used.

    Attributes
    ----------
    views : list of View
    spec : BoardSpec
    intrinsics : CameraIntrinsics
    image_folder : Path
    intrinsics_report : str
        Where the intrinsics came from and how good they are.
    """

    views: list
    spec: BoardSpec
    intrinsics: CameraIntrinsics
    image_folder: Path
    intrinsics_report: str = ""
    extra: dict = field(default_factory=dict)

    @property
    def accepted(self) -> list:
        """Views with a pose."""
        return [v for v in self.views if v.pose.ok]

    def save(self, path: str | Path) -> Path:
        """Write ``path`` (JSON) and the CSV summary beside it; returns the CSV path."""
        path = Path(path)
        folder = Path(_relpath(self.image_folder, path.parent))
        doc = {
            "format": "handeye-detections-1",
            "board": self.spec.to_dict(),
            "intrinsics": self.intrinsics.to_dict(),
            "intrinsics_report": self.intrinsics_report,
            "image_folder": str(folder),
            "views": [v.to_dict() for v in self.views],
        }
        write_text_atomic(path, json.dumps(doc, indent=1) + "\n")
        csv_path = path.with_suffix(".csv")
        buffer = io.StringIO(newline="")
        # the table built in memory, then written whole (handeye.core.safe_write)
        w = csv.writer(buffer)
        w.writerow(
            [
                "image",
                "n_corners",
                "rms_px",
                "T_cam_target.x",
                "T_cam_target.y",
                "T_cam_target.z",
                "T_cam_target.qx",
                "T_cam_target.qy",
                "T_cam_target.qz",
                "T_cam_target.qw",
                "reason",
            ]
        )
        for v in self.views:
            d = v.to_dict()
            pose = (
                d["T_cam_target"]["translation_m"] + d["T_cam_target"]["quaternion_xyzw"]
                if "T_cam_target" in d
                else [""] * 7
            )
            rms = "" if d["rms_px"] is None else f"{d['rms_px']:.4f}"
            w.writerow(
                [v.image, d["n_corners"], rms, *[f"{x:.9g}" if x != "" else "" for x in pose], v.pose.reason or ""]
            )
        write_text_atomic(csv_path, buffer.getvalue())
        return csv_path

    @classmethod
    def load(cls, path: str | Path) -> "Views":
        """Read a detections file written by :meth:`save`.

        Raises
        ------
        DetectionsFileError
            Naming the file.
        """
        from handeye.core.jsonfile import read_json_file
        from handeye.core.numbers import as_float, as_int, float_array

        path = Path(path)
        doc = read_json_file(path, DetectionsFileError, "detections file")
        try:
            spec = BoardSpec(**doc["board"])
            intr = CameraIntrinsics.from_dict(doc["intrinsics"])
            views = []
            for v in doc["views"]:
                where = f"{path}: view {v.get('image', len(views))!r}"
                ids = float_array(v["ids"], f"{where} ids", DetectionsFileError)
                if ids.size and (ids != np.round(ids)).any():
                    raise DetectionsFileError(f"{where} ids: not whole numbers")
                det = Detection(
                    ids.astype(int),
                    float_array(v["corners_px"], f"{where} corners_px", DetectionsFileError).reshape(-1, 2),
                    as_int(v.get("n_markers", 0), f"{where} n_markers", DetectionsFileError),
                    tuple(as_int(s, f"{where} image_size", DetectionsFileError) for s in v["image_size"]),
                )
                T = None
                if "T_cam_target" in v:
                    T = transform_from_pos_quat_xyzw(
                        float_array(v["T_cam_target"]["translation_m"], f"{where} translation_m", DetectionsFileError),
                        float_array(v["T_cam_target"]["quaternion_xyzw"], f"{where} quaternion", DetectionsFileError),
                    )
                rms = np.nan if v["rms_px"] is None else as_float(v["rms_px"], f"{where} rms_px", DetectionsFileError)
                views.append(View(v["image"], det, ViewPose(T, rms, len(det.ids), v["reason"])))
        except FileNotFoundError:
            raise DetectionsFileError(f"{path}: no such detections file") from None
        except DetectionsFileError:
            raise  # names the file and the view already
        except (json.JSONDecodeError, KeyError, TypeError, ValueError) as exc:
            raise DetectionsFileError(f"{path}: not a handeye detections file ({type(exc).__name__}: {exc})") from None
        return cls(views, spec, intr, (path.parent / doc["image_folder"]).resolve(), doc.get("intrinsics_report", ""))


def _relpath(target: Path, start: Path) -> str:
    import os

    return os.path.relpath(Path(target).resolve(), Path(start).resolve())


def detect_folder(
    folder: str | Path, spec: BoardSpec, intrinsics: CameraIntrinsics | None = None, progress: bool = True
) -> tuple[Views, IntrinsicsResult | None]:
    """Detect the board in every image of a folder and estimate each view's pose.

    Without intrinsics, they are first calibrated from the same images.

    Parameters
    ----------
    folder : str or Path
    spec : BoardSpec
    intrinsics : CameraIntrinsics, optional
    progress : bool
        A progress line on stderr.

    Returns
    -------
    views : Views
    calibrated : IntrinsicsResult or None
        The intrinsics calibration, when one was run.
    """
    folder = Path(folder)
    files = list_images(folder)
    detections = []
    try:
        for k, f in enumerate(files):
            if progress:
                print(f"\rdetect [{k + 1}/{len(files)}] {f.name}", end="", file=sys.stderr, flush=True)
            detections.append(detect_board(read_image(f), spec))
    finally:  # end the progress line, also before an error's message
        if progress:
            print(file=sys.stderr)
    sizes = {d.image_size for d in detections}
    if len(sizes) > 1:
        raise HandEyeInputError(f"{folder}: images of different sizes {sorted(sizes)}; one camera per folder")
    calibrated = None
    if intrinsics is None:
        try:
            calibrated = calibrate_intrinsics(detections, spec)
        except HandEyeInputError as exc:
            raise HandEyeInputError(
                f"{folder}: no intrinsics given and these images cannot calibrate them ({exc}); "
                "pass the camera's intrinsics (CLI: --intrinsics camera.json, from 'handeye intrinsics')"
            ) from None
        intrinsics = calibrated.intrinsics
        report = f"calibrated from these images: {calibrated.summary()}"
    else:
        report = "given"
        if intrinsics.width and (intrinsics.width, intrinsics.height) != detections[0].image_size:
            raise HandEyeInputError(
                f"intrinsics are for {intrinsics.width}x{intrinsics.height} images but {folder} holds "
                f"{detections[0].image_size[0]}x{detections[0].image_size[1]} images"
            )
    views = [View(f.name, d, estimate_pose(d, spec, intrinsics)) for f, d in zip(files, detections)]
    return Views(views, spec, intrinsics, folder, report), calibrated
