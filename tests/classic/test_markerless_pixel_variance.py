"""The per-pixel effect's variance components (classic.markerless.pixel_effect): residuals with a known effect per
pixel (the same in every frame) and a known temporal noise are split into the two (one-way random effects, the
ANOVA estimator), and the prior the point-to-plane fit builds from them (``variance / sigma_p^2`` in
:func:`classic.markerless.pixel_effect.schur_reduction`) is the true ratio of the noise to the effect."""

from __future__ import annotations

import numpy as np

from classic.markerless import pixel_effect
from classic.markerless.point_to_plane import _pixel_reduction
from tests.tolerances import EXACT, PIXEL_VARIANCE_SPLIT_SDS

N_PIXELS, PER_PIXEL, SIGMA_P, NOISE = 3000, 6, 0.002, 0.003  # effect metres at 1 m, noise metres
OUTLIER_SHARE = 0.02  # matches with robust weight 0 and a residual far off: the estimator must ignore them


def _residuals(seed: int = 3):
    """Camera-frame points with depth 0.8-1.4 m seen along their normal (gain ``z^2``), residuals ``g e_p + noise``,
    and the design's expected spreads of the estimates (from the gains and the counts, not from the draw)."""
    rng = np.random.default_rng(seed)
    pixel = np.repeat(np.arange(N_PIXELS), PER_PIXEL)
    n = len(pixel)
    z = rng.uniform(0.8, 1.4, n)
    p_cam = np.column_stack([rng.uniform(-0.3, 0.3, n) * z, rng.uniform(-0.3, 0.3, n) * z, z])
    n_cam = np.tile([0.0, 0.0, 1.0], (n, 1))
    g = pixel_effect.pixel_gain(n_cam, p_cam)  # z^2
    r = g * rng.normal(0.0, SIGMA_P, N_PIXELS)[pixel] + rng.normal(0.0, NOISE, n)
    w = np.ones(n)
    out = rng.random(n) < OUTLIER_SHARE
    w[out], r[out] = 0.0, 0.5
    # the spreads: within, SSW ~ NOISE^2 chi^2(N_in - k); between, per pixel s_p e_hat_p^2 ~ (s_p SIGMA_P^2 + NOISE^2)
    # chi^2(1), independent of SSW; sigma_p^2 = (sum s_p e_hat_p^2 - k v) / S
    s = np.bincount(pixel, w * g * g, minlength=N_PIXELS)
    k, S, dof = N_PIXELS, s.sum(), w.sum() - N_PIXELS
    var_v = 2.0 * NOISE**4 / dof
    var_s2 = (2.0 * np.sum((s * SIGMA_P**2 + NOISE**2) ** 2) + k**2 * var_v) / S**2
    cov = -k * var_v / S  # sigma_p^2 takes k v out
    var_log_ratio = var_v / NOISE**4 + var_s2 / SIGMA_P**4 - 2.0 * cov / (NOISE**2 * SIGMA_P**2)
    spreads = {"v": np.sqrt(var_v), "sigma_p2": np.sqrt(var_s2), "log_ratio": np.sqrt(var_log_ratio)}
    return p_cam, n_cam, r, w, g, pixel, spreads


def test_components_recovered():
    """The within-pixel mean square recovers the temporal noise's variance, the between-pixel one less it the effect's
    variance, each within its standard error."""
    _, _, r, w, g, pixel, spread = _residuals()
    sigma_p, variance = pixel_effect.pixel_variance_components(r, w, g, pixel)
    assert abs(variance - NOISE**2) < PIXEL_VARIANCE_SPLIT_SDS * spread["v"]
    assert abs(sigma_p**2 - SIGMA_P**2) < PIXEL_VARIANCE_SPLIT_SDS * spread["sigma_p2"]


def test_reduction_prior_is_noise_over_effect():
    """The prior of each pixel's effect in the fit's reduction, ``a_p - sum w g^2``, is ``NOISE^2 / SIGMA_P^2``: the
    temporal noise over the effect, not the residuals' total variance (which holds the effect too) over it."""
    p_cam, n_cam, r, w, g, pixel, spread = _residuals()
    rng = np.random.default_rng(4)
    J = np.column_stack([rng.normal(size=(len(r), 3)), n_cam])  # the translation's columns are n_cam
    reduction = _pixel_reduction(p_cam, J, r, w, pixel)
    assert reduction is not None
    coef = reduction[4]
    # the column J[:, 5] = 1: b_p = sum w g, coef = b_p / a_p
    b = np.bincount(pixel, w * g, minlength=N_PIXELS)
    s = np.bincount(pixel, w * g * g, minlength=N_PIXELS)
    prior = b / coef[:, 5] - s
    np.testing.assert_allclose(prior, prior[0], rtol=EXACT)  # one prior for every pixel
    log_ratio = np.log(prior[0] / (NOISE**2 / SIGMA_P**2))
    assert abs(log_ratio) < PIXEL_VARIANCE_SPLIT_SDS * spread["log_ratio"]
