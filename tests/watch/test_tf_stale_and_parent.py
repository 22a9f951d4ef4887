"""What tf consumers are told (a fake rclpy, tests/watch/test_ros2.py): a stale calibration is said on the status
topic and in the current JSON, nothing new is sent on tf meanwhile; a camera frame with a parent on /tf_static
(a camera driver's optical frame) is reached through its tree's root; a camera already placed under the base is
refused before anything is appended."""

from __future__ import annotations

import json
import sys
from types import SimpleNamespace

import numpy as np
import pytest

from handeye.cli import main
from handeye.core.se3 import make_transform, pos_quat_xyzw_from_transform, so3_exp
from handeye.watch import History
from handeye.watch.ros2 import STATUS_TOPIC, TfPublisher
from tests.tolerances import FLOAT
from tests.watch.cell_streams import KnownAnswer, bumped_frames, watcher
from tests.watch.test_ros2 import fake_ros

#: A RealSense driver's static tree: camera_link -> camera_color_frame -> camera_color_optical_frame.
T_LINK_COLOR = make_transform(so3_exp([0.0, 0.0, 0.01]), [0.0, 0.015, 0.0])
T_COLOR_OPTICAL = make_transform(so3_exp(np.pi / 2 * np.array([-1.0, 1.0, -1.0]) / np.sqrt(3)), [0.0, 0.0, 0.0])
T_BASE_CAM = make_transform(so3_exp([0.1, -0.2, 0.3]), [0.9, -0.4, 1.1])


def _transform(parent: str, child: str, T: np.ndarray):
    t, q = pos_quat_xyzw_from_transform(T)
    return SimpleNamespace(
        header=SimpleNamespace(frame_id=parent),
        child_frame_id=child,
        transform=SimpleNamespace(
            translation=SimpleNamespace(x=t[0], y=t[1], z=t[2]),
            rotation=SimpleNamespace(x=q[0], y=q[1], z=q[2], w=q[3]),
        ),
    )


def _matrix(msg) -> np.ndarray:
    from handeye.core.se3 import transform_from_pos_quat_xyzw

    t, r = msg.transform.translation, msg.transform.rotation
    return transform_from_pos_quat_xyzw([t.x, t.y, t.z], [r.x, r.y, r.z, r.w])


def _driver_tree(*extra):
    tree = [
        _transform("camera_link", "camera_color_frame", T_LINK_COLOR),
        _transform("camera_color_frame", "camera_color_optical_frame", T_COLOR_OPTICAL),
    ]
    return [("/tf_static", SimpleNamespace(transforms=tree + list(extra)))]


def _statuses(calls) -> list:
    return [json.loads(c[2].data) for c in calls if c[0] == "publish" and c[1] == STATUS_TOPIC]


def test_a_stale_calibration_is_said_on_the_status_topic_and_in_the_current_json(tmp_path, monkeypatch):
    calls = fake_ros(monkeypatch, [])
    rclpy = sys.modules["rclpy"]
    tf = TfPublisher(rclpy.create_node("handeye_watch"), "base_link", "cam")
    current = tmp_path / "current.json"
    w = watcher(tmp_path, KnownAnswer(), current_path=current, on_commit=[tf], on_stale=[tf.stale])
    tf.publish(w.T_base_cam, w.version)
    seen = []  # (state of each event, the JSON's stale_since, transforms sent so far, statuses so far)
    for f in bumped_frames():
        for e in w.feed(f):
            sent = sum(c[0] == "sendTransform" for c in calls)
            seen.append((e, json.loads(current.read_text())["stale_since"], sent, _statuses(calls)[-1]))
    moved = [s for s in seen if s[0].state == "moved"]
    recal = [s for s in seen if s[0].state == "recalibrated"]
    assert len(moved) == 1 and len(recal) == 1
    e, stale_since, sent, status = moved[0]
    assert stale_since == e.t and e.stale_since == e.t  # the JSON says so from the alarm's frame
    assert sent == 1  # the start's transform only: nothing new on tf while stale
    assert status == {
        "calibration": "stale",
        "stale_since": e.t,
        "version": 1,
        "parent_frame": "base_link",
        "child_frame": "cam",
    }
    e, stale_since, sent, status = recal[0]
    assert stale_since is None and sent == 2 and status["calibration"] == "valid" and status["version"] == 2
    assert [s["calibration"] for s in _statuses(calls)] == ["valid", "stale", "valid"]
    durability = {c[2]: c[3] for c in calls if c[0] == "publisher"}
    assert durability[STATUS_TOPIC] == "transient_local"  # a late subscriber gets the last status


def test_a_camera_frame_with_a_driver_parent_is_reached_through_its_trees_root(tmp_path, monkeypatch, capsys):
    calls = fake_ros(monkeypatch, _driver_tree())
    h = History(tmp_path / "h.jsonl")
    h.append(T_BASE_CAM, "test")
    assert main(["watch", "rollback", "--history", str(h.path), "1", "--publish-tf"]) == 0
    out = capsys.readouterr().out
    assert "published base_link -> camera_link" in out and "camera_color_optical_frame<-camera_color_frame" in out
    (sent,) = [c[1] for c in calls if c[0] == "sendTransform"]
    assert sent.header.frame_id == "base_link" and sent.child_frame_id == "camera_link"
    # the optical frame tf2 computes through the driver's tree is the calibration's
    T_base_optical = _matrix(sent) @ T_LINK_COLOR @ T_COLOR_OPTICAL
    np.testing.assert_allclose(T_base_optical, T_BASE_CAM, atol=FLOAT)


@pytest.mark.parametrize(
    "placement",
    [
        [_transform("base_link", "camera_link", np.eye(4))],  # a URDF joint (or another watcher) places it
        [_transform("world", "base_link", np.eye(4)), _transform("world", "camera_link", np.eye(4))],
    ],
)
def test_a_camera_placed_under_the_base_is_refused_before_the_rollback(tmp_path, monkeypatch, capsys, placement):
    calls = fake_ros(monkeypatch, _driver_tree(*placement))
    h = History(tmp_path / "h.jsonl")
    h.append(T_BASE_CAM, "test")
    assert main(["watch", "rollback", "--history", str(h.path), "1", "--publish-tf"]) == 2
    err = capsys.readouterr().err
    assert "already placed under base_link" in err and "--camera-frame" in err
    assert not [c for c in calls if c[0] == "sendTransform"]
    assert [v.version for v in h.versions()] == [1]  # nothing appended


def test_a_camera_frame_without_a_parent_is_published_as_given(monkeypatch):
    fake_ros(monkeypatch, _driver_tree())
    rclpy = sys.modules["rclpy"]
    rclpy.init()
    tf = TfPublisher(rclpy.create_node("n"), "base_link", "camera_link")
    assert tf.attach(rclpy) == "base_link -> camera_link"
    np.testing.assert_array_equal(tf.T_cam_child, np.eye(4))
