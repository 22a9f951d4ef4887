"""Processes and the system's refusals (issue 40 items 4 and 11).

Workers die with the process that started them (``kill -9`` included), so none writes into a dataset
after its lock is gone; a read-only folder, a full disk, an unopenable lock file or a standard output that
cannot be written is one line and a non-zero status, never a traceback, and a rerun works.
"""

from __future__ import annotations

import errno
import os
import resource
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest

from handeye.cli import describe_os_error, main
from tests.tiers import hold_ray_lock

REPO = Path(__file__).resolve().parents[1]
DATA = REPO / "handeye" / "data"
#: How long orphaned workers may live after their parent's ``kill -9`` (the issue's bound): the kernel's
#: parent-death signal ends them at once, so 2 s is scheduling slack on a loaded machine, not waiting.
ORPHAN_DEADLINE_S = 2.0
#: How long to wait for the workers of a spawned pool to start (imports on a loaded 2-core machine).
START_TIMEOUT_S = 60.0

pytestmark = pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")


def _state(pid: int) -> str | None:
    """The process's state letter (``R``, ``S``, ``Z`` ...), or None when it is gone."""
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except (OSError, IndexError):
        return None


def _alive(pid: int) -> bool:
    return _state(pid) not in (None, "Z", "X")  # a zombie has ended; only its exit status waits to be read


def _workers_of(pid: int) -> list[int]:
    """Living children of ``pid`` that are multiprocessing's spawned workers."""
    found = []
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            ppid = int((entry / "stat").read_text().rsplit(")", 1)[1].split()[1])
            cmdline = (entry / "cmdline").read_bytes()
        except (OSError, IndexError, ValueError):
            continue
        if ppid == pid and b"spawn_main" in cmdline and _alive(int(entry.name)):
            found.append(int(entry.name))
    return found


def _wait_for(condition, timeout_s: float, what: str):
    t0 = time.monotonic()
    while time.monotonic() - t0 < timeout_s:
        value = condition()
        if value:
            return value
        time.sleep(0.05)
    pytest.fail(f"timed out after {timeout_s} s waiting for {what}")


def _kill_and_time_orphans(parent: subprocess.Popen, workers: list[int], deadline_s=ORPHAN_DEADLINE_S) -> list[int]:
    """``kill -9`` the parent; the workers still alive ``deadline_s`` later."""
    try:
        os.kill(parent.pid, signal.SIGKILL)
        parent.wait()
        t0 = time.monotonic()
        while any(_alive(w) for w in workers) and time.monotonic() - t0 < deadline_s:
            time.sleep(0.02)
        return [w for w in workers if _alive(w)]
    finally:
        for w in workers:  # a failed test leaves nothing running
            if _alive(w):
                os.kill(w, signal.SIGKILL)


POOL_SCRIPT = textwrap.dedent(
    """
    import os, sys, time
    from pathlib import Path

    from handeye.core.engine_protocol import EngineOptions
    from handeye.core.pool import PoolEngine

    def busy(task):
        folder, number = task
        Path(folder, f"{os.getpid()}.started").touch()
        time.sleep(60)  # far longer than the test: a worker that outlives its parent is seen
        return number

    if __name__ == "__main__":
        list(PoolEngine().run(busy, [(sys.argv[1], k) for k in range(4)], EngineOptions(workers=2, progress=False)))
    """
)


def test_pool_workers_die_with_their_parent_mid_task(tmp_path):
    script = tmp_path / "pool_script.py"
    script.write_text(POOL_SCRIPT)
    parent = subprocess.Popen([sys.executable, str(script), str(tmp_path)], cwd=REPO)
    _wait_for(lambda: len(list(tmp_path.glob("*.started"))) == 2, START_TIMEOUT_S, "two busy workers")
    workers = [int(p.name.split(".")[0]) for p in tmp_path.glob("*.started")]
    assert sorted(workers) == sorted(_workers_of(parent.pid))
    assert _kill_and_time_orphans(parent, workers) == []


RAY_SCRIPT = POOL_SCRIPT.replace(
    "handeye.core.pool import PoolEngine", "handeye.core.ray_pool import RayEngine"
).replace("PoolEngine().run(busy", "RayEngine().run(busy")


