"""Hostile files: each command that reads a user's file answers in one short line, never a traceback or a
library's warning, whatever the file is built to do.

The corpus is generated here (nothing shipped): decompression bombs (PNG, JPEG and 16-bit depth PNG declaring
60,000 x 60,000 pixels in a few hundred bytes), deeply nested and alias-bomb JSON and YAML, CSV with a
300,000-column header, a megabyte field, NUL bytes or mixed encodings, absurd numbers, truncated ROS 2 bags
(sqlite3 and MCAP), a dataset declaring billions of cameras, symlinks leaving a dataset or looping, and model
files that are not handeye's (one a pickle that would run a command when unpickled). Each is fed to every
command that reads such a file; the limits are :mod:`handeye.core.limits`.
"""

from __future__ import annotations

import json
import shutil

import numpy as np
import pytest

from benchmarks.hostile_corpus import (
    POSE_HEADER,
    jpeg_bomb,
    png_bomb,
    rewrite_manifest,
    truncated_bag,
    yaml_alias_bomb,
)
from handeye.cli import main
from handeye.core.limits import MAX_MESSAGE_CHARS


def check_one_line(rc: int, err: str) -> None:
    """Exit 2, one line of at most MAX_MESSAGE_CHARS, no traceback, no library warning."""
    # progress lines (redrawn with a carriage return) are not messages
    lines = [ln for ln in err.split("\n") if ln.strip() and not ln.startswith("\r")]
    assert rc == 2, err[-2000:]
    assert len(lines) == 1, err[-2000:]
    assert len(lines[0]) <= MAX_MESSAGE_CHARS, lines[0]
    assert lines[0].startswith("handeye ")
    assert "Traceback" not in err and "Warning" not in err


def run(capfd, argv) -> str:
    rc = main([str(a) for a in argv])
    err = capfd.readouterr().err
    check_one_line(rc, err)
    return err


# ------------------------------------------------------------------ images


@pytest.mark.parametrize("kind", ["png", "jpeg", "png16"])
def test_detect_refuses_a_decompression_bomb_from_its_header(kind, tmp_path, capfd):
    pytest.importorskip("cv2")
    folder = tmp_path / "images"
    folder.mkdir()
    data = {"png": png_bomb(), "jpeg": jpeg_bomb(), "png16": png_bomb(bit_depth=16, colour_type=0)}[kind]
    (folder / f"bomb.{'jpg' if kind == 'jpeg' else 'png'}").write_bytes(data)
    from classic.vision.board import BoardSpec

    BoardSpec(squares_x=5, squares_y=7, square_length_m=0.04, marker_length_m=0.03).save(tmp_path / "board.json")
    err = run(capfd, ["detect", folder, "--board", tmp_path / "board.json", "-o", tmp_path / "d.json"])
    assert "declares 60000x60000 pixels, over the limit" in err


def test_label_and_markerless_refuse_bombs_in_a_dataset(small_copy, capfd):
    """A shard's colour and depth PNGs replaced by bombs, the manifest rewritten to match."""
    shard = small_copy / "shards" / "cam_0000"
    cal = sorted((shard / "rgb").glob("calibration_*.png"))[0]
    cal.write_bytes(png_bomb())
    depth = sorted((shard / "depth").glob("data_*.png"))[0]
    depth.write_bytes(png_bomb(bit_depth=16, colour_type=0))
    rewrite_manifest(shard)
    err = run(capfd, ["markerless", small_copy, "--camera", "0", "--quiet"])
    assert depth.name in err and "over the limit" in err
    err = run(capfd, ["label", small_copy, "--quiet"])
    assert cal.name in err and "over the limit" in err


# ------------------------------------------------------------------ JSON and YAML


def test_deeply_nested_json_is_refused(tmp_path, capfd):
    deep = tmp_path / "poses.json"
    deep.write_text("[" * 100_000 + "]" * 100_000)
    run(capfd, ["calibrate", deep, "--setup", "eye-to-hand"])
    moderately = tmp_path / "start.json"
    moderately.write_text('{"T_base_cam": ' + "[" * 200 + "]" * 200 + "}")
    pytest.importorskip("pinocchio")
    err = run(capfd, ["markerless", tmp_path, "--start", moderately])
    assert "start.json: nested deeper than 64 levels" in err


def test_a_yaml_alias_bomb_is_refused(tmp_path, capfd):
    pytest.importorskip("yaml")
    path = tmp_path / "samples.yaml"
    path.write_text(yaml_alias_bomb())
    run(capfd, ["calibrate", path, "--setup", "eye-to-hand"])


# ------------------------------------------------------------------ CSV


