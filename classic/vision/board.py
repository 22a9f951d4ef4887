"""ChArUco board specification: the printable board and its corner coordinates."""

from __future__ import annotations

import json
from dataclasses import asdict, dataclass
from pathlib import Path

import cv2
import numpy as np

from handeye.core.errors import HandEyeInputError

__all__ = ["BoardSpec", "BoardSpecError", "dictionary_id"]


class BoardSpecError(HandEyeInputError):
    """A board specification is invalid or cannot be read."""


def dictionary_id(name: str) -> int:
    """OpenCV's constant of an ArUco dictionary: ``"5X5_100"``, ``"DICT_5X5_100"``, any case.

    Parameters
    ----------
    name : str

    Returns
    -------
    int

    Raises
    ------
    BoardSpecError
    """
    key = str(name).upper()
    key = key if key.startswith("DICT_") else "DICT_" + key
    if not hasattr(cv2.aruco, key):
        known = sorted(k[5:] for k in dir(cv2.aruco) if k.startswith("DICT_") and "APRILTAG" not in k)
        raise BoardSpecError(f"unknown ArUco dictionary {name!r}; known: {', '.join(known)}")
    return int(getattr(cv2.aruco, key))


@dataclass(frozen=True)
class BoardSpec:
    """A ChArUco board: squares, their size, the markers' size and dictionary.

    Attributes
    ----------
    squares_x, squares_y : int
        Number of squares along x (columns) and y (rows).
    square_length_m : float
        Side of a chessboard square, metres.
    marker_length_m : float
        Side of an ArUco marker, metres (smaller than the square).
    dictionary : str
        ArUco dictionary, e.g. ``"5X5_100"``.

    Examples
    --------
    >>> spec = BoardSpec(7, 5, 0.04, 0.03, "5X5_100")
    >>> spec.corners_target().shape
    (24, 3)
    """

    squares_x: int
    squares_y: int
    square_length_m: float
    marker_length_m: float
    dictionary: str = "5X5_100"

    def __post_init__(self):
        if int(self.squares_x) < 2 or int(self.squares_y) < 2:
            raise BoardSpecError(f"a ChArUco board needs at least 2x2 squares, got {self.squares_x}x{self.squares_y}")
        if not 0 < self.marker_length_m < self.square_length_m:
            raise BoardSpecError(
                f"marker length {self.marker_length_m} m must be positive and smaller than the square length "
                f"{self.square_length_m} m (swapped?)"
            )
        if self.square_length_m > 1.0:
            raise BoardSpecError(f"square length {self.square_length_m} m: lengths are in metres (millimetres given?)")
        n_markers = (self.squares_x * self.squares_y) // 2
        size = int(cv2.aruco.getPredefinedDictionary(dictionary_id(self.dictionary)).bytesList.shape[0])
        if n_markers > size:
            raise BoardSpecError(f"a {self.squares_x}x{self.squares_y} board needs {n_markers} markers; "
                                 f"dictionary {self.dictionary} has {size}")

    @property
    def n_corners(self) -> int:
        """Number of inner (ChArUco) corners."""
        return (self.squares_x - 1) * (self.squares_y - 1)

    @property
    def size_m(self) -> tuple[float, float]:
        """Board width and height in metres."""
        return self.squares_x * self.square_length_m, self.squares_y * self.square_length_m

    def corners_target(self) -> np.ndarray:
        """Inner corners in the target frame, metres, in ChArUco id order.

        Returns
        -------
        p_target : array, shape (n_corners, 3)
            Corner ``k = r (squares_x - 1) + c`` at ``((c + 1) L, (r + 1) L, 0)``.
        """
        r, c = np.divmod(np.arange(self.n_corners), self.squares_x - 1)
        L = self.square_length_m
        return np.column_stack([(c + 1) * L, (r + 1) * L, np.zeros(self.n_corners)])

    def cv_board(self):
        """The OpenCV ``cv2.aruco.CharucoBoard``."""
        d = cv2.aruco.getPredefinedDictionary(dictionary_id(self.dictionary))
        return cv2.aruco.CharucoBoard(
            (int(self.squares_x), int(self.squares_y)), float(self.square_length_m), float(self.marker_length_m), d
        )

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
            Each square is a whole number of pixels, :meth:`pixels_per_square` (rounded from
            ``square_length_m * pixels_per_metre``), so the drawing is exact.
        """
        n = self.pixels_per_square(pixels_per_metre)
        w = self.squares_x * n + 2 * margin_px
        h = self.squares_y * n + 2 * margin_px
        return self.cv_board().generateImage((w, h), marginSize=int(margin_px), borderBits=1)

    def pixels_per_square(self, pixels_per_metre: float) -> int:
        """Whole pixels per square used by :meth:`render` (at least 10)."""
        return max(10, int(round(self.square_length_m * pixels_per_metre)))

    def to_dict(self) -> dict:
        """JSON-serialisable dictionary."""
        return asdict(self)

    def save(self, path: str | Path) -> None:
        """Write the spec as JSON."""
        Path(path).write_text(json.dumps({"type": "charuco", **self.to_dict()}, indent=2) + "\n")

    @classmethod
    def load(cls, path: str | Path) -> "BoardSpec":
        """Read a spec written by :meth:`save`.

        Raises
        ------
        BoardSpecError
            Naming the file, if it is missing, not JSON, or not a valid spec.
        """
        path = Path(path)
        try:
            doc = json.loads(path.read_text())
        except FileNotFoundError:
            raise BoardSpecError(f"{path}: no such board file") from None
        except json.JSONDecodeError as exc:
            raise BoardSpecError(f"{path}: not valid JSON ({exc})") from None
        fields = ("squares_x", "squares_y", "square_length_m", "marker_length_m", "dictionary")
        missing = [f for f in fields if f not in doc]
        if missing:
            raise BoardSpecError(f"{path}: missing {', '.join(missing)}")
        try:
            return cls(int(doc["squares_x"]), int(doc["squares_y"]), float(doc["square_length_m"]),
                       float(doc["marker_length_m"]), str(doc["dictionary"]))
        except BoardSpecError as exc:
            raise BoardSpecError(f"{path}: {exc}") from None
