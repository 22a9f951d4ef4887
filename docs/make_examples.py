"""Regenerate the example outputs the README and the documentation print, from the commands printed above them.

The files: the README, the getting-started page, the your-own-robot, images, poses, real-cell,
simulate-and-label, learned and markerless guides (``FILES``). Run from the repository root::

    python docs/make_examples.py            # rewrite every example output in place
    python docs/make_examples.py --check    # exit 1, naming the file, where a printed output is not today's
    python docs/make_examples.py docs/guides/poses.md   # one page

An example is a ``bash`` block whose ``handeye`` command is followed by a plain fenced block: that block is the
command's output. The outputs are deterministic (seeded data, shipped example files); the tests
(``tests/test_docs.py::test_printed_examples_print_what_is_shown``) compare them with a fresh run within the
last printed digit, so an output that drifts fails CI until this script is run again. An output of more than
``LONG`` lines is shown as its first ``HEAD`` and last ``TAIL`` lines around a line counting the rest
(:func:`trim`): the learned report's tables.

A page that renders (``SMOKE``) runs its steps in a smoke run (``HANDEYE_SMOKE_TEST=1``: every preset cut to
seconds, :mod:`handeye.core.smoke`), and says so above its outputs; the run times and rates a command prints
change per run and are printed as ``…`` (``TIME``, and a table's column headed ``s``). A page whose steps train
networks (``TRAINS``: the learned guide's) runs them on one torch thread: the figures a training prints move
with the thread count and the CPU's kernels (in their third significant digit), so the tests compare them
within a relative bound (``tests/tolerances.py``'s ``SMOKE_TRAINED_RTOL``) instead of the last digit.

A page whose steps read what others made (``INPUTS``: the markerless guide's recording, a simulated D435 cell
written as ROS 2 bags, :func:`render_cell`; the learned guide's ``data/paper-sim``, the simulate-and-label
guide's steps run, :func:`rendered_and_labelled`) has it built first; the markerless guide's steps run with
``HOME`` in their folder (``~/ws/src``).
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
from unittest import mock

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
        "docs/guides/learned.md",
        "docs/guides/markerless.md",
    )
)
SIMULATE_LABEL, LEARNED = ROOT / "docs/guides/simulate-label.md", ROOT / "docs/guides/learned.md"
#: The pages whose steps render or train: run in a smoke run, their outputs a smoke run's.
SMOKE = (SIMULATE_LABEL, LEARNED)
#: The pages whose steps train networks: run on one torch thread (:func:`torch_threads`).
TRAINS = (LEARNED,)
#: An output of more than ``LONG`` lines is shown as its first ``HEAD`` and last ``TAIL`` lines (:func:`trim`).
LONG, HEAD, TAIL = 30, 10, 1
#: A run time or rate (``38.6 s``, ``7.5 frames/s``), which changes per run: printed as ``… s``.
TIME = re.compile(r"\b\d+(?:\.\d+)?(?= (?:s|min|frames/s|camera/s)\b)")
#: A bash block with a ``handeye`` command (continued over lines ending in ``\\``), then a plain block: the
#: command's output.
EXAMPLE = re.compile(
    r"(^```bash\n(?P<command>handeye (?:[^\n]*\\\n)*[^\n]+)\n```\n\n(?:[^\n`][^\n]*\n)*?\n?```\n)"
    r"(?P<output>.*?)(^```)",
    re.S | re.M,
)


#: A bash block of one ``python -c "..."`` (its code on one line or several): a step that writes a page's inputs
#: (a synthetic recording).
SETUP = re.compile(r'^```bash\n(?P<setup>python -c "[^"]*")\n```\n', re.M)


def mask_times(text: str) -> str:
    """``text`` with its run times and rates (``TIME``) and the cells of a table's column headed ``s`` as ``…``."""
    lines, timed = TIME.sub("…", text).splitlines(keepends=True), set()
    for k, line in enumerate(lines):
        if not line.startswith("|"):
            timed = set()
            continue
        cells = line.rstrip("\n").split("|")
        if k == 0 or not lines[k - 1].startswith("|"):  # a table's header
            timed = {i for i, c in enumerate(cells) if c.strip() == "s"}
        elif not set(line) <= set("|-: \n"):
            lines[k] = "|".join(" … " if i in timed else c for i, c in enumerate(cells)) + "\n"
    return "".join(lines)


