"""The hold-out check: calibrate on all but k poses, predict the k held out, compare with their measurements.

Every pose is held out once (the poses are split into folds of ``k``). For a held-out pose ``i`` the
fit on the other poses predicts the camera's measurement,

.. math:: \\hat T_{cam,target}(i) = X^{-1} A_i Y,

and the prediction error ``r_i = [log(R_pred^T R_meas), t_meas - t_pred]`` is set against its predicted
covariance: the measurement's noise (the fold's noise model through the residual's Jacobians,
:func:`classic.noise_model.residual_covariances`) plus the fold's uncertainty of ``X`` and ``Y`` carried
to the prediction, ``C_i = S_i + J_i P J_i^T``. When the noise model and the covariance are right, the
RMS error over the held-out poses matches the RMS predicted sigma (ratio near 1).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from handeye.core.errors import HandEyeInputError
from handeye.core.se3 import make_transform, so3_exp
from handeye.core.setups import robot_side_poses
from handeye.core.validation import MIN_POSES

__all__ = ["HoldOutCheck", "hold_out_check", "default_k"]


@dataclass
class HoldOutCheck:
    """Prediction errors of held-out poses against their predicted sigma.

    Attributes
    ----------
    k : int
        Poses held out per fold.
    indices : array of int, shape (M,)
        The predicted poses (indices into the calibration's poses).
    fold : array of int, shape (M,)
    rotation_deg, translation_mm : array, shape (M,)
        Norm of the prediction error of ``T_cam_target``.
    sigma_rotation_deg, sigma_translation_mm : array, shape (M,)
        Predicted 1-sigma of those norms (``sqrt`` of the trace of the error's covariance block).
    mahalanobis : array, shape (M,)
        ``sqrt(r^T C^-1 r)`` of the 6-vector error; its square is chi-square with 6 degrees of freedom.
    refused : list of str
        Folds that could not be calibrated, with the reason.
    """

    k: int
    indices: np.ndarray
    fold: np.ndarray
    rotation_deg: np.ndarray
    translation_mm: np.ndarray
    sigma_rotation_deg: np.ndarray
    sigma_translation_mm: np.ndarray
    mahalanobis: np.ndarray
    refused: list = field(default_factory=list)

    @property
    def n_folds(self) -> int:
        """Folds calibrated (refused ones excluded)."""
        return int(len(np.unique(self.fold)))

    @staticmethod
    def _rms(v: np.ndarray) -> float:
        return float(np.sqrt(np.mean(v**2))) if len(v) else float("nan")

    @property
    def summary(self) -> dict:
        """RMS errors and sigmas, their ratios (1 when the sigma is right), the share within 3 sigma.

        Returns
        -------
        dict
        """
        rot, trans = self._rms(self.rotation_deg), self._rms(self.translation_mm)
        s_rot, s_trans = self._rms(self.sigma_rotation_deg), self._rms(self.sigma_translation_mm)
        within = (self.rotation_deg <= 3 * self.sigma_rotation_deg) & (
            self.translation_mm <= 3 * self.sigma_translation_mm
        )
        return {
            "k": self.k,
            "folds": self.n_folds,
            "predicted": int(len(self.indices)),
            "rms_rotation_deg": rot,
            "rms_translation_mm": trans,
            "rms_sigma_rotation_deg": s_rot,
            "rms_sigma_translation_mm": s_trans,
            "ratio_rotation": rot / s_rot if s_rot > 0 else float("nan"),
            "ratio_translation": trans / s_trans if s_trans > 0 else float("nan"),
            "within_3_sigma": float(np.mean(within)) if len(within) else float("nan"),
            "mean_chi2_per_dof": float(np.mean(self.mahalanobis**2) / 6) if len(self.mahalanobis) else float("nan"),
            "refused": list(self.refused),
        }

    def to_dict(self) -> dict:
        """JSON-serialisable: the summary and the per-pose rows."""
        rows = [
            {
                "index": int(i),
                "fold": int(f),
                "rotation_deg": float(r),
                "translation_mm": float(t),
                "sigma_rotation_deg": float(sr),
                "sigma_translation_mm": float(st),
                "mahalanobis": float(m),
            }
            for i, f, r, t, sr, st, m in zip(
                self.indices,
                self.fold,
                self.rotation_deg,
                self.translation_mm,
                self.sigma_rotation_deg,
                self.sigma_translation_mm,
                self.mahalanobis,
            )
        ]
        return {**self.summary, "per_pose": rows}


def default_k(n: int) -> int:
    """Poses held out per fold: five folds, at least one pose each, leaving at least ``2 * MIN_POSES`` to fit."""
    return int(max(1, min(round(n / 5), n - 2 * MIN_POSES)))


def _residuals(A: np.ndarray, B: np.ndarray, X: np.ndarray, Y: np.ndarray) -> np.ndarray:
    from classic.residuals import pose_residuals

    r_rot, r_trans = pose_residuals(A, B, X, Y)
    return np.concatenate([r_rot, r_trans], axis=1)  # (M, 6)


def _prediction_jacobian(A: np.ndarray, B: np.ndarray, X: np.ndarray, Y: np.ndarray, h: float = 1e-6) -> np.ndarray:
    """``d r_i / d [w_X, v_X, w_Y, v_Y]`` by central differences (``R <- exp(w) R``, ``t <- t + v``), (M, 6, 12)."""

    def moved(T, d):
        return make_transform(so3_exp(d[:3]) @ T[:3, :3], T[:3, 3] + d[3:])

    cols = []
    for j in range(12):
        e = np.zeros(12)
        e[j] = h
        plus = _residuals(A, B, moved(X, e[:6]), moved(Y, e[6:]))
        minus = _residuals(A, B, moved(X, -e[:6]), moved(Y, -e[6:]))
        cols.append((plus - minus) / (2 * h))
    return np.stack(cols, axis=2)


def _measurement_covariance(noise: dict, A, B, X, Y, setup, camera_covariance) -> np.ndarray:
    """Covariance of each held-out residual from the measurements' noise under the fold's model, (M, 6, 6)."""
    from classic.noise_model import NoiseModel, residual_covariances

    kw = {}
    if "camera_rotation_deg" in noise:
        kw["camera_rot_rad"] = tuple(np.radians(noise["camera_rotation_deg"]))
        kw["camera_trans_m"] = tuple(np.asarray(noise["camera_translation_mm"]) / 1000.0)
    elif camera_covariance is not None:
        kw["camera_covariance"] = camera_covariance
    else:
        raise HandEyeInputError("the hold-out check needs the per-pose camera covariances of this noise model")
    if "robot_rotation_deg" in noise:
        kw["robot_rot_rad"] = tuple(np.radians(noise["robot_rotation_deg"]))
        kw["robot_trans_m"] = tuple(np.asarray(noise["robot_translation_mm"]) / 1000.0)
    S = residual_covariances(NoiseModel(**kw), A, B, X, Y, setup)
    return S * float(noise.get("variance_factor_applied", 1.0))


def hold_out_check(
    T_base_ee: np.ndarray,
    T_cam_target: np.ndarray,
    setup: str,
    fit: Callable[[np.ndarray], object],
    k: int | None = None,
    use: np.ndarray | None = None,
    camera_covariance: np.ndarray | None = None,
    rng: np.random.Generator | None = None,
) -> HoldOutCheck:
    """Calibrate on all but ``k`` poses, predict the held-out ``T_cam_target``, for every fold.

    Parameters
    ----------
    T_base_ee : array, shape (N, 4, 4)
        Flange poses in the robot base, metres.
    T_cam_target : array, shape (N, 4, 4)
        Measured target poses in the camera's optical frame, metres.
    setup : {"eye_to_hand", "eye_in_hand"}
    fit : callable
        ``fit(keep)`` with ``keep`` a boolean mask of shape (N,) returns the
        :class:`classic.CalibrationResult` of those poses (same options as the calibration checked).
    k : int, optional
        Poses held out per fold; default :func:`default_k` of the poses used.
    use : array of bool, shape (N,), optional
        Poses taking part (default all): pass the calibration's inliers, so that outliers are
        neither fitted nor predicted.
    camera_covariance : array, shape (N, 6, 6), optional
        Per-pose camera covariances, when the noise model has them (PnP poses).
    rng : numpy.random.Generator, optional
        Assigns poses to folds; default seeded, so the check is reproducible.

    Returns
    -------
    HoldOutCheck

    Raises
    ------
    TooFewPosesError
        When fewer than ``MIN_POSES + 1`` poses take part.
    """
    from handeye.core.errors import TooFewPosesError

    n = len(T_base_ee)
    use = np.ones(n, dtype=bool) if use is None else np.asarray(use, dtype=bool)
    pool = np.flatnonzero(use)
    if len(pool) < MIN_POSES + 1:
        raise TooFewPosesError(f"the hold-out check needs at least {MIN_POSES + 1} poses, got {len(pool)}")
    k = default_k(len(pool)) if k is None else int(k)
    if not 1 <= k <= len(pool) - MIN_POSES:
        raise HandEyeInputError(f"hold-out k must be 1 to {len(pool) - MIN_POSES} with {len(pool)} poses, got {k}")
    rng = np.random.default_rng(0) if rng is None else rng
    order = rng.permutation(pool)
    folds = [np.sort(order[s : s + k]) for s in range(0, len(order), k)]
    A_all = robot_side_poses(T_base_ee, setup)
    rows, refused = [], []
    for f, held in enumerate(folds):
        keep = use.copy()
        keep[held] = False
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                res = fit(keep)
        except ValueError as exc:  # every refusal of calibrate() is a ValueError subclass
            refused.append(f"fold {f} (poses {', '.join(map(str, held))}): {exc}")
            continue
        A, B = A_all[held], T_cam_target[held].copy()
        if "scale" in res.diagnostics:
            B[:, :3, 3] *= res.diagnostics["scale"]["value"]
        r = _residuals(A, B, res.X, res.Y)
        J = _prediction_jacobian(A, B, res.X, res.Y)
        cov_held = None if camera_covariance is None else np.asarray(camera_covariance)[held]
        C = _measurement_covariance(res.diagnostics["noise_model"], A, B, res.X, res.Y, setup, cov_held)
        C = C + J @ res.covariance @ np.swapaxes(J, 1, 2)
        maha = np.sqrt(np.einsum("mi,mi->m", r, np.linalg.solve(C, r[..., None])[..., 0]))
        for m, i in enumerate(held):
            rows.append(
                (
                    i,
                    f,
                    np.degrees(np.linalg.norm(r[m, :3])),
                    1000 * np.linalg.norm(r[m, 3:]),
                    np.degrees(np.sqrt(np.trace(C[m, :3, :3]))),
                    1000 * np.sqrt(np.trace(C[m, 3:, 3:])),
                    maha[m],
                )
            )
    rows.sort()
    cols = [np.array([row[c] for row in rows]) for c in range(7)] if rows else [np.zeros(0)] * 7
    return HoldOutCheck(k, cols[0].astype(int), cols[1].astype(int), *cols[2:], refused=refused)
