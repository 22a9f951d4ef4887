"""ArUco / AprilTag marker grid (OpenCV's ``GridBoard``): its drawing and its detection, corners in id order.

Marker ``i = r squares_x + c`` carries dictionary id ``i``; its corners, OpenCV's order (top-left, then
clockwise as drawn), take the ids ``4 i + j``, ``j = 0..3`` (:meth:`BoardSpec.corners_target`).

Sub-pixel corners: ``cornerSubPix`` on each marker corner with a window of :data:`WINDOW_MODULES` of the
marker's bit cells each side (at least 2 px, at most 5 px), so the window holds the marker's outer corner but
not its inner bits (OpenCV's default window can snap to an inner bit corner several pixels away). A marker
corner is a convex L, not a saddle like a chessboard corner: blurred, its gradient fixed point lies slightly
inside the marker (measured ~0.15 to 0.25 px on rendered views with about 5 px per bit cell); this shrink is
left in the corners and shows in the RMS.
"""

from __future__ import annotations

import cv2
import numpy as np

from classic.vision.dictionaries import dictionary_id

__all__ = ["render_grid", "detect_grid", "marker_pixels", "WINDOW_MODULES"]

#: Half-width of the sub-pixel window, in the marker's bit cells.
WINDOW_MODULES = 0.8


def marker_pixels(spec, pixels_per_square: int) -> int:
    """Whole pixels per marker side at ``pixels_per_square`` pixels per marker pitch."""
    return max(1, int(round(spec.marker_length_m / spec.square_length_m * pixels_per_square)))


def render_grid(spec, pixels_per_square: int, margin_px: int = 0) -> np.ndarray:
    """Image of the marker grid, every marker at whole pixels.

    Parameters
    ----------
    spec : classic.vision.board.BoardSpec
        Of kind ``"aruco_grid"``.
    pixels_per_square : int
        Pixels per marker pitch.
    margin_px : int
        White margin.

    Returns
    -------
    image : array of uint8, shape (H, W)
        Marker ``(c, r)`` drawn from pixel ``(margin_px + c n, margin_px + r n)``, :func:`marker_pixels` wide.
    """
    n, nm = int(pixels_per_square), marker_pixels(spec, pixels_per_square)
    d = cv2.aruco.getPredefinedDictionary(dictionary_id(spec.dictionary))
    w = spec.squares_x * n - (n - nm) + 2 * margin_px
    h = spec.squares_y * n - (n - nm) + 2 * margin_px
    image = np.full((h, w), 255, np.uint8)
    for i in range(spec.n_markers):
        r, c = divmod(i, spec.squares_x)
        y0, x0 = margin_px + r * n, margin_px + c * n
        image[y0 : y0 + nm, x0 : x0 + nm] = cv2.aruco.generateImageMarker(d, i, nm, borderBits=1)
    return image


def detect_grid(gray: np.ndarray, spec):
    """Corners of the grid's markers found in the image.

    Parameters
    ----------
    gray : array of uint8, shape (H, W)
    spec : classic.vision.board.BoardSpec
        Of kind ``"aruco_grid"``.

    Returns
    -------
    ids : array of int, shape (M,)
        ``4 * marker_id + j``, sorted.
    corners_px : array, shape (M, 2)
    n_markers : int
        Markers of the board found.
    reason : str or None
    """
    params = cv2.aruco.DetectorParameters()
    params.cornerRefinementMethod = cv2.aruco.CORNER_REFINE_NONE
    d = cv2.aruco.getPredefinedDictionary(dictionary_id(spec.dictionary))
    corners, marker_ids, _ = cv2.aruco.ArucoDetector(d, params).detectMarkers(gray)
    cells = int(d.markerSize) + 2
    criteria = (cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_COUNT, 100, 1e-4)
    ids, pts = [], []
    if marker_ids is not None:
        marker_ids = marker_ids.ravel()
        values, counts = np.unique(marker_ids, return_counts=True)
        once = set(values[(counts == 1) & (values < spec.n_markers)].tolist())  # a marker seen twice is dropped
        h, w = gray.shape
        for m, c in zip(marker_ids, corners):
            if int(m) in once:
                quad = np.asarray(c, dtype=np.float32).reshape(4, 1, 2)
                side_px = np.mean(np.linalg.norm(quad[:, 0] - np.roll(quad[:, 0], 1, axis=0), axis=1))
                half = int(np.clip(round(WINDOW_MODULES * side_px / cells), 2, 5))
                if np.any(quad < half + 1) or np.any(quad[:, 0] > np.array([w, h]) - 2 - half):
                    continue  # cut by the image border: its corners are the border's, not the marker's
                quad = cv2.cornerSubPix(gray, quad.copy(), (half, half), (-1, -1), criteria)
                ids.append(4 * int(m) + np.arange(4))
                pts.append(quad.reshape(4, 2).astype(float))
    if not ids:
        if marker_ids is not None and len(marker_ids):
            return (
                np.zeros(0, int),
                np.zeros((0, 2)),
                0,
                (
                    f"board not found: {len(marker_ids)} markers of dictionary {spec.dictionary} found but none of the "
                    f"board's 0..{spec.n_markers - 1} wholly in the image"
                ),
            )
        return (
            np.zeros(0, int),
            np.zeros((0, 2)),
            0,
            (
                f"board not found: no marker 0..{spec.n_markers - 1} of dictionary {spec.dictionary} "
                "(wrong dictionary, or board not in view)"
            ),
        )
    ids, pts = np.concatenate(ids), np.concatenate(pts)
    ids, pts = _restart_stray_corners(gray, spec, ids, pts, criteria)
    order = np.argsort(ids)
    return ids[order], pts[order], len(ids) // 4, None


def _restart_stray_corners(gray, spec, ids, pts, criteria, stray_px: float = 1.5):
    """Corners off a local homography of the neighbouring markers by over ``stray_px`` (a bad polygon corner of
    the marker detector) are refined again from that prediction; a marker with a corner still off is dropped.

    The homography of the markers next to a marker (not the marker itself) predicts its corners to well under a
    pixel: over two marker pitches, lens distortion is close to projective."""
    markers = ids[::4] // 4
    xy = spec.corners_target()[ids, :2]
    pts = pts.copy()
    keep = np.ones(len(ids), bool)
    for k, m in enumerate(markers):
        r, c = divmod(int(m), spec.squares_x)
        near = [
            j
            for j, n in enumerate(markers)
            if n != m and abs(n // spec.squares_x - r) <= 1 and abs(n % spec.squares_x - c) <= 1
        ]
        if len(near) < 2:
            continue
        rows = np.concatenate([np.arange(4 * j, 4 * j + 4) for j in near])
        H, _ = cv2.findHomography(xy[rows], pts[rows], cv2.RANSAC, 1.0)
        if H is None:
            continue
        own = np.arange(4 * k, 4 * k + 4)
        pred = cv2.perspectiveTransform(xy[own].reshape(-1, 1, 2), H).reshape(-1, 2)
        stray = np.linalg.norm(pts[own] - pred, axis=1) > stray_px
        if stray.any():
            start = pred[stray].astype(np.float32).reshape(-1, 1, 2)
            pts[own[stray]] = cv2.cornerSubPix(gray, start, (3, 3), (-1, -1), criteria).reshape(-1, 2)
            if np.any(np.linalg.norm(pts[own] - pred, axis=1) > stray_px):
                keep[own] = False
    return ids[keep], pts[keep]
