""" "Nothing moved", learnt from the first seconds of a stream, and a sequential test that says when it stops holding.

**The null.** Each frame's check (:mod:`handeye.watch.check`) gives a correction ``delta`` (6,) with a
covariance ``Sigma`` that counts pixels as independent. Two things make the raw ``delta^T Sigma^{-1} delta``
no ``chi2(6)``: pixels of one frame share errors (the sensor's correlated noise, the model's sampling), which
scales it up, and a fixed bias of the model and the sensor (depth scale and offset, mesh detail) gives
``delta`` a mean even when nothing moved. :func:`fit_null` takes the first ``N`` frames as "nothing moved":
the bias ``delta_ref`` is their mean weighted by each frame's information ``Sigma_i^{-1}`` (Huber weights beyond
the ``REF_HUBER_LEVEL`` quantile of ``chi2(6)``: a few odd frames in the first seconds move it little), its own
covariance ``Sigma_ref = (sum_i w_i Sigma_i^{-1})^{-1}``, and the scale ``c`` the median of
``x_i = (delta_i - delta_ref)^T Sigma_i^{-1} (delta_i - delta_ref) / (1 - h_i)`` (``h_i`` the frame's share
of the reference's information) over the median of ``chi2(6)``. Each frame is then tested with
``(Sigma + Sigma_ref) c``: the reference's error is shared by every frame after it, and the frames' covariances
differ with the arm's pose by factors of ten, so a component-wise median's error, small against the frames
that dominate it, was several sigmas of the best-determined frames: on the running-cell benchmark's
30-minute static stream at 2 Hz (true calibration and depth unit), a null learnt from 20 frames at eight places
of the stream gave 0 to 85 false alarms each (273 in the 4 hours), this one 0 to 3 (4 in 4 hours).

**The change test.** A CUSUM of the log-likelihood ratio of ``x = chi2 / c`` under "nothing moved"
(``chi2(6)``) against "the statistic's scale grew by ``1 + rho``" (a shift of noncentrality ``lambda``
raises its mean from 6 to ``6 + lambda``; ``rho = 1`` is tuned to ``lambda`` near 6):

.. math:: \\ell(x) = \\frac{\\rho}{2 (1 + \\rho)} x - 3 \\log(1 + \\rho), \\qquad
          S_t = \\max(0, S_{t-1} + \\min(\\ell(x_t), h / 2)), \\quad \\text{alarm when } S_t \\ge h.

Because ``E_0[e^{\\ell}] = 1`` (and capping the increment only lowers it), the CUSUM's mean run length to a
false alarm is at least ``e^h`` frames (Lorden 1971: the CUSUM is a sequence of one-sided SPRTs, each of which
crosses ``h`` under the null with probability at most ``e^{-h}`` by Wald's inequality, which needs only
``E_0[e^{increment}] <= 1``): ``h = log(frames per false alarm)`` makes the false-alarm
rate **at most** the one stated, whatever the shape of the alternative. The cap ``h / 2`` means no single
frame alarms. The rate holds as far as ``x`` follows ``chi2(6)`` after the fit; the tests simulate it.

**The scale at its upper bound.** The guarantee needs ``E_0[e^{\\ell(x)}] <= 1``; with ``x`` divided by a scale
``c_hat`` while the frames' is ``c``, ``E_0[e^{\\ell}] = (1 + \\rho)^{-3} (1 - \\rho c / (c_hat (1 + \\rho)))^{-3}``,
at most 1 only for ``c_hat >= c``, and steeply above it: a scale 15 % low (``rho = 1``) gives 1.75 per frame.
The median of ``N`` frames has a relative standard error of :data:`MEDIAN_SE` ``/ sqrt(N)``, 17 % for the 20
frames of a 10-s null at 2 Hz (the running-cell benchmark's seed-2 60-minute static stream learnt 2.31 where its
6378 watched frames give 2.71: 7 false alarms in the hour, 0 at 2.71). :class:`NullScale` therefore goes on
estimating ``c`` from every frame the change test passes (not those of a run that ended in an alarm), and the
test divides by its upper confidence bound ``c_hat exp(SCALE_Z MEDIAN_SE / sqrt(n))``, ``n`` the frames' distinct
arm poses (frames of one pose share its part of the step's error): wide while the null is young, within 3 %
after a few thousand poses.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import optimize, stats

__all__ = [
    "NullModel",
    "fit_null",
    "fit_depth_unit",
    "fit_joint_variance",
    "NullScale",
    "Cusum",
    "cusum_threshold",
    "llr",
    "CHI2_6_MEDIAN",
]

#: A component of the depth unit's fit is applied when it is at least this many standard errors
#: (:func:`fit_depth_unit`): a one-sided normal tail of 1e-3, noise taken for a unit error once in a thousand fits.
UNIT_Z = 3.1

#: A frame whose statistic lies beyond this quantile of ``chi2(6)`` gets a Huber weight below 1 in the reference
#: (:func:`fit_null`): a frame of the null is down-weighted once in a hundred, and then slightly.
REF_HUBER_LEVEL = 0.99
#: Rounds of the reweighted reference (from the component-wise median); the weights settle in two or three.
REF_ROUNDS = 3

#: :func:`fit_joint_variance` searches this many decades either side of the joints' variance at which their part of
#: a frame's covariance equals the pixels' (eight grid points a decade, then refined): from a sensor whose noise
#: hides the joints' error by four orders of magnitude in variance to one it hides by as many.
JOINT_GRID_DECADES = 4

#: Median of the chi-square distribution with 6 degrees of freedom.
CHI2_6_MEDIAN = float(stats.chi2.median(6))
#: The relative standard error of the median of ``N`` independent ``chi2(6)`` values is ``MEDIAN_SE / sqrt(N)``:
#: ``1 / (2 f(m) m)``, ``f`` the density at the median ``m`` (the sample median's asymptotic variance
#: ``1 / (4 N f(m)^2)``); 0.757, so 17 % for 20 frames.
MEDIAN_SE = float(1.0 / (2.0 * stats.chi2.pdf(CHI2_6_MEDIAN, 6) * CHI2_6_MEDIAN))
#: The scale is used at this many of its (log-)standard errors above its estimate (:class:`NullScale`), as the depth
#: unit's fit takes :data:`UNIT_Z`: a one-sided normal tail of 1e-3, a scale below the frames' once in a thousand.
SCALE_Z = 3.1
#: :class:`NullScale` keeps at most this many frames' statistics (its bound is then within 1 % of its estimate
#: for any pose count above 1e5 / 10); beyond, the scale stays as they give it.
SCALE_MAX_SAMPLES = 100_000


@dataclass(frozen=True)
class NullModel:
    """ "Nothing moved" as the stream's first frames showed it.

    Attributes
    ----------
    delta_ref : array, shape (6,)
        The corrections' bias when nothing moved (rad, m, camera frame).
    scale : float
        ``c``: the raw statistic over ``chi2(6)``.
    frames : int
        Frames it was fitted on.
    ref_covariance : array, shape (6, 6), or None
        ``Sigma_ref``: the covariance of ``delta_ref`` in the frames' units (before the scale ``c``); None: that
        of a median of ``frames`` frames of the tested frame's own covariance, ``pi / (2 N) Sigma``.
    samples : array, shape (frames,), or None
        The frames' raw statistics whose median over ``CHI2_6_MEDIAN`` is ``scale`` (:func:`fit_null` fitting the
        scale); None when the scale was given. :class:`NullScale` goes on from them.
    """

    delta_ref: np.ndarray
    scale: float
    frames: int
    ref_covariance: np.ndarray | None = None
    samples: np.ndarray | None = None

    def statistic(self, delta: np.ndarray, covariance: np.ndarray) -> float:
        """``x = (delta - delta_ref)^T (Sigma + Sigma_ref)^{-1} (delta - delta_ref) / c``: ``chi2(6)`` when nothing
        moved; ``Sigma_ref`` is the error of ``delta_ref`` (:attr:`ref_covariance`)."""
        d = np.asarray(delta, dtype=float) - self.delta_ref
        covariance = np.asarray(covariance, dtype=float)
        if self.ref_covariance is None:
            return float(d @ np.linalg.solve(covariance, d)) / (self.scale * (1 + np.pi / 2 / self.frames))
        return float(d @ np.linalg.solve(covariance + self.ref_covariance, d)) / self.scale


def fit_null(deltas: np.ndarray, covariances: np.ndarray, scale: float | None = None) -> NullModel:
    """Fit :class:`NullModel` to frames taken as "nothing moved" (module docstring).

    Parameters
    ----------
    deltas : array, shape (N, 6)
    covariances : array, shape (N, 6, 6)
    scale : float, optional
        ``c`` when known (a relearning after a commit keeps the sensor's): only the reference is fitted.

    Returns
    -------
    NullModel

    Raises
    ------
    ValueError
        Fewer than 6 frames (none, with ``scale`` given), or shapes that do not fit.
    """
    deltas = np.asarray(deltas, dtype=float)
    covariances = np.asarray(covariances, dtype=float)
    if deltas.ndim != 2 or deltas.shape[1] != 6 or covariances.shape != (len(deltas), 6, 6):
        raise ValueError(f"deltas (N, 6) and covariances (N, 6, 6) expected, got {deltas.shape}, {covariances.shape}")
    if len(deltas) < (6 if scale is None else 1):
        raise ValueError(f"the null needs at least 6 frames with a check, got {len(deltas)}")
    infos = np.linalg.inv(covariances)
    ref, c = np.median(deltas, axis=0), scale
    bound = float(stats.chi2.isf(1.0 - REF_HUBER_LEVEL, 6))
    for _ in range(REF_ROUNDS):
        d = deltas - ref
        x = np.einsum("ni,nij,nj->n", d, infos, d)
        c = scale if scale is not None else max(float(np.median(x)) / CHI2_6_MEDIAN, 1e-12)
        w = np.minimum(1.0, np.sqrt(bound / np.maximum(x / c, 1e-300)))  # Huber on sqrt(x / c)
        info = np.einsum("n,nij->ij", w, infos)
        ref = np.linalg.solve(info, np.einsum("n,nij,nj->i", w, infos, deltas))
    ref_cov = np.linalg.inv(info)
    if scale is None:  # each frame's residual is shrunk by its share h_i of the reference's information
        d = deltas - ref
        h = np.einsum("n,nij,ji->n", w, infos, ref_cov) / 6.0
        x = np.einsum("ni,nij,nj->n", d, infos, d) / np.maximum(1.0 - h, 1.0 / len(deltas))
        c = max(float(np.median(x)) / CHI2_6_MEDIAN, 1e-12)
        return NullModel(ref, float(c), len(deltas), ref_cov, x)
    return NullModel(ref, float(c), len(deltas), ref_cov)


def fit_depth_unit(deltas: np.ndarray, covariances: np.ndarray, gains: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The depth correction's change ``(dk, dc)`` that makes the frames' corrections one constant.

    A wrong depth unit (scale, offset) biases each frame's correction by an amount that depends on the arm's pose
    (``gains @ (dk, dc)``, :attr:`handeye.watch.check.FrameCheck.unit_gain`); the arm's pose changes slowly, so the
    statistic becomes correlated from frame to frame and heavy-tailed, and the CUSUM's stated rate fails (the
    running-cell benchmark's static stream: lag-1 correlation 0.7, 99th percentile 43 against ``chi2(6)``'s 17).
    Weighted least squares over ``(ref, dk, dc)`` of ``delta_i = ref - gains_i @ (dk, dc)``:

    .. math:: \\min \\sum_i (\\delta_i - r + G_i u)^T \\Sigma_i^{-1} (\\delta_i - r + G_i u)

    Parameters
    ----------
    deltas : array, shape (N, 6)
    covariances : array, shape (N, 6, 6)
    gains : array, shape (N, 6, 2)

    Returns
    -------
    u : array, shape (2,)
        ``(dk, dc)`` to add to the depth correction ``(k, c)`` (c in metres): only its components (in the
        eigenbasis of their information, the corrections' scale counted in, :func:`fit_null`) that are at
        least ``UNIT_Z`` of their standard errors; a scale and an offset are nearly one unknown over the arm's
        depth range, and the poorly determined combination, fitted to noise, would bend the depth elsewhere.
    corrected : array, shape (N, 6)
        The corrections as the new depth correction would have given them, ``delta_i + gains_i @ u``.
    """
    deltas, gains = np.asarray(deltas, dtype=float), np.asarray(gains, dtype=float)
    info = np.linalg.inv(np.asarray(covariances, dtype=float))
    n = len(deltas)
    # unknowns (ref, u): the model of delta_i is [I, -G_i] (ref, u)
    J = np.concatenate([np.broadcast_to(np.eye(6), (n, 6, 6)), -gains], axis=2)  # (N, 6, 8)
    H = np.einsum("nji,njk,nkl->il", J, info, J)
    g = np.einsum("nji,njk,nk->i", J, info, deltas)
    u = np.linalg.lstsq(H, g, rcond=None)[0][6:]
    scale = fit_null(deltas + gains @ u, covariances).scale
    S = (H[6:, 6:] - H[6:, :6] @ np.linalg.solve(H[:6, :6], H[:6, 6:])) / scale  # u's information
    lam, V = np.linalg.eigh(S)
    z = V.T @ u
    u = V @ np.where(z**2 * np.maximum(lam, 0) >= UNIT_Z**2, z, 0.0)
    return u, deltas + gains @ u


def fit_joint_variance(
    deltas: np.ndarray, covariances: np.ndarray, joint_gains: np.ndarray, unit_gains: np.ndarray | None = None
) -> float:
    """The recorded joints' error variance ``a`` (per joint, in the frames' units) from frames taken as "nothing
    moved": each frame's covariance is then ``Sigma_i + a G_i G_i^T`` (:func:`handeye.watch.check.with_joint_noise`).

    The steps are modelled as ``delta_i = ref - U_i u + e_i``, ``e_i ~ N(0, c (Sigma_i + a G_i G_i^T))``: the
    reference, the depth unit's change ``u`` (with ``unit_gains``, as :func:`fit_depth_unit` models it), the scale
    ``c`` and ``a``. ``a`` minimises the negative log-likelihood profiled over the others,

    .. math:: L(a) = \\sum_i \\log\\det(\\Sigma_i + a G_i G_i^T) + 6 N \\log \\hat c(a),

    ``(ref, u)`` their weighted least squares at that ``a``, ``c_hat`` Huber's M-estimate of the frames' statistic's
    scale (:func:`_huber_scale`: the Gaussian profile's mean over 6 with each frame's statistic capped at the
    :data:`REF_HUBER_LEVEL` quantile of ``chi2(6)``, so that a few odd frames in the first seconds move it little;
    the median, as :func:`fit_null` takes the scale, left the sigma five times as scattered, 20 % against 4 % from
    300 frames whose joints' part is as large as the pixels'). One variance for all joints: the frames' scatter
    tells the joints' error from the pixels' only where the joints' share of a step changes with the arm's pose,
    not joint by joint. Searched on a grid of :data:`JOINT_GRID_DECADES` decades either side of the variance at
    which the joints' part of a frame's covariance equals its pixels' (trace over trace, median over the frames),
    then refined; 0 where ``a = 0`` fits as well (a sensor whose noise hides the joints' error).

    Parameters
    ----------
    deltas : array, shape (N, 6)
    covariances : array, shape (N, 6, 6)
        Of the steps, without the joints' part.
    joint_gains : array, shape (N, 6, nq)
        ``d delta / d q`` (:attr:`handeye.watch.check.FrameCheck.joint_gain`).
    unit_gains : array, shape (N, 6, 2), optional

    Returns
    -------
    float
        ``a``, radians squared per joint over the null's scale (``a c`` is the joints' variance).
    """
    deltas, covariances = np.asarray(deltas, dtype=float), np.asarray(covariances, dtype=float)
    G = np.asarray(joint_gains, dtype=float)
    GG = G @ np.swapaxes(G, 1, 2)
    n = len(deltas)
    J = np.broadcast_to(np.eye(6), (n, 6, 6))
    if unit_gains is not None:  # the model of delta_i is [I, -U_i] (ref, u), as fit_depth_unit's
        J = np.concatenate([J, -np.asarray(unit_gains, dtype=float)], axis=2)

    def cost(a: float) -> float:
        S = covariances + a * GG
        info = np.linalg.inv(S)
        H = np.einsum("nji,njk,nkl->il", J, info, J)
        theta = np.linalg.lstsq(H, np.einsum("nji,njk,nk->i", J, info, deltas), rcond=None)[0]
        r = deltas - J @ theta
        c = _huber_scale(np.einsum("ni,nij,nj->n", r, info, r))
        return float(np.sum(np.linalg.slogdet(S)[1]) + 6 * n * np.log(max(c, 1e-300)))

    traces = np.einsum("nii->n", GG)
    if not np.any(traces > 0):
        return 0.0
    unit = float(np.median(np.einsum("nii->n", covariances)[traces > 0] / traces[traces > 0]))
    grid = unit * 10.0 ** np.linspace(-JOINT_GRID_DECADES, JOINT_GRID_DECADES, 8 * JOINT_GRID_DECADES + 1)
    k = int(np.argmin([cost(a) for a in grid]))
    lo, hi = np.log(grid[max(k - 1, 0)]), np.log(grid[min(k + 1, len(grid) - 1)])
    best = optimize.minimize_scalar(lambda v: cost(float(np.exp(v))), bounds=(lo, hi), method="bounded")
    a = float(np.exp(best.x))
    return a if cost(a) < cost(0.0) else 0.0


def _huber_scale(x: np.ndarray) -> float:
    """Huber's M-estimate of the scale ``c`` of statistics ``x`` (N,) that follow ``c chi2(6)``: the ``c`` at which
    ``mean(min(x / c, k))`` is ``E[min(chi2(6), k)]``, ``k`` the :data:`REF_HUBER_LEVEL` quantile (0 when the
    median is)."""
    x = np.asarray(x, dtype=float)
    median = float(np.median(x))
    if not median > 0:
        return 0.0
    k = float(stats.chi2.isf(1.0 - REF_HUBER_LEVEL, 6))
    # E[min(X, k)] = E[X; X < k] + k P(X >= k), and x f_6(x) = 6 f_8(x)
    target = 6.0 * stats.chi2.cdf(k, 8) + k * stats.chi2.sf(k, 6)
    start = np.log(median / CHI2_6_MEDIAN)
    v = optimize.brentq(lambda v: np.mean(np.minimum(x * np.exp(-v), k)) - target, start - 30.0, start + 30.0)
    return float(np.exp(v))


class NullScale:
    """The statistic's scale ``c`` from every frame the change test passed, and its upper bound (module docstring).

    Each tested frame's raw statistic ``x c`` (``(delta - delta_ref)^T (Sigma + Sigma_ref)^{-1} (delta -
    delta_ref)``) is held (:meth:`add`) until the CUSUM is back at 0 (:meth:`keep`) or alarms (:meth:`drop`): a
    move's frames do not widen the null. The estimate is the median of the kept ones over ``CHI2_6_MEDIAN``;
    :attr:`bound`, ``estimate exp(SCALE_Z MEDIAN_SE / sqrt(n))`` with ``n`` their distinct arm poses, is what the
    statistic divides by. Recomputed when the kept frames grew by 2 % (a median of up to
    :data:`SCALE_MAX_SAMPLES` values).

    Parameters
    ----------
    samples : array, shape (N,)
        The first null's frames' raw statistics (:attr:`NullModel.samples`).
    poses : int
        Their distinct arm poses (at most ``N``).
    """

    def __init__(self, samples: np.ndarray, poses: int):
        self._samples = [float(v) for v in np.asarray(samples, dtype=float).ravel()]
        if not self._samples:
            raise ValueError("the scale needs at least one frame's statistic")
        self.poses = max(1, min(int(poses), len(self._samples)))
        self._pending: list[tuple[float, bool]] = []
        self._update()

    @property
    def frames(self) -> int:
        """Frames kept."""
        return len(self._samples)

    def _update(self) -> None:
        self._computed_at = len(self._samples)
        self.estimate = max(float(np.median(self._samples)) / CHI2_6_MEDIAN, 1e-12)
        self.bound = self.estimate * float(np.exp(SCALE_Z * MEDIAN_SE / np.sqrt(self.poses)))

    def add(self, raw: float, new_pose: bool) -> None:
        """Hold one tested frame's raw statistic; ``new_pose``: its arm pose differs from the previous frame's."""
        if np.isfinite(raw):
            self._pending.append((float(raw), bool(new_pose)))

    def drop(self) -> None:
        """Forget the held frames (their run ended in an alarm, or the test was re-armed)."""
        self._pending.clear()

    def keep(self) -> bool:
        """Keep the held frames (the CUSUM is back at 0); True when the bound was recomputed."""
        room = SCALE_MAX_SAMPLES - len(self._samples)
        for raw, new_pose in self._pending[: max(room, 0)]:
            self._samples.append(raw)
            self.poses += new_pose
        self._pending.clear()
        if len(self._samples) >= 1.02 * self._computed_at + 1:
            self._update()
            return True
        return False


def cusum_threshold(frames_per_false_alarm: float) -> float:
    """``h = log(frames per false alarm)``: the CUSUM's false-alarm rate is then at most one per that many frames."""
    if not frames_per_false_alarm > 1:
        raise ValueError(f"frames per false alarm must be > 1, got {frames_per_false_alarm}")
    return float(np.log(frames_per_false_alarm))


def llr(x, rho: float = 1.0):
    """Log-likelihood ratio of ``x`` under ``(1 + rho) chi2(6)`` against ``chi2(6)`` (any shape)."""
    return rho / (2.0 * (1.0 + rho)) * np.asarray(x, dtype=float) - 3.0 * np.log1p(rho)


class Cusum:
    """The one-sided CUSUM of the module docstring.

    Parameters
    ----------
    frames_per_false_alarm : float
        The stated false-alarm rate's inverse, in frames (``3600 * rate_hz / false_alarms_per_hour``).
    rho : float
        The alternative's scale growth.
    """

    def __init__(self, frames_per_false_alarm: float, rho: float = 1.0):
        if not rho > 0:
            raise ValueError(f"rho must be > 0, got {rho}")
        self.h = cusum_threshold(frames_per_false_alarm)
        self.rho = float(rho)
        self.value = 0.0

    @property
    def cap(self) -> float:
        """Largest increment of one frame."""
        return self.h / 2.0

    def update(self, x: float) -> bool:
        """Add one frame's ``x`` (``inf`` for a frame whose evidence is maximal); True when it alarms."""
        step = min(float(llr(x, self.rho)), self.cap)
        self.value = max(0.0, self.value + step)
        return self.value >= self.h

    def reset(self) -> None:
        """Re-arm: the statistic back to 0."""
        self.value = 0.0
