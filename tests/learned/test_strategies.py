"""Each strategy trains on what its algorithm says: counts from the buffer, c3, skipped poses."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("torch")

from learned.experiment import time_steps  # noqa: E402
from learned.strategies import make_strategy  # noqa: E402
from tests.learned._synthetic import (  # noqa: E402
    FRAMES_PER_CAMERA,
    TRAIN_PER_REGION,
    count_setting,
)

PRESET, FIRST, LATER = count_setting()


def _run(name, frames, **params):
    strat = make_strategy(name, PRESET.model_config("translation"), FIRST, LATER, np.random.default_rng(1), **params)
    steps = time_steps(frames)
    for k, cams in enumerate(steps):
        strat.step(k, cams, frames, last=k == len(steps) - 1)
    return strat, steps


def test_time_steps_are_the_regions_training_cameras(frames):
    steps = time_steps(frames)
    assert len(steps) == 3 and all(len(s) == TRAIN_PER_REGION for s in steps)
    assert all(np.all(frames.split[np.isin(frames.camera, s)] == "train") for s in steps)


def test_naive_trains_on_the_current_step_only(frames):
    strat, steps = _run("naive", frames)
    per_step = TRAIN_PER_REGION * FRAMES_PER_CAMERA
    assert strat.processed == FIRST.epochs * per_step + 2 * LATER.epochs * per_step
    assert strat.stored == 0 and strat.trained_on == steps


@pytest.mark.parametrize("c1", [2, 4])
def test_reservoir_replays_c1_samples_of_every_past_camera_pose(frames, c1):
    strat, steps = _run("reservoir", frames, c1=c1)
    current = TRAIN_PER_REGION * FRAMES_PER_CAMERA
    # step 1: current only; step 2: + c1 x 3 past poses; step 3: + c1 x 6 past poses
    expected = FIRST.epochs * current + LATER.epochs * (current + 3 * c1) + LATER.epochs * (current + 6 * c1)
    assert strat.processed == expected
    assert sorted(strat.buffer) == sorted(c for s in steps for c in s)
    assert all(len(v) == c1 for v in strat.buffer.values())
    for c, idx in strat.buffer.items():  # the buffer holds that camera's own training frames
        assert np.all(frames.camera[idx] == c) and np.all(frames.split[idx] == "train")
    assert strat.stored == 9 * c1


def test_reservoir_c2_limits_the_past_poses_and_c3_the_current_data(frames):
    strat, _ = _run("reservoir", frames, c1=4, c2=2, c3=0.5)
    current = int(round(0.5 * TRAIN_PER_REGION * FRAMES_PER_CAMERA))
    # the first subset whole, as naive trains it (the paper applies c3 to the later steps only)
    first = TRAIN_PER_REGION * FRAMES_PER_CAMERA
    assert strat.processed == FIRST.epochs * first + 2 * LATER.epochs * (current + 2 * 4)


def test_selection_skips_every_pose_below_a_huge_threshold(frames):
    strat, steps = _run("selection", frames, c1=4, threshold_mm=1e9)
    later = [c for s in steps[1:] for c in s]
    assert strat.skipped == later
    assert strat.processed == FIRST.epochs * TRAIN_PER_REGION * FRAMES_PER_CAMERA
    assert strat.evaluated == len(later) * 1  # 10 % of 10 frames per pose
    assert sorted(strat.buffer) == steps[0]


def test_selection_trains_on_every_pose_above_a_zero_threshold(frames):
    strat, steps = _run("selection", frames, c1=4, threshold_mm=0.0)
    assert strat.skipped == []
    # each later pose is its own time step: its frames plus a third (1 / poses per region) of the buffer so far
    # (3 first-region poses of c1 = 4 samples, growing by 4 per pose), so a region costs one reservoir step
    expected = FIRST.epochs * TRAIN_PER_REGION * FRAMES_PER_CAMERA
    for k in range(6):
        expected += LATER.epochs * (FRAMES_PER_CAMERA + int(round(4 * (3 + k) / TRAIN_PER_REGION)))
    assert strat.processed == expected
    assert strat.trained_on[1:] == steps[1:]


def test_selection_replaying_the_whole_buffer_per_pose(frames):
    strat, steps = _run("selection", frames, c1=4, threshold_mm=0.0, replay_share="all")
    expected = FIRST.epochs * TRAIN_PER_REGION * FRAMES_PER_CAMERA
    for k in range(6):
        expected += LATER.epochs * (FRAMES_PER_CAMERA + 4 * (3 + k))
    assert strat.processed == expected


def test_batch_trains_from_scratch_on_everything_at_the_last_step(frames):
    strat, steps = _run("batch", frames)
    assert strat.trained_on[:2] == [[], []] and sorted(strat.trained_on[2]) == sorted(c for s in steps for c in s)
    assert strat.processed == FIRST.epochs * 9 * FRAMES_PER_CAMERA


def test_counts_hold_for_the_keypoint_model(frames):
    """Reservoir and selection on the keypoint model: the same buffer arithmetic as on the paper's networks."""
    from dataclasses import replace

    from learned.data import with_keypoints

    kp = np.random.default_rng(3).uniform(-0.5, 0.5, size=(len(frames), 5, 3)).astype(np.float32)
    kframes = replace(with_keypoints(frames, kp), intrinsics_norm=np.tile([1.0, 1.0, 0.5, 0.5], (len(frames), 1)))
    config = PRESET.model_config("keypoints", n_keypoints=5)
    strat = make_strategy("reservoir", config, FIRST, LATER, np.random.default_rng(1), c1=4)
    steps = time_steps(kframes)
    for k, cams in enumerate(steps):
        strat.step(k, cams, kframes, last=k == len(steps) - 1)
    per_step = TRAIN_PER_REGION * FRAMES_PER_CAMERA
    expected = (
        FIRST.epochs * per_step
        + LATER.epochs * (per_step + 4 * TRAIN_PER_REGION)
        + LATER.epochs * (per_step + 8 * TRAIN_PER_REGION)
    )
    assert strat.processed == expected and strat.stored == 4 * 3 * TRAIN_PER_REGION
    sel = make_strategy(
        "selection", config, FIRST, LATER, np.random.default_rng(1), threshold_mm=1e9, threshold_deg=1e9
    )
    for k, cams in enumerate(steps):
        sel.step(k, cams, kframes, last=k == len(steps) - 1)
    assert len(sel.skipped) == 2 * TRAIN_PER_REGION  # nothing is novel at infinite thresholds
