"""The watcher's sources refuse images of another size than their camera_info, as the import does: a depth
stream not registered to that camera (a RealSense's raw depth beside the colour camera_info) would be checked
with the wrong camera matrix, every pixel's ray wrong, and read as a moved camera or a wrong recalibration."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("rosbags")

from handeye.core.errors import HandEyeInputError, ImageSizeError  # noqa: E402
from handeye.watch.ros2 import Ros2Frames  # noqa: E402
from handeye.watch.source import bag_frames  # noqa: E402
from tests.watch.cell_streams import bumped_frames  # noqa: E402
from tests.watch.test_bag_replay import NAMES, TOPICS, write_stream_bag  # noqa: E402
from tests.watch.test_ros2 import TOPICS as LIVE  # noqa: E402
from tests.watch.test_ros2 import _image, _info, _joints, fake_ros  # noqa: E402


def _cropped(frames, depth=True, colour=False):
    """The frames with the depth (and/or colour) one row and one column short of the camera_info's size."""
    for f in frames:
        if depth:
            f.depth_m = np.ascontiguousarray(f.depth_m[:-1, :-1])
        if colour:
            f.rgb = np.ascontiguousarray(f.rgb[:-1, :-1])
    return frames


@pytest.mark.parametrize("what", ["depth", "colour"])
def test_a_bag_with_images_of_another_size_than_its_camera_info_is_refused(tmp_path, what):
    frames = _cropped(bumped_frames(n=3), depth=what == "depth", colour=what == "colour")
    bag = write_stream_bag(tmp_path / "bag", frames)
    with pytest.raises(ImageSizeError, match="the camera_info is for"):
        bag_frames(bag, NAMES, TOPICS)


def test_a_live_depth_image_of_another_size_than_the_camera_info_is_refused(monkeypatch):
    (f,) = _cropped(bumped_frames(n=1))
    fake_ros(monkeypatch, [(LIVE.info, _info(0.0)), (LIVE.joints, _joints(f.t, f.joints)), (LIVE.depth, None)])
    live = Ros2Frames(NAMES, LIVE)
    live.wait_for_camera_info()
    msg = _image(f.t, f.depth_m)
    msg.height, msg.width, msg.step = f.depth_m.shape[0], f.depth_m.shape[1], 2 * f.depth_m.shape[1]
    live.rclpy.spin_once(live.node)  # the joint state
    with pytest.raises(ImageSizeError, match="the camera_info is for"):
        live.node.subscriptions[LIVE.depth](msg)


def test_a_live_camera_info_that_changes_is_refused(monkeypatch):
    """The watcher keeps the first camera_info's K: a later, different one (the driver restarted with another
    profile) would leave it checking the new images with the old K."""
    other = _info(1.0)
    other.k = other.k + np.array([0, 0, 2.0, 0, 0, 0, 0, 0, 0])  # the principal point 2 px over
    fake_ros(monkeypatch, [(LIVE.info, _info(0.0)), (LIVE.info, _info(0.5)), (LIVE.info, other)])
    live = Ros2Frames(NAMES, LIVE)
    live.wait_for_camera_info()
    live.rclpy.spin_once(live.node)  # the same camera_info again: taken
    with pytest.raises(HandEyeInputError, match="camera_info changed"):
        live.rclpy.spin_once(live.node)
