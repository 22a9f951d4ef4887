"""The ``handeye`` command line: one module per command in :mod:`handeye.commands`.

Commands import their packages lazily, inside ``run``, so that ``handeye
calibrate`` works with only the core dependencies installed.
"""

from __future__ import annotations

import argparse
import contextlib
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
    ):
        module.add_parser(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``handeye`` console script.

    Bad input exits with status 2 and a one-line message, no traceback.
    """
    args = build_parser().parse_args(argv)
    _quiet_opencv()
    if smoke_test():
        print(f"handeye {args.command}: {NOTICE}", file=sys.stderr)
    try:
        with _own_warnings(args.command):
            return int(args.run(args) or 0)
    except (HandEyeInputError, MissingDependencyError) as exc:
        print(one_line(f"handeye {args.command}: error: {exc}"), file=sys.stderr)
        return 2
    except RecursionError:  # a reader that missed its nesting limit: still one line, never a traceback
        print(f"handeye {args.command}: error: an input is nested too deeply to read", file=sys.stderr)
        return 2
    except BrokenPipeError:  # the output was piped into a reader that stopped (``| head``): not an error of ours
        sys.stderr.close()
        return 0


@contextlib.contextmanager
def _own_warnings(command: str):
    """Library warnings (numpy's overflow, OpenCV's, Pillow's) kept off the terminal; handeye's own warnings
    (:mod:`handeye.core.errors`: weak motion, ...) printed as one line each after a command that succeeded."""
    import numpy as np

    with warnings.catch_warnings(record=True) as caught, np.errstate(all="ignore"):
        warnings.simplefilter("always")
        yield  # after an error its one line is all: a failed run's warnings are not its answer
        own = [one_line(f"handeye {command}: warning: {w.message}") for w in caught if _is_own(w.category)]
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
