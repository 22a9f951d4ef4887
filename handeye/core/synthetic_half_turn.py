"""Synthetic hand-eye problems whose motion pairs turn by up to half a turn, with known truth.

A real recording often has motion pairs near 180 degrees (a board or marker seen from both sides
of a turn of the wrist). There the quaternion of a motion has a scalar part near zero, and pose
noise decides its sign independently on the robot side and the camera side: the closed forms
built on quaternion vector parts must align the signs of each pair first (:mod:`classic.motions`).

Three ways to build the robot's orientations (translations are random in a 0.5 m box; the camera
poses follow from the true ``X`` and ``Y`` as in :func:`handeye.core.synthetic.make_problem`):

* ``"near"`` (:func:`half_turn_orientations`): each orientation is a common rotation times one
  of the four quaternions ``1, i, j, k``, times a small rotation of angle up to ``spread_deg``.
  Pairs of different quaternions turn by ``180 - 2 spread_deg`` to 180 degrees (three quarters
  of all pairs), pairs of the same one by at most ``2 spread_deg``. With ``spread_deg = 0`` the
  set is degenerate: half turns about three orthogonal axes commute, and the rotations alone
  cannot tell ``R_X`` from ``R_X`` turned half a turn about one of them (only the translations
  can); keep ``spread_deg`` well above the noise.
* ``"exact"`` (:func:`exact_half_turn_orientations`): pairs of orientations exactly half a turn
  apart (before noise), about random axes; the other pairs at random angles.
* ``"capped"`` (:func:`capped_orientations`): uniformly random orientations, each accepted only
  when it turns by at most ``max_angle_deg`` from every one accepted before: motion pairs of every
  angle up to the cap, several near it.
"""

from __future__ import annotations

import numpy as np

from handeye.core.se3 import invert_transform, make_transform, matrix_from_quat_xyzw, rotation_angle, so3_exp
from handeye.core.setups import normalize_setup
from handeye.core.synthetic import HandEyeProblem, perturb, random_rotations

__all__ = ["half_turn_orientations", "exact_half_turn_orientations", "capped_orientations", "half_turn_problem"]

#: The four quaternions (x, y, z, w) whose pairwise rotations are half turns about x, y and z.
_HALF_TURN_QUATS = np.array([[0.0, 0.0, 0.0, 1.0], [1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0]])


def _small_rotations(rng: np.random.Generator, n: int, max_angle_rad: float) -> np.ndarray:
    axes = rng.normal(size=(n, 3))
    axes /= np.linalg.norm(axes, axis=1, keepdims=True)
    return so3_exp(axes * rng.uniform(0.0, max_angle_rad, (n, 1)))


def half_turn_orientations(rng: np.random.Generator, n: int, spread_deg: float) -> np.ndarray:
    """Orientations whose pairs mostly turn by ``180 - 2 spread_deg`` to 180 degrees.

    Parameters
    ----------
    rng : numpy.random.Generator
    n : int
        Number of orientations; pose ``i`` takes the half-turn quaternion ``i mod 4``.
    spread_deg : float
        Largest angle of the small rotation applied to each, degrees.

    Returns
    -------
    R : array, shape (n, 3, 3)
    """
    R0 = random_rotations(rng, 1)[0]
    E = matrix_from_quat_xyzw(_HALF_TURN_QUATS[np.arange(n) % 4])
    return R0 @ E @ _small_rotations(rng, n, np.radians(spread_deg))


