"""Regenerate the example outputs the README and the documentation print, from the commands printed above them.

The files: the README, the getting-started page, the your-own-robot, images, poses, real-cell and
simulate-and-label guides (``FILES``). Run from the repository root::

    python docs/make_examples.py            # rewrite every example output in place
    python docs/make_examples.py --check    # exit 1, naming the file, where a printed output is not today's
    python docs/make_examples.py docs/guides/poses.md   # one page

An example is a ``bash`` block whose ``handeye`` command is followed by a plain fenced block: that block is the
command's output. The outputs are deterministic (seeded data, shipped example files); the tests
(``tests/test_docs.py::test_printed_examples_print_what_is_shown``) compare them with a fresh run within the
last printed digit, so an output that drifts fails CI until this script is run again.

A page that renders (``SMOKE``) runs its steps in a smoke run (``HANDEYE_SMOKE_TEST=1``: every preset cut to
seconds, :mod:`handeye.core.smoke`), and says so above its outputs; the run times and rates a command prints
change per run and are printed as ``…`` (``TIME``).
"""

from __future__ import annotations

import argparse
import contextlib
import io
import os
import re
import shlex
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
#: The pages whose examples print their output.
FILES = tuple(
    ROOT / f
    for f in (
        "README.md",
        "docs/getting-started.md",
        "docs/guides/your-robot.md",
        "docs/guides/images.md",
        "docs/guides/poses.md",
        "docs/guides/real-cell.md",
        "docs/guides/simulate-label.md",
    )
)
#: The pages whose steps render: run in a smoke run, their outputs a smoke run's.
SMOKE = tuple(ROOT / f for f in ("docs/guides/simulate-label.md",))
#: A run time or rate (``38.6 s``, ``7.5 frames/s``), which changes per run: printed as ``… s``.
TIME = re.compile(r"\b\d+(?:\.\d+)?(?= (?:s|min|frames/s|camera/s)\b)")
#: A bash block with a ``handeye`` command, then a plain block: the command's output.
EXAMPLE = re.compile(
    r"(^```bash\n(?P<command>handeye [^\n]+)\n```\n\n(?:[^\n`][^\n]*\n)*?\n?```\n)(?P<output>.*?)(^```)", re.S | re.M
)


#: A bash block of one ``python -c "..."`` (its code on one line or several): a step that writes a page's inputs
#: (a synthetic recording).
SETUP = re.compile(r'^```bash\n(?P<setup>python -c "[^"]*")\n```\n', re.M)


def run(command: str, folder: Path) -> str:
    """What ``command`` (a ``handeye`` command line) prints, run in-process in ``folder``."""
    from handeye.cli import main

    out = io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.chdir(folder):
        status = main(shlex.split(command)[1:])
    if status != 0:
        raise SystemExit(f"{command!r} exited {status}")
    return TIME.sub("…", out.getvalue())


@contextlib.contextmanager
def smoke_run(on: bool):
    """``HANDEYE_SMOKE_TEST`` set to 1 within the block where ``on`` (for this process and the steps it
    starts), as it was before after it."""
    from handeye.core.smoke import ENV

    before = os.environ.get(ENV)
    if on:
        os.environ[ENV] = "1"
    try:
        yield
    finally:
        if on and before is None:
            os.environ.pop(ENV)
        elif on:
            os.environ[ENV] = before


def outputs(path: Path, folder: Path | None = None) -> list[tuple[re.Match, str]]:
    """Each example of the file with what its command prints today: the file's steps (its ``python -c``
    blocks and its examples) run in their order in one fresh folder holding the repository's ``handeye/``
    (the shipped example files at the paths the documentation prints); what a step writes is there for the
    next, and goes with the folder (a temporary one, or the empty ``folder`` given, where it stays)."""
    text = path.read_text()
    steps = sorted([*SETUP.finditer(text), *EXAMPLE.finditer(text)], key=lambda m: m.start())
    printed = []
    with contextlib.ExitStack() as stack, smoke_run(path.resolve() in SMOKE):
        folder = folder if folder is not None else stack.enter_context(tempfile.TemporaryDirectory())
        (Path(folder) / "handeye").symlink_to(ROOT / "handeye")
        for m in steps:
            if "setup" in m.groupdict():
                env = dict(os.environ, PYTHONPATH=str(ROOT))
                subprocess.run([sys.executable, *shlex.split(m["setup"])[1:]], cwd=folder, env=env, check=True)
            else:
                printed.append((m, run(m["command"], Path(folder))))
    return printed


def regenerate(path: Path) -> tuple[str, list[str]]:
    """The file's text with every example output regenerated, and the commands whose output changed."""
    text, changed = path.read_text(), []
    fresh = {m.start(): output for m, output in outputs(path)}

    def replace(m: re.Match) -> str:
        output = fresh[m.start()]
        if output != m["output"]:
            changed.append(m["command"])
        return m.group(1) + output + m.group(4)

    return EXAMPLE.sub(replace, text), changed


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--check", action="store_true", help="change nothing; exit 1 where an output is not today's")
    ap.add_argument("files", nargs="*", type=Path, help="only these pages (default: every page of FILES)")
    args = ap.parse_args(argv)
    stale = 0
    for path in [p.resolve() for p in args.files] or FILES:
        text, changed = regenerate(path)
        for command in changed:
            name = path.relative_to(ROOT) if path.is_relative_to(ROOT) else path
            print(f"{name}: the output of {command!r} {'differs' if args.check else 'rewritten'}")
        if changed and not args.check:
            from handeye.core.safe_write import write_text_atomic

            write_text_atomic(path, text)  # a page is rewritten whole or left as it was
        stale += len(changed)
    return 1 if args.check and stale else 0


if __name__ == "__main__":
    sys.exit(main())
