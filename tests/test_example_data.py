"""The shipped example is what its header says: the call it names regenerates its poses and its truth."""

from __future__ import annotations

import importlib
import json
import re
from pathlib import Path

import numpy as np
import pytest

from handeye.core.posefile import read_pose_file
from tests.tolerances import FLOAT

DATA = Path(__file__).resolve().parents[1] / "handeye" / "data"
#: The CSV holds 12 significant digits: values of order 1 (metres, quaternion components) are rounded by at most
#: 5e-12 or so, and the quaternion-to-matrix product multiplies that by a few; 1e-10 leaves headroom and still
#: fails on any other draw (poses of different draws differ by order 1).
CSV_DIGITS = 1e-10


def _named_call(csv: Path):
    """The ``# Synthetic: module.function(args)`` line of the file's header, evaluated."""
    line = next(line for line in csv.read_text().splitlines() if line.startswith("# Synthetic: "))
    module, function, args = re.fullmatch(r"# Synthetic: ([\w.]+)\.(\w+)\((.*)\)", line).groups()
    return getattr(importlib.import_module(module), function), args


@pytest.mark.parametrize(
    "name,X,Y", [("eye_to_hand", "T_base_cam", "T_ee_target"), ("eye_in_hand", "T_ee_cam", "T_base_target")]
)
def test_the_example_header_names_the_call_that_makes_it(name, X, Y):
    make, args = _named_call(DATA / f"example_{name}.csv")
    problem = eval(f"make({args})", {"make": make, "np": np})  # the header's own arguments
    poses = read_pose_file(DATA / f"example_{name}.csv")
    assert np.abs(poses.T_base_ee - problem.T_base_ee).max() < CSV_DIGITS
    assert np.abs(poses.T_cam_target - problem.T_cam_target).max() < CSV_DIGITS
    truth = json.loads((DATA / f"example_{name}_truth.json").read_text())
    assert np.abs(np.array(truth[X]) - problem.X_true).max() < FLOAT
    assert np.abs(np.array(truth[Y]) - problem.Y_true).max() < FLOAT
    assert f"{make.__module__}.{make.__name__}" in truth["note"]
