"""The simulated running cell (sim.stream): the written dataset holds the events at their stated times.

One small stream is rendered once (40 frames of 96 x 96 at 2 Hz through the d435 profile) and read back with
:class:`handeye.core.dataset.Dataset`, the way a watcher replays it; the checks compare what was written
with the preset's stated events, never with the generator's own bookkeeping alone.
"""

from __future__ import annotations

import numpy as np
import pytest

from handeye.core.errors import HandEyeInputError
from handeye.core.se3 import invert_transform, rotation_angle
from sim.stream_events import Bump, Drift, Dropout, Lighting, Occlusion, StreamPreset, get_stream_preset

#: Poses go through cameras.csv as repr floats (17 significant digits) and unit quaternions: the round trip is
#: exact to about 1e-15 m and rad; 1e-9 leaves room for the quaternion's normalisation and nothing else.
ROUND_TRIP = 1e-9
#: The occluder stands at half the camera-to-tool distance, its surface at most its radius nearer; the depth
#: at the tool's pixel is then at most half the tool's depth plus this margin: the d435's noise at 0.6 m
#: (a few mm, 3 sigma under 1 cm) and the tool's reference point lying up to 5 cm inside the tool.
OCCLUDED_MARGIN_M = 0.06
#: The lights at 0.4 scale every lit pixel's value by 0.4 (clipped values aside); with the background colour
#: unlit, a mean drop of at least 20 % is certain as long as lit pixels make up over a third of the image's
#: brightness, as the floor and arm filling the view make them.
LIGHT_DROP = 0.8

PRESET = StreamPreset(
    "test",
    minutes=20.0 / 60.0,
    rate_hz=2.0,
    image_size=(96, 96),
    bumps=(Bump(5.0, 20.0, 2.0), Bump(17.2, 200.0, 20.0, "remount")),
    occlusions=(Occlusion(9.0, 3.0, "person"),),
    lighting=(Lighting(13.0, 0.4, duration_s=2.0),),
    dropouts=(Dropout(15.0, 1.5),),
    drift=Drift(rate_mm_per_min=0.1, step_s=8.0),
)


@pytest.fixture(scope="module")
def stream(tmp_path_factory):
    pytest.importorskip("pyrender")
    pytest.importorskip("pinocchio")
    from handeye.core.dataset import Dataset
    from sim.stream import generate_stream, read_stream

    out = tmp_path_factory.mktemp("stream") / "cell"
    generate_stream(out, PRESET, seed=3, sensor="d435", workers=1, progress=False)
    return Dataset.open(out), read_stream(out)


def _frames(ds):
    tables = [ds.select(c, "data") for c in range(len(ds))]
    return {k: np.concatenate([t[k] for t in tables]) for k in tables[0]}


def _segment(doc, k):
    """The segment (camera id) holding frame ``k``."""
    return next(s["camera"] for s in doc["segments"] if s["first_frame"] <= k < s["first_frame"] + s["frames"])


def _events(doc, kind):
    return [e for e in doc["events"] if e["type"] == kind]


def test_dataset_opens_validates_and_frames_run_in_time_order(stream):
    ds, doc = stream
    ds.validate(images=True)
    frames = _frames(ds)
    assert np.array_equal(frames["frame"], np.arange(PRESET.n_frames))
    assert doc["rate_hz"] == PRESET.rate_hz and doc["frames"] == PRESET.n_frames == 40
    for seg in doc["segments"]:
        shard = ds.select(seg["camera"], "data")
        assert shard["frame"][0] == seg["first_frame"] and len(shard["frame"]) == seg["frames"]
        assert seg["start_s"] == seg["first_frame"] / PRESET.rate_hz
        assert "camera_id" not in seg and "t0_s" not in seg  # one name each


