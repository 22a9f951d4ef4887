"""The training path built for an accelerator, run on the CPU: frames resident on the device and shifted
there, the regression networks' bfloat16 encoders, and the ``torch.compile`` flag."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from learned.data import with_keypoints
from learned.device_data import DeviceFrames, shift_batch, shift_target_batch
from learned.keypoints import shift_images, shift_targets
from learned.model import CalibrationNet, ModelConfig
from learned.trainer import TrainConfig, train
from tests.learned._synthetic import make_frames
from tests.tolerances import BF16_ENCODER_RTOL


@pytest.fixture(scope="module")
def frames():
    rng = np.random.default_rng(0)
    frames = make_frames(rng, train_per_region=2, test_per_region=1, frames_per_camera=4, size=(32, 32))
    n = len(frames)
    frames.intrinsics_norm = np.tile(np.array([1.0, 1.0, 0.5, 0.5], np.float32), (n, 1))
    return with_keypoints(frames, rng.uniform(-0.6, 0.6, (n, 5, 3)) + [0.0, 0.0, 0.3])


def test_the_frames_rest_on_the_device_as_uint8_colour_and_float16_depth_and_batches_are_the_frames(frames):
    index = np.array([7, 3, 3, 11])
    data = DeviceFrames.upload(frames, index, torch.device("cpu"), "keypoints")
    assert len(data) == 3  # a duplicate held once
    assert data.rgb.dtype == torch.uint8 and data.depth_m.dtype == torch.float16
    rgb, depth, ref = data.batch(data.positions(index))
    assert np.array_equal(rgb.numpy(), frames.rgb[index])
    assert np.array_equal(depth.numpy(), frames.depth_m[index].astype(np.float32))
    assert np.array_equal(ref.numpy(), frames.pose_base_ref[index])
    assert data.target.dtype == torch.float64 and data.target.shape == (3, 5, 3)


def test_shifts_on_the_device_move_images_and_targets_as_the_host_shifts_did(frames):
    rng = np.random.default_rng(1)
    index = np.arange(6)
    shifts = rng.integers(-3, 4, size=(6, 2))
    shifts[0] = (3, -3)  # the largest shift at a corner
    data = DeviceFrames.upload(frames, index, torch.device("cpu"), "keypoints")
    rgb, depth, _ = data.batch(data.positions(index))
    want_rgb, want_depth = shift_images(rgb, depth, shifts)
    got_rgb, got_depth = shift_batch(rgb, depth, torch.from_numpy(shifts), pad=3)
    assert torch.equal(got_rgb, want_rgb) and torch.equal(got_depth, want_depth)
    want = shift_targets(data.target.numpy(), shifts, (32, 32))
    assert np.array_equal(shift_target_batch(data.target, torch.from_numpy(shifts), (32, 32)).numpy(), want)


def test_a_bfloat16_encoder_predicts_in_float32_near_the_float32_network():
    torch.manual_seed(0)
    config = ModelConfig("translation", (32, 32), (8, 16, 32), (64, 32))
    full = CalibrationNet(config).eval()
    half = CalibrationNet(ModelConfig("translation", (32, 32), (8, 16, 32), (64, 32), trunk_dtype="bfloat16")).eval()
    half.load_state_dict(full.state_dict())
    seen = []
    half.rgb_encoder.register_forward_hook(lambda module, args, out: seen.append(out.dtype))
    rgb = torch.randint(0, 256, (4, 3, 32, 32), dtype=torch.uint8)
    depth, ref = 1.0 + torch.rand(4, 1, 32, 32), torch.rand(4, 7)
    with torch.no_grad():
        a, b = full(rgb, depth, ref), half(rgb, depth, ref)
    assert seen == [torch.bfloat16] and b.dtype == torch.float32  # the encoder in bfloat16, the head in float32
    raw_a, raw_b = a / config.translation_scale_mm, b / config.translation_scale_mm
    assert (raw_a - raw_b).abs().max() <= BF16_ENCODER_RTOL * raw_a.abs().max()
    assert not torch.equal(a, b)


@pytest.mark.parametrize("compile", [False, True])
def test_the_compile_flag_is_honoured(frames, monkeypatch, compile):
    compiled = []

    def spy(module, *args, **kwargs):
        compiled.append(module)
        return module  # the module itself: what is tested is that the flag reaches torch.compile

    monkeypatch.setattr(torch, "compile", spy)
    torch.manual_seed(0)
    model = CalibrationNet(ModelConfig("translation", (32, 32), (8, 16, 32), (64, 32)))
    index = np.flatnonzero(frames.split == "train")
    assert train(model, frames, index, TrainConfig(1, 8, compile=compile), np.random.default_rng(0)) == len(index)
    assert compiled == ([model] if compile else [])
