"""One camera's intrinsics shared by its placements: the others' estimates pooled into one placement's prior.

A camera's matrix does not change when the camera is moved, but one placement's depth frames pin its focal
length poorly: a focal length off by a fraction of a percent, the distance along the optical axis and the depth
offset move the arm's points alike, so the estimate's error (0.2 % at 1.2 m) becomes millimetres along the axis.
Several placements of the same camera each estimate ``(f_x, f_y, c_x, c_y)`` from different geometry; their
information-weighted mean is a prior no single placement has. This module builds that prior for one placement
from the *other* placements' estimates (leave one out, so the placement's own frames are not counted twice):

- per parameter, the inverse-variance weighted mean of the others and its sigma, widened by the Birge ratio
  (the root of the scatter's chi-square per degree of freedom) where the estimates disagree a little beyond
  their sigmas; where they scatter beyond what chance allows (:data:`SPREAD_QUANTILE`: a unit whose
  depth-to-colour shift moved between placements, a fixed pattern pulling each one differently), the placements'
  values differ by a spread of their own, and the prior is where one more placement's value may lie: the mean
  give or take that spread (:func:`_weighted_pool`);
- a parameter is pooled only where the placement's own estimate agrees with the pool within ``conflict_sigmas``
  combined sigmas; where it does not, that parameter keeps the camera matrix given and its stated prior, and the
  prior says so (a camera re-registered, or a different unit, is not averaged in);
- with fewer than ``min_others`` other placements nothing is pooled;
- the given camera matrix's prior counts once: the first passes are registered under a prior
  :data:`FIRST_PASS_PRIOR_TIMES` wider (:func:`first_pass_options`), each estimate has that prior taken out before
  it is pooled (:func:`_without_prior`), and the stated prior joins the pool's once. Each first pass under the
  stated prior keeps a share of the given matrix's error, and the pool would keep it too, at a sigma many times
  smaller: the pooled answers then moved with the sign of the factory's error.

The registration then runs again with the pooled matrix as the prior's mean and the pooled sigmas as its
sigmas (:func:`second_pass_options`): an ordinary prior, so the pose's covariance carries what is left of the
intrinsics' uncertainty. Measured in ``docs/benchmarks/markerless.md`` ('Intrinsics shared by the placements').
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from scipy import stats

from classic.markerless.intrinsics import NAMES, camera_matrix, intrinsics_vector, prior_sigma_px
from classic.markerless.options import MarkerlessOptions

__all__ = [
    "SharedIntrinsicsPrior",
    "pooled_prior",
    "second_pass_options",
    "estimate_and_sigma",
    "against_given",
    "intrinsics_estimates",
    "leave_one_out_priors",
    "second_passes",
    "inverse_variance_mean",
    "MIN_OTHERS",
    "MIN_OTHERS_OWN_SIGMA",
    "SPREAD_QUANTILE",
    "SHARED_PIXEL_EFFECT_PX",
    "FIRST_PASS_PRIOR_TIMES",
    "first_pass_options",
]

#: Other placements' estimates a pool needs: the scatter's chi-square then has at least 2 degrees of freedom.
MIN_OTHERS = 3

#: Other placements a pool needs for its answers to keep their own sigma; with fewer, each answer's sigma is kept no
#: narrower than under the stated prior (:attr:`MarkerlessOptions.intrinsics_floor_prior_sigma`). The pool's sigma
#: trusts the placements' own sigmas except where their scatter shows more (the Birge ratio, the spread), and the
#: scatter of k estimates measures that ratio to a relative sd of about ``1 / sqrt(2 (k - 1))``: 0.41 at 4, a quarter
#: from 9. Measured on `paper-real-noisy` (white depth noise, the camera matrix given exactly): 4 others, the five test
#: placements' answers shared a 0.26 mm error along the optical axis at sigmas of 0.10, the errors' RMS 2.18 of their
#: sigmas; 23 others, 0.045 mm and 0.86 (``docs/benchmarks/markerless.md``, 'The pooled sigma, the pool's own').
MIN_OTHERS_OWN_SIGMA = 9

#: The placements' estimates of a parameter differ by a spread of their own (a depth image shifted against the
#: camera model by each unit's amount) where their scatter's chi-square exceeds this quantile: chance alone puts it
#: there once in twenty pools of one camera, per parameter.
SPREAD_QUANTILE = 0.95

#: The first passes of placements that will pool their intrinsics are registered under the given camera matrix's
#: prior this many times wider (:func:`first_pass_options`), and the pool takes that prior out of each estimate
#: and adds the stated one once (:func:`pooled_prior`). Under the stated prior each first pass keeps a share of the
#: given matrix's error, and the pool keeps it at a sigma many times smaller: measured on `paper-real`'s all-together
#: case, 0.11-0.12 of a +0.7 % focal-length error per placement (0.16-0.27 under the fit that takes the noise's
#: bias out, whose frames hold the focal length less tightly), which moved the pooled answers along the optical axis
#: by the sign of the factory's error (the camera matrix -0.7 % instead of +0.7 %: 2.08 mm median against 0.93).
#: Three times wider leaves a ninth of it, and the rest is what the linear taking-out removes.
FIRST_PASS_PRIOR_TIMES = 3.0

#: Coarse windows of a second pass started from the first's answer: it is within millimetres already.
SECOND_PASS_WINDOWS_M = (0.02, 0.01)
#: Fine gates of that second pass: its matches are those of a converged answer, the wide gates only slow it.
SECOND_PASS_GATES_M = (0.01,)
#: Fine iterations of that second pass (the first's 20 start from centimetres off).
SECOND_PASS_FINE_ITERATIONS = 10
#: The per-cell depth error (:attr:`MarkerlessOptions.pixel_effect_px`) the front marginalises, in both passes,
#: where the placements share their intrinsics. Alone it is off (it worsened one row of the error table); with the
#: intrinsics shared every row stays within 0.13 mm of sharing without it or improves (all together 2.45 -> 1.18 mm
#: median on paper-real, 1.26 -> 0.74 on paper-sim), 0 beyond 3 sigma, at most 9.6 s of CPU per placement
#: (``docs/benchmarks/markerless.md``, 'Intrinsics shared by the placements').
SHARED_PIXEL_EFFECT_PX = 2


@dataclass(frozen=True)
class SharedIntrinsicsPrior:
    """The prior one placement takes from the others.

    Attributes
    ----------
    K : array, shape (3, 3)
        The prior's mean: the pooled parameters, the given camera matrix's elsewhere.
    prior_sigma : tuple of 4 float
        ``(f_x, f_y)`` relative, ``(c_x, c_y)`` pixels, as :attr:`MarkerlessOptions.intrinsics_prior_sigma`.
    pooled : tuple of 4 bool
        Per parameter of :data:`classic.markerless.intrinsics.NAMES`, whether it was pooled.
    others : int
        How many other placements' estimates entered.
    birge : tuple of 4 float
        The others' scatter over their sigmas (root chi-square per degree of freedom; 1 where consistent).
    spread : tuple of 4 float
        Pixels: where the others scatter beyond chance, how much their values themselves differ
        (:func:`_weighted_pool`), which the prior's sigma holds; 0 elsewhere.
    reason : str
        Why a parameter was not pooled, empty when all were.
    """

    K: np.ndarray
    prior_sigma: tuple
    pooled: tuple
    others: int
    birge: tuple
    reason: str = ""
    spread: tuple = (0.0, 0.0, 0.0, 0.0)

    @property
    def any_pooled(self) -> bool:
        return any(self.pooled)

    def to_dict(self) -> dict:
        """JSON-serialisable: the prior's mean and sigma per parameter, what was pooled, from how many."""
        theta = intrinsics_vector(self.K)
        sigma_px = prior_sigma_px(self.prior_sigma, theta)
        return {
            "others": self.others,
            "reason": self.reason,
            **{
                name: {
                    "pooled": bool(self.pooled[i]),
                    "mean": float(theta[i]),
                    "sigma": float(sigma_px[i]),
                    "birge": float(self.birge[i]) if np.isfinite(self.birge[i]) else None,
                    "spread": float(self.spread[i]),
                }
                for i, name in enumerate(NAMES)
            },
        }


