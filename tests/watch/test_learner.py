"""The continual learner beside the watcher: each commit offered in the background, never delaying the check;
its prediction an extra start of the recalibration; the real ContinualCalibrator takes what it is given."""

from __future__ import annotations

import threading
import time
from types import SimpleNamespace

import numpy as np
import pytest

from handeye.core.se3 import make_transform, so3_exp
from handeye.watch.learner import BackgroundLearner, frame_set
from tests.classic.test_markerless import K
from tests.tolerances import EXACT, FLOAT32_RTOL
from tests.watch.cell_streams import RECAL_FRAMES, T_BUMPED, KnownAnswer, bumped_frames, watcher

#: How long the slow fake trains at most (it waits for the test to let it end): a synchronous learner would hold
#: feed() this long and the test would see its training finished before feed() returned.
SLOW_TRAINING_S = 5.0
#: Time a spawned process takes to start and import the project (seconds; generous on a loaded machine).
SPAWN_S = 120.0
T_LEARNED = make_transform(so3_exp([0.0, 0.02, 0.0]), [0.5, -0.4, 0.8])
IMAGE_SIZE = (16, 12)


def reference(q):
    """A stand-in for the robot's fk_ref: the first three joint values as the reference's position."""
    q = np.atleast_2d(q)
    out = np.tile(np.eye(4), (len(q), 1, 1))
    out[:, :3, 3] = q[:, :3]
    return out


class SlowCalibrator:
    """Records observe's frames; observe blocks until ``release`` (at most SLOW_TRAINING_S), then is trained."""

    def __init__(self, trained: bool = False):
        self.preset = SimpleNamespace(image_size=IMAGE_SIZE)
        self.models = {"translation": 1} if trained else {}
        self.started, self.finished, self.release = threading.Event(), threading.Event(), threading.Event()
        self.observed, self.predicted = [], []

    def observe(self, frames):
        self.started.set()
        self.observed.append(frames)
        self.release.wait(SLOW_TRAINING_S)
        self.models = {"translation": 1}
        self.finished.set()
        return {"translation": {"novel": True, "sample_error": None, "processed": len(frames)}}

    def predict(self, rgb, depth_m, pose_base_ref):
        self.predicted.append((rgb.shape, depth_m.shape, pose_base_ref.shape))
        return T_LEARNED


def test_a_commit_is_offered_and_feed_returns_while_the_learner_trains(tmp_path):
    cal = SlowCalibrator()
    learner = BackgroundLearner(cal, reference, K)
    w = watcher(tmp_path, KnownAnswer(), on_commit=[learner])
    committed_at = None
    for f in bumped_frames():
        events = w.feed(f)
        if any(e.state == "recalibrated" for e in events):
            committed_at = f.index
            assert cal.started.wait(SLOW_TRAINING_S)  # the offer reached the learner...
            assert not cal.finished.is_set()  # ...and feed() returned while it trains
    assert committed_at is not None
    assert not cal.finished.is_set()  # the frames after the commit were checked while it trained
    cal.release.set()
    assert learner.wait(SLOW_TRAINING_S)
    learner.close()  # its idle worker thread ended (tests/watch/conftest.py)
    assert learner.reports == [f"learner: version {w.version} observed: translation novel, trained"]
    data = cal.observed[0]
    n = len(data)
    assert data.rgb.shape == (n, 3, IMAGE_SIZE[1], IMAGE_SIZE[0]) and data.depth_m.shape == (n, 1, 12, 16)
    np.testing.assert_allclose(data.t_base_cam_mm, np.tile(1e3 * T_BUMPED[:3, 3], (n, 1)), rtol=FLOAT32_RTOL)
    assert set(data.camera) == {w.version}
    # the reference poses are the kinematics' at each frame's joints
    q = np.stack([f.joints for f in bumped_frames() if f.index in w.history.latest().frames])
    np.testing.assert_allclose(data.pose_base_ref[:, :3], q[:, :3], rtol=FLOAT32_RTOL)


