"""Diagnostics of a motion set: can it determine X, and are the poses consistent?

Two checks every hand-eye tool should make and OpenCV does not:

* **rotation-axis diversity.** X is determined only if the robot rotates about
  at least two non-parallel axes. The axes of the motions, weighted by
  ``2 sin(theta / 2)``, are stacked in a ``(K, 3)`` matrix; its singular
  values ``s1 >= s2 >= s3`` (normalised by ``sqrt(K)``) measure the spread.
  ``s2 / s1`` near zero means one axis only.
* **consistency.** ``A_ij X = X B_ij`` makes the rotation angles of ``A_ij``
  and ``B_ij`` equal whatever X is: mis-paired poses break this before any
  solve. Relative angles cannot see an inverted pose, the wrong setup or a
  permuted quaternion order (each preserves them), so a quick closed-form fit
  is compared with the fit of the other reading of the data, and with shifted
  pairings; a fit far beyond any sensor's noise is refused.
"""

from __future__ import annotations

import warnings
from dataclasses import asdict, dataclass, field

import numpy as np

from classic.motions import Motions, motions_from_poses
from classic.pairs import pair_indices
from classic.ransac import pose_error_m
from classic.residuals import pose_residuals
from classic.shah import shah_solve
from handeye.core.errors import DegenerateMotionError, InconsistentPosesError, WeakMotionWarning
from handeye.core.setups import robot_side_poses

__all__ = [
    "MotionDiagnostics",
    "THRESHOLDS",
    "diagnose_motion",
    "angle_mismatch_deg",
    "check_consistency",
    "fit_residual_m",
    "quick_fit_residuals",
]

#: Limits of the motion checks (angles in degrees). Below ``*_error`` refuses, below ``*_warn`` warns.
THRESHOLDS = {
    "max_rotation_error_deg": 0.5,
    "max_rotation_warn_deg": 10.0,
    "axis_diversity_error": 0.02,
    "axis_diversity_warn": 0.15,
    "poses_warn": 6,
    # consistency: low quantile of |angle(A_ij) - angle(B_ij)| (robust to outliers)
    "consistency_quantile": 0.2,
    "consistency_error_deg": 1.0,
    "consistency_error_ratio": 0.15,
    # an alternative reading of the data (inverted poses, other setup) that fits this many times better wins
    "fit_ratio": 10.0,
    # no usable camera or robot has a median pose error this large: the data are mis-paired
    "fit_error_deg": 5.0,
}


@dataclass
class MotionDiagnostics:
    """What the motion set can determine.

    Attributes
    ----------
    n_poses, n_motions : int
    max_rotation_deg : float
        Largest rotation between two robot poses.
    axis_singular_values : list of float, length 3
        Singular values of the weighted rotation axes, normalised.
    axis_diversity : float
        ``s2 / s1``: 0 when all rotations share one axis, up to 1.
    dominant_axis : list of float, length 3
        The principal rotation axis (in the frame of ``A``'s motions).
    translation_condition : float
        Condition number of ``sum (R_A - I)^T (R_A - I)``, the translation system.
    angle_mismatch_deg : float
        Robust (low-quantile) ``|angle(A_ij) - angle(B_ij)|``; near the noise level when consistent.
    warnings : list of str
    """

    n_poses: int
    n_motions: int
    max_rotation_deg: float
    axis_singular_values: list
    axis_diversity: float
    dominant_axis: list
    translation_condition: float
    angle_mismatch_deg: float
    warnings: list = field(default_factory=list)

    def to_dict(self) -> dict:
        """Plain JSON-serialisable dictionary."""
        return asdict(self)


def _motions(T_base_ee, T_cam_target, setup, pairs) -> Motions:
    return motions_from_poses(robot_side_poses(T_base_ee, setup), T_cam_target, *pair_indices(len(T_base_ee), pairs))


def angle_mismatch_deg(m: Motions, quantile: float = THRESHOLDS["consistency_quantile"]) -> tuple[float, float]:
    """Robust mismatch of the rotation angles of paired motions.

    Parameters
    ----------
    m : Motions
        Motions with ``A_k X = X B_k``.
    quantile : float
        Quantile of the per-motion mismatch reported (low, to tolerate outliers).

    Returns
    -------
    mismatch_deg : float
        The quantile of ``|angle(A_k) - angle(B_k)|``.
    typical_angle_deg : float
        The median motion angle, for scale.
    """
    a = np.degrees(m.angles_A)
    b = np.degrees(m.angles_B)
    return float(np.quantile(np.abs(a - b), quantile)), float(np.median(a))


def _is_inconsistent(mismatch: float, typical: float) -> bool:
    return mismatch > THRESHOLDS["consistency_error_deg"] and mismatch > THRESHOLDS["consistency_error_ratio"] * typical


