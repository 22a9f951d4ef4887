"""One camera's intrinsics pooled over its placements: the leave-one-out prior, its widening and its refusals."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from scipy import integrate, stats

from classic.markerless.intrinsics import camera_matrix, intrinsics_vector
from classic.markerless.shared_intrinsics import (
    FIRST_PASS_PRIOR_TIMES,
    MIN_OTHERS,
    SPREAD_QUANTILE,
    against_given,
    pooled_prior,
    second_pass_options,
)
from tests.tolerances import FLOAT, SHARED_INTRINSICS_SES, SIGMA_BOUND

THETA = np.array([222.0, 221.0, 128.0, 127.0])  # the camera's true fx, fy, cx, cy, pixels
GIVEN = camera_matrix(THETA * np.array([1.007, 1.007, 1.0, 1.0]) + np.array([0, 0, 3.0, 0]))  # a factory matrix
GIVEN_SIGMA = (0.007, 0.007, 3.0, 3.0)


def draws(rng, n, scale=1.0, prior_times=FIRST_PASS_PRIOR_TIMES):
    """``n`` placements' estimates of THETA as a first pass gives them: each its frames' estimate (its own sigma,
    0.2-0.8 px, scattered ``scale`` times it) under the prior of the camera matrix given, ``prior_times`` its stated
    sigma (:func:`first_pass_options`), a posterior, which holds ``sigma^2 / prior_sigma^2`` of the given matrix's
    error (the pool must not keep that share)."""
    given = intrinsics_vector(GIVEN)
    given_px = prior_times * np.array(GIVEN_SIGMA) * np.array([given[0], given[1], 1.0, 1.0])
    out = []
    for s in rng.uniform(0.2, 0.8, size=(n, 4)):
        frames = THETA + scale * s * rng.normal(size=4)
        precision = 1 / s**2 + 1 / given_px**2
        out.append(((frames / s**2 + given / given_px**2) / precision, 1 / np.sqrt(precision)))
    return out


def test_pool_recovers_the_camera_within_its_sigma():
    rng = np.random.default_rng(0)
    n_draws, k = 400, 6
    z2 = []
    for _ in range(n_draws):
        est = draws(rng, k + 1)
        prior = pooled_prior(est, None, GIVEN, GIVEN_SIGMA)  # no own estimate: no conflict check
        assert all(prior.pooled) and prior.others == k + 1 and prior.reason == ""
        mean = intrinsics_vector(prior.K)
        sigma = np.array(prior.prior_sigma) * np.array([mean[0], mean[1], 1.0, 1.0])
        z2.append(((mean - THETA) / sigma) ** 2)
    # the Birge widening's expected effect with k degrees of freedom: E[1 / max(X / k, 1)], X chi-square(k), over the
    # pools whose scatter stays below SPREAD_QUANTILE; the others' prior is wider still (a spread of their own), so
    # the bound leaves their share of the mean out (z^2 >= 0)
    top = stats.chi2.ppf(SPREAD_QUANTILE, k)
    widened, _ = integrate.quad(lambda x: stats.chi2.pdf(x, k) / max(x / k, 1.0), 0, top)
    se = np.sqrt(2.0 / (4 * n_draws))
    assert widened - SHARED_INTRINSICS_SES * se <= np.mean(z2) <= 1.0 + SHARED_INTRINSICS_SES * se


def test_scatter_beyond_the_sigmas_widens_the_prior():
    rng = np.random.default_rng(1)
    consistent = pooled_prior(draws(rng, 8), None, GIVEN, GIVEN_SIGMA)
    rng = np.random.default_rng(1)
    scattered = pooled_prior(draws(rng, 8, scale=5.0), None, GIVEN, GIVEN_SIGMA)
    # five times the scatter: a Birge ratio near 5, beyond chance, so the prior holds the spread itself (a sigma
    # near the estimates' own, many times the consistent pool's; the draws' chi-square varies)
    assert np.all(np.array(scattered.birge) > 2.5)
    assert np.all(np.array(scattered.prior_sigma) > 2.5 * np.array(consistent.prior_sigma))


def test_placements_whose_values_differ_give_the_next_one_the_spread():
    """A depth image shifted against the camera model by each unit's own amount (1 px per axis) moves each
    placement's principal point by it; measured to 0.1-0.4 px each, the placements then scatter far beyond their
    sigmas. The prior for one more placement must hold where its own value may lie: the pool's mean give or take
    the spread (E[z^2] about 1), not the mean's sigma widened by the Birge ratio (z^2 of tens)."""
    rng = np.random.default_rng(5)
    n_draws, k = 400, 23
    spread = np.array([0.0, 0.0, 1.0, 1.0])  # the focal lengths are the lens's, alike at every placement
    z2, spreads = [], []
    for _ in range(n_draws):
        sigma = np.hstack([rng.uniform(0.2, 0.8, size=(k, 2)), rng.uniform(0.1, 0.4, size=(k, 2))])
        est = [(THETA + spread * rng.normal(size=4) + s * rng.normal(size=4), s) for s in sigma]
        own_value = THETA + spread * rng.normal(size=4)
        prior = pooled_prior(est, None, GIVEN, GIVEN_SIGMA)
        spreads.append(prior.spread)
        mean = intrinsics_vector(prior.K)
        z2.append(((mean - own_value) / (np.array(prior.prior_sigma) * np.array([mean[0], mean[1], 1.0, 1.0]))) ** 2)
    z2 = np.mean(z2, axis=0)
    se = np.sqrt(2.0 / n_draws)
    spreads = np.array(spreads)
    tau2 = spreads[:, 2:] ** 2
    # the spread reported: the principal point's square about its 1 px^2, within its mean's standard error
    assert np.all(np.abs(tau2.mean(axis=0) - 1.0) <= SHARED_INTRINSICS_SES * tau2.std(axis=0) / np.sqrt(n_draws))
    # the spread estimated from k placements scatters, and E[1 / tau_hat^2] = (1 + Var(tau_hat^2) / tau^4) / tau^2
    # to second order: E[z^2] runs above 1 by that relative variance
    inflation = tau2.var(axis=0) / tau2.mean(axis=0) ** 2
    assert np.all(np.abs(z2[2:] - (1.0 + inflation)) <= SHARED_INTRINSICS_SES * se)
    assert np.all(z2[:2] <= 1.0 + SHARED_INTRINSICS_SES * se)  # no spread: the Birge-widened mean's sigma
    # the focal lengths' spread 0 but in the pools chance puts beyond SPREAD_QUANTILE
    chance = 1 - SPREAD_QUANTILE  # a binomial share of n_draws pools
    assert np.all(
        np.mean(spreads[:, :2] > 0, axis=0)
        <= chance + SHARED_INTRINSICS_SES * np.sqrt(chance * SPREAD_QUANTILE / n_draws)
    )


