"""The dataset format's building blocks: tables, pose columns, depth encoding, manifests (core only)."""

from __future__ import annotations

import numpy as np
import pytest

from handeye.core.dataset import (
    columns_to_poses,
    decode_depth,
    encode_depth,
    poses_to_columns,
    read_table,
    shard_is_complete,
    write_manifest,
    write_table,
)
from handeye.core.errors import DatasetError
from handeye.core.se3 import make_transform
from handeye.core.synthetic import random_rotations
from tests.tolerances import DEPTH_QUANTUM_M, EXACT


def random_transforms(n, rng):
    return make_transform(random_rotations(rng, n), rng.normal(size=(n, 3)))


def test_pose_columns_round_trip(rng):
    T = random_transforms(5, rng)
    np.testing.assert_allclose(columns_to_poses(poses_to_columns("T_base_ee", T), "T_base_ee"), T, atol=EXACT)


def test_tables_round_trip_with_unknown_cells(tmp_path, rng):
    T = random_transforms(3, rng)
    table = {
        "camera_id": np.arange(3),
        "split": np.array(["train", "test", "train"], dtype=object),
        **poses_to_columns("T_base_cam_true", T),
    }
    table["T_base_cam_true.x"][1] = np.nan  # unknown truth: an empty cell
    write_table(tmp_path / "t.csv", table)
    back = read_table(tmp_path / "t.csv", ["camera_id", "split"])
    assert list(back["split"]) == ["train", "test", "train"] and back["camera_id"].dtype.kind == "i"
    poses = columns_to_poses(back, "T_base_cam_true")
    assert np.isnan(poses[1]).all()
    np.testing.assert_allclose(poses[[0, 2]], T[[0, 2]], atol=1e-15 + EXACT)


def test_table_errors_name_file_and_row(tmp_path):
    path = tmp_path / "t.csv"
    with pytest.raises(DatasetError, match="t.csv: table missing"):
        read_table(path, [])
    path.write_text("camera_id,radius_m\n0,1.5\n1\n")
    with pytest.raises(DatasetError, match="t.csv: row 3 has 1 values for 2 columns"):
        read_table(path, [])
    path.write_text("camera_id,radius_m\n0,1.5\n")
    with pytest.raises(DatasetError, match="t.csv: missing column.*split"):
        read_table(path, ["camera_id", "split"])
    path.write_text("camera_id,radius_m\n0.5,1.5\n")
    with pytest.raises(DatasetError, match="row 2 column camera_id: '0.5' is not an integer"):
        read_table(path, [])


def test_depth_encoding_is_lossless_to_half_a_unit(rng):
    scale = 1e-4
    depth = rng.uniform(0.1, 6.0, size=(20, 30)).astype(np.float32)
    depth[0, 0] = 0.0  # no hit
    depth[0, 1] = 7.0  # beyond 16 bits of 0.1 mm: stored as no depth, not wrapped around
    back = decode_depth(encode_depth(depth, scale), scale)
    assert back[0, 0] == 0 and back[0, 1] == 0
    np.testing.assert_allclose(back.ravel()[2:], depth.ravel()[2:], atol=DEPTH_QUANTUM_M + 1e-6)


def test_manifest_recognises_complete_and_damaged_shards(tmp_path):
    shard = tmp_path / "cam_0000"
    (shard / "rgb").mkdir(parents=True)
    (shard / "rgb" / "a.png").write_bytes(b"12345")
    assert shard_is_complete(shard) == (False, f"{shard / 'manifest.json'}: missing (shard half-written)")
    write_manifest(shard, 0, {"data": 1})
    assert shard_is_complete(shard) == (True, "")
    (shard / "rgb" / "a.png").write_bytes(b"123")
    ok, why = shard_is_complete(shard)
    assert not ok and "3 bytes, the manifest says 5" in why


def test_a_rewritten_camera_table_keeps_the_units_registration_truth():
    """What the simulator records of a misregistered unit survives a rewrite of cameras.csv (labelling, markerless
    labels rewrite it with camera_table_columns): before, the three columns were dropped."""
    from handeye.core.dataset import CAMERA_COLUMNS, REGISTRATION_COLUMNS, SENSOR_COLUMNS, camera_table_columns

    table = {c: [0.0] for c in CAMERA_COLUMNS + SENSOR_COLUMNS + REGISTRATION_COLUMNS}
    assert camera_table_columns(table)[-3:] == REGISTRATION_COLUMNS
    del table[REGISTRATION_COLUMNS[0]]
    assert not set(REGISTRATION_COLUMNS) & set(camera_table_columns(table))
