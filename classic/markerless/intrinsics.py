"""The depth camera's intrinsics as parameters of the registration: rays, their Jacobian, priors, a summary.

A depth pixel ``(u, v)`` with depth ``z`` is the point ``z (x_n, y_n, 1)``, ``x_n = (u - c_x) / f_x`` and
``y_n = (v - c_y) / f_y``. A camera matrix off by a fraction of a percent in focal length or a few pixels in
the principal point moves every point sideways by ``z`` times that much: 0.7 % of the arm's 0.3 m spread
off the axis is 2 mm, 3 px at 220 px focal length is 16 mm at 1.2 m, the same in every frame, which the pose
absorbs as millimetres of error the residuals do not show. The registration estimates ``(f_x, f_y, c_x, c_y)``
with the pose where the arm's many positions across the image and in depth determine them, under a prior
of the camera matrix's stated uncertainty (:data:`INTRINSICS_PRIORS`), so that it is never worse than taking
them as exact, and the pose's covariance carries what the frames leave of their uncertainty.

The points are back-projected once with the camera matrix given (``K_ref``); for other intrinsics each one's
pixel is recovered from its ray, ``u = f_x^{ref} x_n^{ref} + c_x^{ref}``, and its ray recomputed. Only the
ray's direction changes; the depth does not.
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "INTRINSICS_PRIORS",
    "NAMES",
    "camera_matrix",
    "intrinsics_vector",
    "prior_sigma_px",
    "rays_for",
    "intrinsics_summary",
]

#: The parameters, in the order of the vectors below.
NAMES = ("fx", "fy", "cx", "cy")

#: Stated uncertainty of a camera matrix per sensor profile (one sigma): focal lengths relative, principal point
#: in pixels at the image's resolution. ``camera_info`` and the datasheets give none; a factory-calibrated
#: D435-class unit's intrinsics are off by up to about 0.7 % and 3 px (the figure of issue 41), taken here as
#: one sigma, so that the prior never claims more than the camera's calibration. The Zivid is calibrated per
#: unit with its projector (trueness < 0.2 %).
INTRINSICS_PRIORS = {
    "factory": (0.007, 0.007, 3.0, 3.0),
    "d435": (0.007, 0.007, 3.0, 3.0),
    "d455": (0.007, 0.007, 3.0, 3.0),
    "l515": (0.007, 0.007, 3.0, 3.0),
    "azure-kinect": (0.007, 0.007, 3.0, 3.0),
    "zivid": (0.002, 0.002, 1.0, 1.0),
}


def intrinsics_vector(K: np.ndarray) -> np.ndarray:
    """``(f_x, f_y, c_x, c_y)`` of a camera matrix ``K`` (3, 3); shape (4,)."""
    return np.array([K[0, 0], K[1, 1], K[0, 2], K[1, 2]], dtype=float)


def prior_sigma_px(relative_sigma, theta: np.ndarray) -> np.ndarray:
    """Pixels, shape (4,), of intrinsics sigmas stated as :attr:`MarkerlessOptions.intrinsics_prior_sigma` states them
    (``f_x``, ``f_y`` relative, ``c_x``, ``c_y`` pixels), about ``theta = (f_x, f_y, c_x, c_y)``."""
    return np.asarray(relative_sigma, dtype=float) * np.array([theta[0], theta[1], 1.0, 1.0])


def camera_matrix(theta: np.ndarray) -> np.ndarray:
    """The camera matrix (3, 3) of ``theta = (f_x, f_y, c_x, c_y)`` (no skew)."""
    fx, fy, cx, cy = (float(x) for x in theta)
    return np.array([[fx, 0.0, cx], [0.0, fy, cy], [0.0, 0.0, 1.0]])


def rays_for(q_ref: np.ndarray, K_ref: np.ndarray, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Points back-projected with ``K_ref``, back-projected again with the intrinsics ``theta``.

    Parameters
    ----------
    q_ref : array, shape (N, 3)
        Camera-frame points from ``K_ref`` (``z > 0``), metres.
    K_ref : array, shape (3, 3)
    theta : array, shape (4,)
        ``(f_x, f_y, c_x, c_y)``, pixels.

    Returns
    -------
    q : array, shape (N, 3)
        The same pixels and depths with ``theta``.
    dray : array, shape (N, 2, 4)
        ``d (x_n, y_n) / d theta`` per point (the ray's third coordinate stays 1).
    """
    fx, fy, cx, cy = theta
    z = q_ref[:, 2]
    u = K_ref[0, 0] * q_ref[:, 0] / z + K_ref[0, 2]
    v = K_ref[1, 1] * q_ref[:, 1] / z + K_ref[1, 2]
    x, y = (u - cx) / fx, (v - cy) / fy
    dray = np.zeros((len(z), 2, 4))
    dray[:, 0, 0], dray[:, 0, 2] = -x / fx, -1.0 / fx
    dray[:, 1, 1], dray[:, 1, 3] = -y / fy, -1.0 / fy
    return np.column_stack([x * z, y * z, z]), dray


def intrinsics_summary(
    theta: np.ndarray,
    covariance: np.ndarray | None,
    covariance_frames: np.ndarray | None,
    K_given: np.ndarray,
    prior_sigma: np.ndarray,
    determined_share: float,
) -> dict:
    """Per parameter: the estimate, its sigma, the prior's, and whether the frames determined it.

    Parameters
    ----------
    theta : array, shape (4,)
        The estimate ``(f_x, f_y, c_x, c_y)``, pixels.
    covariance : array, shape (4, 4) or None
        Its covariance (the errors the frames share included).
    covariance_frames : array, shape (4, 4) or None
        The same clustered by frame only: what the frames' geometry leaves of it, which decides whether the
        data determined a parameter.
    K_given : array, shape (3, 3)
        The camera matrix given (the prior's mean).
    prior_sigma : array, shape (4,)
        The prior's sigmas, pixels.
    determined_share : float
        Determined where the frames leave the sigma below this share of the prior's.

    Returns
    -------
    dict
        ``model`` ``"estimated"``, ``given`` (the camera matrix's four numbers), and per name of :data:`NAMES`
        a dict of ``estimate``, ``change`` (estimate minus given), ``sigma``, ``prior_sigma``, ``ratio``
        (posterior over prior sigma, from the frames' clustering) and ``determined``.
    """
    given = intrinsics_vector(K_given)
    out = {"model": "estimated", "given": [float(x) for x in given]}
    sd = np.full(4, np.nan) if covariance is None else np.sqrt(np.maximum(np.diag(covariance), 0.0))
    frames = covariance if covariance_frames is None else covariance_frames
    sd_frames = np.full(4, np.nan) if frames is None else np.sqrt(np.maximum(np.diag(frames), 0.0))
    for i, name in enumerate(NAMES):
        ratio = float(sd_frames[i] / prior_sigma[i])
        out[name] = {
            "estimate": float(theta[i]),
            "change": float(theta[i] - given[i]),
            "sigma": float(sd[i]),
            "prior_sigma": float(prior_sigma[i]),
            "ratio": ratio,
            "determined": bool(ratio < determined_share),
        }
    return out