def test_the_learned_prediction_is_an_extra_start_unless_it_is_training(tmp_path):
    cal = SlowCalibrator(trained=True)
    learner = BackgroundLearner(cal, reference, K)
    answer = KnownAnswer()
    w = watcher(tmp_path, answer, extra_starts=learner.starts)
    for f in bumped_frames():
        w.feed(f)
    assert len(answer.calls) == 1
    np.testing.assert_allclose(answer.calls[0]["extra_starts"]["learned"], T_LEARNED, atol=EXACT)
    assert cal.predicted[0] == ((6, 3, 12, 16), (6, 1, 12, 16), (6, 7))
    # while it trains, no prediction is waited for: the recalibration starts from the last calibration alone
    frames = bumped_frames()[:6]
    learner._busy.acquire()
    try:
        t0 = time.perf_counter()
        assert learner.starts(frames) == {}
        assert time.perf_counter() - t0 < SLOW_TRAINING_S
    finally:
        learner._busy.release()
    assert BackgroundLearner(SlowCalibrator(trained=False), reference, K).starts(frames) == {}


def test_frames_without_colour_are_not_offered(tmp_path):
    cal = SlowCalibrator()
    learner = BackgroundLearner(cal, reference, K)
    w = watcher(tmp_path, KnownAnswer(), on_commit=[learner])
    for f in bumped_frames(colour=False):
        w.feed(f)
    assert learner.wait(SLOW_TRAINING_S) and not cal.started.is_set()
    assert learner.reports == [f"learner: version {w.version} not offered: frames without colour"]


class FileGatedCalibrator:
    """A calibrator a child process can take (paths only): observe marks ``started``, waits for ``release`` (at
    most SLOW_TRAINING_S), then is trained."""

    def __init__(self, folder):
        self.folder, self.preset, self.models, self.observed = folder, SimpleNamespace(image_size=IMAGE_SIZE), {}, 0

    def observe(self, frames):
        (self.folder / "started").touch()
        end = time.monotonic() + SLOW_TRAINING_S
        while not (self.folder / "release").exists() and time.monotonic() < end:
            time.sleep(0.01)
        self.models, self.observed = {"translation": 1}, len(frames)
        return {"translation": {"novel": True, "sample_error": None, "processed": len(frames)}}


@pytest.mark.slow
def test_training_in_a_child_process_returns_the_trained_calibrator(tmp_path):
    """in_process: the calibrator goes to a spawned process and comes back trained; feed() meanwhile returns."""
    learner = BackgroundLearner(FileGatedCalibrator(tmp_path), reference, K, in_process=True)
    w = watcher(tmp_path, KnownAnswer(), on_commit=[learner])
    for f in bumped_frames():
        w.feed(f)
    assert not (tmp_path / "release").exists() and learner.calibrator.models == {}  # the parent's copy, untrained
    (tmp_path / "release").touch()
    assert learner.wait(SPAWN_S + SLOW_TRAINING_S), learner.reports
    learner.close()
    assert learner.calibrator.observed == RECAL_FRAMES and learner.calibrator.models == {"translation": 1}
    assert (tmp_path / "started").exists()


@pytest.mark.slow
def test_the_real_calibrator_takes_the_frames_and_predicts_a_pose():
    """The FrameSet is what ContinualCalibrator takes: the tiny preset's networks train from scratch on one
    committed pose's frames and predict a pose from them (its accuracy is the learned module's, not tested here)."""
    pytest.importorskip("torch")
    from learned.calibrator import ContinualCalibrator

    cal = ContinualCalibrator("tiny", seed=0, device="cpu")
    frames = bumped_frames()[:8]
    data = frame_set(frames, T_BUMPED, reference, K, tuple(cal.preset.image_size), 3)
    out = cal.observe(data)
    assert out["first"] and set(out) >= {"translation", "orientation"}
    learner = BackgroundLearner(cal, reference, K)
    T = learner.starts(frames)["learned"]
    assert T.shape == (4, 4) and np.isfinite(T).all()
