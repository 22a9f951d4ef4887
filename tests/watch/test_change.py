"""The change test's stated false-alarm rate and its detection delay, on simulated chi2 streams."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from handeye.watch.change import CHI2_6_MEDIAN, Cusum, NullModel, fit_null, llr

# Tail probability at which a count is called inconsistent with its stated mean: a wrong threshold (h / 2 for h,
# a rate in seconds for frames) multiplies the count by e^(h/2) or the frame rate, far beyond this.
COUNT_TAIL = 1e-6


def _alarm_count(x: np.ndarray, frames_per_alarm: float) -> int:
    """Alarms of :class:`Cusum` itself (re-armed after each) over independent streams, the rows of ``x``."""
    count = 0
    for row in x:
        c = Cusum(frames_per_alarm)
        for xi in row.tolist():
            if c.update(xi):
                count += 1
                c.reset()
    return count


def test_false_alarms_on_null_streams_stay_within_the_stated_rate():
    """The threshold log(F) bounds the rate at one alarm per F frames: 400 000 null frames at F = 2000 give a
    count no larger than Poisson(200)'s 1e-6 upper tail (the bound is a mean; the count is Poisson at most)."""
    rng = np.random.default_rng(0)
    frames_per_alarm = 2000.0
    x = rng.chisquare(6, size=(200, 2000))
    count = _alarm_count(x, frames_per_alarm)
    bound = stats.poisson.isf(COUNT_TAIL, x.size / frames_per_alarm)
    assert count <= bound, (count, bound)


def test_the_stated_rate_is_not_met_by_a_threshold_that_is_too_low():
    """The same check fails for half the threshold: the test above can fail."""
    rng = np.random.default_rng(1)
    x = rng.chisquare(6, size=(200, 2000))
    count = _alarm_count(x, np.sqrt(2000.0))  # h / 2
    assert count > stats.poisson.isf(COUNT_TAIL, x.size / 2000.0)


@pytest.mark.parametrize("noncentrality", [12.0, 40.0])
def test_a_shift_is_detected_within_walds_bound(noncentrality):
    """Mean delay after a shift of noncentrality lambda at most (h + cap) / mu, mu the capped increment's mean
    (Wald's identity on the unreflected walk: it stops no earlier than the CUSUM and overshoots by at most the
    cap), plus 4 standard errors of the simulated mean."""
    rng = np.random.default_rng(2)
    c = Cusum(3600 * 30.0)  # one per hour at 30 Hz
    mu = float(np.mean(np.minimum(llr(rng.noncentral_chisquare(6, noncentrality, 10**6)), c.cap)))
    delays = []
    for _ in range(2000):
        c.reset()
        n = 1
        while not c.update(rng.noncentral_chisquare(6, noncentrality)):
            n += 1
        delays.append(n)
    delays = np.array(delays)
    assert delays.min() >= 2  # the cap: no single frame alarms
    assert delays.mean() <= (c.h + c.cap) / mu + 4 * delays.std() / np.sqrt(len(delays))


def test_the_null_fit_recovers_the_scale_and_the_bias():
    """c from the median: its sampling sd is 1 / (2 sqrt(N) f(m)) / m for chi2(6)'s median m and density f there
    (5.4 % at N = 300); within 4 of them."""
    rng = np.random.default_rng(3)
    n, scale = 300, 3.2
    ref = np.array([1e-3, -2e-3, 5e-4, 2e-3, 1e-3, -3e-3])
    A = rng.normal(size=(n, 6, 6)) * 1e-3
    cov = A @ A.transpose(0, 2, 1) + 1e-7 * np.eye(6)
    deltas = ref + np.einsum("nij,nj->ni", np.linalg.cholesky(scale * cov), rng.normal(size=(n, 6)))
    null = fit_null(deltas, cov)
    sd = 1.0 / (2 * np.sqrt(n) * stats.chi2.pdf(CHI2_6_MEDIAN, 6)) / CHI2_6_MEDIAN
    assert abs(null.scale / scale - 1) <= 4 * sd
    # the reference within its stated covariance (scaled): chi2(6) beyond its 1e-6 tail would be a wrong covariance
    e = null.delta_ref - ref
    assert e @ np.linalg.solve(null.ref_covariance * scale, e) <= stats.chi2.isf(COUNT_TAIL, 6)


def _frames(rng, n, scale, ref, spread):
    """``n`` frames of "nothing moved": covariances of random shape whose size varies by ``10 ** U(-spread,
    spread)`` (the check's vary so with the arm's pose), corrections drawn from ``scale`` times them."""
    A = rng.normal(size=(n, 6, 6)) * 1e-3
    size = 10.0 ** rng.uniform(-spread, spread, size=n)
    cov = (A @ A.transpose(0, 2, 1) + 1e-7 * np.eye(6)) * size[:, None, None]
    return ref + np.einsum("nij,nj->ni", np.linalg.cholesky(scale * cov), rng.normal(size=(n, 6))), cov


def test_a_reference_from_few_unequal_frames_keeps_the_statistic_null(planted_median=False):
    """A reference from 20 frames whose covariances differ by up to 100x (as the check's do over the arm's poses):
    the later frames' x, at the true scale, keeps chi2(6)'s mean 6 (the reference's error counted in its
    covariance). Over 400 references, within 4 standard errors of their 400 means."""
    rng = np.random.default_rng(4)
    ref, scale, means = np.array([1e-3, -2e-3, 5e-4, 2e-3, 1e-3, -3e-3]), 3.2, []
    for _ in range(400):
        deltas, cov = _frames(rng, 70, scale, ref, 1.0)
        fitted = fit_null(deltas[:20], cov[:20])
        if planted_median:  # the reference as a component-wise median with the error of equal frames
            null = NullModel(np.median(deltas[:20], axis=0), scale, 20)
        else:
            null = NullModel(fitted.delta_ref, scale, 20, fitted.ref_covariance)
        means.append(np.mean([null.statistic(d, c) for d, c in zip(deltas[20:], cov[20:])]))
    mean, se = np.mean(means), np.std(means) / np.sqrt(len(means))
    assert abs(mean - 6.0) <= 4 * se, (mean, se)


def test_a_component_wise_median_reference_fails_the_check_above():
    """The check above can fail: the median's error is several sigmas of the best-determined frames."""
    with pytest.raises(AssertionError):
        test_a_reference_from_few_unequal_frames_keeps_the_statistic_null(planted_median=True)


def test_bad_inputs_raise():
    with pytest.raises(ValueError, match="at least 6"):
        fit_null(np.zeros((3, 6)), np.tile(np.eye(6), (3, 1, 1)))
    with pytest.raises(ValueError, match="frames per false alarm"):
        Cusum(1.0)
    assert NullModel(np.zeros(6), 1.0, 10).statistic(np.ones(6), np.eye(6)) == pytest.approx(6.0 / (1 + np.pi / 20))
