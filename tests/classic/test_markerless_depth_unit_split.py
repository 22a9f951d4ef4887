"""The split check's groups widen the depth unit's sigma as they widen the pose's (issue 41).

A depth error the frames of one group share (by depth, by the arm's place in the image) pulls the sensor's scale
and offset the registration estimates, and a covariance that counts the frames as independent does not see it. The
split check solves groups of the frames again; their depth units ``(k, c)``, with the depth noise's own bias taken
out of each, scatter by that error beyond their own noise, and the full answer's share of the excess is added to
the depth unit's covariance (``diagnostics["sigma_consistency"]["depth_variance"]``), as it is to the pose's.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
from scipy import integrate, stats

from classic.markerless import MarkerlessOptions, register_robot
from classic.markerless.consistency import split_excess
from handeye.core.se3 import make_transform
from tests.classic.test_markerless import SIGMA_1M, K, _scene
from tests.tolerances import DEPTH_UNIT_CHI2_TAIL, DEPTH_UNIT_SIGMA_SES, FLOAT

#: Groups of one split, and draws of the groups' answers.
GROUPS, DRAWS = 4, 400
#: Each group's own noise in ``k`` and ``c`` (one sigma), and the spread of the error the frames of a group share,
#: twice the noise: the full answer's error is then sqrt(1 + 4) = 2.2 times what the groups' noise alone gives.
NOISE_K, NOISE_C = 1e-3, 2e-3
SHARED_K, SHARED_C = 2e-3, 4e-3


def _unit_groups(rng, shared=True):
    """One draw: a ``solve`` answering the groups with the identity pose and ``(k, c)`` off by a shared error (one
    draw per group, the same spread) plus their own noise; and the full answer, the groups' mean, as the error the
    sigma is to hold, with the noise's covariance of that mean."""
    C = np.diag([NOISE_K**2, NOISE_C**2])
    errors = rng.normal(size=(GROUPS, 2)) * [NOISE_K, NOISE_C]
    if shared:
        errors += rng.normal(size=(GROUPS, 2)) * [SHARED_K, SHARED_C]
    answers = iter(
        [(make_transform(np.eye(3), np.zeros(3)), np.eye(6) * 1e-6, (np.array([1.0, 0.0]) + e, C)) for e in errors]
    )
    return (lambda mask: next(answers)), errors.mean(axis=0), C / GROUPS


