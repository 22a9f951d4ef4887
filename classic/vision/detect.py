"""Board detection and per-view pose (PnP), with the reason whenever a view is rejected."""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from classic.vision.board import BoardSpec
from classic.vision.camera import CameraIntrinsics
from handeye.core.se3 import make_transform, so3_exp

__all__ = [
    "Detection",
    "ViewPose",
    "POSE_LIMITS",
    "corners_collinear",
    "detect_board",
    "estimate_pose",
    "project_points",
]

#: Acceptance limits of a view's pose.
POSE_LIMITS = {
    "min_corners": 6,
    "max_rms_px": 2.0,
    # IPPE's second solution must fit this many times worse, or the pose is ambiguous
    "ambiguity_ratio": 2.0,
}


@dataclass
class Detection:
    """Board corners found in one image.

    Attributes
    ----------
    ids : array of int, shape (M,)
        Corner ids (see :meth:`BoardSpec.corners_target`).
    corners_px : array, shape (M, 2)
        Sub-pixel corner positions, pixel centres at integers.
    n_markers : int
        ArUco markers of the board's dictionary found (0 for a checkerboard).
    image_size : (int, int)
        ``(width, height)``.
    reason : str or None
        Why nothing usable was found, or None.
    """

    ids: np.ndarray
    corners_px: np.ndarray
    n_markers: int
    image_size: tuple
    reason: str | None = None


@dataclass
class ViewPose:
    """The board's pose in one view, or why the view was rejected.

    Attributes
    ----------
    T_cam_target : array, shape (4, 4) or None
    rms_px : float
        RMS reprojection error of the corners (NaN when no pose).
    n_corners : int
    reason : str or None
        Rejection reason; None for an accepted view.
    """

    T_cam_target: np.ndarray | None
    rms_px: float
    n_corners: int
    reason: str | None = None

    @property
    def ok(self) -> bool:
        """Whether the view is accepted."""
        return self.reason is None


def detect_board(image: np.ndarray, spec: BoardSpec) -> Detection:
    """Detect the board's corners, sub-pixel: ChArUco (``CharucoDetector``), checkerboard
    (:mod:`classic.vision.checkerboard`), marker grid (:mod:`classic.vision.aruco_grid`) or circle grid
    (:mod:`classic.vision.circle_grid`: the circles' centres).

    Parameters
    ----------
    image : array of uint8, shape (H, W) or (H, W, 3)
    spec : BoardSpec

    Returns
    -------
    Detection
        Corner ids as :meth:`BoardSpec.corners_target` numbers them, with ``reason`` set when the board is
        not found.
    """
    gray = image if image.ndim == 2 else cv2.cvtColor(image, cv2.COLOR_BGR2GRAY)
    size = (int(gray.shape[1]), int(gray.shape[0]))
    if spec.kind == "checkerboard":
        from classic.vision.checkerboard import detect_checkerboard

        ids, corners, reason = detect_checkerboard(gray, spec.squares_x, spec.squares_y)
        return Detection(ids, corners, 0, size, reason)
    if spec.kind in ("circles", "asymmetric_circles"):
        from classic.vision.circle_grid import detect_circle_grid

        ids, corners, reason = detect_circle_grid(gray, spec)
        return Detection(ids, corners, 0, size, reason)
    if spec.kind == "aruco_grid":
        from classic.vision.aruco_grid import detect_grid

        ids, corners, n_markers, reason = detect_grid(gray, spec)
        return Detection(ids, corners, n_markers, size, reason)
    detector = cv2.aruco.CharucoDetector(spec.cv_board())
    corners, ids, _, marker_ids = detector.detectBoard(gray)
    n_markers = 0 if marker_ids is None else len(marker_ids)
    if ids is None or len(ids) == 0:
        if n_markers == 0:
            reason = (
                f"board not found: no marker of dictionary {spec.dictionary} (wrong dictionary, or board not in view)"
            )
        else:
            reason = (
                f"{n_markers} markers found but no ChArUco corner could be interpolated: too little of the board "
                f"in view, or the spec does not match the board ({spec.squares_x}x{spec.squares_y} squares; "
                f"swapped?{' legacy pattern?' if spec.squares_y % 2 == 0 else ''})"
            )
        return Detection(np.zeros(0, int), np.zeros((0, 2)), n_markers, size, reason)
    return Detection(ids.ravel().astype(int), corners.reshape(-1, 2).astype(float), n_markers, size)


