"""The Ray engine: a 2-worker local cluster renders and labels the small preset exactly as the process pool does,
and a worker killed in the middle of a shard costs nothing but time."""

from __future__ import annotations

import filecmp
import os
import signal
import threading
from pathlib import Path

import pytest

ray = pytest.importorskip(
    "ray", reason="the Ray engine needs the optional 'cluster' extra: pip install 'handeye[cluster]'"
)

from benchmarks.cluster_engines import differing_files, kill_when_half_written  # noqa: E402
from handeye.core.engine_protocol import EngineOptions  # noqa: E402
from handeye.core.ray_pool import LOCAL_WORKER_NICENESS, RayEngine  # noqa: E402
from tests.tiers import hold_ray_lock  # noqa: E402


def run_ray(fn, tasks, workers, **options):
    return RayEngine().run(fn, tasks, EngineOptions(workers=workers, **options))


@pytest.fixture(scope="module")
def local_cluster(request):
    """One local 2-CPU Ray cluster for the module (RayEngine uses an initialised Ray as is); the environment as it
    was after it: ``ray.init`` leaves ``RAY_AUTH_MODE=token`` in this process's environment, and a later test's
    ``ray start --head`` (the docs' blocks, under ``pytest -n 0``) inherited it and was refused for want of a
    token."""
    hold_ray_lock(request)
    before = dict(os.environ)
    os.environ.setdefault(*LOCAL_WORKER_NICENESS)  # as RayEngine starts its own
    ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False, object_store_memory=256 * 2**20)
    yield
    ray.shutdown()
    os.environ.clear()
    os.environ.update(before)


def _square_and_inits(x):
    return os.getpid(), x * x


def _log_init(log):
    """Initializer: this worker's pid appended to ``log``, once per run of the initializer."""
    with open(log, "a") as f:
        f.write(f"{os.getpid()}\n")


def _fails_on_three(x):
    if x == 3:
        raise ValueError("three is refused")
    return x


def _dies_once(args):
    """Kill this worker process (SIGKILL) the first time task 2 runs; the retry finds the marker."""
    x, marker = args
    if x == 2 and not Path(marker).exists():
        Path(marker).write_text("killed once")
        os.kill(os.getpid(), signal.SIGKILL)
    return x * 10


def test_results_in_order_and_initializer_once_per_worker(local_cluster, tmp_path):
    log = tmp_path / "inits"
    out = list(
        run_ray(_square_and_inits, range(8), 2, progress=False, ordered=True, initializer=_log_init, initargs=(log,))
    )
    assert [r[1] for r in out] == [x * x for x in range(8)]
    inits = log.read_text().split()
    # every worker that ran a task initialised, and once however many tasks it took (workers that served an
    # earlier test hold those tests' initializer keys too: counted by process, not by key)
    assert sorted(inits) == sorted(set(inits)) and {str(r[0]) for r in out} <= set(inits)
    assert sorted(r[1] for r in run_ray(_square_and_inits, range(5), 2, progress=False)) == [0, 1, 4, 9, 16]


def test_a_task_error_is_raised_with_its_type_and_the_task_named(local_cluster):
    with pytest.raises(ValueError, match="three is refused") as info:
        list(run_ray(_fails_on_three, range(6), 2, progress=False, describe=lambda x: f"number {x}"))
    assert "while running task number 3" in info.value.__notes__


def test_a_killed_worker_is_replaced_and_its_task_run_again(local_cluster, tmp_path):
    marker = tmp_path / "killed"
    out = sorted(run_ray(_dies_once, [(x, str(marker)) for x in range(5)], 2, progress=False))
    assert marker.exists(), "the fault was not injected"
    assert out == [0, 10, 20, 30, 40]


@pytest.mark.slow  # 19 s, a whole preset on Ray (a killed worker alone: the test above it)
def test_small_preset_on_ray_with_a_worker_killed_is_byte_identical_to_the_pool(local_cluster, small_dataset, tmp_path):
    from handeye.core.dataset import Dataset
    from handeye.labelling import LabelRunOptions, label_dataset
    from sim.generate import Recipe, generate

    pool_root = small_dataset[0]
    root = tmp_path / "small"
    stop, killed = threading.Event(), []
    killer = threading.Thread(target=kill_when_half_written, args=(root, stop, killed))
    killer.start()
    try:
        report = generate(root, Recipe("small", seed=0), options=EngineOptions(workers=2, progress=False), engine="ray")
    finally:
        stop.set()
        killer.join()
    assert killed, "no worker was killed: the fault drill did not run"
    assert report.rendered == list(range(6)) and not report.regenerated
    assert not list((root / "shards").glob("*.partial")), "a half-written shard was left behind"
    assert differing_files(pool_root / "shards", root / "shards") == []
    assert filecmp.cmp(pool_root / "meta.json", root / "meta.json", shallow=False)
    for c in range(len(Dataset.open(root))):
        Dataset.open(root).frames(c)  # every shard passes the manifest check
    label_dataset(root, workers=2, progress=False, plot=False, options=LabelRunOptions(engine="ray"))
    assert filecmp.cmp(pool_root / "cameras.csv", root / "cameras.csv", shallow=False)


def test_an_address_without_the_ray_engine_is_refused(tmp_path, capsys):
    from handeye.cli import main

    assert main(["sim", "generate", "--out", str(tmp_path / "d"), "--address", "auto", "--quiet"]) == 2
    assert "--engine ray" in capsys.readouterr().err
    assert not (tmp_path / "d").exists()


def test_a_folder_other_nodes_cannot_see_is_named(tmp_path):
    from handeye.core.engines import require_visible
    from handeye.core.errors import DatasetError

    with pytest.raises(DatasetError, match="shared by every node"):
        require_visible(tmp_path / "elsewhere" / "meta.json")


def _remember(value):
    global _REMEMBERED
    _REMEMBERED = value


def _recall(_):
    return _REMEMBERED


def test_a_worker_initialises_again_when_the_arguments_change(local_cluster):
    """On a standing cluster a worker serves call after call: state set up for other arguments is never reused."""
    for value in ("first", "second", "first"):
        out = set(run_ray(_recall, range(4), 2, progress=False, initializer=_remember, initargs=(value,)))
        assert out == {value}


def _io_error_once(args):
    """An OSError the first time (a shared folder's hiccup), the result on the retry."""
    x, marker = args
    if not Path(marker).exists():
        Path(marker).write_text("failed once")
        raise OSError(5, "Input/output error", marker)
    return x + 1


def _value_error_counted(log):
    with open(log, "a") as f:
        f.write("attempt\n")
    raise ValueError("bad input fails again the same way")


def test_an_io_error_is_retried_and_other_errors_are_not(local_cluster, tmp_path):
    assert list(run_ray(_io_error_once, [(1, str(tmp_path / "hiccup"))], 1, progress=False)) == [2]
    log = tmp_path / "attempts"
    with pytest.raises(ValueError, match="fails again"):
        list(run_ray(_value_error_counted, [str(log)], 1, progress=False))
    assert log.read_text().count("attempt") == 1
