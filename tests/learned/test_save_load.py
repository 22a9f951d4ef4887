"""Saved networks and calibrators reload to identical predictions; mismatches are refused clearly."""

from __future__ import annotations

import numpy as np
import pytest

torch = pytest.importorskip("torch")

from handeye.core.errors import HandEyeInputError  # noqa: E402
from learned.calibrator import ContinualCalibrator  # noqa: E402
from learned.experiment import PRESETS, load_model, save_model  # noqa: E402
from learned.model import CalibrationNet  # noqa: E402
from learned.trainer import TrainConfig, predict, train  # noqa: E402
from tests.learned._synthetic import make_frames  # noqa: E402
from tests.tolerances import ABSOLUTE_ONLY, FLOAT32_ROTATION  # noqa: E402

TINY = PRESETS["tiny"]


@pytest.fixture(scope="module")
def frames():
    return make_frames(
        np.random.default_rng(0),
        regions=((0, 60), (120, 180)),
        train_per_region=3,
        test_per_region=1,
        frames_per_camera=10,
        size=TINY.image_size,
    )


@pytest.mark.parametrize("kind", ["translation", "orientation"])
def test_a_saved_network_reloads_to_identical_predictions(frames, tmp_path, kind):
    model = CalibrationNet(TINY.model_config(kind, (100.0, 200.0, 300.0)))
    train(model, frames, np.arange(len(frames)), TrainConfig(epochs=2, batch_size=16), np.random.default_rng(0))
    save_model(model, tmp_path / "m.pt")
    again = load_model(tmp_path / "m.pt", expect=model.config)
    assert torch.equal(torch.from_numpy(predict(model, frames)), torch.from_numpy(predict(again, frames)))


def test_a_network_with_another_config_is_refused(frames, tmp_path):
    save_model(CalibrationNet(TINY.model_config("translation")), tmp_path / "m.pt")
    other = PRESETS["cpu"].model_config("translation")
    with pytest.raises(HandEyeInputError, match="m.pt: saved with another config.*image_size.*channels"):
        load_model(tmp_path / "m.pt", expect=other)
    with pytest.raises(HandEyeInputError, match="no saved model"):
        load_model(tmp_path / "none.pt")


def _pose_frames(frames, camera):
    return frames.subset(np.flatnonzero(frames.camera == camera))


def test_the_calibrator_keeps_learning_across_a_restart(frames, tmp_path):
    cal = ContinualCalibrator(TINY, seed=0)
    first = cal.observe(frames.subset(np.flatnonzero((frames.region == 0) & (frames.split == "train"))))
    assert first["first"] and first["translation"]["novel"] and first["translation"]["sample_error"] is None
    assert len(cal.memory["translation"]) == 3 * TINY.c1  # c1 samples per camera pose trained on
    new_pose = int(frames.cameras("train")[frames.cameras("train") >= 4][0])
    step = cal.observe(_pose_frames(frames, new_pose))
    assert step["translation"]["sample_error"] is not None
    cal.save(tmp_path / "cell.pt")
    again = ContinualCalibrator.load(tmp_path / "cell.pt", preset=TINY)
    test = _pose_frames(frames, int(frames.cameras("test")[0]))
    np.testing.assert_array_equal(
        cal.predict(test.rgb, test.depth_m, test.pose_base_ref),
        again.predict(test.rgb, test.depth_m, test.pose_base_ref),
    )
    assert again.history == cal.history
    for kind in ("translation", "orientation"):
        np.testing.assert_array_equal(again.memory[kind].rgb, cal.memory[kind].rgb)
    # the same next update on both gives the same model: weights, buffer and random state all survived
    nxt = _pose_frames(frames, int(frames.cameras("train")[-1]))
    a, b = cal.observe(nxt), again.observe(nxt)
    assert a == b
    np.testing.assert_array_equal(
        cal.predict(test.rgb, test.depth_m, test.pose_base_ref),
        again.predict(test.rgb, test.depth_m, test.pose_base_ref),
    )
    T = cal.predict(test.rgb, test.depth_m, test.pose_base_ref)
    assert T.shape == (4, 4)
    assert np.allclose(T[:3, :3] @ T[:3, :3].T, np.eye(3), rtol=ABSOLUTE_ONLY, atol=FLOAT32_ROTATION)