def test_a_parameter_the_placement_disagrees_with_keeps_the_given_prior():
    rng = np.random.default_rng(2)
    est = draws(rng, 7)
    own_theta, own_sigma = est[0]
    own = (own_theta + np.array([0.0, 0.0, 10.0, 0.0]), own_sigma)  # cx shifted 10 px: a re-registered unit
    prior = pooled_prior(est[1:], own, GIVEN, GIVEN_SIGMA)
    assert prior.pooled == (True, True, False, True)
    assert "cx (disagrees with this placement)" in prior.reason
    assert prior.K[0, 2] == GIVEN[0, 2] and prior.prior_sigma[2] == GIVEN_SIGMA[2]
    assert abs(prior.K[0, 0] - THETA[0]) < 3 * prior.prior_sigma[0] * prior.K[0, 0]


def test_too_few_placements_or_a_pool_no_tighter_share_nothing():
    rng = np.random.default_rng(3)
    few = pooled_prior(draws(rng, MIN_OTHERS - 1), None, GIVEN, GIVEN_SIGMA)
    assert not few.any_pooled and f"at least {MIN_OTHERS} needed" in few.reason
    np.testing.assert_array_equal(few.K, GIVEN)
    loose = [(THETA + 0.1, np.array([5.0, 5.0, 9.0, 9.0]))] * 4  # each looser than the factory's 1.5 px and 3 px
    prior = pooled_prior(loose, None, GIVEN, GIVEN_SIGMA)
    assert not prior.any_pooled and "pool not tighter than given" in prior.reason


