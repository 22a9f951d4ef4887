"""``handeye calibrate`` names an outlier pose by index and file row: refused by default, left out with --robust."""

from __future__ import annotations

from pathlib import Path

from handeye.cli import main

EXAMPLE = Path(__file__).resolve().parents[1] / "handeye" / "data" / "example_eye_to_hand.csv"


def _moved(tmp_path: Path, row_of_pose: int, metres: float) -> Path:
    """The shipped example with one robot pose's x moved (the issue's reproduction: 1.8 m)."""
    lines = EXAMPLE.read_text().splitlines()
    header = next(i for i, line in enumerate(lines) if line.startswith("T_base_ee.x"))
    fields = lines[header + 1 + row_of_pose].split(",")
    fields[0] = str(float(fields[0]) + metres)
    lines[header + 1 + row_of_pose] = ",".join(fields)
    path = tmp_path / "moved.csv"
    path.write_text("\n".join(lines) + "\n")
    return path


def test_a_robot_pose_moved_by_1_8_m_is_refused_with_its_row(tmp_path, capsys):
    path = _moved(tmp_path, 3, 1.8)
    assert main(["calibrate", str(path), "--setup", "eye-to-hand"]) == 2
    err = capsys.readouterr().err
    assert "pose 3 (row 9): translation 1" in err and "--robust" in err and "Traceback" not in err
    assert main(["calibrate", str(path), "--setup", "eye-to-hand", "--robust"]) == 0
    out = capsys.readouterr().out
    assert "outlier poses (excluded): [3]" in out
    assert "    pose 3 (row 9): translation off" in out


def test_the_clean_example_names_no_pose(capsys):
    assert main(["calibrate", str(EXAMPLE), "--setup", "eye-to-hand"]) == 0
    assert "outlier bound" not in capsys.readouterr().out
