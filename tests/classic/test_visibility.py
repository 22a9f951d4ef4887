"""The point-splat z-buffer keeps, in every pixel of every frame, the nearest front-facing point."""

from __future__ import annotations

import numpy as np
import pytest

from classic.markerless.visibility import project, visible_points

K = np.array([[100.0, 0.0, 31.5], [0.0, 100.0, 23.5], [0.0, 0.0, 1.0]])
H, W = 48, 64


def _brute_force(p_cam, frame):
    """The nearest point of each (frame, pixel), by a loop over the points."""
    best: dict[tuple[int, int, int], int] = {}
    uv = np.rint(project(p_cam, K)).astype(int)
    for i, ((u, v), f, z) in enumerate(zip(uv, frame, p_cam[:, 2])):
        if z <= 0.05 or not (0 <= u < W and 0 <= v < H):
            continue
        k = (int(f), int(v), int(u))
        if k not in best or z < p_cam[best[k], 2]:
            best[k] = i
    return {k: best[k] for k in sorted(best)}


def test_nearest_point_per_pixel_as_a_loop_finds_it():
    rng = np.random.default_rng(3)
    n = 4000
    frame = rng.integers(0, 3, n)
    # few pixels for many points, so that most pixels hold several; depths distinct
    p = np.c_[rng.uniform(-0.1, 0.1, (n, 2)), rng.uniform(0.2, 1.0, n)]
    p[:, :2] *= p[:, 2:]  # inside the view at every depth
    p[:5, 2] = 0.01  # behind the near plane
    expected = _brute_force(p, frame)
    got = visible_points(p, None, frame, K, H, W)
    assert list(got) == list(expected.values())  # one per covered pixel, in pixel order


def test_an_occluded_surface_is_hidden_and_back_faces_dropped():
    # two parallel squares on the optical axis, 0.5 m and 0.8 m away, facing the camera
    g = np.stack(np.meshgrid(np.linspace(-0.05, 0.05, 40), np.linspace(-0.05, 0.05, 40)), -1).reshape(-1, 2)
    near = np.c_[g, np.full(len(g), 0.5)]
    far = np.c_[g * 3, np.full(len(g), 0.8)]  # wider: its rim shows round the near one
    p = np.r_[near, far]
    n = np.tile([0.0, 0.0, -1.0], (len(p), 1))
    seen = visible_points(p, n, np.zeros(len(p), int), K, H, W)
    uv_near = np.rint(project(near, K)).astype(int)
    uv_far = np.rint(project(p[seen[seen >= len(g)]], K)).astype(int)
    covered = {tuple(x) for x in uv_near}
    assert seen[seen < len(g)].size == len(covered)
    assert not covered & {tuple(x) for x in uv_far}, "a far point kept in a pixel the near square covers"
    assert visible_points(p, -n, np.zeros(len(p), int), K, H, W).size == 0  # all facing away


def test_nothing_in_view_is_an_empty_answer():
    p = np.array([[0.0, 0.0, -1.0], [5.0, 0.0, 1.0]])
    assert visible_points(p, None, np.zeros(2, int), K, H, W).size == 0


@pytest.mark.parametrize("n", [1, 2])
def test_few_points(n):
    p = np.tile([0.0, 0.0, 1.0], (n, 1))
    p[:, 2] += np.arange(n) * 0.1
    assert list(visible_points(p, None, np.zeros(n, int), K, H, W)) == [0]


@pytest.mark.parametrize("tolerance", [0.004, np.full((2, 1, 1), 0.004)])
def test_a_pixel_between_two_surfaces_is_mixed_and_a_slanted_plane_is_not(tolerance):
    """``mixed_pixels``: a depth step (1.0 m to 1.5 m) with one pixel at 1.3 m between them is flagged; the
    step's own pixels are not, away from that pixel and the image's border rows (whose vertical neighbours are
    missing); a plane slanted across the image has no mixed pixel (its inverse depth is affine in the pixel)."""
    from classic.markerless.depth import mixed_pixels

    step = np.full((H, W), 1.0)
    step[:, W // 2 :] = 1.5
    step[10, W // 2] = 1.3
    v, u = np.mgrid[0:H, 0:W].astype(float)
    plane = 1.0 / (1.0 + 0.004 * (u - W / 2) + 0.002 * (v - H / 2))
    mixed = mixed_pixels(np.stack([step, plane]), tolerance)
    assert mixed[0, 10, W // 2]
    flagged = {tuple(x) for x in np.argwhere(mixed[0])}
    assert all(u in (W // 2 - 1, W // 2) and (v in (0, H - 1) or abs(v - 10) <= 1) for v, u in flagged), flagged
    assert not mixed[1].any()


def _mixed_by_loops(depth, tolerance, min_jump=0.03):
    """``mixed_pixels`` by its definition, pixel by pixel: a valid pixel whose 3x3 neighbourhood within the image
    (valid pixels only) spans more than ``min_jump``, and whose inverse depth is the mean of no pair of opposite
    neighbours' (both valid and inside the image) within ``tolerance / z^2``."""
    n, h, w = depth.shape
    out = np.zeros(depth.shape, bool)
    for f, v, u in np.argwhere(depth > 0):
        window = depth[f, max(v - 1, 0) : v + 2, max(u - 1, 0) : u + 2]
        window = window[window > 0]
        if window.max() - window.min() <= min_jump:
            continue
        z = depth[f, v, u]
        on_a_surface = False
        for dv, du in ((0, 1), (1, 0), (1, 1), (1, -1)):
            (va, ua), (vb, ub) = (v + dv, u + du), (v - dv, u - du)
            if not (0 <= va < h and 0 <= ua < w and 0 <= vb < h and 0 <= ub < w):
                continue
            a, b = depth[f, va, ua], depth[f, vb, ub]
            if a > 0 and b > 0 and abs(1 / z - 0.5 * (1 / a + 1 / b)) <= tolerance[f, v, u] / z**2:
                on_a_surface = True
        out[f, v, u] = not on_a_surface
    return out


def test_mixed_pixels_as_a_loop_finds_them():
    """``mixed_pixels`` (whole-array filters, the neighbour test on the edge pixels) flags the pixels its definition
    does, on noisy depth steps with holes, at the image's border too."""
    from classic.markerless.depth import mixed_pixels

    rng = np.random.default_rng(5)
    depth = np.where(rng.random((3, 20, 24)) < 0.5, 1.0, 1.2) + rng.normal(0, 0.004, (3, 20, 24))
    depth[rng.random(depth.shape) < 0.1] = 0.0  # missing
    tolerance = np.full(depth.shape, 0.004)
    expected = _mixed_by_loops(depth, tolerance)
    assert expected.sum() > 20 and (~expected & (depth > 0)).sum() > 20  # both kinds present
    np.testing.assert_array_equal(mixed_pixels(depth, tolerance), expected)
