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
    assert reused.depth_analysis is first.depth_analysis  # taken, not found again
    assert fresh.depth_analysis is not first.depth_analysis


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


def test_the_3x3_range_is_scipys_filter_value_for_value():
    """The mixed pixels' neighbourhood minimum and maximum (classic.markerless.depth._over_3x3) are
    scipy.ndimage's minimum_filter and maximum_filter of size (1, 3, 3), borders and single rows included."""
    from scipy import ndimage

    from classic.markerless.depth import _over_3x3

    rng = np.random.default_rng(5)
    for shape in [(3, 5, 7), (2, 1, 4), (1, 3, 1), (2, 40, 30)]:
        a = rng.normal(size=shape).astype(np.float32)
        a[a > 1.5] = np.inf
        assert np.array_equal(_over_3x3(np.minimum, a), ndimage.minimum_filter(a, size=(1, 3, 3)))
        assert np.array_equal(_over_3x3(np.maximum, a), ndimage.maximum_filter(a, size=(1, 3, 3)))


def test_the_fine_gates_are_positive_distances():
    """A second pass's gates (one, the finest) pass; none, or a zero, negative or NaN gate, is refused by name."""
    import pytest

    from classic.markerless import MarkerlessOptions
    from handeye.core.errors import HandEyeInputError

    assert MarkerlessOptions(fine_gates_m=(0.01,)).fine_gates_m == (0.01,)
    for bad in ((), (0.02, 0.0), (-0.01,), (float("nan"),)):
        with pytest.raises(HandEyeInputError, match="fine_gates_m"):
            MarkerlessOptions(fine_gates_m=bad)