def estimate_and_sigma(intrinsics: dict) -> tuple[np.ndarray, np.ndarray] | None:
    """``(theta, sigma)``, shape (4,) each in pixels, of a result's intrinsics summary; None when not estimated.

    Parameters
    ----------
    intrinsics : dict
        :attr:`MarkerlessResult.intrinsics` (``model`` ``"estimated"`` with per-parameter ``estimate`` and
        ``sigma``).
    """
    if not intrinsics or intrinsics.get("model") != "estimated":
        return None
    theta = np.array([intrinsics[n]["estimate"] for n in NAMES], dtype=float)
    sigma = np.array([intrinsics[n]["sigma"] for n in NAMES], dtype=float)
    if not (np.all(np.isfinite(theta)) and np.all(np.isfinite(sigma)) and np.all(sigma > 0)):
        return None
    return theta, sigma


def intrinsics_estimates(results: dict) -> dict:
    """Per accepted placement of ``results`` (placement -> :class:`MarkerlessResult`) that estimated the
    intrinsics: ``(theta, sigma)`` (:func:`estimate_and_sigma`)."""
    estimates = {c: estimate_and_sigma(r.intrinsics) for c, r in results.items() if r.ok}
    return {c: e for c, e in estimates.items() if e is not None}


def leave_one_out_priors(results: dict, K_given: np.ndarray, given_sigma: tuple) -> dict:
    """Per placement of ``results`` (placement -> first-pass :class:`MarkerlessResult`), the prior the others'
    estimates give it (:func:`pooled_prior`); empty with ``MIN_OTHERS`` or fewer estimates (nothing to share)."""
    estimates = intrinsics_estimates(results)
    if len(estimates) <= MIN_OTHERS:
        return {}
    return {
        c: pooled_prior([e for o, e in estimates.items() if o != c], estimates.get(c), K_given, given_sigma)
        for c in results
    }


