"""Robot controllers' Euler angles and URDF rpy: known answers, scipy as the reference, round trips."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from handeye.core.robot_angles import (
    fanuc_wpr_from_matrix,
    kuka_abc_from_matrix,
    matrix_from_fanuc_wpr,
    matrix_from_kuka_abc,
    matrix_from_urdf_rpy,
    urdf_rpy_from_matrix,
)
from tests.tolerances import FLOAT

#: 90 degrees about one axis, written out.
RX90 = np.array([[1.0, 0, 0], [0, 0, -1], [0, 1, 0]])
RY90 = np.array([[0.0, 0, 1], [0, 1, 0], [-1, 0, 0]])
RZ90 = np.array([[0.0, -1, 0], [1, 0, 0], [0, 0, 1]])


@pytest.mark.parametrize(
    "abc, expected",
    [
        ((90, 0, 0), RZ90),  # A about Z
        ((0, 90, 0), RY90),  # B about Y
        ((0, 0, 90), RX90),  # C about X
        ((90, 90, 0), RZ90 @ RY90),  # Rz(A) Ry(B): [[0, -1, 0], [0, 0, 1], [-1, 0, 0]]
    ],
)
def test_kuka_abc_known_answers(abc, expected):
    np.testing.assert_allclose(matrix_from_kuka_abc(abc), expected, atol=FLOAT)


def test_kuka_order_written_out():
    """A = 90, B = 90: rotate about z, then about the new y: the matrix written by hand."""
    np.testing.assert_allclose(matrix_from_kuka_abc([90, 90, 0]), [[0, -1, 0], [0, 0, 1], [-1, 0, 0]], atol=FLOAT)


@pytest.mark.parametrize(
    "wpr, expected",
    [
        ((90, 0, 0), RX90),  # W about X
        ((0, 90, 0), RY90),  # P about Y
        ((0, 0, 90), RZ90),  # R about Z
        ((90, 0, 90), RZ90 @ RX90),  # fixed axes: W first, then R about the fixed z
    ],
)
def test_fanuc_wpr_known_answers(wpr, expected):
    np.testing.assert_allclose(matrix_from_fanuc_wpr(wpr), expected, atol=FLOAT)


def test_urdf_rpy_known_answers():
    np.testing.assert_allclose(matrix_from_urdf_rpy([np.pi / 2, 0, 0]), RX90, atol=FLOAT)
    np.testing.assert_allclose(matrix_from_urdf_rpy([0, 0, np.pi / 2]), RZ90, atol=FLOAT)
    np.testing.assert_allclose(matrix_from_urdf_rpy([np.pi / 2, 0, np.pi / 2]), RZ90 @ RX90, atol=FLOAT)


def test_against_scipy(rng):
    """KUKA is scipy's intrinsic "ZYX", Fanuc and URDF its extrinsic "xyz"; batches of any shape."""
    angles = rng.uniform(-180, 180, size=(2, 50, 3))
    angles[..., 1] /= 2  # the middle angle in [-90, 90]
    flat = angles.reshape(-1, 3)
    kuka = Rotation.from_euler("ZYX", flat, degrees=True).as_matrix().reshape(2, 50, 3, 3)
    fanuc = Rotation.from_euler("xyz", flat, degrees=True).as_matrix().reshape(2, 50, 3, 3)
    urdf = Rotation.from_euler("xyz", np.radians(flat)).as_matrix().reshape(2, 50, 3, 3)
    np.testing.assert_allclose(matrix_from_kuka_abc(angles), kuka, atol=FLOAT)
    np.testing.assert_allclose(matrix_from_fanuc_wpr(angles), fanuc, atol=FLOAT)
    np.testing.assert_allclose(matrix_from_urdf_rpy(np.radians(angles)), urdf, atol=FLOAT)
    # the same rotation: Fanuc (W, P, R) is KUKA (C, B, A)
    np.testing.assert_allclose(matrix_from_fanuc_wpr(angles[..., ::-1]), kuka, atol=FLOAT)


def test_matrix_to_angles_round_trip_and_range(rng):
    R = Rotation.random(200, random_state=rng).as_matrix()
    abc = kuka_abc_from_matrix(R)
    assert np.all(np.abs(abc[:, 1]) <= 90) and np.all(np.abs(abc[:, [0, 2]]) <= 180)
    np.testing.assert_allclose(matrix_from_kuka_abc(abc), R, atol=FLOAT)
    np.testing.assert_allclose(matrix_from_fanuc_wpr(fanuc_wpr_from_matrix(R)), R, atol=FLOAT)
    np.testing.assert_allclose(matrix_from_urdf_rpy(urdf_rpy_from_matrix(R)), R, atol=FLOAT)
    np.testing.assert_allclose(kuka_abc_from_matrix(matrix_from_kuka_abc([30, -45, 120])), [30, -45, 120], atol=FLOAT)


@pytest.mark.parametrize("b", [90.0, -90.0])
def test_gimbal_lock_still_round_trips(b):
    """At B = +-90 deg only A - C (or A + C) is defined: the matrix comes back, with C = 0."""
    R = matrix_from_kuka_abc([40.0, b, 25.0])
    abc = kuka_abc_from_matrix(R)
    assert abc[2] == 0.0 and abc[1] == pytest.approx(b)
    np.testing.assert_allclose(matrix_from_kuka_abc(abc), R, atol=FLOAT)
    np.testing.assert_allclose(matrix_from_urdf_rpy(urdf_rpy_from_matrix(R)), R, atol=FLOAT)
