"""The benchmarks' report header: the command it repeats is one a shell takes back as it was given."""

from __future__ import annotations

import shlex

from benchmarks._report import Report


def test_the_header_repeats_the_command_quoted(capsys):
    argv = ["--bands", "1.2 m", "--sensors", "d435-sgbm", "d435"]
    rep = Report("t", "benchmarks/imported_bag.py", argv, "numpy")
    command = next(line for line in rep.lines if line.startswith("command: "))
    assert shlex.split(command.removeprefix("command: ")) == ["python", "benchmarks/imported_bag.py", *argv]
