"""The cluster-robust covariance (classic/clustered_covariance.py) against the scatter of many repeats.

A mean estimated from residuals that share errors: by group (a frame's own error) and across groups (a bias of
each depth bin, the same in every frame). Counting each residual as independent, or clustering by frame only,
misses the shared bias; the two-way clustered estimate predicts the repeats' scatter.
"""

from __future__ import annotations

import numpy as np

from classic.clustered_covariance import clustered_covariance
from tests.tolerances import RELATIVE_ONLY, SCALE_RTOL

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


def test_one_way_is_the_sandwich_and_a_second_clustering_equal_to_the_first_changes_nothing():
    """One way: ``H^-1 (k / (k - 1) sum_g s_g s_g^T) H^-1``, written out here; two-way with the same clusters
    twice is ``C + C - C = C``."""
    rng = np.random.default_rng(1)
    J = np.c_[np.ones(300), rng.normal(size=(300, 5))]  # a column the groups' shared errors add up in
    r = rng.normal(size=300) + np.repeat(rng.normal(size=10), 30)  # a shared error per group: sandwich > plain
    w = np.ones(300)
    group = np.repeat(np.arange(10), 30)
    scores = np.array([(J[group == g] * r[group == g, None]).sum(axis=0) for g in range(10)])
    H_inv = np.linalg.inv(J.T @ J)
    by_hand = H_inv @ (scores.T @ scores * 10 / 9) @ H_inv
    one_way = clustered_covariance(J, r, w, group)
    plain = H_inv * (r @ r) / (300 - 6)
    assert np.trace(by_hand) > np.trace(plain)  # the sandwich, not the floor, is what comes back
    np.testing.assert_allclose(one_way, by_hand, rtol=SCALE_RTOL)
    np.testing.assert_allclose(
        clustered_covariance(J, r, w, group, cross_group=group), one_way, rtol=SCALE_RTOL, atol=RELATIVE_ONLY
    )
