"""A rollback reaches a running watcher: the version another process appends to the history is taken at the next
frame (event "replaced"), published (current JSON, on_commit hooks with no frames) and no longer stale."""

from __future__ import annotations

import json
from types import SimpleNamespace

import numpy as np

from handeye.cli import main
from tests.tolerances import EXACT
from tests.watch.cell_streams import T_BUMPED, KnownAnswer, bumped_frames, watcher
from tests.watch.test_cell import T_TRUE


class Refusing:
    """A ``recalibrate`` that refuses every answer: the calibration stays stale."""

    def __call__(self, frames, T_start, **kwargs):
        return SimpleNamespace(ok=False, refused="test")


def _run(tmp_path, recalibrate, until):
    """A watcher with a current JSON and a hook recorder, fed until ``until(events)``; the frames left."""
    committed = []
    w = watcher(
        tmp_path, recalibrate, current_path=tmp_path / "c.json", on_commit=[lambda T, f, v: committed.append((T, f, v))]
    )
    frames, events = bumped_frames(), []
    while not until(events):
        events += w.feed(frames.pop(0))
    return w, frames, committed


def test_a_rollback_of_a_commit_is_taken_at_the_next_frame(tmp_path, capsys):
    w, frames, committed = _run(tmp_path, KnownAnswer(), lambda ev: any(e.state == "recalibrated" for e in ev))
    np.testing.assert_allclose(w.T_base_cam, T_BUMPED, atol=EXACT)
    assert main(["watch", "rollback", "--history", str(w.history.path), "1"]) == 0
    assert "running on this history takes it at its next frame" in capsys.readouterr().out
    events = w.feed(frames.pop(0))
    assert [e.state for e in events][:1] == ["replaced"] and events[0].version == 3
    assert "rollback to version 1" in events[0].detail and events[0].stale_since is None
    np.testing.assert_allclose(w.T_base_cam, T_TRUE, atol=EXACT)
    assert w.version == 3 and committed[-1][1:] == ([], 3)
    assert json.loads((tmp_path / "c.json").read_text())["version"] == 3
    assert [e.state for e in w.feed(frames.pop(0))] == []  # its own look: taken once


def test_a_rollback_ends_a_stale_calibration(tmp_path):
    w, frames, committed = _run(tmp_path, Refusing(), lambda ev: any(e.state == "refused" for e in ev))
    assert w.stale_since is not None and json.loads((tmp_path / "c.json").read_text())["stale_since"] is not None
    w.history.__class__(w.history.path).rollback(1)  # another process's History
    (event, *_) = w.feed(frames.pop(0))
    assert event.state == "replaced" and event.previous == "refused" and event.stale_since is None
    assert w.stale_since is None and w.version == 2 and w.mode == "relearning"
    doc = json.loads((tmp_path / "c.json").read_text())
    assert doc["version"] == 2 and doc["stale_since"] is None
    assert len(committed) == 1