def test_second_pass_reports_against_the_given_matrix():
    from classic.markerless import MarkerlessOptions

    rng = np.random.default_rng(4)
    prior = pooled_prior(draws(rng, 6), None, GIVEN, GIVEN_SIGMA)
    opts = second_pass_options(MarkerlessOptions(), prior, started_near=True)
    assert opts.intrinsics_prior_sigma == prior.prior_sigma and max(opts.coarse_windows_m) <= 0.02
    far = second_pass_options(MarkerlessOptions(), prior, started_near=False)
    assert far.coarse_windows_m == MarkerlessOptions().coarse_windows_m
    pooled = intrinsics_vector(prior.K)
    estimate = pooled + 0.05
    sigma_px = np.array(prior.prior_sigma) * np.array([pooled[0], pooled[1], 1, 1])
    frames = np.array([0.3, 0.3, 0.2, 2.5])  # what the frames alone leave, pixels
    summary = {"model": "estimated", "given": pooled.tolist()}
    for i, name in enumerate(("fx", "fy", "cx", "cy")):
        summary[name] = {
            "estimate": estimate[i],
            "change": estimate[i] - pooled[i],
            "sigma": 0.1,
            "prior_sigma": sigma_px[i],
            "ratio": frames[i] / sigma_px[i],
            "determined": False,
        }
    told = against_given(summary, GIVEN, GIVEN_SIGMA, 0.5)
    given = intrinsics_vector(GIVEN)
    given_px = np.array(GIVEN_SIGMA) * np.array([given[0], given[1], 1, 1])
    assert told["prior"] == "shared" and told["given"] == pytest.approx(given.tolist())
    for i, name in enumerate(("fx", "fy", "cx", "cy")):
        assert told[name]["change"] == pytest.approx(estimate[i] - given[i], abs=FLOAT)
        assert told[name]["prior_mean"] == pytest.approx(pooled[i], abs=FLOAT)
        assert told[name]["ratio"] == pytest.approx(frames[i] / given_px[i])
        assert told[name]["determined"] == (frames[i] / given_px[i] < 0.5)
    assert [told[n]["determined"] for n in ("fx", "fy", "cx", "cy")] == [True, True, True, False]


def test_the_front_marginalises_a_per_cell_depth_error_only_where_it_shares():
    from classic.markerless import MarkerlessOptions
    from classic.markerless.shared_intrinsics import SHARED_PIXEL_EFFECT_PX
    from handeye.markerless_shared import shared_options

    opts = MarkerlessOptions()
    assert shared_options(opts, MIN_OTHERS + 1).pixel_effect_px == SHARED_PIXEL_EFFECT_PX
    assert shared_options(opts, MIN_OTHERS) is opts  # too few to share: as given
    fixed = replace(opts, intrinsics_model="fixed")
    assert shared_options(fixed, 10) is fixed  # nothing to share
    chosen = replace(opts, pixel_effect_px=3)
    assert shared_options(chosen, 10) is chosen  # the user's cell size kept


def test_leave_one_out_needs_enough_placements_and_writes_json():
    import json
    from types import SimpleNamespace

    from classic.markerless.shared_intrinsics import leave_one_out_priors

    rng = np.random.default_rng(5)

    def result(theta, sigma, ok=True):
        summary = {
            "model": "estimated",
            **{n: {"estimate": t, "sigma": s} for n, t, s in zip(("fx", "fy", "cx", "cy"), theta, sigma)},
        }
        return SimpleNamespace(ok=ok, intrinsics=summary)

    few = {c: result(*e) for c, e in enumerate(draws(rng, MIN_OTHERS))}
    few[MIN_OTHERS] = result(THETA, np.ones(4), ok=False)  # a refusal adds no estimate
    assert leave_one_out_priors(few, GIVEN, GIVEN_SIGMA) == {}
    enough = {c: result(*e) for c, e in enumerate(draws(rng, MIN_OTHERS + 1))}
    priors = leave_one_out_priors(enough, GIVEN, GIVEN_SIGMA)
    assert sorted(priors) == sorted(enough) and all(p.others == MIN_OTHERS for p in priors.values())
    json.dumps(priors[0].to_dict(), allow_nan=False)
    nothing = pooled_prior([], None, GIVEN, GIVEN_SIGMA).to_dict()  # NaN Birge ratios: null in JSON
    assert json.loads(json.dumps(nothing, allow_nan=False))["fx"]["birge"] is None


