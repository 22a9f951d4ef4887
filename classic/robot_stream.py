"""Robot poses as a function of time: interpolation between samples, and its time derivative.

A robot controller and a camera rarely sample at the same instants, and their clocks disagree by an
unknown offset. :class:`RobotStream` gives ``T_base_ee`` at any time inside the recording (rotation
along the geodesic, ``R(t) = R_k exp(tau log(R_k^T R_k+1))``, translation linear) and the pose's
rate of change in the noise convention of :mod:`classic.noise_model` (angular velocity in the
flange frame, linear velocity in the base frame), which the refinement's Jacobian of a time offset
needs. Written here rather than with :class:`scipy.spatial.transform.Slerp` because the rate in
that convention is needed alongside the pose and costs one line more.
"""

from __future__ import annotations

import numpy as np

from handeye.core.errors import HandEyeInputError
from handeye.core.se3 import make_transform, so3_exp, so3_log
from handeye.core.validation import check_transforms

__all__ = ["RobotStream"]


class RobotStream:
    """Robot flange poses sampled over time.

    Parameters
    ----------
    times_s : array, shape (M,)
        Strictly increasing sample times, seconds.
    T_base_ee : array, shape (M, 4, 4)
        Flange poses at those times, metres.
    """

    def __init__(self, times_s: np.ndarray, T_base_ee: np.ndarray):
        t = np.asarray(times_s, dtype=float)
        T = check_transforms(T_base_ee, "T_base_ee")
        if t.ndim != 1 or len(t) != len(T):
            raise HandEyeInputError(f"{len(T)} robot poses need {len(T)} times, got shape {t.shape}")
        if len(t) < 2 or not np.all(np.isfinite(t)) or np.any(np.diff(t) <= 0):
            raise HandEyeInputError("robot stream times must be finite and strictly increasing (at least two)")
        self.times_s = t
        self.T_base_ee = T
        R = T[:, :3, :3]
        dt = np.diff(t)
        self._omega = so3_log(np.swapaxes(R[:-1], 1, 2) @ R[1:]) / dt[:, None]  # flange frame, rad/s
        self._velocity = np.diff(T[:, :3, 3], axis=0) / dt[:, None]  # base frame, m/s

    def at(self, query_s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Poses and rates at the query times.

        Parameters
        ----------
        query_s : array, shape (N,)

        Returns
        -------
        T_base_ee : array, shape (N, 4, 4)
        rate : array, shape (N, 6)
            ``[omega (flange frame, rad/s), velocity (base frame, m/s)]``.

        Raises
        ------
        HandEyeInputError
            A query outside the recording.
        """
        q = np.asarray(query_s, dtype=float)
        t = self.times_s
        if np.any(q < t[0]) or np.any(q > t[-1]):
            bad = q[(q < t[0]) | (q > t[-1])]
            raise HandEyeInputError(
                f"time {bad[0]:.6f} s is outside the robot recording [{t[0]:.6f}, {t[-1]:.6f}] s; "
                "trim the camera poses to the robot's time span (or reduce the offset)"
            )
        k = np.clip(np.searchsorted(t, q, side="right") - 1, 0, len(t) - 2)
        tau = q - t[k]
        R = self.T_base_ee[k, :3, :3] @ so3_exp(self._omega[k] * tau[:, None])
        p = self.T_base_ee[k, :3, 3] + self._velocity[k] * tau[:, None]
        return make_transform(R, p), np.concatenate([self._omega[k], self._velocity[k]], axis=1)
