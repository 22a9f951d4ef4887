"""The per-frame check of the current calibration: the posed robot surface against one depth image.

The robot's surface, posed by the frame's joints (base frame) and moved into the camera by the current
``T_base_cam``, is z-buffered into the image (:func:`classic.markerless.visible_points`). At each visible
model point's pixel the observed depth ``z_obs`` is compared with the model's ``z_mod``:

- no depth there: a **dropout** pixel;
- ``z_obs < z_mod - w``: something in front of the arm, an **occluder** (``w`` is the match window,
  ``CheckOptions.window_sigmas`` sensor sigmas at that depth plus ``window_floor_m``);
- ``z_obs > z_mod + w``: the background seen where the model says arm (**behind**; a moved camera makes
  these, an occluder cannot);
- else **matched**.

The matched points give ONE Gauss-Newton step of robust point-to-plane (the parametrisation of
:mod:`classic.markerless.point_to_plane`: ``T_base_cam exp(delta)``, ``delta = (omega, v)`` in the camera
frame, radians and metres):

.. math:: r_i = n_i^T (q_i - m_i), \\qquad J_i = [q_i \\times n_i,\\ n_i], \\qquad
          \\delta = -(J^T W J)^{-1} J^T W r

with each residual whitened by its sensor sigma along the normal, ``sigma(z) |n_i . (x, y, 1)|`` (a depth
error moves the point along its pixel's ray), in quadrature with ``model_sigma_m``, and Cauchy weights at
``robust_sigmas``. Its covariance ``(J^T W J)^{-1}`` counts the pixels as independent; they are not (the
sensor's noise is correlated over a few pixels, the model's sampling error is shared by neighbours), so
the statistic ``chi2 = delta^T Sigma^{-1} delta`` is scaled by a factor estimated from the first seconds of
the stream (:mod:`handeye.watch.change`).

The surface is posed at the recorded joints, taken as exact; where it carries its joint twists the check also gives
``d delta / d q`` (:attr:`FrameCheck.joint_gain`), with which :func:`with_joint_noise` adds the joints' error to the
step's covariance: one error of the whole frame, which no number of pixels averages away, and with a precise sensor
most of the step's scatter.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from functools import lru_cache

import numpy as np

from classic.least_squares import loss_weights
from classic.markerless import visible_points
from classic.markerless.depth import pixel_rays
from classic.markerless.kinematics import offset_columns
from classic.markerless.visibility import project, zbuffer_grid
from handeye.core.errors import ShapeError

__all__ = ["CheckOptions", "FrameCheck", "check_frame", "camera_rays", "unit_correction", "with_joint_noise"]


@dataclass(frozen=True)
class CheckOptions:
    """Settings of :func:`check_frame`.

    Attributes
    ----------
    window_sigmas : float
        Half-width of the match window in sensor sigmas at the model's depth.
    window_floor_m : float
        Added to the window, metres (the model's own error: mesh detail, sampling, the sensor's bias).
    model_sigma_m : float
        The model's residual in quadrature with the sensor's, metres (sampling of the surface).
    robust_sigmas : float
        Scale of the Cauchy loss in whitened units.
    min_matched : int
        Fewer matched points: no step (``delta`` None).
    zbuffer_stride : int
        The z-buffer's pixels are this many image pixels wide (the surface sampled for it, as
        :func:`handeye.markerless.robot_surface_for` returns it: a sparser surface would leak hidden parts through
        the gaps of a finer z-buffer); each visible point is compared with the depth at its own pixel.
    reference_focal_px : float
        The camera the check's work is made for, by its focal length in pixels (the arm's area in pixels grows as
        its square): with a longer focal length ``f`` the z-buffer's stride is ``zbuffer_stride`` times
        ``factor = max(1, round(f / reference_focal_px))`` (:meth:`stride_for`), so a larger image checks about as
        many points as this one, at as much CPU per frame. The default, 222 px, is 256 pixels over 60 degrees
        (the running-cell benchmark's frames); a D435's 848x480 depth over 87 degrees (447 px) gets ``factor``
        2. 0: the stride as given at any size. Fewer points widen the step's covariance; they do not bias it.
    """

    window_sigmas: float = 4.0
    window_floor_m: float = 0.003
    model_sigma_m: float = 0.0003
    robust_sigmas: float = 3.0
    min_matched: int = 50
    zbuffer_stride: int = 1
    reference_focal_px: float = 222.0

    def __post_init__(self):
        for key in ("window_sigmas", "window_floor_m", "model_sigma_m", "robust_sigmas", "reference_focal_px"):
            value = getattr(self, key)
            if not np.isfinite(value) or value < 0:
                raise ValueError(f"CheckOptions.{key} must be finite and >= 0, got {value}")
        if self.zbuffer_stride < 1:
            raise ValueError(f"CheckOptions.zbuffer_stride must be >= 1, got {self.zbuffer_stride}")
        if self.min_matched < 6:
            raise ValueError(f"CheckOptions.min_matched must be >= 6 (6 unknowns), got {self.min_matched}")

    def factor_for(self, K: np.ndarray) -> int:
        """``max(1, round(f / reference_focal_px))`` for the camera ``K`` (3, 3), ``f`` its larger focal length in
        pixels; 1 with ``reference_focal_px`` 0."""
        if self.reference_focal_px == 0:
            return 1
        f_px = float(max(K[0][0], K[1][1]))
        return max(1, int(np.floor(f_px / self.reference_focal_px + 0.5)))

    def stride_for(self, K: np.ndarray) -> int:
        """The z-buffer's stride :func:`check_frame` uses with the camera ``K``: ``zbuffer_stride`` times
        :meth:`factor_for`."""
        return self.zbuffer_stride * self.factor_for(K)


@dataclass
class FrameCheck:
    """What one frame says about the current calibration.

    Attributes
    ----------
    delta : array, shape (6,), or None
        The correction ``(omega, v)`` (rad, m, camera frame) that one Gauss-Newton step finds:
        ``T_base_cam exp(delta)`` fits the frame better; None with fewer than ``min_matched`` matches.
    covariance : array, shape (6, 6), or None
        Of ``delta``, pixels counted as independent (not inflated); with the joints' error in it where
        :func:`with_joint_noise` added it.
    chi2 : float
        ``delta^T covariance^{-1} delta`` (NaN without a step).
    n_visible, n_matched, n_occluders, n_behind, n_dropout : int
        Visible model points; those matched; those with depth in front by more than the window; behind by
        more; without depth.
    rms_m : float
        RMS point-to-plane residual of the matched points, metres (NaN with none).
    n_at_offset : int
        Visible points with depth whose ``z_obs - z_mod`` lies within the match window of its median over them:
        most of them there while the median is off is a consistent offset (a moved camera or a wrong depth
        unit), not an occluder (which leaves the rest matched).
    unit_gain : array, shape (6, 2), or None
        ``d delta / d (k, c)``: how the step moves when the depth correction ``(k, c)`` changes (to first order:
        ``delta(k + dk, c + dc) = delta(k, c) + unit_gain @ (dk, dc)``); None without a step.
    joint_gain : array, shape (6, nq), or None
        ``d delta / d q``: how the step moves when the joints the surface was posed at are off by ``dq`` (radians),
        from the surface's joint twists (``joint_twists_base``); None without a step or without twists. An error
        of the recorded joints moves the whole posed surface, so it is one error of the frame's step, however many
        pixels: :func:`with_joint_noise` adds its covariance.
    """

    delta: np.ndarray | None
    covariance: np.ndarray | None
    chi2: float
    n_visible: int
    n_matched: int
    n_occluders: int
    n_behind: int
    n_dropout: int
    rms_m: float
    n_at_offset: int = 0
    unit_gain: np.ndarray | None = None
    joint_gain: np.ndarray | None = None

    def fraction(self, count: int) -> float:
        """``count`` over the visible model points with depth (0 when none)."""
        seen = self.n_visible - self.n_dropout
        return count / seen if seen > 0 else 0.0


def camera_rays(K: np.ndarray, height: int, width: int) -> np.ndarray:
    """Every pixel's ray ``(x/z, y/z, 1)``, shape (height, width, 3), read-only: computed once per camera."""
    K = np.asarray(K, dtype=float)
    return _rays(K.tobytes(), int(height), int(width))


@lru_cache(maxsize=4)
def _rays(K_bytes: bytes, height: int, width: int) -> np.ndarray:
    rays = pixel_rays(np.frombuffer(K_bytes, dtype=float).reshape(3, 3), height, width)
    rays.flags.writeable = False
    return rays


def unit_correction(scale: float, offset_m: float) -> tuple[float, float]:
    """``(k, c)`` of :func:`check_frame` for a sensor that reports ``d_obs = scale d + offset_m``: the true depth
    is ``d = d_obs / scale - offset_m / scale``, so ``k = 1 / scale``, ``c = -offset_m / scale`` (metres)."""
    return (1.0 / float(scale), -float(offset_m) / float(scale))


def check_frame(
    depth_m: np.ndarray,
    K: np.ndarray,
    surface,
    T_base_cam: np.ndarray,
    sigma_m,
    options: CheckOptions | None = None,
    depth_correction: tuple = (1.0, 0.0),
) -> FrameCheck:
    """Check ``T_base_cam`` against one depth frame (module docstring).

    Parameters
    ----------
    depth_m : array, shape (H, W)
        Depth, metres, 0 or NaN where the sensor has none.
    K : array, shape (3, 3)
        Camera matrix of the depth image (OpenCV convention).
    surface : object with ``points_base`` and ``normals_base``, arrays of shape (M, 3)
        The robot's surface posed at the frame's joints, base frame, outward normals (``RobotSurface.posed``),
        sampled for the z-buffer's stride ``options.zbuffer_stride`` or, as :class:`handeye.watch.CellWatcher`
        thins it for a long focal length, for :meth:`CheckOptions.stride_for` (a denser one costs more to pose,
        for about as many points checked).
    T_base_cam : array, shape (4, 4)
        The calibration being checked.
    sigma_m : callable
        Axial depth sigma at a depth, metres (``DepthSensor.sigma_m``).
    options : CheckOptions, optional
    depth_correction : (float, float)
        ``(k, c)``: the true depth is ``k z_obs + c`` (metres), as the markerless registration estimates it
        (a sensor reporting ``d_obs = s d + o`` has ``k = 1 / s``, ``c = -o / s``); ``(1, 0)``: none.

    Returns
    -------
    FrameCheck
    """
    o = options or CheckOptions()
    depth_m = np.asarray(depth_m, dtype=float)
    if depth_m.ndim != 2:
        raise ShapeError(f"depth must be one (H, W) image, got shape {depth_m.shape}")
    height, width = depth_m.shape
    rays = camera_rays(K, height, width)
    R, t_cam = T_base_cam[:3, :3], T_base_cam[:3, 3]
    p_cam = (np.asarray(surface.points_base, dtype=float) - t_cam) @ R  # R^T (p - t), row-wise
    n_cam = np.asarray(surface.normals_base, dtype=float) @ R
    idx = _visible(p_cam, n_cam, K, height, width, o.stride_for(K))
    uv = np.rint(project(p_cam[idx], K)).astype(np.int64)
    z_raw = depth_m[uv[:, 1], uv[:, 0]]
    have = np.isfinite(z_raw) & (z_raw > 0)
    z_raw = np.where(have, z_raw, 0.0)
    k, c = depth_correction
    z_obs = np.where(have, k * z_raw + c, 0.0)
    z_mod = p_cam[idx, 2]
    sigma_z = np.asarray(sigma_m(z_mod), dtype=float)
    window = o.window_sigmas * sigma_z + o.window_floor_m
    dz = z_obs - z_mod  # 0 where no depth: those are dropouts below, never matched
    occluder = have & (dz < -window)
    behind = have & (dz > window)
    matched = have & ~occluder & ~behind
    counts = _counts(len(idx), have, occluder, behind, matched, dz, window)
    if counts["n_matched"] < o.min_matched:
        rms = float(np.sqrt(np.mean(dz[matched] ** 2))) if matched.any() else float("nan")
        return FrameCheck(None, None, float("nan"), rms_m=rms, **counts)
    ray = rays[uv[matched, 1], uv[matched, 0]]
    q = ray * z_obs[matched, None]
    m, n = p_cam[idx[matched]], n_cam[idx[matched]]
    r = np.einsum("ij,ij->i", n, q - m)
    s = np.hypot(sigma_z[matched] * np.abs(np.einsum("ij,ij->i", n, ray)), o.model_sigma_m)
    s = np.maximum(s, 1e-9)
    A = np.hstack([np.cross(q, n), n]) / s[:, None]
    b = r / s
    w = loss_weights(b, "cauchy", o.robust_sigmas)
    AW = A * w[:, None]
    H = AW.T @ A
    g = AW.T @ b
    try:
        covariance = np.linalg.inv(H)
    except np.linalg.LinAlgError:
        return FrameCheck(None, None, float("nan"), rms_m=float(np.sqrt(np.mean(r**2))), **counts)
    delta = -covariance @ g
    chi2 = float(delta @ H @ delta)
    # r moves by (n . ray)(z_raw dk + dc) when (k, c) does; the step by -(J^T W J)^-1 J^T W of that
    nr = np.einsum("ij,ij->i", n, ray) / s
    unit = np.stack([nr * z_raw[matched], nr], axis=1)
    gain = -covariance @ (AW.T @ unit)
    joint_gain = _joint_gain(surface, idx[matched], s, AW, covariance)
    return FrameCheck(
        delta,
        covariance,
        chi2,
        rms_m=float(np.sqrt(np.mean(r**2))),
        unit_gain=gain,
        joint_gain=joint_gain,
        **counts,
    )


def _counts(n_visible: int, have, occluder, behind, matched, dz, window) -> dict:
    """The frame's model points by what the depth shows at them (:class:`FrameCheck`'s counts); ``n_at_offset``:
    those within the match window of the residuals' median (one offset: a move or a wrong unit, not an occluder)."""
    offset = np.median(dz[have]) if have.any() else 0.0
    return dict(
        n_visible=n_visible,
        n_matched=int(matched.sum()),
        n_occluders=int(occluder.sum()),
        n_behind=int(behind.sum()),
        n_dropout=int((~have).sum()),
        n_at_offset=int((have & (np.abs(dz - offset) <= window)).sum()),
    )


def _joint_gain(surface, rows, s, AW, covariance) -> np.ndarray | None:
    """``d delta / d q`` (6, nq) of the matched model points ``rows`` (sigmas ``s``; ``AW`` the whitened, weighted
    Jacobian), or None when the surface carries no joint twists: a joint error ``dq`` moves a point ``m`` of part
    ``k`` by ``(omega x m + v) dq`` (base frame), so its residual ``n . (q - m)`` by ``-n . (omega x m + v) dq``
    (:func:`classic.markerless.kinematics.offset_columns`; the normal's turn is of second order: ``q - m`` is
    small), the same in any frame."""
    twists = getattr(surface, "joint_twists_base", None)
    if twists is None:
        return None
    frame = np.asarray(surface.frame)[rows]
    tw = np.asarray(twists)[frame, np.asarray(surface.part)[rows]]  # (M, nq, 6): (omega, v), base frame
    normals = np.asarray(surface.normals_base, dtype=float)[rows]
    points = np.asarray(surface.points_base, dtype=float)[rows]
    dr = offset_columns(normals, points, tw) / s[:, None]
    return -covariance @ (AW.T @ dr)


def with_joint_noise(check: FrameCheck, variance: float) -> FrameCheck:
    """The check with the joints' error in its covariance: ``Sigma + variance G G^T``, ``G`` its
    :attr:`FrameCheck.joint_gain` (``chi2`` recomputed with it).

    The check takes the recorded joints as exact; their error (encoder noise, the joint state's time against the
    depth image's while the arm moves) moves the whole posed surface, an error of the frame's step that no number
    of pixels averages away. With a precise sensor it is most of the step's scatter, and its share changes with the
    arm's pose (the levers of the joints to the links in view): counted as pixel noise, the statistic of some poses
    runs several times the one scale learnt (the running-cell benchmark's ``zivid`` stream, docs/benchmarks/
    running-cell.md). ``variance`` is per joint, in the units of ``covariance`` (the null's scale multiplies it
    too): :func:`handeye.watch.change.fit_joint_variance` learns it.

    Parameters
    ----------
    check : FrameCheck
    variance : float
        Radians squared, per joint, over the null's scale; 0: the check as it is.

    Returns
    -------
    FrameCheck
    """
    if variance == 0 or check.delta is None or check.joint_gain is None:
        return check
    G = check.joint_gain
    covariance = check.covariance + variance * (G @ G.T)
    chi2 = float(check.delta @ np.linalg.solve(covariance, check.delta))
    return replace(check, covariance=covariance, chi2=chi2)


def _visible(p_cam: np.ndarray, n_cam: np.ndarray, K: np.ndarray, height: int, width: int, stride: int) -> np.ndarray:
    """Indices of the front-facing points nearest the camera in each z-buffer pixel (``stride`` image pixels wide)."""
    frame = np.zeros(len(p_cam), dtype=np.int64)
    return visible_points(p_cam, n_cam, frame, *zbuffer_grid(K, height, width, stride))