@pytest.mark.parametrize("case", ["wide header", "huge field", "nul", "mixed encodings"])
def test_hostile_csv_is_one_short_line(case, tmp_path, capfd):
    path = tmp_path / "poses.csv"
    row = "0.1,0,0.5,0,0,0,1,0.2,0,0.6,0,0,0,1\n"
    if case == "wide header":
        data = (",".join(f"c{k}" for k in range(300_000)) + "\n" + row).encode()
    elif case == "huge field":
        data = (POSE_HEADER + "\n" + "9" * 1_000_000 + row[3:]).encode()
    elif case == "nul":
        data = (POSE_HEADER + "\n" + row * 3).encode().replace(b"0.5", b"0\x005", 1)
    else:
        data = (POSE_HEADER + "\n" + row).encode() + "0.1,0,0.5,0,0,0,1,0.2,0,0.6,0,0,0,1 # café\n".encode("latin-1")
    path.write_bytes(data)
    run(capfd, ["calibrate", path, "--setup", "eye-to-hand"])


def test_a_dataset_table_with_a_huge_header_is_one_short_line(small_copy, capfd):
    path = small_copy / "cameras.csv"
    path.write_text(",".join(f"c{k}" for k in range(300_000)) + "\n")
    err = run(capfd, ["markerless", small_copy, "--camera", "0", "--quiet"])
    assert "cameras.csv, line 1" in err and "over the limit" in err


# ------------------------------------------------------------------ numbers


def test_absurd_numbers_are_called_absurd(tmp_path, capfd):
    rng = np.random.default_rng(0)
    rows = []
    for k in range(6):
        t = rng.normal(size=3) * 0.3
        rows.append(f"{t[0]},{t[1]},{t[2]},0,0,0,1,0.1,0,0.5,0,0,0,1")
    rows[2] = "1e308," + rows[2].split(",", 1)[1]
    path = tmp_path / "poses.csv"
    path.write_text(POSE_HEADER + "\n" + "\n".join(rows) + "\n")
    err = run(capfd, ["calibrate", path, "--setup", "eye-to-hand"])
    assert "absurd" in err and "millimetres?" not in err and "looks like millimetres" not in err


# ------------------------------------------------------------------ datasets


def test_a_dataset_declaring_billions_is_refused(small_copy, capfd):
    meta = json.loads((small_copy / "meta.json").read_text())
    meta["cameras"] = 3_000_000_000
    (small_copy / "meta.json").write_text(json.dumps(meta))
    err = run(capfd, ["markerless", small_copy, "--quiet"])
    assert "cameras is 3000000000" in err
    meta["cameras"] = 4
    meta["intrinsics"]["width"] = meta["intrinsics"]["height"] = 1_000_000
    (small_copy / "meta.json").write_text(json.dumps(meta))
    err = run(capfd, ["label", small_copy, "--quiet"])
    assert "1000000x1000000 pixels" in err


def test_symlinks_leaving_the_dataset_or_looping(small_copy, tmp_path, capfd):
    shard = small_copy / "shards" / "cam_0000"
    depth = sorted((shard / "depth").glob("data_*.png"))[0]
    outside = tmp_path / "outside.png"
    shutil.copy(depth, outside)
    depth.unlink()
    depth.symlink_to(outside)  # the cell's path stays inside; the file it names does not
    err = run(capfd, ["markerless", small_copy, "--camera", "0", "--quiet"])
    assert "leaves the shard" in err
    loop = small_copy / "shards" / "cam_0001" / "depth"
    shutil.rmtree(loop)
    loop.symlink_to(loop)
    run(capfd, ["markerless", small_copy, "--camera", "1", "--quiet"])


# ------------------------------------------------------------------ models


def test_model_files_from_elsewhere_are_refused_without_running_them(small_copy, tmp_path, capfd):
    torch = pytest.importorskip("torch")
    model = tmp_path / "model"
    model.mkdir()
    marker = tmp_path / "ran"

    class Payload:
        def __reduce__(self):
            import os

            return (os.system, (f"touch {marker}",))

    torch.save({"state_dict": Payload()}, model / "translation.pt")
    torch.save({"weights": torch.zeros(3)}, model / "orientation.pt")  # another tool's
    run(capfd, ["compare", small_copy, "--model", model, "--no-hybrid"])
    assert not marker.exists()


# ------------------------------------------------------------------ bags


@pytest.mark.parametrize("storage", ["sqlite3", "mcap"])
def test_truncated_bags_are_one_line(storage, tmp_path, capfd):
    pytest.importorskip("rosbags")
    path = truncated_bag(tmp_path, storage)
    run(capfd, ["import", "bag", path, "--robot", "ur5", "--out", tmp_path / "out"])
    run(capfd, ["bag-poses", path, "--base", "a", "--ee", "b", "--marker-topic", "/m", "-o", tmp_path / "p.csv"])