def exact_half_turn_orientations(rng: np.random.Generator, n: int) -> np.ndarray:
    """Random orientations in pairs ``(R, R Rot(pi, axis))``: motions of exactly 180 degrees.

    Parameters
    ----------
    rng : numpy.random.Generator
    n : int

    Returns
    -------
    R : array, shape (n, 3, 3)
        Orientation ``2m + 1`` is orientation ``2m`` turned half a turn about a random axis.
    """
    R = random_rotations(rng, n)
    axes = rng.normal(size=(n // 2, 3))
    axes /= np.linalg.norm(axes, axis=1, keepdims=True)
    R[1 : 2 * (n // 2) : 2] = R[0 : 2 * (n // 2) : 2] @ so3_exp(np.pi * axes)
    return R


def capped_orientations(rng: np.random.Generator, n: int, max_angle_deg: float) -> np.ndarray:
    """Uniformly random orientations, every pair turning by at most ``max_angle_deg``.

    Parameters
    ----------
    rng : numpy.random.Generator
    n : int
    max_angle_deg : float
        The cap on the angle between any two orientations, degrees (at least 90).

    Returns
    -------
    R : array, shape (n, 3, 3)
    """
    if max_angle_deg < 90.0:
        raise ValueError(f"max_angle_deg must be at least 90 (rejection sampling), got {max_angle_deg}")
    cap = np.radians(max_angle_deg)
    accepted = [random_rotations(rng, 1)[0]]
    while len(accepted) < n:
        R = random_rotations(rng, 64)
        for cand in R:
            if np.all(rotation_angle(np.asarray(accepted) @ cand.T) <= cap):
                accepted.append(cand)
                break
    return np.asarray(accepted)


def half_turn_problem(
    n_poses: int,
    setup: str = "eye_to_hand",
    rng: np.random.Generator | None = None,
    camera_noise: tuple[float, float] = (0.0, 0.0),
    robot_noise: tuple[float, float] = (0.0, 0.0),
    orientations: str = "near",
    spread_deg: float = 5.0,
    max_angle_deg: float = 180.0,
) -> HandEyeProblem:
    """A hand-eye problem with motions near half a turn and known ``X``, ``Y``.

    Parameters
    ----------
    n_poses : int
    setup : {"eye_to_hand", "eye_in_hand"}
    rng : numpy.random.Generator, optional
        Default ``np.random.default_rng(0)``.
    camera_noise, robot_noise : (float, float)
        Per-axis standard deviations on ``T_cam_target`` and ``T_base_ee``: (degrees, millimetres),
        as in :func:`handeye.core.synthetic.make_problem`.
    orientations : {"near", "exact", "capped"}
        :func:`half_turn_orientations`, :func:`exact_half_turn_orientations` or
        :func:`capped_orientations` (see the module).
    spread_deg : float
        The spread of ``"near"``, degrees.
    max_angle_deg : float
        The cap of ``"capped"``, degrees.

    Returns
    -------
    HandEyeProblem
        ``T_base_ee`` with the designed orientations; ``X_true = T_base_cam`` (eye-to-hand) or
        ``T_ee_cam`` (eye-in-hand), ``Y_true = T_ee_target`` or ``T_base_target``.
    """
    setup = normalize_setup(setup)
    rng = np.random.default_rng(0) if rng is None else rng
    if orientations == "near":
        R = half_turn_orientations(rng, n_poses, spread_deg)
    elif orientations == "exact":
        R = exact_half_turn_orientations(rng, n_poses)
    elif orientations == "capped":
        R = capped_orientations(rng, n_poses, max_angle_deg)
    else:
        raise ValueError(f"unknown orientations {orientations!r}: use near, exact or capped")
    T_base_ee = make_transform(R, rng.uniform(-0.25, 0.25, (n_poses, 3)) + [0.4, 0.0, 0.4])
    if setup == "eye_to_hand":
        X = make_transform(random_rotations(rng, 1)[0], rng.uniform(-1.0, 1.0, 3) + [0.0, 0.0, 0.5])
        Y = make_transform(random_rotations(rng, 1)[0], rng.uniform(-0.08, 0.08, 3))
        T_cam_target = invert_transform(X) @ T_base_ee @ Y
    else:
        X = make_transform(random_rotations(rng, 1)[0], rng.uniform(-0.1, 0.1, 3))
        Y = make_transform(random_rotations(rng, 1)[0], rng.uniform(-0.6, 0.6, 3))
        T_cam_target = invert_transform(X) @ invert_transform(T_base_ee) @ Y
    deg, mm = np.radians(1.0), 1e-3
    if camera_noise != (0.0, 0.0):
        T_cam_target = perturb(T_cam_target, rng, camera_noise[0] * deg, camera_noise[1] * mm)
    if robot_noise != (0.0, 0.0):
        T_base_ee = perturb(T_base_ee, rng, robot_noise[0] * deg, robot_noise[1] * mm)
    return HandEyeProblem(setup, T_base_ee, T_cam_target, X, Y, np.zeros(n_poses, dtype=bool))
