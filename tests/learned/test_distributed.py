"""Data-parallel training (``torchrun``, gloo on the CPU) computes what one process computes, and only rank 0 writes.

Two levels:

- one :func:`learned.trainer.train` call on synthetic frames, on 2 ranks (and on 3, where a rank's
  slice of the last batch is empty), started here with torchrun's environment variables, against
  one process: the same gradient of a batch, the same trained parameters, the same predictions, for
  the three network kinds;
- ``torchrun --nproc-per-node 2 -m handeye learned run`` of the ``tiny`` preset against
  ``python -m handeye learned run``: the same errors at every time step, and every file written by
  rank 0 (an audit hook, :func:`sys.addaudithook`, records each process's writes).

Every process runs on one torch thread with CUDA hidden. What may differ is float32 rounding: the
tolerances (:mod:`tests.tolerances`) say how much and why.
"""

from __future__ import annotations

import json
import os
import socket
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

torch = pytest.importorskip("torch")
if not torch.distributed.is_available() or not torch.distributed.is_gloo_available():
    pytest.skip("torch without gloo", allow_module_level=True)

from tests.learned import _distributed_worker as worker  # noqa: E402
from tests.tolerances import (  # noqa: E402
    ABSOLUTE_ONLY,
    DDP_GRADIENT_RTOL,
    DDP_PREDICTION_RTOL,
    DDP_RUN_RTOL,
    DDP_UPDATE_RTOL,
    ZERO_GRADIENT_FRACTION,
)

ROOT = Path(__file__).resolve().parents[2]
TORCHRUN_VARIABLES = ("WORLD_SIZE", "RANK", "LOCAL_RANK", "LOCAL_WORLD_SIZE", "MASTER_ADDR", "MASTER_PORT")


def _env(**extra) -> dict:
    """This environment on the CPU (CUDA hidden: gloo, as in CI), one thread, torchrun's variables as given."""
    env = {k: v for k, v in os.environ.items() if k not in TORCHRUN_VARIABLES}
    return dict(env, CUDA_VISIBLE_DEVICES="", OMP_NUM_THREADS="1", **extra)


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _start(command: list, log: Path, env: dict) -> subprocess.Popen:
    with open(log, "w") as f:  # a file, not a pipe: a full pipe would block a rank inside a collective
        return subprocess.Popen(command, cwd=ROOT, env=env, stdout=f, stderr=subprocess.STDOUT)


def _wait(procs: list, logs: list, timeout: float = 300.0) -> list[str]:
    """Wait for all; if one fails (its partners would wait in a collective) or time runs out, stop the rest."""
    deadline = time.monotonic() + timeout
    while any(p.poll() is None for p in procs):
        failed = any(p.poll() not in (None, 0) for p in procs)
        if failed or time.monotonic() > deadline:
            for p in procs:
                if p.poll() is None:
                    p.kill()
                    p.wait()
            break
        time.sleep(0.05)
    texts = [Path(log).read_text() for log in logs]
    for p, text in zip(procs, texts):
        assert p.returncode == 0, text[-4000:]
    return texts


# ---------------------------------------------------------------------------------------------- one train() call


def _check_kind(kind: str, ref: dict, ranks: list[dict]) -> None:
    for r, other in enumerate(ranks[1:], start=1):
        for key in ref:
            # equal_nan: a keypoint model's residual statistics are NaN until its training has estimated them
            assert np.array_equal(other[key], ranks[0][key], equal_nan=True), (
                f"{kind}: {key} differs between ranks 0 and {r}"
            )
    got = ranks[0]
    grads = {k.removeprefix("grad."): v for k, v in ref.items() if k.startswith("grad.")}
    largest = max(np.abs(g).max() for g in grads.values())
    zero = {name for name, g in grads.items() if np.abs(g).max() <= ZERO_GRADIENT_FRACTION * largest}
    assert zero, f"{kind}: every model here has biases before batch norm (gradient 0)"
    for name, g in grads.items():
        scale = largest if name in zero else np.abs(g).max()
        np.testing.assert_allclose(
            got[f"grad.{name}"], g, rtol=ABSOLUTE_ONLY, atol=DDP_GRADIENT_RTOL * scale, err_msg=kind
        )
    for key, value in ref.items():
        name = key.removeprefix("state.")
        if key.startswith("state.") and (name in grads and name not in zero or name.endswith("running_var")):
            change = np.linalg.norm(value - ref[f"init.{name}"])
            assert np.linalg.norm(got[key] - value) <= DDP_UPDATE_RTOL * change, f"{kind} {name}"
        elif name.endswith("num_batches_tracked"):
            assert got[key] == value, f"{kind} {name}"
    pred, want = got["pred"], ref["pred"]
    if kind == "orientation":  # q and -q are the same rotation
        diff = np.minimum(np.linalg.norm(pred - want, axis=-1), np.linalg.norm(pred + want, axis=-1))
    else:
        diff = np.abs(pred - want)
    assert diff.max() <= DDP_PREDICTION_RTOL * np.abs(want).max(), f"{kind}: predictions differ by {diff.max()}"


