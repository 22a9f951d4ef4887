"""The UR robot through Pinocchio: kinematics against the published DH parameters, IK, meshes."""

from __future__ import annotations

import os

import numpy as np
import pytest

pytest.importorskip("pinocchio")
pytest.importorskip("example_robot_data")

from handeye.core.errors import HandEyeInputError  # noqa: E402
from handeye.robot.model import load_robot  # noqa: E402
from tests.tolerances import EXACT, FLOAT, URDF_ROUNDED_ANGLES_M  # noqa: E402

# Universal Robots' published DH parameters (metres): d1, a2, a3, d4, d5, d6
DH = {
    "ur5": (0.089159, -0.425, -0.39225, 0.10915, 0.09465, 0.0823),
    "ur3": (0.1519, -0.24365, -0.21325, 0.11235, 0.08535, 0.0819),
}


@pytest.fixture(scope="module", params=["ur5", "ur3"])
def robot(request):
    return load_robot(request.param)


def test_zero_configuration_matches_dh(robot):
    """At q = 0 the arm is stretched out: the flange sits at (|a2 + a3|, d4 + d6, d1 - d5) (model base frame)."""
    d1, a2, a3, d4, d5, d6 = DH[robot.name]
    p = robot.fk(np.zeros(robot.nq))[:3, 3]
    np.testing.assert_allclose(np.abs(p), [abs(a2 + a3), d4 + d6, abs(d1 - d5)], atol=URDF_ROUNDED_ANGLES_M)


def test_base_joint_rotates_the_flange_about_base_z(robot):
    rng = np.random.default_rng(0)
    q = rng.uniform(-2, 2, robot.nq)
    q2 = q.copy()
    q2[0] += 0.7
    p, p2 = robot.fk(q)[:3, 3], robot.fk(q2)[:3, 3]
    c, s = np.cos(0.7), np.sin(0.7)
    np.testing.assert_allclose(p2, [c * p[0] - s * p[1], s * p[0] + c * p[1], p[2]], atol=EXACT)


def test_batch_and_reference_point(robot):
    q = np.random.default_rng(1).uniform(-2, 2, (2, 3, robot.nq))
    T = robot.fk(q)
    assert T.shape == (2, 3, 4, 4)
    np.testing.assert_allclose(T[1, 2], robot.fk(q[1, 2]), atol=EXACT)
    np.testing.assert_allclose(robot.fk_ref(q), T @ robot.T_ee_ref, atol=EXACT)


def test_keypoints_along_the_long_links_ride_with_their_link(robot):
    """The upper arm and the forearm (DH a2, a3) carry points at LINK_FRACTIONS of the way between their joint
    origins; each stays at a fixed place in its link whatever the joints do."""
    from handeye.robot.model import LINK_FRACTIONS

    names = robot.keypoint_names
    q = np.random.default_rng(3).uniform(-2, 2, (4, robot.nq))
    kp = robot.keypoints_base(q)
    assert kp.shape == (4, robot.nq + 2 * len(LINK_FRACTIONS) + 2, 3) == (4, len(names), 3)
    assert names[-2:] == ["flange", "ref"]
    np.testing.assert_allclose(kp[:, -2], robot.fk(q)[:, :3, 3], atol=EXACT)
    joint = {n: i for i, n in enumerate(names)}
    _, a2, a3, *_ = DH[robot.name]
    for first, second, length in [("shoulder_lift", "elbow", abs(a2)), ("elbow", "wrist_1", abs(a3))]:
        o_a, o_b = kp[:, joint[f"{first}_joint"]], kp[:, joint[f"{second}_joint"]]
        d = np.linalg.norm(o_b - o_a, axis=1)
        for f in LINK_FRACTIONS:
            p = kp[:, joint[f"{first}@{f:.2f}"]]
            np.testing.assert_allclose(np.linalg.norm(p - o_a, axis=1), f * d, atol=EXACT)
            np.testing.assert_allclose(np.linalg.norm(p - o_b, axis=1), (1 - f) * d, atol=EXACT)
        # the segment is the link's: as long whatever the joints (the DH length plus the joints' offset)
        np.testing.assert_allclose(d, d[0], atol=EXACT)
        assert d[0] >= length


