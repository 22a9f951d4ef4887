"""Run a function over tasks on worker processes, with a progress bar: the one pool of the package.

Workers are spawned (never forked: OpenGL, OpenCV and torch state does not
survive a fork), so ``fn``, ``initializer`` and the tasks must be picklable
(module-level functions, plain data), and a script calling :meth:`PoolEngine.run`
must guard its entry point with ``if __name__ == "__main__":``.

Workers die with the process that started them, however it ends (``kill -9`` included), so no worker
writes into a dataset after its writer lost the dataset's lock: on Linux each worker asks the kernel for
``SIGKILL`` when its parent dies (``prctl(PR_SET_PDEATHSIG)``), before it imports the work's modules;
elsewhere a watchdog thread polls the parent every :data:`PARENT_POLL_S`; everywhere a worker checks
its parent before each task.

Example::

    from handeye.core.engine_protocol import EngineOptions
    from handeye.core.pool import PoolEngine

    def square(x):
        return x * x

    if __name__ == "__main__":
        for x2 in PoolEngine().run(square, range(10), EngineOptions(workers=2, desc="squares", ordered=True)):
            print(x2)
"""

from __future__ import annotations

import ctypes
import multiprocessing
import os
import pickle
import signal
import sys
import threading
import time
import warnings
from collections.abc import Callable, Iterable, Iterator
from multiprocessing.reduction import ForkingPickler

from handeye.core.engine_protocol import DEFAULT_WORKERS, EngineOptions
from handeye.core.limits import one_line

__all__ = ["PoolEngine", "NamedTask", "WorkerDiedError", "PARENT_POLL_S", "WORKER_CHECK_S"]

#: Where the kernel cannot kill a worker with its parent (not Linux): seconds between a watchdog's checks.
PARENT_POLL_S = 0.5
#: ``PR_SET_PDEATHSIG`` of ``<sys/prctl.h>``: the signal a process receives when its parent dies.
_PR_SET_PDEATHSIG = 1
#: In a worker process: the pid of the process that started it; None in any other process.
_PARENT: int | None = None
#: In a worker process: the exception its initializer raised, re-raised by every task it is given.
_INIT_FAILURE: Exception | None = None
#: Seconds between the parent's checks that no worker died while it waits for a result.
WORKER_CHECK_S = 0.5
#: How long a failed pool's own ``terminate`` may take before its workers are killed here (:func:`_stop`).
STOP_TIMEOUT_S = 10.0


class WorkerDiedError(ChildProcessError):
    """A worker process ended in the middle of the work (killed: out of memory, a signal, a crash in C code).

    :class:`multiprocessing.pool.Pool` would wait for its task for ever; the work is stopped instead. An
    :class:`OSError`, so the command line prints it as one line.
    """


def _arm_parent_death_signal() -> bool:
    """Ask Linux to SIGKILL this process when its parent dies; False where that is not available."""
    if not sys.platform.startswith("linux"):
        return False
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        return libc.prctl(_PR_SET_PDEATHSIG, int(signal.SIGKILL), 0, 0, 0) == 0
    except (OSError, AttributeError):  # no libc or no prctl (a static or unusual runtime)
        return False


def _exit_if_orphaned() -> None:
    """End this worker at once when the process that started it is gone (its work is no longer wanted)."""
    if _PARENT is not None and os.getppid() != _PARENT:
        os._exit(1)


def _watch_parent() -> None:
    while True:
        _exit_if_orphaned()
        time.sleep(PARENT_POLL_S)


def _one_line_warning(message, category, filename, lineno, file=None, line=None) -> None:
    """A worker's warnings as the command prints its own (``handeye.cli``): handeye's own as one line on stderr
    (``handeye: warning: ...``, not Python's two lines with the source line), a library's not at all."""
    if category.__module__.split(".")[0] in ("handeye", "classic", "sim", "learned"):
        print(one_line(f"handeye: warning: {message}"), file=sys.stderr if file is None else file)


def _start_worker(parent_pid: int, payload: bytes) -> None:
    """A pool worker's initializer: die with the parent, leave Ctrl-C to it, then run the caller's initializer.

    The caller's ``(initializer, initargs)`` arrive pickled, so that the parent-death signal is armed
    before their modules (rendering, torch, ...) are imported, which can take seconds.
    """
    global _PARENT, _INIT_FAILURE
    _PARENT = parent_pid
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is the parent's to handle: it stops the pool
    if not _arm_parent_death_signal():
        threading.Thread(target=_watch_parent, name="handeye-parent-watchdog", daemon=True).start()
    _exit_if_orphaned()  # the parent died before the signal was armed
    warnings.showwarning = _one_line_warning
    try:
        initializer, initargs = pickle.loads(payload)
        if initializer is not None:
            initializer(*initargs)
    except Exception as exc:  # raised in the tasks, of its own type: a pool would restart this worker for ever
        exc.add_note("while starting the worker process")  # once: the same exception is raised by every task
        _INIT_FAILURE = exc


