"""``pairs="all"`` is bounded (classic.pairs): every pair up to MAX_PAIRS, a stated rule beyond, and the
answer on a large set stays at the Cramér–Rao level with a sigma that covers its error."""

from __future__ import annotations

import tracemalloc

import numpy as np
import pytest

from classic.calibrate import calibrate
from classic.motions import iter_motions
from classic.pairs import MAX_PAIRS, bounded_strides, describe_pairs, pair_indices, unique_sorted
from classic.refine import cramer_rao_bound
from handeye.core.se3 import make_transform, so3_exp, so3_log
from handeye.core.synthetic import make_problem
from tests.tolerances import DEG, LARGE_SET_PEAK_MB, LARGE_SET_SIGMA_RTOL, MM, SIGMA_BOUND

#: The most poses whose pairs are all taken: n (n - 1) / 2 <= MAX_PAIRS.
MOST_ALL = int((1 + np.sqrt(1 + 8 * MAX_PAIRS)) // 2)


def test_all_pairs_up_to_the_cap_as_before():
    for n in (2, 8, 200, MOST_ALL):
        i, j = pair_indices(n)
        ti, tj = np.triu_indices(n, k=1)
        assert np.array_equal(i, ti) and np.array_equal(j, tj)
        assert describe_pairs(n)["rule"] == "all"
    assert MOST_ALL * (MOST_ALL - 1) // 2 <= MAX_PAIRS < (MOST_ALL + 1) * MOST_ALL // 2


@pytest.mark.parametrize("n", [MOST_ALL + 1, 3001, 10_000, 100_000])
def test_beyond_the_cap_each_pose_with_the_stated_strides(n):
    i, j = pair_indices(n)
    strides = bounded_strides(n)
    assert len(i) <= MAX_PAIRS or len(strides) == 1
    assert np.all(i < j) and np.all(j < n)
    code = i.astype(np.int64) * n + j
    assert np.all(np.diff(code) > 0)  # each pair once, sorted
    # exactly the pairs (k, k + d mod n) of the stated strides
    gap = np.minimum(j - i, n - (j - i))
    assert set(np.unique(gap).tolist()) == set(strides.tolist())
    assert strides[0] == 1 and strides[-1] <= n // 2
    assert len(strides) == len(np.unique(strides)) <= max(1, MAX_PAIRS // n)
    # every pose is in at least two pairs, its neighbours' among them
    assert np.bincount(np.concatenate([i, j]), minlength=n).min() >= 2
    assert np.isin(np.arange(n - 1) * n + np.arange(1, n), code).all()
    d = describe_pairs(n)
    assert d["rule"] == "bounded" and d["n_pairs"] == len(i) and d["strides"] == strides.tolist()
    # deterministic
    assert np.array_equal(pair_indices(n)[1], j)


def test_unique_sorted_is_numpy_unique():
    codes = np.random.default_rng(0).integers(0, 50, 1000)
    assert np.array_equal(unique_sorted(codes), np.unique(codes))
    assert len(unique_sorted(np.array([], dtype=int))) == 0


def _largest_angle_deg(A, B, i, j) -> float:
    return max(float(np.degrees(m.angles_A.max())) for m in iter_motions(A, B, i, j))


def test_the_bounded_pairs_keep_the_rotation_diversity_of_a_trajectory():
    """A smooth sweep in recording order: the neighbours' pairs turn by a fraction of a degree, the bounded
    pairs reach within a tenth of the largest motion of all pairs."""
    n = MOST_ALL + 300
    t = np.linspace(0.0, 1.0, n)
    w = np.stack([0.6 * np.sin(2 * np.pi * t), 0.6 * np.cos(3 * np.pi * t), 1.2 * t - 0.6], axis=1)
    A = make_transform(so3_exp(w), np.stack([t, 0.5 * t, np.zeros(n)], axis=1))
    every = _largest_angle_deg(A, A, *np.triu_indices(n, k=1))
    bounded = _largest_angle_deg(A, A, *pair_indices(n))
    neighbours = _largest_angle_deg(A, A, *pair_indices(n, "consecutive"))
    assert neighbours < 0.1 * every
    assert bounded > 0.9 * every


@pytest.fixture(scope="module")
def large():
    """10^4 poses, camera noise 0.1 deg / 1 mm per axis: calibrated once, its peak traced memory."""
    noise = (0.1, 1.0)
    p = make_problem(10_000, "eye_to_hand", np.random.default_rng(11), camera_noise=noise)
    tracemalloc.start()
    try:
        res = calibrate(p.T_base_ee, p.T_cam_target, setup="eye_to_hand")
        peak_mb = tracemalloc.get_traced_memory()[1] / 1e6
    finally:
        tracemalloc.stop()
    bound = cramer_rao_bound(p.T_base_ee, p.X_true, p.Y_true, (noise[0] * DEG, noise[1] * MM))
    return p, res, bound, peak_mb


def _errors(res, p):
    e = []
    for T, T_true in ((res.X, p.X_true), (res.Y, p.Y_true)):
        e += [so3_log(T[:3, :3] @ T_true[:3, :3].T), T[:3, 3] - T_true[:3, 3]]
    return e


def test_a_large_set_is_bounded_and_recovers_the_truth_at_the_cramer_rao_level(large):
    p, res, bound, peak_mb = large
    assert res.diagnostics["pairs"]["rule"] == "bounded"
    assert res.diagnostics["pairs"]["n_pairs"] <= MAX_PAIRS
    assert peak_mb < LARGE_SET_PEAK_MB
    for block, e in enumerate(_errors(res, p)):
        cr = np.sqrt(np.trace(bound[3 * block : 3 * block + 3, 3 * block : 3 * block + 3]))
        assert np.linalg.norm(e) < SIGMA_BOUND * cr


def test_a_large_sets_sigma_is_the_bound_and_covers_its_error(large):
    p, res, bound, _ = large
    for block, e in enumerate(_errors(res, p)):
        k = slice(3 * block, 3 * block + 3)
        sigma = np.sqrt(np.trace(res.covariance[k, k]))
        cr = np.sqrt(np.trace(bound[k, k]))
        assert abs(sigma / cr - 1.0) < LARGE_SET_SIGMA_RTOL
        assert np.linalg.norm(e) < SIGMA_BOUND * sigma
