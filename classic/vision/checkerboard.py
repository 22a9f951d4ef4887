"""Plain checkerboard: its drawing and its detection (OpenCV's ``findChessboardCornersSB``), corners in id order.

The board is ``squares_x`` by ``squares_y`` squares, square ``(c, r)`` black when ``c + r`` is even (the
top-left one black). Its inner corners take the ids of :meth:`BoardSpec.corners_target`,
``k = r (squares_x - 1) + c``.

Corner order. ``findChessboardCornersSB`` finds all the inner corners or none, row by row, but which corner
it starts from depends on the view: a grid of corners looks the same turned by 180 degrees (and, for a
square grid, by 90). The spec therefore asks for inner-corner counts of different parity (one even and
one odd square count), which makes the grid's shape fix the rows and the colours fix the rest: turned by
180 degrees, the black and white squares swap. :func:`detect_checkerboard` reorders the corners so the
board seen from its front is right-handed (x to the right of y as drawn), then reads the colours of the
inner squares through the corners' homography and turns the order by 180 degrees when they are swapped.
"""

from __future__ import annotations

import cv2
import numpy as np

__all__ = ["render_checkerboard", "detect_checkerboard"]

#: Least mean gray-level difference between the white and the black inner squares to trust the orientation.
MIN_CONTRAST_GRAY = 20.0


def render_checkerboard(squares_x: int, squares_y: int, pixels_per_square: int, margin_px: int = 0) -> np.ndarray:
    """Image of the checkerboard, the top-left square black.

    Parameters
    ----------
    squares_x, squares_y : int
    pixels_per_square : int
    margin_px : int
        White margin.

    Returns
    -------
    image : array of uint8, shape (squares_y n + 2 margin_px, squares_x n + 2 margin_px)
    """
    n = int(pixels_per_square)
    r, c = np.divmod(np.arange(squares_x * squares_y), squares_x)
    cells = np.where((r + c) % 2 == 0, 0, 255).astype(np.uint8).reshape(squares_y, squares_x)
    board = np.kron(cells, np.ones((n, n), np.uint8))
    return np.pad(board, int(margin_px), constant_values=255)


def _square_contrast(gray: np.ndarray, grid_px: np.ndarray, squares_x: int, squares_y: int) -> float:
    """Mean gray level of the inner squares expected white minus those expected black, for this corner order.

    Parameters
    ----------
    gray : array of uint8, shape (H, W)
    grid_px : array, shape (squares_y - 1, squares_x - 1, 2)
        Corner ``(r, c)`` at inner corner ``((c + 1), (r + 1))`` in square units.
    """
    ny, nx = grid_px.shape[:2]
    r, c = np.divmod(np.arange(nx * ny), nx)
    H, _ = cv2.findHomography(np.column_stack([c + 1.0, r + 1.0]), grid_px.reshape(-1, 2))
    # inner squares (c, r) = 1 .. squares - 2, sampled on a 3 x 3 pattern around each centre
    sq_r, sq_c = np.divmod(np.arange((squares_x - 2) * (squares_y - 2)), squares_x - 2)
    sq_r, sq_c = sq_r + 1, sq_c + 1
    offs = np.array([-0.25, 0.0, 0.25])
    ox, oy = (a.ravel() for a in np.meshgrid(offs, offs))
    x = (sq_c[:, None] + 0.5 + ox[None]).ravel()
    y = (sq_r[:, None] + 0.5 + oy[None]).ravel()
    uv = cv2.perspectiveTransform(np.column_stack([x, y]).reshape(-1, 1, 2), H).reshape(-1, 2).astype(np.float32)
    vals = (
        cv2.remap(
            gray.astype(np.float32),
            uv[:, :1],
            uv[:, 1:],
            cv2.INTER_LINEAR,
            borderMode=cv2.BORDER_CONSTANT,
            borderValue=np.nan,
        )
        .reshape(len(sq_r), -1)
        .mean(axis=1)
    )
    white = (sq_r + sq_c) % 2 == 1
    return float(np.nanmean(vals[white]) - np.nanmean(vals[~white]))


def detect_checkerboard(gray: np.ndarray, squares_x: int, squares_y: int):
    """Inner corners of the checkerboard, all or none, in id order.

    Parameters
    ----------
    gray : array of uint8, shape (H, W)
    squares_x, squares_y : int
        One even, one odd (see the module docstring).

    Returns
    -------
    ids : array of int, shape (M,)
        ``0 .. M - 1`` with ``M = (squares_x - 1) (squares_y - 1)``, or empty.
    corners_px : array, shape (M, 2)
    reason : str or None
        Why no corner is returned.
    """
    nx, ny = squares_x - 1, squares_y - 1
    found, corners = cv2.findChessboardCornersSB(gray, (nx, ny), flags=cv2.CALIB_CB_EXHAUSTIVE | cv2.CALIB_CB_ACCURACY)
    empty = np.zeros(0, int), np.zeros((0, 2))
    if not found or corners is None or len(corners) != nx * ny:
        return (
            *empty,
            f"checkerboard of {squares_x}x{squares_y} squares not found: all {nx}x{ny} inner corners "
            "must be in view (or the spec's square counts do not match the board)",
        )
    grid = corners.reshape(ny, nx, 2).astype(float)
    ex, ey = grid[0, -1] - grid[0, 0], grid[-1, 0] - grid[0, 0]
    if ex[0] * ey[1] - ex[1] * ey[0] < 0:  # mirrored order: seen from the front, x is to the right of y
        grid = grid[:, ::-1]
    contrast = _square_contrast(gray, grid, squares_x, squares_y)
    if not abs(contrast) >= MIN_CONTRAST_GRAY:
        return (
            *empty,
            f"checkerboard found but its orientation is unclear (squares differ by {contrast:.0f} gray "
            f"levels, under {MIN_CONTRAST_GRAY:.0f})",
        )
    if contrast < 0:  # black and white swapped: the order is turned by 180 degrees
        grid = grid[::-1, ::-1]
    return np.arange(nx * ny), grid.reshape(-1, 2), None
