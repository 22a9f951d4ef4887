"""Run a function over tasks on worker processes, with a progress bar: the one pool of the package.

Workers are spawned (never forked: OpenGL, OpenCV and torch state does not
survive a fork), so ``fn``, ``initializer`` and the tasks must be picklable
(module-level functions, plain data), and a script calling :func:`run_pool`
must guard its entry point with ``if __name__ == "__main__":``.

Workers die with the process that started them, however it ends (``kill -9`` included), so no worker
writes into a dataset after its writer lost the dataset's lock: on Linux each worker asks the kernel for
``SIGKILL`` when its parent dies (``prctl(PR_SET_PDEATHSIG)``), before it imports the work's modules;
elsewhere a watchdog thread polls the parent every :data:`PARENT_POLL_S`; everywhere a worker checks
its parent before each task.

Example::

    from handeye.core.pool import run_pool

    def square(x):
        return x * x

    if __name__ == "__main__":
        for x2 in run_pool(square, range(10), workers=2, desc="squares", ordered=True):
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

from handeye.core.limits import one_line
from handeye.core.optional import require_package

__all__ = ["run_pool", "WorkerDiedError", "PARENT_POLL_S", "WORKER_CHECK_S"]

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


class _Named:
    """``fn`` of one task, re-raising a failure with the task named (a note on the exception)."""

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


def run_pool(
    fn: Callable,
    tasks: Iterable,
    workers: int = 2,
    progress: bool = True,
    desc: str = "",
    unit: str = "task",
    ordered: bool = False,
    initializer: Callable | None = None,
    initargs: tuple = (),
    isolate: bool = False,
    describe: Callable[[object], str] = repr,
) -> Iterator:
    """Yield ``fn(task)`` for every task, computed on ``workers`` spawned processes.

    Parameters
    ----------
    fn : callable
        A module-level function of one task.
    tasks : iterable
        The tasks (each picklable).
    workers : int
        Processes, at most one per task; 1 runs in this process unless ``isolate``.
    progress : bool
        A progress bar on stderr (``tqdm``: ``pip install "handeye[sim]"``).
    desc, unit : str
        The progress bar's label and unit.
    ordered : bool
        Results in the order of the tasks; False (default) yields each as it completes.
    initializer : callable, optional
        Called once in each worker process with ``initargs`` (in this process when run in it), after the
        worker has armed its death with this process.
    initargs : tuple
    isolate : bool
        Run in a worker process even with ``workers=1`` (work that must not touch this process's state,
        such as an OpenGL context).
    describe : callable
        Names a task in the message of its failure (module-level, picklable); default ``repr``.

    Yields
    ------
    object
        ``fn(task)``, in task order when ``ordered``, else as completed.

    Raises
    ------
    Exception
        The first exception a task (or a worker's ``initializer``) raises, of its own type, with the note
        ``while running task ...`` (its ``__notes__``, printed under its traceback); the remaining work is
        stopped.
    WorkerDiedError
        A worker process died (killed, out of memory) before its task returned; the remaining work is stopped.

    Examples
    --------
    >>> list(run_pool(abs, [-1, 2, -3], workers=1, progress=False, ordered=True))
    [1, 2, 3]
    """
    if workers < 1:
        raise ValueError(f"workers must be >= 1, got {workers}")
    tasks = list(tasks)
    if not tasks:
        return
    call = _Named(fn, describe)
    bar = None
    if progress:
        tqdm = require_package("tqdm", extra="sim", purpose="a progress bar").tqdm
        bar = tqdm(total=len(tasks), desc=desc, unit=unit, file=sys.stderr)
    pool, finished = None, False
    try:
        if workers == 1 and not isolate:
            if initializer is not None:
                initializer(*initargs)
            results = map(call, tasks)
        else:
            payload = bytes(ForkingPickler.dumps((initializer, initargs)))  # as the pool pickles its arguments
            pool = multiprocessing.get_context("spawn").Pool(
                min(workers, len(tasks)), _start_worker, (os.getpid(), payload)
            )
            results = _watched(pool, (pool.imap if ordered else pool.imap_unordered)(call, tasks), len(tasks))
        for result in results:
            if bar is not None:
                bar.update(1)
            yield result
        finished = True
    finally:
        if pool is not None:
            if finished:
                pool.close()
            else:  # a failure: stop the remaining work
                pool.terminate()
            pool.join()
        if bar is not None:
            bar.close()
