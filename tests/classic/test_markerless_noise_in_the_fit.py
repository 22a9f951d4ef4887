"""The depth noise does not bias what the point-to-plane fit estimates (issue 41).

The observed depth's noise enters the fit's equations twice over: in the Jacobian's columns that hold the observed
point (the rotation's, the depth scale's, the intrinsics'), and on a curved part in the second-order residual's
gradient ``n + S d``, whose tangential offset ``d`` holds the noise's tangential part; times the residual, which
holds the same noise, their mean is not 0 (errors in variables). On a robot's 4 cm links at a stereo camera's noise
that put the focal length about 0.2 % low. Given the matches' depth variance (``MatchedModel.depth_variance``) the
fit takes both at the point moved along its ray onto the surface, and the second-order term's mean under the noise
out of the residual (:func:`classic.markerless.curvature.residual_under_noise`). Each test below shows the bias
without it, so that the one with it can fail.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from classic.markerless import point_to_plane
from classic.markerless.curvature import MIN_RAY_COSINE, residual_under_noise, second_order_residual
from classic.markerless.point_to_plane import MatchedModel, PlaneFitOptions, solve_point_to_plane
from handeye.core.se3 import make_transform
from tests.tolerances import FLOAT, SIGMA_BOUND

K = np.array([[220.0, 0.0, 128.0], [0.0, 220.0, 128.0], [0.0, 0.0, 1.0]])
#: A D435's depth noise at 1 m, metres (0.08 px subpixel over f B = 447 px x 50 mm), rounded up; it grows with
#: the depth squared.
STEREO_SIGMA_1M = 0.004
#: Noise draws: the mean of their estimates has the draws' own scatter over sqrt(DRAWS) as its standard error.
DRAWS = 30
#: The camera.
T_BASE_CAM = make_transform(Rotation.from_rotvec([0.2, -0.1, 0.05]).as_matrix(), [0.1, 0.2, -1.2])


def _rays(step: float) -> np.ndarray:
    """Pixel rays (unit depth) on a grid of ``step`` pixels, camera frame; shape (N, 3)."""
    u, v = (g.ravel() for g in np.meshgrid(np.arange(20, 236, step), np.arange(20, 236, step)))
    return np.c_[(u - K[0, 2]) / K[0, 0], (v - K[1, 2]) / K[1, 1], np.ones_like(u)]


def _planes():
    """Four planes at 1.0-1.3 m, one per image quadrant: each pixel's ray, its true depth, and the model (its point
    and normal on the ray, base frame)."""
    ray = _rays(3.0)
    normals = np.array([[0.5, 0.0, -1.0], [-0.5, 0.2, -1.0], [0.0, 0.6, -1.0], [0.1, -0.6, -1.0]])
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    quadrant = (ray[:, 0] > 0).astype(int) + 2 * (ray[:, 1] > 0).astype(int)
    n_cam = normals[quadrant]
    z = np.array([1.1, 1.2, 1.3, 1.0])[quadrant] * n_cam[:, 2] / np.einsum("ij,ij->i", n_cam, ray)
    R, t = T_BASE_CAM[:3, :3], T_BASE_CAM[:3, 3]
    return ray, z, ((ray * z[:, None]) @ R.T + t, n_cam @ R.T, None, None)


def _cylinders(radius: float = 0.04):
    """Twelve cylinders of a robot link's radius at 0.9-1.5 m across the image, their axes turned every way
    across the view: each ray that meets one, its true depth, and the model there (point, outward normal, principal
    curvatures ``(1 / radius, 0)`` and the first principal direction, base frame)."""
    rng = np.random.default_rng(11)
    ray = _rays(1.0)
    best = np.full(len(ray), np.inf)
    normal, direction = np.zeros_like(ray), np.zeros_like(ray)
    for centre_px in rng.uniform(40, 216, size=(12, 2)):
        depth = rng.uniform(0.9, 1.5)
        c = depth * np.r_[(centre_px - K[[0, 1], [2, 2]]) / K[0, 0], 1.0]
        axis = np.r_[rng.normal(size=2), 0.3 * rng.normal()]
        axis /= np.linalg.norm(axis)
        # the ray z * ray meets the cylinder |(z ray - c) x axis| = radius: a quadratic in z
        a_ = np.cross(ray, axis)
        b_ = np.cross(c, axis)
        A = np.einsum("ij,ij->i", a_, a_)
        B = -2 * a_ @ b_
        C = b_ @ b_ - radius**2
        disc = B**2 - 4 * A * C
        hit = disc > 0
        z = np.where(hit, (-B - np.sqrt(np.where(hit, disc, 0.0))) / (2 * A), 0.0)
        p = ray * z[:, None]
        radial = (p - c) - np.outer((p - c) @ axis, axis)
        n = radial / radius
        nearer = hit & (z > 0) & (z < best) & (np.einsum("ij,ij->i", n, ray) < -0.05)
        best[nearer] = z[nearer]
        normal[nearer] = n[nearer]
        direction[nearer] = np.cross(axis, n[nearer])
    seen = np.isfinite(best)
    ray, z, normal, direction = ray[seen], best[seen], normal[seen], direction[seen]
    R, t = T_BASE_CAM[:3, :3], T_BASE_CAM[:3, 3]
    curvatures = np.c_[np.full(len(z), 1 / radius), np.zeros(len(z))]
    return ray, z, ((ray * z[:, None]) @ R.T + t, normal @ R.T, curvatures, direction @ R.T)


def _intrinsics_errors(scene, noise_out: bool) -> np.ndarray:
    """``(f_x, f_y, c_x, c_y)`` estimated less the truth (pixels), one row per draw of the depth noise; with
    ``noise_out`` the fit is given the depth variance."""
    ray, z, (m, n, curvatures, direction) = scene
    variance = (STEREO_SIGMA_1M * z**2) ** 2
    model = MatchedModel(m, n, curvatures, direction, depth_variance=variance if noise_out else None)
    options = PlaneFitOptions(scale_m=0.05, loss="linear", iterations=8, covariance=False, intrinsics_K_ref=K)
    errors = []
    for draw in range(DRAWS):
        z_obs = z + np.sqrt(variance) * np.random.default_rng([draw, 7]).normal(size=z.shape)
        fit = solve_point_to_plane(ray * z_obs[:, None], model, T_BASE_CAM, options)
        errors.append(fit.intrinsics - K[[0, 1, 0, 1], [0, 1, 2, 2]])
    return np.array(errors)


def _standard_errors(errors: np.ndarray) -> np.ndarray:
    """Each column's mean over its standard error (the draws' scatter over sqrt(DRAWS))."""
    return errors.mean(0) / (errors.std(0, ddof=1) / np.sqrt(len(errors)))


@pytest.mark.parametrize("scene", [_planes, _cylinders], ids=["planes", "cylinders"])
def test_the_intrinsics_are_unbiased_under_a_stereo_cameras_depth_noise(scene):
    """Each intrinsic's mean error over the draws within SIGMA_BOUND of its standard error (P(|t_29| > 4) < 5e-4)."""
    t = _standard_errors(_intrinsics_errors(scene(), noise_out=True))
    assert np.all(np.abs(t) <= SIGMA_BOUND), t


