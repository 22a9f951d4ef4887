"""Shifted training images: the image and its keypoint targets move together, and only when asked."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from learned.keypoints import inside_image, shift_images, shift_targets
from learned.trainer import TrainConfig
from tests.tolerances import FLOAT

W, H = 20, 14


def _dots(rng, b):
    """Images with one lit pixel each (colour and depth), and the keypoint target at its centre."""
    u, v = rng.integers(3, W - 3, b), rng.integers(3, H - 3, b)
    rgb, depth = torch.zeros(b, 3, H, W), torch.zeros(b, 1, H, W)
    rgb[np.arange(b), :, v, u] = 1.0
    depth[np.arange(b), 0, v, u] = torch.from_numpy(rng.uniform(0.5, 2.0, b)).float()
    target = np.stack([(u + 0.5) / W, (v + 0.5) / H, depth[np.arange(b), 0, v, u].numpy()], -1)[:, None]
    return rgb, depth, target


def test_a_shifted_image_and_its_shifted_target_still_agree():
    rng = np.random.default_rng(0)
    rgb, depth, target = _dots(rng, 6)
    shifts = rng.integers(-5, 6, (6, 2))
    shifts[0] = 0
    rgb_s, depth_s = shift_images(rgb, depth, shifts)
    target_s = shift_targets(target, shifts, (W, H))
    assert rgb_s.shape == rgb.shape and depth_s.shape == depth.shape
    for i in range(6):
        lit = torch.nonzero(rgb_s[i, 0])
        if inside_image(torch.from_numpy(target_s[i : i + 1]))[0, 0]:  # the dot is still in the picture
            v, u = lit[0].tolist()
            assert len(lit) == 1
            np.testing.assert_allclose(target_s[i, 0, :2], [(u + 0.5) / W, (v + 0.5) / H], atol=FLOAT)
            assert depth_s[i, 0, v, u] == depth[i].max() == pytest.approx(target_s[i, 0, 2])
        else:
            assert len(lit) == 0
    torch.testing.assert_close(rgb_s[0], rgb[0])  # no shift: the same image
    np.testing.assert_array_equal(target_s[0], target[0])


def test_the_uncovered_border_is_empty():
    rgb, depth = torch.ones(2, 3, H, W), torch.full((2, 1, H, W), 1.5)
    rgb_s, depth_s = shift_images(rgb, depth, np.array([[3, -2], [-1, 0]]))
    assert (rgb_s[0, :, :, :3] == 0).all() and (rgb_s[0, :, -2:, :] == 0).all()
    assert (depth_s[0, :, :, :3] == 0).all() and (depth_s[0, :, :-2, 3:] == 1.5).all()
    assert (depth_s[1, :, :, -1:] == 0).all() and (rgb_s[1, :, :, :-1] == 1).all()


def test_shifts_are_off_unless_asked_for_and_never_negative():
    assert TrainConfig().shift_px == 0
    with pytest.raises(ValueError, match="shift_px"):
        TrainConfig(shift_px=-1)
