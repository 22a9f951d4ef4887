"""The calibration history: append-only, every committed version survives a kill -9 at any byte."""

from __future__ import annotations

import json
import os
import signal
import time
import warnings

import numpy as np
import pytest

from handeye.core.errors import HandEyeInputError
from handeye.core.se3 import make_transform, so3_exp
from handeye.watch.history import History, TornLineWarning
from tests.tolerances import ABSOLUTE_ONLY, FLOAT


def pose_of(version: int) -> np.ndarray:
    """A distinct, reproducible T_base_cam per version number (the writer below uses the same)."""
    return make_transform(so3_exp(np.array([0.01, 0.02, 0.03]) * version), [0.001 * version, 0.5, 1.0])


def _writer(path, current, out_fd: int) -> None:
    """The forked writer: append versions forever, reporting each number after its commit (never returns)."""
    try:
        h = History(path, current)
        while True:
            latest = h.latest()
            n = 1 if latest is None else latest.version + 1
            h.append(pose_of(n), "test", sigma=np.full(6, 1e-3), frames=range(n))
            os.write(out_fd, f"{n}\n".encode())
    finally:
        os._exit(1)


def _check_complete(h: History, at_least: int) -> int:
    versions = h.versions()
    assert [v.version for v in versions] == list(range(1, len(versions) + 1))
    for v in versions:
        np.testing.assert_allclose(v.T_base_cam, pose_of(v.version), atol=FLOAT, rtol=ABSOLUTE_ONLY)
        assert v.frames == tuple(range(v.version))
    assert len(versions) >= at_least
    return len(versions)


def test_a_writer_killed_at_random_moments_loses_no_committed_version(tmp_path):
    """SIGKILL a writer 12 times mid-stream: every version it reported (after its fsync) is there and complete."""
    rng = np.random.default_rng(0)
    path, current = tmp_path / "history.jsonl", tmp_path / "current.json"
    acknowledged = 0
    for _ in range(12):
        r, w = os.pipe()
        pid = os.fork()  # no new interpreter: a kill per few milliseconds of writing
        if pid == 0:
            os.close(r)
            _writer(path, current, w)
        os.close(w)
        with os.fdopen(r, "rb") as pipe:
            first = pipe.readline()  # the writer is running and has committed one version
            time.sleep(rng.uniform(0.0, 0.05))
            os.kill(pid, signal.SIGKILL)
            os.waitpid(pid, 0)
            out = first + pipe.read()
        numbers = [int(w) for w in out.split()]
        acknowledged = max([acknowledged, *numbers])
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", TornLineWarning)  # the kill may or may not have cut a line
            n = _check_complete(History(path), acknowledged)
        assert n >= acknowledged
    doc = json.loads(current.read_text())
    assert doc["version"] >= acknowledged - 1  # published after the commit: at most the last one behind


def test_a_torn_last_line_at_every_byte_is_ignored_with_a_warning_then_cut(tmp_path):
    path = tmp_path / "history.jsonl"
    h = History(path)
    for n in range(1, 5):
        h.append(pose_of(n), "test", frames=range(n))
    data = path.read_bytes()
    start = data.rstrip(b"\n").rfind(b"\n") + 1  # the last line's first byte
    for cut in range(start, len(data)):
        path.write_bytes(data[:cut])
        if cut > start:
            with pytest.warns(TornLineWarning, match="never committed"):
                assert _check_complete(History(path), 3) == 3
        else:
            assert _check_complete(History(path), 3) == 3
    # the next append cuts the torn tail first and continues the numbering
    path.write_bytes(data[: len(data) - 7])
    with pytest.warns(TornLineWarning):
        v = History(path).append(pose_of(4), "test", frames=range(4))
    assert v.version == 4 and v.replaces == 3
    assert path.read_bytes().startswith(data[:start]) and path.read_bytes().endswith(b"}\n")
    assert _check_complete(History(path), 4) == 4


