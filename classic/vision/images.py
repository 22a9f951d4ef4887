"""Reading images (PNG, JPEG, ...) with errors that name the file."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np

from handeye.core.errors import HandEyeInputError
from handeye.core.limits import check_image_bytes

__all__ = ["ImageError", "IMAGE_SUFFIXES", "read_image", "list_images"]

IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff")
_PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
_PNG_END = b"IEND"


class ImageError(HandEyeInputError):
    """An image cannot be read."""


def read_image(path: str | Path) -> np.ndarray:
    """Read an image as 8-bit grayscale.

    Parameters
    ----------
    path : str or Path

    Returns
    -------
    image : array of uint8, shape (H, W)

    Raises
    ------
    ImageError
        If the file is missing or not a readable image.
    """
    path = Path(path)
    if not path.is_file():
        raise ImageError(f"{path}: no such image")
    try:  # bytes decoded in memory: cv2.imread crashes on a file name that is not UTF-8
        data = np.fromfile(path, dtype=np.uint8)
    except OSError as exc:
        raise ImageError(f"{path}: cannot read the image ({exc.strerror or exc})") from None
    if data[:8].tobytes() == _PNG_SIGNATURE and _PNG_END not in data.tobytes():
        # refused before decoding: libpng would print its own error line on stderr first
        raise ImageError(f"{path}: a truncated PNG (its end chunk is missing)")
    check_image_bytes(data.tobytes(), str(path), ImageError)  # a decompression bomb, refused from its header
    image = cv2.imdecode(data, cv2.IMREAD_GRAYSCALE) if data.size else None
    if image is None:
        raise ImageError(f"{path}: not a readable image (PNG, JPEG, BMP or TIFF expected)")
    return image


def list_images(folder: str | Path) -> list[Path]:
    """Image files of a folder, sorted by name.

    Raises
    ------
    ImageError
        If the folder is missing or holds no image.
    """
    folder = Path(folder)
    if not folder.is_dir():
        raise ImageError(f"{folder}: no such folder")
    files = sorted(p for p in folder.iterdir() if p.suffix.lower() in IMAGE_SUFFIXES)
    if not files:
        raise ImageError(f"{folder}: no images ({', '.join(IMAGE_SUFFIXES)})")
    return files
