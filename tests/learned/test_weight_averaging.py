"""Weight averaging at the end of a training call (TrainConfig.average_epochs)."""

from __future__ import annotations

import numpy as np
import pytest

torch = pytest.importorskip("torch")

from learned.model import ModelConfig, make_network  # noqa: E402
from learned.trainer import TrainConfig, predict, train  # noqa: E402
from tests.learned._synthetic import make_frames  # noqa: E402
from tests.tolerances import FLOAT32_AVERAGE_ATOL, FLOAT32_AVERAGE_RTOL  # noqa: E402

CONFIG = ModelConfig("translation", (32, 32), (4, 8), (16,))


def _trained(frames, epochs: int, average: int) -> torch.nn.Module:
    torch.manual_seed(0)
    model = make_network(CONFIG)
    train(
        model,
        frames,
        np.arange(len(frames)),
        TrainConfig(epochs=epochs, batch_size=8, average_epochs=average),
        np.random.default_rng(1),
    )
    return model


def _weights(model) -> list:
    return [p.detach().clone() for p in model.parameters()]


@pytest.fixture(scope="module")
def frames():
    return make_frames(np.random.default_rng(0), frames_per_camera=3)


def test_the_average_of_the_last_two_epochs_is_the_mean_of_their_weights(frames):
    after_2, after_3 = _weights(_trained(frames, 2, 0)), _weights(_trained(frames, 3, 0))
    averaged = _weights(_trained(frames, 3, 2))
    # the same batches in the same order: the averaged run's epochs 2 and 3 are the two plain runs' ends
    for a, b, m in zip(after_2, after_3, averaged):
        torch.testing.assert_close(m, (a + b) / 2, rtol=FLOAT32_AVERAGE_RTOL, atol=FLOAT32_AVERAGE_ATOL)
    assert any(not torch.equal(a, b) for a, b in zip(after_2, after_3))  # the two epochs' weights differ


def test_averaging_one_epoch_keeps_the_weights_and_renews_the_batch_norm_statistics(frames):
    plain, one = _trained(frames, 2, 0), _trained(frames, 2, 1)
    for a, b in zip(plain.parameters(), one.parameters()):
        assert torch.equal(a, b)  # no step is taken differently: bit for bit
    norms = [m for m in one.modules() if isinstance(m, torch.nn.BatchNorm2d)]
    # the running statistics are the cumulative average over the call's frames, restored to the usual momentum
    assert norms and all(m.momentum == 0.1 for m in norms)
    assert all(int(m.num_batches_tracked) == -(-len(frames) // 8) for m in norms)
    assert np.all(np.isfinite(predict(one, frames)))


def test_a_negative_number_of_epochs_to_average_is_refused():
    with pytest.raises(ValueError, match="average_epochs"):
        TrainConfig(average_epochs=-1)