def test_second_passes_register_every_placement_again_from_the_first_answer():
    from types import SimpleNamespace

    from classic.markerless import MarkerlessOptions
    from classic.markerless.shared_intrinsics import MIN_OTHERS_OWN_SIGMA, SECOND_PASS_FINE_ITERATIONS, second_passes

    rng = np.random.default_rng(6)

    def result(theta, sigma, ok=True):
        summary = {
            "model": "estimated",
            **{n: {"estimate": t, "sigma": s} for n, t, s in zip(("fx", "fy", "cx", "cy"), theta, sigma)},
        }
        return SimpleNamespace(ok=ok, intrinsics=summary, T_base_cam=np.eye(4) * (2 if ok else 3))

    first = {c: result(*e) for c, e in enumerate(draws(rng, MIN_OTHERS + 2))}
    first[MIN_OTHERS + 2] = result(THETA, np.ones(4), ok=False)  # refused: pools nothing, is registered again
    calls = {}

    def register(c, K, starts, options):
        calls[c] = (K, starts, options)
        return SimpleNamespace(ok=False, name=f"second {c}")  # refused: returned as it is

    opts = MarkerlessOptions()
    out = second_passes(first, GIVEN, opts, register, only=iter([0, MIN_OTHERS + 2]))
    assert list(out) == [0, MIN_OTHERS + 2] and sorted(calls) == [0, MIN_OTHERS + 2]
    K0, starts0, opts0 = calls[0]
    prior0 = out[0][0]
    assert out[0][1].name == "second 0" and np.array_equal(K0, prior0.K)
    assert starts0["first pass"] is first[0].T_base_cam
    assert opts0.fine_iterations == min(opts.fine_iterations, SECOND_PASS_FINE_ITERATIONS)
    assert opts0.intrinsics_prior_sigma == prior0.prior_sigma
    # a pool of fewer than MIN_OTHERS_OWN_SIGMA others: the answer's sigma no narrower than under the stated prior
    assert prior0.any_pooled and prior0.others < MIN_OTHERS_OWN_SIGMA
    assert opts0.intrinsics_floor_prior_sigma == opts.intrinsics_prior_sigma
    _, starts_refused, opts_refused = calls[MIN_OTHERS + 2]
    assert starts_refused is None and opts_refused.fine_iterations == opts.fine_iterations
    # where nothing is pooled each is registered again all the same, under the given matrix and the stated prior
    # (its first pass was under the wider first_pass_options prior)
    few = {c: first[c] for c in range(MIN_OTHERS)}  # too few: every prior None
    calls.clear()
    assert all(p is None and r is not None for p, r in second_passes(few, GIVEN, opts, register).values())
    wide = {c: result(THETA, np.full(4, 100.0)) for c in range(MIN_OTHERS + 1)}  # a pool no tighter than given
    assert all(not p.any_pooled for p, _ in second_passes(wide, GIVEN, opts, register).values())
    assert sorted(calls) == list(range(MIN_OTHERS + 1))
    for K, _, options in calls.values():
        assert np.allclose(K, GIVEN) and options.intrinsics_prior_sigma == opts.intrinsics_prior_sigma
        assert options.intrinsics_floor_prior_sigma is None  # nothing pooled: the stated prior itself
    # enough others: the pooled pass's own sigma
    many = {c: result(*e) for c, e in enumerate(draws(rng, MIN_OTHERS_OWN_SIGMA + 1))}
    calls.clear()
    assert all(p.any_pooled for p, _ in second_passes(many, GIVEN, opts, register).values())
    assert all(options.intrinsics_floor_prior_sigma is None for _, _, options in calls.values())


