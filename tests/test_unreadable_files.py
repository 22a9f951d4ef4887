"""A file without read permission is one clear line naming it, exit 2, for every kind of input file.

Running as root (CI, containers), ``chmod 000`` does not stop a read, so the refusal the operating
system would give is simulated: Python's ``open`` (which numpy's ``fromfile`` and Pillow also call)
raises ``PermissionError`` for the one file under test, as the kernel does for another user. Where the
suite runs as an ordinary user, the real ``chmod 000`` case runs too.
"""

from __future__ import annotations

import builtins
import io
import os
import shutil
from pathlib import Path

import numpy as np
import pytest

from handeye.cli import main
from handeye.core.posefile import write_pose_csv
from handeye.core.synthetic import make_problem

ROOT = Path(__file__).resolve().parents[1]
IS_ROOT = hasattr(os, "geteuid") and os.geteuid() == 0


@pytest.fixture
def deny(monkeypatch):
    """``deny(name)``: every later ``open`` of a path ending in ``name`` raises PermissionError (errno 13)."""
    real_open = io.open
    denied: list[str] = []

    def guarded(file, *args, **kwargs):
        if isinstance(file, (str, bytes, os.PathLike)) and any(os.fsdecode(file).endswith(n) for n in denied):
            raise PermissionError(13, "Permission denied", os.fsdecode(file))
        return real_open(file, *args, **kwargs)

    monkeypatch.setattr(builtins, "open", guarded)
    monkeypatch.setattr(io, "open", guarded)
    return denied.append


def _one_line_naming(capsys, name: str) -> None:
    err = capsys.readouterr().err
    lines = [ln for ln in err.split("\n") if ln.strip() and not ln.startswith("\r")]
    assert "Traceback" not in err
    assert len(lines) == 1 and lines[0].startswith("handeye ") and name in lines[0], err
    assert "ermission" in lines[0], err  # the reason, not only the name


@pytest.fixture
def files(tmp_path, capsys):
    """A pose file, a truth file, a board spec, intrinsics and board images, all valid, in ``tmp_path``."""
    pytest.importorskip("cv2")
    p = make_problem(10, "eye_to_hand", np.random.default_rng(0))
    write_pose_csv(tmp_path / "poses.csv", p.T_base_ee, p.T_cam_target)
    shutil.copy(ROOT / "handeye" / "data" / "example_eye_to_hand_truth.json", tmp_path / "truth.json")
    assert main(["board", "-o", str(tmp_path / "board.png")]) == 0
    images = tmp_path / "images"
    images.mkdir()
    for k in range(3):
        shutil.copy(tmp_path / "board.png", images / f"view_{k}.png")
    from classic.vision.camera import CameraIntrinsics

    CameraIntrinsics(np.array([[800.0, 0, 320], [0, 800, 240], [0, 0, 1]]), np.zeros(5), 640, 480).save(
        tmp_path / "camera.json"
    )
    capsys.readouterr()
    return tmp_path


CASES = [
    ("calibrate POSES", ["calibrate", "{d}/poses.csv", "--setup", "eye_to_hand"], "poses.csv"),
    (
        "calibrate --truth",
        ["calibrate", "{d}/poses.csv", "--setup", "eye_to_hand", "--truth", "{d}/truth.json"],
        "truth.json",
    ),
    ("plan POSES", ["plan", "{d}/poses.csv", "--setup", "eye_to_hand", "-o", "{d}/plan.csv"], "poses.csv"),
    (
        "detect --board",
        ["detect", "{d}/images", "--board", "{d}/board.json", "--intrinsics", "{d}/camera.json", "-o", "{d}/d.json"],
        "board.json",
    ),
    (
        "detect --intrinsics",
        ["detect", "{d}/images", "--board", "{d}/board.json", "--intrinsics", "{d}/camera.json", "-o", "{d}/d.json"],
        "camera.json",
    ),
    (
        "detect IMAGES",
        ["detect", "{d}/images", "--board", "{d}/board.json", "--intrinsics", "{d}/camera.json", "-o", "{d}/d.json"],
        "view_1.png",
    ),
    ("intrinsics IMAGES", ["intrinsics", "{d}/images", "--board", "{d}/board.json", "-o", "{d}/c.json"], "view_0.png"),
]


@pytest.mark.parametrize("what, argv, name", CASES, ids=[c[0] for c in CASES])
def test_an_unreadable_input_file_is_one_line(files, deny, capsys, what, argv, name):
    deny(name)
    assert main([a.format(d=files) for a in argv]) == 2
    _one_line_naming(capsys, name)


@pytest.mark.parametrize("name", ["meta.json", "cameras.csv", "frames.csv"])
def test_an_unreadable_dataset_file_is_one_line(small_copy, deny, capsys, name):
    deny(name)
    assert main(["show", str(small_copy), "--camera", "0", "-o", str(small_copy / "sheet.png")]) == 2
    _one_line_naming(capsys, name)


@pytest.mark.skipif(IS_ROOT, reason="root reads a chmod 000 file; the simulated refusal above covers it")
def test_a_chmod_000_pose_file_is_one_line(files, capsys):
    path = files / "poses.csv"
    path.chmod(0)
    try:
        assert main(["calibrate", str(path), "--setup", "eye_to_hand"]) == 2
        _one_line_naming(capsys, "poses.csv")
    finally:
        path.chmod(0o644)