def test_ray_workers_of_a_local_cluster_die_with_the_driver(tmp_path, request):
    """Ray's own notice of a dead driver took 1.9 s here (2.7 s while rendering; Ray 2.60): each task watches
    its driver instead, every ``DRIVER_POLL_S``; 5 polls is the bound (0.12-0.16 s measured)."""
    pytest.importorskip("ray", reason="the Ray engine needs the optional 'cluster' extra")
    from handeye.core.ray_pool import DRIVER_POLL_S

    hold_ray_lock(request)

    script = tmp_path / "ray_script.py"
    script.write_text(RAY_SCRIPT)
    driver = subprocess.Popen([sys.executable, str(script), str(tmp_path)], cwd=REPO, stderr=subprocess.DEVNULL)
    _wait_for(lambda: len(list(tmp_path.glob("*.started"))) == 2, 3 * START_TIMEOUT_S, "two busy Ray workers")
    workers = [int(p.name.split(".")[0]) for p in tmp_path.glob("*.started")]
    assert _kill_and_time_orphans(driver, workers, deadline_s=5 * DRIVER_POLL_S) == []


def test_a_local_ray_cluster_leaves_the_environment_as_it_was(request):
    """RayEngine's own local cluster, started and ended by one call: the process's environment as before it
    (``ray.init`` leaves ``RAY_AUTH_MODE=token`` there, and a ``ray start`` the process ran later was refused)."""
    pytest.importorskip("ray", reason="the Ray engine needs the optional 'cluster' extra")
    from handeye.core.engine_protocol import EngineOptions
    from handeye.core.ray_pool import RayEngine

    hold_ray_lock(request)
    before = dict(os.environ)
    assert sorted(RayEngine().run(abs, [-2, -1], EngineOptions(workers=1, progress=False))) == [1, 2]
    assert dict(os.environ) == before


def _kill_self_on_one(x):
    if x == 1:
        os.kill(os.getpid(), signal.SIGKILL)  # as the out-of-memory killer ends a process
    return x


def _refuse_to_start():
    raise ValueError("no renderer on this machine")


def test_a_worker_killed_mid_task_stops_the_work_instead_of_hanging():
    """multiprocessing's pool waits for a dead worker's task for ever; PoolEngine raises (an OSError: one line)."""
    from handeye.core.engine_protocol import EngineOptions
    from handeye.core.pool import PoolEngine, WorkerDiedError

    with pytest.raises(WorkerDiedError, match="killed by SIGKILL"):
        list(PoolEngine().run(_kill_self_on_one, range(4), EngineOptions(workers=2, progress=False)))


def test_a_pool_whose_task_lock_a_killed_worker_holds_is_stopped_not_waited_for():
    """CPython's ``Pool.terminate`` takes the task queue's read lock, which an idle worker holds while it waits for
    a task; killed then, the worker leaves it held and the terminate waits for ever (this file's test above hung
    so once). Made here for certain: one worker, idle after a task, killed; ``_stop`` must return and leave no
    worker alive."""
    import multiprocessing

    from handeye.core import pool as pool_module

    pool = multiprocessing.get_context("spawn").Pool(1)
    assert pool.apply(abs, (-3,)) == 3
    time.sleep(1.0)  # the worker is back in its queue's get(), holding the read lock
    os.kill(pool._pool[0].pid, signal.SIGKILL)
    time.sleep(1.0)  # the pool starts a replacement, which waits on the lock
    start = time.monotonic()
    pool_module._stop(pool, timeout_s=2.0)
    assert time.monotonic() - start < 2.0 + 5.0
    assert all(p.exitcode is not None for p in pool._pool)


def test_an_initializer_failure_is_raised_not_restarted_for_ever():
    from handeye.core.engine_protocol import EngineOptions
    from handeye.core.pool import PoolEngine

    options = EngineOptions(workers=2, progress=False, initializer=_refuse_to_start)
    with pytest.raises(ValueError, match="no renderer") as info:
        list(PoolEngine().run(abs, range(4), options))
    assert "while starting the worker process" in info.value.__notes__


