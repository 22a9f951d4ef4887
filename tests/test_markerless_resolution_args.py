"""benchmarks/markerless_resolution.py's --size: WIDTHxHEIGHT in pixels, anything else the option's error."""

from __future__ import annotations

import argparse

import pytest

from benchmarks.markerless_resolution import parse_size


def test_size_reads_width_then_height():
    assert parse_size("848x480") == (848, 480)
    assert parse_size("256X256") == (256, 256)


@pytest.mark.parametrize("text", ["848", "848x480x3", "848xabc", "8x480", "848x5000", "-848x480"])
def test_a_bad_size_is_the_options_error(text):
    with pytest.raises(argparse.ArgumentTypeError, match="--size"):
        parse_size(text)
