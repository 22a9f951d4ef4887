"""Maximum-likelihood refinement of X and Y on SE(3) over pose residuals.

Minimises, over the camera pose X and the target pose Y of ``A_i Y = X B_i``,

.. math:: \\sum_i \\rho\\big(\\| W_i\\, r_i(X, Y) \\|^2\\big), \\qquad
          r_i = \\big[\\log(\\hat R_i^T R_{B_i}),\\ t_{B_i} - \\hat t_i\\big], \\quad \\hat B_i = X^{-1} A_i Y,

with ``W_i^T W_i = S_i^-1`` the inverse of the residual's covariance under the noise model
(:mod:`classic.noise_model`: camera and robot noise, anisotropic, per pose, the lever arm). With
Gaussian noise this is the maximum-likelihood estimate to first order. ``S_i`` depends on X and Y
(through the lever arm), so it is evaluated at the estimate and the fit repeated until it settles.
When no noise model is given, the camera-only model is used with one rotation and one translation
scale estimated from the residuals (robustly first, then re-estimated at the optimum, corrected for
each residual's leverage; :func:`_scales`).

Optional extra parameters: a metric scale ``s`` of the camera translations (``t_B <- s t_B``, for
monocular SLAM poses) and a time offset of the camera stream against the robot stream
(:class:`classic.robot_stream.RobotStream`: the robot poses are interpolated at the camera times
plus the offset).

Parametrisation: ``R_X <- so3_exp(w_X) R_X`` and ``t_X <- t_X + v_X`` (same for Y), so the
covariance's blocks read directly as rotation error (rad, in the frame X is expressed in) and
translation error (m). Parameter order: ``[w_X, v_X, w_Y, v_Y, (s), (dt)]``. The optimiser and the
covariance are :mod:`classic.least_squares`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from classic.least_squares import POSE_NAMES, covariance_from_jacobian, fit_least_squares, loss_weights
from classic.noise_model import (
    NoiseModel,
    as_noise_model,
    residual_covariances,
    right_jacobian_inverse,
    robot_residual_jacobian,
    whitening,
)
from classic.residuals import pose_residuals, predict_cam_target, residuals_of_prediction
from handeye.core.se3 import hat, make_transform, so3_exp, so3_log
from handeye.core.setups import robot_side_poses

__all__ = [
    "LOSSES",
    "Refinement",
    "RefineOptions",
    "refine_xy",
    "ROBUST_SCALE",
    "cramer_rao_bound",
    "pose_residual_jacobian",
]

LOSSES = ("linear", "huber", "cauchy")
#: Where the robust losses bend, on each whitened residual component (unit variance when the model fits).
ROBUST_SCALE = 2.5
_CHI2_3_MEDIAN = 2.36597
_CHI2_6_MEDIAN = 5.34812
#: Outer passes at most (noise scales and S_i re-evaluated at the estimate each pass).
_PASSES = 4
#: Significance at which the camera-frame translation residuals' axes are taken to differ in spread
#: (:func:`_scales`), and the fewest poses the test is made on. The two errors cost unequally: a missed
#: depth noise leaves that fit far from the bound, a false alarm costs little. PnP-like noise (10x along
#: the line of sight) at 10 poses: 1.051 / 1.120 of the bound at 0.01, 1.016 / 1.001 at 0.05 (found in 495
#: of 500 trials); isotropic noise is taken for anisotropic in 4-5 % of the trials at 0.05, under 1 % over
#: the cell (``benchmarks/classic_ml.py``, its efficiency table's last column).
_ANISOTROPY_P = 0.05
_ANISOTROPY_MIN_POSES = 8
#: What a refusal of an undetermined direction (:func:`classic.least_squares.require_determined`) asks for.
_REMEDY = (
    "record robot motions that turn about at least two different axes (turns about one axis leave the "
    "translation along it free, pure translations the whole translation); a metric scale needs camera translations, "
    "a time offset robot motion"
)


@dataclass
class Refinement:
    """Outcome of :func:`refine_xy`.

    Attributes
    ----------
    X, Y : array, shape (4, 4)
    covariance : array, shape (12, 12)
        Of ``[w_X, v_X, w_Y, v_Y]`` (rad, m).
    sigma_rot_rad, sigma_trans_m : float
        Camera-noise scales used, RMS over the three axes (estimated, or the given model's camera part).
    weights : array, shape (N,)
        Final robust weight per pose (mean over its six residuals; all 1 for the linear loss).
    iterations : int
        Residual evaluations of the optimiser, over all passes.
    cost_initial, cost_final : float
        Sum of squared whitened residuals at the start and the end (with the final noise model).
    converged : bool
    noise_model : dict
        Which model was used (:meth:`classic.noise_model.NoiseModel.describe`) and whether estimated.
    variance_factor : float
        ``cost_final / (6 N - P)``: 1 when the given model matches the residuals.
    scale, scale_sigma : float
        Metric scale of the camera translations and its sigma (1 and 0 when not estimated).
    time_offset_s, time_offset_sigma_s : float
        Camera-stream time offset and its sigma (0 and 0 when not estimated).
    whitened : array, shape (N, 6)
        Final whitened residuals per pose (unit variance per component under the model).
    jacobian : array, shape (6N, P)
        Whitened Jacobian at the estimate (``[w_X, v_X, w_Y, v_Y, (s), (dt)]``).
    model : NoiseModel or None
        The model itself (``noise_model`` describes it): the given one, or the one estimated.
    """

    X: np.ndarray
    Y: np.ndarray
    covariance: np.ndarray
    sigma_rot_rad: float
    sigma_trans_m: float
    weights: np.ndarray
    iterations: int
    cost_initial: float
    cost_final: float
    converged: bool
    noise_model: dict
    variance_factor: float = 1.0
    scale: float = 1.0
    scale_sigma: float = 0.0
    time_offset_s: float = 0.0
    time_offset_sigma_s: float = 0.0
    whitened: np.ndarray | None = None
    jacobian: np.ndarray | None = None
    model: NoiseModel | None = None


def _apply(T: np.ndarray, w: np.ndarray, v: np.ndarray) -> np.ndarray:
    return make_transform(so3_exp(w) @ T[:3, :3], T[:3, 3] + v)


def _update(X, Y, delta):
    return _apply(X, delta[0:3], delta[3:6]), _apply(Y, delta[6:9], delta[9:12])


def _scales(r_rot, r_trans, w, robust: bool, n_params: int = 12, leverage=None) -> tuple[float, float | np.ndarray]:
    """Camera-noise scales from the residuals: one for rotation; for translation one, or (across, across, along).

    Robust: the median of the squared norms over the chi-square(3) median. Otherwise the weighted
    mean square, each residual corrected for what the fit absorbed (``r / sqrt(1 - h)`` with ``h``
    the hat matrix's diagonal, ``leverage`` (N, 6)), or with a global degrees-of-freedom factor when
    no leverage is given.

    The translation residual is in the camera frame, where a PnP pose is poor along the optical axis
    (depth). It gets two scales, across the line of sight (x and y pooled) and along it (z), only when a
    Brown–Forsythe test (:func:`brown_forsythe_p`, ``scipy.stats.levene`` median-centred) on the
    leverage-corrected residuals says their spreads differ at :data:`_ANISOTROPY_P`. Three free per-axis
    scales ran away on a dozen poses (an axis the fit follows closely gets a smaller scale, hence more
    weight: an overconfident covariance); pooling the two lateral axes halves that scale's sampling
    error, and the test keeps isotropic noise isotropic. Rotation keeps one scale (its residual is in
    the target frame, which turns with every pose).
    """
    w = np.ones(len(r_rot)) if w is None else np.asarray(w, dtype=float)
    out = []
    for k, r in enumerate((np.asarray(r_rot), np.asarray(r_trans))):
        if leverage is not None:
            r = r / np.sqrt(np.clip(1.0 - np.asarray(leverage)[:, 3 * k : 3 * k + 3], 1e-6, None))
        n = w.sum()
        dof = 1.0 if leverage is not None else max(6.0 * n - n_params, 1.0) / (6.0 * n)
        if k == 1 and len(r) >= _ANISOTROPY_MIN_POSES:
            across, along = np.concatenate([r[:, 0], r[:, 1]]), r[:, 2]
            if brown_forsythe_p(across, along) < _ANISOTROPY_P:
                if robust:
                    level = 1.4826 * np.array([np.median(np.abs(across)), np.median(np.abs(along))])
                else:
                    level = np.sqrt([np.sum(np.r_[w, w] * across**2) / (2.0 * n) / dof, np.sum(w * along**2) / n / dof])
                level = np.maximum(level, 1e-12)
                out.append(np.array([level[0], level[0], level[1]]))
                continue
        z2 = np.sum(r**2, axis=1)
        if robust:
            level = np.sqrt(np.median(z2) / _CHI2_3_MEDIAN)
        else:
            level = np.sqrt(np.sum(w * z2) / (3.0 * n) / dof)
        out.append(max(float(level), 1e-12))
    return out[0], out[1]


def brown_forsythe_p(a: np.ndarray, b: np.ndarray) -> float:
    """p-value of the Brown–Forsythe test that two samples have the same spread.

    ``scipy.stats.levene(a, b, center="median").pvalue`` (the tests check the two agree), written
    out for two groups: the one-way ANOVA F of the absolute deviations from each group's median, its
    tail from ``scipy.special.fdtrc``. ``levene``'s general argument handling costs several times the
    arithmetic, and the refinement asks once per pass.

    Parameters
    ----------
    a, b : array, shape (n_a,) and (n_b,)

    Returns
    -------
    float
    """
    from scipy.special import fdtrc

    za = np.abs(a - np.median(a))
    zb = np.abs(b - np.median(b))
    na, nb = len(za), len(zb)
    ma, mb = za.mean(), zb.mean()
    m = (na * ma + nb * mb) / (na + nb)
    between = na * (ma - m) ** 2 + nb * (mb - m) ** 2
    within = np.sum((za - ma) ** 2) + np.sum((zb - mb) ** 2)
    if within <= 0.0:
        return 0.0 if between > 0.0 else 1.0
    return float(fdtrc(1.0, na + nb - 2.0, (na + nb - 2.0) * between / within))


def _camera_model(s_r: float, s_t) -> NoiseModel:
    per_axis = np.ndim(s_t) > 0
    name = "camera, estimated (translation across and along the line of sight)" if per_axis else "camera, estimated"
    return NoiseModel(camera_rot_rad=s_r, camera_trans_m=tuple(s_t) if per_axis else s_t, name=name)


def _left_jacobian_inverse(r: np.ndarray) -> np.ndarray:
    """``J_l(r)^-1`` of SO(3): ``log(exp(-d) exp(r)) = r - J_l(r)^-1 d`` to first order. Shape (N, 3, 3)."""
    return right_jacobian_inverse(-np.asarray(r))  # J_l(r) = J_r(-r)


def pose_residual_jacobian(A, B, X, Y, R_P=None, r_rot=None):
    """Analytic Jacobian of the raw residuals w.r.t. ``[w_X, v_X, w_Y, v_Y]``, shape (N, 6, 12).

    With ``P_i = X^-1 A_i Y`` and ``w_i = R_A t_Y + t_A - t_X`` (so ``t_P = R_X^T w_i``):
    ``d r_rot / d w_X = Jl^-1 R_P^T R_X^T``, ``d r_rot / d w_Y = -Jl^-1 R_Y^T``,
    ``d r_t / d w_X = -R_X^T [w_i]x``, ``d r_t / d v_X = R_X^T``, ``d r_t / d v_Y = -R_X^T R_A``.
    ``R_P`` (N, 3, 3) and the rotation residuals ``r_rot`` (N, 3), when the caller has them, are not
    computed again.
    """
    R_X, t_X, R_Y, t_Y = X[:3, :3], X[:3, 3], Y[:3, :3], Y[:3, 3]
    R_A, t_A = A[:, :3, :3], A[:, :3, 3]
    if R_P is None or r_rot is None:
        R_P = R_X.T @ R_A @ R_Y
        r_rot = so3_log(np.swapaxes(R_P, 1, 2) @ B[:, :3, :3])
    Jinv = _left_jacobian_inverse(r_rot)
    w = R_A @ t_Y + t_A - t_X
    J = np.zeros((len(A), 6, 12))
    J[:, :3, 0:3] = Jinv @ np.swapaxes(R_P, 1, 2) @ R_X.T
    J[:, :3, 6:9] = -(Jinv @ R_Y.T)
    J[:, 3:, 0:3] = -(R_X.T @ hat(w))
    J[:, 3:, 3:6] = R_X.T
    J[:, 3:, 9:12] = -(R_X.T @ R_A)
    return J


class _Problem:
    """The residuals and Jacobian of one pass, about a base point ``at = (X, Y, s, dt)`` with fixed ``W_i``."""

    def __init__(self, A_of, B, setup, at: tuple, W, with_scale, with_offset):
        self.A_of, self.B, self.setup = A_of, B, setup
        (self.X, self.Y, self.s, self.dt), self.W = at, W
        self.with_scale, self.with_offset = with_scale, with_offset
        self.n_params = 12 + int(with_scale) + int(with_offset)
        self._last = None

    def unpack(self, delta):
        X, Y = _update(self.X, self.Y, delta)
        k = 12
        s = self.s
        if self.with_scale:
            s = self.s + delta[k]
            k += 1
        dt = self.dt + delta[k] if self.with_offset else self.dt
        return X, Y, s, dt

    def _at(self, delta):
        """Poses, prediction and residuals at ``delta``; the last one kept (the optimiser asks for the
        residuals and then the Jacobian at the same point)."""
        key = np.asarray(delta, dtype=float).tobytes()
        if self._last is None or self._last[0] != key:
            X, Y, s, dt = self.unpack(delta)
            A, rate = self.A_of(dt)
            B = _scaled(self.B, s)
            P = predict_cam_target(A, X, Y)
            self._last = (key, X, Y, s, A, rate, B, P, *residuals_of_prediction(P, B))
        return self._last[1:]

    def raw(self, delta):
        *_, r_rot, r_t = self._at(delta)
        return np.concatenate([r_rot, r_t], axis=1)

    def fun(self, delta):
        return np.einsum("nij,nj->ni", self.W, self.raw(delta)).ravel()

    def jac(self, delta):
        X, Y, s, A, rate, B, P, r_rot, _ = self._at(delta)
        J = pose_residual_jacobian(A, B, X, Y, R_P=P[:, :3, :3], r_rot=r_rot)
        cols = [J]
        if self.with_scale:
            c = np.zeros((len(A), 6, 1))
            c[:, 3:, 0] = self.B[:, :3, 3]
            cols.append(c)
        if self.with_offset:
            cols.append((robot_residual_jacobian(A, X, Y, self.setup, _scaled(self.B, s)) @ rate[:, :, None]))
        J = cols[0] if len(cols) == 1 else np.concatenate(cols, axis=2)
        return np.einsum("nij,njk->nik", self.W, J).reshape(-1, self.n_params)


@dataclass(frozen=True, kw_only=True)
class RefineOptions:
    """Settings of :func:`refine_xy`: the loss, the noise model, the iterations and the extra unknowns' starts.

    Attributes
    ----------
    loss : {"linear", "huber", "cauchy"}
        On each whitened residual component, bending at :data:`ROBUST_SCALE`.
    noise : None, (float, float) or NoiseModel
        None: camera-only noise with its scales estimated from the residuals (:func:`_scales`: one for
        rotation; translation across and along the line of sight when they differ); a pair: camera-only
        per-axis ``(sigma_rot_rad, sigma_trans_m)``; a :class:`classic.noise_model.NoiseModel`:
        camera and robot noise as stated.
    max_iterations : int
        Bounds the optimiser's residual evaluations per pass (3x this); 0 keeps ``(X0, Y0)`` and
        evaluates the covariance there.
    tol : float
        scipy's tolerances.
    setup : {"eye_to_hand", "eye_in_hand"}
        Needed for the robot-noise part of the model and for a robot stream.
    estimate_scale : bool
        Also estimate a metric scale ``s`` of the camera translations (``t_B <- s t_B``).
    scale0 : float
        Its start.
    time_offset0_s : float
        Start of the time offset, estimated with a robot stream (robot time = camera time + offset).
    undetermined : {"refuse", "infinite"}
        What a direction the poses do not determine does (:func:`classic.least_squares.covariance_from_jacobian`):
        refused with :class:`~handeye.core.errors.DegenerateMotionError` naming it, or (for a caller whose
        motion check is off) an infinite variance of the parameters it moves.
    """

    loss: str = "linear"
    noise: object = None
    max_iterations: int = 50
    tol: float = 1e-12
    setup: str = "eye_to_hand"
    estimate_scale: bool = False
    scale0: float = 1.0
    time_offset0_s: float = 0.0
    undetermined: str = "refuse"


def refine_xy(
    A: np.ndarray | None,
    B: np.ndarray,
    X0: np.ndarray,
    Y0: np.ndarray,
    options: RefineOptions | None = None,
    stream=None,
    camera_times_s: np.ndarray | None = None,
) -> Refinement:
    """Refine ``A_i Y = X B_i`` by weighted nonlinear least squares from ``(X0, Y0)``.

    Parameters
    ----------
    A : array, shape (N, 4, 4)
        Robot-side poses (``T_base_ee`` eye-to-hand, ``T_ee_base`` eye-in-hand); ignored when
        ``stream`` is given.
    B : array, shape (N, 4, 4)
        ``T_cam_target``.
    X0, Y0 : array, shape (4, 4)
        Initial camera and target poses.
    options : RefineOptions, optional
        Loss, noise model, iterations, setup, scale and time offset; None: :class:`RefineOptions`' defaults.
    stream : classic.robot_stream.RobotStream, optional
        Robot poses ``T_base_ee`` over time: the robot side is interpolated at ``camera_times_s``
        plus a time offset, which is estimated.
    camera_times_s : array, shape (N,), optional
        Times of the camera poses ``B`` (with ``stream``).

    Returns
    -------
    Refinement

    Raises
    ------
    DegenerateMotionError
        The poses leave a direction of X, Y (or the scale, the time offset) undetermined: its sigma would
        read as 0. The message names it. Not with ``undetermined="infinite"``.
    """
    run = _start(A, B, X0, Y0, options or RefineOptions(), stream, camera_times_s)
    for p in range(_PASSES if run.opts.max_iterations > 0 else 1):
        if not _one_pass(run, first=p == 0):
            break
    return _outcome(run)


@dataclass
class _Run:
    """A refinement under way: its data and settings, and the estimate and noise model so far."""

    A_of: object  # time offset -> (robot-side poses (N, 4, 4), their rates (N, 6))
    B: np.ndarray
    X0: np.ndarray
    Y0: np.ndarray
    opts: RefineOptions
    with_offset: bool
    estimated: bool
    X: np.ndarray
    Y: np.ndarray
    s: float
    dt: float
    model: NoiseModel | None
    factor: float = 1.0  # common variance factor of a model given up to scale (scale_to_residuals)
    weights: np.ndarray | None = None
    evaluations: int = 0
    converged: bool = True

    def problem(self, W: np.ndarray, X=None, Y=None, s=None, dt=None) -> _Problem:
        """The residuals about the estimate (or the given point) with the whitening ``W`` fixed."""
        at = (self.X, self.Y, self.s, self.dt) if X is None else (X, Y, s, dt)
        return _Problem(self.A_of, self.B, self.opts.setup, at, W, self.opts.estimate_scale, self.with_offset)

    def whitening(self) -> np.ndarray:
        """``W_i`` of the noise model at the estimate, shape (N, 6, 6)."""
        A_now, _ = self.A_of(self.dt)
        cov = residual_covariances(self.model, A_now, _scaled(self.B, self.s), self.X, self.Y, self.opts.setup)
        return whitening(self.factor * cov)


def _start(A, B, X0, Y0, opts: RefineOptions, stream, camera_times_s) -> _Run:
    """The checked settings, the robot side as a function of the time offset, and the starting noise model."""
    if opts.loss not in LOSSES:
        raise ValueError(f"unknown loss {opts.loss!r}: use one of {LOSSES}")
    model = as_noise_model(opts.noise)
    B = np.asarray(B, dtype=float)
    A_of = _robot_side(A, opts.setup, stream, camera_times_s)
    s, dt = float(opts.scale0), float(opts.time_offset0_s)
    run = _Run(
        A_of, B, X0, Y0, opts, with_offset=stream is not None, estimated=model is None,
        X=X0, Y=Y0, s=s, dt=dt, model=model, weights=np.ones(len(B)),
    )  # fmt: skip
    if run.estimated:
        A_now, _ = A_of(dt)
        run.model = _camera_model(*_scales(*pose_residuals(A_now, _scaled(B, s), X0, Y0), None, robust=True))
    return run


def _robot_side(A, setup: str, stream, camera_times_s):
    """``dt -> (A, rate)``: the fixed poses with zero rates, or the stream's at the camera times plus ``dt``."""
    if stream is not None:
        times = np.asarray(camera_times_s, dtype=float)

        def A_of(dt):
            T, rate = stream.at(times + dt)
            if setup == "eye_to_hand":
                return T, rate
            return robot_side_poses(T, setup), rate

        return A_of
    A_fixed = np.asarray(A, dtype=float)
    zero_rate = np.zeros((len(A_fixed), 6))

    def A_of(dt):
        return A_fixed, zero_rate

    return A_of


def _one_pass(run: _Run, first: bool) -> bool:
    """One fit with ``S_i`` fixed at the estimate, then the noise model at the new one; whether to go on."""
    n, opts = len(run.B), run.opts
    prob = run.problem(run.whitening())
    fit = fit_least_squares(
        prob.fun,
        prob.jac,
        prob.n_params,
        loss=opts.loss,
        loss_scale=ROBUST_SCALE,
        max_evaluations=3 * opts.max_iterations,
        tol=opts.tol,
    )
    run.evaluations += fit.evaluations if opts.max_iterations > 0 else 0
    run.converged = fit.converged
    run.X, run.Y, run.s, run.dt = prob.unpack(fit.x)
    moved = float(np.abs(fit.x).max())
    run.weights = fit.weights.reshape(n, 6).mean(axis=1)
    if run.estimated:
        changed = _reestimate_camera_noise(run, fit, prob.n_params)
    elif run.model.scale_to_residuals:
        changed = _rescale_model(run, fit, prob.n_params)
    else:  # a given model: S_i depends on X and Y through the robot's part, so evaluate it once more
        changed = 1.0 if (first and run.model.has_robot_noise) else 0.0
    # a 1 % change of the noise scales moves the estimate by a small fraction of its sigma
    return not (changed < 1e-2 or moved < 1e-12)


def _reestimate_camera_noise(run: _Run, fit, n_params: int) -> float:
    """The camera-only model's scales from the residuals at the estimate (leverage-corrected); their change."""
    n = len(run.B)
    A_now, _ = run.A_of(run.dt)
    r_rot, r_t = pose_residuals(A_now, _scaled(run.B, run.s), run.X, run.Y)
    old = (run.model.camera_rot_rad, run.model.camera_trans_m)
    hat = _leverages(fit.jacobian, None if run.opts.loss == "linear" else fit.weights).reshape(n, 6)
    s_r, s_t = _scales(r_rot, r_t, run.weights, robust=run.opts.loss != "linear", n_params=n_params, leverage=hat)
    run.model = _camera_model(s_r, s_t)
    return float(max(abs(s_r / old[0] - 1.0), np.max(np.abs(np.asarray(s_t) / np.asarray(old[1]) - 1.0))))


def _rescale_model(run: _Run, fit, n_params: int) -> float:
    """The variance factor of a model given up to scale, from the whitened residuals; its relative change."""
    d2 = np.sum(fit.residuals.reshape(len(run.B), 6) ** 2, axis=1)
    if run.opts.loss != "linear":
        new = run.factor * float(np.median(d2)) / _CHI2_6_MEDIAN
    else:
        new = run.factor * float(np.sum(run.weights * d2)) / max(6.0 * run.weights.sum() - n_params, 1.0)
    new = max(new, 1e-300)
    changed, run.factor = abs(new / run.factor - 1.0), new
    return changed


def _outcome(run: _Run) -> Refinement:
    """The final evaluation at the estimate with the final model: covariance, costs, the extra unknowns' sigmas."""
    n, opts = len(run.B), run.opts
    W = run.whitening()
    prob = run.problem(W)
    zero = np.zeros(prob.n_params)
    r_final = prob.fun(zero)
    J = prob.jac(zero)
    names = POSE_NAMES + ("scale",) * int(opts.estimate_scale) + ("time offset",) * int(run.with_offset)
    weights = loss_weights(r_final, opts.loss, ROBUST_SCALE)
    cov_full = covariance_from_jacobian(J, weights, names=names, remedy=_REMEDY, undetermined=opts.undetermined)
    # the start's cost under the final noise model
    start = run.problem(W, run.X0, run.Y0, float(opts.scale0), float(opts.time_offset0_s))
    sigmas = np.sqrt(np.diag(cov_full)[12:])  # (s), (dt)
    cam = run.factor * run.model.camera(n).mean(axis=0)
    cost_final = float(r_final @ r_final)
    return Refinement(
        X=run.X,
        Y=run.Y,
        covariance=cov_full[:12, :12],
        sigma_rot_rad=float(np.sqrt(np.trace(cam[:3, :3]) / 3.0)),
        sigma_trans_m=float(np.sqrt(np.trace(cam[3:, 3:]) / 3.0)),
        weights=run.weights,
        iterations=run.evaluations,
        cost_initial=float(np.sum(start.fun(np.zeros(prob.n_params)) ** 2)),
        cost_final=cost_final,
        converged=bool(run.converged),
        noise_model=_described(run),
        variance_factor=cost_final / max(6 * n - prob.n_params, 1),
        scale=float(run.s),
        scale_sigma=float(sigmas[0]) if opts.estimate_scale else 0.0,
        time_offset_s=float(run.dt),
        time_offset_sigma_s=float(sigmas[-1]) if run.with_offset else 0.0,
        whitened=r_final.reshape(n, 6),
        jacobian=J,
        model=run.model,
    )


def _described(run: _Run) -> dict:
    """The noise model's description, with whether it was estimated and the variance factor applied."""
    described = run.model.describe()
    described["estimated"] = bool(run.estimated)
    if run.model.scale_to_residuals:
        described["variance_factor_applied"] = run.factor
    return described


#: Rows of a Jacobian whose leverages :func:`_leverages` takes at once (10,000 poses): a larger set's in blocks.
_LEVERAGE_ROWS = 60_000


def _leverages(J: np.ndarray, weights: np.ndarray | None) -> np.ndarray:
    """Diagonal of the hat matrix ``Jw (Jw^T Jw)^+ Jw^T``, ``Jw = J sqrt(weights)``; shape (M,).

    Block by block beyond :data:`_LEVERAGE_ROWS` rows, so a large set never holds two more copies of its
    Jacobian (with unit weights, a least-squares fit's, ``Jw`` is ``J`` itself: ``J * 1.0`` is exact).
    """
    Jw = J if weights is None else J * np.sqrt(weights)[:, None]
    P = np.linalg.pinv(Jw.T @ Jw)
    if len(Jw) <= _LEVERAGE_ROWS:
        return np.einsum("ij,ij->i", Jw @ P, Jw)
    out = np.empty(len(Jw))
    for a in range(0, len(Jw), _LEVERAGE_ROWS):
        part = Jw[a : a + _LEVERAGE_ROWS]
        out[a : a + _LEVERAGE_ROWS] = np.einsum("ij,ij->i", part @ P, part)
    return out


def _scaled(B: np.ndarray, s: float) -> np.ndarray:
    if s == 1.0:
        return B
    out = B.copy()
    out[:, :3, 3] *= s
    return out


def cramer_rao_bound(A: np.ndarray, X: np.ndarray, Y: np.ndarray, noise, setup: str = "eye_to_hand") -> np.ndarray:
    """The Cramér–Rao bound of ``[w_X, v_X, w_Y, v_Y]`` at the truth, for a pose set and a noise model.

    The inverse of the Fisher information ``sum_i J_i^T S_i^-1 J_i`` (first order, Gaussian noise),
    with ``J_i`` the residual's Jacobian and ``S_i`` its covariance under the model, both at the
    truth. No unbiased estimator does better on average; it also tells, before recording, what a
    planned set of poses can give.

    Parameters
    ----------
    A : array, shape (N, 4, 4)
        Robot-side poses (true).
    X, Y : array, shape (4, 4)
        True camera and target poses.
    noise : (float, float) or NoiseModel
    setup : {"eye_to_hand", "eye_in_hand"}

    Returns
    -------
    array, shape (12, 12)
        Covariance bound (rad, m); ``classic.least_squares.sigma_of_blocks`` gives its magnitudes.

    Raises
    ------
    DegenerateMotionError
        The pose set leaves a direction of ``[w_X, v_X, w_Y, v_Y]`` undetermined (an infinite bound), named.
    """
    model = as_noise_model(noise)
    if model is None:
        raise ValueError("the bound needs a noise model")
    A = np.asarray(A, dtype=float)
    B = np.linalg.inv(X) @ A @ Y
    W = whitening(residual_covariances(model, A, B, X, Y, setup))
    J = np.einsum("nij,njk->nik", W, pose_residual_jacobian(A, B, X, Y)).reshape(-1, 12)
    return covariance_from_jacobian(J, names=POSE_NAMES, remedy=_REMEDY)
