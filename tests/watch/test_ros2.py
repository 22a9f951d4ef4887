"""The live ROS 2 source and the static transform, against a fake ``rclpy``/``tf2_ros`` that records the calls
(rclpy comes with ROS 2, not from pip: this is the code path, not a real ROS 2); and the refusal without rclpy."""

from __future__ import annotations

import json
import sys
from types import ModuleType, SimpleNamespace

import numpy as np
import pytest

from handeye.cli import main
from handeye.core.errors import HandEyeInputError
from handeye.core.se3 import pos_quat_xyzw_from_transform
from handeye.watch.ros2 import Ros2Frames, Ros2Topics, TfPublisher, require_rclpy
from tests.classic.test_markerless import H, K, W
from tests.tolerances import EXACT, FLOAT32_RTOL, ROS_STAMP_S
from tests.watch.cell_streams import T_BUMPED, KnownAnswer, bumped_frames, watcher

NAMES = [f"c{i}" for i in range(9)]
TOPICS = Ros2Topics()
#: The depth image's stamps: a second and a bit, so that the times are relative to the first.
EPOCH_S = 1_700_000_000


def _header(t: float, frame: str = ""):
    sec = EPOCH_S + int(np.floor(t))
    return SimpleNamespace(stamp=SimpleNamespace(sec=sec, nanosec=round((t - np.floor(t)) * 1e9)), frame_id=frame)


def _image(t: float, depth_m: np.ndarray):
    mm = np.round(depth_m * 1e3).astype("<u2")
    return SimpleNamespace(
        header=_header(t), height=H, width=W, encoding="16UC1", is_bigendian=0, step=2 * W, data=mm.view(np.uint8)
    )


def _colour(t: float, rgb: np.ndarray):
    return SimpleNamespace(
        header=_header(t), height=H, width=W, encoding="rgb8", is_bigendian=0, step=3 * W, data=rgb.reshape(-1)
    )


def _info(t: float, d=(0.0,) * 5):
    return SimpleNamespace(header=_header(t), width=W, height=H, k=K.reshape(-1), d=list(d))


def _joints(t: float, q):
    return SimpleNamespace(header=_header(t), name=NAMES[::-1], position=list(np.asarray(q)[::-1]))


class FakeNode:
    def __init__(self, name, calls):
        self.name, self.calls, self.subscriptions = name, calls, {}
        self._now = 0

    def create_subscription(self, msg_type, topic, callback, qos):
        self.calls.append(("subscribe", msg_type.__name__, topic))
        self.subscriptions[topic] = callback

    def get_clock(self):
        node = self

        class Clock:
            def now(self):
                node._now += 10**8
                return SimpleNamespace(nanoseconds=node._now, to_msg=lambda: SimpleNamespace(sec=node._now))

        return Clock()

    def create_publisher(self, msg_type, topic, qos):
        calls = self.calls

        class Publisher:
            def publish(self, msg):
                calls.append(("publish", topic, msg))

        self.calls.append(("publisher", msg_type.__name__, topic, qos.durability))
        return Publisher()

    def destroy_node(self):
        self.calls.append(("destroy_node", self.name))


def fake_ros(monkeypatch, script):
    """Fake rclpy, sensor_msgs, geometry_msgs and tf2_ros in sys.modules; ``spin_once`` delivers the next
    ``(topic, message)`` of ``script`` to its subscriber, and ROS 2 is shut down when the script is done."""
    calls, state = [], {"ok": False, "script": list(script), "nodes": []}
    rclpy = ModuleType("rclpy")
    rclpy.ok = lambda: state["ok"]
    rclpy.init = lambda: (calls.append(("init",)), state.update(ok=True))
    rclpy.shutdown = lambda: (calls.append(("shutdown",)), state.update(ok=False))

    def create_node(name):
        state["nodes"].append(FakeNode(name, calls))
        return state["nodes"][-1]

    def spin_once(node, timeout_sec=None):
        if not state["script"]:
            state["ok"] = False
            return
        topic, msg = state["script"].pop(0)
        node.subscriptions[topic](msg)

    rclpy.create_node, rclpy.spin_once = create_node, spin_once
    sensor_msgs, msg = ModuleType("sensor_msgs"), ModuleType("sensor_msgs.msg")
    msg.Image, msg.CameraInfo, msg.JointState = (type(n, (), {}) for n in ("Image", "CameraInfo", "JointState"))
    sensor_msgs.msg = msg
    geometry, geometry_msg = ModuleType("geometry_msgs"), ModuleType("geometry_msgs.msg")

    def transform_stamped():
        xyz = SimpleNamespace(x=0.0, y=0.0, z=0.0)
        return SimpleNamespace(
            header=SimpleNamespace(stamp=None, frame_id=""),
            child_frame_id="",
            transform=SimpleNamespace(translation=xyz, rotation=SimpleNamespace(x=0.0, y=0.0, z=0.0, w=1.0)),
        )

    geometry_msg.TransformStamped = transform_stamped
    geometry.msg = geometry_msg
    tf2 = ModuleType("tf2_ros")

    class StaticTransformBroadcaster:
        def __init__(self, node):
            self.node = node

        def sendTransform(self, m):  # noqa: N802 (tf2_ros's name)
            calls.append(("sendTransform", m))

    tf2.StaticTransformBroadcaster = StaticTransformBroadcaster
    qos = ModuleType("rclpy.qos")
    qos.DurabilityPolicy = SimpleNamespace(TRANSIENT_LOCAL="transient_local", VOLATILE="volatile")
    qos.QoSProfile = lambda depth, durability: SimpleNamespace(depth=depth, durability=durability)
    rclpy.qos = qos
    std_msgs, std_msg = ModuleType("std_msgs"), ModuleType("std_msgs.msg")
    std_msg.String = type("String", (), {"data": ""})
    std_msgs.msg = std_msg
    tf2_msgs, tf2_msg = ModuleType("tf2_msgs"), ModuleType("tf2_msgs.msg")
    tf2_msg.TFMessage = type("TFMessage", (), {})
    tf2_msgs.msg = tf2_msg
    modules = {"rclpy": rclpy, "sensor_msgs": sensor_msgs, "sensor_msgs.msg": msg, "geometry_msgs": geometry}
    modules.update({"geometry_msgs.msg": geometry_msg, "tf2_ros": tf2, "rclpy.qos": qos})
    modules.update({"std_msgs": std_msgs, "std_msgs.msg": std_msg, "tf2_msgs": tf2_msgs, "tf2_msgs.msg": tf2_msg})
    for name, module in modules.items():
        monkeypatch.setitem(sys.modules, name, module)
    return calls


