"""The z-buffer's coarser grid (:func:`classic.markerless.visibility.zbuffer_grid`): each point's coarse pixel is the
block of ``stride`` x ``stride`` image pixels that holds its image pixel."""

from __future__ import annotations

import numpy as np
import pytest

from classic.markerless.visibility import project, zbuffer_grid
from tests.tolerances import FLOAT

K = np.array([[612.3, 0.4, 318.7], [0.0, 611.9, 241.2], [0.0, 0.0, 1.0]])
H, W = 480, 640


@pytest.mark.parametrize("stride", [2, 3, 4])
def test_each_point_falls_in_the_block_of_its_image_pixel(stride):
    rng = np.random.default_rng(0)
    uv = rng.uniform([-0.5, -0.5], [W - 0.5, H - 0.5], size=(20000, 2))
    # keep off the pixel edges, where rounding in either camera could go either way
    uv = uv[np.all(np.abs(uv - np.floor(uv) - 0.5) > FLOAT * W, axis=1)]
    z = rng.uniform(0.5, 3.0, len(uv))
    Kinv = np.linalg.inv(K)
    p_cam = (np.c_[uv, np.ones(len(uv))] @ Kinv.T) * z[:, None]
    K_grid, h, w = zbuffer_grid(K, H, W, stride)
    pixel = np.rint(project(p_cam, K)).astype(np.int64)
    coarse = np.rint(project(p_cam, K_grid)).astype(np.int64)
    np.testing.assert_array_equal(coarse, pixel // stride)
    assert (h, w) == (-(-H // stride), -(-W // stride))
    assert coarse[:, 0].max() < w and coarse[:, 1].max() < h


def test_stride_one_is_the_image_itself():
    K_grid, h, w = zbuffer_grid(K, H, W, 1)
    np.testing.assert_array_equal(K_grid, K)
    assert K_grid is not K and (h, w) == (H, W)


def test_a_size_not_divisible_by_the_stride_rounds_up():
    assert zbuffer_grid(K, 481, 641, 2)[1:] == (241, 321)
