"""Circle grids, symmetric and asymmetric: their drawing and detection (``cv2.findCirclesGrid``), ids in order.

Geometry (``s`` = ``BoardSpec.square_length_m``, ``d`` = ``marker_length_m``, the circle diameter; ``cols``
= ``squares_x`` circles a row, ``rows`` = ``squares_y`` rows), centre ``k = i cols + j`` (row ``i``,
column ``j``) in the target frame:

* ``"circles"`` (symmetric): ``((j + 1) s, (i + 1) s, 0)``; the board is ``(cols + 1) s`` by ``(rows + 1) s``;
* ``"asymmetric_circles"``: ``((2 j + i mod 2 + 1) s, (i + 1) s, 0)``, OpenCV's asymmetric pattern (its
  calibration sample's object points, shifted by one ``s``): circles of a row ``2 s`` apart, each row
  shifted by ``s`` against the next; the board is ``(2 cols + 1) s`` by ``(rows + 1) s``.

Orientation. A symmetric grid looks the same turned by 180 degrees, and ``findCirclesGrid`` may return
its centres in any of its symmetric orders, mirrored ones too. :func:`detect_circle_grid` makes the order
right-handed seen from the front (x to the right of y, as drawn) and then takes, of the two orders left,
the one whose x axis points to the right in the image: a view turned more than 90 degrees about the
camera's axis from upright gets the ids of the board turned by 180 degrees, and its pose is off by
180 degrees about the board's normal. Keep a symmetric grid upright within +-90 degrees in every view, or
use an asymmetric grid. An asymmetric grid with an odd number of rows has one order only (turned by 180
degrees its rows' shifts no longer match), so ``findCirclesGrid``'s order is checked, not chosen; with an
even number of rows it is as ambiguous as a symmetric one, and :class:`~classic.vision.board.BoardSpec`
refuses it.
"""

from __future__ import annotations

import cv2
import numpy as np

__all__ = ["circle_centres", "detect_circle_grid", "render_circle_grid"]

#: The detected centres' order is accepted when a homography from the board maps them within this many
#: pixels RMS (a wrong order puts centres a whole spacing, tens of pixels, off).
MAX_ORDER_RMS_PX = 2.0
#: Least blob area in pixels the detector takes: a circle of about 3 px across.
MIN_BLOB_AREA_PX = 8.0


def circle_centres(kind: str, cols: int, rows: int, spacing_m: float) -> np.ndarray:
    """Circle centres in the target frame, metres, in id order (geometry in the module docstring).

    Parameters
    ----------
    kind : {"circles", "asymmetric_circles"}
    cols, rows : int
    spacing_m : float
        ``s``.

    Returns
    -------
    p_target : array, shape (cols rows, 3)
    """
    i, j = np.divmod(np.arange(cols * rows), cols)
    x = 2 * j + i % 2 + 1 if kind == "asymmetric_circles" else j + 1
    return np.column_stack([x * spacing_m, (i + 1) * spacing_m, np.zeros(cols * rows)]).astype(float)


def render_circle_grid(spec, pixels_per_square: int, margin_px: int = 0) -> np.ndarray:
    """Image of the circle grid: black circles on white, anti-aliased, centres at sub-pixel positions.

    Parameters
    ----------
    spec : BoardSpec
        A ``"circles"`` or ``"asymmetric_circles"`` spec.
    pixels_per_square : int
        Pixels per spacing ``s``.
    margin_px : int

    Returns
    -------
    image : array of uint8, shape (H, W)
        The target origin at pixel ``(margin_px, margin_px)``'s top-left corner.
    """
    n, m = int(pixels_per_square), int(margin_px)
    w_m, h_m = spec.size_m
    s = spec.square_length_m
    W, H = int(round(w_m / s * n)) + 2 * m, int(round(h_m / s * n)) + 2 * m
    image = np.full((H, W), 255, np.uint8)
    shift = 4  # sub-pixel bits of cv2.circle
    radius = 0.5 * spec.marker_length_m / s * n
    for x, y, _ in spec.corners_target() / s * n:
        # pixel centres at integers: the point (x, y) of the board is at pixel coordinate (x - 0.5, y - 0.5)
        cx, cy = (x + m - 0.5) * 2**shift, (y + m - 0.5) * 2**shift
        cv2.circle(image, (int(round(cx)), int(round(cy))), int(round(radius * 2**shift)), 0, -1, cv2.LINE_AA, shift)
    return image


