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
