"""ArUco and AprilTag dictionaries by name, and the board specification's error.

Its own module so that :mod:`classic.vision.board` and :mod:`classic.vision.aruco_grid` (which renders and
detects the marker grids ``board`` describes) both import it, and not each other.
"""

from __future__ import annotations

import cv2

from handeye.core.errors import HandEyeInputError

__all__ = ["BoardSpecError", "dictionary_id", "dictionary_size"]


class BoardSpecError(HandEyeInputError):
    """A board specification is invalid or cannot be read."""


def dictionary_id(name: str) -> int:
    """OpenCV's constant of an ArUco or AprilTag dictionary: ``"5X5_100"``, ``"DICT_APRILTAG_36h11"``, any case.

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
    names = {k.upper(): k for k in dir(cv2.aruco) if k.startswith("DICT_") and isinstance(getattr(cv2.aruco, k), int)}
    if key not in names:
        known = sorted({k[5:] for k in names})
        raise BoardSpecError(f"unknown ArUco dictionary {name!r}; known: {', '.join(known)}")
    return int(getattr(cv2.aruco, names[key]))


def dictionary_size(name: str) -> int:
    """How many markers the ArUco dictionary ``name`` holds (a board may use no more).

    Parameters
    ----------
    name : str
        A dictionary name (:func:`dictionary_id`).

    Returns
    -------
    int
    """
    return int(cv2.aruco.getPredefinedDictionary(dictionary_id(name)).bytesList.shape[0])
