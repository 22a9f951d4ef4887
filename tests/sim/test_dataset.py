"""The small preset end to end: format, labels against truth, resuming, and errors on damaged datasets."""

from __future__ import annotations

import json
import os

import numpy as np
import pytest

from handeye.core.dataset import Dataset, shard_name
from handeye.core.errors import DatasetError
from tests.tolerances import ESTIMATED_SIGMA_BOUND, FLOAT, LABEL_COMMON_SHIFT_PX, RECOMPUTED_ERROR_RTOL


def test_small_preset_has_what_the_preset_asks_for(small_dataset):
    from sim.cameras import get_preset

    root, report = small_dataset
    preset = get_preset("small")
    ds = Dataset.open(root)
    ds.validate(images=True)
    assert len(ds) == preset.n_cameras and report.rendered == list(range(preset.n_cameras))
    cams = ds.cameras()
    for region in range(2):
        in_region = cams["region"] == region
        assert np.sum(in_region & (cams["split"] == "train")) == preset.train_per_region[region]
        assert np.sum(in_region & (cams["split"] == "test")) == preset.test_per_region[region]
    for c in range(len(ds)):
        assert len(ds.select(c, "data")["frame"]) == preset.configurations
        assert len(ds.select(c, "calibration")["frame"]) == preset.calibration_views
        data = ds.select(c, "data")
        rgb, depth = ds.rgb(c, data["rgb"][0]), ds.depth_m(c, data["depth"][0])
        assert rgb.shape == (preset.image_size[1], preset.image_size[0], 3) and depth.shape == rgb.shape[:2]
        assert depth.dtype == np.float32 and np.all(depth >= 0) and np.median(depth[depth > 0]) > 0.5


def test_recorded_poses_are_the_forward_kinematics_of_the_recorded_joints(small_dataset):
    from handeye.robot.model import load_robot

    ds = Dataset.open(small_dataset[0])
    robot = load_robot(ds.meta["robot"])
    t = ds.frames(0)
    q = ds.joints(t)
    np.testing.assert_allclose(ds.poses(t, "T_base_ee"), robot.fk(q), atol=FLOAT)
    np.testing.assert_allclose(ds.poses(t, "T_base_ref"), robot.fk(q) @ np.array(ds.meta["T_ee_ref"]), atol=FLOAT)


def test_labels_are_within_their_uncertainty_of_the_truth(small_dataset):
    ds = Dataset.open(small_dataset[0])
    cams = ds.cameras()
    assert list(cams["label_status"]) == ["ok"] * len(ds)
    f = ds.meta["calibration_intrinsics"]["K"][0][0]
    from sim.cameras import get_preset

    # the board is near the workspace centre the cameras look at
    distance_m = np.linalg.norm(ds.truth()[:, :3, 3] - np.array(get_preset("small").look_at_m), axis=1)
    floor_rot_deg = np.degrees(LABEL_COMMON_SHIFT_PX / f)
    floor_trans_mm = 1000 * LABEL_COMMON_SHIFT_PX / f * distance_m
    assert np.all(cams["label_error_rot_deg"] <= ESTIMATED_SIGMA_BOUND * cams["label_sigma_rot_deg"] + floor_rot_deg)
    assert np.all(cams["label_error_trans_mm"] <= ESTIMATED_SIGMA_BOUND * cams["label_sigma_trans_mm"] + floor_trans_mm)
    # and the label columns agree with the poses they describe
    from handeye.core.metrics import pose_error

    rot, trans = pose_error(ds.labels(), ds.truth())
    np.testing.assert_allclose(rot, cams["label_error_rot_deg"], rtol=RECOMPUTED_ERROR_RTOL)
    np.testing.assert_allclose(trans, cams["label_error_trans_mm"], rtol=RECOMPUTED_ERROR_RTOL)
    assert (ds.root / "labels.md").is_file() and (ds.root / "label_errors.png").stat().st_size > 1000


def _snapshot(shard):
    return {p.relative_to(shard).as_posix(): p.read_bytes() for p in sorted(shard.rglob("*")) if p.is_file()}


