"""The suite's tiers (:mod:`tests.tiers`): the default run leaves out the slow tests and says how many, ``--full``
(CI's run) runs them; the tests that start Ray hold one lock."""

from __future__ import annotations

import os
import re
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from tests.tiers import ONE_THREAD

ROOT = Path(__file__).resolve().parents[1]

CONFTEST = "from tests.tiers import pytest_addoption, pytest_collection_modifyitems, pytest_terminal_summary\n"
CONFTEST += "from tests.tiers import pytest_configure, pytest_testnodedown\n"
TESTS = """
import os

import pytest

def test_fast():
    if os.environ.get("PYTEST_XDIST_WORKER"):  # one OpenMP and BLAS thread per worker
        assert os.environ.get("OMP_NUM_THREADS") == os.environ.get("OPENBLAS_NUM_THREADS") == "1"

@pytest.mark.slow
def test_slow():
    pass

@pytest.mark.slow
@pytest.mark.parametrize("k", [1, 2])
def test_slow_too(k):
    pass
"""


def _pytest(folder: Path, *args: str) -> str:
    """pytest on a folder of its own (its own ini: the repository's addopts do not apply); its output."""
    # not the outer run's thread settings, nor its worker's identity (PYTEST_XDIST_WORKER ...): a run of its own
    env = {k: v for k, v in os.environ.items() if k not in ONE_THREAD and not k.startswith("PYTEST_")}
    env |= {"PYTHONPATH": str(ROOT)}
    run = subprocess.run(
        [sys.executable, "-m", "pytest", "-p", "no:cacheprovider", "-q", *args],
        cwd=folder,
        env=env,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert run.returncode == 0, run.stdout + run.stderr
    return run.stdout


@pytest.fixture
def suite(tmp_path):
    (tmp_path / "pytest.ini").write_text("[pytest]\nmarkers =\n    slow: the slow tier\n")
    (tmp_path / "conftest.py").write_text(CONFTEST)
    (tmp_path / "test_tiny.py").write_text(textwrap.dedent(TESTS))
    return tmp_path


@pytest.mark.parametrize("workers", ["0", "2"])
def test_the_default_run_leaves_out_the_slow_tests_and_counts_them(suite, workers):
    out = _pytest(suite, "-n", workers)
    assert re.search(r"\b1 passed\b", out), out
    assert "3 slow tests left out" in out, out  # also where xdist's workers report no deselection
    if workers == "0":
        assert "3 deselected" in out, out


def test_full_runs_every_test(suite):
    out = _pytest(suite, "-n", "2", "--full")
    assert re.search(r"\b4 passed\b", out) and "left out" not in out and "deselected" not in out, out


def test_ci_runs_the_full_suite():
    """``.ci/run``'s test command (the README's, a test of test_docs_shell checks) selects the slow tier too."""
    command = (ROOT / ".ci" / "run").read_text().strip().splitlines()[-1]
    pytest_call = command.split("&&")[-1].split()
    assert pytest_call[:3] == ["python", "-m", "pytest"] and "--full" in pytest_call, pytest_call


def test_slow_is_a_registered_marker(pytestconfig):
    assert any(line.startswith("slow:") for line in pytestconfig.getini("markers"))


def test_the_ray_tests_hold_the_ray_lock():
    """Every test file that starts or joins a Ray cluster calls :func:`~tests.tiers.hold_ray_lock` (a second
    cluster started beside a running one would join it, and ``ray stop --force`` stops every cluster on the
    machine). The lock is the guard, with :data:`~tests.tiers.RAY_FILES` one work unit."""
    starts_ray = re.compile(r'ray\.init\(|RayEngine\(|engine="ray"|"start", "--head"')
    unlocked = [
        p.relative_to(ROOT).as_posix()
        for p in sorted((ROOT / "tests").rglob("test_*.py"))
        if p.name != Path(__file__).name and starts_ray.search(p.read_text()) and "hold_ray_lock(" not in p.read_text()
    ]
    assert unlocked == [], "tests that start Ray without tests.tiers.hold_ray_lock"


def test_a_slow_test_named_on_the_command_line_runs(suite):
    out = _pytest(suite, "-n", "2", "test_tiny.py::test_slow", "test_tiny.py::test_fast")
    assert re.search(r"\b2 passed\b", out) and "left out" not in out, out


def test_the_work_units_keep_what_must_not_run_side_by_side():
    """The probe writers share a unit, the Ray files share one, a docs block is its own, any other file is one."""
    from tests.tiers import PER_TEST_FILES, RAY_FILES, SOURCE_TREE_FILES, work_unit

    assert {work_unit(f"{f}::test_x") for f in SOURCE_TREE_FILES} == {"source-tree"}
    assert {work_unit(f"{f}::test_x[1]") for f in RAY_FILES} == {"ray"}
    block = f"{PER_TEST_FILES[0]}::test_blocks[docs/guides/markerless.md-0]"
    assert work_unit(block) == block
    assert work_unit("tests/test_cli.py::test_a") == work_unit("tests/test_cli.py::test_b") == "tests/test_cli.py"
    for f in (*SOURCE_TREE_FILES, *RAY_FILES, *PER_TEST_FILES):
        assert (ROOT / f).is_file(), f  # a renamed file would silently leave its unit
