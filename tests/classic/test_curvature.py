"""Curvature of sampled surfaces, and the second-order residual that removes the markerless fit's sampling bias.

On a sphere and a cylinder the normals are linear in the position over the tangent plane, so the
neighbour fit is exact (float round-off); on a plane and across a box's creases it is zero.
"""

from __future__ import annotations

import numpy as np
import pytest

from classic.markerless import MarkerlessOptions, RobotSurfaceFrames, register_robot
from classic.markerless.curvature import sample_curvatures, second_order_residual
from handeye.core.errors import HandEyeInputError
from handeye.core.metrics import pose_error
from tests.classic.test_markerless import F_PX, RADII, K, _bias_bounds, _scene
from tests.tolerances import ABSOLUTE_ONLY, FLOAT, POINT_ROUNDING_EPS


def _fibonacci_sphere(n, r):
    g = np.arange(n) + 0.5
    phi, theta = np.arccos(1 - 2 * g / n), np.pi * (1 + 5**0.5) * g
    u = np.column_stack([np.cos(theta) * np.sin(phi), np.sin(theta) * np.sin(phi), np.cos(phi)])
    return r * u, u


def test_sphere_has_both_curvatures_one_over_r():
    p, n = _fibonacci_sphere(4000, 0.05)
    kappa, direction = sample_curvatures(p, n, radius_m=0.006)
    np.testing.assert_allclose(kappa, 1 / 0.05, rtol=FLOAT)
    np.testing.assert_allclose(np.einsum("ij,ij->i", direction, n), 0.0, atol=FLOAT)


def test_cylinder_curves_across_its_axis_only(rng):
    r = 0.04
    theta, z = rng.uniform(0, 2 * np.pi, 6000), rng.uniform(-0.15, 0.15, 6000)
    n = np.column_stack([np.cos(theta), np.sin(theta), np.zeros_like(theta)])
    kappa, direction = sample_curvatures(np.column_stack([r * n[:, :2], z]), n, radius_m=0.008)
    inner = np.abs(z) < 0.14  # away from the open ends
    np.testing.assert_allclose(kappa[inner, 0], 1 / r, rtol=FLOAT)
    np.testing.assert_allclose(kappa[inner, 1], 0.0, atol=FLOAT)
    np.testing.assert_allclose(np.abs(direction[inner, 2]), 0.0, atol=FLOAT)  # across the axis


def test_a_box_has_no_curvature_on_its_faces_or_across_its_creases():
    import trimesh

    box = trimesh.creation.box((0.1, 0.1, 0.1))
    p, face = trimesh.sample.sample_surface(box, 6000, seed=3)
    kappa, _ = sample_curvatures(np.asarray(p), box.face_normals[face], radius_m=0.008)
    np.testing.assert_allclose(kappa, 0.0, atol=FLOAT)


def test_second_order_residual_on_a_sphere_leaves_exactly_the_fourth_order_term(rng):
    """A point on a sphere at chord d from the sample (angle t between them): the first-order residual is
    r (cos t - 1) = -d^2/2r, the tangential offset r sin t, so the second-order one is exactly -d^4/8r^3;
    the gradient n + S d is x_dir + (1 - cos t) m_dir = x_dir + d^2/(2 r^2) m_dir."""
    r, n_pts = 0.05, 200
    m_dir = rng.normal(size=(n_pts, 3))
    m_dir /= np.linalg.norm(m_dir, axis=1, keepdims=True)
    x_dir = m_dir + rng.normal(scale=0.05, size=m_dir.shape)  # offsets up to ~5 mm
    x_dir /= np.linalg.norm(x_dir, axis=1, keepdims=True)
    m, x = r * m_dir, r * x_dir
    e1 = np.cross(m_dir, [0, 0, 1.0])
    e1 /= np.linalg.norm(e1, axis=1, keepdims=True)
    res, grad = second_order_residual(x, m, m_dir, np.full((n_pts, 2), 1 / r), e1)
    d = np.linalg.norm(x - m, axis=1)
    rounding = dict(atol=POINT_ROUNDING_EPS * r, rtol=ABSOLUTE_ONLY)  # both are remainders of points of size r
    np.testing.assert_allclose(np.einsum("ij,ij->i", m_dir, x - m), -(d**2) / (2 * r), **rounding)
    np.testing.assert_allclose(res, -(d**4) / (8 * r**3), **rounding)
    np.testing.assert_allclose(grad, x_dir + (d**2 / (2 * r**2))[:, None] * m_dir, atol=FLOAT)


def test_a_second_order_fit_removes_the_sampling_bias():
    """Noise-free spheres: the first-order fit is off by up to the sampling bias; with the spheres' curvature
    estimated from the samples the error falls to the fourth-order term F^4 / (8 r^3) of a pixel footprint F.
    The depth noise is the frames' own, measured on the static background (the front's default): told a noise
    the frames do not have, the fit would take that noise's mean out of the residual
    (:func:`classic.markerless.curvature.residual_under_noise`) and move the answer by as much."""
    depth, s, T_true = _scene(np.random.default_rng(1), noise=False)
    spacing = 0.7 * 0.8 / F_PX
    kappa, direction = np.zeros((len(s.part), 2)), np.zeros((len(s.part), 3))
    for key in np.unique(s.part * 100 + s.frame):
        sel = s.part * 100 + s.frame == key
        kappa[sel], direction[sel] = sample_curvatures(s.points_base[sel], s.normals_base[sel], 2.5 * spacing)
    curved = RobotSurfaceFrames(
        s.points_base, s.normals_base, s.frame, s.part, curvatures=kappa, direction_base=direction
    )
    opts = MarkerlessOptions()
    rot_first, trans_first = pose_error(register_robot(depth, K, s, options=opts).require(), T_true)
    rot_second, trans_second = pose_error(register_robot(depth, K, curved, options=opts).require(), T_true)
    footprint = depth[depth > 0].max() / F_PX
    fourth_mm = footprint**4 / (8 * RADII.min() ** 3) * 1e3
    bias_mm, bias_deg = _bias_bounds(depth)
    assert trans_second <= fourth_mm
    assert rot_second <= bias_deg * fourth_mm / bias_mm
    assert trans_second < trans_first / 10 and rot_second < rot_first / 10


def test_curvatures_come_with_their_directions(scene):
    _, s, _ = scene
    with pytest.raises(HandEyeInputError, match="together"):
        RobotSurfaceFrames(s.points_base, s.normals_base, s.frame, s.part, curvatures=np.zeros((len(s.part), 2)))


@pytest.fixture(scope="module")
def scene():
    return _scene(np.random.default_rng(0))