class NamedTask:
    """``fn`` of one task, re-raising a failure with the task named (a note on the exception); in a pool worker
    it first ends an orphaned worker and re-raises its initializer's failure (a no-op in any other process)."""

    def __init__(self, fn: Callable, describe: Callable[[object], str]):
        self.fn, self.describe = fn, describe

    def __call__(self, task):
        _exit_if_orphaned()  # between tasks: a fallback where the parent-death signal is not available
        if _INIT_FAILURE is not None:
            raise _INIT_FAILURE
        try:
            return self.fn(task)
        except Exception as exc:
            exc.add_note(f"while running task {self.describe(task)}")
            raise


def _watched(pool, results, n: int) -> Iterator:
    """The ``n`` results of a pool's ``imap``; a :class:`WorkerDiedError` when a worker process dies meanwhile."""
    workers: dict = {}
    for _ in range(n):
        while True:
            for process in pool._pool:  # the live workers (a private list, stable since Python 3.2)
                workers.setdefault(process.pid, process)
            try:
                result = results.next(timeout=WORKER_CHECK_S)
                break
            except multiprocessing.TimeoutError:
                dead = [p for p in workers.values() if p.exitcode is not None]
                if dead:
                    raise WorkerDiedError(_death(dead[0])) from None
        yield result


def _death(process) -> str:
    code = process.exitcode
    if code < 0:
        name = signal.Signals(-code).name if -code in signal.valid_signals() else f"signal {-code}"
        how = f"was killed by {name}" + (" (out of memory?)" if -code == signal.SIGKILL else "")
    else:
        how = f"exited with status {code}"
    return f"a worker process (pid {process.pid}) {how} in the middle of the work; the work was stopped"


def _stop(pool, timeout_s: float = STOP_TIMEOUT_S) -> None:
    """Terminate a failed pool, killing its workers here if the pool's own ``terminate`` hangs.

    CPython's ``Pool.terminate`` first takes its task queue's read lock, which an idle worker holds while it waits
    for a task: a worker killed then (the out-of-memory killer, ``kill -9``) leaves it held for ever, and the
    terminate, which the work's own failure called, waits for ever (seen in this project's test of a worker that
    kills itself). Here it runs in a daemon thread; past ``timeout_s`` the workers are killed and the pool left to
    that thread (its finalizer has run, so the interpreter's exit does not wait on it again).
    """
    stopper = threading.Thread(target=pool.terminate, name="handeye-pool-stop", daemon=True)
    stopper.start()
    stopper.join(timeout_s)
    if not stopper.is_alive():
        pool.join()
        return
    for process in list(pool._pool):  # the live workers (a private list, stable since Python 3.2)
        process.kill()
        process.join(timeout_s)


class PoolEngine:
    """The :class:`~handeye.core.engine_protocol.Engine` of this machine: ``workers`` spawned processes.

    One worker runs the tasks in this process, unless ``options.isolate``. A task's failure or a
    worker's death stops the remaining work.

    Examples
    --------
    >>> list(PoolEngine().run(abs, [-1, 2, -3], EngineOptions(workers=1, progress=False, ordered=True)))
    [1, 2, 3]
    """

    def run(self, fn: Callable, tasks: Iterable, options: EngineOptions = EngineOptions()) -> Iterator:
        """Yield ``fn(task)`` for every task, computed on ``options.workers`` processes (at most one per task).

        Parameters, yields and exceptions as :meth:`Engine.run <handeye.core.engine_protocol.Engine.run>`;
        ``options.workers`` None: :data:`~handeye.core.engine_protocol.DEFAULT_WORKERS`.

        Raises
        ------
        WorkerDiedError
            A worker process died (killed, out of memory) before its task returned; the remaining work is
            stopped.
        """
        tasks = list(tasks)
        if not tasks:
            return
        workers = options.workers or DEFAULT_WORKERS
        call = NamedTask(fn, options.describe)
        bar = options.progress_bar(len(tasks))
        pool, finished = None, False
        try:
            if workers == 1 and not options.isolate:
                if options.initializer is not None:
                    options.initializer(*options.initargs)
                results = map(call, tasks)
            else:
                # the caller's initializer as the pool pickles its arguments, unpickled after the death signal
                payload = bytes(ForkingPickler.dumps((options.initializer, options.initargs)))
                pool = multiprocessing.get_context("spawn").Pool(
                    min(workers, len(tasks)), _start_worker, (os.getpid(), payload)
                )
                imap = pool.imap if options.ordered else pool.imap_unordered
                results = _watched(pool, imap(call, tasks), len(tasks))
            for result in results:
                if bar is not None:
                    bar.update(1)
                yield result
            finished = True
        finally:
            if pool is not None:
                if finished:
                    pool.close()
                    pool.join()
                else:  # a failure: stop the remaining work
                    _stop(pool)
            if bar is not None:
                bar.close()