@pytest.mark.parametrize("scene", [_planes, _cylinders], ids=["planes", "cylinders"])
def test_without_the_depth_variance_the_noise_biases_them(scene):
    """The test above can fail: the same draws, the fit not given the depth variance, put an intrinsic's mean
    beyond SIGMA_BOUND standard errors."""
    t = _standard_errors(_intrinsics_errors(scene(), noise_out=False))
    assert np.max(np.abs(t)) > SIGMA_BOUND, t


def test_without_noise_it_is_the_second_order_residual():
    """Given a zero variance, the residual and gradient are second_order_residual's at the observed point (moved
    onto the tangent plane, the point changes the gradient by curvature times the move only, 0 on the surface)."""
    ray, z, (m, n, curvatures, direction) = _cylinders()
    x = (ray * z[:, None]) @ T_BASE_CAM[:3, :3].T + T_BASE_CAM[:3, 3]
    ray_base = ray @ T_BASE_CAM[:3, :3].T
    r, grad, move = residual_under_noise(x, m, n, curvatures, direction, ray_base, np.zeros(len(z)))
    r0, grad0 = second_order_residual(x, m, n, curvatures, direction)
    np.testing.assert_allclose(r, r0, atol=FLOAT)
    np.testing.assert_allclose(grad, grad0, atol=FLOAT)
    np.testing.assert_array_equal(move, 0.0)


