"""The per-pixel depth effect of the markerless fit (classic.markerless.pixel_effect): its elimination is the joint
solve's, and its sigma is recovered from residuals that carry a known one."""

from __future__ import annotations

import numpy as np

from classic.markerless.pixel_effect import compact_pixels, pixel_variance_components, reduced_rows, schur_reduction
from tests.tolerances import PIXEL_EFFECT_SCHUR_RTOL, PIXEL_EFFECT_SIGMA_SDS


def _problem(rng, n_pixels=40, per_pixel=6, n_par=5):
    pixel = np.repeat(np.arange(n_pixels), per_pixel)
    J = rng.normal(size=(len(pixel), n_par))
    g = rng.uniform(0.5, 1.5, size=len(pixel))
    r = rng.normal(size=len(pixel))
    w = rng.uniform(0.5, 1.0, size=len(pixel))
    return J, r, w, g, pixel


def test_schur_reduction_is_the_joint_solve():
    """The step of the reduced normal equations equals the pose part of the joint solve with one unknown per pixel
    under the prior ``variance / sigma_p^2``; the rows with each pixel's estimate taken out are the joint
    residuals."""
    rng = np.random.default_rng(0)
    J, r, w, g, pixel = _problem(rng)
    sigma_p, variance = 0.7, 1.3
    n_pix, n_par = pixel.max() + 1, J.shape[1]
    # the joint system: columns [J | g at the pixel's column]
    A = np.zeros((len(r), n_par + n_pix))
    A[:, :n_par] = J
    A[np.arange(len(r)), n_par + pixel] = g
    H = (A * w[:, None]).T @ A
    H[n_par:, n_par:] += np.eye(n_pix) * variance / sigma_p**2
    x_joint = -np.linalg.solve(H, (A * w[:, None]).T @ r)
    dH, dg, pix, coef = schur_reduction(J, r, w, g, pixel, sigma_p, variance)
    H6, g6 = (J * w[:, None]).T @ J - dH, (J * w[:, None]).T @ r - dg
    xi = -np.linalg.solve(H6, g6)
    np.testing.assert_allclose(xi, x_joint[:n_par], rtol=PIXEL_EFFECT_SCHUR_RTOL)
    # each pixel's effect at that step: -(c_p + b_p . xi) / a_p, the joint solve's
    effect = -(coef[:, -1] + coef[:, :-1] @ xi)
    np.testing.assert_allclose(effect, x_joint[n_par:], rtol=PIXEL_EFFECT_SCHUR_RTOL)
    J_red, r_red = reduced_rows(J, r, g, pix, coef)
    assert J_red.shape == J.shape and r_red.shape == r.shape


def test_sigma_recovered_and_zero_without_effect():
    """Residuals ``g e_p + noise`` with ``e_p ~ N(0, sigma_p^2)``: the method of moments gives ``sigma_p`` within
    its sampling spread; without an effect, a sigma within that spread of 0."""
    rng = np.random.default_rng(1)
    n_pixels, per_pixel, sigma_p, noise = 3000, 8, 0.002, 0.003
    pixel = np.repeat(np.arange(n_pixels), per_pixel)
    g = rng.uniform(0.5, 2.0, size=len(pixel))
    w = np.ones(len(pixel))
    effect = rng.normal(0.0, sigma_p, n_pixels)
    # the estimate of sigma^2 is a mean over pixels of e_hat^2 - its noise: each term's std is about
    # sqrt(2) (sigma_p^2 + noise^2 / sum g^2), so the mean's is that over sqrt(n_pixels)
    mean_gg = per_pixel * np.mean(g**2)
    spread = np.sqrt(2.0) * (sigma_p**2 + noise**2 / mean_gg) / np.sqrt(n_pixels)
    r = g * effect[pixel] + rng.normal(0.0, noise, len(pixel))
    got = pixel_variance_components(r, w, g, pixel)[0]
    assert abs(got**2 - sigma_p**2) < PIXEL_EFFECT_SIGMA_SDS * spread
    r0 = rng.normal(0.0, noise, len(pixel))
    spread0 = np.sqrt(2.0) * (noise**2 / mean_gg) / np.sqrt(n_pixels)
    assert pixel_variance_components(r0, w, g, pixel)[0] ** 2 < PIXEL_EFFECT_SIGMA_SDS * spread0


def test_compact_pixels_is_uniques_inverse():
    """Any ids are numbered as np.unique numbers them; ids already numbered 0..n-1 come back as they are."""
    rng = np.random.default_rng(4)
    ids = rng.choice([7, 300, 12, 5000], size=50)
    assert np.array_equal(compact_pixels(ids), np.unique(ids, return_inverse=True)[1])
    compact = rng.permutation(np.repeat(np.arange(10), 3))
    assert compact_pixels(compact) is compact
    assert np.array_equal(compact_pixels(np.array([0, 2, 2])), [0, 1, 1])  # 1 missing: numbered again