def _script(frames):
    """camera_info once, then per frame its joint state, colour and depth image (one before any camera_info: left
    out; one without a joint state within the tolerance: left out)."""
    out = [(TOPICS.depth, _image(0.0, frames[0].depth_m)), (TOPICS.info, _info(0.0))]
    for f in frames:
        out += [(TOPICS.joints, _joints(f.t, f.joints)), (TOPICS.color, _colour(f.t, f.rgb))]
        out.append((TOPICS.depth, _image(f.t, f.depth_m)))
    out.append((TOPICS.depth, _image(frames[-1].t + 1.0, frames[-1].depth_m)))
    return out


def test_live_frames_come_from_the_topics(monkeypatch):
    frames = bumped_frames(n=4)
    calls = fake_ros(monkeypatch, _script(frames))
    live = Ros2Frames(NAMES, TOPICS)
    np.testing.assert_allclose(live.wait_for_camera_info(), K, atol=EXACT)
    got = list(live)
    live.close()
    assert [c[1:] for c in calls if c[0] == "subscribe"] == [
        ("CameraInfo", TOPICS.info),
        ("JointState", TOPICS.joints),
        ("Image", TOPICS.depth),
        ("Image", TOPICS.color),
    ]
    assert ("destroy_node", "handeye_watch") in calls
    assert live.dropped == {"no camera_info yet": 1, "no joints within the tolerance": 1}
    assert len(got) == len(frames)
    for g, f in zip(got, frames):
        np.testing.assert_allclose(g.joints, f.joints, atol=EXACT)  # reordered to the model's names
        np.testing.assert_allclose(g.depth_m, np.round(f.depth_m * 1e3) * 1e-3, rtol=FLOAT32_RTOL)  # 16-bit mm to m
        assert g.t == pytest.approx(f.t - frames[0].t, abs=ROS_STAMP_S)
        np.testing.assert_array_equal(g.rgb, f.rgb)


def test_a_distorted_camera_info_is_refused(monkeypatch):
    fake_ros(monkeypatch, [(TOPICS.info, _info(0.0, d=(0.1, 0, 0, 0, 0)))])
    with pytest.raises(HandEyeInputError, match="rectified depth"):
        Ros2Frames(NAMES, TOPICS).wait_for_camera_info()


def test_each_commit_is_published_as_a_static_transform(tmp_path, monkeypatch):
    """The live frames through feed(): the bump is committed and T_base_cam sent as base -> camera."""
    frames = bumped_frames()
    calls = fake_ros(monkeypatch, _script(frames))
    live = Ros2Frames(NAMES, TOPICS)
    live.wait_for_camera_info()
    tf = TfPublisher(live.node, "base_link", "cam")
    w = watcher(tmp_path, KnownAnswer(), on_commit=[tf])
    states = [e.state for f in live for e in w.feed(f)]
    assert "recalibrated" in states
    sent = [c[1] for c in calls if c[0] == "sendTransform"]
    assert len(sent) == 1 and sent[0].header.frame_id == "base_link" and sent[0].child_frame_id == "cam"
    t, q = pos_quat_xyzw_from_transform(T_BUMPED)
    tr, rot = sent[0].transform.translation, sent[0].transform.rotation
    np.testing.assert_allclose([tr.x, tr.y, tr.z], t, atol=EXACT)
    np.testing.assert_allclose([rot.x, rot.y, rot.z, rot.w], q, atol=EXACT)


def test_rollback_publishes_the_version_it_restores(tmp_path, capsys, monkeypatch):
    from handeye.core.se3 import make_transform
    from handeye.watch import History

    calls = fake_ros(monkeypatch, [])
    h = History(tmp_path / "h.jsonl")
    h.append(make_transform(np.eye(3), [1.0, 2.0, 3.0]), "test")
    h.append(np.eye(4), "test")
    assert main(["watch", "rollback", "--history", str(h.path), "1", "--publish-tf", "--camera-frame", "cam"]) == 0
    assert "published base_link -> cam" in capsys.readouterr().out
    sent = [c[1] for c in calls if c[0] == "sendTransform"]
    tr = sent[0].transform.translation
    assert len(sent) == 1 and [tr.x, tr.y, tr.z] == [1.0, 2.0, 3.0]


def test_without_rclpy_watch_ros2_says_how_to_get_it(tmp_path, capsys, monkeypatch):
    monkeypatch.setitem(sys.modules, "rclpy", None)  # an import of it raises ImportError
    with pytest.raises(HandEyeInputError, match="needs rclpy.*source /opt/ros"):
        require_rclpy()
    start = tmp_path / "start.json"
    start.write_text(json.dumps({"T_base_cam": np.eye(4).tolist()}))
    assert main(["watch", "--ros2", "--sensor", "d435", "--camera-start", str(start)]) == 2
    err = capsys.readouterr().err
    assert "needs rclpy" in err and "source /opt/ros/<distro>/setup.bash" in err
