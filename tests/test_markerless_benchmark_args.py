"""The markerless benchmarks' error options read in the project's strict number grammar."""

from __future__ import annotations

import argparse

import numpy as np
import pytest

from benchmarks.markerless_sensors import parse_intrinsics_error, parse_joint_offsets, parse_registration_error


def test_key_numbers_default_to_zero_and_read_what_is_given():
    assert parse_intrinsics_error("fx=0.007, cx=3") == {"fx": 0.007, "fy": 0.0, "cx": 3.0, "cy": 0.0}
    assert parse_registration_error("roll=0.2") == {"du": 0.0, "dv": 0.0, "roll": 0.2}
    assert np.array_equal(parse_joint_offsets("0.2, -0.3"), [0.2, -0.3])


@pytest.mark.parametrize(
    "parse,text",
    [
        (parse_intrinsics_error, "fx=nan"),
        (parse_intrinsics_error, "zz=1"),
        (parse_intrinsics_error, "fx=1_0"),
        (parse_registration_error, "du="),
        (parse_joint_offsets, "0.2,inf"),
        (parse_joint_offsets, "0.2,,0.1"),
    ],
)
def test_a_bad_value_is_the_options_error(parse, text):
    with pytest.raises(argparse.ArgumentTypeError):
        parse(text)


def test_options_given_replace_the_profiles_own():
    from benchmarks.markerless_sensors import front_options
    from handeye.robot.depth_sensors import PROFILES

    d435 = PROFILES["d435"]
    assert front_options(d435, 1).stereo_fb_px_m == d435.stereo_fb_px_m
    told = front_options(d435, 1, stereo_fb_px_m=None, depth_model="fixed")
    assert told.stereo_fb_px_m is None and told.depth_model == "fixed"


def test_the_floor_cases_are_told_every_estimated_error_exact():
    from benchmarks.markerless_errors import TOLD_EXACT, diagnostic_cases

    floors = [c for c in diagnostic_cases() if c["name"].startswith("floor")]
    assert len(floors) == 2
    for case in floors:
        assert case["options"] == TOLD_EXACT
        assert case["sensor"].scale_sigma == 0 and case["sensor"].offset_sigma_m == 0
        assert "intrinsics" not in case and "joints" not in case and "registration" not in case
    with_extrinsic, without = floors
    assert with_extrinsic["sensor"].extrinsic_sigma_m > 0 and without["sensor"].extrinsic_sigma_m == 0


def test_an_option_is_a_field_of_markerless_options_with_a_finite_value():
    """--option is refused when parsed, not after the datasets are rendered: a key that is no MarkerlessOptions
    field (a typo) and a value that starts as a number and is none; the documented forms read as their types."""
    from benchmarks.markerless_errors import parse_option

    assert parse_option("max_incidence_deg=65") == ("max_incidence_deg", 65)
    assert parse_option("model_floor_m=1.5e-3") == ("model_floor_m", 0.0015)
    assert parse_option("intrinsics_model=fixed") == ("intrinsics_model", "fixed")
    assert parse_option("static_parts=true") == ("static_parts", True)
    assert parse_option("depth_sigma_m_at_1m=none") == ("depth_sigma_m_at_1m", None)
    assert parse_option("pixel_effect_px=+2") == ("pixel_effect_px", 2)
    bad = ("max_incidence=65", "pixel_effect_px=nan", "pixel_effect_px=1_0", "model_floor_m=-inf", "seed=.nan", "x")
    for text in bad:
        with pytest.raises(argparse.ArgumentTypeError):
            parse_option(text)


def test_each_draws_median_is_of_its_own_accepted_placements():
    """--seed with several draws: the line per case gives each draw's median of its accepted placements alone."""
    from benchmarks.markerless_errors import per_draw

    ok = lambda mm: ("ok", 0.01, mm, 0.1, 3.0, 1.0)  # noqa: E731
    refused = ("refused", np.nan, np.nan, np.nan, np.nan, 1.0)
    draws = {0: [ok(1.0), ok(3.0), refused, ok(0.5)], 3: [refused], 7: [ok(2.25)]}
    assert per_draw("none", draws) == "- none: seed 0 1.00, seed 3 -, seed 7 2.25"
