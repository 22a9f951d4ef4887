"""Read a small text file, or raise one named error that says which way the path is not one.

Every reader of the front's text formats (pose CSV and JSON, YAML, OpenCV FileStorage YAML, matrix text files)
takes its text through :func:`read_text`, so a directory, a missing path, a device or FIFO, a file too large, a
binary file and a file in another encoding are refused the same way, in one line naming the path.
"""

from __future__ import annotations

import stat
from pathlib import Path

from handeye.core.errors import PoseFileError
from handeye.core.limits import MAX_TEXT_FILE_BYTES

__all__ = ["check_text_file", "file_kind", "read_text"]


def file_kind(path: str | Path) -> str:
    """What a path that exists but is not a regular file is, for a message: "a FIFO", "a device", ...

    Parameters
    ----------
    path : str or Path

    Returns
    -------
    str
        "a directory", "a FIFO (named pipe)", "a character device", "a block device", "a socket", or
        "not a regular file".
    """
    try:
        mode = Path(path).stat().st_mode
    except OSError:
        return "not a regular file"
    for test, name in (
        (stat.S_ISDIR, "a directory"),
        (stat.S_ISFIFO, "a FIFO (named pipe)"),
        (stat.S_ISCHR, "a character device"),
        (stat.S_ISBLK, "a block device"),
        (stat.S_ISSOCK, "a socket"),
    ):
        if test(mode):
            return name
    return "not a regular file"


def check_text_file(
    path: str | Path,
    what: str = "text file",
    error: type[Exception] = PoseFileError,
    max_bytes: int = MAX_TEXT_FILE_BYTES,
) -> Path:
    """The path, checked to be a regular file no larger than ``max_bytes``, before anything reads it.

    Parameters
    ----------
    path : str or Path
    what : str
        What the file should be, for the messages.
    error : type of Exception
    max_bytes : int

    Returns
    -------
    Path

    Raises
    ------
    error
        A directory, a missing path, not a regular file (a device, a FIFO), or too large.
    """
    path = Path(path)
    if path.is_dir():
        raise error(f"{path}: is a directory, not a {what}")
    if not path.exists():
        raise error(f"{path}: no such file")
    if not path.is_file():
        raise error(f"{path}: {file_kind(path)}, not a file; give a {what}")
    size = path.stat().st_size
    if size > max_bytes:
        raise error(f"{path}: {size:,} bytes, too large for a {what} (at most {max_bytes:,})")
    return path


def read_text(
    path: str | Path,
    what: str = "text file",
    error: type[Exception] = PoseFileError,
    max_bytes: int = MAX_TEXT_FILE_BYTES,
    hint: str = "",
) -> str:
    """The file's text (UTF-8, a byte-order mark dropped).

    Parameters
    ----------
    path : str or Path
    what : str
        What the file should be, for the messages ("pose file", "YAML file").
    error : type of Exception
        The error raised (its message one line naming the path).
    max_bytes : int
        Larger files are refused before they are read.
    hint : str
        Appended to the encoding error ("; save the pose file as UTF-8").

    Returns
    -------
    str

    Raises
    ------
    error
        The path is a directory, missing, not a regular file, too large, unreadable, binary or not UTF-8.
    """
    path = check_text_file(path, what, error, max_bytes)
    try:
        raw = path.read_bytes()
    except OSError as exc:
        raise error(f"{path}: cannot read ({exc.strerror or exc})") from None
    if b"\x00" in raw:
        raise error(f"{path}: a binary file, not a {what}")
    try:
        return raw.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise error(f"{path}: not UTF-8 text (byte {exc.start}){hint}") from None