def test_half_written_shards_are_detected_and_regenerated_identically(small_copy):
    from handeye.core.engine_protocol import EngineOptions
    from sim.generate import Recipe, generate

    root = small_copy
    before = {c: _snapshot(root / shard_name(c)) for c in (2, 4)}
    # shard 2: an image cut short; shard 4: a crash before the rename left only the .partial directory
    image = root / shard_name(2) / "rgb" / "data_003.png"
    image.write_bytes(image.read_bytes()[:100])
    os.replace(root / shard_name(4), root / (shard_name(4) + ".partial"))
    (root / (shard_name(4) + ".partial") / "manifest.json").unlink()
    with pytest.raises(DatasetError, match="data_003.png.*truncated"):
        Dataset.open(root).frames(2)
    with pytest.raises(DatasetError, match="cam_0004.*resume"):
        Dataset.open(root).frames(4)
    report = generate(root, Recipe("small", seed=0), options=EngineOptions(workers=1, progress=False))
    assert report.rendered == [2, 4] and report.regenerated == [2, 4]
    assert report.skipped == [0, 1, 3, 5]
    assert not (root / (shard_name(4) + ".partial")).exists()
    for c in (2, 4):
        after = _snapshot(root / shard_name(c))
        assert after.keys() == before[c].keys()
        assert all(after[k] == before[c][k] for k in after), f"shard {c} regenerated differently"
    Dataset.open(root).validate(images=True)


def test_resuming_with_other_options_is_refused(small_copy):
    from handeye.core.engine_protocol import EngineOptions
    from sim.generate import Recipe, generate

    with pytest.raises(DatasetError, match="other options"):
        generate(small_copy, Recipe("small", seed=1), options=EngineOptions(workers=1, progress=False))


def _edit_cell(path, row, column, value):
    lines = path.read_text().splitlines()
    header = lines[0].split(",")
    cells = lines[row - 1].split(",")
    cells[header.index(column)] = value
    lines[row - 1] = ",".join(cells)
    path.write_text("\n".join(lines) + "\n")


def test_a_corrupted_camera_table_names_file_row_and_column(small_copy):
    _edit_cell(small_copy / "cameras.csv", 3, "T_base_cam_true.x", "abc")
    with pytest.raises(DatasetError, match=r"cameras.csv: row 3 column T_base_cam_true.x: 'abc' is not a number"):
        Dataset.open(small_copy).cameras()


def test_a_non_unit_quaternion_in_a_table_is_reported(small_copy):
    _edit_cell(small_copy / "cameras.csv", 2, "T_base_cam_true.qw", "3.0")
    with pytest.raises(DatasetError, match="cameras.csv.*row 2.*not a unit quaternion"):
        Dataset.open(small_copy).truth()


def test_a_frame_table_without_a_column_names_the_file(small_copy):
    path = small_copy / shard_name(1) / "frames.csv"
    lines = path.read_text().splitlines()
    lines[0] = lines[0].replace("T_base_ref.qw", "T_base_ref.w")
    path.write_text("\n".join(lines) + "\n")
    # the manifest no longer matches either; the shard check comes first and names the file
    with pytest.raises(DatasetError, match="cam_0001/frames.csv"):
        Dataset.open(small_copy).frames(1)


def test_a_missing_image_names_the_file(small_copy):
    (small_copy / shard_name(3) / "depth" / "data_001.png").unlink()
    with pytest.raises(DatasetError, match="cam_0003/depth/data_001.png: listed in the manifest but missing"):
        Dataset.open(small_copy).validate()
    ds = Dataset.open(small_copy)
    with pytest.raises(DatasetError, match="cam_0003/depth/data_001.png: image missing"):
        ds.depth_m(3, "depth/data_001.png")