@pytest.mark.parametrize(
    "world, batch",
    [
        (2, worker.BATCH),  # batches of 10, 10, 4: slices of 5 and 2
        # batches of 11, 11, 2: slices of 4, 4, 3 and 1, 1 and an empty one; 14 s, the slow tier (CI)
        pytest.param(3, 11, marks=pytest.mark.slow),
    ],
)
def test_one_training_call_on_several_ranks_is_the_one_process_call(tmp_path, world, batch):
    port = _free_port()
    command = [sys.executable, "-m", "tests.learned._distributed_worker", str(tmp_path), str(batch)]
    logs = [tmp_path / f"rank{r}.log" for r in range(world)]
    env = dict(WORLD_SIZE=str(world), LOCAL_WORLD_SIZE=str(world), MASTER_ADDR="127.0.0.1", MASTER_PORT=str(port))
    procs = [_start(command, logs[r], _env(RANK=str(r), LOCAL_RANK=str(r), **env)) for r in range(world)]
    reference = {}
    threads = torch.get_num_threads()
    torch.set_num_threads(1)
    try:  # meanwhile the one-process reference, here
        (tmp_path / "single").mkdir()
        for kind in worker.KINDS:
            worker.run(tmp_path / "single", kind, batch)
            reference[kind] = dict(np.load(tmp_path / "single" / f"{kind}.rank0.npz"))
    finally:
        torch.set_num_threads(threads)
    _wait(procs, logs)
    for kind in worker.KINDS:
        ranks = [dict(np.load(tmp_path / f"{kind}.rank{r}.npz")) for r in range(world)]
        _check_kind(kind, reference[kind], ranks)


# ---------------------------------------------------------------------------------------------- the command line

#: Loaded by every Python process started with its directory on PYTHONPATH: records the files each
#: process creates, replaces or removes under ``HANDEYE_WATCH`` into ``HANDEYE_WRITES.<RANK>``.
SITECUSTOMIZE = """
import atexit, os, sys
if os.environ.get("HANDEYE_WATCH"):
    _watch, _writes = os.environ["HANDEYE_WATCH"], []
    _flags = os.O_WRONLY | os.O_RDWR | os.O_CREAT | os.O_APPEND | os.O_TRUNC

    def _hook(event, args):
        if event == "open" and isinstance(args[0], (str, bytes, os.PathLike)):
            mode, flags = args[1] or "", args[2] or 0
            if any(c in mode for c in "wax+") or flags & _flags:
                _writes.append(os.fsdecode(args[0]))
        elif event in ("os.rename", "os.remove", "os.mkdir"):
            _writes.append(os.fsdecode(args[1] if event == "os.rename" else args[0]))

    def _save():
        with open(os.environ["HANDEYE_WRITES"] + "." + os.environ.get("RANK", "agent"), "w") as f:
            f.write("\\n".join(w for w in _writes if w.startswith(_watch)))

    sys.addaudithook(_hook)
    atexit.register(_save)
"""


def _comparable(out: Path) -> dict:
    results = json.loads((out / "results.json").read_text())
    return {
        "runs": {(r["strategy"], r["network"]): r for r in results["runs"]},
        "summary": results["summary"],
        "world_size": results["world_size"],
    }


@pytest.mark.slow  # the tiny preset in three processes (one, then two ranks): 35 s of the default run; the
# one-training-call test beside it runs on several ranks in the default run
def test_tiny_preset_on_two_processes_matches_one_and_only_rank_0_writes(small_dataset, tmp_path):
    args = ["learned", "run", "--data", str(small_dataset[0]), "--preset", "tiny", "--quiet", "--threads", "1"]
    one, two = tmp_path / "one", tmp_path / "two"
    site = tmp_path / "site"
    site.mkdir()
    (site / "sitecustomize.py").write_text(SITECUSTOMIZE)
    path = os.pathsep.join([str(site), os.environ.get("PYTHONPATH", "")])
    watched = _env(PYTHONPATH=path, HANDEYE_WATCH=str(two), HANDEYE_WRITES=str(tmp_path / "writes"))
    torchrun = [sys.executable, "-m", "torch.distributed.run", "--standalone", "--nproc-per-node", "2"]
    logs = [tmp_path / "one.log", tmp_path / "two.log"]
    procs = [
        _start([sys.executable, "-m", "handeye", *args, "--out", str(one)], logs[0], _env()),
        _start([*torchrun, "-m", "handeye", *args, "--out", str(two)], logs[1], watched),
    ]
    _, text = _wait(procs, logs)
    assert text.count("data-parallel training: 2 processes, backend gloo") == 1
    assert text.count("written: ") == 1  # rank 0 alone prints the findings

    writes = {r: (tmp_path / f"writes.{r}").read_text().split() for r in range(2)}
    assert writes[1] == [], f"rank 1 wrote {writes[1]}"
    written = {Path(p).relative_to(two).as_posix() for p in writes[0]}
    assert {"results.json", "checkpoint.pt", "reservoir/translation.pt", "selection/orientation.pt"} <= written

    a, b = _comparable(one), _comparable(two)
    assert (a["world_size"], b["world_size"]) == (1, 2)
    assert a["runs"].keys() == b["runs"].keys()
    for key, run in a["runs"].items():
        other = b["runs"][key]
        for field in ("processed", "stored", "evaluated", "skipped"):  # the protocol's decisions: identical
            assert run[field] == other[field], (key, field)
        np.testing.assert_allclose(other["matrix"], run["matrix"], rtol=DDP_RUN_RTOL, err_msg=str(key))
    for strategy, networks in a["summary"].items():
        for network, summary in networks.items():
            for stat in ("mean", "median", "rmse"):
                got = b["summary"][strategy][network][stat]
                np.testing.assert_allclose(got, summary[stat], rtol=DDP_RUN_RTOL, err_msg=f"{strategy} {network}")
