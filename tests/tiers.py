"""The suite's two tiers and its parallel run: hooks that ``tests/conftest.py`` takes in.

``python -m pytest`` is the developer's run between edits: it leaves out the tests marked ``slow`` (the
documentation's long blocks in smoke runs, whole pipelines rendered and trained) and says at the end how many
it left out (a test named on the command line, ``FILE::TEST``, runs all the same). ``python -m pytest --full``
is CI's run (``.ci/run``): every test. Nothing is skipped silently:
a slow test runs in CI, and the default run counts what it left out (pytest's ``deselected``, and a line of
its own that also holds on pytest-xdist's workers, which do not report deselections).

Under pytest-xdist (``-n auto --dist loadscope --no-loadscope-reorder``, in ``pyproject.toml``'s
``addopts``) the work units are this module's scopes (:func:`pytest_xdist_make_scheduler`): a test file is one
unit on one worker, so that its module fixtures are built once; the files that read every package file
(:data:`SOURCE_TREE_FILES`), one of which writes probe modules into the tree, are one unit, so that a probe is
never half seen by the other's walk; the files that start a Ray cluster (:data:`RAY_FILES`) are one unit, and every Ray
user holds :func:`hold_ray_lock`, since a second cluster on the machine would be joined (``ray.init()`` finds a
running one) instead of started; each test of the documentation's shell blocks (:data:`PER_TEST_FILES`,
minutes each in the slow tier) is a unit of its own, and the slow tests come first, as the workers take the
units in order. (pytest-xdist's own ``loadgroup`` names its units by rewriting node ids, which pytest 9 no
longer honours: every test became a unit of its own.)
"""

from __future__ import annotations

import fcntl
import os
import tempfile
from pathlib import Path

import pytest

#: Files that read every package file, test_layers writing probe modules into the tree: on two workers its
#: probe, listed by the other's walk and removed before it was read, failed the other's test. One unit.
SOURCE_TREE_FILES = ("tests/test_layers.py", "tests/test_private_imports.py")
#: Files that start a local Ray cluster: one unit.
RAY_FILES = ("tests/test_ray_engine.py", "tests/test_processes.py")
#: Files whose every test is a unit of its own (the documentation's blocks: minutes each, independent).
PER_TEST_FILES = ("tests/test_docs_shell.py",)
#: The lock every Ray user holds (:func:`hold_ray_lock`), in the machine's temporary folder.
RAY_LOCK = Path(tempfile.gettempdir()) / "handeye-tests-ray.lock"
_LEFT_OUT = "slow_tests_left_out"
_LEFT_OUT_KEY = pytest.StashKey[int]()


#: One thread per worker for OpenMP and BLAS (torch, numpy): two workers of two threads each on two cores
#: made torch's tests 100 times slower (test_ablation 2 s alone, 227 s beside another worker under load).
ONE_THREAD = ("OMP_NUM_THREADS", "MKL_NUM_THREADS", "OPENBLAS_NUM_THREADS")
#: OpenMP threads that wait by sleeping, not spinning, where a test asks for more (``threads=2``).
PASSIVE_WAIT = ("OMP_WAIT_POLICY", "PASSIVE")


def pytest_configure(config: pytest.Config) -> None:
    """On pytest-xdist's controller, before its workers start (they inherit the environment, and so do the
    processes the tests start): :data:`ONE_THREAD`, unless set already."""
    if getattr(config.option, "numprocesses", None) and not hasattr(config, "workerinput"):
        for name in ONE_THREAD:
            os.environ.setdefault(name, "1")
        os.environ.setdefault(*PASSIVE_WAIT)


def pytest_addoption(parser: pytest.Parser) -> None:
    parser.addoption(
        "--full",
        action="store_true",
        help="run every test, the ones marked slow too (CI's run, .ci/run); without it they are left out and counted",
    )


