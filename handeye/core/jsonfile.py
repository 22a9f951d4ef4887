"""Read a user's JSON file, every way it can be unreadable reported as one named error naming the file."""

from __future__ import annotations

import json
from pathlib import Path

from handeye.core.limits import MAX_JSON_DEPTH, check_json_depth
from handeye.core.numbers import loads_json
from handeye.core.textfile import file_kind

__all__ = ["MAX_JSON_BYTES", "read_json_file"]

#: A JSON file larger than this is refused before it is read (specs, detections and metadata take kilobytes).
MAX_JSON_BYTES = 64 * 1024 * 1024


def read_json_file(path: str | Path, error: type[Exception], what: str = "JSON file", constants: bool = False):
    """The parsed document of ``path``, or ``error`` (a :class:`HandEyeInputError` subclass) naming the file.

    Parameters
    ----------
    path : str or Path
    error : type
        The exception raised, e.g. :class:`handeye.core.errors.DatasetError`.
    what : str
        What the file should be, for the message ("board file", "detections file").
    constants : bool
        Read ``NaN`` and ``Infinity`` as floats: only for handeye's own result files, whose writers record an
        undefined metric so (:func:`handeye.core.numbers.loads_json`); a user's file refuses them.

    Raises
    ------
    error
        A directory, no such file, a FIFO or device, over :data:`MAX_JSON_BYTES`, unreadable, not UTF-8, not
        JSON, a number outside the grammar of :mod:`handeye.core.numbers` (``NaN``, 5,000 digits).
    """
    path = Path(path)
    if path.is_dir():
        raise error(f"{path}: is a directory, not a {what}")
    if not path.exists():
        raise error(f"{path}: no such {what}")
    if not path.is_file():
        raise error(f"{path}: {file_kind(path)}, not a file; give a {what}")
    size = path.stat().st_size
    if size > MAX_JSON_BYTES:
        raise error(f"{path}: {size:,} bytes, too large for a {what} (at most {MAX_JSON_BYTES:,})")
    try:
        raw = path.read_bytes()
    except OSError as exc:
        raise error(f"{path}: cannot read the {what} ({exc.strerror or exc})") from None
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise error(f"{path}: not UTF-8 text (byte {exc.start}), not a {what}") from None
    try:
        doc = loads_json(text, str(path), error, constants=constants)
    except json.JSONDecodeError as exc:
        raise error(f"{path}: not valid JSON ({exc}), not a {what}") from None
    except RecursionError:
        raise error(
            f"{path}: JSON nested deeper than the parser allows (limit {MAX_JSON_DEPTH}), not a {what}"
        ) from None
    return check_json_depth(doc, str(path), error)
