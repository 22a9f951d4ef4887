"""No training outlives the watch: a frame that raises (or Ctrl-C) ends the learner before the command does, its
queued offers dropped and reported, a child process's training terminated, the thread's waited for."""

from __future__ import annotations

import multiprocessing
import threading
import time

import pytest

from handeye.commands.watch import _replay
from handeye.watch.learner import BackgroundLearner
from tests.classic.test_markerless import K
from tests.watch.cell_streams import T_BUMPED, KnownAnswer, bumped_frames, watcher
from tests.watch.test_learner import SLOW_TRAINING_S, SPAWN_S, FileGatedCalibrator, SlowCalibrator, reference

#: The thread's training is let end this long after the frame raised (well inside SLOW_TRAINING_S, so a close
#: that did not wait would see it alive).
RELEASE_AFTER_S = 0.3


def _raising(frames):
    """A stream whose second frame is bad."""
    yield frames[0]
    raise ValueError("a bad frame")


def test_a_frame_that_raises_ends_the_learner_thread_and_drops_its_queue(tmp_path, capsys):
    cal = SlowCalibrator()
    learner = BackgroundLearner(cal, reference, K)
    frames = bumped_frames()
    learner(T_BUMPED, frames[:6], 1)  # trains until released
    assert cal.started.wait(SLOW_TRAINING_S)
    learner(T_BUMPED, frames[6:12], 2)  # queued behind it
    threading.Timer(RELEASE_AFTER_S, cal.release.set).start()
    with pytest.raises(ValueError, match="a bad frame"):
        _replay(watcher(tmp_path, KnownAnswer()), _raising(frames), learner)
    assert not learner._worker.is_alive()  # joined before _replay raised on
    assert len(cal.observed) == 1
    out = capsys.readouterr().out.splitlines()  # the reports, printed (and taken) by _replay
    assert out[-3:] == [
        "stopping the learner: queued offers dropped; a training under way in its thread ends first",
        "learner: version 1 observed: translation novel, trained",
        "learner: version 2 not learnt: the watch stopped",
    ]
    learner(T_BUMPED, frames[:6], 3)  # closed: refused, not a new worker
    assert learner.reports[-1] == "learner: version 3 not offered: the learner is closed"


def test_the_streams_end_waits_for_the_queue(tmp_path):
    cal = SlowCalibrator()
    cal.release.set()
    with BackgroundLearner(cal, reference, K) as learner:
        frames = bumped_frames()
        learner(T_BUMPED, frames[:6], 1)
        learner(T_BUMPED, frames[6:12], 2)
    assert not learner._worker.is_alive() and len(cal.observed) == 2


@pytest.mark.slow
def test_a_frame_that_raises_terminates_the_training_child_process(tmp_path, capsys):
    learner = BackgroundLearner(FileGatedCalibrator(tmp_path), reference, K, in_process=True)
    frames = bumped_frames()
    learner(T_BUMPED, frames[:6], 1)
    deadline = time.monotonic() + SPAWN_S
    while not (tmp_path / "started").exists() and time.monotonic() < deadline:  # the child is in observe
        time.sleep(0.1)
    assert (tmp_path / "started").exists() and multiprocessing.active_children()
    with pytest.raises(ValueError, match="a bad frame"):
        _replay(watcher(tmp_path, KnownAnswer()), _raising(frames), learner)
    assert not learner._worker.is_alive() and not multiprocessing.active_children()
    assert capsys.readouterr().out.splitlines()[-1] == "learner: version 1 not learnt: the watch stopped"
    assert not (tmp_path / "release").exists()  # it never ended on its own