def test_the_groups_scatter_in_the_depth_unit_is_the_unit_sigmas_too():
    """Over ``DRAWS`` draws of groups whose units carry a shared error, the full answer's squared errors over the mean
    squared sigma (noise plus the split's ``depth_variance``) within chi-square's quantiles (``DEPTH_UNIT_CHI2_TAIL``,
    the upper one widened by the mean squared sigma's own error, ``DEPTH_UNIT_SIGMA_SES``), for ``k`` and ``c``; with
    the noise's sigma alone (as before the depth unit took the split's excess) the statistic is five times beyond
    what it should be."""
    rng = np.random.default_rng(7)
    frame = np.repeat(np.arange(16), 3)
    splits = {"column": np.repeat(np.arange(GROUPS), 16 // GROUPS)}
    errors, noise, added = [], [], []
    for _ in range(DRAWS):
        solve, error, C = _unit_groups(rng)
        out = split_excess(solve, frame, splits)
        errors.append(error)
        noise.append(np.diag(C))
        added.append(out["depth_variance"])
    errors, noise, added = np.array(errors), np.array(noise), np.array(added)
    relative_se = np.sqrt(2 / ((GROUPS - 1) * DRAWS))
    bound = stats.chi2.ppf(1 - DEPTH_UNIT_CHI2_TAIL, DRAWS) / (1 - DEPTH_UNIT_SIGMA_SES * relative_se)
    for i in range(2):
        honest = np.sum(errors[:, i] ** 2) / np.mean(noise[:, i] + added[:, i])
        assert stats.chi2.ppf(DEPTH_UNIT_CHI2_TAIL, DRAWS) <= honest <= bound, (i, honest, bound)
        assert np.sum(errors[:, i] ** 2) / np.mean(noise[:, i]) > bound  # the noise alone falls short


def test_groups_within_their_noise_add_little_and_groups_without_a_unit_none():
    """Without a shared error the added variance is the clipped excess of pure noise: ``noise / G`` times
    ``max(0, chi2_{G-1} / (G - 1) - 1)``, whose mean over ``DRAWS`` draws is within ``DEPTH_UNIT_SIGMA_SES`` of its
    standard errors of its expectation (0.31 for G = 4); a ``solve`` that gives no unit (the depth taken as exact)
    adds no ``depth_variance``."""
    rng = np.random.default_rng(8)
    frame = np.repeat(np.arange(16), 3)
    splits = {"depth": np.repeat(np.arange(GROUPS), 4)}
    added = [split_excess(_unit_groups(rng, shared=False)[0], frame, splits)["depth_variance"] for _ in range(DRAWS)]
    dof = GROUPS - 1
    moments = [
        integrate.quad(lambda x, p=p: (x / dof - 1) ** p * stats.chi2.pdf(x, dof), dof, np.inf)[0] for p in (1, 2)
    ]
    bound = moments[0] + DEPTH_UNIT_SIGMA_SES * np.sqrt((moments[1] - moments[0] ** 2) / DRAWS)
    share = np.mean(added, axis=0) / (np.array([NOISE_K**2, NOISE_C**2]) / GROUPS)
    assert np.all(share <= bound), (share, bound)
    pose_only = iter([(make_transform(np.eye(3), np.zeros(3)), np.eye(6) * 1e-6)] * GROUPS)
    assert "depth_variance" not in split_excess(lambda mask: next(pose_only), frame, splits)


def test_the_registrations_depth_sigma_holds_the_split_checks_depth_variance(monkeypatch):
    """On the analytic scene (12 frames: three groups of four) the split check finds no shared error, so its
    ``depth_variance`` is planted (the check's answer wrapped): the depth unit's covariance is the one without
    the split check plus it, through ``s = 1 / k``, ``o = -c / k`` (the scale's variance grows by ``v_k / k^4``,
    the offset's by ``(c / k^2)^2 v_k + v_c / k^2``); the pose, the unit itself and the pose's noise term are
    those without it. Slack: float rounding through the 2x2 products, far below the planted growth (3x)."""
    from classic.markerless.problem import Problem

    depth, surface, _ = _scene(np.random.default_rng(5), n_frames=12)
    opts = MarkerlessOptions(depth_sigma_m_at_1m=SIGMA_1M)
    plain = register_robot(depth, K, surface, options=replace(opts, split_check=False))
    k = 1 / plain.depth["scale"]
    c = -plain.depth["offset_mm"] / 1e3 * k
    v_k = 3 * plain.depth["scale_sigma"] ** 2 * k**4
    v_c = 3 * (plain.depth["offset_sigma_mm"] / 1e3) ** 2 * k**2
    checked = Problem.split_check

    def planted(self, T, matches):
        return {**checked(self, T, matches), "depth_variance": [v_k, v_c]}

    monkeypatch.setattr(Problem, "split_check", planted)
    res = register_robot(depth, K, surface, options=opts)
    assert res.ok and plain.ok
    assert res.diagnostics["sigma_consistency"]["depth_variance"] == [v_k, v_c]
    assert np.array_equal(res.T_base_cam, plain.T_base_cam) and res.depth["scale"] == plain.depth["scale"]
    grown_s = res.depth["scale_sigma"] ** 2 - plain.depth["scale_sigma"] ** 2
    assert abs(grown_s - v_k / k**4) <= 1e3 * FLOAT * res.depth["scale_sigma"] ** 2
    grown_o = (res.depth["offset_sigma_mm"] ** 2 - plain.depth["offset_sigma_mm"] ** 2) / 1e6
    want_o = (c / k**2) ** 2 * v_k + v_c / k**2
    assert abs(grown_o - want_o) <= 1e3 * FLOAT * (res.depth["offset_sigma_mm"] / 1e3) ** 2
    assert res.diagnostics["sigma_noise"] == plain.diagnostics["sigma_noise"]
