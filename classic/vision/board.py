"""Board specification: the kind of target, the printable board and its corner coordinates.

Three kinds share one spec and one contract, corner ids and their target-frame coordinates
(:meth:`BoardSpec.corners_target`), so PnP, intrinsics and the reprojection refinement take any of them:

- ``"charuco"`` (default): ChArUco, ``legacy=True`` for OpenCV's pre-4.6 pattern (differs on boards
  with an even number of rows);
- ``"checkerboard"``: a plain chessboard; its two inner-corner counts must differ in parity, so
  that a 180 degree turn of the board is told apart (:mod:`classic.vision.checkerboard`);
- ``"aruco_grid"``: an ArUco or AprilTag marker grid (:mod:`classic.vision.aruco_grid`);
- ``"circles"`` and ``"asymmetric_circles"``: circle grids, symmetric and asymmetric
  (:mod:`classic.vision.circle_grid`): ``squares_x`` circles a row, ``squares_y`` rows,
  ``square_length_m`` the spacing ``s`` (OpenCV's ``squareSize``), ``marker_length_m`` the circle
  diameter; the "corners" are the circles' centres.
"""

from __future__ import annotations

import json
from dataclasses import asdict, dataclass
from pathlib import Path

import cv2
import numpy as np

from classic.vision.dictionaries import BoardSpecError, dictionary_id, dictionary_size
from handeye.core.safe_write import write_text_atomic

__all__ = ["BoardSpec", "BoardSpecError", "KINDS", "dictionary_id"]

#: Board kinds; ``"aruco-grid"`` is accepted for ``"aruco_grid"``, ``"asymmetric-circles"`` alike.
KINDS = ("charuco", "checkerboard", "aruco_grid", "circles", "asymmetric_circles")
#: Kinds without ArUco markers (no dictionary).
_NO_MARKERS = ("checkerboard", "circles", "asymmetric_circles")


