"""A learned start the recalibration can use, or none: a prediction that is not a rigid transform (a diverged
network's NaN) or a predict that fails is reported and left out, never passed on: the registration refuses a
non-finite start by raising, and the watcher would stop on the learner's failure."""

from __future__ import annotations

import numpy as np
import pytest

from handeye.core.se3 import make_transform
from handeye.watch.learner import BackgroundLearner
from tests.classic.test_markerless import K
from tests.watch.cell_streams import bumped_frames
from tests.watch.test_learner import IMAGE_SIZE, T_LEARNED, SlowCalibrator, reference


class Predicting(SlowCalibrator):
    """Trained; its predict gives ``answer`` (raises it when it is an exception)."""

    def __init__(self, answer):
        super().__init__(trained=True)
        self.answer = answer

    def predict(self, rgb, depth_m, pose_base_ref):
        if isinstance(self.answer, Exception):
            raise self.answer
        return self.answer


NAN_POSE = np.full((4, 4), np.nan)
SHEARED = make_transform(np.diag([1.0, 1.0, 1.5]), [0.1, 0.2, 0.3])


@pytest.mark.parametrize(
    "answer, why",
    [
        (NAN_POSE, "NaN or infinity"),
        (SHEARED, "not orthonormal"),
        (RuntimeError("CUDA error: device-side assert"), "RuntimeError: CUDA error"),
    ],
)
def test_a_learned_start_that_is_no_rigid_transform_is_reported_and_left_out(answer, why):
    learner = BackgroundLearner(Predicting(answer), reference, K)
    assert learner.image_size == IMAGE_SIZE
    assert learner.starts(bumped_frames()[:6]) == {}
    assert len(learner.reports) == 1 and "learner: no start:" in learner.reports[0] and why in learner.reports[0]


def test_a_rigid_learned_start_is_passed_on():
    learner = BackgroundLearner(Predicting(T_LEARNED), reference, K)
    np.testing.assert_array_equal(learner.starts(bumped_frames()[:6])["learned"], T_LEARNED)
    assert learner.reports == []
