"""What a depth error repeated at one image position in every frame adds to the pose's covariance.

A sensor's fixed pattern (and any error fixed in the image: a camera matrix or a depth-to-image registration that
the fit does not quite undo) is the same in every frame where the arm covers that pixel. The frame-clustered
covariance takes the frames as independent: it holds each frame's own share of such an error, never the
covariance between frames. That part does not average down with more pixels: at a finer resolution the pattern,
correlated over a fixed physical window, spans more pixels, the frames' scores come out narrower, and the pull of
the pattern (the same pixels in every frame) stays.

Model: each residual ``r_i = g_i e(u_i) + n_i``, ``g_i`` its change per metre-at-1-m of depth error at its pixel
(:func:`classic.markerless.pixel_effect.pixel_gain`), ``e`` a stationary field over the image with covariance
function ``C(d) = cov(e(u), e(u + d))`` (metres at 1 m, squared), ``n_i`` independent between frames. The fit's
estimating equation ``sum_i w_i J_i r_i = 0`` moves by ``sum_i b_i e(u_i)`` with ``b_i = w_i g_i J_i``, so the
parameters by ``-H^{-1}`` times that, ``H = J^T W J`` plus the priors' information. Its covariance is

.. math:: \\Sigma_{rep} = H^{-1} \\Big( \\sum_{f(i) \\ne f(j)} b_i b_j^T C(u_j - u_i) \\Big) H^{-1}

over the pairs of matches across frames. Summed over all pairs instead, the same frame's ones and each match with
itself included, ``S = sum_{i,j} b_i b_j^T C(u_j - u_i) = sum_u B(u) (C * B)(u)^T`` with ``B(u)`` the sum of
``b_i`` over all frames at pixel ``u`` (the whitened Jacobian rows of every frame at that pixel, against each
other through the field's covariance; a correlated field summed in cells of its correlation length): one image
and one convolution. That is what is added: it counts the same frame's pairs, which the frame-clustered covariance
already holds, a second time, a share of about one over the frames that see a pixel: it errs wide, not short.

``C`` is measured from the final residuals, not from a sensor profile (a real sensor does not state its pattern):
over the pairs of inliers (robust weight above :data:`INLIER_WEIGHT`) in different frames, by integer distance
``k`` (rings of ``round(|d|)``) out to ``radius_px``, the least-squares fit of ``r_i r_j = g_i g_j C``:

.. math:: \\hat C(k) = \\frac{\\sum_{f(i) \\ne f(j), |u_j - u_i| = k} g_i g_j r_i r_j}
          {\\sum_{f(i) \\ne f(j), |u_j - u_i| = k} g_i^2 g_j^2}

Unweighted: the robust weights fall with ``|r|``, and weighted products would leave the field's large values out
and bias ``C`` low (paper-real at 848x480 with a 3.6 mm pattern: 2.2 mm at 1 m weighted, 3.0 unweighted). Across
frames the temporal noise drops out of the products (independent between frames), also where it is correlated
over a matching window within a frame; what is left is what repeats. ``C`` is kept up to the first ring where it
is not positive (its correlation length) and taken as 0 beyond. The sums run over dense images of the per-pixel
sums (all frames together, FFT correlation) less the same frame's (each frame's own image, cropped to its
matches), so the cost is FFTs, not pairs.
"""

from __future__ import annotations

import numpy as np
from scipy.signal import fftconvolve

__all__ = ["repeated_error_covariance", "INLIER_WEIGHT"]

#: Robust weight below which a match is an outlier to the field's covariance (Cauchy: beyond 3 loss scales).
INLIER_WEIGHT = 0.1


