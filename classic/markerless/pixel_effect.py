"""A depth error the same in every frame at one image pixel (a sensor's fixed pattern), marginalised from the fit.

A depth sensor's fixed-pattern error ``e_p z^2`` at pixel ``p`` repeats in every frame where the arm covers
``p``. The frames then do not average it: the arm's pixels over all frames sample the pattern only as many times
as there are distinct pixels, and a pattern correlated over a few pixels pulls the weakly determined direction of
the fit (focal length, distance along the optical axis and depth offset move the arm alike) by tenths of a
percent. Modelled as one unknown ``e_p`` per pixel under a Gaussian prior of sigma ``sigma_p`` (metres at
1 m), each match's residual moves by ``g_i e_p`` with ``g_i = (n_cam . r_i) z_i^2`` (its normal along its ray
times its depth squared). The per-pixel unknowns are eliminated in closed form (Schur complement), so the fit
keeps its few parameters: the information of pixel ``p``'s matches is reduced by
``b_p b_p^T / a_p`` with ``a_p = sum w g^2 + v / sigma_p^2`` and ``b_p = sum w g J`` (``v`` the residuals' temporal
variance, the part that does not repeat at a pixel: the units of ``J^T W J``). Where the pixel's matches differ in
depth and normal across frames, the pose is still determined by them; what they share is not counted again.
``sigma_p`` and ``v`` are measured from the residuals, split into the spread of the per-pixel estimates beyond
their own noise and the scatter within a pixel (:func:`pixel_variance_components`); the residuals' total
variance holds the effect as well, and in place of ``v`` it would make the prior too tight.
"""

from __future__ import annotations

import numpy as np

__all__ = ["compact_pixels", "pixel_gain", "pixel_variance_components", "schur_reduction", "reduced_rows"]


def pixel_gain(n_cam: np.ndarray, q_obs: np.ndarray) -> np.ndarray:
    """Each residual's change per metre-at-1-m of its pixel's depth error: ``(n_cam . r) z^2``.

    Parameters
    ----------
    n_cam : array, shape (N, 3)
        Residual gradient in the camera frame (the model normal, camera frame).
    q_obs : array, shape (N, 3)
        Observed points as the sensor reports them, camera frame (``z > 0``).

    Returns
    -------
    array, shape (N,)
    """
    z = q_obs[:, 2]
    return np.einsum("ij,ij->i", n_cam, q_obs) * z  # (n . q / z) z^2


def compact_pixels(pixel: np.ndarray) -> np.ndarray:
    """Pixel ids numbered 0..n-1 in their sorted order (``np.unique``'s inverse); ids already so numbered are
    returned as they are, without the sort (a fit compacts its matches' pixels once, not at every iteration).

    Parameters
    ----------
    pixel : array of int, shape (N,)

    Returns
    -------
    array of int, shape (N,)
    """
    pixel = np.asarray(pixel)
    # compact ids are at most N - 1: that bound first, so that large ids never size the count
    if len(pixel) and pixel.min() >= 0 and pixel.max() < len(pixel) and np.bincount(pixel).all():
        return pixel
    return np.unique(pixel, return_inverse=True)[1]


def _per_pixel(pixel: np.ndarray, values: np.ndarray, n: int) -> np.ndarray:
    """Sums of ``values`` (N,) or (N, K) per pixel index (0..n-1)."""
    if values.ndim == 1:
        return np.bincount(pixel, values, minlength=n)
    return np.stack([np.bincount(pixel, values[:, k], minlength=n) for k in range(values.shape[1])], axis=1)


