"""The registration calibrates the sensor's depth: a known scale and offset recovered, refused where unobservable.

The analytic sphere scenes of ``test_markerless``: depth ray-cast exactly, noise of known sigma, then the
sensor's systematic error ``d_obs = s d + o`` applied as a real camera's calibration error would be.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from scipy import optimize, stats

from classic.markerless import MarkerlessOptions, register_robot
from classic.markerless.depth import depth_noise_curve
from handeye.core.metrics import pose_error
from tests.classic.test_markerless import (
    RADII,
    SIGMA_1M,
    H,
    K,
    _bias_bounds,
    _look_at,
    _scene,
    covariance_carries_sigma,
    render_depth,
    sphere_model,
)
from tests.tolerances import MAD_SD_SQRT_N, SIGMA_BOUND

#: A consumer RGB-D camera's calibration error: 1.2 % of scale, 4 mm of offset (within their datasheets' 1-2 %).
SCALE, OFFSET_M = 1.012, 0.004


def _sensor(depth, scale=SCALE, offset_m=OFFSET_M):
    return np.where(depth > 0, scale * depth + offset_m, 0.0)


def _flat_scene(rng, depth_spread_m, n_frames=8):
    """Moving spheres whose centres keep to the plane through the look-at point facing the camera, moved along
    the optical axis by up to ``depth_spread_m``: 0 puts every sphere at one depth."""
    T_base_cam = _look_at(np.array([1.2, -0.6, 0.9]), np.array([0.0, 0.0, 0.35]))
    x, y, z = T_base_cam[:3, 0], T_base_cam[:3, 1], T_base_cam[:3, 2]
    p0 = np.array([0.0, 0.0, 0.35])
    a = rng.uniform(-1, 1, size=(n_frames, len(RADII) - 1, 3))
    centres = np.empty((n_frames, len(RADII), 3))
    centres[:, 0] = p0
    centres[:, 1:] = p0 + 0.3 * a[..., :1] * x + 0.3 * a[..., 1:2] * y + depth_spread_m * a[..., 2:3] * z
    return render_depth(centres, T_base_cam, rng), sphere_model(centres), T_base_cam


def test_a_known_depth_scale_and_offset_are_recovered():
    depth, surface, T_true = _scene(np.random.default_rng(3))
    res = register_robot(_sensor(depth), K, surface)
    assert res.ok, res.refused
    d = res.depth
    assert abs(d["scale"] - SCALE) <= SIGMA_BOUND * d["scale_sigma"]
    assert abs(d["offset_mm"] - OFFSET_M * 1e3) <= SIGMA_BOUND * d["offset_sigma_mm"]
    rot_deg, trans_mm = pose_error(res.T_base_cam, T_true)
    bias_mm, bias_deg = _bias_bounds(depth)
    assert trans_mm <= SIGMA_BOUND * res.sigma["translation_mm"] + bias_mm
    assert rot_deg <= SIGMA_BOUND * res.sigma["rotation_deg"] + bias_deg


def test_the_same_depth_taken_as_exact_is_confidently_wrong():
    """Why the depth is calibrated: without it, the 1.2 % scale pulls the camera far outside its own sigma."""
    depth, surface, T_true = _scene(np.random.default_rng(3))
    opts = MarkerlessOptions(depth_model="fixed", depth_sigma_m_at_1m=SIGMA_1M)
    res = register_robot(_sensor(depth), K, surface, options=opts)
    if res.ok:  # accepted: then outside the bound any right answer keeps (SIGMA_BOUND of its own sigmas)
        _, trans_mm = pose_error(res.T_base_cam, T_true)
        assert trans_mm > SIGMA_BOUND * res.sigma["translation_mm"]
    assert "scale" not in res.depth


@pytest.mark.parametrize("depth_spread_m", [0.15, 0.3])
def test_arm_moving_in_depth_calibrates_it(depth_spread_m):
    depth, surface, T_true = _flat_scene(np.random.default_rng(0), depth_spread_m)
    res = register_robot(_sensor(depth), K, surface)
    assert res.ok, res.refused
    assert abs(res.depth["scale"] - SCALE) <= SIGMA_BOUND * res.depth["scale_sigma"]
    _, trans_mm = pose_error(res.T_base_cam, T_true)
    assert trans_mm <= SIGMA_BOUND * res.sigma["translation_mm"] + _bias_bounds(depth)[0]


def test_every_frame_at_one_depth_is_refused_with_the_reason():
    """Spheres kept at one distance: the scale and the offset cannot be told apart, and the answer would rest on
    the prior alone."""
    depth, surface, _ = _flat_scene(np.random.default_rng(0), depth_spread_m=0.0)
    res = register_robot(_sensor(depth), K, surface)
    assert not res.ok and res.T_base_cam is None
    assert "depth scale and offset not observable" in res.refused
    assert "span" in res.refused


def test_depth_taken_as_exact_needs_no_depth_range():
    depth, surface, T_true = _flat_scene(np.random.default_rng(0), depth_spread_m=0.0)
    res = register_robot(depth, K, surface, options=MarkerlessOptions(depth_model="fixed"))
    assert res.ok, res.refused
    _, trans_mm = pose_error(res.T_base_cam, T_true)
    assert trans_mm <= SIGMA_BOUND * res.sigma["translation_mm"] + _bias_bounds(depth)[0]


def _noise_bounds(med_m, truth_m, samples, sigma_1m):
    """Bounds on each of :func:`depth_noise_curve`'s bins (equal counts of the pixels sorted by ``med_m``, their
    median depth) when the noise at true depth z is ``sigma_1m z^2``, with ``samples`` independent values per
    pixel. A robust spread pooled over a bin's pixels, 1.4826 times the median m of the values' magnitudes,
    converges to the root of ``mean_i P(|N(0, sigma_i)| < m) = 1/2`` (weighted by the samples), between the
    nearest and farthest pixel's sigma; the bounds are that limit, widened by SIGMA_BOUND of the robust sigma's
    sampling deviation over the bin's samples. (The over-time measure, a median of 12-value spreads, comes out
    10 % low, the median absolute deviation of few values being biased low: the larger measure is the spatial.)"""
    order = np.argsort(med_m)
    chunks = np.array_split(order, min(10, max(1, len(order) // 50)))
    lo, hi = [], []
    for c in chunks:
        sigma_i, weight = sigma_1m * truth_m[c] ** 2, samples[c] / samples[c].sum()
        half = optimize.brentq(
            lambda m: weight @ (2 * stats.norm.cdf(m / sigma_i) - 1) - 0.5, sigma_i.min() / 2, sigma_i.max()
        )
        pooled = half / stats.norm.ppf(0.75)
        widen = SIGMA_BOUND * MAD_SD_SQRT_N / np.sqrt(samples[c].sum())
        lo.append(pooled * (1 - widen))
        hi.append(pooled * (1 + widen))
    return np.array(lo), np.array(hi)


def test_noise_is_measured_on_the_static_background():
    """The floor does not move: its depth's spread over frames is the sensor's noise, SIGMA_1M z^2. Spheres move
    over it (none stands still: a static sphere's curvature is not the planar background the spatial measure
    assumes), seen from above so that the floor lies within 2.2 m: there the spatial measure's background gate
    (2 cm from a pixel's median depth) is SIGMA_BOUND sigmas or more and cuts no noise off."""
    rng = np.random.default_rng(4)
    n_frames = 12
    T_base_cam = _look_at(np.array([0.6, -0.3, 1.6]), np.array([0.0, 0.0, 0.2]))
    centres = rng.uniform([-0.3, -0.3, 0.25], [0.3, 0.3, 0.65], size=(n_frames, 3, 3))
    depth = render_depth(centres, T_base_cam, rng, radii=RADII[1:])
    z, sigma = depth_noise_curve(depth)
    assert len(z) >= 5 and np.all(np.diff(z) > 0)
    # the floor's true depth, and the frames in which a pixel sees it (the spheres cover it in the others)
    floor = render_depth(np.zeros((1, 0, 3)), T_base_cam, radii=RADII[:0])[0]
    valid = (depth > 0).all(axis=0)
    assert SIGMA_BOUND * SIGMA_1M * floor[valid].max() ** 2 <= 0.02
    seen = (np.abs(render_depth(centres, T_base_cam, radii=RADII[1:]) - floor) == 0).sum(axis=0)
    lo, hi = _noise_bounds(np.median(depth[:, valid], axis=0), floor[valid], seen[valid], SIGMA_1M)
    assert np.all((lo <= sigma) & (sigma <= hi)), (z, sigma / (SIGMA_1M * z**2))


def test_noise_curve_needs_frames_and_background():
    assert len(depth_noise_curve(np.ones((2, 20, 20)))[0]) == 0
    assert len(depth_noise_curve(np.zeros((10, 20, 20)))[0]) == 0


def test_bad_depth_options_raise():
    from handeye.core.errors import HandEyeInputError

    with pytest.raises(HandEyeInputError, match="depth_model"):
        MarkerlessOptions(depth_model="scale")
    with pytest.raises(HandEyeInputError, match="prior"):
        MarkerlessOptions(depth_scale_prior_sigma=0.0)
    with pytest.raises(HandEyeInputError, match="depth_sigma_m_at_1m"):
        MarkerlessOptions(depth_sigma_m_at_1m=-1.0)


def test_noise_that_stays_put_is_measured_across_the_image():
    """A matcher's error under a fixed projector pattern is the same in every frame: no spread over time.
    Across the image it shows: the floor is a plane, so the inverse depth's second difference is noise only."""
    rng = np.random.default_rng(11)
    h, w = 120, 160
    v, u = np.mgrid[0:h, 0:w].astype(float)
    floor = 1.0 / (1 / 1.6 + (v - 60) * 0.4 / 120 + (u - 80) * 0.05 / 160)  # a plane seen at 1.2-2.4 m
    sigma_1m = 0.004
    fixed = floor + sigma_1m * floor**2 * rng.normal(size=(h, w))  # the same error in every frame
    frames = np.repeat(fixed[None], 10, axis=0)
    for i in range(10):  # an arm crossing the view: nearer than the floor, a different place in each frame
        frames[i, 30:70, 10 + 14 * i : 30 + 14 * i] = 0.9
    z, sigma = depth_noise_curve(frames)
    assert len(z) >= 5
    # over time alone this would be 0; across the image it is the fixed error's sigma: one draw per pixel
    lo, hi = _noise_bounds(np.median(frames, axis=0).ravel(), floor.ravel(), np.ones(h * w), sigma_1m)
    assert np.all((lo <= sigma) & (sigma <= hi)), (z, sigma / (sigma_1m * z**2))


#: An active-stereo camera's disparity constant (a D435 at 848x480: 447 px x 50 mm) and its matcher's pull
#: toward whole disparities, 0.15 px (OpenCV's matcher on the simulated D435 pulls by about 0.2 px).
STEREO_FB_PX_M, LOCKING_PX = 22.35, 0.15


def _stereo_sensor(depth, scale=SCALE, offset_m=OFFSET_M, locking_px=LOCKING_PX):
    """Depth as a stereo camera reports it: the matcher sees the true baseline (``f B / scale``) and its disparity
    ``d`` errs by ``locking_px sin(2 pi d)`` (``d - locking_px sin(2 pi d) = d_true``, solved by Newton's method);
    the camera converts with its own ``f B`` and adds its offset."""
    d_true = STEREO_FB_PX_M / (scale * np.where(depth > 0, depth, 1.0))
    d = d_true.copy()
    for _ in range(20):  # monotone for 2 pi locking_px < 1: converges from d_true
        d -= (d - locking_px * np.sin(2 * np.pi * d) - d_true) / (1 - 2 * np.pi * locking_px * np.cos(2 * np.pi * d))
    return np.where(depth > 0, STEREO_FB_PX_M / d + offset_m, 0.0)


def test_a_stereo_matchers_pull_toward_whole_disparities_is_recovered():
    depth, surface, T_true = _scene(np.random.default_rng(3))
    res = register_robot(_stereo_sensor(depth), K, surface, options=MarkerlessOptions(stereo_fb_px_m=STEREO_FB_PX_M))
    assert res.ok, res.refused
    locking = res.depth["pixel_locking_px"]
    assert abs(locking["sin"] - LOCKING_PX) <= SIGMA_BOUND * locking["sin_sigma"]
    assert abs(locking["cos"]) <= SIGMA_BOUND * locking["cos_sigma"]
    assert abs(res.depth["scale"] - SCALE) <= SIGMA_BOUND * res.depth["scale_sigma"]
    assert abs(res.depth["offset_mm"] - OFFSET_M * 1e3) <= SIGMA_BOUND * res.depth["offset_sigma_mm"]
    rot_deg, trans_mm = pose_error(res.T_base_cam, T_true)
    bias_mm, bias_deg = _bias_bounds(depth)
    assert trans_mm <= SIGMA_BOUND * res.sigma["translation_mm"] + bias_mm
    assert rot_deg <= SIGMA_BOUND * res.sigma["rotation_deg"] + bias_deg


def test_a_stereo_camera_without_its_matchers_bias_modelled_is_not_trusted():
    """Why the bias is modelled: at this scene's 1.3 m it moves the depth by 1 cm, periodically in depth, which
    no scale and offset absorb; unmodelled, the answer is refused or lies outside its own sigma."""
    depth, surface, T_true = _scene(np.random.default_rng(3))
    res = register_robot(_stereo_sensor(depth), K, surface)
    if res.ok:
        rot_deg, trans_mm = pose_error(res.T_base_cam, T_true)
        assert trans_mm > SIGMA_BOUND * res.sigma["translation_mm"] or rot_deg > SIGMA_BOUND * res.sigma["rotation_deg"]
    assert "pixel_locking_px" not in res.depth


def test_a_stereo_camera_without_locking_gives_none():
    """The bias modelled where the matcher has none: estimated at zero, and the pose still right."""
    depth, surface, T_true = _scene(np.random.default_rng(3))
    res = register_robot(
        _stereo_sensor(depth, locking_px=0.0), K, surface, options=MarkerlessOptions(stereo_fb_px_m=STEREO_FB_PX_M)
    )
    assert res.ok, res.refused
    locking = res.depth["pixel_locking_px"]
    assert abs(locking["sin"]) <= SIGMA_BOUND * locking["sin_sigma"]
    assert abs(locking["cos"]) <= SIGMA_BOUND * locking["cos_sigma"]
    _, trans_mm = pose_error(res.T_base_cam, T_true)
    assert trans_mm <= SIGMA_BOUND * res.sigma["translation_mm"] + _bias_bounds(depth)[0]


def test_bad_stereo_options_raise():
    from handeye.core.errors import HandEyeInputError

    with pytest.raises(HandEyeInputError, match="stereo_fb_px_m"):
        MarkerlessOptions(stereo_fb_px_m=-1.0)
    with pytest.raises(HandEyeInputError, match="scale-offset"):
        MarkerlessOptions(stereo_fb_px_m=STEREO_FB_PX_M, depth_model="fixed")
    with pytest.raises(HandEyeInputError, match="pixel_locking_prior_px"):
        MarkerlessOptions(stereo_fb_px_m=STEREO_FB_PX_M, pixel_locking_prior_px=0.0)


def _frozen_error_on_the_base(depth, centres, T_base_cam, push_m):
    """The sensor's error on the static sphere (part 0): the same in every frame, growing across the image's rows
    to ``push_m`` at the sphere's lower rim (as a fixed projector pattern's matching error stays on a static
    surface)."""
    base_only = render_depth(centres[:, :1], T_base_cam)
    floor_only = render_depth(centres[:, :1] + [0.0, 0.0, 5.0], T_base_cam)
    on_base = (base_only > 0) & (base_only < floor_only - 1e-6) & (np.abs(depth - base_only) < 0.01)
    rows = np.nonzero(on_base[0].any(axis=1))[0]
    v = (np.arange(H)[:, None] - rows.min()) / max(rows.max() - rows.min(), 1)
    return np.where(on_base, depth + push_m * v, depth)


def test_a_static_parts_frozen_error_is_counted_once():
    """The static base is seen the same way in every frame: a sensor error on it (2 cm at its rim) repeats in every
    frame, so the frames cannot reveal it. Left out (the default), the moving parts give the truth within their
    sigma. Fitted (``static_parts``), its matches count once per z-buffer cell, not once per frame, and its pull on
    the answer is added whole to the moving parts' own sigma: the answer stays within its own sigma's bound, and the
    covariance carries the whole sigma (the noise, the repeated error, the groups' scatter, the pull). Counted
    once per frame (the old code), the base pulled the camera 24.6 mm at a sigma of 4.5 mm, beyond the bound
    (20.8 mm); without the pull, the sigma (0.71 mm) is narrower than the 1.48 mm the base moved the answer. The
    camera matrix is exact here and taken as exact (a 3 px prior on the principal point of this 150 px camera would
    widen the bound fourfold and hide the comparison)."""
    rng = np.random.default_rng(3)
    T_base_cam = _look_at(np.array([1.2, -0.6, 0.9]), np.array([0.0, 0.0, 0.35]))
    centres = np.empty((12, len(RADII), 3))
    centres[:, 0] = [0, 0, 0.09]
    centres[:, 1:] = rng.uniform([-0.3, -0.3, 0.25], [0.3, 0.3, 0.65], size=(12, 3, 3))
    depth = _frozen_error_on_the_base(render_depth(centres, T_base_cam, rng), centres, T_base_cam, 0.02)
    surface = sphere_model(centres)
    bias_mm, bias_deg = _bias_bounds(depth)
    exact = MarkerlessOptions(intrinsics_model="fixed")
    moving = register_robot(_sensor(depth), K, surface, options=exact)
    fitted = register_robot(_sensor(depth), K, surface, options=replace(exact, static_parts=True))
    for res in (moving, fitted):
        assert res.ok, res.refused
        rot_deg, trans_mm = pose_error(res.T_base_cam, T_base_cam)
        assert trans_mm <= SIGMA_BOUND * res.sigma["translation_mm"] + bias_mm, res.diagnostics["fitted_parts"]
        assert rot_deg <= SIGMA_BOUND * res.sigma["rotation_deg"] + bias_deg, res.diagnostics["fitted_parts"]
        assert covariance_carries_sigma(res), res.diagnostics["fitted_parts"]
    # the terms the covariance carries here beside the noise and the sampling bound: the groups' scatter and the
    # base's pull; the repeated-error term is computed, but the base's matches count once, so its error repeats in
    # no other frame: the term sees the spheres' noise alone (0.37 mm of sigma, or none), not the base's error again
    assert moving.diagnostics["sigma_consistency"]["translation_mm"] > 0
    assert fitted.diagnostics["sigma_static"]["translation_mm"] > 0
    repeated = fitted.diagnostics["sigma_repeated"]
    assert 0 <= repeated["translation_mm"] < fitted.diagnostics["sigma_static"]["translation_mm"]
    # the base counted once: no more of its matches fitted than it has pixels in the image (not one set per frame)
    base_pixels = int((render_depth(centres[:1, :1], T_base_cam) > 0).sum())
    assert fitted.diagnostics["fitted_parts"] == "all"
    assert 0 < fitted.diagnostics["static_matches"] <= base_pixels
    # the base may move the answer, but the sigma is not narrower than how far it moved it (its pull taken whole)
    rot_deg, trans_mm = pose_error(fitted.T_base_cam, moving.T_base_cam)
    assert fitted.sigma["translation_mm"] >= trans_mm and fitted.sigma["rotation_deg"] >= rot_deg
