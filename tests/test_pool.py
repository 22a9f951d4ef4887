"""PoolEngine: results on one and on two processes, a worker's failure raised with its task named."""

from __future__ import annotations

import os

import pytest

from handeye.core.engine_protocol import EngineOptions
from handeye.core.errors import HandEyeInputError
from handeye.core.pool import PoolEngine


def _square(x):
    return x * x


def _pid(_):
    return os.getpid()


def _fail_on_three(x):
    if x == 3:
        raise ValueError("three is not allowed")
    return x


def _describe(x):
    return f"number {x}"


_INITIALISED = []


def _init(tag):
    _INITIALISED.append(tag)


def run_pool(fn, tasks, workers, **options):
    return PoolEngine().run(fn, tasks, EngineOptions(workers=workers, **options))


@pytest.mark.parametrize("workers", [1, 2])
def test_results_in_order_and_as_completed(workers):
    tasks = list(range(7))
    assert list(run_pool(_square, tasks, workers, progress=False, ordered=True)) == [x * x for x in tasks]
    assert sorted(run_pool(_square, tasks, workers, progress=True, desc="squares")) == [x * x for x in tasks]
    assert list(run_pool(_square, [], workers, progress=False)) == []


def test_one_worker_runs_here_unless_isolated():
    assert set(run_pool(_pid, range(3), 1, progress=False)) == {os.getpid()}
    assert os.getpid() not in set(run_pool(_pid, range(3), 1, progress=False, isolate=True))
    _INITIALISED.clear()
    list(run_pool(_square, [1], 1, progress=False, initializer=_init, initargs=("here",)))
    assert _INITIALISED == ["here"]


@pytest.mark.parametrize("workers", [1, 2])
def test_a_failure_is_raised_with_its_task_named(workers):
    with pytest.raises(ValueError, match="three is not allowed") as info:
        list(run_pool(_fail_on_three, range(6), workers, progress=False, describe=_describe))
    assert "while running task number 3" in info.value.__notes__
    with pytest.raises(ValueError) as info:
        list(run_pool(_fail_on_three, [3], workers, progress=False))
    assert "while running task 3" in info.value.__notes__


def test_workers_must_be_positive():
    with pytest.raises(HandEyeInputError, match="workers must be >= 1"):
        EngineOptions(workers=0)


def _warn(x):
    import warnings

    from handeye.core.errors import SuspectPosesWarning

    warnings.warn(f"pose {x} lies beyond the outlier bound", SuspectPosesWarning, stacklevel=1)
    warnings.warn("a library's overflow", RuntimeWarning, stacklevel=1)
    return x


def test_a_workers_own_warnings_are_one_line_and_a_librarys_none(capfd):
    assert sorted(run_pool(_warn, [1, 2], 2, progress=False)) == [1, 2]
    lines = [line for line in capfd.readouterr().err.splitlines() if line]
    assert lines and all(line.startswith("handeye: warning: pose ") for line in lines), lines
