"""One render per test run: a session fixture's dataset built once and shared by pytest-xdist's workers.

A session fixture is built once per process; under ``-n 2`` each worker that needs the ``small`` preset
rendered its own (34 s of two cores each), and every documentation block (a work unit of its own) on another
worker rendered and trained the paper-sim stand-in again. :func:`shared_build` builds under a lock in the
temporary folder the run's workers share (pytest's base temporary folder's parent on a worker, the base
folder itself without xdist: never one of an earlier run), and the others wait for it and reuse it. What is
built is read-only for the tests, as a session fixture's data was already.
"""

from __future__ import annotations

import fcntl
import os
import pickle
import shutil
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

from handeye.core.safe_write import write_bytes_atomic

#: Written last into a finished build, whole or not at all, with the builder's value pickled: a folder without
#: it is a build that was interrupted (its worker crashed), removed and built again.
DONE = "shared-build.pickle"


def shared_folder(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The temporary folder this run's processes share: the base folder's parent on an xdist worker (each
    worker's base is ``popen-gwN`` inside the run's own ``pytest-N``), the base folder itself otherwise."""
    base = tmp_path_factory.getbasetemp()
    return base.parent if os.environ.get("PYTEST_XDIST_WORKER") else base


def shared_build(tmp_path_factory: pytest.TempPathFactory, key: str, build: Callable[[Path], Any]) -> tuple[Path, Any]:
    """``build(folder)`` once per run for ``key``; every process gets ``folder`` and build's (picklable) value.

    Parameters
    ----------
    tmp_path_factory : pytest.TempPathFactory
    key : str
        Names the build: one folder and one lock per key.
    build : callable
        Fills the empty ``folder`` it is given and returns a picklable value (paths inside ``folder`` stay
        valid: the folder is not moved afterwards).

    Returns
    -------
    folder : Path
    value : object
        ``build``'s return value, as the process that built it returned it.
    """
    root = shared_folder(tmp_path_factory) / "shared-builds"
    root.mkdir(exist_ok=True)
    folder = root / key
    with open(root / f"{key}.lock", "a") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)  # released when the file closes
        done = folder / DONE
        if not done.is_file():
            shutil.rmtree(folder, ignore_errors=True)
            folder.mkdir()
            value = build(folder)
            write_bytes_atomic(done, pickle.dumps(value))  # a crash mid-write leaves no half marker
        return folder, pickle.loads(done.read_bytes())
