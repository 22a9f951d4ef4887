"""A ``handeye learned run`` killed with SIGKILL mid-training resumes and ends identical to an uninterrupted run.

Exact equality (wall times and inference timings aside): each process runs on one torch thread, the
same operations in the same order on the CPU, with every random state (numpy generators, torch's
global generator) restored from the checkpoint, so nothing is left to differ.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time

import pytest

pytest.importorskip("torch")

from handeye.core.errors import HandEyeInputError  # noqa: E402
from learned.checkpoint import CHECKPOINT_NAME, load_checkpoint, save_checkpoint  # noqa: E402

RUN = "from handeye.cli import main; import sys; sys.exit(main(sys.argv[1:]))"


def _command(root, out):
    return [
        sys.executable,
        "-c",
        RUN,
        "learned",
        "run",
        "--data",
        str(root),
        "--preset",
        "tiny",
        "--out",
        str(out),
        "--threads",
        "1",
    ]


def _comparable(out):
    results = json.loads((out / "results.json").read_text())
    results.pop("inference")  # timings
    for run in results["runs"]:
        run.pop("wall_s")
    return results


def _kill_when(command, env, out, ready):
    """Start ``command``; SIGKILL it as soon as ``<out>/checkpoint.pt`` satisfies ``ready``."""
    from learned.safe_io import SavedFileError, load_document

    proc = subprocess.Popen(command, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    deadline, seen = time.monotonic() + 300, None
    while proc.poll() is None and time.monotonic() < deadline:
        path = out / CHECKPOINT_NAME
        try:
            stamp = path.stat().st_mtime_ns
            if stamp != seen:
                seen = stamp
                if ready(load_document(path, "checkpoint", 1)):
                    break
        except (FileNotFoundError, SavedFileError):
            pass
        time.sleep(0.005)
    proc.send_signal(signal.SIGKILL)
    proc.wait(timeout=60)
    assert proc.returncode == -signal.SIGKILL, "the run ended before it could be killed"
    assert (out / CHECKPOINT_NAME).is_file() and not (out / "results.json").exists()


@pytest.mark.slow  # three tiny-preset runs in subprocesses, two killed: 38 s of the default run; CI's run has it
def test_a_killed_run_resumes_to_the_uninterrupted_results(small_dataset, tmp_path):
    root = small_dataset[0]
    env = dict(os.environ, OMP_NUM_THREADS="1")
    whole, killed = tmp_path / "whole", tmp_path / "killed"
    subprocess.run(_command(root, whole) + ["--quiet"], check=True, env=env, capture_output=True, timeout=600)
    assert not (whole / CHECKPOINT_NAME).exists()  # removed once results.json is written

    # killed once after the first checkpoint (batch, mid-unit), then again mid-unit of a strategy with a
    # buffer (reservoir or later: weights, buffer, generator and partial record all restored)
    _kill_when(_command(root, killed) + ["--quiet"], env, killed, lambda doc: True)
    _kill_when(_command(root, killed) + ["--quiet"], env, killed, lambda doc: doc["unit"] >= 4 and "strategy" in doc)
    again = subprocess.run(_command(root, killed), env=env, capture_output=True, text=True, timeout=600)
    assert again.returncode == 0, again.stderr[-2000:]
    assert "resuming from" in again.stderr
    assert _comparable(killed) == _comparable(whole)


def test_a_checkpoint_of_another_run_is_refused(tmp_path):
    save_checkpoint(tmp_path, {"seed": 0, "preset": {"name": "tiny"}}, 1, 0, [])
    assert load_checkpoint(tmp_path, {"seed": 0, "preset": {"name": "tiny"}})["unit"] == 1
    with pytest.raises(HandEyeInputError, match="checkpoint of another run \\(differs in seed\\).*--fresh"):
        load_checkpoint(tmp_path, {"seed": 1, "preset": {"name": "tiny"}})
    assert load_checkpoint(tmp_path / "none", {"seed": 0}) is None
