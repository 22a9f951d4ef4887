"""The README and the documentation: short, linked, and their examples run and print what they show."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

from tests.tolerances import SMOKE_TRAINED_RTOL

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
DOCS = ROOT / "docs"
#: The README is a newcomer's page; guides, figures and history live in docs/ and CHANGELOG.md.
README_MAX_LINES = 150
NUMBER = re.compile(r"[-+]?\d+\.\d+|[-+]?\d+")
#: Options whose value a command writes (a file or a folder).
OUTPUT_OPTIONS = ("-o", "--out", "--report", "--board-out", "--export-easy-handeye", "--export-launch", "--export-urdf")


def markdown_files() -> list[Path]:
    return [README, ROOT / "CHANGELOG.md", *sorted(DOCS.rglob("*.md"))]


def code_blocks(path: Path, language: str) -> list[str]:
    """The fenced blocks of one language in a markdown file, in order."""
    return re.findall(rf"^```{language}\n(.*?)^```", path.read_text(), flags=re.S | re.M)


def command_lines(text: str) -> list[str]:
    """A bash block's command lines: continuations joined, comments and blank lines dropped."""
    joined = re.sub(r"\\\n\s*", " ", text)
    return [ln.split(" #")[0].strip() for ln in joined.splitlines() if ln.strip() and not ln.lstrip().startswith("#")]


def written_paths(text: str) -> list[str]:
    """What a bash block's commands write: the value after each of :data:`OUTPUT_OPTIONS` (a ``python -c
    "..."`` step's code, on one line or several, is not read as commands)."""
    import shlex

    text = re.sub(r'python -c "[^"]*"', "python -c", text)
    out = []
    for command in command_lines(text):
        words = shlex.split(command)
        out += [words[k + 1] for k, w in enumerate(words[:-1]) if w in OUTPUT_OPTIONS]
    return out


def test_readme_is_short():
    n = len(README.read_text().splitlines())
    assert n <= README_MAX_LINES, f"README.md has {n} lines; move the rest into docs/"


def test_benchmark_pages_name_no_issue():
    """A benchmark page says what a figure is measured against, not which ticket asked for it: an issue number
    means nothing to a reader of the documentation (the CHANGELOG and the commits keep that history)."""
    named = {
        p.name: re.findall(r".{0,30}\bissues? #?\d+.{0,30}", p.read_text(encoding="utf-8"), flags=re.IGNORECASE)
        for p in (ROOT / "docs" / "benchmarks").glob("*.md")
    }
    assert not {name: hits for name, hits in named.items() if hits}


@pytest.mark.parametrize("path", [README, ROOT / "CHANGELOG.md"], ids=lambda p: p.name)
def test_relative_links_resolve(path):
    """mkdocs checks the site's links (``mkdocs build --strict`` in the test command); this checks the README's."""
    for target in re.findall(r"\]\(([^)#\s]+)(?:#[^)]*)?\)", path.read_text()):
        if "://" in target:
            continue
        assert (path.parent / target).exists(), f"{path.name} links to {target}, which does not exist"


def _same_within_last_digit(printed: str, shown: str, rtol: float = 0.0) -> None:
    """Equal text, and every number within two units of its last printed digit (BLAS may differ there), or
    within ``rtol`` of it where that is wider."""
    got, want = printed.strip().splitlines(), shown.strip().splitlines()
    assert len(got) == len(want), f"{len(got)} lines printed, {len(want)} shown"
    for g, w in zip(got, want):
        assert NUMBER.sub("#", g) == NUMBER.sub("#", w), f"printed {g!r}, shown {w!r}"
        for a, b in zip(NUMBER.findall(g), NUMBER.findall(w)):
            decimals = len(b.split(".")[1]) if "." in b else 0
            bound = max(2 * 10.0**-decimals, rtol * abs(float(b)))
            assert abs(float(a) - float(b)) <= bound, f"printed {g!r}, shown {w!r}"


