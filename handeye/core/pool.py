"""Run a function over tasks on worker processes, with a progress bar: the one pool of the package.

Workers are spawned (never forked: OpenGL, OpenCV and torch state does not
survive a fork), so ``fn``, ``initializer`` and the tasks must be picklable
(module-level functions, plain data), and a script calling :func:`run_pool`
must guard its entry point with ``if __name__ == "__main__":``.

Example::

    from handeye.core.pool import run_pool

    def square(x):
        return x * x

    if __name__ == "__main__":
        for x2 in run_pool(square, range(10), workers=2, desc="squares", ordered=True):
            print(x2)
"""

from __future__ import annotations

import multiprocessing
import sys
from collections.abc import Callable, Iterable, Iterator

from handeye.core.optional import require_package

__all__ = ["run_pool"]


class _Named:
    """``fn`` of one task, re-raising a failure with the task named (a note on the exception)."""

    def __init__(self, fn: Callable, describe: Callable[[object], str]):
        self.fn, self.describe = fn, describe

    def __call__(self, task):
        try:
            return self.fn(task)
        except Exception as exc:
            exc.add_note(f"while running task {self.describe(task)}")
            raise


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
        Called once in each worker process with ``initargs`` (in this process when run in it).
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
        The first exception a task raises, of its own type, with the note ``while running task ...`` (its
        ``__notes__``, printed under its traceback); the remaining work is stopped.

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
            pool = multiprocessing.get_context("spawn").Pool(min(workers, len(tasks)), initializer, initargs)
            results = (pool.imap if ordered else pool.imap_unordered)(call, tasks)
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
