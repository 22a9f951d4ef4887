"""The keypoint network with more than one stride-2 stage."""

from __future__ import annotations

import torch

from learned.keypoints import KeypointNet
from learned.model import ModelConfig


def test_a_two_stage_network_keeps_the_heatmaps_at_half_its_input():
    torch.manual_seed(0)
    one = KeypointNet(ModelConfig("keypoints", (64, 64), (8,), (), n_keypoints=5))
    two = KeypointNet(ModelConfig("keypoints", (128, 96), (4, 8), (), n_keypoints=5))
    out, prob = two(torch.zeros(2, 3, 96, 128, dtype=torch.uint8), torch.ones(2, 1, 96, 128), heatmaps=True)
    assert out.shape == (2, 5, 3) and prob.shape == (2, 5, 48, 64)
    # one stage: the same modules as before stages existed, so saved models still load
    assert {k.split(".")[0] for k in one.state_dict()} == {"stem", "deep", "fuse", "heat", "depth"}