def test_an_image_path_leaving_the_shard_is_refused(small_copy):
    """A ``../`` path in frames.csv, even with a manifest that agrees with the table, is never followed."""
    from handeye.core.dataset import write_manifest

    shard = small_copy / shard_name(1)
    table = (shard / "frames.csv").read_text().splitlines()
    header = table[0].split(",")
    row = table[1].split(",")
    row[header.index("rgb")] = "../" + shard_name(0) + "/" + row[header.index("rgb")]
    (shard / "frames.csv").write_text("\n".join([table[0], ",".join(row), *table[2:]]) + "\n")
    manifest = json.loads((shard / "manifest.json").read_text())
    write_manifest(shard, 1, manifest["frames"])  # the manifest now agrees with the edited table
    ds = Dataset.open(small_copy)
    # refused where the table is read, naming the row and column, and again where an image is opened
    with pytest.raises(DatasetError, match=r"row 2 column rgb: .* leaves the shard"):
        ds.frames(1)
    with pytest.raises(DatasetError, match="leaves the shard"):
        ds.rgb(1, row[header.index("rgb")])
    with pytest.raises(DatasetError, match="leaves the shard"):
        ds.validate(images=True)
    with pytest.raises(DatasetError, match="leaves the shard"):
        ds.depth_m(1, "/etc/passwd")


def test_meta_errors(small_copy, tmp_path):
    with pytest.raises(DatasetError, match="no such dataset directory"):
        Dataset.open(tmp_path / "nothing")
    meta = small_copy / "meta.json"
    doc = json.loads(meta.read_text())
    meta.write_text(json.dumps({**doc, "version": 99}))
    with pytest.raises(DatasetError, match="format version 99"):
        Dataset.open(small_copy)
    meta.write_text("{not json")
    with pytest.raises(DatasetError, match="meta.json: not valid JSON"):
        Dataset.open(small_copy)
    meta.unlink()
    with pytest.raises(DatasetError, match="meta.json: missing"):
        Dataset.open(small_copy)


def test_an_unlabelled_dataset_says_how_to_label_it(small_copy):
    from handeye.core.dataset import CAMERA_COLUMNS, read_table, write_table

    table = read_table(small_copy / "cameras.csv", CAMERA_COLUMNS)
    write_table(small_copy / "cameras.csv", table, CAMERA_COLUMNS)
    with pytest.raises(DatasetError, match="no labels; run 'handeye label"):
        Dataset.open(small_copy).labels()


def test_cli_label_and_show(small_copy, tmp_path, capsys):
    from handeye.cli import main

    assert main(["label", str(small_copy), "--workers", "1", "--quiet"]) == 0
    out = capsys.readouterr().out
    assert "6 of 6 camera poses labelled" in out and "median" in out
    png = tmp_path / "cam2.png"
    assert main(["show", str(small_copy), "--camera", "2", "-o", str(png)]) == 0
    assert "label vs truth" in capsys.readouterr().out and png.stat().st_size > 10_000
    assert main(["show", str(small_copy), "--camera", "9", "-o", str(png)]) == 2
    assert "no camera 9" in capsys.readouterr().err
    assert main(["sim", "generate", "--out", str(small_copy), "--seed", "5", "--quiet"]) == 2
    assert "other options" in capsys.readouterr().err
    assert main(["sim", "generate", "--out", str(small_copy), "--quiet"]) == 0
    assert "kept 6 complete" in capsys.readouterr().out


def test_a_second_writer_on_one_dataset_is_refused(tmp_path):
    """Two generators on one output folder: the second is refused at once, naming the first; nothing is written."""
    from handeye.core.dataset import dataset_lock
    from handeye.core.engine_protocol import EngineOptions
    from sim.generate import Recipe, generate

    with dataset_lock(tmp_path, "handeye sim generate (test holder)"):
        refused = r"handeye sim generate \(test holder\) \(pid \d+\) is writing this dataset"
        with pytest.raises(DatasetError, match=refused):
            generate(tmp_path, Recipe("small"), options=EngineOptions(workers=1, progress=False))
    assert sorted(p.name for p in tmp_path.iterdir()) == [".lock"]
    with dataset_lock(tmp_path, "again"):  # released: the next writer gets it
        pass
