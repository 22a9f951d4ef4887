"""The one replay buffer: class balance, max_size, reservoir merging, and its state through safe_io."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("torch")

from learned.replay import ReplayBuffer  # noqa: E402
from learned.safe_io import load_document, save_document  # noqa: E402
from tests.learned._synthetic import make_frames  # noqa: E402
from tests.tolerances import REPLAY_FREQUENCY_ATOL  # noqa: E402


@pytest.fixture(scope="module")
def frames():
    return make_frames(
        np.random.default_rng(0),
        regions=((0, 60), (120, 180)),
        train_per_region=3,
        test_per_region=1,
        frames_per_camera=10,
    )


def _of(frames, cams):
    return np.flatnonzero(np.isin(frames.camera, cams))


def test_class_balance_and_max_size(frames):
    buf = ReplayBuffer(4)
    buf.update(frames, _of(frames, [0, 1, 2]), np.random.default_rng(0))
    assert list(buf) == [0, 1, 2] and buf.size == 12 and all(np.all(frames.camera[buf[c]] == c) for c in buf)
    small = ReplayBuffer(4, max_size=6)
    small.update(frames, _of(frames, [0, 1, 2]), np.random.default_rng(0))
    assert small.size == 6 and sorted(len(v) for v in small.values()) == [2, 2, 2]


def test_a_pose_seen_again_keeps_a_uniform_sample(frames):
    """Frames of one pose given in two parts: each frame ends in the buffer with probability c1 / n."""
    idx = _of(frames, [0])
    counts = np.zeros(len(frames))
    rng = np.random.default_rng(1)
    for _ in range(2000):
        buf = ReplayBuffer(4)
        buf.update(frames, idx[:3], rng)
        buf.update(frames, idx[3:], rng)
        assert len(buf[0]) == 4 and len(set(buf[0].tolist())) == 4
        counts[buf[0]] += 1
    np.testing.assert_allclose(counts[idx] / 2000, 0.4, atol=REPLAY_FREQUENCY_ATOL)


@pytest.mark.parametrize("keep_samples", [False, True])
def test_state_round_trips_through_safe_io(frames, tmp_path, keep_samples):
    buf = ReplayBuffer(3, max_size=10, keep_samples=keep_samples)
    buf.update(frames, _of(frames, [4, 5, 0]), np.random.default_rng(2))
    state = buf.state_dict()
    save_document(tmp_path / "b.pt", "buffer", 1, {"meta": state["meta"], "tensors": state["tensors"]})
    again = ReplayBuffer(1)
    again.load_state_dict(load_document(tmp_path / "b.pt", "buffer", 1))
    assert list(again) == list(buf) and again.size == buf.size == 9
    if keep_samples:
        np.testing.assert_array_equal(again.frames().rgb, buf.frames().rgb)
        assert list(again.frames().split) == list(buf.frames().split)
    else:
        assert all(np.array_equal(again[c], buf[c]) for c in buf)
