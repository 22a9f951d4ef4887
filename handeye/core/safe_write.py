"""Write an output file whole or not at all, and only where a regular file belongs.

Every file a command writes goes through :func:`write_text_atomic` or :func:`write_bytes_atomic`:

- the target is checked first (:func:`check_output_path`): a directory, a device, a FIFO or a socket is
  refused in one line (renaming a temporary file over ``/dev/null`` would replace the device), and so is a
  path whose folder does not exist;
- a symbolic link is followed on purpose: the file it points to is replaced and the link kept, as an
  editor saving through a link does;
- the data go to a temporary file beside the target, flushed to disk, then renamed over it
  (``os.replace``, atomic on one file system): a reader sees the old file or the new one, never a part;
- any ``OSError`` (a full disk, no permission, a read-only folder) removes the temporary file and raises
  :class:`handeye.core.errors.OutputFileError` naming the path and the cause, so a rerun starts clean.

Written here because the standard library has the pieces (``tempfile``, ``os.replace``) but not the checks.
"""

from __future__ import annotations

import os
import stat
import tempfile
from pathlib import Path

from handeye.core.errors import OutputFileError

__all__ = [
    "check_output_folder",
    "check_output_path",
    "write_bytes_atomic",
    "write_figure_atomic",
    "write_text_atomic",
]


#: What an output path that is not a regular file is, for the refusal: the first test of its mode that holds.
_MODE_KINDS = {stat.S_ISDIR: "a directory", stat.S_ISFIFO: "a FIFO", stat.S_ISCHR: "a device", stat.S_ISBLK: "a device"}


def _link_target(path: Path) -> Path:
    """The path a symbolic link points to (``path`` itself when it is not a link), refusing a dangling link."""
    if not path.is_symlink():
        return path
    try:
        return path.resolve(strict=True)
    except (OSError, RuntimeError):
        raise OutputFileError(f"{path}: a symbolic link to nothing that exists; remove it or name another file")


def check_output_path(path: str | Path) -> Path:
    """The regular file a write to ``path`` replaces: symbolic links followed, anything else refused.

    Parameters
    ----------
    path : str or Path

    Returns
    -------
    Path
        The path to write (the link's target for a symbolic link).

    Raises
    ------
    OutputFileError
        A directory, device, FIFO or socket, a dangling or looping link, or a folder that does not exist.
    """
    path = Path(path)
    target = _link_target(path)
    try:
        mode = target.stat().st_mode
    except FileNotFoundError:
        mode = None
    except OSError as exc:
        raise OutputFileError(f"{path}: cannot write here ({exc.strerror or exc})") from None
    if mode is not None and not stat.S_ISREG(mode):
        kind = next((name for test, name in _MODE_KINDS.items() if test(mode)), "not a regular file")
        raise OutputFileError(f"{path}: {kind}, not a file to write; name a file")
    if not target.parent.is_dir():
        raise OutputFileError(f"{path}: the folder {target.parent} does not exist; create it or name another file")
    if not os.access(target.parent, os.W_OK | os.X_OK):
        raise OutputFileError(
            f"{path}: cannot write in the folder {target.parent} (permission denied); name another file"
        )
    return target


def check_output_folder(path: str | Path) -> Path:
    """A folder that files can be written into (created later if missing): checked before the work starts.

    Parameters
    ----------
    path : str or Path

    Returns
    -------
    Path

    Raises
    ------
    OutputFileError
        ``path`` exists and is not a folder, or the nearest folder that exists above it cannot be written.
    """
    path = Path(path)
    if path.exists() and not path.is_dir():
        raise OutputFileError(f"{path}: exists and is not a folder; name a folder for the files")
    existing = path
    while not existing.exists():
        if existing.is_symlink():
            raise OutputFileError(f"{path}: a symbolic link to nothing that exists ({existing}); name another folder")
        existing = existing.parent
    if not existing.is_dir():
        raise OutputFileError(f"{path}: {existing} is not a folder; name another folder")
    if not os.access(existing, os.W_OK | os.X_OK):
        raise OutputFileError(f"{path}: cannot write in {existing} (permission denied); name another folder")
    return path


def _mode_for(target: Path) -> int:
    """The new file's permissions: the old file's, or what ``open`` would give under the umask."""
    try:
        return stat.S_IMODE(target.stat().st_mode)
    except OSError:
        umask = os.umask(0)
        os.umask(umask)
        return 0o666 & ~umask


def write_bytes_atomic(path: str | Path, data: bytes) -> Path:
    """Write ``data`` to ``path`` whole, or raise with nothing changed.

    Parameters
    ----------
    path : str or Path
    data : bytes

    Returns
    -------
    Path
        The file written (a symbolic link's target).

    Raises
    ------
    OutputFileError
    """
    target = check_output_path(path)
    tmp = None
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".tmp", dir=target.parent)
        with os.fdopen(fd, "wb") as f:
            f.write(data)
            f.flush()
            os.fsync(f.fileno())
        os.chmod(tmp, _mode_for(target))
        os.replace(tmp, target)
    except BaseException as exc:  # a full disk, or Ctrl-C: no temporary file left behind either way
        try:
            if tmp is not None:
                os.unlink(tmp)
        except OSError:
            pass
        if isinstance(exc, OSError):
            raise OutputFileError(f"{path}: cannot write ({exc.strerror or exc}); nothing was written") from None
        raise
    return target


def write_text_atomic(path: str | Path, text: str, errors: str = "strict") -> Path:
    """Write ``text`` (UTF-8) to ``path`` whole, or raise with nothing changed (:func:`write_bytes_atomic`).

    Parameters
    ----------
    path : str or Path
    text : str
    errors : str
        Encoding error handler (``"backslashreplace"`` for text holding undecodable file names).

    Returns
    -------
    Path
    """
    return write_bytes_atomic(path, text.encode("utf-8", errors=errors))


def write_figure_atomic(fig, path: str | Path, **savefig_kwargs) -> Path:
    """Render a matplotlib figure in memory and write it whole (:func:`write_bytes_atomic`).

    Parameters
    ----------
    fig : matplotlib.figure.Figure
    path : str or Path
        The image format is the suffix's (``.png`` when there is none).
    **savefig_kwargs
        Passed to ``fig.savefig`` (``dpi``, ``bbox_inches``...).

    Returns
    -------
    Path
    """
    import io

    buffer = io.BytesIO()
    fmt = Path(path).suffix.lstrip(".").lower() or "png"
    fig.savefig(buffer, format=fmt, **savefig_kwargs)
    return write_bytes_atomic(path, buffer.getvalue())
