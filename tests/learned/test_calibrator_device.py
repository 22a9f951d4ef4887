"""The online calibrator trains where the experiment does: CUDA when available, else the CPU."""

from __future__ import annotations

import numpy as np
import pytest

torch = pytest.importorskip("torch")

from learned.calibrator import ContinualCalibrator  # noqa: E402
from learned.presets import PRESETS  # noqa: E402
from learned.trainer import default_device  # noqa: E402
from tests.learned._synthetic import make_frames  # noqa: E402
from tests.tolerances import ABSOLUTE_ONLY, DEVICE_PREDICTION_ATOL  # noqa: E402

TINY = PRESETS["tiny"]


@pytest.fixture(scope="module")
def frames():
    return make_frames(
        np.random.default_rng(0),
        regions=((0, 60), (120, 180)),
        train_per_region=2,
        test_per_region=1,
        frames_per_camera=8,
        size=TINY.image_size,
    )


def _observe_two(cal, frames):
    cal.observe(frames.subset(np.flatnonzero((frames.region == 0) & (frames.split == "train"))))
    cal.observe(frames.subset(np.flatnonzero(frames.camera == int(frames.cameras("train")[-1]))))


def test_the_device_follows_the_trainers_rule(frames, monkeypatch):
    assert ContinualCalibrator(TINY).device == default_device()
    monkeypatch.setattr(torch.cuda, "is_available", lambda: True)
    assert ContinualCalibrator(TINY).device == torch.device("cuda")
    monkeypatch.setattr(torch.cuda, "is_available", lambda: False)
    cal = ContinualCalibrator(TINY)
    assert cal.device == torch.device("cpu")
    _observe_two(cal, frames)
    assert {p.device for m in cal.models.values() for p in m.parameters()} == {torch.device("cpu")}


@pytest.mark.skipif(not torch.cuda.is_available(), reason="needs a CUDA device (the calibrator trains on it)")
def test_the_calibrator_trains_on_the_gpu_and_reloads_anywhere(frames, tmp_path, monkeypatch):
    # float32 on both devices (cuDNN's default TF32 rounds a convolution's operands to 10 mantissa bits)
    monkeypatch.setattr(torch.backends.cudnn, "allow_tf32", False)
    monkeypatch.setattr(torch.backends.cuda.matmul, "allow_tf32", False)
    cal = ContinualCalibrator(TINY)
    assert cal.device.type == "cuda"
    _observe_two(cal, frames)
    assert all(p.is_cuda for m in cal.models.values() for p in m.parameters())
    test = frames.subset(np.flatnonzero(frames.camera == int(frames.cameras("test")[0])))
    T = cal.predict(test.rgb, test.depth_m, test.pose_base_ref)
    cal.save(tmp_path / "cell.pt")
    np.testing.assert_array_equal(
        ContinualCalibrator.load(tmp_path / "cell.pt").predict(test.rgb, test.depth_m, test.pose_base_ref), T
    )
    on_cpu = ContinualCalibrator.load(tmp_path / "cell.pt", device="cpu")
    T_cpu = on_cpu.predict(test.rgb, test.depth_m, test.pose_base_ref)
    np.testing.assert_allclose(T_cpu, T, atol=DEVICE_PREDICTION_ATOL, rtol=ABSOLUTE_ONLY)
