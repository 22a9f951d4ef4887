"""The ``handeye`` command line: one module per command in :mod:`handeye.commands`.

Commands import their packages lazily, inside ``run``, so that ``handeye
calibrate`` works with only the core dependencies installed.
"""

from __future__ import annotations

import argparse
import contextlib
import errno
import os
import sys
import warnings

from handeye.core.errors import HandEyeInputError, MissingDependencyError
from handeye.core.limits import one_line
from handeye.core.smoke import NOTICE, smoke_test

__all__ = ["main", "build_parser"]


def build_parser() -> argparse.ArgumentParser:
    """The argument parser with every sub-command registered."""
    from handeye.commands import (
        bag_poses,
        board,
        calibrate,
        compare,
        demo,
        detect,
        import_recording,
        intrinsics,
        label,
        learned,
        markerless,
        plan,
        show,
        sim,
        watch,
    )

    parser = argparse.ArgumentParser(prog="handeye", description="Robot hand-eye calibration toolkit.")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for module in (
        calibrate,
        board,
        detect,
        intrinsics,
        sim,
        label,
        show,
        learned,
        compare,
        markerless,
        demo,
        bag_poses,
        import_recording,
        plan,
        watch,
    ):
        module.add_parser(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``handeye`` console script.

    Bad input exits with status 2 and a one-line message, no traceback; a failed read or write of the
    system (a read-only folder, a full disk: an :class:`OSError`) exits with status 1 and one line naming
    the path and the cause. Standard output that cannot be written (``> /dev/full``) is one line and
    status 1; a reader that stopped reading (``| head -1``) ends the command quietly with status 1, as
    Python's own recipe for ``SIGPIPE`` does (the output is incomplete, so not a success). Ctrl-C is one
    line and status 130 (128 + SIGINT, as a shell reports it).
    """
    try:
        args = build_parser().parse_args(argv)
    except SystemExit:  # --help, or a usage error: argparse has printed it, maybe into a closed pipe
        failed = _flush_stdout("handeye")
        if failed is not None:
            return failed
        raise
    _quiet_opencv()
    prog = _prog(args)
    if smoke_test():
        _say(f"{prog}: {NOTICE}")
    try:
        with _own_warnings(prog), _guarded_stdout():
            status = int(args.run(args) or 0)
    except _StdoutError as exc:
        return _stdout_failed(prog, exc.__cause__)
    except (HandEyeInputError, MissingDependencyError) as exc:
        _say(one_line(f"{prog}: error: {exc}"))
        return 2
    except RecursionError:  # a reader that missed its nesting limit: still one line, never a traceback
        _say(f"{prog}: error: an input is nested too deeply to read")
        return 2
    except OSError as exc:
        _say(one_line(f"{prog}: error: {describe_os_error(exc)}"))
        return 1
    except KeyboardInterrupt:  # Ctrl-C: what was written is whole (safe writes, shards published whole)
        _say(f"{prog}: interrupted")
        return 130
    failed = _flush_stdout(prog)  # a full disk under stdout shows here, not at exit
    return status if failed is None else failed


def describe_os_error(exc: OSError) -> str:
    """An :class:`OSError` as one line: the path(s) it names, the cause, and the task it ran in (its notes).

    Examples
    --------
    >>> describe_os_error(PermissionError(13, "Permission denied", "/data/ds"))
    '/data/ds: Permission denied (check the permissions of that path, or choose another)'
    """
    cause = exc.strerror or str(exc) or type(exc).__name__
    paths = [str(p) for p in (exc.filename, exc.filename2) if p is not None]
    text = f"{' -> '.join(paths)}: {cause}" if paths else cause
    hint = {
        errno.ENOSPC: "free some space and run it again",
        errno.EDQUOT: "free some space and run it again",
        errno.EFBIG: "the file is over the size this system allows",
        errno.EACCES: "check the permissions of that path, or choose another",
        errno.EPERM: "check the permissions of that path, or choose another",
        errno.EROFS: "the file system is read-only: choose another path",
    }.get(exc.errno)
    notes = "; ".join(getattr(exc, "__notes__", ()))
    return text + "".join(f" ({extra})" for extra in (hint, notes) if extra)


def _say(text: str) -> None:
    """One line on stderr; nothing when stderr itself cannot be written (``2> /dev/full``)."""
    try:
        print(text, file=sys.stderr, flush=True)
    except (OSError, ValueError):
        pass


class _StdoutError(Exception):
    """Standard output could not be written (its :class:`OSError` is the ``__cause__``)."""


class _GuardedStream:
    """Standard output whose write errors are told apart from every other :class:`OSError` of a command."""

    def __init__(self, stream):
        self._stream = stream

    def write(self, text):
        try:
            return self._stream.write(text)
        except OSError as exc:
            raise _StdoutError() from exc

    def flush(self):
        try:
            return self._stream.flush()
        except OSError as exc:
            raise _StdoutError() from exc

    def __getattr__(self, name):
        return getattr(self._stream, name)


@contextlib.contextmanager
def _guarded_stdout():
    stream = sys.stdout
    sys.stdout = _GuardedStream(stream)
    try:
        yield
    finally:
        if isinstance(sys.stdout, _GuardedStream):  # a command that replaced stdout keeps its own
            sys.stdout = stream


def _flush_stdout(prefix: str) -> int | None:
    """Flush standard output; None when it worked, else the exit status after saying why (one line)."""
    try:
        sys.stdout.flush()
        return None
    except (OSError, ValueError) as exc:
        return _stdout_failed(prefix, exc)


def _stdout_failed(prefix: str, exc: BaseException | None) -> int:
    """Say why standard output failed (nothing for a reader that stopped: ``EPIPE``); the exit status, 1.

    Standard output is then pointed at the null device, so that the interpreter's own flush at exit finds
    nothing to complain about (no ``Exception ignored ... BrokenPipeError``).
    """
    _discard_stdout()
    if not (isinstance(exc, OSError) and exc.errno == errno.EPIPE):
        cause = getattr(exc, "strerror", None) or exc
        _say(f"{prefix}: error: cannot write the standard output ({cause}); its text is incomplete")
    return 1


def _discard_stdout() -> None:
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        os.close(devnull)
    except (OSError, ValueError, AttributeError):  # no file descriptor (a captured stream): drop the object
        sys.stdout = open(os.devnull, "w")  # noqa: SIM115 - lives until the interpreter exits


def _prog(args: argparse.Namespace) -> str:
    """The command as typed, for its messages: ``handeye calibrate``, ``handeye sim generate``."""
    sub = getattr(args, f"{args.command}_command", None) or getattr(args, f"{args.command}_kind", None)
    return f"handeye {args.command}" + (f" {sub}" if sub else "")


@contextlib.contextmanager
def _own_warnings(prog: str):
    """Library warnings (numpy's overflow, OpenCV's, Pillow's) kept off the terminal; handeye's own warnings
    (:mod:`handeye.core.errors`: weak motion, ...) printed as one line each after a command that succeeded."""
    import numpy as np

    with warnings.catch_warnings(record=True) as caught, np.errstate(all="ignore"):
        warnings.simplefilter("always")
        yield  # after an error its one line is all: a failed run's warnings are not its answer
        own = [one_line(f"{prog}: warning: {w.message}") for w in caught if _is_own(w.category)]
        for text in dict.fromkeys(own):
            print(text, file=sys.stderr)


def _is_own(category) -> bool:
    return category.__module__.split(".")[0] in ("handeye", "classic", "sim", "learned")


def _quiet_opencv() -> None:
    """OpenCV's own warnings off stderr (a truncated PNG prints one before our error names the file)."""
    os.environ.setdefault("OPENCV_LOG_LEVEL", "ERROR")  # read when cv2 is first imported
    cv2 = sys.modules.get("cv2")
    if cv2 is not None:
        cv2.utils.logging.setLogLevel(cv2.utils.logging.LOG_LEVEL_ERROR)


if __name__ == "__main__":
    sys.exit(main())
