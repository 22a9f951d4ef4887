"""The one table writer: markdown lines and CSV files, one way everywhere."""

from __future__ import annotations

import csv

import pytest

from handeye.core.tables import markdown_table, write_csv


def test_markdown_table_lines():
    assert markdown_table(["a", "b"], [[1, "x"], [2.5, ""]]) == ["| a | b |", "|---|---|", "| 1 | x |", "| 2.5 |  |"]
    with pytest.raises(ValueError, match="row 0 has 1 cells for 2 columns"):
        markdown_table(["a", "b"], [[1]])


def test_csv_round_trip(tmp_path):
    path = write_csv(tmp_path / "t.csv", ["name", "value"], [["x", 0.1], ["y, z", 2]])
    with path.open(newline="") as f:
        assert list(csv.reader(f)) == [["name", "value"], ["x", "0.1"], ["y, z", "2"]]
