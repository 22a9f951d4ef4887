"""Markerless registration on analytic scenes (numpy only): spheres that move between frames over a floor.

The depth images are ray-cast exactly (ray-sphere and ray-plane intersections), so the
only errors are the depth noise, whose sigma is known, and the model's sampling: a model
point stands for the surface within half a pixel of its ray, off the tangent plane by at
most ``F^2 / (8 r)`` for a pixel footprint ``F`` on a sphere of radius ``r``.
"""

from __future__ import annotations

import numpy as np
import pytest

from classic.clustered_covariance import pose_sigma
from classic.markerless import MarkerlessOptions, RobotSurfaceFrames, register_robot
from classic.markerless.depth import pixel_rays
from handeye.core.errors import HandEyeInputError, NonFiniteError, ShapeError
from handeye.core.metrics import pose_error
from handeye.core.se3 import make_transform, so3_exp
from tests.tolerances import FLOAT, SIGMA_BOUND

W, H, F_PX = 160, 120, 150.0
K = np.array([[F_PX, 0, (W - 1) / 2], [0, F_PX, (H - 1) / 2], [0, 0, 1.0]])
SIGMA_1M = 0.001
RADII = np.array([0.09, 0.07, 0.06, 0.05])  # part 0 is static (the "base"), parts 1-3 move


def _look_at(eye, target):
    z = target - eye
    z /= np.linalg.norm(z)
    x = np.cross(z, [0, 0, 1.0])
    x /= np.linalg.norm(x)
    return make_transform(np.column_stack([x, np.cross(z, x), z]), eye)


def _scene(rng, n_frames=8, noise=True, in_view=True):
    T_base_cam = _look_at(np.array([1.2, -0.6, 0.9]), np.array([0.0, 0.0, 0.35]))
    centres = np.empty((n_frames, len(RADII), 3))
    centres[:, 0] = [0, 0, 0.09]
    centres[:, 1:] = rng.uniform([-0.3, -0.3, 0.25], [0.3, 0.3, 0.65], size=(n_frames, 3, 3))
    if not in_view:
        centres[:, :] += [0, 0, 5.0]  # all far above the camera's view
    return render_depth(centres, T_base_cam, rng if noise else None), sphere_model(centres), T_base_cam


def render_depth(centres, T_base_cam, rng=None, radii=RADII, K=K, size=(H, W)):
    """Ray-cast depth of the spheres (``centres``: (frames, spheres, 3), base frame; ``radii`` per sphere) over the
    floor z = 0, through the camera ``K`` at ``size`` (rows, columns).

    With ``rng``, noise of ``SIGMA_1M`` at 1 m growing with depth squared.
    """
    n_frames, (H, W) = len(centres), size
    rays_cam = pixel_rays(K, H, W).reshape(-1, 3)
    R, o = T_base_cam[:3, :3], T_base_cam[:3, 3]
    d_base = rays_cam @ R.T  # ray direction scaled so that t is the camera-frame depth z
    depth = np.zeros((n_frames, H * W))
    for i in range(n_frames):
        t_best = np.where(d_base[:, 2] < 0, -o[2] / np.where(d_base[:, 2] < 0, d_base[:, 2], -1), np.inf)  # floor
        for c, r in zip(centres[i], radii):
            oc = o - c
            a = (d_base**2).sum(1)
            b = 2 * d_base @ oc
            disc = b**2 - 4 * a * (oc @ oc - r**2)
            t = np.where(disc > 0, (-b - np.sqrt(np.maximum(disc, 0))) / (2 * a), np.inf)
            t_best = np.minimum(t_best, np.where(t > 0, t, np.inf))
        z = np.where(np.isfinite(t_best) & (t_best < 5), t_best, 0.0)
        if rng is not None:
            z = np.where(z > 0, z + rng.normal(size=z.shape) * SIGMA_1M * z**2, 0.0)
        depth[i] = z
    return depth.reshape(n_frames, H, W)


def sphere_model(centres, radii=RADII, f_px=F_PX):
    """The spheres' surface at every frame: each sampled (Fibonacci) at 0.7 of the pixel footprint at 0.8 m (focal
    length ``f_px``)."""
    n_frames = len(centres)
    spacing = 0.7 * 0.8 / f_px
    pts, nrm, frame, part = [], [], [], []
    for k, r in enumerate(radii):
        n = int(4 * np.pi * r**2 / spacing**2)
        g = np.arange(n) + 0.5
        phi, theta = np.arccos(1 - 2 * g / n), np.pi * (1 + 5**0.5) * g
        u = np.column_stack([np.cos(theta) * np.sin(phi), np.sin(theta) * np.sin(phi), np.cos(phi)])
        for i in range(n_frames):
            pts.append(centres[i, k] + r * u)
            nrm.append(u)
            frame.append(np.full(n, i))
            part.append(np.full(n, k))
    return RobotSurfaceFrames(np.concatenate(pts), np.concatenate(nrm), np.concatenate(frame), np.concatenate(part))


