"""Each committed camera pose is a camera pose of its own in the learner (its replay buffer's class): the
calibration's version when the learner has not seen that number, else the next unused one. Without a history
every commit has no version, and a learner loaded from an earlier run has seen the versions of that run: both
used to reach ``observe`` as one camera pose, so different poses (different targets) merged into one class."""

from __future__ import annotations

from handeye.watch.learner import BackgroundLearner
from tests.classic.test_markerless import K
from tests.watch.cell_streams import T_BUMPED, bumped_frames
from tests.watch.test_learner import IMAGE_SIZE, SLOW_TRAINING_S, reference


class Remembering:
    """A calibrator whose history names the camera poses it has observed (as ContinualCalibrator's does)."""

    def __init__(self, seen=()):
        self.preset, self.models = type("P", (), {"image_size": IMAGE_SIZE})(), {}
        self.history = [{"cameras": list(seen), "first": True}] if seen else []

    def observe(self, frames):
        self.history.append({"cameras": sorted({int(c) for c in frames.camera}), "first": not self.history})
        return {"translation": {"novel": True, "sample_error": None, "processed": len(frames)}}


def _offered(calibrator, versions) -> list:
    frames = bumped_frames()[:6]
    with BackgroundLearner(calibrator, reference, K) as learner:  # its worker ended on leaving
        for v in versions:
            learner(T_BUMPED, frames, v)
        assert learner.wait(SLOW_TRAINING_S), learner.reports
    return [e["cameras"] for e in calibrator.history]


def test_commits_without_a_version_are_camera_poses_of_their_own():
    assert _offered(Remembering(), [None, None, None]) == [[0], [1], [2]]


def test_a_version_the_loaded_learner_has_seen_gets_a_new_number():
    assert _offered(Remembering(seen=[1, 2, 3]), [2, 5, 4]) == [[1, 2, 3], [4], [5], [6]]


def test_an_unseen_version_is_kept():
    assert _offered(Remembering(seen=[0]), [3, 7]) == [[0], [3], [7]]
