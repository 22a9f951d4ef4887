"""Choosing the engine: bad choices refused before any work, Ray missing named with its extra (no Ray needed)."""

from __future__ import annotations

import sys

import pytest

from handeye.core.engines import EngineOptions, check_engine, run_tasks
from handeye.core.errors import HandEyeInputError, MissingDependencyError


def _double(x):
    return 2 * x


@pytest.mark.parametrize(
    "engine, address, workers, message",
    [
        ("dask", None, None, "unknown engine 'dask'"),
        ("pool", "auto", None, "add --engine ray"),
        ("pool", None, 0, "workers must be >= 1"),
        ("ray", None, -2, "workers must be >= 1"),
    ],
)
def test_bad_choices_are_refused(engine, address, workers, message):
    with pytest.raises(HandEyeInputError, match=message):
        check_engine(engine, address, workers)
    with pytest.raises(HandEyeInputError, match=message):
        list(run_tasks(_double, [1, 2], EngineOptions(workers=workers, progress=False), engine, address))


def test_the_pool_is_the_default_and_keeps_task_order():
    assert list(run_tasks(_double, [3, 1, 2], EngineOptions(workers=1, progress=False, ordered=True))) == [6, 2, 4]


def test_ray_missing_names_the_cluster_extra(monkeypatch):
    monkeypatch.setitem(sys.modules, "ray", None)  # an import of ray now fails, as where it is not installed
    with pytest.raises(MissingDependencyError, match=r"handeye\[cluster\]"):
        list(run_tasks(_double, [1], EngineOptions(progress=False), "ray"))


def test_the_command_line_says_so_in_one_line(monkeypatch, tmp_path, capsys):
    from handeye.cli import main

    monkeypatch.setitem(sys.modules, "ray", None)
    pytest.importorskip("pyrender")
    assert main(["sim", "generate", "--out", str(tmp_path / "d"), "--engine", "ray", "--quiet"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "handeye[cluster]" in err
    assert not (tmp_path / "d").exists()  # refused before any output
