"""The robot's silhouette in the colour image as a measure of the camera matrix (issue 41, a prototype).

Depth alone does not separate the depth camera's focal length from its distance and depth offset: a focal
length off by ``e`` and the arm ``e`` farther give the same depth image to first order. The colour image's
edges are sharp where the depth image's are eroded, and the arm's outline there depends on the camera
matrix and the pose without any depth: this module fits ``(f_x, f_y, c_x, c_y)`` and the camera's pose to the
arm's outline over every frame, from a finished registration's start.

The observed outline: the static scene is the per-pixel median over the frames (the arm moves, the cell does
not), the arm is where a frame differs from it by more than ``threshold`` in some channel; pixels the model
covers in more than ``max_cover`` of the frames (the base, always there) have no background and are left out.
Its signed distance (pixels, positive outside) comes from two Euclidean distance transforms
(:func:`scipy.ndimage.distance_transform_edt`), half a pixel taken off each side, so that its zero lies between
the last pixel in and the first pixel out.

The model's outline: the surface samples of the moving parts whose normal is nearly perpendicular to the
view ray (the rim, ``|n . r| < rim_cos``) and whose outside, ``outside_px`` along the outline's image normal,
no part of the model covers (an outer edge, not one against another part). Each such sample, projected, should
land on the observed outline: its residual is the signed distance there, bilinear, under a soft-L1 loss (the
gripper and any part the model lacks make outliers). The sigma is the frame-clustered sandwich covariance and
the shift a uniform bias of the mask's outline would cause (``SilhouetteOptions.grid_bias_px``).

Only numpy and scipy.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy import ndimage, optimize
from scipy.spatial.transform import Rotation

from classic.clustered_covariance import clustered_covariance
from classic.least_squares import loss_weights
from handeye.core.errors import TooFewPosesError

#: Unknowns of the outline's fit: ``(f_x, f_y, c_x, c_y)`` and the camera's pose.
N_PARAMS = 10
#: Fewest frames with outline points: the frame-clustered covariance has rank at most frames - 1, so with fewer
#: than ``N_PARAMS + 1`` some direction of the fit has no sigma at all (3 frames of the test scene: c_x 42 px off
#: at 57 sigma).
MIN_FRAMES = N_PARAMS + 1

__all__ = ["SilhouetteOptions", "SilhouetteFit", "foreground_masks", "signed_distance", "refine_silhouette"]


@dataclass(frozen=True)
class SilhouetteOptions:
    """Settings of :func:`refine_silhouette`.

    Attributes
    ----------
    threshold : float
        Colour difference from the static scene (0-255, any channel) above which a pixel is the arm's.
    max_cover : float
        Pixels the model covers in more than this share of the frames have no background: left out.
    rim_cos : float
        ``|n . r|`` below which a surface sample is on the rim.
    outside_px : float
        How far outside an outline point (pixels) the model must cover nothing for it to be an outer edge.
    loss_scale_px : float
        Soft-L1 scale of the residuals, pixels.
    rounds : int
        Rim re-selected at the refined pose this many times.
    grid_bias_px : float
        Bound on the mask outline's own bias, pixels: the signed distance of a pixel-centre sampled disc of
        4-7 px radius reads +0.03 px at its true outline (0.00 at 10-20 px; 16 000 samples at random sub-pixel
        centres, standard error 0.002 px), taken with three standard errors. The parameters' shift a uniform
        offset of this size causes through the fit is added to their covariance.
    """

    threshold: float = 25.0
    max_cover: float = 0.4
    rim_cos: float = 0.02
    outside_px: float = 2.5
    loss_scale_px: float = 0.5
    rounds: int = 2
    grid_bias_px: float = 0.035


@dataclass
class SilhouetteFit:
    """The camera matrix and pose the arm's outline gives.

    Attributes
    ----------
    T_base_cam : array, shape (4, 4)
        Colour camera in the base frame.
    theta : array, shape (4,)
        ``(f_x, f_y, c_x, c_y)``, pixels.
    covariance : array, shape (10, 10)
        Of ``(f_x, f_y, c_x, c_y)`` (px) and the pose's rotation vector (rad) and translation (m), camera frame;
        frame-clustered sandwich, plus the shift a uniform outline bias of ``grid_bias_px`` causes.
    sigma_theta : array, shape (4,)
    rms_px : float
        RMS of the inlier residuals (``|r| < 3 loss_scale_px``).
    n_points : int
        Outline points in the last round.
    diagnostics : dict
    """

    T_base_cam: np.ndarray
    theta: np.ndarray
    covariance: np.ndarray
    sigma_theta: np.ndarray
    rms_px: float
    n_points: int
    diagnostics: dict = field(default_factory=dict)


def foreground_masks(rgb: np.ndarray, threshold: float) -> np.ndarray:
    """The pixels that differ from the static scene (the per-pixel median over the frames).

    Parameters
    ----------
    rgb : array of uint8, shape (N, H, W, 3)
    threshold : float
        0-255, any channel.

    Returns
    -------
    array of bool, shape (N, H, W)
    """
    rgb = np.asarray(rgb, dtype=np.int16)
    background = np.median(rgb, axis=0).astype(np.int16)
    return np.abs(rgb - background).max(axis=-1) > threshold


def signed_distance(mask: np.ndarray) -> np.ndarray:
    """Signed distance (pixels) to the outline of ``mask`` (H, W): positive outside, zero half-way between the
    last pixel in and the first out. Shape (H, W)."""
    if not mask.any():
        return np.full(mask.shape, 1e3)
    outside = ndimage.distance_transform_edt(~mask) - 0.5
    inside = ndimage.distance_transform_edt(mask) - 0.5
    return np.where(mask, -inside, outside)


def _project(theta, p_cam):
    z = p_cam[:, 2]
    return theta[0] * p_cam[:, 0] / z + theta[2], theta[1] * p_cam[:, 1] / z + theta[3]


def _to_cam(T_base_cam, p_base):
    R, t = T_base_cam[:3, :3], T_base_cam[:3, 3]
    return (p_base - t) @ R


def _model_masks(theta, p_cam, frame, n_frames, shape):
    """Per frame, the pixels the posed model covers (samples splatted, closed over 1 px)."""
    u, v = _project(theta, p_cam)
    ui, vi = np.rint(u).astype(int), np.rint(v).astype(int)
    ok = (ui >= 0) & (ui < shape[1]) & (vi >= 0) & (vi < shape[0]) & (p_cam[:, 2] > 0)
    masks = np.zeros((n_frames, *shape), dtype=bool)
    masks[frame[ok], vi[ok], ui[ok]] = True
    st = np.zeros((1, 3, 3), dtype=bool)
    st[0] = True
    return ndimage.binary_closing(ndimage.binary_dilation(masks, st), st)


def _outline_points(theta, T_base_cam, points, normals, frame, moving, masks, opts):
    """Indices of the moving samples on the model's outer outline, seen from ``T_base_cam``; ``masks``: the pixels
    the model covers per frame (those it covers in more than ``opts.max_cover`` of them are not used)."""
    usable = masks.mean(axis=0) <= opts.max_cover
    idx = np.flatnonzero(moving)
    p = _to_cam(T_base_cam, points[idx])
    n = normals[idx] @ T_base_cam[:3, :3]
    rim = np.abs(np.einsum("ij,ij->i", n, p)) < opts.rim_cos * np.linalg.norm(p, axis=1)
    idx, p, n = idx[rim], p[rim], n[rim]
    u, v = _project(theta, p)
    du = theta[0] * (n[:, 0] * p[:, 2] - p[:, 0] * n[:, 2]) / p[:, 2] ** 2
    dv = theta[1] * (n[:, 1] * p[:, 2] - p[:, 1] * n[:, 2]) / p[:, 2] ** 2
    norm = np.hypot(du, dv) + 1e-12
    uo, vo = u + opts.outside_px * du / norm, v + opts.outside_px * dv / norm
    ui, vi = np.rint(uo).astype(int), np.rint(vo).astype(int)
    h, w = masks.shape[1:]
    inside = (ui >= 1) & (ui < w - 1) & (vi >= 1) & (vi < h - 1) & (u > 1) & (u < w - 2) & (v > 1) & (v < h - 2)
    idx, ui, vi = idx[inside], ui[inside], vi[inside]
    ur, vr = np.rint(u[inside]).astype(int), np.rint(v[inside]).astype(int)
    outer = ~masks[frame[idx], vi, ui] & usable[vi, ui] & usable[vr, ur]
    return idx[outer]


def _pose(T, x):
    """``T`` moved by ``x = (rotvec, translation)`` in the camera frame."""
    D = np.eye(4)
    D[:3, :3] = Rotation.from_rotvec(x[:3]).as_matrix()
    D[:3, 3] = x[3:]
    return T @ D


def refine_silhouette(rgb, theta0, T_base_cam0, points, normals, frame, moving, options=None) -> SilhouetteFit:
    """Fit the camera matrix and pose to the arm's outline in the colour frames.

    Parameters
    ----------
    rgb : array of uint8, shape (N, H, W, 3)
        The colour frames, the static scene the same in all.
    theta0 : array, shape (4,)
        Start ``(f_x, f_y, c_x, c_y)``, pixels (a registration's estimate).
    T_base_cam0 : array, shape (4, 4)
        Start pose of the colour camera in the base frame.
    points, normals : array, shape (M, 3)
        The posed surface samples of every frame, base frame (joint offsets already applied).
    frame : array of int, shape (M,)
        Frame of each sample.
    moving : array of bool, shape (M,)
        Samples of the parts that move over the frames (the static base has no background).
    options : SilhouetteOptions, optional

    Returns
    -------
    SilhouetteFit

    Raises
    ------
    TooFewPosesError
        The outline is seen in fewer than :data:`MIN_FRAMES` frames.
    """
    opts = options or SilhouetteOptions()
    n_frames, h, w = rgb.shape[:3]
    fg = foreground_masks(rgb, opts.threshold)
    sdf = np.stack([signed_distance(m) for m in fg])
    theta, T = np.asarray(theta0, dtype=float).copy(), np.asarray(T_base_cam0, dtype=float).copy()
    for _ in range(opts.rounds):
        masks = _model_masks(theta, _to_cam(T, points), frame, n_frames, (h, w))
        idx = _outline_points(theta, T, points, normals, frame, moving, masks, opts)
        pts, fr = points[idx], frame[idx]
        _check_frames(fr)
        flat = sdf.reshape(n_frames, -1)

        def residuals(x, pts=pts, fr=fr, T=T):
            u, v = _project(x[:4], _to_cam(_pose(T, x[4:]), pts))
            ui, vi = np.clip(u, 0, w - 1.001), np.clip(v, 0, h - 1.001)
            u0, v0 = np.floor(ui).astype(int), np.floor(vi).astype(int)
            a, b = ui - u0, vi - v0
            base = v0 * w + u0
            return (
                (1 - a) * (1 - b) * flat[fr, base]
                + a * (1 - b) * flat[fr, base + 1]
                + (1 - a) * b * flat[fr, base + w]
                + a * b * flat[fr, base + w + 1]
            )

        x0 = np.concatenate([theta, np.zeros(6)])
        scale = np.array([1.0, 1.0, 1.0, 1.0, 1e-3, 1e-3, 1e-3, 1e-3, 1e-3, 1e-3])
        sol = optimize.least_squares(
            residuals, x0, loss="soft_l1", f_scale=opts.loss_scale_px, x_scale=scale, diff_step=1e-6, max_nfev=50
        )
        theta, T = sol.x[:4], _pose(T, sol.x[4:])
    # frame-clustered sandwich at the soft-L1 fit's IRLS weights (its k/(k-1) and the plain floor included)
    cov = clustered_covariance(sol.jac, sol.fun, loss_weights(sol.fun, "soft_l1", opts.loss_scale_px), fr)
    shift = _uniform_offset_shift(sol, opts.loss_scale_px, opts.grid_bias_px)
    cov = cov + np.outer(shift, shift)
    r = sol.fun
    inl = np.abs(r) < 3 * opts.loss_scale_px
    return SilhouetteFit(
        T_base_cam=T,
        theta=theta,
        covariance=cov,
        sigma_theta=np.sqrt(np.diag(cov)[:4]),
        rms_px=float(np.sqrt(np.mean(r[inl] ** 2))) if inl.any() else float("nan"),
        n_points=len(r),
        diagnostics={"inlier_share": float(inl.mean()), "median_abs_px": float(np.median(np.abs(r)))},
    )


def _check_frames(frame: np.ndarray) -> None:
    """Refuse an outline seen in fewer than :data:`MIN_FRAMES` frames: its frame-clustered sigma is not defined."""
    n = len(np.unique(frame))
    if n < MIN_FRAMES:
        raise TooFewPosesError(
            f"the arm's outer outline is seen in {n} frame(s); the outline's fit needs at least {MIN_FRAMES} "
            f"(its sigma is clustered by frame over {N_PARAMS} unknowns): record more frames of the arm moving"
        )


def _uniform_offset_shift(sol, scale, offset_px):
    """The parameters' first-order shift when every residual moves by ``offset_px``: ``-A^-1 J^T W 1 b``."""
    w1 = loss_weights(sol.fun, "soft_l1", scale)
    A = (sol.jac * w1[:, None]).T @ sol.jac
    return -np.linalg.solve(A, sol.jac.T @ (w1 * offset_px))