def second_passes(first: dict, K_given: np.ndarray, options: MarkerlessOptions, register, only=None) -> dict:
    """Placements of one camera registered again, each under the prior the other placements' estimates give it.

    Parameters
    ----------
    first : dict
        Placement -> its first pass (:class:`classic.markerless.result.MarkerlessResult`), registered under
        :func:`first_pass_options` of ``options``: every placement of the camera, all of them pooled.
    K_given : array, shape (3, 3)
        The camera matrix the first passes were given.
    options : MarkerlessOptions
        The options as stated (the first passes' before :func:`first_pass_options`).
    register : callable
        ``register(c, K, starts, options)`` -> :class:`MarkerlessResult`: placement ``c`` registered with the camera
        matrix ``K`` (the pooled prior's mean) from ``starts`` (``{"first pass": T_base_cam}``, or None where the
        first pass was refused) under ``options`` (:func:`second_pass_options`).
    only : iterable, optional
        The placements registered again (all of ``first`` by default; an iterable such as a progress bar is read
        once); the others still pool.

    Returns
    -------
    dict
        Placement -> ``(prior, result)``: the :class:`SharedIntrinsicsPrior` (None with too few placements), and the
        second pass's result. Where nothing was pooled the second pass is under the given camera matrix and the
        stated prior, so that every answer is under the prior the options state, not the first pass's wider one.
    """
    priors = leave_one_out_priors(first, K_given, options.intrinsics_prior_sigma)
    out = {}
    for c in first if only is None else only:
        prior = priors.get(c)
        started_near = first[c].ok
        starts = {"first pass": first[c].T_base_cam} if started_near else None
        K = K_given if prior is None else prior.K
        second = register(c, K, starts, second_pass_options(options, prior, started_near))
        out[c] = (prior, second)
    return out


