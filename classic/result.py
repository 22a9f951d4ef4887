"""The result of :func:`classic.calibrate`: estimate, residuals, covariance, diagnostics."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from classic.least_squares import sigma_of_blocks
from handeye.core.se3 import pos_quat_xyzw_from_transform
from handeye.core.setups import UNKNOWN_NAMES

__all__ = ["PoseResiduals", "CalibrationResult"]


@dataclass
class PoseResiduals:
    """Per-pose disagreement of the measured and the predicted ``T_cam_target``.

    Attributes
    ----------
    rotation_deg : array, shape (N,)
    translation_mm : array, shape (N,)
    inliers : array of bool, shape (N,)
        False for poses rejected by the robust path.
    """

    rotation_deg: np.ndarray
    translation_mm: np.ndarray
    inliers: np.ndarray

    @property
    def rms_rotation_deg(self) -> float:
        """RMS rotation residual over inliers, degrees."""
        return float(np.sqrt(np.mean(self.rotation_deg[self.inliers] ** 2)))

    @property
    def rms_translation_mm(self) -> float:
        """RMS translation residual over inliers, millimetres."""
        return float(np.sqrt(np.mean(self.translation_mm[self.inliers] ** 2)))


@dataclass
class CalibrationResult:
    """Hand-eye calibration result.

    ``X`` is the camera pose and ``Y`` the target pose of ``A_i Y = X B_i``
    (:mod:`handeye.core.setups`); read them by frame name: ``T_base_cam`` and
    ``T_ee_target`` (eye-to-hand) or ``T_ee_cam`` and ``T_base_target``
    (eye-in-hand).

    Attributes
    ----------
    setup : str
    method : str
        Closed-form initial method, ``+lm`` when refined, ``ransac+`` when robust.
    X, Y : array, shape (4, 4)
    residuals : PoseResiduals
    covariance : array, shape (12, 12)
        Of ``[w_X, v_X, w_Y, v_Y]``: rotation (rad, ``R = so3_exp(w) R_est``)
        and translation (m) errors of X then Y.
    diagnostics : dict
        Motion diagnostics, noise scales, refinement and outlier information.
    """

    setup: str
    method: str
    X: np.ndarray
    Y: np.ndarray
    residuals: PoseResiduals
    covariance: np.ndarray
    diagnostics: dict = field(default_factory=dict)

    def _named(self, name: str, which: str) -> np.ndarray:
        names = UNKNOWN_NAMES[self.setup]
        if name not in names:
            have = " and ".join(names)
            raise AttributeError(f"{name} is not estimated in the {self.setup} setup; this result has {have}")
        return self.X if which == "X" else self.Y

    @property
    def T_base_cam(self) -> np.ndarray:
        """Camera pose in the robot base (eye-to-hand), shape (4, 4)."""
        return self._named("T_base_cam", "X")

    @property
    def T_ee_target(self) -> np.ndarray:
        """Target pose on the flange (eye-to-hand), shape (4, 4)."""
        return self._named("T_ee_target", "Y")

    @property
    def T_ee_cam(self) -> np.ndarray:
        """Camera pose on the flange (eye-in-hand), shape (4, 4)."""
        return self._named("T_ee_cam", "X")

    @property
    def T_base_target(self) -> np.ndarray:
        """Target pose in the robot base (eye-in-hand), shape (4, 4)."""
        return self._named("T_base_target", "Y")

    @property
    def sigma(self) -> dict:
        """Predicted 1-sigma error magnitudes (RMS of the error's norm).

        Returns
        -------
        dict
            ``X_rotation_deg``, ``X_translation_mm``, ``Y_rotation_deg``,
            ``Y_translation_mm``: ``sqrt(trace)`` of each covariance block.
        """
        return sigma_of_blocks(self.covariance)

    def to_dict(self) -> dict:
        """JSON-serialisable summary: poses by frame name, residuals, sigma, diagnostics.

        Returns
        -------
        dict
        """
        out = {"setup": self.setup, "method": self.method, "units": {"translation": "m", "quaternion": "xyzw"}}
        for name, T in zip(UNKNOWN_NAMES[self.setup], (self.X, self.Y)):
            t, q = pos_quat_xyzw_from_transform(T)
            out[name] = {"matrix": T.tolist(), "translation_m": t.tolist(), "quaternion_xyzw": q.tolist()}
        out["sigma"] = self.sigma
        out["residuals"] = {
            "rms_rotation_deg": self.residuals.rms_rotation_deg,
            "rms_translation_mm": self.residuals.rms_translation_mm,
            "per_pose": [
                {"index": i, "rotation_deg": float(r), "translation_mm": float(t), "inlier": bool(k)}
                for i, (r, t, k) in enumerate(
                    zip(self.residuals.rotation_deg, self.residuals.translation_mm, self.residuals.inliers)
                )
            ],
        }
        out["covariance"] = {"order": "[w_X, v_X, w_Y, v_Y] (rad, m)", "matrix": self.covariance.tolist()}
        out["diagnostics"] = self.diagnostics
        return out
