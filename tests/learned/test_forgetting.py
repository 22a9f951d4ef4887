"""The tiny preset forgets with naive fine-tuning and less with the reservoir buffer (on data built for it)."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("torch")

from learned.experiment import PRESETS, run_experiment  # noqa: E402
from tests.learned._synthetic import make_frames  # noqa: E402


@pytest.fixture(scope="module")
def results():
    frames = make_frames(
        np.random.default_rng(0),
        regions=((0, 70), (180, 250)),
        train_per_region=5,
        test_per_region=2,
        frames_per_camera=16,
        size=PRESETS["tiny"].image_size,
    )
    return run_experiment(frames, "tiny", strategies=("naive", "reservoir"), progress=False, threads=2)


def _matrix(results, strategy, network):
    return np.array(next(r for r in results["runs"] if r["strategy"] == strategy and r["network"] == network)["matrix"])


@pytest.mark.parametrize("network", ["translation", "orientation"])
def test_naive_forgets_the_first_region(results, network):
    m = _matrix(results, "naive", network)
    # S1 error after the second step is at least twice its error after the first (the paper's finding)
    assert m[1, 0] >= 2 * m[0, 0]


@pytest.mark.parametrize("network", ["translation", "orientation"])
def test_reservoir_forgets_less_than_naive(results, network):
    naive, reservoir = _matrix(results, "naive", network), _matrix(results, "reservoir", network)
    assert reservoir[1, 0] <= 0.5 * naive[1, 0]
