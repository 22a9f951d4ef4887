"""Choose where tasks run: this machine's process pool (default) or a Ray cluster.

:func:`run_tasks` is what the generator and the labeller call; ``engine``
and ``address`` come from the command line (``--engine ray --address ADDR``).
"""

from __future__ import annotations

import socket
from collections.abc import Callable, Iterable, Iterator
from pathlib import Path

from handeye.core.engine_protocol import DEFAULT_WORKERS, Engine, EngineOptions
from handeye.core.errors import DatasetError, HandEyeInputError
from handeye.core.numbers import cli_int
from handeye.core.optional import require_package
from handeye.core.pool import PoolEngine
from handeye.core.ray_pool import RayEngine

__all__ = [
    "ENGINES",
    "DEFAULT_WORKERS",
    "EngineOptions",
    "run_tasks",
    "check_engine",
    "require_visible",
    "add_engine_arguments",
]

ENGINES = ("pool", "ray")


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
    options: EngineOptions = EngineOptions(),
    engine: str = "pool",
    address: str | None = None,
) -> Iterator:
    """Yield ``fn(task)`` for every task, on the engine named ``engine`` (at ``address``).

    Parameters
    ----------
    fn, tasks, options
        As :meth:`Engine.run <handeye.core.engine_protocol.Engine.run>`, which says what is yielded and
        raised: the same for either engine.
    engine : {"pool", "ray"}
        ``pool``: spawned processes on this machine (:class:`~handeye.core.pool.PoolEngine`); ``ray``: a Ray
        cluster (:class:`~handeye.core.ray_pool.RayEngine`).
    address : str, optional
        A running Ray cluster (Ray engine only); None starts a local one.

    Raises
    ------
    HandEyeInputError
        A bad engine or address (a bad worker count is refused by :class:`EngineOptions`).
    """
    check_engine(engine, address)
    chosen: Engine = RayEngine(address) if engine == "ray" else PoolEngine()
    yield from chosen.run(fn, tasks, options)