def quick_fit_residuals(T_base_ee: np.ndarray, T_cam_target: np.ndarray, setup: str) -> tuple[float, float]:
    """Median per-pose residuals of a quick closed-form fit (Shah): distance (m) and angle (deg).

    Parameters
    ----------
    T_base_ee, T_cam_target : array, shape (N, 4, 4)
    setup : {"eye_to_hand", "eye_in_hand"}

    Returns
    -------
    residual_m : float
        See :func:`fit_residual_m`.
    angle_deg : float
        Median rotation residual.
    """
    A = robot_side_poses(T_base_ee, setup)
    try:
        Y_target, X_cam = shah_solve(A, T_cam_target)
    except np.linalg.LinAlgError:
        return np.inf, 180.0
    r_rot, _ = pose_residuals(A, T_cam_target, X_cam, Y_target)
    d = pose_error_m(A, T_cam_target, X_cam, Y_target)
    return float(np.median(d)), float(np.degrees(np.median(np.linalg.norm(r_rot, axis=1))))


def fit_residual_m(T_base_ee: np.ndarray, T_cam_target: np.ndarray, setup: str) -> float:
    """Median per-pose residual of a quick closed-form fit (Shah), in metres.

    The residual of pose i is ``sqrt(|r_trans|^2 + (L r_angle)^2)`` with ``L``
    the median camera-to-target distance (the displacement an angle error
    causes at the target).

    Parameters
    ----------
    T_base_ee, T_cam_target : array, shape (N, 4, 4)
    setup : {"eye_to_hand", "eye_in_hand"}

    Returns
    -------
    residual_m : float
    """
    return quick_fit_residuals(T_base_ee, T_cam_target, setup)[0]


def check_consistency(
    T_base_ee: np.ndarray, T_cam_target: np.ndarray, setup: str, pairs: str = "all", motions: Motions | None = None
) -> dict:
    """Refuse pose sets that no hand-eye transform explains, naming the likely mistake.

    Two tests. Rotation angles of paired motions must agree (``A_ij X = X B_ij``
    preserves angles whatever X is); mis-paired poses break this. Angles cannot
    see an inverted pose, the wrong setup or a permuted quaternion order (all
    preserve relative angles), so a quick closed-form fit is compared with the
    fits of those alternatives: if one explains the data ten times better, the
    data as given are refused with its name.

    Parameters
    ----------
    T_base_ee, T_cam_target : array, shape (N, 4, 4)
    setup : {"eye_to_hand", "eye_in_hand"}
    pairs : {"all", "consecutive"}
    motions : Motions, optional
        The pose pairs' motions when already computed.

    Returns
    -------
    dict
        ``angle_mismatch_deg`` and ``fit_residual_mm`` of the data as given.

    Raises
    ------
    InconsistentPosesError
    """
    m = motions if motions is not None else _motions(T_base_ee, T_cam_target, setup, pairs)
    mismatch, typical = angle_mismatch_deg(m)
    if _is_inconsistent(mismatch, typical):
        raise InconsistentPosesError(
            f"robot and camera motions disagree: the rotation angles of paired motions differ by "
            f"{mismatch:.1f} deg or more for {100 * (1 - THRESHOLDS['consistency_quantile']):.0f}% of pairs "
            f"(typical motion {typical:.1f} deg); no hand-eye transform can explain that. Check that pose i "
            "of the robot and of the camera were recorded together (mis-paired or shifted rows), and that "
            "quaternions are read in the right order."
        )
    given, given_deg = quick_fit_residuals(T_base_ee, T_cam_target, setup)
    other = "eye_in_hand" if setup == "eye_to_hand" else "eye_to_hand"
    # Inverting the robot poses is the other setup; inverting the camera poses is the other setup with
    # the roles of X and Y swapped (A^-1 X = Y B^-1); inverting both is this setup with X and Y swapped,
    # which fits as well as the data as given. So one alternative covers the detectable mistakes.
    alt = fit_residual_m(T_base_ee, T_cam_target, other)
    if given > 1e-6 and alt < given / THRESHOLDS["fit_ratio"]:
        raise InconsistentPosesError(
            f"the poses do not fit the {setup} model (median residual {1000 * given:.1f} mm) but fit with "
            f"setup='{other}', or equivalently with the robot poses or the camera poses inverted (T_ee_base "
            f"passed for T_base_ee, or T_target_cam for T_cam_target?): median residual {1000 * alt:.2f} mm. "
            "Fix the input rather than calibrate on it."
        )
    n = len(T_base_ee)
    for shift in (1, -1, 2, -2):
        robot = np.arange(max(0, -shift), min(n, n - shift))
        if len(robot) < 6:
            continue
        alt = fit_residual_m(T_base_ee[robot], T_cam_target[robot + shift], setup)
        if given > 1e-6 and alt < given / THRESHOLDS["fit_ratio"]:
            raise InconsistentPosesError(
                f"robot and camera poses were not recorded together as paired: the poses do not fit "
                f"(median residual {1000 * given:.1f} mm, {given_deg:.1f} deg) but fit when robot pose i is "
                f"paired with camera pose i{shift:+d} (median residual {1000 * alt:.2f} mm): rows shifted by "
                f"{abs(shift)}?"
            )
    if given_deg > THRESHOLDS["fit_error_deg"]:
        raise InconsistentPosesError(
            f"the poses do not fit any hand-eye transform: median rotation residual {given_deg:.1f} deg and "
            f"{1000 * given:.0f} mm after a closed-form fit, far beyond any camera's or robot's noise. Check "
            "that pose i of the robot and of the camera were recorded together, that each is the pose of the "
            "named frame in the other (T_base_ee, T_cam_target), and the setup. If only some poses are "
            "gross outliers, calibrate with robust=True (CLI: --robust)."
        )
    return {"angle_mismatch_deg": mismatch, "fit_residual_mm": 1000 * given, "fit_residual_deg": given_deg}