def _bias_bounds(depth, radii=RADII):
    """Sampling bias of the model (see the module docstring): translation (mm) and rotation (deg)."""
    footprint = depth[depth > 0].max() / F_PX
    trans_m = footprint**2 / (8 * radii.min())
    lever_m = 0.2  # the moving spheres span +-0.3 m: a rotation moves them at least this far
    return trans_m * 1e3, np.degrees(trans_m / lever_m)


def within_sigma(res, T_true, depth, radii=RADII) -> bool:
    """The accepted result within SIGMA_BOUND predicted sigmas of ``T_true``, plus the sampling bias bound."""
    rot_deg, trans_mm = pose_error(res.T_base_cam, T_true)
    bias_mm, bias_deg = _bias_bounds(depth, radii)
    return (
        trans_mm <= SIGMA_BOUND * res.sigma["translation_mm"] + bias_mm
        and rot_deg <= SIGMA_BOUND * res.sigma["rotation_deg"] + bias_deg
    )


def covariance_carries_sigma(res) -> bool:
    """The accepted result's covariance is its whole sigma: :func:`classic.clustered_covariance.pose_sigma` of it is
    the printed sigma, and of ``diagnostics["covariance_noise"]`` the noise term, to float rounding (measured
    5e-16 relative: a sum of a few 6x6 matrices, a trace and a square root)."""
    R = res.T_base_cam[:3, :3]
    whole = pose_sigma(res.covariance, R)
    noise = pose_sigma(np.array(res.diagnostics["covariance_noise"]), R)
    return all(
        abs(whole[key] - res.sigma[key]) <= FLOAT * res.sigma[key]
        and abs(noise[key] - res.diagnostics["sigma_noise"][key]) <= FLOAT * res.diagnostics["sigma_noise"][key]
        for key in ("rotation_deg", "translation_mm")
    )


@pytest.fixture(scope="module")
def scene():
    return _scene(np.random.default_rng(0))


def test_recovers_the_camera_pose_without_a_start(scene):
    depth, surface, T_true = scene
    res = register_robot(depth, K, surface, options=MarkerlessOptions(depth_sigma_m_at_1m=SIGMA_1M))
    assert res.ok, res.refused
    assert within_sigma(res, T_true, depth)
    assert len(res.residual_mm_per_frame) == len(depth)


def test_noiseless_depth_gives_the_truth_to_the_sampling_bias():
    depth, surface, T_true = _scene(np.random.default_rng(1), noise=False)
    res = register_robot(depth, K, surface, options=MarkerlessOptions(depth_sigma_m_at_1m=SIGMA_1M))
    assert res.ok, res.refused
    rot_deg, trans_mm = pose_error(res.T_base_cam, T_true)
    bias_mm, bias_deg = _bias_bounds(depth)
    assert trans_mm <= bias_mm and rot_deg <= bias_deg


@pytest.mark.parametrize("trans_m, angle_deg, centroid", [(0.05, 5.0, False), (0.3, 30.0, True)])
def test_converges_from_given_starts(scene, rng, trans_m, angle_deg, centroid):
    """5 cm / 5 deg off: the coarse stage alone brings it home; 30 cm / 30 deg: with the centroid start beside it."""
    depth, surface, T_true = scene
    bias_mm, bias_deg = _bias_bounds(depth)
    for _ in range(2):
        axis, direction = rng.normal(size=3), rng.normal(size=3)
        T0 = T_true @ make_transform(
            so3_exp(np.radians(angle_deg) * axis / np.linalg.norm(axis)),
            trans_m * direction / np.linalg.norm(direction),
        )
        res = register_robot(depth, K, surface, starts={"user": T0}, centroid_start=centroid)
        assert res.ok, res.refused
        rot_deg, trans_mm = pose_error(res.T_base_cam, T_true)
        assert trans_mm <= SIGMA_BOUND * res.sigma["translation_mm"] + bias_mm
        assert rot_deg <= SIGMA_BOUND * res.sigma["rotation_deg"] + bias_deg


