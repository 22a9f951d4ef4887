"""A ROS 2 bag replayed into the watcher: the frames the import's reader gives (depth, joints at their stamps,
colour), the same events as the frames fed directly, paced at the recorded rate, and ``handeye watch BAG``."""

from __future__ import annotations

import json

import numpy as np
import pytest

pytest.importorskip("rosbags")

from handeye.cli import main  # noqa: E402
from handeye.watch.source import BagTopics, Frame, bag_frames, paced  # noqa: E402
from tests.classic.test_markerless import H, K, W  # noqa: E402
from tests.test_import_checks import MSG, _header, _image, _info, _write_messages  # noqa: E402
from tests.tolerances import EXACT  # noqa: E402
from tests.watch.cell_streams import T_TRUE, KnownAnswer, bumped_frames, watcher  # noqa: E402
from tests.watch.test_cell import RATE_HZ, Spheres  # noqa: E402

TOPICS = BagTopics()
#: The spheres' "joints": nine coordinates, named in the bag in another order than the model's.
NAMES = [f"c{i}" for i in range(9)]
EPOCH_NS = 1_700_000_000 * 10**9
#: Half a nanosecond per frame: the stamps are whole nanoseconds of i / RATE_HZ s.
STAMP_S = 1e-9


def write_stream_bag(path, frames, storage="sqlite3", joints_for=None):
    """A bag of the frames: 32FC1 depth, rgb8 colour, camera_info and joint states (reversed names), each
    stamped at the frame's time; joint states only for the frames ``joints_for`` (default all)."""
    messages = []
    for f in frames:
        s = EPOCH_NS + round(f.t * 1e9)
        messages += [
            (TOPICS.depth, "sensor_msgs/msg/Image", s, _image(s, "32FC1", f.depth_m.astype(np.float32))),
            (TOPICS.color, "sensor_msgs/msg/Image", s, _image(s, "rgb8", f.rgb)),
            (TOPICS.info, "sensor_msgs/msg/CameraInfo", s, _info(s, K, W, H)),
        ]
        if joints_for is None or f.index in joints_for:
            q = np.ascontiguousarray(np.asarray(f.joints, float)[::-1])
            state = MSG["sensor_msgs/msg/JointState"](_header(s, ""), NAMES[::-1], q, np.zeros(0), np.zeros(0))
            messages.append((TOPICS.joints, "sensor_msgs/msg/JointState", s, state))
    return _write_messages(path, messages, storage)


@pytest.mark.parametrize("storage", ["sqlite3", "mcap"])
def test_a_bag_gives_the_frames_it_was_written_from(tmp_path, storage):
    """Depth (32FC1: exact), colour, the joints in the model's order, times from the bag's start; the last frame
    has no joint state after it within the tolerance, so it is left out and counted."""
    frames = bumped_frames(n=5)
    bag = write_stream_bag(tmp_path / "bag", frames, storage, joints_for=range(4))
    stream = bag_frames(bag, NAMES, TOPICS)
    assert stream.dropped == 1 and len(stream.frames) == 4
    np.testing.assert_allclose(stream.K, K, atol=EXACT)
    assert stream.size == (W, H)
    for got, want in zip(stream.frames, frames):
        np.testing.assert_array_equal(got.depth_m, want.depth_m.astype(np.float32))
        np.testing.assert_array_equal(got.rgb, want.rgb)
        np.testing.assert_allclose(got.joints, want.joints, atol=EXACT)
        assert got.t == pytest.approx(want.t, abs=STAMP_S) and got.index == want.index


def test_a_replayed_bag_gives_the_events_of_the_frames_fed_directly(tmp_path):
    """One code path: the bumped stream through a bag and through feed() directly, the same event lines (a bag
    that lost the depth's unit or the joints' order would be "lost" or never "moved")."""
    frames = bumped_frames()
    bag = write_stream_bag(tmp_path / "bag", frames)
    direct = watcher(tmp_path / "direct", KnownAnswer())
    replay = watcher(tmp_path / "replay", KnownAnswer())
    want = [e.line() for f in frames for e in direct.feed(f)]
    got = [e.line() for f in bag_frames(bag, NAMES, TOPICS).frames for e in replay.feed(f)]
    assert got == want
    assert [ln.split(" ")[1] for ln in want] == ["ok", "moved", "recalibrated", "learning"]


def test_paced_replays_at_the_recorded_rate_and_never_waits_twice():
    now = [100.0]
    waits = []

    def sleep(s):
        waits.append(s)
        now[0] += s

    frames = [Frame(t, np.zeros((1, 1)), np.zeros(1), i) for i, t in enumerate([5.0, 5.1, 5.3, 5.4])]
    out = []
    for f in paced(frames, clock=lambda: now[0], sleep=sleep):
        out.append((f.index, now[0]))
        if f.index == 1:
            now[0] += 0.25  # a slow check: frame 2 is due at 100.3, it is 100.35 already
    np.testing.assert_allclose([t for _, t in out], [100.0, 100.1, 100.35, 100.4])
    np.testing.assert_allclose(waits, [0.1, 0.05])
    with pytest.raises(ValueError, match="speed"):
        next(paced(frames, speed=0))


def test_watch_replays_a_bag_from_the_command_line(tmp_path, capsys, monkeypatch):
    """``handeye watch BAG --fast``: the spheres stand in for the robot model and its surface."""
    import handeye.commands.watch_sources as sources

    class Model:
        names = ["universe", *NAMES]

    monkeypatch.setattr(sources, "robot_model", lambda args: type("R", (), {"model": Model, "fk_ref": None})())
    monkeypatch.setattr(sources, "_surface", lambda robot, K, width: (Spheres(), 1))
    bag = write_stream_bag(tmp_path / "bag", bumped_frames(n=70))
    start = tmp_path / "start.json"
    start.write_text(json.dumps({"T_base_cam": T_TRUE.tolist()}))
    history = tmp_path / "h.jsonl"
    args = ["watch", str(bag), "--fast", "--sensor", "ideal", "--camera-start", str(start), "--history", str(history)]
    assert main([*args, "--null-seconds", str(60 / RATE_HZ)]) == 0
    out = capsys.readouterr().out
    assert "ok (was learning)" in out and "moved" not in out, out
    assert "70 frames" in out
    assert main(["watch", str(bag), "--truth-start", "--sensor", "ideal"]) == 2
    assert "--truth-start is for simulated datasets" in capsys.readouterr().err
    assert main(["watch", str(bag), "--camera-start", str(start)]) == 2
    assert "give --sensor" in capsys.readouterr().err
    assert main(["watch", "--sensor", "ideal"]) == 2
    assert "nothing to watch" in capsys.readouterr().err
