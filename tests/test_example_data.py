"""The shipped example is what its header says: the call it names regenerates its poses and its truth."""

from __future__ import annotations

import importlib
import json
import re
from pathlib import Path

import numpy as np

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


def test_the_example_header_names_the_call_that_makes_it():
    make, args = _named_call(DATA / "example_eye_to_hand.csv")
    problem = eval(f"make({args})", {"make": make, "np": np})  # the header's own arguments
    poses = read_pose_file(DATA / "example_eye_to_hand.csv")
    assert np.abs(poses.T_base_ee - problem.T_base_ee).max() < CSV_DIGITS
    assert np.abs(poses.T_cam_target - problem.T_cam_target).max() < CSV_DIGITS
    truth = json.loads((DATA / "example_eye_to_hand_truth.json").read_text())
    assert np.abs(np.array(truth["T_base_cam"]) - problem.X_true).max() < FLOAT
    assert np.abs(np.array(truth["T_ee_target"]) - problem.Y_true).max() < FLOAT
    assert f"{make.__module__}.{make.__name__}" in truth["note"]