def pixel_variance_components(
    r: np.ndarray, w: np.ndarray, g: np.ndarray, pixel: np.ndarray, min_matches: int = 3
) -> tuple[float, float]:
    """The residuals' variance split into the part each pixel repeats and the part it does not (one-way random
    effects, the ANOVA estimator).

    Model ``r_i = g_i e_p + n_i``: ``e_p`` the pixel's effect (metres at 1 m, the same in every frame, about 0
    with sigma ``sigma_p``), ``n_i`` the temporal noise of variance ``v``. Over the pixels with at least
    ``min_matches`` matches, each pixel's weighted least-squares effect ``e_p = c_p / s_p`` (``c_p = sum w g r``,
    ``s_p = sum w g^2``); the within-pixel mean square ``MSW = sum w (r - g e_p)^2 / (sum w - k)`` (``k`` pixels)
    estimates ``v``; the between-pixel mean square ``MSB = sum s_p e_p^2 / k`` has the expectation
    ``v + (S / k) sigma_p^2`` (``S = sum s_p``), so ``sigma_p^2 = (MSB - MSW) / (S / k)``, floored at 0. MSB is
    taken about 0, the prior's mean, not about the effects' mean: a share common to all pixels is part of what
    the prior must cover (the pose takes most of it out of ``r`` anyway).

    Parameters
    ----------
    r, w, g : array, shape (N,)
        Residuals (m), robust weights, :func:`pixel_gain`.
    pixel : array of int, shape (N,)
        Each match's pixel index.
    min_matches : int
        Matches of weight above 0.5 a pixel needs to count.

    Returns
    -------
    sigma_p : float
        The effect's sigma, metres at 1 m (0 when the pixels' estimates spread no more than their noise, or
        no pixel has ``min_matches``).
    variance : float
        ``v``, the within-pixel variance, m^2 (the weighted mean square of all residuals where no pixel counts).
    """
    pix = compact_pixels(pixel)
    n = int(pix.max()) + 1 if len(pix) else 0
    count = np.bincount(pix, w > 0.5, minlength=n)
    wgg = _per_pixel(pix, w * g * g, n)
    wgr = _per_pixel(pix, w * g * r, n)
    use = (count >= min_matches) & (wgg > 0)
    if not use.any():
        return 0.0, float((w * r**2).sum() / max(float(w.sum()), 1.0))
    e_all = np.where(wgg > 0, wgr / np.where(wgg > 0, wgg, 1.0), 0.0)
    inside = use[pix]
    within = r[inside] - g[inside] * e_all[pix[inside]]
    k = float(use.sum())
    msw = float((w[inside] * within**2).sum() / max(float(w[inside].sum()) - k, 1.0))
    msb = float((wgg[use] * e_all[use] ** 2).sum() / k)
    n0 = float(wgg[use].sum()) / k
    return float(np.sqrt(max(msb - msw, 0.0) / n0)), msw


def schur_reduction(
    J: np.ndarray, r: np.ndarray, w: np.ndarray, g: np.ndarray, pixel: np.ndarray, sigma_p: float, variance: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """What eliminating the per-pixel effects takes from the normal equations ``J^T W J`` and ``J^T W r``.

    Parameters
    ----------
    J : array, shape (N, P)
    r, w, g : array, shape (N,)
    pixel : array of int, shape (N,)
    sigma_p : float
        The effect's prior sigma, metres at 1 m (> 0).
    variance : float
        The residuals' within-pixel (temporal) variance, the prior's units (:func:`pixel_variance_components`).

    Returns
    -------
    dH : array, shape (P, P)
        ``sum_p b_p b_p^T / a_p``, to subtract from the information.
    dg : array, shape (P,)
        ``sum_p b_p c_p / a_p`` (``c_p = sum w g r``), to subtract from the gradient.
    pix : array of int, shape (N,)
        Each match's compact pixel index.
    coef : array, shape (n_pixels, P + 1)
        Per pixel ``(b_p, c_p) / a_p``: the effect's estimate moves by ``-coef[:, :P] xi`` for a step ``xi``
        (:func:`reduced_rows`).
    """
    pix = compact_pixels(pixel)
    n = int(pix.max()) + 1
    a = _per_pixel(pix, w * g * g, n) + variance / sigma_p**2
    b = _per_pixel(pix, (w * g)[:, None] * J, n)
    c = _per_pixel(pix, w * g * r, n)
    dH = (b / a[:, None]).T @ b
    dg = (b / a[:, None]).T @ c
    return dH, dg, pix, np.column_stack([b, c]) / a[:, None]


def reduced_rows(J: np.ndarray, r: np.ndarray, g: np.ndarray, pix: np.ndarray, coef: np.ndarray):
    """The rows with each pixel's estimated effect taken out (for the covariance): ``J - g coef_J``,
    ``r - g coef_r``."""
    return J - g[:, None] * coef[pix, :-1], r - g * coef[pix, -1]
