"""The markerless registration's sigma beside the covariance, and the summaries of what it estimated: the model's
sampling bias, the depth-to-colour registration's terms, the terms added in quadrature, the depth correction as
a sensor's scale and offset; and the covariance's clusterings beside the frames (depth bins, image tiles).
"""

from __future__ import annotations

import numpy as np

from classic.markerless.options import MarkerlessOptions
from classic.markerless.visibility import project

__all__ = ["sampling_sigma", "in_quadrature", "registration_terms", "image_tiles", "depth_bins", "depth_summary"]


def sampling_sigma(z_med: float, lever_m: float, K: np.ndarray, opts: MarkerlessOptions) -> dict:
    """What all frames share and the covariance cannot see: the model's sampling bias.

    A model point stands for the surface up to half a pixel off its ray, off the tangent plane by at most
    ``F^2 / (8 r)`` on a link of radius ``r`` for a pixel footprint ``F``; taken as a uniform error
    (std = bound / sqrt 3) in translation, and over the matched points' spread ``lever_m`` in rotation.
    """
    footprint_m = z_med / max(K[0, 0], K[1, 1])
    sampling_mm = footprint_m**2 / (8 * opts.model_radius_m) / np.sqrt(3) * 1e3
    return {
        "rotation_deg": float(np.degrees(sampling_mm / 1e3 / max(lever_m, 1e-3))),
        "translation_mm": float(sampling_mm),
    }


def in_quadrature(*terms: dict) -> dict:
    """The sigma's terms (each ``rotation_deg`` and ``translation_mm``) added in quadrature."""
    return {key: float(np.sqrt(sum(t[key] ** 2 for t in terms))) for key in ("rotation_deg", "translation_mm")}


def registration_terms(opts: MarkerlessOptions, fit, theta_given: np.ndarray) -> dict:
    """What the depth-to-colour registration adds to the sigma, and which of its parts the fit estimated.

    The extrinsic's rotation and translation move the colour camera off the depth camera the fit finds: bounded,
    per axis. A shift of the depth image against the camera model is the principal point's error: estimated with
    the intrinsics (the change found holds the camera matrix's own error there too), or taken as exact with them.
    """
    estimated = fit.intrinsics is not None
    out = {
        "translation": {
            "treatment": "bounded",
            "sigma_mm": float(opts.depth_extrinsic_sigma_m * 1e3),
            "rss_mm": float(np.sqrt(3) * opts.depth_extrinsic_sigma_m * 1e3),
        },
        "rotation": {
            "treatment": "bounded",
            "sigma_deg": float(opts.depth_extrinsic_sigma_deg),
            "rss_deg": float(np.sqrt(3) * opts.depth_extrinsic_sigma_deg),
        },
    }
    if estimated:
        change = np.asarray(fit.intrinsics[2:4]) - np.asarray(theta_given[2:4])
        sigma = np.sqrt(np.clip(np.diag(fit.intrinsics_covariance)[2:4], 0.0, None))
        out["shift_px"] = {
            "treatment": "estimated (with the principal point)",
            "dx": float(change[0]),
            "dy": float(change[1]),
            "sigma": [float(x) for x in sigma],
        }
    else:
        out["shift_px"] = {"treatment": "taken as exact (intrinsics fixed)"}
    return out


def image_tiles(p_cam: np.ndarray, K: np.ndarray, width: int, tiles: int) -> np.ndarray | None:
    """Each observed point's image tile: square tiles, ``tiles`` across the image's ``width`` (None when
    ``tiles`` < 2). ``p_cam`` as back-projected with ``K``, so its pixel is found again exactly."""
    if tiles < 2 or len(p_cam) < 2 * tiles:
        return None
    size = width / tiles
    uv = np.floor(project(p_cam, K) / size).astype(np.int64)
    return uv[:, 1] * (tiles + 1) + uv[:, 0]


def depth_bins(z: np.ndarray, bins: int) -> np.ndarray | None:
    """Each depth's bin among ``bins`` of equal counts (None when ``bins`` < 2)."""
    if bins < 2 or len(z) < 2 * bins:
        return None
    edges = np.quantile(z, np.linspace(0, 1, bins + 1)[1:-1])
    return np.searchsorted(edges, z)


def depth_summary(
    fit, opts: MarkerlessOptions, depth_range: tuple, noise_source: str, noise_mm: float, shared=None
) -> dict:
    """The depth correction as the sensor's scale and offset, ``d_obs = s d + o``, with their sigmas: the fit's
    covariance of ``(k, c)``, plus ``shared`` (shape (2, 2), optional): what an error the frames share adds to it
    (:mod:`classic.markerless.repeated_error`, the split check's groups: :mod:`classic.markerless.consistency`), as
    the pose's sigma has it."""
    out = {"model": opts.depth_model, "noise_source": noise_source, "noise_mm_at_median_depth": noise_mm}
    out["range_m"] = [float(depth_range[0]), float(depth_range[1])]
    if fit.depth_correction is None:
        return out
    k, c = fit.depth_correction[:2]
    # s = 1 / k, o = -c / k; first order through the Jacobian of (s, o) in (k, c)
    G = np.array([[-1 / k**2, 0.0], [c / k**2, -1 / k]])
    C = G @ (fit.depth_covariance[:2, :2] + (0.0 if shared is None else shared)) @ G.T
    frames = fit.depth_covariance if fit.depth_covariance_frames is None else fit.depth_covariance_frames
    F = G @ frames[:2, :2] @ G.T
    out.update(
        {
            "scale": float(1 / k),
            "scale_sigma": float(np.sqrt(max(C[0, 0], 0.0))),
            "offset_mm": float(-c / k * 1e3),
            "offset_sigma_mm": float(np.sqrt(max(C[1, 1], 0.0)) * 1e3),
            "observability": {
                "scale_sigma": float(np.sqrt(max(F[0, 0], 0.0))),
                "offset_sigma_mm": float(np.sqrt(max(F[1, 1], 0.0)) * 1e3),
            },
        }
    )
    if len(fit.depth_correction) == 4:  # the stereo matcher's disparity error a sin(2 pi d) + b cos(2 pi d)
        (a, b), L = fit.depth_correction[2:], fit.depth_covariance[2:, 2:]
        out["pixel_locking_px"] = {
            "sin": a,
            "cos": b,
            "sin_sigma": float(np.sqrt(max(L[0, 0], 0.0))),
            "cos_sigma": float(np.sqrt(max(L[1, 1], 0.0))),
            "amplitude": float(np.hypot(a, b)),
        }
    return out
