"""Choose where tasks run: this machine's process pool (default) or a Ray cluster.

:func:`run_tasks` is what the generator and the labeller call; ``engine``
and ``address`` come from the command line (``--engine ray --address ADDR``).
"""

from __future__ import annotations

import socket
from collections.abc import Callable, Iterable, Iterator
from pathlib import Path

from handeye.core.errors import DatasetError, HandEyeInputError
from handeye.core.numbers import cli_int
from handeye.core.optional import require_package

__all__ = ["ENGINES", "DEFAULT_WORKERS", "run_tasks", "check_engine", "require_visible", "add_engine_arguments"]

ENGINES = ("pool", "ray")
#: Processes of the local pool (and CPUs of a local Ray cluster) when not given.
DEFAULT_WORKERS = 2


def check_engine(engine: str, address: str | None = None, workers: int | None = None) -> None:
    """Refuse an unknown engine, an ``address`` without Ray, ``workers < 1`` or a missing Ray, naming the fix.

    Raises
    ------
    HandEyeInputError
    MissingDependencyError
        The Ray engine without Ray installed.
    """
    if engine not in ENGINES:
        raise HandEyeInputError(f"unknown engine {engine!r}: use one of {', '.join(ENGINES)}")
    if address is not None and engine != "ray":
        raise HandEyeInputError(f"an address ({address}) is for the Ray engine: add --engine ray")
    if workers is not None and workers < 1:
        raise HandEyeInputError(f"workers must be >= 1, got {workers}")
    if engine == "ray":  # before any output is written
        require_package("ray", extra="cluster", purpose="the Ray engine")


def add_engine_arguments(parser, what: str) -> None:
    """``--workers``, ``--engine`` and ``--address`` of a command whose tasks may run on Ray."""
    parser.add_argument(
        "--workers",
        type=cli_int,
        default=None,
        help=f"{what} processes, or Ray tasks in flight (default {DEFAULT_WORKERS}; every CPU of a cluster "
        "given by --address)",
    )
    parser.add_argument(
        "--engine",
        default="pool",
        choices=ENGINES,
        help="pool: processes on this machine (default); ray: a Ray cluster (pip install 'handeye[cluster]'), "
        "tasks retried when a worker dies",
    )
    parser.add_argument(
        "--address",
        default=None,
        help="a running Ray cluster: auto, HOST:6379 or ray://HOST:10001 (default: start a local one); the dataset "
        "folder must be shared by every node",
    )


def require_visible(path: str | Path) -> Path:
    """``path`` (a file a worker needs), or a :class:`DatasetError` saying the folder is not shared.

    A Ray worker on another machine sees only what its own file system holds: the dataset folder must be
    shared by every node, at the same path.
    """
    path = Path(path)
    if not path.exists():
        raise DatasetError(
            f"{path}: not visible on host {socket.gethostname()}; on a cluster of several machines the dataset "
            "folder must be shared by every node at the same path (NFS, or a bucket mounted with s3fs/gcsfuse)"
        )
    return path


def run_tasks(
    fn: Callable,
    tasks: Iterable,
    engine: str = "pool",
    workers: int | None = None,
    address: str | None = None,
    progress: bool = True,
    desc: str = "",
    unit: str = "task",
    ordered: bool = False,
    initializer: Callable | None = None,
    initargs: tuple = (),
    isolate: bool = False,
    describe: Callable[[object], str] = repr,
) -> Iterator:
    """Yield ``fn(task)`` for every task, on the chosen engine.

    Parameters
    ----------
    fn, tasks, progress, desc, unit, ordered, initializer, initargs, describe
        As :func:`handeye.core.pool.run_pool`.
    engine : {"pool", "ray"}
        ``pool``: spawned processes on this machine; ``ray``: :func:`handeye.core.ray_pool.run_ray`.
    workers : int, optional
        Processes (pool), or tasks in flight (Ray); None: :data:`DEFAULT_WORKERS`, or all the CPUs of a Ray
        cluster given by ``address``.
    address : str, optional
        A running Ray cluster (Ray engine only); None starts a local one.
    isolate : bool
        Pool only: run in a worker process even with one worker (Ray tasks always run in workers).

    Yields
    ------
    object
        ``fn(task)``.

    Raises
    ------
    HandEyeInputError
        A bad engine, address or worker count.
    """
    check_engine(engine, address, workers)
    if engine == "ray":
        from handeye.core.ray_pool import run_ray

        n = workers if workers is not None or address is not None else DEFAULT_WORKERS
        yield from run_ray(fn, tasks, n, address, progress, desc, unit, ordered, initializer, initargs, describe)
        return
    from handeye.core.pool import run_pool

    n = DEFAULT_WORKERS if workers is None else workers
    yield from run_pool(fn, tasks, n, progress, desc, unit, ordered, initializer, initargs, isolate, describe)
