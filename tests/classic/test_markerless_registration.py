"""The depth-to-colour registration estimated or bounded (issue 41 item 2), on the analytic sphere scenes.

Depth aligned to the colour image through a factory extrinsic that is turned is the depth of a turned camera:
the registration finds that camera, and no depth can tell it from the colour one, so the extrinsic's rotation
is bounded by its stated sigma. A shift of the depth image against the camera model (an alignment off by
pixels) is the principal point's error, estimated with the pose. The result says which part was estimated and
which bounded.
"""

from __future__ import annotations

import numpy as np
import pytest

from classic.markerless import MarkerlessOptions, register_robot
from handeye.core.errors import HandEyeInputError
from handeye.core.se3 import make_transform, so3_exp
from tests.classic.test_markerless import (
    K,
    _look_at,
    covariance_carries_sigma,
    render_depth,
    sphere_model,
    within_sigma,
)
from tests.tolerances import SIGMA_BOUND

#: The extrinsic's rotation error, degrees (tilt about y, roll about z): large against the scene's rotation
#: bias bound (about 0.8 degrees, :func:`tests.classic.test_markerless._bias_bounds`), so that it shows.
TURN_DEG = np.array([0.0, 2.0, 2.0])
#: A shift of the depth image against the camera model, pixels along x.
SHIFT_PX = 2


def _scene(turn_deg=(0.0, 0.0, 0.0)):
    rng = np.random.default_rng(11)
    T_base_colour = _look_at(np.array([1.2, -0.6, 0.9]), np.array([0.0, 0.0, 0.35]))
    T_base_depth = T_base_colour @ make_transform(so3_exp(np.radians(turn_deg)), np.zeros(3))
    centres = np.empty((8, 4, 3))
    centres[:, 0] = [0, 0, 0.09]
    centres[:, 1:] = rng.uniform([-0.3, -0.3, 0.25], [0.3, 0.3, 0.65], size=(8, 3, 3))
    return render_depth(centres, T_base_depth, rng), sphere_model(centres), T_base_colour


@pytest.fixture(scope="module")
def turned():
    return _scene(TURN_DEG)


def test_a_turned_extrinsic_not_bounded_is_confidently_wrong(turned):
    depth, surface, T_true = turned
    res = register_robot(depth, K, surface)
    assert res.ok, res.refused
    assert res.registration["rotation"]["rss_deg"] == 0.0
    assert not within_sigma(res, T_true, depth)


def test_a_turned_extrinsic_is_bounded_by_its_sigma(turned):
    depth, surface, T_true = turned
    sigma_deg = float(np.abs(TURN_DEG).max())
    res = register_robot(depth, K, surface, options=MarkerlessOptions(depth_extrinsic_sigma_deg=sigma_deg))
    assert res.ok, res.refused
    assert within_sigma(res, T_true, depth)
    rotation = res.registration["rotation"]
    assert rotation["treatment"] == "bounded" and rotation["sigma_deg"] == sigma_deg
    assert rotation["rss_deg"] == pytest.approx(np.sqrt(3) * sigma_deg)
    assert res.sigma["rotation_deg"] >= rotation["rss_deg"]
    assert covariance_carries_sigma(res)  # the extrinsic's bound in the covariance too, not only in the sigma


def test_a_shifted_depth_image_is_estimated_as_the_principal_point():
    depth, surface, T_true = _scene()
    shifted = np.zeros_like(depth)
    shifted[:, :, SHIFT_PX:] = depth[:, :, :-SHIFT_PX]  # the content moves right: the principal point with it
    res = register_robot(shifted, K, surface)
    assert res.ok, res.refused
    assert within_sigma(res, T_true, depth)
    shift = res.registration["shift_px"]
    assert shift["treatment"].startswith("estimated")
    assert abs(shift["dx"] - SHIFT_PX) <= SIGMA_BOUND * shift["sigma"][0]
    assert abs(shift["dy"]) <= SIGMA_BOUND * shift["sigma"][1]
    fixed = register_robot(shifted, K, surface, options=MarkerlessOptions(intrinsics_model="fixed"))
    assert fixed.registration["shift_px"]["treatment"].startswith("taken as exact")


@pytest.mark.parametrize("key", ["depth_extrinsic_sigma_deg", "depth_extrinsic_sigma_m"])
@pytest.mark.parametrize("value", [-0.1, float("nan"), float("inf")])
def test_a_bad_registration_sigma_is_refused(key, value):
    with pytest.raises(HandEyeInputError, match=key):
        MarkerlessOptions(**{key: value})