def test_a_start_outside_the_basin_is_refused_not_answered(scene):
    """Starts that cannot converge (the camera turned away, or a metre off): a refusal with the reason."""
    depth, surface, T_true = scene
    bias_mm, bias_deg = _bias_bounds(depth)
    for angle, offset in ((180.0, 0.0), (90.0, 1.0), (0.0, 3.0)):
        T0 = T_true @ make_transform(so3_exp(np.radians(angle) * np.array([1.0, 0, 0])), [offset, 0, 0])
        res = register_robot(depth, K, surface, starts={"user": T0}, centroid_start=False)
        if res.ok:  # an answer is only acceptable if it is right
            rot_deg, trans_mm = pose_error(res.T_base_cam, T_true)
            assert trans_mm <= SIGMA_BOUND * res.sigma["translation_mm"] + bias_mm
        else:
            assert res.T_base_cam is None
            assert any(w in res.refused for w in ("basin", "converge", "residual"))
            # a refusal is not solved again in groups: no answer, no split check
            assert res.diagnostics.get("sigma_consistency") is None


def test_no_robot_in_view_is_refused_with_the_reason(rng):
    depth, surface, _ = _scene(rng, in_view=False)
    res = register_robot(depth, K, surface)
    assert not res.ok and res.T_base_cam is None
    assert "too few robot pixels" in res.refused


def test_bad_inputs_raise_named_errors(scene):
    depth, surface, _ = scene
    bad = depth.copy()
    bad[3, 10, 10] = np.nan
    with pytest.raises(NonFiniteError, match="frame 3"):
        register_robot(bad, K, surface)
    with pytest.raises(ShapeError, match="N frames, H, W"):
        register_robot(depth[0], K, surface)
    with pytest.raises(ShapeError, match="camera matrix"):
        register_robot(depth, np.eye(2), surface)
    with pytest.raises(ShapeError, match="surface frames"):
        register_robot(depth[:2], K, surface)


def test_covariance_groups_by_frame():
    """The sandwich covariance: residuals that share a frame-wide offset are one sample, not thousands."""
    from classic.markerless import MatchedModel, PlaneFitOptions, solve_point_to_plane

    rng = np.random.default_rng(2)
    n_frames, per = 10, 2000
    p = rng.uniform(-0.3, 0.3, size=(n_frames * per, 3)) + [0, 0, 1.5]
    n = rng.normal(size=p.shape)
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    group = np.repeat(np.arange(n_frames), per)
    offset = rng.normal(scale=0.002, size=(n_frames, 3))[group]  # a common error per frame
    m = p + offset + rng.normal(scale=1e-4, size=p.shape)
    options = PlaneFitOptions(scale_m=0.01, loss="linear")
    fit_grouped = solve_point_to_plane(p, MatchedModel(m, n), np.eye(4), options, group=group)
    fit_plain = solve_point_to_plane(p, MatchedModel(m, n), np.eye(4), options)
    # the per-frame offsets average over only 10 frames: the grouped variance is far larger
    assert np.trace(fit_grouped.covariance[3:, 3:]) > 20 * np.trace(fit_plain.covariance[3:, 3:])


def test_grazing_matches_left_out_on_request_and_the_answer_kept(scene):
    """``max_incidence_deg`` leaves out the spheres' rims. Seen from afar, the pixels whose ray meets a sphere within
    ``a`` of its normal are ``sin^2 a`` of its disc: a quarter at 30 deg, three quarters at 60 deg; the outermost
    ring is lost to the depth edges already, so fewer go than that, but more the tighter the bound, and at 30 deg
    at least half (of the three quarters cut, less than half of the disc can have been lost to the edges: the
    ring beyond 60 deg is an eighth of the radius). The answer stays within its sigma."""
    depth, surface, T_true = scene

    def matched(angle):
        opts = MarkerlessOptions(depth_sigma_m_at_1m=SIGMA_1M, max_incidence_deg=angle)
        res = register_robot(depth, K, surface, options=opts)
        assert res.ok, res.refused
        assert within_sigma(res, T_true, depth)
        return res.diagnostics["matched_points"]

    every, sixty, thirty = matched(None), matched(60.0), matched(30.0)
    assert thirty < sixty < every and thirty < 0.5 * every
    for bad in (0.0, 90.0, float("nan")):
        with pytest.raises(HandEyeInputError):
            MarkerlessOptions(max_incidence_deg=bad)