def trim(text: str) -> str:
    """``text``, or where it has more than ``LONG`` lines its first ``HEAD`` and last ``TAIL`` lines around one
    line that counts the others (``… 152 more lines …``)."""
    lines = text.splitlines(keepends=True)
    if len(lines) <= LONG:
        return text
    return "".join([*lines[:HEAD], f"… {len(lines) - HEAD - TAIL} more lines …\n", *lines[-TAIL:]])


def run(command: str, folder: Path) -> str:
    """What ``command`` (a ``handeye`` command line, continued over lines ending in ``\\``) prints, run
    in-process in ``folder``, its times masked and a long output trimmed; ``~`` is the ``HOME`` of the moment, as
    a shell expands it."""
    from handeye.cli import main

    words = [os.path.expanduser(w) for w in shlex.split(re.sub(r"\\\n\s*", " ", command))]
    out = io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.chdir(folder):
        status = main(words[1:])
    if status != 0:
        raise SystemExit(f"{command!r} exited {status}")
    return trim(mask_times(out.getvalue()))


def render_cell(root: Path) -> list[dict]:
    """The markerless guide's recording, built into the empty folder ``root``: two placements of a UR5 cell as
    a D435 reports depth (8 data frames each at 480x480, 8 board views at 480x480, seed 5; ``sim/``), written
    as ROS 2 bags as a cell records them (``bags/``, :func:`sim.bag_export.write_placement_bags`), and the
    board file (``board.json``). About 35 s on the loaded 2-core Xeon.

    Returns
    -------
    list of dict
        Per placement, its bags: ``{"data": Path, "calibration": Path}``.
    """
    from classic.vision.board import BoardSpec
    from handeye.core.dataset import Dataset
    from handeye.core.engine_protocol import EngineOptions
    from sim.bag_export import write_placement_bags
    from sim.cameras import CameraPreset
    from sim.generate import NoiseModel, Recipe, generate

    preset = CameraPreset(
        "cell", "ur5", ((0.0, 60.0),), (1,), (1,), 8, calibration_views=8, image_size=(480, 480),
        calibration_image_size=(480, 480),
    )  # fmt: skip
    recipe = Recipe(preset, seed=5, noise=NoiseModel(pixel_sigma=2.0, joint_sigma_deg=0.01), sensor="d435")
    generate(root / "sim", recipe, options=EngineOptions(workers=2, progress=False))
    ds = Dataset.open(root / "sim")
    BoardSpec(**ds.meta["board"]).save(root / "board.json")
    return [write_placement_bags(ds, c, root / "bags") for c in range(2)]


def cell_inputs(built: Path, folder: Path) -> None:
    """The markerless guide's inputs in its steps' ``folder``, from a :func:`render_cell` build: the bags
    ``data_0/ cal_0/ data_1/ cal_1/``, ``board.json``, ``guess.json`` (the first placement's truth 2 cm and
    2 degrees off), ``my_arm.urdf`` (the UR5's) with its meshes under ``home/ws/src`` (``~/ws/src``)."""
    import json
    import shutil

    import example_robot_data as erd
    import numpy as np

    from handeye.core.dataset import Dataset
    from handeye.core.se3 import make_transform, so3_exp

    for c in range(2):
        shutil.copytree(built / "bags" / f"cam_{c:04d}_data", folder / f"data_{c}")
        shutil.copytree(built / "bags" / f"cam_{c:04d}_calibration", folder / f"cal_{c}")
    shutil.copy(built / "board.json", folder / "board.json")
    T_base_cam_true = Dataset.open(built / "sim").truth()[0]
    T_base_cam_guess = make_transform(so3_exp(np.radians([2.0, 0.0, 0.0])), [0.02, 0.0, 0.0]) @ T_base_cam_true
    (folder / "guess.json").write_text(json.dumps({"T_base_cam": T_base_cam_guess.tolist()}))
    loader = erd.robots_loader.UR5Loader()
    shutil.copy(loader.df_path, folder / "my_arm.urdf")
    share = Path(loader.model_path).resolve().parents[1]  # holds example-robot-data/, the package
    (folder / "home" / "ws" / "src").mkdir(parents=True)
    (folder / "home" / "ws" / "src" / "example-robot-data").symlink_to(share / "example-robot-data")