def _blob_detector(image_area: float, n_circles: int):
    params = cv2.SimpleBlobDetector_Params()
    params.minArea = MIN_BLOB_AREA_PX
    params.maxArea = max(5000.0, image_area / (2.0 * n_circles))
    params.minDistBetweenBlobs = 2.0
    return cv2.SimpleBlobDetector_create(params)


def _order_rms(grid: np.ndarray, spec) -> float:
    """RMS pixels of the best homography from the board's centres to the detected ones, in this order."""
    obj = spec.corners_target()[:, :2]
    H, _ = cv2.findHomography(obj, grid.reshape(-1, 2), 0)
    if H is None:
        return np.inf
    proj = cv2.perspectiveTransform(obj.reshape(-1, 1, 2), H).reshape(-1, 2)
    return float(np.sqrt(np.mean(np.sum((proj - grid.reshape(-1, 2)) ** 2, axis=1))))


def detect_circle_grid(gray: np.ndarray, spec):
    """Circle centres of the grid, all or none, in id order.

    Parameters
    ----------
    gray : array of uint8, shape (H, W)
    spec : BoardSpec
        ``"circles"`` or ``"asymmetric_circles"``.

    Returns
    -------
    ids : array of int, shape (M,)
        ``0 .. M - 1`` with ``M = cols rows``, or empty.
    centres_px : array, shape (M, 2)
    reason : str or None
        Why no centre is returned: the grid not found (not all circles in view, or the spec's counts do not
        match the board), or found in an order no view of the board gives.
    """
    cols, rows = int(spec.squares_x), int(spec.squares_y)
    asymmetric = spec.kind == "asymmetric_circles"
    flags = cv2.CALIB_CB_ASYMMETRIC_GRID if asymmetric else cv2.CALIB_CB_SYMMETRIC_GRID
    detector = _blob_detector(float(gray.size), cols * rows)
    empty = np.zeros(0, int), np.zeros((0, 2))
    name = "asymmetric circle grid" if asymmetric else "circle grid"
    try:
        found, centres = cv2.findCirclesGrid(gray, (cols, rows), flags=flags, blobDetector=detector)
    except cv2.error as exc:  # OpenCV refuses some degenerate inputs instead of returning not found
        found, centres = False, None
        cause = str(exc).strip().splitlines()[-1]
        return *empty, f"{name} of {cols}x{rows} circles not found (OpenCV: {cause})"
    if not found or centres is None or len(centres) != cols * rows:
        return (
            *empty,
            f"{name} of {cols}x{rows} circles not found: all {cols * rows} circles must be in view, dark on a "
            f"light board (or the spec's counts do not match the board: {cols} a row, {rows} rows)",
        )
    grid = centres.reshape(rows, cols, 2).astype(float)
    if not asymmetric:
        ex, ey = grid[0, -1] - grid[0, 0], grid[-1, 0] - grid[0, 0]
        if ex[0] * ey[1] - ex[1] * ey[0] < 0:  # mirrored: seen from the front, x is to the right of y
            grid = grid[:, ::-1]
        ex = grid[0, -1] - grid[0, 0]
        if ex[0] < 0 or (ex[0] == 0 and ex[1] > 0):  # the x axis to the right in the image (module docstring)
            grid = grid[::-1, ::-1]
    rms = _order_rms(grid, spec)
    if not rms <= MAX_ORDER_RMS_PX:
        return (
            *empty,
            f"{name} found but its circles are not in an order the board can take ({rms:.1f} px off a "
            f"homography of the board, more than {MAX_ORDER_RMS_PX:g}): the spec does not match the board",
        )
    return np.arange(cols * rows), grid.reshape(-1, 2), None