def pooled_prior(
    others: list[tuple[np.ndarray, np.ndarray]],
    own: tuple[np.ndarray, np.ndarray] | None,
    K_given: np.ndarray,
    given_sigma: tuple,
    *,
    conflict_sigmas: float = 3.0,
    min_others: int = MIN_OTHERS,
) -> SharedIntrinsicsPrior:
    """The prior of one placement's intrinsics from the other placements' estimates of the same camera.

    Parameters
    ----------
    others : list of (array (4,), array (4,))
        The other placements' ``(theta, sigma)`` (:func:`estimate_and_sigma`), pixels.
    own : (array (4,), array (4,)) or None
        This placement's own first estimate; None when it had none (refused), then every parameter of an
        adequate pool is taken.
    K_given : array, shape (3, 3)
        The camera matrix given.
    given_sigma : tuple of 4 float
        Its stated prior (:attr:`MarkerlessOptions.intrinsics_prior_sigma`: focal lengths relative, principal
        point pixels).
    conflict_sigmas : float
        A parameter whose own estimate lies further than this many combined sigmas from the pool is not pooled.
    min_others : int
        Fewer other placements than this: nothing pooled.

    Returns
    -------
    SharedIntrinsicsPrior
    """
    given = intrinsics_vector(np.asarray(K_given, dtype=float))
    given_px = prior_sigma_px(given_sigma, given)
    if len(others) < min_others:
        reason = f"{len(others)} other placements estimated the intrinsics (at least {min_others} needed)"
        return _prior(given, given_px, np.zeros(4, bool), len(others), np.full(4, np.nan), reason)
    wide = FIRST_PASS_PRIOR_TIMES * given_px  # the prior the first passes were registered under
    mean, sigma, birge, spread = _weighted_pool([_without_prior(t, sd, given, wide) for t, sd in others])
    tighter = sigma < given_px  # the frames' pool no tighter than the given prior adds nothing
    use = tighter.copy()
    # the given prior once: each estimate's share of it was taken out above
    precision = 1 / sigma**2 + 1 / given_px**2
    mean, sigma = (mean / sigma**2 + given / given_px**2) / precision, 1 / np.sqrt(precision)
    if own is not None:
        use &= np.abs(own[0] - mean) <= conflict_sigmas * np.hypot(own[1], sigma)
    reason = ", ".join(
        f"{name} ({'disagrees with this placement' if tighter[i] else 'pool not tighter than given'})"
        for i, name in enumerate(NAMES)
        if not use[i]
    )
    reason = f"not pooled: {reason}" if reason else ""
    pooled = (np.where(use, mean, given), np.where(use, sigma, given_px))
    return _prior(*pooled, use, len(others), birge, reason, spread=np.where(use, spread, 0.0))


def _without_prior(theta, sigma, given, given_px):
    """One placement's estimate ``(theta, sigma)`` with the given camera matrix's prior (mean ``given``, sigma
    ``given_px``) taken out: what its frames alone say, ``(d, s)`` (where they said nothing, the given value at no
    weight).

    Each estimate is a posterior under the same prior, and holds about ``sigma^2 / given_px^2`` of the given
    matrix's error; an inverse-variance mean of such estimates keeps that share at a sigma many times smaller
    (:data:`FIRST_PASS_PRIOR_TIMES`). The frames' precision is the posterior's less the prior's, ``1 / s^2 = 1 /
    sigma^2 - 1 / given_px^2``, and ``d`` the frames' mean, ``(theta / sigma^2 - given / given_px^2) s^2``.
    """
    precision = 1 / sigma**2 - 1 / given_px**2
    seen = precision > 1e-6 / given_px**2  # else the frames said nothing: no weight in the pool
    precision = np.where(seen, precision, 1e-12 / given_px**2)
    return np.where(seen, (theta / sigma**2 - given / given_px**2) / precision, given), 1 / np.sqrt(precision)