def repeated_error_covariance(
    J: np.ndarray,
    r: np.ndarray,
    w: np.ndarray,
    g: np.ndarray,
    uv: np.ndarray,
    frame: np.ndarray,
    prior_information: np.ndarray | None = None,
    radius_px: int = 16,
) -> dict:
    """The covariance of the fit's parameters that an error repeated per image pixel across frames adds.

    Parameters
    ----------
    J : array, shape (N, P)
        Jacobian rows at the solution.
    r, w, g : array, shape (N,)
        Residuals (m), robust weights, gains (:func:`classic.markerless.pixel_effect.pixel_gain`).
    uv : array of int, shape (N, 2)
        Each match's image pixel (column, row).
    frame : array of int, shape (N,)
        Each match's frame.
    prior_information : array, shape (P, P), optional
        The priors' information in the units of ``J^T W J`` (as the fit adds it).
    radius_px : int
        Farthest distance at which the field's covariance is measured, pixels.

    Returns
    -------
    dict
        ``covariance``: array, shape (P, P), ``H^{-1} S H^{-1}`` (symmetric, negative eigenvalues set to 0);
        ``sigma_m_at_1m``: ``sqrt(C(0))``; ``length_px``: the last ring kept (-1 where ``C(0) <= 0``: nothing
        repeats, the covariance is 0); ``rings``: ``C(k)`` as measured, metres at 1 m squared.
    """
    uv = np.asarray(uv, dtype=np.int64)
    uv = uv - uv.min(axis=0)  # only the pixels' offsets matter
    frame = np.asarray(frame, dtype=np.int64)
    n_par = J.shape[1]
    shape = (int(uv[:, 1].max()) + 1, int(uv[:, 0].max()) + 1)
    lags = np.arange(-radius_px, radius_px + 1)
    ring = np.rint(np.hypot(*np.meshgrid(lags, lags, indexing="ij"))).astype(np.int64)  # (2R+1, 2R+1), [dv, du]
    use = (w > INLIER_WEIGHT).astype(float)  # unweighted: the robust weights fall with |r| and would bias C low
    both = np.column_stack([use * g * r, use * g * g])
    lags = _lags(_image(uv, both, shape), radius_px) - _same_frame_lags(uv, frame, both, radius_px)
    rings = _ring_means(lags[..., 0], lags[..., 1], ring, radius_px)
    out = {"sigma_m_at_1m": float(np.sqrt(max(rings[0], 0.0))), "rings": rings}
    kept = np.flatnonzero(~(rings > 0))
    length = (int(kept[0]) if len(kept) else radius_px + 1) - 1
    out["length_px"] = length
    if length < 0:
        out["covariance"] = np.zeros((n_par, n_par))
        return out
    kernel = np.where(ring <= length, rings[np.minimum(ring, radius_px)], 0.0)
    b = (w * g)[:, None] * J
    B = _image(uv, b, shape)
    spread = fftconvolve(B, kernel[:, :, None], mode="same", axes=(0, 1))
    meat = B.reshape(-1, n_par).T @ spread.reshape(-1, n_par)  # every pair, the same frame's included
    H = (J * w[:, None]).T @ J + (0.0 if prior_information is None else prior_information)
    H_inv = np.linalg.pinv(H)
    cov = H_inv @ (meat + meat.T) / 2 @ H_inv
    value, vector = np.linalg.eigh((cov + cov.T) / 2)
    out["covariance"] = (vector * np.maximum(value, 0.0)) @ vector.T
    return out


def _image(uv: np.ndarray, values: np.ndarray, shape: tuple) -> np.ndarray:
    """Sums of ``values`` (N,) or (N, K) per pixel as a dense image, shape ``shape`` or ``shape + (K,)``."""
    index = uv[:, 1] * shape[1] + uv[:, 0]
    n = shape[0] * shape[1]
    if values.ndim == 1:
        return np.bincount(index, values, minlength=n).reshape(shape)
    columns = [np.bincount(index, values[:, k], minlength=n) for k in range(values.shape[1])]
    return np.stack(columns, axis=1).reshape(*shape, values.shape[1])


def _lags(image: np.ndarray, radius_px: int) -> np.ndarray:
    """The autocorrelation of each channel of ``image`` (h, w, K) at lags ``(dv, du)`` up to ``radius_px``:
    ``sum_u x(u) x(u + d)``, shape (2R+1, 2R+1, K)."""
    h, w = image.shape[:2]
    R = radius_px
    pad = np.zeros((max(h, R + 1), max(w, R + 1), image.shape[2]))
    pad[:h, :w] = image
    h, w = pad.shape[:2]
    full = fftconvolve(pad, pad[::-1, ::-1], mode="full", axes=(0, 1))  # lag (dv, du) at (h - 1 + dv, w - 1 + du)
    return full[h - 1 - R : h + R, w - 1 - R : w + R]


def _same_frame_lags(uv: np.ndarray, frame: np.ndarray, values: np.ndarray, radius_px: int) -> np.ndarray:
    """:func:`_lags` of each frame's own image (cropped to its matches), summed over the frames."""
    out = np.zeros((2 * radius_px + 1, 2 * radius_px + 1, values.shape[1]))
    order = np.argsort(frame, kind="stable")
    bounds = np.flatnonzero(np.diff(frame[order])) + 1
    for rows in np.split(order, bounds):
        corner = uv[rows].min(axis=0)
        local = uv[rows] - corner
        out += _lags(_image(local, values[rows], (int(local[:, 1].max()) + 1, int(local[:, 0].max()) + 1)), radius_px)
    return out


def _ring_means(num: np.ndarray, den: np.ndarray, ring: np.ndarray, radius_px: int) -> np.ndarray:
    """``C(k) = sum num / sum den`` over each ring ``k = 0..radius_px`` (NaN where ``den`` sums to 0)."""
    k = np.minimum(ring, radius_px + 1).ravel()
    top = np.bincount(k, num.ravel(), minlength=radius_px + 2)[: radius_px + 1]
    bottom = np.bincount(k, den.ravel(), minlength=radius_px + 2)[: radius_px + 1]
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(bottom > 0, top / np.where(bottom > 0, bottom, 1.0), np.nan)
