"""The report's numbers as table rows: poses by frame name, the noise model, motion, hold-out."""

from __future__ import annotations

import numpy as np

from handeye.core.se3 import pos_quat_xyzw_from_transform

__all__ = ["rpy_deg", "pose_rows", "noise_text", "motion_rows", "holdout_rows", "POSE_HEADERS"]

POSE_HEADERS = (
    "frame",
    "translation x, y, z [mm]",
    "quaternion x, y, z, w",
    "roll, pitch, yaw [deg]",
    "1-sigma [deg / mm]",
)


def rpy_deg(T: np.ndarray) -> np.ndarray:
    """Roll, pitch, yaw of a pose's rotation, ROS convention ``R = Rz(yaw) Ry(pitch) Rx(roll)``.

    Parameters
    ----------
    T : array, shape (4, 4) or (3, 3)

    Returns
    -------
    array, shape (3,)
        Degrees; pitch in [-90, 90].
    """
    from scipy.spatial.transform import Rotation

    return Rotation.from_matrix(np.asarray(T)[:3, :3]).as_euler("xyz", degrees=True)  # extrinsic x, y, z


def _join(values, fmt: str) -> str:
    return ", ".join(format(float(v), fmt) for v in values)


def pose_rows(named: list[tuple[str, np.ndarray]], sigma: dict) -> list[list[str]]:
    """One row per pose: translation (mm), quaternion (xyzw), roll-pitch-yaw (deg), its 1-sigma.

    Parameters
    ----------
    named : list of (str, array of shape (4, 4))
        ``(frame name, T)`` for X then Y, e.g. ``[("T_base_cam", X), ("T_ee_target", Y)]``.
    sigma : dict
        ``X_rotation_deg``, ``X_translation_mm``, ``Y_rotation_deg``, ``Y_translation_mm``.

    Returns
    -------
    list of list of str
        Columns of :data:`POSE_HEADERS`.
    """
    rows = []
    for (name, T), which in zip(named, "XY"):
        t, q = pos_quat_xyzw_from_transform(T)
        rows.append(
            [
                name,
                _join(1000 * t, "+.2f"),
                _join(q, "+.6f"),
                _join(rpy_deg(T), "+.3f"),
                f"{sigma[f'{which}_rotation_deg']:.4f} / {sigma[f'{which}_translation_mm']:.3f}",
            ]
        )
    return rows


def _per_axis(d: dict, side: str) -> str:
    """A side's (``"camera"`` or ``"robot"``) per-axis sigmas of a noise model's dict, in words."""
    rotation, translation = _join(d[f"{side}_rotation_deg"], ".4g"), _join(d[f"{side}_translation_mm"], ".4g")
    return f"{side} per axis {rotation} deg / {translation} mm"


def noise_text(d: dict) -> str:
    """The noise model of ``diagnostics["noise_model"]`` in words."""
    parts = [d.get("name", "?")]
    if "camera" in d:
        parts.append(f"camera: {d['camera']}")
    elif "camera_rotation_deg" in d:
        parts.append(_per_axis(d, "camera"))
    if "robot" in d:
        parts.append(f"robot: {d['robot']}")
    elif any(d.get("robot_rotation_deg", [0])) or any(d.get("robot_translation_mm", [0])):
        parts.append(_per_axis(d, "robot"))
    if d.get("estimated"):
        parts.append("scales estimated from the residuals")
    if "variance_factor_applied" in d:
        parts.append(f"scaled to the residuals by {d['variance_factor_applied']:.3g}")
    return "; ".join(parts)


def motion_rows(motion: dict) -> list[list[str]]:
    """Rows ``(quantity, value, what it means)`` of ``diagnostics["motion"]``."""
    from classic.diagnostics import THRESHOLDS

    s = motion["axis_singular_values"]
    return [
        [
            "poses / motion pairs",
            f"{motion['n_poses']} / {motion['n_motions']}",
            f"{THRESHOLDS['poses_warn']} poses or more; 10 to 20 well spread recommended",
        ],
        [
            "largest rotation between poses",
            f"{motion['max_rotation_deg']:.1f} deg",
            f"warning below {THRESHOLDS['max_rotation_warn_deg']:g} deg, refused below "
            f"{THRESHOLDS['max_rotation_error_deg']:g} deg",
        ],
        [
            "axis diversity s2/s1",
            f"{motion['axis_diversity']:.3f}",
            f"0 when all rotations share one axis, up to 1; warning below {THRESHOLDS['axis_diversity_warn']:g}, "
            f"refused below {THRESHOLDS['axis_diversity_error']:g}",
        ],
        ["axis singular values", _join(s, ".3f"), "spread of the rotation axes, largest first"],
        ["dominant rotation axis", "[" + _join(motion["dominant_axis"], "+.2f") + "]", "robot side's frame"],
        ["translation condition number", f"{motion['translation_condition']:.3g}", "of the translation system; 1 best"],
        [
            "angle mismatch robot / camera",
            f"{motion['angle_mismatch_deg']:.3f} deg",
            "low quantile of |angle(A) - angle(B)|: near the noise when the pairing is right",
        ],
    ]


def holdout_rows(summary: dict) -> list[list[str]]:
    """Rows ``(quantity, rotation, translation)`` of :attr:`HoldOutCheck.summary`."""
    return [
        ["RMS prediction error", f"{summary['rms_rotation_deg']:.4f} deg", f"{summary['rms_translation_mm']:.3f} mm"],
        [
            "RMS predicted 1-sigma",
            f"{summary['rms_sigma_rotation_deg']:.4f} deg",
            f"{summary['rms_sigma_translation_mm']:.3f} mm",
        ],
        [
            "error / sigma (1 when the sigma is right)",
            f"{summary['ratio_rotation']:.2f}",
            f"{summary['ratio_translation']:.2f}",
        ],
    ]
