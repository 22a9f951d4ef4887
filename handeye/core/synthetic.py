"""Synthetic hand-eye problems with known truth, for tests, benchmarks and demos.

A problem is generated from the camera side: target poses ``T_cam_target``
that a real camera would see (board 0.4 to 0.9 m in front of it, inside the
field of view, tilted at most ``max_tilt_deg``), then the robot poses that
produce them through the true ``X`` and ``Y``. Noise is added afterwards:

* camera noise: ``R <- R @ so3_exp(w)``, ``w ~ N(0, sigma_rot^2 I3)``, and
  ``t <- t + N(0, sigma_trans^2 I3)``, per axis, on ``T_cam_target``;
* robot noise: the same model on ``T_base_ee``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from handeye.core.se3 import invert_transform, make_transform, matrix_from_quat_xyzw, so3_exp
from handeye.core.setups import normalize_setup

__all__ = ["HandEyeProblem", "make_problem", "random_rotations", "perturb"]


@dataclass
class HandEyeProblem:
    """A hand-eye data set with its truth.

    Attributes
    ----------
    setup : str
        ``"eye_to_hand"`` or ``"eye_in_hand"``.
    T_base_ee : array, shape (N, 4, 4)
        Measured robot poses (noisy if robot noise was asked for).
    T_cam_target : array, shape (N, 4, 4)
        Measured target poses (noisy if camera noise was asked for).
    X_true : array, shape (4, 4)
        ``T_base_cam`` (eye-to-hand) or ``T_ee_cam`` (eye-in-hand).
    Y_true : array, shape (4, 4)
        ``T_ee_target`` (eye-to-hand) or ``T_base_target`` (eye-in-hand).
    outliers : array of bool, shape (N,)
        Poses replaced by gross errors.
    """

    setup: str
    T_base_ee: np.ndarray
    T_cam_target: np.ndarray
    X_true: np.ndarray
    Y_true: np.ndarray
    outliers: np.ndarray


def random_rotations(rng: np.random.Generator, n: int) -> np.ndarray:
    """Uniformly distributed rotation matrices.

    Parameters
    ----------
    rng : numpy.random.Generator
    n : int

    Returns
    -------
    R : array, shape (n, 3, 3)
    """
    return matrix_from_quat_xyzw(rng.normal(size=(n, 4)))


def perturb(T: np.ndarray, rng: np.random.Generator, sigma_rot_rad: float, sigma_trans_m: float) -> np.ndarray:
    """Add pose noise: ``R @ so3_exp(w)`` with ``w ~ N(0, s_r^2 I)``, ``t + N(0, s_t^2 I)``.

    Parameters
    ----------
    T : array, shape (N, 4, 4)
    rng : numpy.random.Generator
    sigma_rot_rad : float
        Per-axis standard deviation of the rotation noise, radians.
    sigma_trans_m : float
        Per-axis standard deviation of the translation noise, metres.

    Returns
    -------
    T_noisy : array, shape (N, 4, 4)
    """
    n = len(T)
    R = T[:, :3, :3] @ so3_exp(rng.normal(scale=sigma_rot_rad, size=(n, 3)))
    t = T[:, :3, 3] + rng.normal(scale=sigma_trans_m, size=(n, 3))
    return make_transform(R, t)


def _tilt(rx: np.ndarray, ry: np.ndarray, rz: np.ndarray) -> np.ndarray:
    def axis_rot(angle, axis):
        v = np.zeros(angle.shape + (3,))
        v[..., axis] = angle
        return so3_exp(v)

    return axis_rot(rz, 2) @ axis_rot(ry, 1) @ axis_rot(rx, 0)


def _target_in_camera(rng: np.random.Generator, n: int, motion: str, max_tilt_deg: float) -> np.ndarray:
    """Target poses ``T_cam_target`` a camera would see."""
    z = rng.uniform(0.4, 0.9, n)
    xy = rng.uniform(-0.15, 0.15, (n, 2)) * z[:, None]
    t = np.column_stack([xy, z])
    tilt = np.radians(max_tilt_deg)
    if motion == "random":
        rx, ry = rng.uniform(-tilt, tilt, (2, n))
        rz = rng.uniform(-np.pi / 4, np.pi / 4, n)
    elif motion == "structured":
        # a grid a person records by hand: tilt about x, then y, then both, in-plane turns
        levels = np.array([-1.0, -0.5, 0.5, 1.0]) * tilt
        grid = [(a, 0.0, 0.0) for a in levels] + [(0.0, b, 0.0) for b in levels]
        grid += [(a, b, c) for a in levels[[0, 3]] for b in levels[[0, 3]] for c in (-0.4, 0.4)]
        grid = np.array(grid)
        sel = grid[np.arange(n) % len(grid)]
        rx, ry, rz = sel.T
        rz = rz + 0.05 * (np.arange(n) // len(grid))
    elif motion == "one_axis":
        # every robot motion about the same axis: the camera's optical axis
        rx = np.full(n, 0.3)
        ry = np.full(n, -0.2)
        rz = np.linspace(-np.pi / 3, np.pi / 3, n)
        t = np.tile(t[:1], (n, 1)) + np.column_stack([np.zeros((n, 2)), np.linspace(0, 0.1, n)])
        return make_transform(_tilt(rx, ry, np.zeros(n)) @ _tilt(np.zeros(n), np.zeros(n), rz), t)
    elif motion == "translation_only":
        rx, ry, rz = np.zeros((3, n)) + np.array([[0.2], [0.1], [0.3]])
    else:
        raise ValueError(f"unknown motion {motion!r}: use random, structured, one_axis or translation_only")
    return make_transform(_tilt(rx, ry, rz), t)


def make_problem(
    n_poses: int,
    setup: str = "eye_to_hand",
    rng: np.random.Generator | None = None,
    camera_noise: tuple[float, float] = (0.0, 0.0),
    robot_noise: tuple[float, float] = (0.0, 0.0),
    motion: str = "random",
    outlier_fraction: float = 0.0,
    max_tilt_deg: float = 35.0,
) -> HandEyeProblem:
    """Generate a hand-eye problem with known ``X`` and ``Y``.

    Parameters
    ----------
    n_poses : int
    setup : {"eye_to_hand", "eye_in_hand"}
    rng : numpy.random.Generator, optional
        Default ``np.random.default_rng(0)``.
    camera_noise : (float, float)
        Per-axis standard deviations on ``T_cam_target``: (degrees, millimetres).
    robot_noise : (float, float)
        Per-axis standard deviations on ``T_base_ee``: (degrees, millimetres).
    motion : {"random", "structured", "one_axis", "translation_only"}
        How the board is presented. ``one_axis`` and ``translation_only`` are
        degenerate on purpose.
    outlier_fraction : float
        Fraction of camera poses replaced by gross errors (rotated 10 to 90
        degrees and moved 5 to 30 cm).
    max_tilt_deg : float
        Largest tilt of the board from facing the camera.

    Returns
    -------
    HandEyeProblem
    """
    setup = normalize_setup(setup)
    rng = np.random.default_rng(0) if rng is None else rng
    T_cam_target = _target_in_camera(rng, n_poses, motion, max_tilt_deg)
    if setup == "eye_to_hand":
        # camera 1 to 1.5 m from the base, target a few cm off the flange
        X = make_transform(random_rotations(rng, 1)[0], rng.uniform(-1.0, 1.0, 3) + [0.0, 0.0, 0.5])
        Y = make_transform(random_rotations(rng, 1)[0], rng.uniform(-0.08, 0.08, 3))
        T_base_ee = X @ T_cam_target @ invert_transform(Y)
    else:
        # camera a few cm off the flange, target on the table
        X = make_transform(random_rotations(rng, 1)[0], rng.uniform(-0.1, 0.1, 3))
        Y = make_transform(random_rotations(rng, 1)[0], rng.uniform(-0.6, 0.6, 3))
        T_base_ee = Y @ invert_transform(T_cam_target) @ invert_transform(X)
    deg, mm = np.radians(1.0), 1e-3
    if camera_noise != (0.0, 0.0):
        T_cam_target = perturb(T_cam_target, rng, camera_noise[0] * deg, camera_noise[1] * mm)
    if robot_noise != (0.0, 0.0):
        T_base_ee = perturb(T_base_ee, rng, robot_noise[0] * deg, robot_noise[1] * mm)
    outliers = np.zeros(n_poses, dtype=bool)
    n_out = int(round(outlier_fraction * n_poses))
    if n_out:
        idx = rng.choice(n_poses, n_out, replace=False)
        outliers[idx] = True
        axes = rng.normal(size=(n_out, 3))
        axes /= np.linalg.norm(axes, axis=1, keepdims=True)
        angles = rng.uniform(np.radians(10), np.radians(90), n_out)
        shifts = rng.normal(size=(n_out, 3))
        shifts *= (rng.uniform(0.05, 0.3, n_out) / np.linalg.norm(shifts, axis=1))[:, None]
        gross = make_transform(so3_exp(axes * angles[:, None]), shifts)
        T_cam_target = T_cam_target.copy()
        T_cam_target[idx] = gross @ T_cam_target[idx]
    return HandEyeProblem(setup, T_base_ee, T_cam_target, X, Y, outliers)
