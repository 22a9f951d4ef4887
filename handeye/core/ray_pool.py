"""Run a function over tasks on a Ray cluster, with a progress bar: :class:`RayEngine`, the pool's twin for many
machines.

The same contract as :class:`handeye.core.pool.PoolEngine` (module-level ``fn``,
picklable tasks, an ``initializer`` run once in each worker process), but the
tasks go to Ray (``pip install "handeye[cluster]"``): a local cluster started
for the call (``address=None``) or a running one (``address="auto"`` on one of
its nodes, ``"ray://HEAD:10001"`` from outside). Ray restarts a task whose
worker process or node died, or that raised an ``OSError`` (a shared folder's
hiccup), up to ``max_retries`` times, so a task must be idempotent: the
dataset shards are (each is drawn from its own seed and published atomically
by :class:`handeye.core.shard_writer.ShardWriter`). Any other exception raised
by ``fn`` (bad input would fail again the same way) is not retried: it is
re-raised with the task named, and the tasks not yet finished are cancelled.

A driver killed outright (``kill -9``) leaves no task running for long: a local cluster that
:class:`RayEngine` started (``address=None``) is ended by the kernel with it (Ray's own processes share
their starter's fate), and each task's worker also watches the driver's process (:data:`DRIVER_POLL_S`)
and ends itself when it is gone, before Ray's own notice (measured 2.7-2.8 s after the driver's death,
Ray 2.60; its dashboard and runtime-env agents linger longer, but write nothing). On a running cluster
(``address``) Ray ends the tasks of a driver that died, within its own heartbeat.

On a cluster of several machines every path a task reads or writes must be the
same on every node: a shared folder (NFS, or an object store mounted with
s3fs / gcsfuse), and the project installed in the same environment on every
node.

Example::

    from handeye.core.engine_protocol import EngineOptions
    from handeye.core.ray_pool import RayEngine

    def square(x):
        return x * x

    if __name__ == "__main__":
        print(sorted(RayEngine().run(square, range(10), EngineOptions(workers=2))))
"""

from __future__ import annotations

import hashlib
import logging
import os
import pickle
import threading
import time
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass
from pathlib import Path

from handeye.core.engine_protocol import DEFAULT_WORKERS, EngineOptions
from handeye.core.errors import HandEyeInputError
from handeye.core.optional import require_package
from handeye.core.pool import NamedTask

__all__ = ["RayEngine", "busy_worker_pids"]

#: Seconds between a worker's checks that the driver of a local cluster is still alive.
DRIVER_POLL_S = 0.2
#: A local cluster's workers at the driver's priority. Ray starts its workers at niceness 15 (its
#: ``worker_niceness``), so that on a machine doing anything else they get a few percent of a core: the small
#: preset's render on a local cluster took 10 s on an idle 2-core machine and 269 s beside three busy processes,
#: where the process pool takes 1.8 times its idle time. Set before ``ray.init`` starts the raylet, unless the
#: environment says otherwise; a running cluster (``--address``) keeps what ``ray start`` gave it.
LOCAL_WORKER_NICENESS = ("RAY_worker_niceness", "0")
#: The driver this (worker) process watches: ``(pid, start time)`` of a local cluster's driver, or None.
_WATCHED: tuple | None = None

#: The key (initializer and its arguments) each initializer last ran with in this (worker) process: a Ray
#: worker runs many tasks, of one call or, on a standing cluster, of several calls with other arguments.
_READY: dict = {}


def busy_worker_pids() -> list[int]:
    """Process ids of this machine's Ray workers busy with a :class:`RayEngine` task (Linux ``/proc``).

    For fault drills: kill one (``os.kill(pid, signal.SIGKILL)``) and Ray runs its task again on another
    worker; the result and a dataset's shards are the same as without the fault.
    """
    pids = []
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                title = (entry / "cmdline").read_bytes()
            except OSError:  # gone meanwhile
                continue
            if title.startswith(b"ray::" + _handeye_task.__name__.encode()):
                pids.append(int(entry.name))
    return sorted(pids)


def _process_identity(pid: int) -> tuple | None:
    """``(pid, start time)`` of a living process on this machine (Linux ``/proc``); None when gone or unknown.

    The start time tells the process from a later one that reuses its pid.
    """
    try:
        fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    except (OSError, IndexError):
        return None
    if len(fields) < 20 or fields[0] in ("Z", "X"):  # a zombie has ended: only its exit status is left
        return None
    return pid, fields[19]  # field 22 of proc(5), clock ticks since boot


def _watch_driver(driver: tuple) -> None:
    while _process_identity(driver[0]) == driver:
        time.sleep(DRIVER_POLL_S)
    os._exit(1)  # the driver is gone: its results have no reader, and its dataset's lock is released


def _follow_driver(driver: tuple | None) -> None:
    """In a worker of a local cluster: end this process when the driver that started the cluster dies."""
    global _WATCHED
    if driver is None or _WATCHED == driver:
        return
    _WATCHED = driver
    threading.Thread(target=_watch_driver, args=(driver,), name="handeye-driver-watchdog", daemon=True).start()


def _handeye_task(
    fn: Callable, initializer: Callable | None, initargs: tuple, key: str, task, driver: tuple | None = None
):
    """Body of one Ray task: watch a local cluster's driver, run the initializer once per worker process, then
    ``fn(task)``."""
    _follow_driver(driver)
    if initializer is not None and _READY.get(initializer) != key:
        initializer(*initargs)  # first task here, or the last ran with other arguments: its state is stale
        _READY[initializer] = key
    return fn(task)


