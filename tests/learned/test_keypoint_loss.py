"""The keypoint model's loss: soft-argmax error plus the heatmap's spread about the true position."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from learned.keypoints import KeypointNet, keypoint_loss
from learned.model import ModelConfig
from tests.tolerances import KEYPOINT_SPREAD_RTOL

W, H = 16, 12  # input pixels; heatmaps at half resolution, 8 x 6


def _uniform(b=1, k=1, h=H // 2, w=W // 2):
    return torch.full((b, k, h, w), 1.0 / (h * w), dtype=torch.float64)


def test_a_diffuse_heatmap_costs_its_spread_and_a_peak_costs_nothing():
    """Both heatmaps put the soft-argmax on the target, the image centre. The uniform one is charged the RMS
    distance of the cell centres from it; the peak on the four cells around it, half a cell's diagonal."""
    target = torch.tensor([[[0.5, 0.5, 1.0]]], dtype=torch.float64)
    pred = target.clone()
    hh, ww = H // 2, W // 2
    xs = ((np.arange(ww) + 0.5) / ww - 0.5) * W
    ys = ((np.arange(hh) + 0.5) / hh - 0.5) * H
    expected_rms = np.sqrt(np.mean(xs**2) + np.mean(ys**2))
    diffuse = keypoint_loss(pred, target, (W, H), _uniform(), spread_weight=1.0).item()
    np.testing.assert_allclose(diffuse, expected_rms, rtol=KEYPOINT_SPREAD_RTOL)
    peak = torch.zeros(1, 1, hh, ww, dtype=torch.float64)
    peak[0, 0, hh // 2 - 1 : hh // 2 + 1, ww // 2 - 1 : ww // 2 + 1] = 0.25  # the four cells around the centre
    np.testing.assert_allclose(
        keypoint_loss(pred, target, (W, H), peak, spread_weight=1.0).item(),
        np.sqrt((W / ww / 2) ** 2 + (H / hh / 2) ** 2),
        rtol=KEYPOINT_SPREAD_RTOL,
    )
    assert keypoint_loss(pred, target, (W, H)).item() == 0.0  # without heatmaps: the coordinates alone


def test_the_spread_is_off_by_default():
    target = torch.tensor([[[0.5, 0.5, 1.0]]], dtype=torch.float64)
    assert keypoint_loss(target.clone(), target, (W, H), _uniform()).item() == 0.0


def test_keypoints_outside_the_image_are_not_charged():
    target = torch.tensor([[[1.5, 0.5, 1.0], [0.5, 0.5, 1.0]]], dtype=torch.float64)
    pred = target.clone()
    both = keypoint_loss(pred, target, (W, H), _uniform(k=2), spread_weight=1.0).item()
    only_inside = keypoint_loss(pred[:, 1:], target[:, 1:], (W, H), _uniform(k=1), spread_weight=1.0).item()
    np.testing.assert_allclose(both, only_inside)


def test_the_heatmaps_returned_are_the_ones_the_prediction_is_made_from():
    torch.manual_seed(0)
    net = KeypointNet(ModelConfig("keypoints", (W, H), (4,), (), n_keypoints=3)).eval()
    rgb = torch.randint(0, 255, (2, 3, H, W), dtype=torch.uint8)
    depth = torch.rand(2, 1, H, W) + 0.5
    with torch.no_grad():
        plain = net(rgb, depth)
        pred, prob = net(rgb, depth, heatmaps=True)
    torch.testing.assert_close(pred, plain)
    assert prob.shape == (2, 3, H // 2, W // 2)
    torch.testing.assert_close(prob.sum((-1, -2)), torch.ones(2, 3))
    x_from_prob = (prob.sum(2) * ((torch.arange(W // 2) + 0.5) / (W // 2))).sum(-1)
    torch.testing.assert_close(pred[..., 0], x_from_prob)


def test_the_keypoint_settings_reach_the_keypoint_model_only():
    from dataclasses import replace

    from learned.presets import get_preset
    from learned.trainer import TrainConfig

    preset = replace(
        get_preset("tiny"),
        keypoint_schedule="cosine",
        keypoint_spread_weight=0.5,
        keypoint_batch_size=4,
        keypoint_channels=(8, 16),
        keypoint_image_size=(64, 48),
        keypoint_shift_px=3,
    )
    keypoints = preset.train_configs("reservoir", "keypoints")
    assert all(c.schedule == "cosine" and c.heatmap_spread_weight == 0.5 and c.batch_size == 4 for c in keypoints)
    assert all(c.shift_px == 3 for c in keypoints)
    regression = preset.train_configs("reservoir", "translation")
    assert all(c.schedule == "constant" and c.heatmap_spread_weight == 0.0 and c.shift_px == 0 for c in regression)
    assert all(c.batch_size == preset.batch_size for c in regression)
    config = preset.model_config("keypoints", n_keypoints=8)
    assert config.channels == (8, 16) and config.image_size == (64, 48)
    assert preset.frame_size("keypoints") == (64, 48) and preset.frame_size() == tuple(preset.image_size)
    assert preset.model_config("translation").image_size == tuple(preset.image_size)
    with pytest.raises(ValueError, match="schedule"):
        TrainConfig(schedule="linear")


def test_a_smaller_dataset_trains_the_keypoint_model_more_epochs_up_to_the_cap():
    """Epochs scale by reference / training frames, between 1 and the cap, for the keypoint model alone."""
    from dataclasses import replace

    from learned.presets import get_preset

    preset = replace(
        get_preset("tiny"), keypoint_epochs=(15, 8, 15), keypoint_reference_frames=4200, keypoint_max_epoch_scale=2.0
    )

    def epochs(strategy, kind, n):
        return tuple(c.epochs for c in preset.train_configs(strategy, kind, n))

    assert epochs("reservoir", "keypoints", 4200) == (15, 8) == epochs("reservoir", "keypoints", None)
    assert epochs("reservoir", "keypoints", 9000) == (15, 8)  # more data: never fewer epochs
    assert epochs("reservoir", "keypoints", 2800) == (22, 12)  # 1.5x: round(22.5) = 22, 12
    assert epochs("batch", "keypoints", 1900) == (30, 16)  # 2.21x, capped at 2
    assert epochs("reservoir", "translation", 1900) == (preset.first_epochs, preset.later_epochs)
    assert replace(preset, keypoint_reference_frames=0).epoch_scale("keypoints", 1900) == 1.0