#: A stereo camera's f B, pixels x metres (a D435's 447 px x 50 mm), for the pixel locking's columns.
STEREO_FB_PX_M = 22.35


@pytest.mark.parametrize(
    "intrinsics, locking", [(False, False), (True, False), (True, True)], ids=["pose", "intrinsics", "locking"]
)
def test_the_columns_are_the_derivative_at_the_point_moved_onto_the_surface(intrinsics, locking):
    """Given the depth variance, the rotation's, the depth correction's (with a stereo camera's pixel locking too:
    its phase moves with the depth), the intrinsics' and the translation's columns equal the residual's derivative
    (the plain second-order fit's) at the observed point moved along its ray onto the matched tangent plane, on
    every row seen at more than MIN_RAY_COSINE. The locking's columns taken at the observed depth instead put the
    focal length 0.1-0.15 px high on `paper-real` under a white noise (``docs/benchmarks/markerless.md``)."""
    ray, z, (m, n, curvatures, direction) = _cylinders()
    z_obs = z + 0.004 * np.random.default_rng(3).normal(size=z.shape)
    k, c = 1.01, -0.004  # the depth correction: p = k q_obs + c ray
    # with the locking (a, b) at 0, where a fit starts it: its columns (the phase's sine and cosine times z^2 / f B)
    # still change with the depth, the correction does not bend the ray's depth
    depth = (k, c, 0.0, 0.0) if locking else (k, c)
    opts = PlaneFitOptions(
        scale_m=1.0,
        depth_start=depth,
        intrinsics_K_ref=K if intrinsics else None,
        stereo_fb_px_m=STEREO_FB_PX_M if locking else None,
    )
    unknowns = point_to_plane._Unknowns(opts, None)
    noisy = MatchedModel(m, n, curvatures, direction, depth_variance=np.full(len(z), 1.0))  # no move cut short
    _, J_moved = point_to_plane._linearise(ray * z_obs[:, None], noisy, T_BASE_CAM, unknowns)
    fb = STEREO_FB_PX_M if locking else None
    x = point_to_plane.corrected_points(ray * z_obs[:, None], *depth, stereo_fb_px_m=fb) @ T_BASE_CAM[:3, :3].T
    x += T_BASE_CAM[:3, 3]
    ray_base = ray @ T_BASE_CAM[:3, :3].T
    _, _, move = residual_under_noise(x, m, n, curvatures, direction, ray_base, noisy.depth_variance)
    z_on_plane = z_obs - move / k  # the raw depth whose corrected point is the moved one
    plain = MatchedModel(m, n, curvatures, direction)
    _, J_on = point_to_plane._linearise(ray * z_on_plane[:, None], plain, T_BASE_CAM, unknowns)
    seen = np.abs(np.einsum("ij,ij->i", n, ray_base)) > MIN_RAY_COSINE
    assert seen.mean() > 0.5
    np.testing.assert_allclose(J_moved[seen], J_on[seen], rtol=FLOAT, atol=FLOAT)