def _init_key(initializer: Callable | None, initargs: tuple) -> str:
    if initializer is None:
        return ""
    name = f"{initializer.__module__}.{initializer.__qualname__}".encode()
    return hashlib.sha256(name + pickle.dumps(initargs)).hexdigest()


def _start(ray, address: str | None, workers: int | None) -> bool:
    """Connect to Ray (or start a local cluster); True when this call started it and must shut it down."""
    if ray.is_initialized():
        return False
    os.environ.setdefault("RAY_ACCEL_ENV_VAR_OVERRIDE_ON_ZERO", "0")  # quiets a FutureWarning of Ray 2.x
    kwargs = dict(include_dashboard=False, log_to_driver=False, logging_level=logging.WARNING)
    if address is None:  # a local cluster of `workers` CPUs, with a small object store (tasks pass paths, not data)
        os.environ.setdefault(*LOCAL_WORKER_NICENESS)
        ray.init(num_cpus=workers, object_store_memory=256 * 2**20, **kwargs)
    else:
        try:
            ray.init(address=address, **kwargs)
        except (ConnectionError, RuntimeError, ValueError) as exc:
            raise HandEyeInputError(f"--address {address}: cannot connect to a Ray cluster ({exc})") from None
    return True


@dataclass(frozen=True)
class RayEngine:
    """The :class:`~handeye.core.engine_protocol.Engine` of a Ray cluster: Ray workers, one CPU a task.

    Attributes
    ----------
    address : str, optional
        A running cluster (``"auto"``, ``"HOST:6379"``, ``"ray://HOST:10001"``); None starts a local one of
        ``options.workers`` CPUs for each run and stops it at the end. When Ray is already initialised in this
        process, it is used as is.
    max_retries : int
        Times Ray runs a task again after its worker process or node died, or it raised ``OSError``.
    """

    address: str | None = None
    max_retries: int = 3

    def run(self, fn: Callable, tasks: Iterable, options: EngineOptions = EngineOptions()) -> Iterator:
        """Yield ``fn(task)`` for every task, with ``options.workers`` tasks in flight at once.

        Parameters, yields and exceptions as :meth:`Engine.run <handeye.core.engine_protocol.Engine.run>`;
        ``options.workers`` None: :data:`~handeye.core.engine_protocol.DEFAULT_WORKERS` on a local cluster,
        all the CPUs of a running one (``address``); ``options.isolate`` always holds (tasks run in Ray's
        workers); a task failed by ``OSError`` or a dead worker is run again, up to ``max_retries`` times.

        Raises
        ------
        MissingDependencyError
            Ray is not installed.
        HandEyeInputError
            ``address`` cannot be reached.
        """
        tasks = list(tasks)
        if not tasks:
            return
        ray = require_package("ray", extra="cluster", purpose="the Ray engine")
        workers = options.workers or (DEFAULT_WORKERS if self.address is None else None)
        environ = dict(os.environ)  # ray.init leaves RAY_AUTH_MODE and PYTHONBREAKPOINT in it
        started = _start(ray, self.address, workers)
        bar = None
        pending: list = []
        try:
            # transient I/O errors (a shared folder's hiccup) are retried like a dead worker; the task's other
            # exceptions (bad input, a refused dataset) would fail again the same way, so they stop the run
            remote = ray.remote(num_cpus=1, max_retries=self.max_retries, retry_exceptions=[OSError])(_handeye_task)
            key = _init_key(options.initializer, options.initargs)
            driver = _process_identity(os.getpid()) if started and self.address is None else None  # a local cluster
            initargs_ref = ray.put(options.initargs)
            call = NamedTask(fn, options.describe)
            window = workers or max(1, int(ray.cluster_resources().get("CPU", 1)))
            bar = options.progress_bar(len(tasks))
            submitted = 0

            def submit():
                nonlocal submitted
                ref = remote.remote(call, options.initializer, initargs_ref, key, tasks[submitted], driver)
                pending.append(ref)
                submitted += 1

            while submitted < min(window, len(tasks)):
                submit()
            while pending:
                result = _get(ray, _next_done(ray, pending, options.ordered))
                if submitted < len(tasks):
                    submit()
                if bar is not None:
                    bar.update(1)
                yield result
        finally:
            for ref in pending:  # a failure or an abandoned generator: stop the remaining work
                ray.cancel(ref, force=True)
            if bar is not None:
                bar.close()
            if started:  # the cluster this call started, ended, and the process's environment as it was
                ray.shutdown()
                os.environ.clear()
                os.environ.update(environ)


def _next_done(ray, pending: list, ordered: bool):
    """Take the next task to collect out of ``pending``: the oldest when ``ordered``, else the first finished."""
    ref = pending[0] if ordered else ray.wait(pending, num_returns=1)[0][0]
    pending.remove(ref)
    return ref


def _get(ray, ref):
    """``ray.get`` with the task's own exception re-raised (not Ray's wrapper)."""
    try:
        return ray.get(ref)
    except ray.exceptions.RayTaskError as exc:
        cause = exc.cause if isinstance(exc.cause, BaseException) else None
        if cause is not None:
            raise cause from None
        raise
