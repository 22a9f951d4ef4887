"""The split check: groups of the frames solved again, their scatter beyond their noise added to the sigma."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from classic.markerless import MarkerlessOptions, register_robot
from classic.markerless.consistency import MAX_GROUPS, MIN_FRAMES_PER_GROUP, frame_splits, split_excess
from handeye.core.metrics import pose_error
from handeye.core.se3 import make_transform, so3_exp
from tests.classic.test_markerless import SIGMA_1M, K, _bias_bounds, _scene
from tests.tolerances import FLOAT, SIGMA_BOUND


def _groups(answers_t_m, answers_rot_rad, sd_m, sd_rad):
    """A ``solve`` that answers group ``g`` with the given translation and rotation vector, each with the given
    per-axis sigmas (in the order the groups are asked for)."""
    C = np.diag([sd_rad**2] * 3 + [sd_m**2] * 3)
    answers = iter(
        [(make_transform(so3_exp(np.asarray(w)), np.asarray(t)), C) for t, w in zip(answers_t_m, answers_rot_rad)]
    )
    return lambda mask: next(answers)


def test_two_groups_add_a_quarter_of_what_the_noise_does_not_explain():
    frame = np.repeat(np.arange(8), 5)
    splits = {"depth": np.repeat([0, 1], 4)}
    # 10 mm apart with 1 mm per axis in each: 100 - 6 mm^2 unexplained, a quarter of it is 23.5 mm^2
    solve = _groups([[0, 0, 0], [0.010, 0, 0]], [[0, 0, 0], [0.002, 0, 0]], 0.001, 0.0005)
    out = split_excess(solve, frame, splits)
    assert abs(out["translation_mm"] - np.sqrt((100 - 6) / 4)) < 1e3 * FLOAT
    expected_rad2 = (0.002**2 - 6 * 0.0005**2) / 4
    assert abs(out["rotation_deg"] - np.degrees(np.sqrt(expected_rad2))) < 1e3 * FLOAT
    report = out["splits"]["depth"]
    assert report["groups"] == 2
    assert abs(report["scatter_mm"] - 5.0) < 1e3 * FLOAT  # each 5 mm from their mean
    assert abs(report["expected_mm"] - np.sqrt(0.5 * 6 / 2)) < 1e3 * FLOAT


def test_four_groups_measure_the_spread_of_their_errors():
    """Groups whose answers carry independent errors of known spread, and no noise: the added variance is the
    full answer's share, spread / G, on average over many draws."""
    rng = np.random.default_rng(0)
    frame = np.repeat(np.arange(16), 3)
    splits = {"depth": np.repeat(np.arange(4), 4)}
    spread_m = 0.002  # per axis
    added = []
    for _ in range(2000):
        t = rng.normal(0.0, spread_m, size=(4, 3))
        added.append(split_excess(_groups(t, np.zeros((4, 3)), 0.0, 0.0), frame, splits)["translation_mm"] ** 2)
    # E[added] = 3 spread^2 / 4 (mm^2); the scatter over spread^2 is chi-square with 3 (G - 1) = 9 degrees of
    # freedom, so the mean of 2000 draws has a relative standard error of sqrt(2 / 9 / 2000), 1 %; five of them
    expected = 3 * (spread_m * 1e3) ** 2 / 4
    assert abs(np.mean(added) / expected - 1) < 5 * np.sqrt(2 / 9 / 2000)


def test_groups_within_their_noise_add_nothing():
    frame = np.repeat(np.arange(8), 5)
    within = _groups([[0, 0, 0], [0.001, 0.001, 0]], [[0, 0, 0], [0, 0, 0]], 0.001, 0.001)
    out = split_excess(within, frame, {"column": np.repeat([0, 1], 4)})
    assert out["translation_mm"] == 0.0 and out["rotation_deg"] == 0.0
    assert split_excess(lambda mask: None, frame, {}) == {"rotation_deg": 0.0, "translation_mm": 0.0, "splits": {}}


def test_frames_are_grouped_by_depth_and_by_image_column():
    n_frames, per = 16, 20
    frame = np.repeat(np.arange(n_frames), per)
    z = np.repeat(np.linspace(0.8, 1.7, n_frames), per)  # frame i farther than frame i - 1
    x = np.repeat(np.linspace(0.3, -0.3, n_frames), per) * z  # and farther left
    splits = frame_splits(frame, np.c_[x, np.zeros_like(z), z], n_frames)
    assert list(splits["depth"]) == list(np.repeat(np.arange(MAX_GROUPS), n_frames // MAX_GROUPS))
    assert list(splits["column"]) == list(np.repeat(np.arange(MAX_GROUPS)[::-1], n_frames // MAX_GROUPS))
    # fewer frames: fewer groups, each with at least MIN_FRAMES_PER_GROUP; a frame without matches in none
    keep = frame < 12
    keep &= frame != 3
    splits = frame_splits(frame[keep], np.c_[x, np.zeros_like(z), z][keep], 12)
    assert splits["depth"][3] == -1
    assert splits["depth"].max() == 11 // MIN_FRAMES_PER_GROUP - 1
    few = 2 * MIN_FRAMES_PER_GROUP - 1
    f = np.repeat(np.arange(few), per)
    assert frame_splits(f, np.c_[np.zeros((len(f), 2)), np.ones(len(f))], few) == {}


def test_the_registration_adds_the_groups_scatter_to_its_sigma():
    """On the analytic scene (12 frames: three groups of four), the sigma is the noise, the sampling bound, the
    groups' scatter and the repeated error's term in quadrature; without the check the scatter is left out, and the
    answer the same."""
    depth, surface, T_true = _scene(np.random.default_rng(5), n_frames=12)
    opts = MarkerlessOptions(depth_sigma_m_at_1m=SIGMA_1M)
    res = register_robot(depth, K, surface, options=opts)
    assert res.ok, res.refused
    d = res.diagnostics
    assert set(d["sigma_consistency"]["splits"]) == {"depth", "column"}
    for key in ("rotation_deg", "translation_mm"):
        parts = [d["sigma_noise"][key], d["sigma_sampling"][key], d["sigma_consistency"][key], d["sigma_repeated"][key]]
        assert abs(res.sigma[key] - np.sqrt(np.sum(np.square(parts)))) <= 1e3 * FLOAT * res.sigma[key]
    rot_deg, trans_mm = pose_error(res.T_base_cam, T_true)
    bias_mm, bias_deg = _bias_bounds(depth)
    assert trans_mm <= SIGMA_BOUND * res.sigma["translation_mm"] + bias_mm
    assert rot_deg <= SIGMA_BOUND * res.sigma["rotation_deg"] + bias_deg
    plain = register_robot(depth, K, surface, options=replace(opts, split_check=False))
    assert plain.diagnostics["sigma_consistency"] is None
    assert np.array_equal(plain.T_base_cam, res.T_base_cam)
    assert plain.sigma["translation_mm"] <= res.sigma["translation_mm"]
