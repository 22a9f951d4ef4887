"""``classic.calibrate`` builds the motion pairs once and hands them down to every stage that reads them.

Bit-identity of the stages against the function they were split from is measured by
``python benchmarks/calibrate_identity.py --against REV``; these tests keep the one pass.
"""

from __future__ import annotations

import importlib

import numpy as np
import pytest

import classic.contamination as contamination
import classic.diagnostics as diagnostics
import classic.motions as motions
from handeye.core.synthetic import make_problem
from tests.tolerances import EXACT

front = importlib.import_module("classic.calibrate")  # the module: the package's name "calibrate" is the function


@pytest.fixture
def builds(monkeypatch):
    """Counts every motion pairs' build, wherever a stage would do it."""
    count = {"n": 0}
    real = motions.motions_from_poses

    def counted(*args, **kwargs):
        count["n"] += 1
        return real(*args, **kwargs)

    for module in (front, diagnostics):
        monkeypatch.setattr(module, "motions_from_poses", counted)
    real_iter = motions.iter_motions

    def counted_iter(*args, **kwargs):
        count["n"] += 1
        return real_iter(*args, **kwargs)

    # the pair consensus builds its own pairs' motions chunk by chunk (classic.contamination)
    for module in (front, contamination):
        monkeypatch.setattr(module, "iter_motions", counted_iter)
    return count


@pytest.mark.parametrize("setup", ["eye_to_hand", "eye_in_hand"])
@pytest.mark.parametrize("method", ["auto", "park", "tsai"])
def test_the_motions_are_built_once(builds, setup, method):
    p = make_problem(15, setup, np.random.default_rng(3))
    res = front.calibrate(p.T_base_ee, p.T_cam_target, setup=setup, method=method)
    np.testing.assert_allclose(res.X, p.X_true, atol=EXACT)
    # the motion and consistency checks, the start and the pair consensus all read one build
    assert builds["n"] == 1


def test_the_robust_path_builds_them_again_only_for_its_own_inliers(builds):
    p = make_problem(30, "eye_to_hand", np.random.default_rng(4), camera_noise=(0.1, 0.5), outlier_fraction=0.2)
    res = front.calibrate(p.T_base_ee, p.T_cam_target, setup="eye_to_hand", robust=True)
    assert not res.residuals.inliers.all()
    assert builds["n"] == 1
