"""handeye.watch.halves: a recalibration's frames split in time, each half registered alone, compared."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from handeye.core.se3 import make_transform
from handeye.watch.halves import HALVES_SIGMAS, MIN_HALF_FRAMES, halves_disagree

SIGMA = {"rotation_deg": 0.05, "translation_mm": 1.0}


def _registration(frames, T_start):
    """A stand-in registration: the camera at the mean of its frames' x offsets (metres), sigma SIGMA."""
    x = float(np.mean([f.x for f in frames]))
    return SimpleNamespace(ok=True, T_base_cam=make_transform(np.eye(3), [x, 0.0, 0.0]), sigma=dict(SIGMA))


def _frames(xs):
    return [SimpleNamespace(x=x) for x in xs]


WHOLE = SimpleNamespace(ok=True, T_base_cam=np.eye(4), sigma=dict(SIGMA))


def test_halves_of_one_pose_agree():
    assert halves_disagree(_registration, _frames([0.0] * 30), WHOLE) is None


def test_halves_of_two_poses_beyond_their_sigmas_are_named():
    """A move of 5 mm between the halves: 5 / (1 mm * sqrt 2) = 3.5 combined sigmas, beyond HALVES_SIGMAS."""
    reason = halves_disagree(_registration, _frames([0.0] * 15 + [0.005] * 15), WHOLE)
    assert reason is not None and "5.00 mm" in reason and "moved while the frames were collected" in reason


def test_a_move_within_the_combined_sigmas_is_no_disagreement():
    """4 mm between the halves is 2.8 combined sigmas: within HALVES_SIGMAS (3)."""
    assert 4.0 / np.hypot(1.0, 1.0) < HALVES_SIGMAS
    assert halves_disagree(_registration, _frames([0.0] * 15 + [0.004] * 15), WHOLE) is None


def test_too_few_frames_or_a_refused_half_cannot_tell():
    assert halves_disagree(_registration, _frames([0.0] * (2 * MIN_HALF_FRAMES - 1)), WHOLE) is None

    def refusing(frames, T_start):
        return SimpleNamespace(ok=False, refused="too few robot pixels")

    assert halves_disagree(refusing, _frames([0.0] * 15 + [0.05] * 15), WHOLE) is None
