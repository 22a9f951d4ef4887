"""The printed report of a benchmark: a header with the command, the machine and the versions, then lines.

One rule for every benchmark: the report is printed, and written to a file only when ``--out`` names one
(:meth:`Report.add_out`, :meth:`Report.write`). No benchmark defaults ``--out`` to a page under
``benchmarks/results/``: a run cut short (``--max-placements 1``, a smoke run) would replace the page the
documentation quotes without a word.
"""

from __future__ import annotations

import argparse
import datetime
import os
import shlex
import sys
from pathlib import Path

from benchmarks._machine import machine
from handeye.core.safe_write import write_text_atomic
from handeye.core.smoke import NOTICE, smoke_test


class Report:
    """Lines printed as they come and kept, for ``--out``.

    Parameters
    ----------
    title : str
    script : str
        The script's path from the repository root, e.g. ``benchmarks/plan_poses.py``.
    argv : list of str or None
        The arguments as given (``sys.argv[1:]`` when None), so the header repeats the command.
    versions : str
        Library versions, e.g. ``"numpy 2.4.6"``.
    """

    def __init__(self, title: str, script: str, argv, versions: str):
        self.lines: list[str] = []
        args = argv if argv is not None else sys.argv[1:]
        self.say(f"# {title}")
        self.say("command: python " + shlex.join([script, *args]))  # quoted as a shell takes it back
        self.say(f"machine: {machine()}")
        self.say(f"{versions}; {datetime.datetime.now(datetime.UTC):%Y-%m-%d %H:%M} UTC")
        if smoke_test():
            self.say(f"SMOKE RUN: {NOTICE}")
        self.say()

    @staticmethod
    def cut(args, **sizes) -> None:
        """In a smoke run (:mod:`handeye.core.smoke`), each ``args.NAME`` cut to at most ``sizes[NAME]``
        (a None, "all", becomes ``sizes[NAME]``): a benchmark's own sizes, as the presets cut theirs."""
        if smoke_test():
            for name, most in sizes.items():
                value = getattr(args, name)
                setattr(args, name, most if value is None else min(value, most))

    def say(self, s: str = "") -> None:
        """Print a line and keep it."""
        print(s, flush=True)
        self.lines.append(s)

    @staticmethod
    def add_out(ap: argparse.ArgumentParser, flag: str = "--out") -> None:
        """Add ``flag`` (a path, default None) to ``ap``: the file the report is written to, printed only without it."""
        ap.add_argument(
            flag,
            type=Path,
            default=None,
            help="also write the report to this file (Markdown); without it the report is printed only",
        )

    def write(self, out: str | os.PathLike | None) -> int:
        """Write the kept lines to ``out`` when given, nothing otherwise; returns 0 (the scripts' exit status)."""
        if out:
            write_text_atomic(out, "\n".join(self.lines) + "\n")  # no half report, no FIFO or link written into
            print(f"written: {out}", file=sys.stderr)
        return 0
