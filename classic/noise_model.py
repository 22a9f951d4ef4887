"""What the pose residuals' noise is: camera and robot noise, anisotropic, per pose, through the lever arm.

The refinement (:mod:`classic.refine`) minimises ``sum_i r_i^T S_i^-1 r_i`` over ``X`` and ``Y``, where
``r_i = [log(R_P^T R_B), t_B - t_P]`` is pose ``i``'s residual (``P = X^-1 A_i Y``, the prediction of
the measured ``B_i = T_cam_target``) and ``S_i`` its covariance: the maximum-likelihood estimate
when the noise is Gaussian and small. ``S_i`` is the noise of both measurements carried to the
residual to first order,

.. math:: S_i = J_{B,i} \\Sigma_{cam,i} J_{B,i}^T + J_{A,i} \\Sigma_{rob,i} J_{A,i}^T,

so a robot's rotation noise reaches the residual's translation through the lever arm (the
target's offset from the flange, ``t_Y`` eye-to-hand), and a PnP camera pose, poor along the
optical axis, weighs less in that direction. Conventions (those of :mod:`handeye.core.synthetic`):

* camera noise on ``T_cam_target``: ``R <- R exp(w)`` (``w`` in the target frame),
  ``t <- t + n`` (``n`` in the camera frame);
* robot noise on ``T_base_ee``, whichever the setup: ``R <- R exp(w)`` (flange frame),
  ``t <- t + n`` (base frame). Joint-encoder noise is carried to it by the robot's Jacobian
  (:func:`joint_noise_covariance`).

Every covariance is 6x6 in the order ``[w, n]`` (rad, m).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from handeye.core.errors import HandEyeInputError
from handeye.core.se3 import hat, so3_log

__all__ = [
    "NoiseModel",
    "as_noise_model",
    "camera_residual_jacobian",
    "robot_residual_jacobian",
    "residual_covariances",
    "whitening",
    "joint_noise_covariance",
    "right_jacobian_inverse",
]


def _per_axis(value, name: str) -> np.ndarray:
    v = np.broadcast_to(np.asarray(value, dtype=float), (3,)).copy()
    if not np.all(np.isfinite(v)) or np.any(v < 0):
        raise HandEyeInputError(f"{name} must be finite and >= 0, got {value!r}")
    return v


@dataclass(frozen=True)
class NoiseModel:
    """Standard deviations of the camera's and the robot's pose noise, or per-pose covariances.

    Attributes
    ----------
    camera_rot_rad, camera_trans_m : float or (3,)
        Per axis: rotation in the target frame, translation in the camera frame (PnP-like noise:
        ``camera_trans_m=(s, s, s_z)`` with ``s_z`` along the optical axis).
    robot_rot_rad, robot_trans_m : float or (3,)
        Per axis: rotation in the flange frame, translation in the base frame.
    camera_covariance, robot_covariance : array, shape (N, 6, 6), optional
        Per pose, ``[w, n]`` order; replace the per-axis values of that side when given (for example
        the corner reprojection's covariance of each PnP pose, or :func:`joint_noise_covariance`).
    name : str
        How results name the model.
    scale_to_residuals : bool
        Only the shape is known: the refinement multiplies every covariance by one factor
        estimated from the residuals (the a-posteriori variance of unit weight).
    """

    camera_rot_rad: float | tuple = 0.0
    camera_trans_m: float | tuple = 0.0
    robot_rot_rad: float | tuple = 0.0
    robot_trans_m: float | tuple = 0.0
    camera_covariance: np.ndarray | None = None
    robot_covariance: np.ndarray | None = None
    name: str = "given"
    scale_to_residuals: bool = False

    def camera(self, n: int) -> np.ndarray:
        """Camera covariance per pose, shape (n, 6, 6)."""
        if self.camera_covariance is not None:
            return _checked_stack(self.camera_covariance, n, "camera_covariance")
        d = (
            np.concatenate(
                [_per_axis(self.camera_rot_rad, "camera_rot_rad"), _per_axis(self.camera_trans_m, "camera_trans_m")]
            )
            ** 2
        )
        return np.broadcast_to(np.diag(d), (n, 6, 6))

    def robot(self, n: int) -> np.ndarray:
        """Robot covariance per pose, shape (n, 6, 6)."""
        if self.robot_covariance is not None:
            return _checked_stack(self.robot_covariance, n, "robot_covariance")
        d = (
            np.concatenate(
                [_per_axis(self.robot_rot_rad, "robot_rot_rad"), _per_axis(self.robot_trans_m, "robot_trans_m")]
            )
            ** 2
        )
        return np.broadcast_to(np.diag(d), (n, 6, 6))

    def subset(self, keep: np.ndarray) -> "NoiseModel":
        """The model of the poses in ``keep`` (a mask or indices): per-pose covariances cut to them."""
        changes = {
            name: np.asarray(getattr(self, name))[keep]
            for name in ("camera_covariance", "robot_covariance")
            if getattr(self, name) is not None
        }
        return dataclasses.replace(self, **changes) if changes else self

    @property
    def has_robot_noise(self) -> bool:
        if self.robot_covariance is not None:
            return bool(np.any(np.asarray(self.robot_covariance) != 0))
        return bool(
            np.any(_per_axis(self.robot_rot_rad, "robot_rot_rad"))
            or np.any(_per_axis(self.robot_trans_m, "robot_trans_m"))
        )

    def describe(self) -> dict:
        """JSON-ready summary (deg, mm) for a result's diagnostics."""
        out = {"name": self.name, "scale_to_residuals": bool(self.scale_to_residuals)}
        if self.camera_covariance is not None:
            out["camera"] = "per-pose covariance"
        else:
            out["camera_rotation_deg"] = np.degrees(_per_axis(self.camera_rot_rad, "camera_rot_rad")).tolist()
            out["camera_translation_mm"] = (1000 * _per_axis(self.camera_trans_m, "camera_trans_m")).tolist()
        if self.robot_covariance is not None:
            out["robot"] = "per-pose covariance"
        else:
            out["robot_rotation_deg"] = np.degrees(_per_axis(self.robot_rot_rad, "robot_rot_rad")).tolist()
            out["robot_translation_mm"] = (1000 * _per_axis(self.robot_trans_m, "robot_trans_m")).tolist()
        return out


def _checked_stack(C, n: int, name: str) -> np.ndarray:
    C = np.asarray(C, dtype=float)
    if C.shape != (n, 6, 6):
        raise HandEyeInputError(f"{name} must have shape ({n}, 6, 6), got {C.shape}")
    if not np.all(np.isfinite(C)):
        raise HandEyeInputError(f"{name} has non-finite entries")
    return C


def as_noise_model(noise) -> NoiseModel | None:
    """``None`` (estimate), a ``(rot_rad, trans_m)`` camera-only pair, or a :class:`NoiseModel`."""
    if noise is None or isinstance(noise, NoiseModel):
        return noise
    try:
        s_r, s_t = noise
    except (TypeError, ValueError):
        raise HandEyeInputError(f"noise must be None, (rot_rad, trans_m) or a NoiseModel, got {noise!r}") from None
    return NoiseModel(camera_rot_rad=float(s_r), camera_trans_m=float(s_t), name="camera, given")


def right_jacobian_inverse(r: np.ndarray) -> np.ndarray:
    """``J_r(r)^-1`` of SO(3): ``log(exp(r) exp(d)) = r + J_r(r)^-1 d`` to first order, shape (N, 3, 3)."""
    theta = np.linalg.norm(r, axis=1)[:, None, None]
    K = hat(r)
    small = theta < 1e-6
    th = np.where(small, 1.0, theta)
    c = np.where(small, 1.0 / 12.0, 1.0 / th**2 - (1.0 + np.cos(th)) / (2.0 * th * np.sin(th)))
    return np.eye(3) + 0.5 * K + c * (K @ K)


def camera_residual_jacobian(A: np.ndarray, B: np.ndarray, X: np.ndarray, Y: np.ndarray) -> np.ndarray:
    """``d r_i / d e_cam``: the residual's response to camera noise ``[w, n]``, shape (N, 6, 6)."""
    R_P = X[:3, :3].T @ A[:, :3, :3] @ Y[:3, :3]
    r_rot = so3_log(np.swapaxes(R_P, 1, 2) @ B[:, :3, :3])
    J = np.zeros((len(A), 6, 6))
    J[:, :3, :3] = right_jacobian_inverse(r_rot)
    J[:, 3:, 3:] = np.eye(3)
    return J


def robot_residual_jacobian(
    A: np.ndarray, X: np.ndarray, Y: np.ndarray, setup: str, B: np.ndarray | None = None
) -> np.ndarray:
    """``d r_i / d e_rob``: the residual's response to robot noise ``[w, n]`` on ``T_base_ee``, shape (N, 6, 6).

    Eye-to-hand (``A = T_base_ee``): ``d r_rot/dw = -R_Y^T``, ``d r_t/dw = R_X^T R_A [t_Y]x`` (the lever
    arm), ``d r_t/dn = -R_X^T``. Eye-in-hand (``A = T_ee_base``, noise on its inverse):
    ``d r_rot/dw = R_Y^T R_A^T``, ``d r_t/dw = -R_X^T [R_A t_Y + t_A]x``, ``d r_t/dn = R_X^T R_A``. With the
    measurements ``B`` the rotation rows carry ``J_l(r)^-1`` of the residual (exact); without, they are
    those at a zero residual.
    """
    R_X, R_Y, t_Y = X[:3, :3], Y[:3, :3], Y[:3, 3]
    R_A, t_A = A[:, :3, :3], A[:, :3, 3]
    J = np.zeros((len(A), 6, 6))
    if setup == "eye_to_hand":
        J[:, :3, :3] = -R_Y.T
        J[:, 3:, :3] = R_X.T @ R_A @ hat(t_Y)
        J[:, 3:, 3:] = -R_X.T
    elif setup == "eye_in_hand":
        J[:, :3, :3] = R_Y.T @ np.swapaxes(R_A, 1, 2)
        J[:, 3:, :3] = -(R_X.T @ hat(R_A @ t_Y + t_A))
        J[:, 3:, 3:] = R_X.T @ R_A
    else:
        raise HandEyeInputError(f"unknown setup {setup!r}")
    if B is not None:
        R_P = R_X.T @ R_A @ R_Y
        r_rot = so3_log(np.swapaxes(R_P, 1, 2) @ B[:, :3, :3])
        J[:, :3, :3] = right_jacobian_inverse(-r_rot) @ J[:, :3, :3]  # J_l(r)^-1 = J_r(-r)^-1
    return J


def residual_covariances(
    model: NoiseModel, A: np.ndarray, B: np.ndarray, X: np.ndarray, Y: np.ndarray, setup: str
) -> np.ndarray:
    """``S_i``, the covariance of each pose residual at ``(X, Y)`` under ``model``, shape (N, 6, 6)."""
    n = len(A)
    Jc = camera_residual_jacobian(A, B, X, Y)
    S = Jc @ model.camera(n) @ np.swapaxes(Jc, 1, 2)
    if model.has_robot_noise:
        Jr = robot_residual_jacobian(A, X, Y, setup, B)
        S = S + Jr @ model.robot(n) @ np.swapaxes(Jr, 1, 2)
    return S


def whitening(S: np.ndarray) -> np.ndarray:
    """``W_i`` with ``W_i^T W_i = S_i^-1`` (inverse Cholesky factor), shape (N, 6, 6).

    Raises
    ------
    HandEyeInputError
        When a covariance is not positive definite (a noise model with a zero direction, for
        example camera rotation noise 0 and no robot noise).
    """
    try:
        L = np.linalg.cholesky(S)
    except np.linalg.LinAlgError:
        raise HandEyeInputError(
            "the noise model gives a residual covariance that is not positive definite: "
            "every residual direction needs some noise (camera or robot)"
        ) from None
    return np.linalg.inv(L)


def joint_noise_covariance(jacobians: np.ndarray, sigma_joint_rad) -> np.ndarray:
    """Robot pose covariance from joint-encoder noise: ``J_q diag(sigma_q^2) J_q^T`` per pose.

    Parameters
    ----------
    jacobians : array, shape (N, 6, nq)
        ``d e_rob / d q`` of each pose: rows ``[w (flange frame), n (base frame)]`` of ``T_base_ee``
        per joint (the robot model's geometric Jacobian in that convention).
    sigma_joint_rad : float or (nq,)

    Returns
    -------
    array, shape (N, 6, 6)
    """
    Jq = np.asarray(jacobians, dtype=float)
    if Jq.ndim != 3 or Jq.shape[1] != 6:
        raise HandEyeInputError(f"joint Jacobians must have shape (N, 6, nq), got {Jq.shape}")
    s2 = np.broadcast_to(np.asarray(sigma_joint_rad, dtype=float), (Jq.shape[2],)) ** 2
    return (Jq * s2) @ np.swapaxes(Jq, 1, 2)
