"""The cluster-robust covariance (classic/clustered_covariance.py) against the scatter of many repeats.

A mean estimated from residuals that share errors: by group (a frame's own error) and across groups (a bias of
each depth bin, the same in every frame). Counting each residual as independent, or clustering by frame only,
misses the shared bias; the two-way clustered estimate predicts the repeats' scatter.
"""

from __future__ import annotations

import numpy as np

from classic.clustered_covariance import clustered_covariance

FRAMES, BINS, PER_CELL = 20, 12, 15
FRAME_SIGMA, BIN_SIGMA, NOISE_SIGMA = 0.5, 1.0, 2.0


def _repeat(rng):
    frame = np.repeat(np.arange(FRAMES), BINS * PER_CELL)
    depth_bin = np.tile(np.repeat(np.arange(BINS), PER_CELL), FRAMES)
    y = (
        rng.normal(0, FRAME_SIGMA, FRAMES)[frame]
        + rng.normal(0, BIN_SIGMA, BINS)[depth_bin]
        + rng.normal(0, NOISE_SIGMA, len(frame))
    )
    J = np.ones((len(y), 1))
    estimate = y.mean()  # the least-squares mean
    r = y - estimate
    w = np.ones(len(y))
    one_way = clustered_covariance(J, r, w, frame)[0, 0]
    two_way = clustered_covariance(J, r, w, frame, cross_group=depth_bin)[0, 0]
    return estimate, one_way, two_way


def test_a_bias_shared_across_frames_is_counted_by_the_second_clustering():
    rng = np.random.default_rng(0)
    runs = np.array([_repeat(rng) for _ in range(400)])
    scatter = runs[:, 0].var()  # truth: FRAME_SIGMA^2 / FRAMES + BIN_SIGMA^2 / BINS + noise / N
    expected = FRAME_SIGMA**2 / FRAMES + BIN_SIGMA**2 / BINS + NOISE_SIGMA**2 / (FRAMES * BINS * PER_CELL)
    # 400 repeats give the scatter within about 7 % (one sigma); the bins' bias dominates it
    assert abs(scatter / expected - 1) < 0.25
    one_way, two_way = runs[:, 1].mean(), runs[:, 2].mean()
    assert one_way < 0.3 * scatter  # clustered by frame only: the shared bias is invisible
    # two-way: within the small-sample bias of 12 clusters (the centred scores lose one of 12 degrees of freedom)
    assert 0.75 < two_way / scatter < 1.25


def test_without_a_second_clustering_the_estimate_is_unchanged():
    rng = np.random.default_rng(1)
    J = rng.normal(size=(300, 6))
    r = rng.normal(size=300)
    w = np.ones(300)
    group = np.repeat(np.arange(10), 30)
    np.testing.assert_array_equal(clustered_covariance(J, r, w, group), clustered_covariance(J, r, w, group, None))
