"""The depth noise does not bias the intrinsics or the pose the point-to-plane fit estimates (issue 41).

The observed depth sits in the Jacobian's rotation, depth-scale and intrinsics columns; taken there as observed, its
noise biases what those columns estimate (errors in variables): on the planes below, with a D435's noise, the focal
length came out about 0.9 px high and the principal point's ``c_y`` 3.2 px low, 13 and 25 of the mean's standard
errors. Taken at the model's point on each pixel's ray (:func:`classic.markerless.point_to_plane._at_model_depth`)
the columns hold no noise.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from classic.markerless import point_to_plane
from classic.markerless.point_to_plane import MatchedModel, PlaneFitOptions, solve_point_to_plane
from handeye.core.se3 import make_transform
from tests.tolerances import FLOAT, SIGMA_BOUND

K = np.array([[220.0, 0.0, 128.0], [0.0, 220.0, 128.0], [0.0, 0.0, 1.0]])
#: A D435's depth noise at 1 m, metres (0.08 px subpixel over f B = 447 px x 50 mm), rounded up.
STEREO_SIGMA_1M = 0.004
#: Noise draws: the mean of their estimates has the draws' own scatter over sqrt(DRAWS) as its standard error.
DRAWS = 30


def _planes():
    """Four planes at 1.0-1.3 m, one per image quadrant, seen by a camera at ``T_base_cam``: each pixel's ray, its
    true depth, and the model's point and normal in the base frame."""
    T_base_cam = make_transform(Rotation.from_rotvec([0.2, -0.1, 0.05]).as_matrix(), [0.1, 0.2, -1.2])
    u, v = (g.ravel() for g in np.meshgrid(np.arange(20, 236, 3.0), np.arange(20, 236, 3.0)))
    ray = np.c_[(u - K[0, 2]) / K[0, 0], (v - K[1, 2]) / K[1, 1], np.ones_like(u)]
    normals = np.array([[0.5, 0.0, -1.0], [-0.5, 0.2, -1.0], [0.0, 0.6, -1.0], [0.1, -0.6, -1.0]])
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    quadrant = (u > K[0, 2]).astype(int) + 2 * (v > K[1, 2]).astype(int)
    n_cam = normals[quadrant]
    z = np.array([1.1, 1.2, 1.3, 1.0])[quadrant] * n_cam[:, 2] / np.einsum("ij,ij->i", n_cam, ray)
    model = MatchedModel((ray * z[:, None]) @ T_base_cam[:3, :3].T + T_base_cam[:3, 3], n_cam @ T_base_cam[:3, :3].T)
    return T_base_cam, ray, z, model


def _intrinsics_errors() -> np.ndarray:
    """``(f_x, f_y, c_x, c_y)`` estimated less the truth (pixels), one row per draw of the depth noise."""
    T_base_cam, ray, z, model = _planes()
    options = PlaneFitOptions(scale_m=0.05, loss="linear", iterations=8, covariance=False, intrinsics_K_ref=K)
    errors = []
    for draw in range(DRAWS):
        z_obs = z + STEREO_SIGMA_1M * z**2 * np.random.default_rng([draw, 7]).normal(size=z.shape)
        fit = solve_point_to_plane(ray * z_obs[:, None], model, T_base_cam, options)
        errors.append(fit.intrinsics - K[[0, 1, 0, 1], [0, 1, 2, 2]])
    return np.array(errors)


def _standard_errors(errors: np.ndarray) -> np.ndarray:
    """Each column's mean over its standard error (the draws' scatter over sqrt(DRAWS))."""
    return errors.mean(0) / (errors.std(0, ddof=1) / np.sqrt(len(errors)))


def test_the_intrinsics_are_unbiased_under_a_stereo_cameras_depth_noise():
    """Each intrinsic's mean error over the draws within SIGMA_BOUND of its standard error (P(|t_29| > 4) < 5e-4)."""
    t = _standard_errors(_intrinsics_errors())
    assert np.all(np.abs(t) <= SIGMA_BOUND), t


def test_the_observed_depth_in_the_jacobian_biases_them(monkeypatch):
    """The test above can fail: with the Jacobian's columns at the observed points (the residuals' derivative), the
    same draws put the focal lengths' or the principal point's mean beyond SIGMA_BOUND standard errors."""
    monkeypatch.setattr(point_to_plane, "_at_model_depth", lambda *args: None)
    t = _standard_errors(_intrinsics_errors())
    assert np.max(np.abs(t)) > SIGMA_BOUND, t


@pytest.mark.parametrize("intrinsics", [False, True])
def test_the_columns_are_the_derivative_at_the_models_point_on_the_ray(intrinsics):
    """The rotation's, the depth scale's and the intrinsics' columns equal the residual's derivative taken at the
    observed point moved along its ray onto the matched plane (where the residual is 0)."""
    T_base_cam, ray, z, model = _planes()
    rng = np.random.default_rng(3)
    z_obs = z + 0.01 * rng.normal(size=z.shape)
    k, c = 1.01, -0.004  # the depth correction: p = k q_obs + c ray
    opts = PlaneFitOptions(scale_m=1.0, depth_start=(k, c), intrinsics_K_ref=K if intrinsics else None)
    unknowns = point_to_plane._Unknowns(opts, None)
    r, J_model = point_to_plane._linearise(ray * z_obs[:, None], model, T_base_cam, unknowns)
    n_ray = np.einsum("ij,ij->i", model.normals_base @ T_base_cam[:3, :3], ray)
    z_on_plane = z_obs - r / n_ray / k  # the raw depth whose corrected point lies on the plane
    r_on, J_on = point_to_plane._linearise(ray * z_on_plane[:, None], model, T_base_cam, unknowns, at_model=False)
    np.testing.assert_allclose(r_on, 0.0, atol=FLOAT)
    np.testing.assert_allclose(J_model[:, :3], J_on[:, :3], rtol=FLOAT, atol=FLOAT)
    np.testing.assert_allclose(J_model[:, 6:], J_on[:, 6:], rtol=FLOAT, atol=FLOAT)