def test_ctrl_c_is_the_parents_to_handle(tmp_path):
    """Ctrl-C reaches the whole process group: the workers leave it to the parent, which stops the pool; no
    worker prints a traceback (before: one ``KeyboardInterrupt`` traceback per worker)."""
    script = tmp_path / "pool_script.py"
    run = "    list(PoolEngine().run("
    stop = "    except KeyboardInterrupt:\n        sys.exit(130)\n"
    script.write_text(POOL_SCRIPT.replace(run, "    try:\n    " + run) + stop)
    parent = subprocess.Popen(
        [sys.executable, str(script), str(tmp_path)],
        cwd=REPO,
        start_new_session=True,
        stderr=subprocess.PIPE,
        text=True,
        # as from a terminal: an ignored SIGINT is inherited across exec, and pytest may run with it ignored (a
        # shell without job control starts a background job so: `bash -c 'pytest ... &'` fails this test
        # without this line, 30 s timeout, as CI did); no test here was found to leave it ignored (/proc's SigIgn
        # after every test of test_ray_engine, test_processes, learned/test_distributed, test_accelerator_path,
        # watch's learner, history and ros2 tests: SIGINT at its default)
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )
    _wait_for(lambda: len(list(tmp_path.glob("*.started"))) == 2, START_TIMEOUT_S, "two busy workers")
    workers = [int(p.name.split(".")[0]) for p in tmp_path.glob("*.started")]
    os.killpg(parent.pid, signal.SIGINT)
    try:
        assert parent.communicate(timeout=30) == (None, "") and parent.returncode == 130
    finally:
        for w in workers:
            if _alive(w):
                os.kill(w, signal.SIGKILL)


def test_sim_generate_workers_die_with_it(tmp_path):
    """``kill -9`` of ``handeye sim generate`` (small preset, 2 workers) leaves no worker rendering."""
    pytest.importorskip("pyrender")
    out = tmp_path / "ds"
    parent = subprocess.Popen(
        [sys.executable, "-m", "handeye", "sim", "generate", "--preset", "small", "--out", str(out)]
        + ["--workers", "2", "--quiet"],
        cwd=REPO,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    workers = _wait_for(
        lambda: _workers_of(parent.pid) if len(_workers_of(parent.pid)) == 2 else None, START_TIMEOUT_S, "workers"
    )
    assert _kill_and_time_orphans(parent, workers) == []
    from handeye.core.dataset import dataset_lock

    with dataset_lock(out, "test"):  # the lock died with the parent; no worker holds it
        pass


# ---------------------------------------------------------------- item 11: the system's refusals

#: One data frame of one camera pose at 128x128: a colour PNG of ~10-40 kB, over the file-size limit below,
#: while meta.json (~3 kB), cameras.csv and frames.csv (< 1 kB) stay under it.
TINY_ARGS = ("tiny", "ur5", ((0.0, 360.0),), (1,), (0,), 1)
TINY_SIZE = (128, 128)
#: RLIMIT_FSIZE of the full-disk drill that fails inside the worker (bytes).
SHARD_FSIZE = 8_000

TINY_SCRIPT = textwrap.dedent(
    f"""
    import sys

    if __name__ == "__main__":
        from sim.cameras import PRESETS, CameraPreset

        PRESETS["tiny"] = CameraPreset(*{TINY_ARGS!r}, image_size={TINY_SIZE!r})
        from handeye.cli import main

        sys.exit(main(sys.argv[1:]))
    """
)


def _full_disk_run(tmp_path: Path, out: Path, limit: int) -> subprocess.CompletedProcess:
    """``handeye sim generate --preset tiny`` with files limited to ``limit`` bytes (a full disk, EFBIG)."""
    script = tmp_path / "tiny_generate.py"
    script.write_text(TINY_SCRIPT)

    def limit_files():
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)  # a write over the limit fails instead of killing
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))

    argv = ["sim", "generate", "--preset", "tiny", "--recordings", "data", "--out", str(out), "--workers", "1"]
    return subprocess.run(
        [sys.executable, str(script), *argv, "--quiet"],
        cwd=REPO,
        preexec_fn=limit_files,
        capture_output=True,
        text=True,
        timeout=300,
    )


def _one_line_error(text: str, *needles: str) -> None:
    assert "Traceback" not in text, text
    lines = text.strip().splitlines()
    assert len(lines) == 1, text
    assert "error" in lines[0] and all(n in lines[0] for n in needles), lines[0]


def test_a_full_disk_in_a_worker_is_one_line_and_a_rerun_completes(tmp_path):
    pytest.importorskip("pyrender")
    from handeye.core.engine_protocol import EngineOptions
    from sim.cameras import CameraPreset
    from sim.generate import Recipe, generate

    out = tmp_path / "ds"
    run = _full_disk_run(tmp_path, out, SHARD_FSIZE)
    assert run.returncode != 0 and run.stdout == ""
    _one_line_error(run.stderr, "cam_0000", "File too large")
    assert not list((out / "shards").glob("cam_0000*")), "a failed shard is left behind"
    preset = CameraPreset(*TINY_ARGS, image_size=TINY_SIZE)
    report = generate(out, Recipe(preset, recordings=("data",)), options=EngineOptions(workers=1, progress=False))
    assert report.rendered == [0] and report.frames == 1


