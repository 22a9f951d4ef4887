"""The foundation's measurement-space pose fit: its residuals' Jacobian and what it leaves out."""

from __future__ import annotations

import numpy as np

from handeye.core.keypoint_fit import CAUCHY_SCALE, backproject, likelihood_fit, project, whitened_residuals
from handeye.core.se3 import make_transform, so3_exp
from tests.tolerances import ABSOLUTE_ONLY, FLOAT, JACOBIAN_RTOL, KEYPOINT_FIT_AGREEMENT


def _scene(rng, m=40):
    T_base_cam = make_transform(so3_exp(rng.normal(size=3)), rng.normal(size=3))
    p_cam = rng.uniform(-0.4, 0.4, (m, 3)) + [0.0, 0.0, 1.5]
    p_base = p_cam @ T_base_cam[:3, :3].T + T_base_cam[:3, 3]
    intr = np.tile([0.9, 0.85, 0.5, 0.48], (m, 1))
    meas = np.column_stack(
        [
            intr[:, 0] * p_cam[:, 0] / p_cam[:, 2] + intr[:, 2],
            intr[:, 1] * p_cam[:, 1] / p_cam[:, 2] + intr[:, 3],
            p_cam[:, 2],
        ]
    )
    return T_base_cam, p_base, intr, meas


def test_projection_is_the_pinhole_in_normalised_units_and_backprojection_inverts_it(rng):
    """``project`` against the scene's hand-written pinhole; ``backproject`` gives the camera-frame points back."""
    T, p_base, intr, meas = _scene(rng)
    p_cam = (p_base - T[:3, 3]) @ T[:3, :3]  # T_cam_base p_base
    np.testing.assert_allclose(project(p_cam, intr), meas, atol=FLOAT)
    np.testing.assert_allclose(backproject(meas, intr), p_cam, atol=FLOAT)
    # one intrinsics row broadcast over a batch of point sets
    np.testing.assert_allclose(project(p_cam[None], intr[0]), meas[None], atol=FLOAT)


def test_the_jacobian_is_the_derivative_of_the_residuals_under_the_fits_update(rng):
    """The update is ``p_cam <- exp(dw) p_cam + dv``, i.e. ``T_cam_base <- [exp(dw), dv] T_cam_base``."""
    T, p_base, intr, meas = _scene(rng)
    sigma = rng.uniform(0.5, 2.0, meas.shape) * [1e-3, 1e-3, 1e-2]
    T0 = T @ make_transform(so3_exp(rng.normal(size=3) * 0.01), rng.normal(size=3) * 0.01)  # off the truth
    r0, J, ok = whitened_residuals(meas, p_base, intr, sigma, T0)
    assert ok.all()
    h = 1e-6
    for k in range(6):
        d = np.zeros(6)
        d[k] = h
        E = make_transform(so3_exp(d[:3]), d[3:])
        r_plus = whitened_residuals(meas, p_base, intr, sigma, np.linalg.inv(E @ np.linalg.inv(T0)))[0]
        E = make_transform(so3_exp(-d[:3]), -d[3:])
        r_minus = whitened_residuals(meas, p_base, intr, sigma, np.linalg.inv(E @ np.linalg.inv(T0)))[0]
        np.testing.assert_allclose(
            J[..., k], (r_plus - r_minus) / (2 * h), rtol=ABSOLUTE_ONLY, atol=JACOBIAN_RTOL * np.abs(J).max()
        )


def test_exact_measurements_have_zero_residual_and_points_behind_or_missing_are_left_out(rng):
    T, p_base, intr, meas = _scene(rng)
    r, J, ok = whitened_residuals(meas, p_base, intr, np.ones(3), T)
    np.testing.assert_allclose(r, 0.0, atol=FLOAT)
    meas[0, 2] = -1.0
    meas[1] = np.nan
    r, J, ok = whitened_residuals(meas, p_base, intr, np.ones(3), T)
    assert not ok[:2].any() and ok[2:].all()
    assert (r[:2] == 0).all() and (J[:2] == 0).all()
    T_fit, weights = likelihood_fit(meas[None], p_base[None], intr[None], np.ones(3), T[None])
    np.testing.assert_allclose(T_fit[0], T, atol=FLOAT)
    assert (weights[0, :2] == 0).all()


def test_the_batched_fit_reaches_scipys_minimum_of_the_same_cost(rng):
    """:func:`likelihood_fit` on three sets at once against ``scipy.optimize.least_squares`` (loss "cauchy", the
    same scale) on each: the same minimum, to far below the noise (1e-6 m against millimetres)."""
    from scipy.optimize import least_squares
    from scipy.spatial.transform import Rotation

    sigma = np.array([0.004, 0.004, 0.02])
    scenes = [_scene(rng, 60) for _ in range(3)]
    noisy = [meas + rng.normal(size=meas.shape) * sigma for _, _, _, meas in scenes]
    for meas in noisy:
        meas[0] += [0.1, -0.1, 0.3]  # one gross outlier for the loss to bend on
    T_true = np.stack([s[0] for s in scenes])
    T_fit, _ = likelihood_fit(
        np.stack(noisy), np.stack([s[1] for s in scenes]), np.stack([s[2] for s in scenes]), sigma, T_true
    )
    for (T0, p_base, intr, _), meas, T in zip(scenes, noisy, T_fit):

        def residuals(x, p_base=p_base, intr=intr, meas=meas):
            p = p_base @ Rotation.from_rotvec(x[:3]).as_matrix().T + x[3:]
            model = np.column_stack(
                [intr[:, 0] * p[:, 0] / p[:, 2] + intr[:, 2], intr[:, 1] * p[:, 1] / p[:, 2] + intr[:, 3], p[:, 2]]
            )
            return ((meas - model) / sigma).ravel()

        T_cam_base = np.linalg.inv(T0)
        x0 = np.r_[Rotation.from_matrix(T_cam_base[:3, :3]).as_rotvec(), T_cam_base[:3, 3]]
        ref = least_squares(residuals, x0, loss="cauchy", f_scale=CAUCHY_SCALE, xtol=1e-15, ftol=1e-15, gtol=1e-15)
        T_cam_base_ref = make_transform(Rotation.from_rotvec(ref.x[:3]).as_matrix(), ref.x[3:])
        np.testing.assert_allclose(T, np.linalg.inv(T_cam_base_ref), atol=KEYPOINT_FIT_AGREEMENT)
        assert np.linalg.norm(T[:3, 3] - T0[:3, 3]) > 1e-4  # the noise moved it: not both staying at the start
