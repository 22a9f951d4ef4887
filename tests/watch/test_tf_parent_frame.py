"""The published static transform's parent frame is the frame the robot model's kinematics give ``T_base_cam``
in: for the UR models, ``base_link`` (the URDF's root). UR's ``base`` link is turned 180 degrees about z from
it (``base_link-base_fixed_joint``, rpy 0 0 -pi), so ``T_base_cam`` published under ``base`` puts the camera on
the other side of the robot in tf."""

from __future__ import annotations

import numpy as np
import pytest

from handeye.cli import main
from handeye.watch import History
from handeye.watch.ros2 import TfPublisher
from tests.tolerances import FLOAT
from tests.watch.test_ros2 import fake_ros


def _published_parent(tmp_path, monkeypatch, *extra) -> str:
    calls = fake_ros(monkeypatch, [])
    h = History(tmp_path / "h.jsonl")
    h.append(np.eye(4), "test")
    assert main(["watch", "rollback", "--history", str(h.path), "1", "--publish-tf", *extra]) == 0
    (sent,) = [c[1] for c in calls if c[0] == "sendTransform"]
    return sent.header.frame_id


def test_the_default_parent_frame_is_the_models_base(tmp_path, monkeypatch, capsys):
    pytest.importorskip("pinocchio")
    pytest.importorskip("example_robot_data")
    from handeye.robot.model import load_robot

    parent = _published_parent(tmp_path, monkeypatch)
    robot = load_robot("ur5")
    robot.pin.framesForwardKinematics(robot.model, robot.data, np.zeros(robot.nq))
    T_model_parent = robot.data.oMf[robot.model.getFrameId(parent)].homogeneous
    np.testing.assert_allclose(T_model_parent, np.eye(4), atol=FLOAT)
    assert TfPublisher.__init__.__defaults__[0] == parent


def test_another_parent_frame_is_taken_as_given(tmp_path, monkeypatch, capsys):
    assert _published_parent(tmp_path, monkeypatch, "--base-frame", "world") == "world"
