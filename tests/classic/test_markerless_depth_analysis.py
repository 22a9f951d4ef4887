"""A registration of the same depth frames under another camera matrix takes the frames' own findings (noise, mixed
and moving pixels: classic.markerless.depth_analysis) from the first, bit for bit what it would find itself, and
never takes them for other frames."""

from __future__ import annotations

import json

import numpy as np

from classic.markerless import register_robot
from tests.classic.test_markerless import K, _scene


def _same(a, b) -> bool:
    arrays = all(
        np.array_equal(x, y, equal_nan=True) for x, y in ((a.T_base_cam, b.T_base_cam), (a.covariance, b.covariance))
    )
    return arrays and json.dumps(a.to_dict(), sort_keys=True) == json.dumps(b.to_dict(), sort_keys=True)


def test_second_registration_reuses_the_first_analysis_bit_for_bit():
    depth, surface, _ = _scene(np.random.default_rng(0))
    first = register_robot(depth, K, surface)
    assert first.ok and first.depth_analysis is not None
    K2 = K.copy()
    K2[0, 0] *= 1.003  # a second pass under a pooled camera matrix
    starts = {"first pass": first.T_base_cam}
    reused = register_robot(depth, K2, surface, starts=starts, depth_analysis=first.depth_analysis)
    fresh = register_robot(depth, K2, surface, starts=starts)
    assert reused.ok and _same(reused, fresh)


def test_an_analysis_of_other_frames_is_not_taken():
    depth, surface, _ = _scene(np.random.default_rng(0))
    noise = np.random.default_rng(1).normal(0.0, 0.001, depth.shape)
    other = np.where(depth > 0, depth + noise, 0.0)  # the same scene, more noise
    first = register_robot(depth, K, surface)
    assert first.depth_analysis.moving_bits.any()
    with_wrong = register_robot(other, K, surface, depth_analysis=first.depth_analysis)
    fresh = register_robot(other, K, surface)
    assert with_wrong.ok and _same(with_wrong, fresh)
    assert with_wrong.depth_analysis.key != first.depth_analysis.key