def rendered_and_labelled(root: Path) -> list[str]:
    """The simulate-and-label guide's steps run in the empty folder ``root`` (a smoke run: ``data/paper-sim``, 18
    placements rendered and labelled, and ``cam14.png``), the learned guide's inputs. About 80 s on the loaded
    2-core EPYC.

    Returns
    -------
    list of str
        What each of the guide's examples prints, in order.
    """
    return [output for _, output in outputs(SIMULATE_LABEL, root)]


def paper_sim_inputs(built: Path, folder: Path) -> None:
    """The learned guide's input in its steps' ``folder``: ``data/paper-sim`` of a :func:`rendered_and_labelled`
    build, copied (its steps write beside it, and the build stays as it was)."""
    import shutil

    shutil.copytree(built / "data" / "paper-sim", folder / "data" / "paper-sim")


#: The pages whose steps read what others made: the builder that makes it once, and what lays it out in the folder.
INPUTS = {
    ROOT / "docs/guides/markerless.md": (render_cell, cell_inputs),
    LEARNED: (rendered_and_labelled, paper_sim_inputs),
}


def smoke_run(on: bool):
    """``HANDEYE_SMOKE_TEST`` set to 1 within the block where ``on`` (for this process and the steps it
    starts), the environment as it was after it."""
    from handeye.core.smoke import ENV

    return mock.patch.dict(os.environ, {ENV: "1"} if on else {})


@contextlib.contextmanager
def torch_threads(one: bool):
    """torch's CPU threads set to one within the block where ``one``, as they were after it."""
    if not one:
        yield
        return
    import torch

    before = torch.get_num_threads()
    torch.set_num_threads(1)
    try:
        yield
    finally:
        torch.set_num_threads(before)


def outputs(path: Path, folder: Path | None = None, built: Path | None = None) -> list[tuple[re.Match, str]]:
    """Each example of the file with what its command prints today: the file's steps (its ``python -c``
    blocks and its examples) run in their order in one fresh folder holding the repository's ``handeye/``
    (the shipped example files at the paths the documentation prints); what a step writes is there for the
    next, and goes with the folder (a temporary one, or the empty ``folder`` given, where it stays). A page of
    ``INPUTS`` has its inputs laid out there first, from ``built`` (its builder's folder) or built anew, and
    its steps run with ``HOME`` the folder's ``home/`` where the lay-out made one; a page of ``TRAINS`` on one
    torch thread."""
    text = path.read_text()
    steps = sorted([*SETUP.finditer(text), *EXAMPLE.finditer(text)], key=lambda m: m.start())
    printed = []
    with contextlib.ExitStack() as stack, smoke_run(path.resolve() in SMOKE), torch_threads(path.resolve() in TRAINS):
        folder = folder if folder is not None else stack.enter_context(tempfile.TemporaryDirectory())
        (Path(folder) / "handeye").symlink_to(ROOT / "handeye")
        if path.resolve() in INPUTS:
            build, lay_out = INPUTS[path.resolve()]
            if built is None:
                built = Path(stack.enter_context(tempfile.TemporaryDirectory()))
                build(built)
            lay_out(built, Path(folder))
            if (Path(folder) / "home").is_dir():
                stack.enter_context(mock.patch.dict(os.environ, {"HOME": str(Path(folder) / "home")}))
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