def test_rollback_appends_and_the_current_file_follows(tmp_path):
    h = History(tmp_path / "h.jsonl", tmp_path / "current.json")
    for n in range(1, 4):
        h.append(pose_of(n), "test", sigma=np.full(6, n * 1e-3))
    before = (tmp_path / "h.jsonl").read_bytes()
    v = h.rollback(1)
    assert (v.version, v.replaces, v.reason) == (4, 3, "rollback to version 1")
    np.testing.assert_array_equal(v.T_base_cam, pose_of(1))
    assert (tmp_path / "h.jsonl").read_bytes().startswith(before)  # nothing rewritten
    assert json.loads((tmp_path / "current.json").read_text())["version"] == 4
    with pytest.raises(HandEyeInputError, match="no version 9 .versions: 1..4"):
        h.rollback(9)


def test_a_corrupt_complete_line_is_an_error_not_a_torn_write(tmp_path):
    path = tmp_path / "h.jsonl"
    h = History(path)
    h.append(pose_of(1), "test")
    h.append(pose_of(2), "test")
    lines = path.read_bytes().splitlines(keepends=True)
    path.write_bytes(lines[0][:20] + b"\n" + lines[1])
    with pytest.raises(HandEyeInputError, match="line 1: not JSON"):
        History(path).versions()
    path.write_bytes(lines[0] + lines[1][:20] + b"\n")  # the last complete line, read by append
    with pytest.raises(HandEyeInputError, match="line 2: not JSON"):
        History(path).append(pose_of(3), "test")


@pytest.mark.parametrize("kind", ["device link", "fifo"])
def test_a_history_that_is_not_a_regular_file_is_refused(tmp_path, kind):
    """A link to /dev/null would swallow every committed version; a FIFO would block the read for ever."""
    path = tmp_path / "h.jsonl"
    if kind == "fifo":
        os.mkfifo(path)
    else:
        path.symlink_to(os.devnull)
    with pytest.raises(HandEyeInputError, match="not a regular file"):
        History(path).append(pose_of(1), "test")
    with pytest.raises(HandEyeInputError, match="not a regular file"):
        History(path).latest()


def _appender(path, current, count: int) -> None:
    """A forked writer: append ``count`` versions as fast as it can, then exit (never returns)."""
    try:
        h = History(path, current)
        for _ in range(count):
            h.append(pose_of(1), "concurrent")
        os._exit(0)
    finally:
        os._exit(1)


def test_two_writers_appending_at_once_number_every_version_once(tmp_path):
    """Two processes appending 40 versions each: versions 1..80, each replacing the one before, and the current
    file naming the last (the read of the last version and the append are one step under the history's lock)."""
    path, current = tmp_path / "h.jsonl", tmp_path / "current.json"
    pids = []
    for _ in range(2):
        pid = os.fork()
        if pid == 0:
            _appender(path, current, 40)
        pids.append(pid)
    assert all(os.WEXITSTATUS(os.waitpid(pid, 0)[1]) == 0 for pid in pids)
    versions = History(path).versions()
    assert [v.version for v in versions] == list(range(1, 81))
    assert [v.replaces for v in versions] == [None, *range(1, 80)]
    assert json.loads(current.read_text())["version"] == 80


def test_a_rollback_keeps_the_versions_extra(tmp_path):
    """The rolled-back version's extra (a commit's full sigma and depth correction) comes with it: it was dropped,
    so after a rollback the current file had only the noise part of the sigma (module docstring)."""
    h = History(tmp_path / "h.jsonl", tmp_path / "current.json")
    extra = {"sigma_summary": {"rotation_deg": 0.05, "translation_mm": 1.2}, "depth_correction_k_c_m": [1.001, -0.002]}
    h.append(pose_of(1), "commit", np.full(6, 1e-3), (0, 1), extra=extra)
    h.append(pose_of(2), "commit")
    v = h.rollback(1)
    assert v.extra == extra and h.latest().extra == extra
    assert json.loads((tmp_path / "current.json").read_text())["extra"] == extra