def inverse_variance_mean(values, sigmas) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per column, the inverse-variance weighted mean of independent estimates, its sigma and their Birge ratio.

    Parameters
    ----------
    values, sigmas : array, shape (n, p)
        ``n >= 2`` estimates of ``p`` parameters and their sigmas (> 0).

    Returns
    -------
    mean, sigma, birge : array, shape (p,)
        The mean, its sigma from the estimates' sigmas alone, and the root of the scatter's chi-square per degree
        of freedom (``n - 1``): 1 where the estimates agree as their sigmas say, above where they scatter more.
    """
    values, weight = np.asarray(values, dtype=float), 1.0 / np.asarray(sigmas, dtype=float) ** 2
    if len(values) < 2:  # the scatter has n - 1 degrees of freedom
        raise ValueError(f"the Birge ratio needs at least 2 estimates, got {len(values)}")
    mean = (values * weight).sum(axis=0) / weight.sum(axis=0)
    birge = np.sqrt(((values - mean) ** 2 * weight).sum(axis=0) / (len(values) - 1))
    return mean, 1.0 / np.sqrt(weight.sum(axis=0)), birge


def _weighted_pool(others: list) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The prior ``others``' estimates give one more placement: its mean and sigma, the estimates' Birge ratio
    and the spread of their values (0 where it is not counted); shape (4,) each, pixels.

    Where the estimates agree within their sigmas, the inverse-variance mean and its sigma widened by the Birge ratio
    (at least 1). Where they scatter beyond what their sigmas allow (the scatter's chi-square ``Q`` above its
    :data:`SPREAD_QUANTILE` quantile), the placements' values themselves differ by a spread ``tau`` the sigmas do
    not hold (DerSimonian-Laird: ``tau^2 = (Q - (n - 1)) / (S1 - S2 / S1)``, ``Q`` the
    scatter's chi-square, ``S1``, ``S2`` the sums of the weights and of their squares): the mean weighs each
    estimate by ``1 / (sigma^2 + tau^2)``, and the prior for one more placement is that mean give or take
    ``sqrt(sigma_mean^2 + tau^2)``, where the next placement's own value may lie. Widening the mean's sigma by the
    Birge ratio instead would claim the placement's value to a fraction of the spread: with a depth image shifted by
    its own 1 px per unit, it pulled each placement's well-measured principal point towards the others' mean.
    """
    # written here rather than taken from statsmodels' meta-analysis: classic/ needs only numpy and scipy, and the
    # estimator is these four lines
    values = np.array([t for t, _ in others], dtype=float)
    sigmas = np.array([s for _, s in others], dtype=float)
    mean, sigma, birge = inverse_variance_mean(values, sigmas)
    weight = 1.0 / sigmas**2
    s1 = weight.sum(axis=0)
    chi2 = (birge**2) * (len(values) - 1)  # Q: the Birge ratio is sqrt(Q / (n - 1))
    tau2 = np.maximum((chi2 - (len(values) - 1)) / (s1 - (weight**2).sum(axis=0) / s1), 0.0)
    spread = chi2 > stats.chi2.ppf(SPREAD_QUANTILE, len(values) - 1)
    weight = 1.0 / (sigmas**2 + tau2)
    birge = np.maximum(birge, 1.0)
    mean = np.where(spread, (values * weight).sum(axis=0) / weight.sum(axis=0), mean)
    sigma = np.where(spread, np.sqrt(1.0 / weight.sum(axis=0) + tau2), birge * sigma)
    return mean, sigma, birge, np.where(spread, np.sqrt(tau2), 0.0)


def _prior(mean_px, sigma_px, use, others: int, birge, reason: str, spread=(0.0,) * 4) -> SharedIntrinsicsPrior:
    """A :class:`SharedIntrinsicsPrior` of the per-parameter mean, sigma and spread in pixels (the focal lengths'
    sigma made relative to the mean)."""
    return SharedIntrinsicsPrior(
        K=camera_matrix(mean_px),
        prior_sigma=(
            float(sigma_px[0] / mean_px[0]),
            float(sigma_px[1] / mean_px[1]),
            float(sigma_px[2]),
            float(sigma_px[3]),
        ),
        pooled=tuple(bool(u) for u in use),
        others=others,
        birge=tuple(float(b) for b in birge),
        reason=reason,
        spread=tuple(float(x) for x in spread),
    )


def first_pass_options(options: MarkerlessOptions) -> MarkerlessOptions:
    """The options of a first pass whose estimate a pool will take: ``options`` with the intrinsics' prior
    :data:`FIRST_PASS_PRIOR_TIMES` times wider (as they are where the intrinsics are taken as exact)."""
    if options.intrinsics_model != "estimate":
        return options
    return replace(
        options, intrinsics_prior_sigma=tuple(FIRST_PASS_PRIOR_TIMES * s for s in options.intrinsics_prior_sigma)
    )


