"""The ``handeye calibrate`` command: the README's main job, JSON output, errors without tracebacks."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from handeye.cli import main
from handeye.core.metrics import pose_error
from handeye.core.posefile import write_pose_csv
from handeye.core.se3 import invert_transform
from handeye.core.synthetic import make_problem
from tests.tolerances import EXACT

DATA = Path(__file__).resolve().parents[1] / "handeye" / "data"


def test_example_file_recovers_its_truth(tmp_path, capsys):
    """The README's main job on the shipped example: the result is within 4 predicted sigmas of the truth."""
    out = tmp_path / "result.json"
    rc = main(
        [
            "calibrate",
            str(DATA / "example_eye_to_hand.csv"),
            "--setup",
            "eye-to-hand",
            "--truth",
            str(DATA / "example_eye_to_hand_truth.json"),
            "-o",
            str(out),
        ]
    )
    assert rc == 0
    printed = capsys.readouterr().out
    assert "T_base_cam" in printed and "error vs truth T_base_cam" in printed
    result = json.loads(out.read_text())
    truth = json.loads((DATA / "example_eye_to_hand_truth.json").read_text())
    rot, trans = pose_error(np.array(result["T_base_cam"]["matrix"]), np.array(truth["T_base_cam"]))
    assert rot < 4 * result["sigma"]["X_rotation_deg"]
    assert trans < 4 * result["sigma"]["X_translation_mm"]
    assert len(result["residuals"]["per_pose"]) == 15
    assert np.array(result["covariance"]["matrix"]).shape == (12, 12)


def test_eye_in_hand_and_robust_from_csv(tmp_path, capsys):
    p = make_problem(16, "eye_in_hand", np.random.default_rng(11), camera_noise=(0.1, 1.0), outlier_fraction=0.2)
    path = tmp_path / "poses.csv"
    write_pose_csv(path, p.T_base_ee, p.T_cam_target)
    out = tmp_path / "r.json"
    assert main(["calibrate", str(path), "--setup", "eye-in-hand", "--robust", "-o", str(out)]) == 0
    result = json.loads(out.read_text())
    assert result["diagnostics"]["outliers"] == [int(i) for i in np.flatnonzero(p.outliers)]
    assert "T_ee_cam" in result and "T_base_target" in result
    rot, trans = pose_error(np.array(result["T_ee_cam"]["matrix"]), p.X_true)
    assert rot < 4 * result["sigma"]["X_rotation_deg"] and trans < 4 * result["sigma"]["X_translation_mm"]
    assert "outlier poses" in capsys.readouterr().out


def test_bad_input_exits_2_with_a_message(tmp_path, capsys):
    p = make_problem(10, "eye_to_hand", np.random.default_rng(2))
    path = tmp_path / "inverted.csv"
    write_pose_csv(path, p.T_base_ee, invert_transform(p.T_cam_target))
    assert main(["calibrate", str(path), "--setup", "eye-to-hand"]) == 2
    err = capsys.readouterr().err
    assert "camera poses inverted" in err and "setup='eye_in_hand'" in err and "Traceback" not in err
    assert main(["calibrate", str(tmp_path / "missing.csv"), "--setup", "eye-to-hand"]) == 2
    assert "no such file" in capsys.readouterr().err


def test_console_script_runs(tmp_path):
    """The installed entry point, as a user types it."""
    proc = subprocess.run(
        [
            sys.executable,
            "-m",
            "handeye.cli",
            "calibrate",
            str(DATA / "example_eye_to_hand.csv"),
            "--setup",
            "eye-to-hand",
            "-o",
            "-",
        ],
        capture_output=True,
        text=True,
        check=False,
    )
    assert proc.returncode == 0, proc.stderr
    assert json.loads(proc.stdout)["setup"] == "eye_to_hand"


@pytest.mark.parametrize("units", ["mm"])
def test_units_option(tmp_path, units):
    p = make_problem(10, "eye_to_hand", np.random.default_rng(4))
    A, B = p.T_base_ee.copy(), p.T_cam_target.copy()
    A[:, :3, 3] *= 1000
    B[:, :3, 3] *= 1000
    path = tmp_path / "mm.csv"
    write_pose_csv(path, A, B)
    assert main(["calibrate", str(path), "--setup", "eye-to-hand"]) == 2  # millimetres read as metres
    out = tmp_path / "r.json"
    assert main(["calibrate", str(path), "--setup", "eye-to-hand", "--units", units, "-o", str(out)]) == 0
    X = np.array(json.loads(out.read_text())["T_base_cam"]["matrix"])
    np.testing.assert_allclose(X, p.X_true, atol=EXACT)


def test_contaminated_file_refused_then_robust_and_noise_model_options(tmp_path, capsys):
    """Gross outliers without --robust: exit 2 naming the poses; --camera-noise/--robot-noise: the ML model is used."""
    p = make_problem(
        16,
        "eye_to_hand",
        np.random.default_rng(5),
        camera_noise=(0.1, 1.0),
        robot_noise=(0.02, 0.1),
        outlier_fraction=0.15,
    )
    path = tmp_path / "poses.csv"
    write_pose_csv(path, p.T_base_ee, p.T_cam_target)
    assert main(["calibrate", str(path), "--setup", "eye-to-hand"]) == 2
    err = capsys.readouterr().err
    assert "--robust" in err and "Traceback" not in err  # refused (by the consistency or the contamination check)
    out = tmp_path / "r.json"
    assert (
        main(
            [
                "calibrate",
                str(path),
                "--setup",
                "eye-to-hand",
                "--robust",
                "--camera-noise",
                "0.1",
                "1",
                "1",
                "1",
                "--robot-noise",
                "0.02",
                "0.1",
                "-o",
                str(out),
            ]
        )
        == 0
    )
    printed = capsys.readouterr().out
    assert "noise model: given on the command line" in printed and "variance factor" in printed
    result = json.loads(out.read_text())
    assert result["diagnostics"]["noise_model"]["robot_translation_mm"] == pytest.approx([0.1, 0.1, 0.1])
    rot, trans = pose_error(np.array(result["T_base_cam"]["matrix"]), p.X_true)
    assert rot < 4 * result["sigma"]["X_rotation_deg"] and trans < 4 * result["sigma"]["X_translation_mm"]
    assert main(["calibrate", str(path), "--setup", "eye-to-hand", "--robot-noise", "0.02", "0.1"]) == 2
    assert "--camera-noise" in capsys.readouterr().err


def test_the_printed_noise_model_says_when_depth_was_estimated_apart():
    from handeye.noise_args import describe_noise

    iso = {"estimated": True, "camera_rotation_deg": [0.1] * 3, "camera_translation_mm": [1.0] * 3}
    assert describe_noise(iso).endswith("(0.1000 deg, 1.000 mm per axis)")
    pnp = dict(iso, camera_translation_mm=[0.3, 0.3, 3.0])
    assert "0.300 mm across and 3.000 mm along the line of sight" in describe_noise(pnp)
