"""The split check: the frames' halves solved again, their disagreement beyond their noise added to the sigma."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from classic.markerless import MarkerlessOptions, register_robot
from classic.markerless.consistency import MIN_FRAMES_PER_HALF, frame_splits, split_excess
from handeye.core.metrics import pose_error
from handeye.core.se3 import make_transform, so3_exp
from tests.classic.test_markerless import SIGMA_1M, K, _bias_bounds, _scene
from tests.tolerances import FLOAT, SIGMA_BOUND


def _halves(d_rot_rad, d_trans_m, sd_m, sd_rad):
    """A ``solve`` whose two halves differ by exactly the given rotation and translation, each half with
    the given per-axis sigmas."""
    C = np.diag([sd_rad**2] * 3 + [sd_m**2] * 3)
    T_b = make_transform(so3_exp(np.asarray(d_rot_rad)), np.asarray(d_trans_m))
    answers = iter([(np.eye(4), C), (T_b, C)])
    return lambda mask: next(answers)


def test_the_excess_is_a_quarter_of_what_the_noise_does_not_explain():
    frame = np.repeat(np.arange(8), 5)
    splits = {"near/far": np.arange(8) < 4}
    # 10 mm apart with 1 mm per axis in each half: 100 - 6 mm^2 unexplained, a quarter of it is 23.5 mm^2
    out = split_excess(_halves([0.002, 0, 0], [0.010, 0, 0], 0.001, 0.0005), frame, splits)
    assert abs(out["translation_mm"] - np.sqrt((100 - 6) / 4)) < 1e3 * FLOAT
    expected_rad2 = (0.002**2 - 6 * 0.0005**2) / 4
    assert abs(out["rotation_deg"] - np.degrees(np.sqrt(expected_rad2))) < 1e3 * FLOAT
    assert abs(out["splits"]["near/far"]["difference_mm"] - 10.0) < 1e3 * FLOAT
    assert abs(out["splits"]["near/far"]["expected_mm"] - np.sqrt(6)) < 1e3 * FLOAT


def test_halves_within_their_noise_add_nothing():
    frame = np.repeat(np.arange(8), 5)
    within = _halves([0, 0, 0], [0.001, 0.001, 0], 0.001, 0.001)
    out = split_excess(within, frame, {"left/right": np.arange(8) % 2 == 0})
    assert out["translation_mm"] == 0.0 and out["rotation_deg"] == 0.0
    assert split_excess(lambda mask: None, frame, {}) == {"rotation_deg": 0.0, "translation_mm": 0.0, "splits": {}}


def test_frames_are_split_by_depth_and_by_image_column():
    n_frames, per = 10, 20
    frame = np.repeat(np.arange(n_frames), per)
    z = np.repeat(np.linspace(0.8, 1.7, n_frames), per)  # frame i at depth 0.8 + 0.1 i
    x = np.repeat(np.linspace(0.3, -0.3, n_frames), per) * z  # and farther left as it is farther away
    splits = frame_splits(frame, np.c_[x, np.zeros_like(z), z], n_frames)
    assert list(splits["near/far"]) == [True] * 5 + [False] * 5
    assert list(splits["left/right"]) == [False] * 5 + [True] * 5
    # a half with fewer frames than a clustered covariance needs: the split is left out
    few = MIN_FRAMES_PER_HALF * 2 - 1
    f = np.repeat(np.arange(few), per)
    assert frame_splits(f, np.c_[np.zeros((len(f), 2)), np.ones(len(f))], few) == {}


def test_the_registration_adds_the_halves_disagreement_to_its_sigma():
    """On the analytic scene (12 frames: 6 per half), the sigma is the noise, the sampling bound and the
    halves' disagreement in quadrature; without the check it is the first two only, and the answer the same."""
    depth, surface, T_true = _scene(np.random.default_rng(5), n_frames=12)
    opts = MarkerlessOptions(depth_sigma_m_at_1m=SIGMA_1M)
    res = register_robot(depth, K, surface, options=opts)
    assert res.ok, res.refused
    d = res.diagnostics
    assert set(d["sigma_consistency"]["splits"]) == {"near/far", "left/right"}
    for key in ("rotation_deg", "translation_mm"):
        parts = [d["sigma_noise"][key], d["sigma_sampling"][key], d["sigma_consistency"][key]]
        assert abs(res.sigma[key] - np.sqrt(np.sum(np.square(parts)))) <= 1e3 * FLOAT * res.sigma[key]
    rot_deg, trans_mm = pose_error(res.T_base_cam, T_true)
    bias_mm, bias_deg = _bias_bounds(depth)
    assert trans_mm <= SIGMA_BOUND * res.sigma["translation_mm"] + bias_mm
    assert rot_deg <= SIGMA_BOUND * res.sigma["rotation_deg"] + bias_deg
    plain = register_robot(depth, K, surface, options=replace(opts, split_check=False))
    assert plain.diagnostics["sigma_consistency"] is None
    assert np.array_equal(plain.T_base_cam, res.T_base_cam)
    assert plain.sigma["translation_mm"] <= res.sigma["translation_mm"]