def test_ik_round_trip(robot):
    rng = np.random.default_rng(2)
    for _ in range(5):
        q = rng.uniform(-2, 2, robot.nq)
        target = robot.fk(q)
        sol = robot.ik(target, q + rng.normal(scale=0.1, size=robot.nq))
        assert sol is not None
        rot, trans = robot.pose_error(sol, target)
        assert rot < EXACT and trans < EXACT


def test_meshes_exist(robot):
    links = robot.link_poses(np.zeros(robot.nq))
    assert len(links) == 7
    for _, path, T in links:
        assert os.path.isfile(path)
        assert T.shape == (4, 4)


def test_unknown_robot():
    with pytest.raises(HandEyeInputError, match="ur5"):
        load_robot("ur10e")


def test_any_urdf_by_path_gives_the_same_robot():
    """load_robot_urdf (a user's URDF with meshes) on the UR5's own file: the same kinematics and meshes."""
    from pathlib import Path

    import example_robot_data as erd

    from handeye.robot.model import load_robot, load_robot_urdf

    loader = erd.robots_loader.UR5Loader()
    urdf = Path(loader.df_path)
    share = Path(loader.model_path).resolve().parents[1]  # its meshes are package://example-robot-data/robots/...
    mine, theirs = load_robot_urdf(urdf, [share]), load_robot("ur5")
    q = np.random.default_rng(0).uniform(-2, 2, size=(5, 6))
    np.testing.assert_allclose(mine.fk(q), theirs.fk(q), atol=FLOAT)
    np.testing.assert_allclose(mine.keypoints_base(q), theirs.keypoints_base(q), atol=FLOAT)
    assert [Path(p).name for _, p, _ in mine.link_poses(q[0])] == [Path(p).name for _, p, _ in theirs.link_poses(q[0])]


def test_pose_jacobians_are_the_flange_pose_derivatives(robot):
    """Rows [w (flange frame), n (base frame)] per joint: what classic.noise_model's robot noise means."""
    from handeye.core.se3 import so3_log
    from tests.tolerances import JACOBIAN_RTOL

    q = np.array([[0.3, -1.2, 1.5, -1.8, -1.57, 0.4], [1.0, -0.5, 0.7, 0.2, 1.1, -2.0]])
    J = robot.pose_jacobians(q)
    h = 1e-6
    for k, qk in enumerate(q):
        T = robot.fk(qk)
        for j in range(robot.nq):
            e = np.zeros(robot.nq)
            e[j] = h
            Tp, Tm = robot.fk(qk + e), robot.fk(qk - e)
            w = (so3_log(T[:3, :3].T @ Tp[:3, :3]) - so3_log(T[:3, :3].T @ Tm[:3, :3])) / (2 * h)
            n = (Tp[:3, 3] - Tm[:3, 3]) / (2 * h)
            np.testing.assert_allclose(J[k, :, j], np.concatenate([w, n]), atol=JACOBIAN_RTOL)


def test_each_loaded_robot_has_its_own_models():
    """The URDF is parsed once a process (``load_robot``'s cache); a robot changed by one caller leaves the next
    load as the description has it."""
    first = load_robot("ur5")
    q = np.array([0.3, -1.1, 0.9, 0.2, -0.4, 0.6])
    T_before = first.fk(q)
    first.model.jointPlacements[1].translation = first.model.jointPlacements[1].translation + 0.1
    assert not np.allclose(first.fk(q), T_before)  # the change took
    second = load_robot("ur5")
    assert second.model is not first.model and second.visual_model is not first.visual_model
    np.testing.assert_array_equal(second.fk(q), T_before)