def corners_collinear(spec: BoardSpec, ids: np.ndarray) -> bool:
    """Whether the corners ``ids`` lie on one line of the board, which leaves a pose undetermined.

    ChArUco: OpenCV's ``testCharucoCornersCollinear``; other kinds: the second singular value of the
    centred target coordinates is below ``1e-9`` of the square length.

    Parameters
    ----------
    spec : BoardSpec
    ids : array of int, shape (M,)

    Returns
    -------
    bool
    """
    ids = np.asarray(ids, dtype=int).ravel()
    if spec.kind == "charuco":
        return bool(cv2.aruco.testCharucoCornersCollinear(spec.cv_board(), ids.reshape(-1, 1).astype(np.int32)))
    if len(ids) < 3:
        return True
    xy = spec.corners_target()[ids, :2]
    s = np.linalg.svd(xy - xy.mean(axis=0), compute_uv=False)
    return bool(s[1] <= 1e-9 * spec.square_length_m)


def project_points(p_target: np.ndarray, T_cam_target: np.ndarray, intr: CameraIntrinsics) -> np.ndarray:
    """Pixel positions of target points (OpenCV's projection with distortion).

    Parameters
    ----------
    p_target : array, shape (M, 3)
    T_cam_target : array, shape (4, 4)
    intr : CameraIntrinsics

    Returns
    -------
    uv : array, shape (M, 2)
    """
    rvec, _ = cv2.Rodrigues(T_cam_target[:3, :3])
    uv, _ = cv2.projectPoints(p_target.astype(float), rvec, T_cam_target[:3, 3].astype(float), intr.K, intr.dist)
    return uv.reshape(-1, 2)


def estimate_pose(det: Detection, spec: BoardSpec, intr: CameraIntrinsics, limits: dict | None = None) -> ViewPose:
    """``T_cam_target`` of one view by PnP with the camera's distortion, or the reason to reject it.

    Planar PnP (IPPE) gives two candidate poses; the view is rejected as
    ambiguous unless the better one fits clearly better, then the pose is
    refined by Levenberg-Marquardt. Rejected: too few corners, collinear
    corners, ambiguous pose, RMS reprojection error above the limit.

    Parameters
    ----------
    det : Detection
    spec : BoardSpec
    intr : CameraIntrinsics
    limits : dict, optional
        Overrides of :data:`POSE_LIMITS`.

    Returns
    -------
    ViewPose
    """
    lim = {**POSE_LIMITS, **(limits or {})}
    n = len(det.ids)
    if det.reason is not None:
        return ViewPose(None, np.nan, n, det.reason)
    if n < lim["min_corners"]:
        return ViewPose(None, np.nan, n, f"too few corners: {n} < {lim['min_corners']}")
    if corners_collinear(spec, det.ids):
        return ViewPose(None, np.nan, n, f"the {n} corners found are collinear: the pose is undetermined")
    obj = spec.corners_target()[det.ids]
    img = det.corners_px
    count, rvecs, tvecs, errors = cv2.solvePnPGeneric(obj, img, intr.K, intr.dist, flags=cv2.SOLVEPNP_IPPE)
    if count == 0:
        return ViewPose(None, np.nan, n, "PnP found no pose")
    errors = np.asarray(errors).ravel()
    order = np.argsort(errors)
    best = int(order[0])
    if count > 1 and errors[order[1]] < lim["ambiguity_ratio"] * max(errors[best], 1e-12):
        return ViewPose(
            None,
            float(errors[best]),
            n,
            f"ambiguous pose: two poses fit within {lim['ambiguity_ratio']}x "
            f"({errors[best]:.2f} and {errors[order[1]]:.2f} px RMS); tilt the board more or see more "
            "of it",
        )
    rvec, tvec = cv2.solvePnPRefineLM(obj, img, intr.K, intr.dist, rvecs[best].copy(), tvecs[best].copy())
    T = make_transform(so3_exp(rvec.ravel()), tvec.ravel())
    rms = float(np.sqrt(np.mean(np.sum((project_points(obj, T, intr) - img) ** 2, axis=1))))
    if rms > lim["max_rms_px"]:
        return ViewPose(
            None,
            rms,
            n,
            f"reprojection RMS {rms:.2f} px above {lim['max_rms_px']} px "
            "(wrong intrinsics, motion blur, or a mis-detection)",
        )
    if T[2, 3] <= 0:
        return ViewPose(None, rms, n, "PnP put the board behind the camera")
    return ViewPose(T, rms, n)