def test_an_unopenable_lock_file_is_one_line(tmp_path, capsys):
    pytest.importorskip("pyrender")
    out = tmp_path / "ds"
    (out / ".lock").mkdir(parents=True)
    assert main(["sim", "generate", "--preset", "small", "--out", str(out), "--quiet"]) != 0
    _one_line_error(capsys.readouterr().err, ".lock")
    assert [p.name for p in out.iterdir()] == [".lock"]


def test_a_folder_that_cannot_be_created_is_one_line(tmp_path, capsys, monkeypatch):
    """As root a read-only folder is writable, so the refusal is injected where the folder is made."""
    pytest.importorskip("pyrender")

    def refuse(self, *args, **kwargs):
        raise PermissionError(errno.EACCES, "Permission denied", str(self))

    monkeypatch.setattr(Path, "mkdir", refuse)
    out = tmp_path / "ro" / "ds"
    assert main(["sim", "generate", "--preset", "small", "--out", str(out), "--quiet"]) != 0
    _one_line_error(capsys.readouterr().err, str(out), "Permission denied", "writable --out")


@pytest.mark.skipif(os.geteuid() == 0, reason="root writes into a read-only folder")
def test_a_read_only_folder_is_one_line(tmp_path, capsys):
    pytest.importorskip("pyrender")
    ro = tmp_path / "ro"
    ro.mkdir()
    ro.chmod(0o555)
    try:
        assert main(["sim", "generate", "--preset", "small", "--out", str(ro / "ds"), "--quiet"]) != 0
    finally:
        ro.chmod(0o755)
    _one_line_error(capsys.readouterr().err, str(ro / "ds"))


# ---------------------------------------------------------------- standard output

CALIBRATE = ["calibrate", str(DATA / "example_eye_to_hand.csv"), "--setup", "eye-to-hand"]


def _handeye(argv: list[str], stdout) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "handeye", *argv], cwd=REPO, stdout=stdout, stderr=subprocess.PIPE, text=True
    )


def test_stdout_on_a_full_device_is_one_line():
    with open("/dev/full", "w") as full:
        run = _handeye(CALIBRATE, full)
    assert run.returncode == 1
    _one_line_error(run.stderr, "standard output", "No space left on device")


def test_stdout_into_a_closed_pipe_ends_quietly():
    """``handeye ... | head -1`` where ``head`` has gone: no traceback, no message, a non-zero status."""
    read, write = os.pipe()
    os.close(read)  # the reader has stopped: every write is EPIPE
    try:
        run = _handeye(CALIBRATE, write)
    finally:
        os.close(write)
    assert (run.returncode, run.stderr) == (1, "")


def test_an_os_error_names_its_path_cause_and_task():
    exc = OSError(errno.ENOSPC, "No space left on device", "/data/ds/shards/cam_0003.partial/rgb/x.png")
    exc.add_note("while running task render camera 3 of /data/ds")
    text = describe_os_error(exc)
    assert text.startswith("/data/ds/shards/cam_0003.partial/rgb/x.png: No space left on device")
    assert "free some space" in text and "render camera 3" in text
    assert describe_os_error(ConnectionResetError(errno.ECONNRESET, "Connection reset by peer")) == (
        "Connection reset by peer"
    )


def test_any_os_error_of_a_command_is_one_line(monkeypatch, capsys):
    import handeye.commands.calibrate as calibrate

    def fail(args):
        raise IsADirectoryError(errno.EISDIR, "Is a directory", "/tmp/some/where")

    monkeypatch.setattr(calibrate, "run", fail)
    assert main(CALIBRATE) == 1
    _one_line_error(capsys.readouterr().err, "handeye calibrate: error: /tmp/some/where: Is a directory")


def test_ctrl_c_is_one_line(monkeypatch, capsys):
    import handeye.commands.calibrate as calibrate

    def interrupted(args):
        raise KeyboardInterrupt

    monkeypatch.setattr(calibrate, "run", interrupted)
    assert main(CALIBRATE) == 130
    assert capsys.readouterr().err == "handeye calibrate: interrupted\n"
