"""handeye.core.se3 against scipy.spatial.transform.Rotation, an independent implementation."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from handeye.core import se3
from tests.tolerances import ABSOLUTE_ONLY, FLOAT, NEAR_PI_ANGLE, SAME_FORMULA

BATCH_SHAPES = [(), (5,), (2, 5)]


def _random_rotvecs(rng: np.random.Generator, shape: tuple) -> np.ndarray:
    """Rotation vectors with uniformly random axes and angles in (0, pi)."""
    axes = rng.normal(size=shape + (3,))
    axes /= np.linalg.norm(axes, axis=-1, keepdims=True)
    return axes * rng.uniform(0.0, np.pi, size=shape + (1,))


def _scipy_matrices(rotvec: np.ndarray) -> np.ndarray:
    return Rotation.from_rotvec(rotvec.reshape(-1, 3)).as_matrix().reshape(rotvec.shape[:-1] + (3, 3))


def _same_rotation_quat(q1: np.ndarray, q2: np.ndarray) -> np.ndarray:
    """Distance between quaternions up to sign (both signs describe one rotation)."""
    return np.minimum(np.abs(q1 - q2).max(axis=-1), np.abs(q1 + q2).max(axis=-1))


# ---------------------------------------------------------------- hat / vee


def test_hat_is_cross_product_and_vee_inverts_it(rng):
    a, b = rng.normal(size=(2, 7, 3))
    np.testing.assert_allclose(se3.hat(a) @ b[..., None], np.cross(a, b)[..., None], atol=FLOAT)
    np.testing.assert_allclose(se3.vee(se3.hat(a)), a, atol=FLOAT)
    S = se3.hat(a)
    np.testing.assert_array_equal(S, -np.swapaxes(S, -1, -2))  # entries are copies and negations: exact


# ---------------------------------------------------------------- so3_exp / so3_log


@pytest.mark.parametrize("shape", BATCH_SHAPES)
def test_so3_exp_matches_scipy(rng, shape):
    rv = _random_rotvecs(rng, shape)
    R = se3.so3_exp(rv)
    assert R.shape == shape + (3, 3)
    np.testing.assert_allclose(R, _scipy_matrices(rv), atol=FLOAT)


@pytest.mark.parametrize("shape", BATCH_SHAPES)
def test_so3_log_matches_scipy_and_inverts_exp(rng, shape):
    rv = _random_rotvecs(rng, shape)
    R = _scipy_matrices(rv)
    out = se3.so3_log(R)
    assert out.shape == shape + (3,)
    reference = Rotation.from_matrix(R.reshape(-1, 3, 3)).as_rotvec().reshape(shape + (3,))
    np.testing.assert_allclose(out, reference, atol=FLOAT)
    np.testing.assert_allclose(out, rv, atol=FLOAT)
    np.testing.assert_allclose(se3.so3_exp(out), R, atol=FLOAT)


@pytest.mark.parametrize("angle", [0.0, 1e-14, 1e-10, 1e-8, 1e-7, 1e-5, 1e-3])
def test_so3_exp_log_near_zero(rng, angle):
    axis = rng.normal(size=3)
    axis /= np.linalg.norm(axis)
    rv = angle * axis
    R = se3.so3_exp(rv)
    np.testing.assert_allclose(R, Rotation.from_rotvec(rv).as_matrix(), atol=FLOAT)
    # near zero the rotation vector must come back to relative accuracy, not just absolute
    np.testing.assert_allclose(se3.so3_log(R), rv, rtol=FLOAT, atol=FLOAT * angle + 1e-300)
    assert abs(se3.rotation_angle(R) - angle) <= FLOAT * max(angle, 1e-300) + 1e-300


@pytest.mark.parametrize("gap", [0.0, 1e-12, 1e-9, 1e-6, 1e-3])
def test_so3_log_near_pi(rng, gap):
    axis = rng.normal(size=3)
    axis /= np.linalg.norm(axis)
    angle = np.pi - gap
    R = Rotation.from_rotvec(angle * axis).as_matrix()
    out = se3.so3_log(R)
    assert abs(np.linalg.norm(out) - angle) <= NEAR_PI_ANGLE
    # at pi the axis sign is arbitrary: both axis*pi and -axis*pi are the same rotation
    assert min(np.abs(out - angle * axis).max(), np.abs(out + angle * axis).max()) <= NEAR_PI_ANGLE
    np.testing.assert_allclose(se3.so3_exp(out), R, atol=NEAR_PI_ANGLE)
    assert abs(se3.rotation_angle(R) - angle) <= NEAR_PI_ANGLE


@pytest.mark.parametrize("shape", BATCH_SHAPES)
def test_rotvec_from_quaternion_ignores_sign(rng, shape):
    rv = _random_rotvecs(rng, shape)
    q = Rotation.from_rotvec(rv.reshape(-1, 3)).as_quat().reshape(shape + (4,))
    out = se3.rotvec_from_quat_xyzw(q)
    assert out.shape == shape + (3,)
    np.testing.assert_allclose(out, rv, atol=FLOAT)
    np.testing.assert_allclose(se3.rotvec_from_quat_xyzw(-q), rv, atol=FLOAT)


@pytest.mark.parametrize("shape", BATCH_SHAPES)
def test_rotation_angle_matches_scipy(rng, shape):
    rv = _random_rotvecs(rng, shape)
    ang = se3.rotation_angle(_scipy_matrices(rv))
    assert np.shape(ang) == shape
    np.testing.assert_allclose(ang, np.linalg.norm(rv, axis=-1), atol=FLOAT)


# ---------------------------------------------------------------- quaternions


@pytest.mark.parametrize("shape", BATCH_SHAPES)
def test_quaternion_xyzw_matches_scipy_canonical(rng, shape):
    rv = _random_rotvecs(rng, shape)
    R = _scipy_matrices(rv)
    q = se3.quat_xyzw_from_matrix(R)
    assert q.shape == shape + (4,)
    assert np.all(q[..., 3] >= 0.0)
    np.testing.assert_allclose(np.linalg.norm(q, axis=-1), 1.0, atol=FLOAT)
    ref = Rotation.from_matrix(R.reshape(-1, 3, 3)).as_quat(canonical=True).reshape(shape + (4,))
    np.testing.assert_allclose(q, ref, atol=FLOAT)
    np.testing.assert_allclose(se3.matrix_from_quat_xyzw(q), R, atol=FLOAT)


def test_quaternion_canonical_sign_for_every_largest_component(rng):
    # Shepperd's method has four branches (w, x, y or z largest): hit each one,
    # with angles close to pi so that w is small.
    for k in range(3):
        axis = np.zeros(3)
        axis[k] = 1.0
        axis += 0.05 * rng.normal(size=3)
        for angle in (0.3, 2.5, 3.1, np.pi - 1e-9):
            R = Rotation.from_rotvec(angle * axis / np.linalg.norm(axis)).as_matrix()
            q = se3.quat_xyzw_from_matrix(R)
            assert q[3] >= 0.0
            ref = Rotation.from_matrix(R).as_quat(canonical=True)
            assert _same_rotation_quat(q, ref) <= FLOAT


def test_matrix_from_quaternion_normalises_and_ignores_sign(rng):
    q = rng.normal(size=(6, 4))
    R = se3.matrix_from_quat_xyzw(q)
    ref = Rotation.from_quat(q).as_matrix()  # scipy normalises too
    np.testing.assert_allclose(R, ref, atol=FLOAT)
    np.testing.assert_allclose(se3.matrix_from_quat_xyzw(-q), R, atol=FLOAT)


def test_wxyz_xyzw_reordering_round_trip(rng):
    q = rng.normal(size=(2, 3, 4))
    wxyz = se3.quat_xyzw_to_wxyz(q)
    np.testing.assert_array_equal(wxyz[..., 0], q[..., 3])
    np.testing.assert_array_equal(wxyz[..., 1:], q[..., :3])
    np.testing.assert_array_equal(se3.quat_wxyz_to_xyzw(wxyz), q)


def test_quaternion_product_is_rotation_composition(rng):
    R1 = Rotation.random(5, random_state=1)
    R2 = Rotation.random(5, random_state=2)
    p = se3.quat_xyzw_to_wxyz(R1.as_quat())
    q = se3.quat_xyzw_to_wxyz(R2.as_quat())
    pq = se3.quat_wxyz_to_xyzw(se3.quat_multiply_wxyz(p, q))
    assert np.all(_same_rotation_quat(pq, (R1 * R2).as_quat()) <= FLOAT)


# ---------------------------------------------------------------- transforms


def _random_transforms(rng, shape):
    return se3.make_transform(_scipy_matrices(_random_rotvecs(rng, shape)), rng.normal(size=shape + (3,)))


@pytest.mark.parametrize("shape", BATCH_SHAPES)
def test_invert_transform(rng, shape):
    T = _random_transforms(rng, shape)
    T_inv = se3.invert_transform(T)
    assert T_inv.shape == shape + (4, 4)
    np.testing.assert_allclose(T_inv @ T, np.broadcast_to(np.eye(4), T.shape), atol=FLOAT)
    np.testing.assert_allclose(T @ T_inv, np.broadcast_to(np.eye(4), T.shape), atol=FLOAT)
    np.testing.assert_allclose(T_inv, np.linalg.inv(T), atol=FLOAT)


def test_transform_convention_maps_points(rng):
    # T_a_b maps coordinates in b to coordinates in a: p_a = R p_b + t
    R = Rotation.random(random_state=3)
    t = rng.normal(size=3)
    T_a_b = se3.make_transform(R.as_matrix(), t)
    p_b = rng.normal(size=3)
    np.testing.assert_allclose((T_a_b @ np.append(p_b, 1.0))[:3], R.apply(p_b) + t, atol=FLOAT)


@pytest.mark.parametrize("shape", BATCH_SHAPES)
def test_pos_quat_round_trip(rng, shape):
    T = _random_transforms(rng, shape)
    t, q = se3.pos_quat_xyzw_from_transform(T)
    assert t.shape == shape + (3,) and q.shape == shape + (4,)
    assert np.all(q[..., 3] >= 0)
    np.testing.assert_allclose(se3.transform_from_pos_quat_xyzw(t, q), T, atol=FLOAT)


@pytest.mark.parametrize("shape", BATCH_SHAPES)
def test_transform_from_rotvec_translation(rng, shape):
    rv = _random_rotvecs(rng, shape)
    t = rng.normal(size=shape + (3,))
    T = se3.transform_from_rotvec_translation(rv, t)
    assert T.shape == shape + (4, 4)
    np.testing.assert_allclose(T[..., :3, :3], _scipy_matrices(rv), atol=FLOAT)
    np.testing.assert_array_equal(T[..., :3, 3], t)  # a copy
    np.testing.assert_array_equal(T[..., 3, :], np.broadcast_to([0.0, 0.0, 0.0, 1.0], shape + (4,)))


# ---------------------------------------------------------------- projection


@pytest.mark.parametrize("shape", BATCH_SHAPES)
def test_project_to_so3_gives_proper_rotation(rng, shape):
    M = rng.normal(size=shape + (3, 3))
    # half of them are reflections-plus-noise: the projection must still be det +1
    R = se3.project_to_so3(M)
    assert R.shape == shape + (3, 3)
    np.testing.assert_allclose(np.swapaxes(R, -1, -2) @ R, np.broadcast_to(np.eye(3), R.shape), atol=FLOAT)
    np.testing.assert_allclose(np.linalg.det(R), 1.0, atol=FLOAT)


def test_project_to_so3_recovers_a_perturbed_rotation(rng):
    R = Rotation.random(4, random_state=4).as_matrix()
    np.testing.assert_allclose(se3.project_to_so3(R), R, atol=FLOAT)
    # the nearest rotation to a scaled rotation is the rotation itself
    np.testing.assert_allclose(se3.project_to_so3(3.0 * R), R, atol=FLOAT)
    # a reflection is never returned: det(-R) = -1 must come out with det +1
    assert np.all(np.linalg.det(se3.project_to_so3(-R)) > 0)


@pytest.mark.parametrize("angle", [0.0, 1e-9, 1e-8, 1e-4, 1.0, np.pi - 1e-6, np.pi])
def test_so3_exp_of_one_vector_is_the_batched_formula(rng, angle):
    """One rotation vector takes a scalar path (refinement steps); it must give the batched values."""
    axis = rng.normal(size=3)
    rv = angle * axis / np.linalg.norm(axis)
    np.testing.assert_allclose(se3.so3_exp(rv), se3.so3_exp(rv[None])[0], rtol=ABSOLUTE_ONLY, atol=SAME_FORMULA)
