"""The per-frame check at a D435's native 848x480 over 87 degrees: its work chosen by the focal length
(``CheckOptions.factor_for``), the statistic still ``chi2(6)`` when nothing moved, a moved camera still seen.

The analytic spheres (tests/classic/test_markerless.py) ray-cast at 848x480: the floor over the whole image, the
spheres in the window that holds them (the same camera, its principal point moved) over the floor's depth cast
once, so a frame costs a tenth of a full ray-cast."""

from __future__ import annotations

from functools import lru_cache

import numpy as np
import pytest
from scipy import stats

from handeye.core.errors import HandEyeInputError
from handeye.core.se3 import make_transform, so3_exp
from handeye.robot.depth_sensors import sensor_profile
from handeye.watch.change import CHI2_6_MEDIAN, fit_null
from handeye.watch.check import CheckOptions, check_frame
from tests.classic.test_markerless import RADII, SIGMA_1M, render_depth, sphere_model
from tests.tolerances import WATCH_STATISTIC_SCALE_SDS, WATCH_STATISTIC_TAIL
from tests.watch.test_cell import T_TRUE

W, H, HFOV_DEG = 848, 480, 87.0
F_PX = (W / 2) / np.tan(np.radians(HFOV_DEG) / 2)  # 446.8 px
K = np.array([[F_PX, 0, (W - 1) / 2], [0, F_PX, (H - 1) / 2], [0, 0, 1.0]])
#: Frames the null is fitted on, and frames tested after it.
NULL_FRAMES, TESTED_FRAMES = 40, 10
#: The camera moved by 1 mm and 0.1 deg: a fifth of the running-cell benchmark's smallest bump but one.
MOVE = make_transform(so3_exp(np.radians(0.1) * np.array([0.6, 0.0, 0.8])), 1e-3 * np.array([0.0, 0.6, 0.8]))


@lru_cache(maxsize=1)
def _floor() -> np.ndarray:
    """The floor's noiseless depth over the whole image (read-only)."""
    floor = render_depth(np.zeros((1, 0, 3)), T_TRUE, None, radii=(), K=K, size=(H, W))[0]
    floor.flags.writeable = False
    return floor


def _frame(rng):
    """One frame: depth (H, W) and the spheres' surface sampled for the check's stride (``factor`` 2)."""
    centres = np.vstack([[0, 0, 0.09], rng.uniform([-0.3, -0.3, 0.25], [0.3, 0.3, 0.65], size=(3, 3))])[None]
    floor = _floor()
    depth = floor + rng.normal(size=floor.shape) * SIGMA_1M * floor**2  # render_depth's noise
    c_cam = (centres[0] - T_TRUE[:3, 3]) @ T_TRUE[:3, :3]
    uv = c_cam[:, :2] / c_cam[:, 2:] * F_PX + K[:2, 2]
    reach = RADII * F_PX / (c_cam[:, 2] - RADII) + 2  # each sphere's outline within this many pixels of its centre
    u0, v0 = np.maximum(np.floor((uv - reach[:, None]).min(0)).astype(int), 0)
    u1, v1 = np.minimum(np.ceil((uv + reach[:, None]).max(0)).astype(int) + 1, [W, H])
    K_win = K.copy()
    K_win[:2, 2] -= [u0, v0]
    depth[v0:v1, u0:u1] = render_depth(centres, T_TRUE, rng, K=K_win, size=(v1 - v0, u1 - u0))[0]
    return depth, sphere_model(centres, f_px=F_PX / CheckOptions().factor_for(K))