def test_events_take_effect_at_the_first_frame_at_or_after_their_stated_time(stream):
    _, doc = stream
    rate = PRESET.rate_hz
    stated = {
        "bump": [b.t_s for b in PRESET.bumps],
        "drift": [8.0, 16.0],
        "occlusion_start": [9.0],
        "occlusion_end": [12.0],
        "lighting": [13.0, 15.0],
        "dropout": [15.0],
    }
    for kind, times in stated.items():
        got = [e["frame"] for e in _events(doc, kind)]
        assert got == [int(np.ceil(t * rate)) for t in times], kind
        assert all(e["t_s"] == e["frame"] / rate for e in _events(doc, kind))
    assert _events(doc, "bump")[1]["frame"] == 35  # 17.2 s at 2 Hz: the frame at 17.5 s
    # every camera change starts a segment, and only those
    changes = sorted(e["frame"] for e in doc["events"] if e["type"] in ("bump", "drift"))
    assert [s["first_frame"] for s in doc["segments"]] == [0] + changes


def test_truth_per_segment_differs_by_the_stated_bump_and_drift(stream):
    ds, doc = stream
    T = ds.truth()
    for e in _events(doc, "bump") + _events(doc, "drift"):
        s = e["segment"]
        dT = invert_transform(T[s - 1]) @ T[s]
        if e["type"] == "bump":  # a motion in the camera frame of the stated sizes
            assert np.linalg.norm(dT[:3, 3]) == pytest.approx(e["translation_mm"] * 1e-3, abs=ROUND_TRIP)
            assert rotation_angle(dT[:3, :3]) == pytest.approx(np.radians(e["rotation_deg"]), abs=ROUND_TRIP)
        else:  # a translation along the base frame's up, 0.1 mm/min times the 8 s step
            assert rotation_angle(dT[:3, :3]) < ROUND_TRIP
            step = T[s][:3, 3] - T[s - 1][:3, 3]
            assert np.allclose(step, [0.0, 0.0, 0.1e-3 * 8.0 / 60.0], atol=ROUND_TRIP)


def test_an_occlusion_hides_the_tool_in_its_middle_frame(stream):
    ds, doc = stream
    frames = _frames(ds)
    T = ds.truth()
    K = np.array(ds.meta["intrinsics"]["K"])
    occlusion = doc["occlusions"][0]

    def depth_at_tool(k):
        """The measured depth at the tool reference's pixel (median of the valid 5 x 5) and the tool's depth."""
        camera = _segment(doc, k)
        p_cam = invert_transform(T[camera]) @ ds.poses({c: v[k : k + 1] for c, v in frames.items()}, "T_base_ref")[0]
        u, v = np.rint(K[:2, :2] @ (p_cam[:2, 3] / p_cam[2, 3]) + K[:2, 2]).astype(int)
        depth = ds.depth_m(camera, frames["depth"][k])[v - 2 : v + 3, u - 2 : u + 3]
        return np.median(depth[depth > 0]), p_cam[2, 3]

    measured, tool = depth_at_tool(occlusion["mid_frame"])
    assert measured < 0.5 * tool + OCCLUDED_MARGIN_M
    measured, tool = depth_at_tool(occlusion["first_frame"] - 1)  # before it: nothing half-way
    assert measured > 0.5 * tool + OCCLUDED_MARGIN_M
    assert occlusion["arm_hidden_fraction"][occlusion["mid_frame"] - occlusion["first_frame"]] > 0


def test_dropout_frames_have_no_depth_and_the_others_do(stream):
    ds, doc = stream
    frames = _frames(ds)
    (dropout,) = _events(doc, "dropout")
    lost = np.zeros(PRESET.n_frames, bool)
    lost[30:33] = True  # 15.0 s to 16.5 s at 2 Hz
    assert (dropout["frame"], dropout["end_frame"]) == (30, 33)
    assert np.array_equal(frames["depth"] == "", lost)


def test_the_lights_dim_in_the_written_colour(stream):
    ds, doc = stream
    frames = _frames(ds)
    dim, restored = _events(doc, "lighting")
    assert (dim["factor"], restored["factor"]) == (0.4, 1.0)

    def brightness(k):
        return ds.rgb(_segment(doc, k), frames["rgb"][k]).mean()

    assert brightness(dim["frame"]) < LIGHT_DROP * brightness(dim["frame"] - 1)
    assert brightness(restored["frame"]) > brightness(restored["frame"] - 1) / LIGHT_DROP