def second_pass_options(
    options: MarkerlessOptions, prior: SharedIntrinsicsPrior | None, started_near: bool
) -> MarkerlessOptions:
    """The registration's options for its second pass under ``prior``.

    Parameters
    ----------
    options : MarkerlessOptions
        As stated (the first passes' before :func:`first_pass_options`).
    prior : SharedIntrinsicsPrior or None
        None: the stated prior (too few placements to pool). The answer's sigma is the second pass's own, under the
        pooled prior, where at least :data:`MIN_OTHERS_OWN_SIGMA` other placements pooled; with fewer, it is kept no
        narrower than under the stated prior (:attr:`MarkerlessOptions.intrinsics_floor_prior_sigma`): a few
        placements' agreement cannot show that their own sigmas are short, and their pooled answers then share the
        pool's error. Until 8934628 every pooled answer was floored at its first pass's sigma; since the fit takes
        the depth noise's bias out (c7d6e2a) that floor made the sigmas of large pools two to four times their errors
        (``docs/benchmarks/markerless.md``, 'The pooled sigma, the pool's own').
    started_near : bool
        The second pass starts from the first's accepted answer: only the finest coarse windows
        (:data:`SECOND_PASS_WINDOWS_M`) are searched, and the fine stage starts at the finest gate
        (:data:`SECOND_PASS_GATES_M`) and iterates at most :data:`SECOND_PASS_FINE_ITERATIONS` times.
    """
    out = options if prior is None else replace(options, intrinsics_prior_sigma=prior.prior_sigma)
    if prior is not None and prior.any_pooled and prior.others < MIN_OTHERS_OWN_SIGMA:
        out = replace(out, intrinsics_floor_prior_sigma=options.intrinsics_prior_sigma)
    if started_near:
        out = replace(
            out,
            coarse_windows_m=SECOND_PASS_WINDOWS_M,
            fine_gates_m=SECOND_PASS_GATES_M,
            fine_iterations=min(options.fine_iterations, SECOND_PASS_FINE_ITERATIONS),
        )
    return out


def against_given(intrinsics: dict, K_given: np.ndarray, given_sigma: tuple, determined_share: float) -> dict:
    """A second pass's intrinsics summary told against the camera matrix given, not the pooled prior.

    The registration reports each parameter's ``change`` from its prior's mean and ``ratio`` (what the frames
    leave of the sigma) against its prior's sigma; under a pooled prior both would count from the pool. Here
    they count from ``K_given`` and ``given_sigma`` again, so that ``determined`` keeps its meaning (the frames
    alone pinned the parameter below ``determined_share`` of the stated uncertainty); the pooled prior is kept
    as ``prior_mean`` and ``prior_sigma``, and ``prior`` is ``"shared"``.

    Parameters
    ----------
    intrinsics : dict
        :attr:`MarkerlessResult.intrinsics` of the second pass (``model`` ``"estimated"``).
    K_given : array, shape (3, 3)
    given_sigma : tuple of 4 float
        Focal lengths relative, principal point pixels.
    determined_share : float
        :attr:`MarkerlessOptions.intrinsics_determined_share`.

    Returns
    -------
    dict
        A new summary; ``intrinsics`` itself unchanged (returned as is when not estimated).
    """
    if not intrinsics or intrinsics.get("model") != "estimated":
        return intrinsics
    given = intrinsics_vector(np.asarray(K_given, dtype=float))
    given_px = prior_sigma_px(given_sigma, given)
    out = {"model": "estimated", "prior": "shared", "given": [float(x) for x in given]}
    for i, name in enumerate(NAMES):
        entry = dict(intrinsics[name])
        frames_sigma = entry["ratio"] * entry["prior_sigma"]
        entry["prior_mean"] = entry["estimate"] - entry["change"]
        entry["change"] = entry["estimate"] - float(given[i])
        entry["ratio"] = float(frames_sigma / given_px[i])
        entry["determined"] = bool(entry["ratio"] < determined_share)
        out[name] = entry
    return out