@pytest.hookimpl(tryfirst=True)
def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    """Leave out the slow tier unless ``--full``; the slow tests first (the longest units started first
    finish first)."""
    if not config.getoption("--full"):
        named = _named(config)
        slow = [item for item in items if item.get_closest_marker("slow") and not item.nodeid.startswith(named)]
        if slow:
            left_out = set(map(id, slow))
            items[:] = [item for item in items if id(item) not in left_out]
            config.hook.pytest_deselected(items=slow)
        _record_left_out(config, len(slow))
    items.sort(key=lambda item: item.get_closest_marker("slow") is None)  # stable: the file order kept


def work_unit(nodeid: str) -> str:
    """The unit of work a test belongs to under pytest-xdist (see the module's docstring)."""
    path = nodeid.split("::", 1)[0]
    if path in SOURCE_TREE_FILES:
        return "source-tree"
    if path in RAY_FILES:
        return "ray"
    return nodeid if path in PER_TEST_FILES else path


#: Workers per core beyond one: the tests wait on processes they start (renders on two workers, a Ray cluster's
#: start and stop, a killed worker's timeout), and a third worker on two cores fills those waits.
EXTRA_WORKERS = 1


def pytest_xdist_auto_num_workers(config: pytest.Config) -> int:
    """``-n auto``: one worker per core and :data:`EXTRA_WORKERS` more (``--maxprocesses`` caps it)."""
    return (os.cpu_count() or 1) + EXTRA_WORKERS


def pytest_xdist_make_scheduler(config: pytest.Config, log):
    """pytest-xdist's scope scheduler with :func:`work_unit` as the scope (``--dist loadscope``)."""
    if config.getvalue("dist") != "loadscope":
        return None
    from xdist.scheduler import LoadScopeScheduling

    class _Units(LoadScopeScheduling):
        def _split_scope(self, nodeid: str) -> str:
            return work_unit(nodeid)

    return _Units(config, log)


def hold_ray_lock(request: pytest.FixtureRequest) -> None:
    """Wait for, then hold until ``request``'s end, the machine-wide lock of the tests that run a Ray cluster."""
    handle = open(RAY_LOCK, "a")  # noqa: SIM115 (closed by the finalizer)
    fcntl.flock(handle, fcntl.LOCK_EX)

    def release():
        fcntl.flock(handle, fcntl.LOCK_UN)
        handle.close()

    request.addfinalizer(release)


def _named(config: pytest.Config) -> tuple[str, ...]:
    """The tests named on the command line (``FILE::TEST``), as node ids: they run even when slow."""
    named = []
    for arg in config.args:
        if "::" in arg:
            path, rest = arg.split("::", 1)
            try:
                named.append(f"{Path(path).resolve().relative_to(config.rootpath).as_posix()}::{rest}")
            except ValueError:
                pass
    return tuple(named)


def _record_left_out(config: pytest.Config, count: int) -> None:
    """Keep the count for the summary: on the controller (or a run without workers) as an attribute, on an
    xdist worker also in what the worker sends back (``workeroutput``)."""
    config.stash[_LEFT_OUT_KEY] = count
    if hasattr(config, "workeroutput"):
        config.workeroutput[_LEFT_OUT] = count


@pytest.hookimpl(optionalhook=True)
def pytest_testnodedown(node, error) -> None:
    """An xdist worker finished: keep the count of slow tests it left out (every worker collects them all)."""
    count = getattr(node, "workeroutput", {}).get(_LEFT_OUT)
    if count is not None:
        node.config.stash[_LEFT_OUT_KEY] = max(count, node.config.stash.get(_LEFT_OUT_KEY, 0))


def pytest_terminal_summary(terminalreporter, exitstatus: int, config: pytest.Config) -> None:
    count = config.stash.get(_LEFT_OUT_KEY, None)
    if count:
        terminalreporter.write_line(
            f"{count} slow test{'s' if count != 1 else ''} left out (the default run); "
            "python -m pytest --full runs them too, as CI does"
        )