@dataclass(frozen=True)
class BoardSpec:
    """A calibration board: its kind, squares (or markers), their size and the markers' dictionary.

    Attributes
    ----------
    squares_x, squares_y : int
        Squares along x (columns) and y (rows); for ``"aruco_grid"`` markers along x and y.
    square_length_m : float
        Side of a chessboard square, metres; for ``"aruco_grid"`` the marker pitch (marker side plus
        the gap between markers).
    marker_length_m : float
        Side of an ArUco marker, metres (smaller than ``square_length_m``); unused by ``"checkerboard"``.
    dictionary : str
        ArUco or AprilTag dictionary, e.g. ``"5X5_100"``, ``"APRILTAG_36h11"``; unused by ``"checkerboard"``.
    kind : {"charuco", "checkerboard", "aruco_grid"}
    legacy : bool
        ChArUco only: OpenCV's legacy pattern (``CharucoBoard.setLegacyPattern``).

    Examples
    --------
    >>> spec = BoardSpec(7, 5, 0.04, 0.03, "5X5_100")
    >>> spec.corners_target().shape
    (24, 3)
    >>> BoardSpec.checkerboard(9, 6, 0.025).n_corners
    40
    >>> BoardSpec.aruco_grid(4, 3, 0.04, 0.01, "APRILTAG_36h11").n_corners
    48
    """

    squares_x: int
    squares_y: int
    square_length_m: float
    marker_length_m: float
    dictionary: str = "5X5_100"
    kind: str = "charuco"
    legacy: bool = False

    def __post_init__(self):
        kind = str(self.kind).lower().replace("-", "_")
        if kind not in KINDS:
            raise BoardSpecError(f"unknown board kind {self.kind!r}; use one of {', '.join(KINDS)}")
        object.__setattr__(self, "kind", kind)
        if not isinstance(self.legacy, (bool, np.bool_)):
            raise BoardSpecError(f"legacy must be true or false, got {self.legacy!r}")
        if self.legacy and kind != "charuco":
            raise BoardSpecError(f"legacy is a ChArUco pattern switch; a {kind} board has none")
        name = {
            "charuco": "ChArUco board",
            "checkerboard": "checkerboard",
            "aruco_grid": "marker grid",
            "circles": "circle grid",
            "asymmetric_circles": "asymmetric circle grid",
        }[kind]
        least = 3 if kind in _NO_MARKERS else 2
        if int(self.squares_x) < least or int(self.squares_y) < least:
            raise BoardSpecError(
                f"a {name} needs at least {least}x{least} squares, got {self.squares_x}x{self.squares_y}"
            )
        if not np.isfinite(self.square_length_m) or self.square_length_m <= 0:
            raise BoardSpecError(f"square length {self.square_length_m} m must be positive")
        if self.square_length_m > 1.0:
            raise BoardSpecError(f"square length {self.square_length_m} m: lengths are in metres (millimetres given?)")
        if kind == "checkerboard":
            if (self.squares_x + self.squares_y) % 2 == 0:
                raise BoardSpecError(
                    f"a {self.squares_x}x{self.squares_y} checkerboard looks the same turned by 180 degrees, so its "
                    "corner order is ambiguous; use one even and one odd square count (e.g. 10x7)"
                )
            return
        if kind in ("circles", "asymmetric_circles"):
            self._check_circles(name)
            return
        if not 0 < self.marker_length_m < self.square_length_m:
            raise BoardSpecError(
                f"marker length {self.marker_length_m} m must be positive and smaller than the square length "
                f"{self.square_length_m} m (swapped?)"
            )
        n_markers = self.n_markers
        size = dictionary_size(self.dictionary)
        if n_markers > size:
            raise BoardSpecError(
                f"a {self.squares_x}x{self.squares_y} {name} needs {n_markers} markers; "
                f"dictionary {self.dictionary} has {size}"
            )

    def _check_circles(self, name: str) -> None:
        """The circle grid's own rules: diameter below the spacing, an order that a view can fix."""
        if not 0 < self.marker_length_m < self.square_length_m:
            raise BoardSpecError(
                f"circle diameter {self.marker_length_m} m must be positive and smaller than the spacing "
                f"{self.square_length_m} m (swapped?)"
            )
        if self.kind == "circles" and self.squares_x == self.squares_y:
            raise BoardSpecError(
                f"a {self.squares_x}x{self.squares_y} {name} looks the same turned by 90 degrees; use different "
                "counts of circles a row and of rows (e.g. 7x6)"
            )
        if self.kind == "asymmetric_circles" and self.squares_y % 2 == 0:
            raise BoardSpecError(
                f"a {name} of {self.squares_y} rows looks the same turned by 180 degrees, so its circle order is "
                "ambiguous; use an odd number of rows (e.g. 4x11)"
            )

    @classmethod
    def circle_grid(
        cls, cols: int, rows: int, spacing_m: float, diameter_m: float, asymmetric: bool = False
    ) -> "BoardSpec":
        """A grid of ``cols`` circles a row, ``rows`` rows, ``diameter_m`` wide (:mod:`classic.vision.circle_grid`).

        ``spacing_m`` is ``s``: the distance between neighbours of a symmetric grid; for an asymmetric grid
        (OpenCV's pattern) the rows' pitch, circles of one row being ``2 s`` apart.
        """
        kind = "asymmetric_circles" if asymmetric else "circles"
        return cls(cols, rows, spacing_m, diameter_m, "", kind=kind)

    @classmethod
    def checkerboard(cls, squares_x: int, squares_y: int, square_length_m: float) -> "BoardSpec":
        """A plain chessboard of ``squares_x`` by ``squares_y`` squares (one count even, one odd)."""
        return cls(squares_x, squares_y, square_length_m, 0.0, "", kind="checkerboard")

    @classmethod
    def aruco_grid(
        cls,
        markers_x: int,
        markers_y: int,
        marker_length_m: float,
        separation_m: float,
        dictionary: str = "APRILTAG_36h11",
    ) -> "BoardSpec":
        """A grid of markers ``marker_length_m`` wide, ``separation_m`` apart (OpenCV's ``GridBoard``)."""
        return cls(markers_x, markers_y, marker_length_m + separation_m, marker_length_m, dictionary, kind="aruco_grid")

    @property
    def n_markers(self) -> int:
        """Markers on the board (0 for a checkerboard or a circle grid)."""
        return {
            "charuco": (self.squares_x * self.squares_y) // 2,
            "aruco_grid": self.squares_x * self.squares_y,
        }.get(self.kind, 0)

    @property
    def n_corners(self) -> int:
        """Number of corner ids: inner corners, 4 per marker of a marker grid, or the circles of a grid."""
        if self.kind == "aruco_grid":
            return 4 * self.n_markers
        if self.kind in ("circles", "asymmetric_circles"):
            return self.squares_x * self.squares_y
        return (self.squares_x - 1) * (self.squares_y - 1)

    @property
    def size_m(self) -> tuple[float, float]:
        """Board width and height in metres (a marker grid: outer marker edge to outer marker edge)."""
        if self.kind == "circles":
            return (self.squares_x + 1) * self.square_length_m, (self.squares_y + 1) * self.square_length_m
        if self.kind == "asymmetric_circles":
            return (2 * self.squares_x + 1) * self.square_length_m, (self.squares_y + 1) * self.square_length_m
        gap = self.square_length_m - self.marker_length_m if self.kind == "aruco_grid" else 0.0
        return self.squares_x * self.square_length_m - gap, self.squares_y * self.square_length_m - gap

    def corners_target(self) -> np.ndarray:
        """Corners in the target frame, metres, in id order.

        Returns
        -------
        p_target : array, shape (n_corners, 3)
            ChArUco and checkerboard: inner corner ``k = r (squares_x - 1) + c`` at ``((c + 1) L, (r + 1) L, 0)``.
            Marker grid: corner ``k = 4 i + j`` of marker ``i = r squares_x + c`` at ``(c L, r L, 0)`` plus
            ``(0, 0), (m, 0), (m, m), (0, m)`` for ``j = 0..3`` (OpenCV's top-left, clockwise), ``L`` the pitch,
            ``m`` the marker side. Circle grids: the circles' centres (:mod:`classic.vision.circle_grid`).
        """
        L = self.square_length_m
        if self.kind in ("circles", "asymmetric_circles"):
            from classic.vision.circle_grid import circle_centres

            return circle_centres(self.kind, int(self.squares_x), int(self.squares_y), L)
        if self.kind == "aruco_grid":
            i, j = np.divmod(np.arange(self.n_corners), 4)
            r, c = np.divmod(i, self.squares_x)
            m = self.marker_length_m
            off = np.array([[0.0, 0.0], [m, 0.0], [m, m], [0.0, m]])[j]
            return np.column_stack([c * L + off[:, 0], r * L + off[:, 1], np.zeros(self.n_corners)])
        r, c = np.divmod(np.arange(self.n_corners), self.squares_x - 1)
        return np.column_stack([(c + 1) * L, (r + 1) * L, np.zeros(self.n_corners)])

    def cv_board(self):
        """The OpenCV board: ``cv2.aruco.CharucoBoard`` or ``cv2.aruco.GridBoard``.

        Raises
        ------
        BoardSpecError
            For a checkerboard, which has no OpenCV board object.
        """
        if self.kind in _NO_MARKERS:
            raise BoardSpecError(f"a {self.kind.replace('_', ' ')} board has no OpenCV aruco board")
        d = cv2.aruco.getPredefinedDictionary(dictionary_id(self.dictionary))
        size = (int(self.squares_x), int(self.squares_y))
        if self.kind == "aruco_grid":
            gap = float(self.square_length_m - self.marker_length_m)
            return cv2.aruco.GridBoard(size, float(self.marker_length_m), gap, d)
        board = cv2.aruco.CharucoBoard(size, float(self.square_length_m), float(self.marker_length_m), d)
        board.setLegacyPattern(bool(self.legacy))
        return board

    def render(self, pixels_per_metre: float, margin_px: int = 0) -> np.ndarray:
        """Image of the board, one pixel per ``1 / pixels_per_metre`` metres.

        Parameters
        ----------
        pixels_per_metre : float
            E.g. ``dpi / 0.0254`` for printing.
        margin_px : int
            White margin around the board.

        Returns
        -------
        image : array of uint8, shape (H, W)
            The board's top-left corner (target origin) is at pixel ``(margin_px, margin_px)``.
            Each square (marker pitch) is a whole number of pixels, :meth:`pixels_per_square` (rounded from
            ``square_length_m * pixels_per_metre``), so the drawing is exact; a marker grid's markers are
            ``round(marker_length_m / square_length_m * pixels_per_square)`` pixels.
        """
        n = self.pixels_per_square(pixels_per_metre)
        if self.kind == "checkerboard":
            from classic.vision.checkerboard import render_checkerboard

            return render_checkerboard(self.squares_x, self.squares_y, n, int(margin_px))
        if self.kind == "aruco_grid":
            from classic.vision.aruco_grid import render_grid

            return render_grid(self, n, int(margin_px))
        if self.kind in ("circles", "asymmetric_circles"):
            from classic.vision.circle_grid import render_circle_grid

            return render_circle_grid(self, n, int(margin_px))
        w = self.squares_x * n + 2 * margin_px
        h = self.squares_y * n + 2 * margin_px
        return self.cv_board().generateImage((w, h), marginSize=int(margin_px), borderBits=1)

    def pixels_per_square(self, pixels_per_metre: float) -> int:
        """Whole pixels per square used by :meth:`render` (at least 10)."""
        return max(10, int(round(self.square_length_m * pixels_per_metre)))

    def to_dict(self) -> dict:
        """JSON-serialisable dictionary."""
        out = asdict(self)
        out["legacy"] = bool(out["legacy"])
        return out

    def save(self, path: str | Path) -> None:
        """Write the spec as JSON."""
        write_text_atomic(path, json.dumps({"type": self.kind, **self.to_dict()}, indent=2) + "\n")

    @classmethod
    def load(cls, path: str | Path) -> "BoardSpec":
        """Read a spec written by :meth:`save` (a file without ``kind`` is a ChArUco board).

        Raises
        ------
        BoardSpecError
            Naming the file, if it is missing, not JSON, or not a valid spec.
        """
        path = Path(path)
        from handeye.core.jsonfile import read_json_file

        doc = read_json_file(path, BoardSpecError, "board file")
        if not isinstance(doc, dict):
            raise BoardSpecError(f"{path}: not a board spec (a JSON object is needed)")
        kind = str(doc.get("kind", doc.get("type", "charuco"))).lower().replace("-", "_")
        fields = ["squares_x", "squares_y", "square_length_m"]
        if kind != "checkerboard":
            fields += ["marker_length_m"]
        if kind not in _NO_MARKERS:
            fields += ["dictionary"]
        missing = [f for f in fields if f not in doc]
        if missing:
            raise BoardSpecError(f"{path}: missing {', '.join(missing)}")
        legacy = doc.get("legacy", False)
        if not isinstance(legacy, bool):
            raise BoardSpecError(f"{path}: legacy must be true or false, got {legacy!r}")
        from handeye.core.numbers import as_float, as_int

        try:
            return cls(
                as_int(doc["squares_x"], f"{path}: squares_x", BoardSpecError),
                as_int(doc["squares_y"], f"{path}: squares_y", BoardSpecError),
                as_float(doc["square_length_m"], f"{path}: square_length_m", BoardSpecError),
                as_float(doc.get("marker_length_m", 0.0), f"{path}: marker_length_m", BoardSpecError),
                str(doc.get("dictionary", "")),
                kind,
                legacy,
            )
        except BoardSpecError as exc:
            raise BoardSpecError(exc if str(exc).startswith(str(path)) else f"{path}: {exc}") from None
        except (TypeError, ValueError) as exc:
            raise BoardSpecError(f"{path}: not a valid board spec ({exc})") from None
