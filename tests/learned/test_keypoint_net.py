"""The keypoint network with more than one stride-2 stage, and the keypoint model's own input size."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
import torch

from handeye.core.errors import HandEyeInputError
from learned.experiment import ExperimentOptions, run_experiment
from learned.keypoints import KeypointNet
from learned.model import ModelConfig
from learned.presets import get_preset
from tests.learned._synthetic import make_frames


def test_a_two_stage_network_keeps_the_heatmaps_at_half_its_input():
    torch.manual_seed(0)
    one = KeypointNet(ModelConfig("keypoints", (64, 64), (8,), (), n_keypoints=5))
    two = KeypointNet(ModelConfig("keypoints", (128, 96), (4, 8), (), n_keypoints=5))
    out, prob = two(torch.zeros(2, 3, 96, 128, dtype=torch.uint8), torch.ones(2, 1, 96, 128), heatmaps=True)
    assert out.shape == (2, 5, 3) and prob.shape == (2, 5, 48, 64)
    # one stage: the same modules as before stages existed (and the residual statistics, which older
    # files may lack: learned.model.load_weights), so saved models still load
    assert {k.split(".")[0] for k in one.state_dict()} == {"stem", "deep", "fuse", "heat", "depth", "residual_stats"}


def test_an_input_the_stages_cannot_halve_is_refused():
    with pytest.raises(ValueError, match="divisible by 8"):
        ModelConfig("keypoints", (100, 96), (4, 8), (), n_keypoints=5)


def test_the_protocol_refuses_frames_of_another_size_than_the_keypoint_model_takes():
    frames = make_frames(np.random.default_rng(0), size=(32, 32))
    preset = replace(get_preset("tiny"), keypoint_image_size=(64, 64))
    assert preset.frame_size("keypoints") == (64, 64) and preset.frame_size("regression") == (32, 32)
    with pytest.raises(HandEyeInputError, match=r"needs \(64, 64\) for keypoints"):
        run_experiment(frames, preset, ["batch"], options=ExperimentOptions(family="keypoints"))


def test_a_bfloat16_trunk_predicts_in_float32_what_the_float32_trunk_does():
    torch.manual_seed(0)
    full = KeypointNet(ModelConfig("keypoints", (64, 64), (8,), (), n_keypoints=5)).eval()
    half = KeypointNet(ModelConfig("keypoints", (64, 64), (8,), (), n_keypoints=5, trunk_dtype="bfloat16")).eval()
    half.load_state_dict(full.state_dict())
    rgb = torch.randint(0, 256, (2, 3, 64, 64), dtype=torch.uint8)
    depth = 1.0 + torch.rand(2, 1, 64, 64)
    with torch.no_grad():
        a, b = full(rgb, depth), half(rgb, depth)
    assert b.dtype == torch.float32
    # bfloat16 keeps 8 bits of each activation (relative rounding 2^-9); through the trunk's eight layers the
    # logits move by about a percent of their size, so a position moves by far less than a heatmap cell
    # (1/32 of the image) and a depth by far less than its 1-2 m
    assert (a - b)[..., :2].abs().max() < 1 / 32
    assert (a - b)[..., 2].abs().max() < 0.01
    assert not torch.equal(a, b)  # the trunk did run in the lower precision


def test_a_trunk_precision_other_than_float32_or_bfloat16_is_refused():
    with pytest.raises(ValueError, match="trunk_dtype"):
        ModelConfig("keypoints", (64, 64), (8,), (), n_keypoints=5, trunk_dtype="float16")
    with pytest.raises(ValueError, match="trunk_dtype"):
        ModelConfig("translation", trunk_dtype="float16")
    assert ModelConfig("translation", trunk_dtype="bfloat16").trunk_dtype == "bfloat16"  # the regression encoders