def test_a_native_d435_frame_is_checked_at_256x256s_work_with_the_null_kept_and_a_move_seen():
    """The factor is 2 (z-buffer stride 2); the null fitted on NULL_FRAMES frames; TESTED_FRAMES fresh frames at
    the truth have each x within chi2(6)'s upper WATCH_STATISTIC_TAIL / TESTED_FRAMES quantile, widened by the
    fitted scale's own error: c from the median of N frames has relative sd 1 / (2 sqrt(N) f(m) m) (m chi2(6)'s
    median, f its density there; tests/watch/test_change.py), and x over c_hat / c, so the bound over
    1 - WATCH_STATISTIC_SCALE_SDS of those. The same frames checked with the camera moved by 1 mm / 0.1 deg
    have each x beyond that bound."""
    options = CheckOptions()
    assert options.factor_for(K) == 2 and options.stride_for(K) == 2
    assert CheckOptions(reference_focal_px=0.0).stride_for(K) == 1
    rng = np.random.default_rng(0)
    sigma_m = sensor_profile("ideal").sigma_m
    null_checks = [check_frame(d, K, m, T_TRUE, sigma_m) for d, m in (_frame(rng) for _ in range(NULL_FRAMES))]
    null = fit_null(np.array([c.delta for c in null_checks]), np.array([c.covariance for c in null_checks]))
    scale_sd = 1.0 / (2 * np.sqrt(NULL_FRAMES) * stats.chi2.pdf(CHI2_6_MEDIAN, 6)) / CHI2_6_MEDIAN
    bound = stats.chi2.isf(WATCH_STATISTIC_TAIL / TESTED_FRAMES, 6) / (1 - WATCH_STATISTIC_SCALE_SDS * scale_sd)
    x_true, x_moved = [], []
    for depth, model in (_frame(rng) for _ in range(TESTED_FRAMES)):
        check = check_frame(depth, K, model, T_TRUE, sigma_m)
        x_true.append(null.statistic(check.delta, check.covariance))
        # the depth seen from T_TRUE checked against a calibration off by MOVE: the camera moved by its inverse
        off = check_frame(depth, K, model, T_TRUE @ MOVE, sigma_m)
        x_moved.append(null.statistic(off.delta, off.covariance))
        if len(x_true) == 1:  # the stride chosen is the z-buffer's: as with stride 2 given and the choice off
            given = CheckOptions(zbuffer_stride=2, reference_focal_px=0)
            assert check_frame(depth, K, model, T_TRUE, sigma_m, given).chi2 == check.chi2
    assert max(x_true) <= bound, (np.round(x_true, 1), bound)
    assert min(x_moved) > bound, (np.round(x_moved, 1), bound)


def test_a_thinned_surface_keeps_every_kth_sample_of_each_part_posed_the_same():
    """``RobotSurface.thinned(4)``, which the watcher poses for a factor 2: each part's every 4th sample, posed
    exactly as the whole surface poses it (the same arrays, the same transforms)."""
    pytest.importorskip("pinocchio")
    from handeye.robot.model import load_robot
    from handeye.robot.surface import RobotSurface

    surface = RobotSurface(load_robot("ur5"), spacing_m=0.02)
    thin = surface.thinned(4)
    assert surface.thinned(1) is surface
    q = np.array([[0.3, -1.2, 1.4, -0.5, 1.1, 0.2]])
    whole, part = surface.posed(q, twists=False), thin.posed(q, twists=False)
    keep = np.concatenate([np.flatnonzero(whole.part == k)[::4] for k in range(len(surface.parts))])
    assert thin.n_points == len(keep) < surface.n_points
    np.testing.assert_array_equal(part.points_base, whole.points_base[keep])
    np.testing.assert_array_equal(part.normals_base, whole.normals_base[keep])
    with pytest.raises(HandEyeInputError, match="every must be >= 1"):
        surface.thinned(0)


def test_the_watcher_poses_the_surface_thinned_by_the_factors_square():
    """At 848x480 over 87 degrees the watcher's check poses ``thinned(4)``; at the analytic scenes' 160x120 (focal
    length 150 px, factor 1) the surface whole; a surface without ``thinned`` is posed whole."""
    from handeye.watch import CellWatcher
    from tests.classic.test_markerless import K as K_SMALL
    from tests.watch.test_cell import Spheres

    class Thinnable(Spheres):
        asked = []

        def thinned(self, every):
            self.asked.append(every)
            return self

    sensor = sensor_profile("ideal")
    CellWatcher(Thinnable(), K, T_TRUE, sensor)
    CellWatcher(Thinnable(), K_SMALL, T_TRUE, sensor)
    CellWatcher(Spheres(), K, T_TRUE, sensor)  # no thinned: no error
    assert Thinnable.asked == [4]