def diagnose_motion(
    T_base_ee: np.ndarray,
    T_cam_target: np.ndarray,
    setup: str,
    pairs: str = "all",
    raise_on_degenerate: bool = True,
    motions: Motions | None = None,
    stacklevel: int = 2,
) -> MotionDiagnostics:
    """Measure how well a pose set determines X; warn on weak data, refuse degenerate data.

    Parameters
    ----------
    T_base_ee, T_cam_target : array, shape (N, 4, 4)
    setup : {"eye_to_hand", "eye_in_hand"}
    pairs : {"all", "consecutive"}
    raise_on_degenerate : bool
        Raise :class:`DegenerateMotionError` when X is not determined.
    motions : Motions, optional
        The pose pairs' motions when already computed (``A_j A_i^-1``, ``B_j B_i^-1`` for ``pairs``).
    stacklevel : int
        Of the warnings: 2 points at the caller's line; a library function calling this one adds its depth.

    Returns
    -------
    MotionDiagnostics

    Raises
    ------
    DegenerateMotionError
        When the robot barely rotates or rotates about one axis only.

    Warns
    -----
    WeakMotionWarning
        When the set is poorly conditioned (few poses, small or near-parallel rotations).
    """
    m = motions if motions is not None else _motions(T_base_ee, T_cam_target, setup, pairs)
    angles = m.angles_A
    P = 2.0 * m.q_A[:, :3]
    eigval, eigvec = np.linalg.eigh(P.T @ P)
    s = np.sqrt(np.maximum(eigval[::-1], 0.0) / len(P))
    Vt = eigvec[:, ::-1].T
    diversity = float(s[1] / s[0]) if s[0] > 0 else 0.0
    S = m.R_A.sum(axis=0)
    cond = float(np.linalg.cond(2.0 * len(m) * np.eye(3) - S - S.T))
    mismatch, _ = angle_mismatch_deg(m)
    max_rot = float(np.degrees(angles.max()))
    axis = Vt[0] * (1 if Vt[0][np.argmax(np.abs(Vt[0]))] > 0 else -1)
    frame = "base" if setup == "eye_to_hand" else "end-effector"
    diag = MotionDiagnostics(
        n_poses=len(T_base_ee),
        n_motions=len(m),
        max_rotation_deg=max_rot,
        axis_singular_values=[float(v) for v in s],
        axis_diversity=diversity,
        dominant_axis=[float(v) for v in axis],
        translation_condition=cond,
        angle_mismatch_deg=mismatch,
    )
    if raise_on_degenerate:
        if max_rot < THRESHOLDS["max_rotation_error_deg"]:
            raise DegenerateMotionError(
                f"the robot barely rotates between poses (largest rotation {max_rot:.3f} deg): translations "
                "alone cannot determine the camera's rotation. Rotate the end-effector between poses, "
                "by 20 degrees or more about at least two different axes."
            )
        if diversity < THRESHOLDS["axis_diversity_error"]:
            raise DegenerateMotionError(
                f"all robot rotations are about one axis (~[{axis[0]:.2f}, {axis[1]:.2f}, {axis[2]:.2f}] in the "
                f"{frame} frame; axis diversity {diversity:.4f}): the translation along that axis is "
                "undetermined. Add poses that rotate the end-effector about a second axis, at least 20 "
                "degrees away from it."
            )
    if len(T_base_ee) < THRESHOLDS["poses_warn"]:
        diag.warnings.append(f"only {len(T_base_ee)} poses: 10 to 20 well spread poses are recommended")
    if max_rot < THRESHOLDS["max_rotation_warn_deg"]:
        diag.warnings.append(f"small rotations (largest {max_rot:.1f} deg): the estimate will be noisy")
    if diversity < THRESHOLDS["axis_diversity_warn"]:
        diag.warnings.append(
            f"rotation axes are nearly parallel (diversity {diversity:.3f}, dominant axis "
            f"[{axis[0]:.2f}, {axis[1]:.2f}, {axis[2]:.2f}] in the {frame} frame): rotate about other axes too"
        )
    for text in diag.warnings:
        warnings.warn(text, WeakMotionWarning, stacklevel=stacklevel)
    return diag