def test_the_command_takes_the_profiles_rotation_spread_or_a_stated_one():
    from argparse import Namespace

    from handeye.commands.markerless import _sensor_terms

    def terms(sensor, sigma):
        args = Namespace(sensor=sensor, registration_sigma=sigma, stereo_fb=None, depth_model="scale-offset")
        return _sensor_terms(args)[:2]

    assert terms("d435-real-cell", None) == (0.0005, 0.2)
    assert terms("d435-real-cell", 0.05) == (0.0005, 0.05)
    for bad in (-0.1, 180.0, float("nan")):
        with pytest.raises(HandEyeInputError, match="registration-sigma"):
            terms("d435", bad)


def test_a_real_recording_without_a_sensor_gets_a_stated_registration_prior(capsys):
    """Not 0: a real camera's depth-to-colour registration is not exact. A simulated dataset keeps its own sensor's
    (exact registration when it was rendered without one); no matcher model is guessed for an unnamed camera."""
    from handeye.commands.markerless import UNNAMED_CAMERA_PRIOR, sensor_of
    from handeye.robot.depth_sensors import PROFILES

    prior = PROFILES[UNNAMED_CAMERA_PRIOR]
    assert prior.extrinsic_sigma_m > 0 and prior.registration_roll_sigma_deg > 0
    for real in ({}, {"generator": "handeye import bag"}):
        sensor = sensor_of(None, real)
        assert (sensor.extrinsic_sigma_m, sensor.registration_roll_sigma_deg) == (
            prior.extrinsic_sigma_m,
            prior.registration_roll_sigma_deg,
        )
        assert sensor.stereo_fb_px_m is None and "no --sensor" in capsys.readouterr().out
    assert sensor_of(None, {"generator": "handeye sim generate", "sensor": None}) is None
    rendered = {"generator": "handeye sim generate", "sensor": PROFILES["d435"].to_dict()}
    assert sensor_of(None, rendered) == PROFILES["d435"]
    assert sensor_of("zivid", {}) == PROFILES["zivid"]


def test_naming_a_camera_never_makes_the_rotation_bound_tighter_than_naming_none(tmp_path):
    """``--sensor d435`` on a real recording bounded the depth-to-colour rotation at 0 (the profile draws no turn in
    the simulator) where naming no camera bounded it at the unnamed prior's 0.2 deg: a real unit of a model with
    separate depth and colour imagers gets the factory bound; one imager (zivid) none; a simulated dataset read
    without ``--sensor`` keeps its own sensor's draw (exact registration)."""
    from argparse import Namespace

    from handeye.commands.markerless import UNNAMED_CAMERA_PRIOR, _sensor_terms
    from handeye.core.dataset import Dataset
    from handeye.robot.depth_sensors import FACTORY_ROLL_BOUND_DEG, PROFILES

    def rotation(sensor, dataset=tmp_path):
        args = Namespace(
            sensor=sensor, registration_sigma=None, stereo_fb=None, depth_model="scale-offset", dataset=dataset
        )
        return _sensor_terms(args)[1]

    for separate in ("d435", "d455", "l515", "azure-kinect"):
        assert PROFILES[separate].registration_roll_sigma_deg == 0  # what made the named bound 0
        assert rotation(separate) == FACTORY_ROLL_BOUND_DEG
    assert rotation("zivid") == 0.0
    assert rotation(UNNAMED_CAMERA_PRIOR) == PROFILES[UNNAMED_CAMERA_PRIOR].registration_roll_sigma_deg
    assert rotation("d435") >= PROFILES[UNNAMED_CAMERA_PRIOR].registration_roll_sigma_deg
    with pytest.MonkeyPatch.context() as mp:
        rendered = {"generator": "handeye sim generate", "sensor": PROFILES["d435"].to_dict()}
        mp.setattr(Dataset, "open", staticmethod(lambda path: Namespace(meta={"recipe": rendered})))
        assert rotation(None) == 0.0


def test_the_run_says_which_part_was_estimated_and_which_bounded(turned):
    from handeye.markerless import MarkerlessRun

    depth, surface, _ = turned
    res = register_robot(depth, K, surface, options=MarkerlessOptions(depth_extrinsic_sigma_deg=0.3))
    note = MarkerlessRun(results={0: res}, seconds={0: 1.0}).registration_note()
    assert "shift estimated with the principal point" in note and "bounded at 0.3 deg" in note
    assert MarkerlessRun(results={}, seconds={}).registration_note() is None
