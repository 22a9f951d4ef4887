"""Multiway clustering (classic/clustered_covariance.py): an error shared by image tile across the frames.

A sensor's fixed pattern is the same in every frame at one image position. Residuals come in frames, depth bins
and image tiles; the tile's error is shared by every frame that sees something there. Clustered by frame and
depth bin only, the estimate misses it; the three-way estimate (frame, depth bin, tile) predicts the scatter of
the fitted parameters over many repeats.
"""

from __future__ import annotations

import numpy as np

from classic.clustered_covariance import clustered_covariance

FRAMES, BINS, TILES, PER_FRAME = 20, 8, 80, 200
TILE_SIGMA, NOISE_SIGMA = 1.0, 1.0
REPEATS = 300
#: The scatter of 300 repeats is known within sqrt(2 / 300) = 8 % (one sigma); a cluster-robust estimate from
#: residuals is low by about the clusters' leverage, p / G = 6 / 80 (the fit absorbs part of the shared error).
#: The band: that bias, and three sigmas of the scatter either side.
RATIO_BAND = (1 - 6 / TILES - 3 * 0.08, 1 + 3 * 0.08)
#: Without the tiles, the shared error (half the residuals' variance, summed over the 50 residuals of a tile)
#: is missed: far below the truth.
MISSED_RATIO = 0.5


def _design(rng):
    frame = np.repeat(np.arange(FRAMES), PER_FRAME)
    tile = rng.integers(0, TILES, len(frame))
    depth_bin = rng.integers(0, BINS, len(frame))
    u = (tile % 10) / 10.0 - 0.5  # the tile's place in the image: the pose's columns depend on it
    v = (tile // 10) / 8.0 - 0.5
    J = np.c_[np.ones(len(frame)), u, v, u * v, rng.normal(size=(len(frame), 2))]
    return J, frame, depth_bin, tile


def test_an_error_shared_by_tile_is_counted_by_the_third_clustering():
    rng = np.random.default_rng(0)
    J, frame, depth_bin, tile = _design(rng)  # one design, as one placement's matches
    w = np.ones(len(frame))
    estimates, two_way, three_way = [], [], []
    for _ in range(REPEATS):
        y = rng.normal(0, TILE_SIGMA, TILES)[tile] + rng.normal(0, NOISE_SIGMA, len(frame))
        beta, *_ = np.linalg.lstsq(J, y, rcond=None)
        r = y - J @ beta
        estimates.append(beta)
        two_way.append(clustered_covariance(J, r, w, frame, cross_group=depth_bin))
        three_way.append(clustered_covariance(J, r, w, frame, cross_group=[depth_bin, tile]))
    scatter = np.trace(np.cov(np.array(estimates).T))
    assert np.trace(np.mean(two_way, axis=0)) < MISSED_RATIO * scatter
    ratio = np.trace(np.mean(three_way, axis=0)) / scatter
    assert RATIO_BAND[0] < ratio < RATIO_BAND[1], ratio


def test_two_clusterings_given_as_a_list_are_the_two_way_estimate_and_single_clusters_are_left_out():
    rng = np.random.default_rng(1)
    J, frame, depth_bin, tile = _design(rng)
    r = rng.normal(size=len(frame)) + rng.normal(size=TILES)[tile]
    w = np.ones(len(frame))
    two_way = clustered_covariance(J, r, w, frame, cross_group=depth_bin)
    np.testing.assert_array_equal(clustered_covariance(J, r, w, frame, cross_group=[depth_bin, None]), two_way)
    one = np.zeros(len(frame), dtype=int)
    np.testing.assert_array_equal(clustered_covariance(J, r, w, frame, cross_group=[depth_bin, one]), two_way)
    three_way = clustered_covariance(J, r, w, frame, cross_group=[depth_bin, tile])
    assert np.all(np.linalg.eigvalsh(three_way) >= -1e-15)  # negative eigenvalues clipped
    assert np.trace(three_way) > np.trace(two_way)
