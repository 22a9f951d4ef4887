"""tests/watch/conftest.py's check sees a learner's worker thread while it runs and not after ``close``: the check
that fails a test leaving one running can fail."""

from __future__ import annotations

from handeye.watch.learner import BackgroundLearner
from tests.classic.test_markerless import K
from tests.watch.cell_streams import T_BUMPED, bumped_frames
from tests.watch.conftest import learner_threads
from tests.watch.test_learner import SLOW_TRAINING_S, SlowCalibrator, reference


def test_a_learners_worker_is_seen_until_it_is_closed():
    before = learner_threads()
    cal = SlowCalibrator()
    cal.release.set()
    learner = BackgroundLearner(cal, reference, K)
    learner(T_BUMPED, bumped_frames()[:6], 1)
    assert learner.wait(SLOW_TRAINING_S), learner.reports
    assert len(learner_threads() - before) == 1  # idle, waiting for the next offer: still alive
    learner.close()
    assert learner_threads() - before == set()