def test_the_sensor_truth_is_one_unit_in_every_segment(stream):
    from handeye.robot.depth_sensors import PROFILES
    from sim.sensors import draw_systematic

    ds, _ = stream
    cams = ds.cameras()
    truth = draw_systematic(PROFILES["d435"], 3, 0)
    assert np.all(cams["depth_scale_true"] == truth.scale)
    assert ds.meta["recipe"]["generator"] == "handeye sim stream"


# ------------------------------------------------------------------ the timeline alone (no rendering)


def test_colliding_events_are_refused():
    pytest.importorskip("pinocchio")
    from handeye.robot.model import load_robot
    from sim.stream_timeline import build_timeline

    robot = load_robot("ur5")
    small = dict(minutes=0.2, rate_hz=2.0, image_size=(64, 64))
    with pytest.raises(HandEyeInputError, match="drift step"):
        build_timeline(StreamPreset("x", bumps=(Bump(5.0, 1.0, 0.1),), drift=Drift(step_s=5.0), **small), 0, robot)
    with pytest.raises(HandEyeInputError, match="overlap"):
        build_timeline(
            StreamPreset("x", occlusions=(Occlusion(1.0, 3.0), Occlusion(2.0, 1.0, "box")), **small), 0, robot
        )
    with pytest.raises(HandEyeInputError, match="two bumps"):
        build_timeline(StreamPreset("x", bumps=(Bump(1.1, 1.0, 0.1), Bump(1.4, 2.0, 0.1)), **small), 0, robot)


def test_repeated_events_repeat_until_the_end():
    pytest.importorskip("pinocchio")
    from handeye.robot.model import load_robot
    from sim.stream_timeline import build_timeline

    preset = get_stream_preset("static")
    timeline = build_timeline(preset, 0, load_robot(preset.robot))
    starts = [e["t_s"] for e in timeline.events if e["type"] == "occlusion_start"]
    # persons at 10 + 40 k, boxes at 26 + 60 k, within 180 s
    assert starts == sorted([10.0, 50.0, 90.0, 130.0, 170.0, 26.0, 86.0, 146.0])
    assert len(timeline.T_base_cam) == 1  # static: one segment
    assert timeline.light.min() == 0.4 and timeline.depth_lost.sum() == 3 * 5  # dropouts of 1 s at 44, 94, 144 s


def test_bad_presets_are_refused():
    with pytest.raises(HandEyeInputError, match="shape"):
        Occlusion(1.0, 2.0, "ghost")
    with pytest.raises(HandEyeInputError, match="image_size"):
        StreamPreset("x", image_size=(8, 8))
    with pytest.raises(HandEyeInputError, match="unknown stream preset"):
        get_stream_preset("nope")


def test_an_out_folder_that_cannot_hold_a_new_stream_is_refused(tmp_path):
    """A non-empty folder, a file, a folder under a file: refused, naming why, before anything is rendered."""
    from handeye.core.errors import DatasetError
    from sim.stream import generate_stream

    (tmp_path / "full").mkdir()
    (tmp_path / "full" / "keep.txt").write_text("mine")
    (tmp_path / "file").write_text("mine")
    cases = (("full", "not an empty folder"), ("file", "not a directory"), ("file/cell", "is a file"))
    for out, reason in cases:
        with pytest.raises(DatasetError, match=reason):
            generate_stream(tmp_path / out, PRESET, progress=False)
    assert (tmp_path / "full" / "keep.txt").read_text() == (tmp_path / "file").read_text() == "mine"


@pytest.mark.parametrize("size", ["96", "96x96x3", "9_6x96", "\uff19\uff16x96", "ninety-sixx96"])
def test_cli_size_is_two_integers_in_the_number_grammar(size, tmp_path, capsys):
    """--size WIDTHxHEIGHT reads each side as handeye.core.numbers does (int() took '9_6' and full-width
    digits as 96); refused in one line before anything is written."""
    pytest.importorskip("pyrender")
    from handeye.cli import main

    out = tmp_path / "cell"
    assert main(["sim", "stream", "--preset", "smoke", "--out", str(out), "--size", size, "--quiet"]) == 2
    assert capsys.readouterr().err.count("\n") == 1 and not out.exists()
