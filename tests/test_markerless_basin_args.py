"""The markerless benchmark's basin offsets: a list of cells or a grid, read in the project's strict number grammar."""

from __future__ import annotations

import argparse

import pytest

from benchmarks.markerless import parse_basin_cells, parse_basin_grid


def test_cells_and_grid_read_what_is_given():
    assert parse_basin_cells("50:5,100:10") == [(50, 5.0), (100, 10.0)]
    assert parse_basin_grid("0,25:0,2.5") == [(0, 0.0), (0, 2.5), (25, 0.0), (25, 2.5)]


@pytest.mark.parametrize(
    "parse,text",
    [
        (parse_basin_cells, "50"),
        (parse_basin_cells, "50:nan"),
        (parse_basin_cells, "50.5:5"),
        (parse_basin_cells, "-50:5"),
        (parse_basin_grid, "0,25"),
        (parse_basin_grid, "0,25:0,,5"),
        (parse_basin_grid, "0,1_0:5"),
        (parse_basin_grid, "0:inf"),
    ],
)
def test_a_bad_offset_is_the_options_error(parse, text):
    with pytest.raises(argparse.ArgumentTypeError, match="start offset|mm:deg pairs|MM_LIST"):
        parse(text)
