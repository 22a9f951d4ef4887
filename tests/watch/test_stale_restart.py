"""A watcher restarted on a history whose current JSON says its latest version is stale (an earlier run's 'moved'):
the status never says valid about it, nothing is put on tf, and the watcher recalibrates before calling any
pose valid; a JSON about an older version, or none, is not taken as the latest's state; an unreadable one is
refused. The tf side through ``handeye watch --ros2`` against the fake rclpy of tests/watch/test_ros2.py."""

from __future__ import annotations

import json

import numpy as np
import pytest

from handeye.cli import main
from handeye.core.errors import HandEyeInputError
from handeye.watch import History
from tests.tolerances import EXACT
from tests.watch.cell_streams import BUMP_AT, RECAL_FRAMES, T_BUMPED, KnownAnswer, bumped_frames, watcher
from tests.watch.test_cell import T_TRUE
from tests.watch.test_rollback_running import Refusing
from tests.watch.test_ros2 import TOPICS, _info, fake_ros
from tests.watch.test_tf_stale_and_parent import _statuses


def _stale_record(tmp_path) -> float:
    """An earlier run that found version 1 off and could not recalibrate: its stale_since."""
    w = watcher(tmp_path, Refusing(), current_path=tmp_path / "c.json")
    frames, events = bumped_frames(), []
    while not any(e.state == "refused" for e in events):
        events += w.feed(frames.pop(0))
    assert w.version == 1 and w.stale_since is not None
    return w.stale_since


def _current(tmp_path) -> dict:
    return json.loads((tmp_path / "c.json").read_text())


def test_a_restarted_watcher_recalibrates_a_version_the_record_says_is_stale(tmp_path):
    stale_since = _stale_record(tmp_path)
    recalibrate = KnownAnswer()
    w = watcher(tmp_path, recalibrate, current_path=tmp_path / "c.json")  # the same start: version 1, stale
    assert w.version == 1 and w.stale_since == stale_since
    assert _current(tmp_path)["stale_since"] == stale_since  # the start leaves the record as it was
    events = [e for f in bumped_frames()[BUMP_AT:] for e in w.feed(f)]
    first = events[0]
    assert first.state == "moved" and first.stale_since == stale_since and "earlier run" in first.detail
    (recal,) = [k for k, e in enumerate(events) if e.state == "recalibrated"]
    # nothing before the validated answer calls the pose fine, nor learns a null on it
    assert all(e.stale_since == stale_since and e.state not in ("ok", "learning") for e in events[:recal])
    assert len(recalibrate.calls) == 1 and len(recalibrate.calls[0]["frames"]) == RECAL_FRAMES
    np.testing.assert_allclose(recalibrate.calls[0]["T_start"], T_TRUE, atol=EXACT)  # from the stale version
    assert w.version == 2 and w.stale_since is None
    doc = _current(tmp_path)
    assert doc["version"] == 2 and doc["stale_since"] is None and "earlier run" in doc["reason"]


def test_a_json_about_an_older_version_says_nothing_about_the_latest(tmp_path):
    _stale_record(tmp_path)
    History(tmp_path / "h.jsonl").rollback(1)  # a process without --current: the JSON still says version 1 stale
    w = watcher(tmp_path, KnownAnswer(), current_path=tmp_path / "c.json")
    assert w.version == 2 and w.stale_since is None and w.mode == "learning"
    doc = _current(tmp_path)  # written anew from the history
    assert doc["version"] == 2 and doc["stale_since"] is None


@pytest.mark.parametrize("text", ["{", "[1]", '{"version": 1, "stale_since": "soon"}'])
def test_an_unreadable_current_json_is_refused_not_taken_as_valid(tmp_path, text):
    h = History(tmp_path / "h.jsonl", tmp_path / "c.json")
    h.append(T_TRUE, "start")
    (tmp_path / "c.json").write_text(text)
    with pytest.raises(HandEyeInputError, match="whether version 1 is stale cannot be told"):
        watcher(tmp_path, KnownAnswer(), current_path=tmp_path / "c.json")


def test_a_current_json_from_before_stale_since_was_recorded_is_not_stale(tmp_path):
    h = History(tmp_path / "h.jsonl", tmp_path / "c.json")
    h.append(T_TRUE, "start")
    doc = _current(tmp_path)
    del doc["stale_since"]
    (tmp_path / "c.json").write_text(json.dumps(doc))
    w = watcher(tmp_path, KnownAnswer(), current_path=tmp_path / "c.json")
    assert w.version == 1 and w.stale_since is None and w.mode == "learning"
    assert _current(tmp_path)["stale_since"] is None  # written anew from the history, with the field


@pytest.mark.parametrize("stale", [True, False])
def test_the_status_topic_at_start_says_what_the_record_says(tmp_path, monkeypatch, capsys, stale):
    """``handeye watch --ros2`` started on a record: camera_info, then the topics end (no frame)."""
    calls = fake_ros(monkeypatch, [(TOPICS.info, _info(0.0))])
    h = History(tmp_path / "h.jsonl", tmp_path / "c.json")
    h.append(T_BUMPED, "start")
    if stale:
        h.mark_stale(12.5)
    args = ["watch", "--ros2", "--sensor", "ideal", "--history", str(h.path), "--current", str(h.current_path)]
    assert main([*args, "--camera-frame", "cam"]) == 0
    out = capsys.readouterr().out
    sent = [c for c in calls if c[0] == "sendTransform"]
    (status,) = _statuses(calls)
    if stale:
        assert not sent  # a pose known off is not put on tf
        assert status["calibration"] == "stale" and status["stale_since"] == 12.5 and status["version"] == 1
        assert "calibration stale since 12.500s" in out
    else:
        assert len(sent) == 1 and status["calibration"] == "valid" and status["stale_since"] is None
    assert _current(tmp_path)["stale_since"] == (12.5 if stale else None)
