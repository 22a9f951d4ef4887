"""What every task engine shares: the settings of a run (:class:`EngineOptions`) and the one method (:class:`Engine`).

Two engines keep the contract: :class:`handeye.core.pool.PoolEngine` (spawned processes on this machine) and
:class:`handeye.core.ray_pool.RayEngine` (a Ray cluster); :func:`handeye.core.engines.run_tasks` chooses one
by name, from the command line.
"""

from __future__ import annotations

import sys
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass
from typing import Protocol

from handeye.core.errors import HandEyeInputError
from handeye.core.optional import require_package

__all__ = ["DEFAULT_WORKERS", "EngineOptions", "Engine"]

#: Processes of the local pool (and CPUs of a local Ray cluster) when not given.
DEFAULT_WORKERS = 2


@dataclass(frozen=True, kw_only=True)
class EngineOptions:
    """How a function runs over tasks, whichever engine runs it.

    Attributes
    ----------
    workers : int, optional
        Processes (pool), or tasks in flight (Ray); at least 1. None: :data:`DEFAULT_WORKERS`, or every CPU
        of a running Ray cluster (:class:`handeye.core.ray_pool.RayEngine` with an address).
    progress : bool
        A progress bar on stderr (``tqdm``: ``pip install "handeye[sim]"``).
    desc, unit : str
        The progress bar's label and unit.
    ordered : bool
        Results in the order of the tasks; False (default) yields each as it completes.
    initializer : callable, optional
        Module-level; called once in each worker process with ``initargs`` before its first task (in this
        process when the pool runs here).
    initargs : tuple
        Picklable arguments of ``initializer``.
    describe : callable
        Names a task in the message of its failure (module-level, picklable); default ``repr``.
    isolate : bool
        Never run in this process, even with one worker (work that must not touch this process's state, such
        as an OpenGL context); Ray tasks always run in worker processes.

    Raises
    ------
    HandEyeInputError
        ``workers < 1``.
    """

    workers: int | None = None
    progress: bool = True
    desc: str = ""
    unit: str = "task"
    ordered: bool = False
    initializer: Callable | None = None
    initargs: tuple = ()
    describe: Callable[[object], str] = repr
    isolate: bool = False

    def __post_init__(self) -> None:
        if self.workers is not None and self.workers < 1:
            raise HandEyeInputError(f"workers must be >= 1, got {self.workers}")

    def progress_bar(self, total: int):
        """A ``tqdm`` bar of ``total`` tasks on stderr, or None without ``progress``."""
        if not self.progress:
            return None
        tqdm = require_package("tqdm", extra="sim", purpose="a progress bar").tqdm
        return tqdm(total=total, desc=self.desc, unit=self.unit, file=sys.stderr)


class Engine(Protocol):
    """Where tasks run: this machine's processes or a cluster."""

    def run(self, fn: Callable, tasks: Iterable, options: EngineOptions) -> Iterator:
        """Yield ``fn(task)`` for every task (in task order when ``options.ordered``, else as completed).

        Parameters
        ----------
        fn : callable
            A module-level function of one task.
        tasks : iterable
            The tasks (each picklable, small: paths and ids, not images).
        options : EngineOptions
            How they run.

        Yields
        ------
        object
            ``fn(task)``.

        Raises
        ------
        Exception
            The first exception a task (or a worker's initializer) raises, of its own type, with the note
            ``while running task ...`` (its ``__notes__``); the remaining work is stopped.
        """
        ...