def test_the_inverse_variance_mean_of_known_estimates():
    """Two estimates 1 and 3 of sigmas 1 and 1: mean 2, sigma 1/sqrt 2, Birge ratio sqrt(2) (each one sigma from
    the mean: chi-square 2 on 1 degree of freedom); a second column weighted 4:1 towards its first estimate."""
    from classic.markerless.shared_intrinsics import inverse_variance_mean

    mean, sigma, birge = inverse_variance_mean([[1.0, 0.0], [3.0, 5.0]], [[1.0, 1.0], [1.0, 2.0]])
    np.testing.assert_allclose(mean, [2.0, 1.0])
    np.testing.assert_allclose(sigma, [np.sqrt(0.5), np.sqrt(0.8)])
    np.testing.assert_allclose(birge, [np.sqrt(2.0), np.sqrt((1.0 + 16.0 / 4.0) / 1.0)])
    with pytest.raises(ValueError, match="at least 2 estimates"):
        inverse_variance_mean([[1.0, 0.0]], [[1.0, 1.0]])


def test_the_pool_counts_the_given_matrix_once():
    """Every first pass's estimate is a posterior under the given matrix's prior (+0.7 %, +3 px off; its sigma
    FIRST_PASS_PRIOR_TIMES the stated one) and holds ``sigma^2 / prior_sigma^2`` of its error. The pool takes that
    prior out of each and adds the stated prior once: its mean then holds ``sigma_pool^2 / given_sigma^2`` of the
    given error (one prior's share, ``sigma_pool`` the prior's reported sigma) and no more, within SIGMA_BOUND of
    the difference's standard error over the pools. Pooling the posteriors as they are kept 6.3 and 6.7 of those
    standard errors more in fx and fy (3.8 and 5.0 over 2000 pools, too few for fx)."""
    rng = np.random.default_rng(6)
    given = intrinsics_vector(GIVEN)
    given_px = np.array(GIVEN_SIGMA) * np.array([given[0], given[1], 1.0, 1.0])
    excess = []
    for _ in range(6000):
        prior = pooled_prior(draws(rng, 7), None, GIVEN, GIVEN_SIGMA)
        mean = intrinsics_vector(prior.K)
        sigma = np.array(prior.prior_sigma) * np.array([mean[0], mean[1], 1.0, 1.0])
        excess.append(mean - THETA - sigma**2 / given_px**2 * (given - THETA))
    excess = np.array(excess)
    assert np.all(np.abs(excess.mean(0)) <= SIGMA_BOUND * excess.std(0, ddof=1) / np.sqrt(len(excess)))


def test_first_passes_are_registered_under_a_wider_prior():
    from classic.markerless import MarkerlessOptions
    from classic.markerless.shared_intrinsics import first_pass_options

    opts = MarkerlessOptions(intrinsics_prior_sigma=GIVEN_SIGMA)
    wide = first_pass_options(opts)
    assert np.allclose(wide.intrinsics_prior_sigma, FIRST_PASS_PRIOR_TIMES * np.array(GIVEN_SIGMA))
    assert replace(wide, intrinsics_prior_sigma=GIVEN_SIGMA) == opts  # nothing else changed
    fixed = MarkerlessOptions(intrinsics_model="fixed")
    assert first_pass_options(fixed) is fixed  # nothing estimated: nothing to widen


def test_too_few_placements_are_returned_as_their_first_passes_are():
    """With MIN_OTHERS placements or fewer nothing is shared: their first passes were registered under the stated
    prior (the wider one is for placements that pool), so they are not registered again (the dataset is not even
    opened)."""
    from types import SimpleNamespace

    from classic.markerless import MarkerlessOptions
    from handeye.markerless_shared import share_intrinsics

    run = SimpleNamespace(results={c: object() for c in range(MIN_OTHERS)})
    assert share_intrinsics("no/such/dataset", run, options=MarkerlessOptions()) is run