def test_calibrator_input_errors(frames, tmp_path):
    cal = ContinualCalibrator(TINY)
    with pytest.raises(HandEyeInputError, match="not been trained"):
        cal.predict(frames.rgb[:1], frames.depth_m[:1], frames.pose_base_ref[:1])
    cal.observe(frames.subset(np.flatnonzero(frames.region == 0)))
    with pytest.raises(HandEyeInputError, match="one camera pose at a time"):
        cal.observe(frames.subset(np.flatnonzero(frames.region == 1)))
    with pytest.raises(HandEyeInputError, match="images must be 32x32"):
        cal.predict(np.zeros((1, 3, 16, 16), np.uint8), np.zeros((1, 1, 16, 16)), np.zeros((1, 7)))
    cal.save(tmp_path / "cell.pt")
    with pytest.raises(HandEyeInputError, match="saved with preset tiny"):
        ContinualCalibrator.load(tmp_path / "cell.pt", preset="demo")


def test_files_are_read_without_pickle_and_foreign_files_are_refused(tmp_path):
    """Saved files hold tensors and JSON only: a pickled (old or foreign) file is refused, never executed."""
    import pickle

    from learned.safe_io import SavedFileError

    save_model(CalibrationNet(TINY.model_config("translation")), tmp_path / "m.pt")
    torch.load(tmp_path / "m.pt", weights_only=True)  # loads under the safe loader

    class Payload:  # what a malicious file would carry: code run on unpickling
        def __reduce__(self):
            return (open, (str(tmp_path / "pwned"), "w"))

    with (tmp_path / "evil.pt").open("wb") as f:
        pickle.dump({"config": {}, "state_dict": Payload()}, f, protocol=2)
    with pytest.raises(SavedFileError, match="evil.pt: not a handeye model file"):
        load_model(tmp_path / "evil.pt")
    assert not (tmp_path / "pwned").exists()
    # an old-format file (pickled dict, as version 1 wrote it) and a tensor file of someone else's
    torch.save(
        {"config": TINY.model_config("translation").to_dict(), "state_dict": {}, "meta": {"x": np.zeros(2)}},
        tmp_path / "old.pt",
    )
    with pytest.raises(SavedFileError, match="old.pt"):
        load_model(tmp_path / "old.pt")
    torch.save({"weights": torch.zeros(3)}, tmp_path / "other.pt")
    with pytest.raises(SavedFileError, match="other.pt: not a handeye model file"):
        load_model(tmp_path / "other.pt")
    (tmp_path / "garbage.pt").write_bytes(b"\x00\x01garbage")
    with pytest.raises(SavedFileError, match="garbage.pt"):
        ContinualCalibrator.load(tmp_path / "garbage.pt")


@pytest.mark.parametrize("trunk_dtype", ["float32", "bfloat16"])
def test_keypoint_model_reloads_to_identical_predictions(tmp_path, trunk_dtype):
    from dataclasses import replace

    from learned.data import with_keypoints
    from learned.experiment import Preset
    from learned.model import make_network

    frames = make_frames(np.random.default_rng(0), frames_per_camera=3)
    frames = with_keypoints(frames, np.random.default_rng(1).uniform(-0.5, 0.5, (len(frames), 4, 3)))
    # the cameras 1.5 m from the keypoints, which then lie in the image (the residual statistics need them)
    frames = replace(frames, intrinsics_norm=np.tile([1.0, 1.0, 0.5, 0.5], (len(frames), 1)))
    config = replace(Preset("kp", (32, 32), (4, 8)), keypoint_trunk_dtype=trunk_dtype).model_config(
        "keypoints", n_keypoints=4
    )
    assert config.trunk_dtype == trunk_dtype
    model = make_network(config)
    train(model, frames, np.arange(len(frames)), TrainConfig(epochs=1, batch_size=8), np.random.default_rng(2))
    save_model(model, tmp_path / "kp.pt")
    again = load_model(tmp_path / "kp.pt", expect=config)
    np.testing.assert_array_equal(predict(model, frames), predict(again, frames))
    # training measured the residuals on its frames; they travel with the weights
    from learned.keypoints import model_residual_stats

    assert model_residual_stats(model) is not None
    np.testing.assert_array_equal(model_residual_stats(again), model_residual_stats(model))
    assert predict(again, frames).shape == (len(frames), 4, 3)
