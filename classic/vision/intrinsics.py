"""Camera intrinsics from ChArUco views (OpenCV's ``calibrateCameraExtended``)."""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from classic.vision.board import BoardSpec
from classic.vision.camera import STD_NAMES, CameraIntrinsics
from classic.vision.detect import POSE_LIMITS, Detection, corners_collinear
from handeye.core.errors import HandEyeInputError

__all__ = ["IntrinsicsResult", "calibrate_intrinsics"]


@dataclass
class IntrinsicsResult:
    """Intrinsics and how good they are.

    Attributes
    ----------
    intrinsics : CameraIntrinsics
    rms_px : float
        Overall RMS reprojection error.
    per_view_rms_px : array, shape (V,)
        Of the views used (``used`` indices).
    used : list of int
        Indices of the detections used.
    std : dict
        One-sigma of ``fx, fy, cx, cy`` (pixels) and ``k1, k2, p1, p2, k3``.
    """

    intrinsics: CameraIntrinsics
    rms_px: float
    per_view_rms_px: np.ndarray
    used: list
    std: dict

    def summary(self) -> str:
        """A line a person can judge the calibration by."""
        K = self.intrinsics.K
        s = self.std
        return (
            f"intrinsics from {len(self.used)} views: RMS {self.rms_px:.3f} px; fx {K[0, 0]:.1f} +- {s['fx']:.1f}, "
            f"fy {K[1, 1]:.1f} +- {s['fy']:.1f}, cx {K[0, 2]:.1f} +- {s['cx']:.1f}, cy {K[1, 2]:.1f} +- "
            f"{s['cy']:.1f} px"
        )


def calibrate_intrinsics(detections: list[Detection], spec: BoardSpec, min_views: int = 4) -> IntrinsicsResult:
    """Calibrate ``K`` and ``(k1, k2, p1, p2, k3)`` from board detections.

    Views with fewer than ``POSE_LIMITS["min_corners"]`` corners or collinear
    corners are left out.

    Parameters
    ----------
    detections : list of Detection
        All of the same image size.
    spec : BoardSpec
    min_views : int

    Returns
    -------
    IntrinsicsResult

    Raises
    ------
    HandEyeInputError
        Too few usable views, or images of different sizes.
    """
    sizes = {d.image_size for d in detections}
    if len(sizes) > 1:
        raise HandEyeInputError(f"images of different sizes {sorted(sizes)}: one camera's intrinsics need one size")
    used, obj, img = [], [], []
    for k, d in enumerate(detections):
        if d.reason is None and len(d.ids) >= POSE_LIMITS["min_corners"] and not corners_collinear(spec, d.ids):
            used.append(k)
            obj.append(spec.corners_target()[d.ids].astype(np.float32))
            img.append(d.corners_px.astype(np.float32))
    if len(used) < min_views:
        raise HandEyeInputError(
            f"intrinsics need at least {min_views} views with {POSE_LIMITS['min_corners']}+ non-collinear corners, "
            f"got {len(used)} of {len(detections)}"
        )
    size = sizes.pop()
    rms, K, dist, _, _, std_intr, _, per_view = cv2.calibrateCameraExtended(obj, img, size, None, None)
    std = {n: float(v) for n, v in zip(STD_NAMES, std_intr.ravel()[: len(STD_NAMES)])}
    # the std travels with the intrinsics (written into their file), for the hand-eye refinement's prior
    return IntrinsicsResult(
        CameraIntrinsics(K, dist.ravel()[:5], size[0], size[1], std), float(rms), per_view.ravel(), used, std
    )