def _make_examples():
    """``docs/make_examples.py``, the script that regenerates the printed outputs, as a module."""
    import importlib.util

    spec = importlib.util.spec_from_file_location("make_examples", DOCS / "make_examples.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


@pytest.mark.parametrize(
    "path",
    # a page that renders or trains (a smoke run: about a minute, two on the loaded 2-core Xeon) is the slow
    # tier's, and so is the markerless guide's (a D435 cell registered: 60 s of steps, loaded) and the real-cell
    # guide's (bags written and imported, a ROS workspace: 16 s)
    [
        pytest.param(
            p,
            marks=[pytest.mark.slow]
            if p in (*_make_examples().SMOKE, *_make_examples().INPUTS, DOCS / "guides" / "real-cell.md")
            else [],
        )
        for p in _make_examples().FILES
    ],
    ids=lambda p: p.name,
)
def test_printed_examples_print_what_is_shown(path, tmp_path, tmp_path_factory):
    """Each printed example of the page (a ``handeye`` command, then its output) prints what is shown, run as
    ``make_examples`` runs it: the page's steps in order in a fresh folder holding the repository's
    ``handeye/``; every file or folder a command names as its output (:data:`OUTPUT_OPTIONS`) is there after.
    These steps are the bash blocks of kind p of ``tests/test_docs_shell.py``, not run again there. A page that
    reads what others made (``INPUTS``) reads the one build the run shares: the markerless guide's D435 cell with
    ``test_docs_shell``'s blocks (:func:`d435_cell_build`), the learned guide's ``data/paper-sim`` with the
    simulate-and-label guide's own test (its steps run once, :func:`_simulate_label_run`). A page that trains
    (``TRAINS``) has its figures compared within ``SMOKE_TRAINED_RTOL``."""
    from tests.shared_renders import shared_build

    mod = _make_examples()
    folder, built = tmp_path, None
    if path in mod.INPUTS:
        key, build, modules = _shared_inputs(mod)[path]
        for module in modules:
            pytest.importorskip(module)
        built, _ = shared_build(tmp_path_factory, key, build)
    if path == mod.SIMULATE_LABEL:
        folder, shown = _simulate_label_run(tmp_path_factory, mod)
        examples = list(mod.EXAMPLE.finditer(path.read_text()))
        assert len(shown) == len(examples), f"{path.name}: {len(shown)} outputs for {len(examples)} examples"
        printed = list(zip(examples, shown))
    else:
        printed = mod.outputs(path, tmp_path, built)
    assert printed, f"{path.name}: no printed example"
    rtol = SMOKE_TRAINED_RTOL if path in mod.TRAINS else 0.0
    for m, output in printed:
        _same_within_last_digit(output, m["output"], rtol)
        for out in written_paths(m["command"]):
            assert (folder / out).exists(), f"{path.name}: {m['command']!r} did not write {out}"


def _simulate_label_run(tmp_path_factory, mod) -> tuple[Path, list[str]]:
    """The simulate-and-label guide's steps run once a test run (a smoke run's render and labels, 80 s on the
    loaded 2-core EPYC), shared by its test and the learned guide's (``make_examples.rendered_and_labelled``):
    the folder they ran in and what each example printed."""
    from tests.shared_renders import shared_build

    return shared_build(tmp_path_factory, "simulate-label-steps", mod.rendered_and_labelled)


def _shared_inputs(mod) -> dict:
    """Per page of ``make_examples.INPUTS``: the key of the build the run shares, its builder and the modules it
    needs."""
    return {
        mod.ROOT / "docs/guides/markerless.md": (
            "d435-cell",
            d435_cell_build,
            ("pyrender", "pinocchio", "rosbags", "example_robot_data"),
        ),
        mod.LEARNED: ("simulate-label-steps", mod.rendered_and_labelled, ("pyrender", "pinocchio", "torch")),
    }


def d435_cell_build(root: Path) -> list[dict]:
    """The markerless guide's cell (``docs/make_examples.py``'s ``render_cell``: ``sim/``, ``bags/``,
    ``board.json``) and its bags imported as ``my-cell/`` (for ``test_docs_shell``'s blocks); its bags per
    placement. Built once a run (``tests.shared_renders.shared_build``, key ``d435-cell``)."""
    from handeye.cli import main

    bags = _make_examples().render_cell(root)
    argv = ["import", "bag", *(str(b["data"]) for b in bags), "--calibration", *(str(b["calibration"]) for b in bags)]
    assert main([*argv, "--robot", "ur5", "--board", str(root / "board.json"), "--out", str(root / "my-cell")]) == 0
    return bags


def printed_steps() -> set[tuple[str, int]]:
    """The bash blocks ``docs/make_examples.py`` runs (its ``SETUP`` steps and ``EXAMPLE`` commands on the pages
    of its ``FILES``), by (file, index among the file's bash blocks), as :func:`code_blocks` numbers them."""
    mod = _make_examples()
    out = set()
    for path in mod.FILES:
        text = path.read_text()
        starts = [m.start() for m in re.finditer(r"^```bash\n", text, flags=re.M)]
        steps = {m.start() for m in (*mod.EXAMPLE.finditer(text), *mod.SETUP.finditer(text))}
        out |= {(path.relative_to(ROOT).as_posix(), i) for i, start in enumerate(starts) if start in steps}
    return out


#: A Python block that renders a preset (``generate(...)``: simulate-label's, the ``small`` preset rendered on 2
#: processes and labelled, 75 s of the default run on the loaded 2-core Xeon) is the slow tier's; the default
#: run renders and labels the same preset through the same calls, without the noise (``small_dataset``,
#: ``tests/conftest.py``).
RENDERS = re.compile(r"\bgenerate\(")


def _python_blocks() -> list:
    return [
        pytest.param(p.relative_to(ROOT).as_posix(), i, b, marks=[pytest.mark.slow] if RENDERS.search(b) else [])
        for p in markdown_files()
        for i, b in enumerate(code_blocks(p, "python"))
    ]


@pytest.mark.parametrize(
    "where,index,block", _python_blocks(), ids=lambda v: str(v) if not isinstance(v, str) or "\n" not in v else ""
)
def test_python_blocks_run(where, index, block, tmp_path):
    """Every Python block of the README and the documentation runs as written, in a fresh interpreter."""
    env = dict(os.environ, PYOPENGL_PLATFORM="egl", PYTHONPATH=str(ROOT))
    run = subprocess.run(
        [sys.executable, "-c", block], cwd=tmp_path, env=env, capture_output=True, text=True, timeout=600
    )
    assert run.returncode == 0, f"{where} block {index} failed:\n{run.stderr[-3000:]}"


def _example_shell_blocks() -> list[tuple[int, str]]:
    """The README's bash blocks after the install: the examples a newcomer copies."""
    return [(i, b) for i, b in enumerate(code_blocks(README, "bash")) if "pip install" not in b]


@pytest.mark.parametrize("index,block", _example_shell_blocks(), ids=lambda v: str(v) if isinstance(v, int) else "")
def test_readme_shell_examples_run(index, block, tmp_path):
    """Each of the README's example commands runs from a fresh folder and exits 0."""
    for name in ("handeye",):
        (tmp_path / name).symlink_to(ROOT / name)  # the shipped example files, as from the repository root
    # the console script beside this interpreter, as in the activated environment the README installs into
    path = os.pathsep.join([str(Path(sys.executable).parent), os.environ.get("PATH", "")])
    env = dict(os.environ, PYOPENGL_PLATFORM="egl", PYTHONPATH=str(ROOT), PATH=path)
    run = subprocess.run(
        ["bash", "-euo", "pipefail", "-c", block], cwd=tmp_path, env=env, capture_output=True, text=True, timeout=600
    )
    assert run.returncode == 0, f"README bash block {index} failed:\n{run.stderr[-3000:]}"


def _browser() -> str | None:
    import shutil

    names = ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable", "chromium-headless-shell")
    return os.environ.get("HANDEYE_TEST_BROWSER") or next(filter(None, map(shutil.which, names)), None)


def _command_parts(path: Path, inline: str | None = None):
    """Each command of the file's bash blocks (and of its inline code spans that start with ``inline``):
    continuation lines joined, comments dropped, split at ``&&``, ``|`` and a ``;`` before the next ``python`` or
    ``handeye`` command (an inline span may hold two commands)."""
    pieces = [re.sub(r"\\\n\s*", " ", block) for block in code_blocks(path, "bash")]
    if inline:
        pieces += [re.sub(r"\s+", " ", span) for span in re.findall(rf"`({re.escape(inline)}[^`]+)`", path.read_text())]
    for piece in pieces:
        for line in piece.splitlines():
            for part in re.split(r"&&|\||;\s+(?=python |handeye )", line.split(" #")[0]):
                yield part.strip()


def _documented_commands() -> list[tuple[str, str]]:
    """Every ``handeye ...`` command line in the bash blocks of the README and the documentation, with its
    file (``torchrun ... -m handeye ...``: the ``handeye`` part)."""
    out = []
    for path in markdown_files():
        for part in _command_parts(path):
            launched = re.search(r"-m (handeye .*)", part)
            if part.startswith("handeye ") or launched:
                out.append((path.relative_to(ROOT).as_posix(), part if not launched else launched[1]))
    return out


@pytest.mark.parametrize("where,command", _documented_commands(), ids=lambda v: v if "/" not in v else "")
def test_documented_commands_parse(where, command):
    """Every command the documentation prints parses with today's options (it may take hours to run, so it
    is parsed, not run): a renamed or removed option fails here instead of in a reader's terminal."""
    import shlex

    from handeye.cli import build_parser

    argv = shlex.split(command)[1:]
    try:
        build_parser().parse_args(argv)
    except SystemExit as exc:
        pytest.fail(f"{where}: {command!r} does not parse (exit {exc.code})")


def _benchmark_commands() -> list[tuple[str, str]]:
    """Every ``python benchmarks/NAME.py ...`` command the README and the documentation print, in bash blocks
    or in inline code, with its file."""
    prefix = "python benchmarks/"
    return sorted(
        {
            (path.relative_to(ROOT).as_posix(), part)
            for path in markdown_files()
            for part in _command_parts(path, inline=prefix)
            if part.startswith(prefix)
        }
    )


class _Parsed(Exception):
    """Raised once a benchmark's arguments parsed: nothing after the parse runs."""


@pytest.mark.parametrize("where,command", _benchmark_commands(), ids=lambda v: v if "/" not in v else "")
def test_documented_benchmark_commands_parse(where, command, monkeypatch):
    """Every benchmark command the documentation prints parses with the script's own arguments (they run for
    minutes to hours, so they are parsed, not run): a renamed or removed option fails here."""
    import argparse
    import runpy
    import shlex

    argv = shlex.split(command)[1:]
    script = ROOT / argv[0]
    assert script.is_file(), f"{where}: {argv[0]} does not exist"
    original = argparse.ArgumentParser.parse_args

    def parse_then_stop(self, args=None, namespace=None):
        original(self, args, namespace)
        raise _Parsed

    monkeypatch.setattr(argparse.ArgumentParser, "parse_args", parse_then_stop)
    monkeypatch.setattr(sys, "argv", argv)
    monkeypatch.chdir(ROOT)
    try:
        runpy.run_path(str(script), run_name="__main__")
    except _Parsed:
        return
    except SystemExit as exc:
        pytest.fail(f"{where}: {command!r} does not parse (exit {exc.code})")
    pytest.fail(f"{where}: {script.name} ran to the end without parsing its arguments")


def test_one_script_regenerates_every_printed_output(tmp_path, monkeypatch):
    """``docs/make_examples.py`` finds the printed outputs (the README's and the getting-started page's) and
    rewrites one that went stale; ``test_printed_examples_print_what_is_shown`` keeps them current."""
    mod = _make_examples()
    assert [len(mod.EXAMPLE.findall(p.read_text())) for p in mod.FILES] == [1, 2, 5, 4, 4, 6, 3, 3, 4]
    stale = tmp_path / "README.md"
    stale.write_text(README.read_text().replace("15 poses, method auto", "14 poses, method auto", 1))
    text, changed = mod.regenerate(stale)
    assert len(changed) == 1 and changed[0].startswith("handeye calibrate")
    assert "15 poses, method auto" in text and "14 poses" not in text  # rewritten from a fresh run
    monkeypatch.setattr(mod, "FILES", (stale,))
    assert mod.main(["--check"]) == 1 and "14 poses" in stale.read_text()  # --check changes nothing
    assert mod.main([]) == 0 and "15 poses, method auto" in stale.read_text()


def test_run_times_are_masked_and_nothing_else():
    """A run time or rate changes per run and is printed as ``…``; the figures the test compares stay."""
    mod = _make_examples()
    line = "rendered 18 camera poses (288 frames, 38.6 s, 7.5 frames/s); label vs truth 0.0029 deg / 0.049 mm (2 s)"
    want = "rendered 18 camera poses (288 frames, … s, … frames/s); label vs truth 0.0029 deg / 0.049 mm (… s)"
    assert mod.TIME.sub("…", line) == want
    table = "| camera | sigma | s |\n|---|---|---|\n| 0 | 6.141 | 13.2 |\nin 34 s\n| s |\n|---|\n| 2 |\n"
    assert mod.mask_times(table) == (
        "| camera | sigma | s |\n|---|---|---|\n| 0 | 6.141 | … |\nin … s\n| s |\n|---|\n| … |\n"
    )


def test_a_long_output_is_shown_by_its_head_and_tail():
    """An output of more than ``LONG`` lines (the learned report's tables) is shown as its first ``HEAD`` and last
    ``TAIL`` lines around a line that counts the rest; a shorter one whole."""
    mod = _make_examples()
    lines = [f"line {k}" for k in range(mod.LONG + 5)]
    hidden = len(lines) - mod.HEAD - mod.TAIL
    want = [*lines[: mod.HEAD], f"… {hidden} more lines …", *lines[-mod.TAIL :]]
    assert mod.trim("\n".join(lines) + "\n").splitlines() == want
    short = "\n".join(lines[: mod.LONG]) + "\n"
    assert mod.trim(short) == short


def test_a_page_that_trains_runs_on_one_torch_thread():
    """The learned guide's steps run on one torch thread (its figures move with the thread count), and the
    threads are as they were after them."""
    torch = pytest.importorskip("torch")
    mod = _make_examples()
    before = torch.get_num_threads()
    torch.set_num_threads(3)
    try:
        with mod.torch_threads(True):
            assert torch.get_num_threads() == 1
        assert torch.get_num_threads() == 3
    finally:
        torch.set_num_threads(before)
    assert mod.LEARNED in mod.TRAINS


def test_documented_installs_name_extras_the_project_has():
    """Every ``pip install -e ".[...]"`` the documentation prints names optional dependencies pyproject.toml
    defines (a renamed extra fails here, not in a reader's terminal)."""
    import tomllib

    extras = set(tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["optional-dependencies"])
    named = {
        (path.name, extra.strip())
        for path in markdown_files()
        for group in re.findall(r'pip install[^\n]*?-e "\.\[([^\]]+)\]"', path.read_text())
        for extra in group.split(",")
    }
    assert named, "no install commands found"
    unknown = sorted((f, e) for f, e in named if e not in extras)
    assert not unknown, f"extras not in pyproject.toml: {unknown}"
