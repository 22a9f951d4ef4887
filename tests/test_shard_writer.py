"""ShardWriter: a real recording written from hand-made arrays reads back; a crash never publishes a shard."""

from __future__ import annotations

import numpy as np
import pytest

from handeye.core.dataset import (
    CAMERA_COLUMNS,
    FORMAT,
    FORMAT_VERSION,
    Dataset,
    poses_to_columns,
    shard_is_complete,
    write_json_atomic,
    write_table,
)
from handeye.core.errors import DatasetError, HandEyeInputError
from handeye.core.se3 import make_transform
from handeye.core.shard_writer import ShardWriter
from handeye.core.synthetic import random_rotations
from tests.tolerances import DEPTH_QUANTUM_M, EXACT

N_JOINTS = 6
SCALE_M = 1e-4


def _poses(rng, n):
    return make_transform(random_rotations(rng, n), rng.normal(size=(n, 3)))


def _real_dataset(root, n_cameras=2):
    """meta.json and cameras.csv as a user writes them for a real robot: truth unknown."""
    intr = {"K": [[300.0, 0, 32], [0, 300.0, 24], [0, 0, 1]], "width": 64, "height": 48, "dist": [0.0] * 5}
    write_json_atomic(
        root / "meta.json",
        {
            "format": FORMAT,
            "version": FORMAT_VERSION,
            "robot": "my-robot",
            "n_joints": N_JOINTS,
            "intrinsics": intr,
            "cameras": n_cameras,
            "depth": {"format": "png16", "scale_m": SCALE_M, "invalid": 0},
            "recipe": {},
        },
    )
    table = {
        "camera_id": np.arange(n_cameras),
        "region": np.zeros(n_cameras, int),
        "split": np.array(["train"] * n_cameras, dtype=object),
    }
    table.update(poses_to_columns("T_base_cam_true", np.full((n_cameras, 4, 4), np.nan)))
    write_table(root / "cameras.csv", table, CAMERA_COLUMNS)


def _recording(rng, n_cal=2, n_data=3):
    cal = [(_poses(rng, 1)[0], rng.integers(0, 256, (48, 64, 3), dtype=np.uint8)) for _ in range(n_cal)]
    data = [
        (
            rng.uniform(-3, 3, N_JOINTS),
            _poses(rng, 1)[0],
            rng.integers(0, 256, (48, 64, 3), dtype=np.uint8),
            rng.uniform(0.3, 2.0, (48, 64)),
        )
        for _ in range(n_data)
    ]
    for _, _, _, depth in data:
        depth[0, :5] = 0.0  # no depth
    return cal, data


def _write(root, camera_id, cal, data, T_ee_ref, crash_after=None):
    with ShardWriter(root, camera_id, region=0, split="train") as shard:
        for T_base_ee, rgb in cal:
            shard.add_frame("calibration", T_base_ee, rgb=rgb)
        for k, (q, T_base_ee, rgb, depth) in enumerate(data):
            if k == crash_after:
                raise RuntimeError("robot driver lost")
            shard.add_frame("data", T_base_ee, rgb=rgb, depth_m=depth, q=q, T_base_ref=T_base_ee @ T_ee_ref)


def test_a_real_recording_reads_back_identically(tmp_path, rng):
    _real_dataset(tmp_path)
    T_ee_ref = make_transform(np.eye(3), [0, 0, 0.12])
    recordings = [_recording(rng) for _ in range(2)]
    for c, (cal, data) in enumerate(recordings):
        _write(tmp_path, c, cal, data, T_ee_ref)
    ds = Dataset.open(tmp_path)
    ds.validate(images=True)
    assert ds.complete_shards() == [0, 1]
    for c, (cal, data) in enumerate(recordings):
        rows = ds.select(c, "calibration")
        np.testing.assert_allclose(ds.poses(rows, "T_base_ee"), [T for T, _ in cal], atol=EXACT)
        assert np.isnan(ds.joints(rows)).all() and list(rows["depth"]) == ["", ""]
        for rel, (_, rgb) in zip(rows["rgb"], cal):
            np.testing.assert_array_equal(ds.rgb(c, rel), rgb)
        rows = ds.select(c, "data")
        np.testing.assert_allclose(ds.joints(rows), [q for q, *_ in data], atol=EXACT)
        np.testing.assert_allclose(ds.poses(rows, "T_base_ee"), [T for _, T, *_ in data], atol=EXACT)
        np.testing.assert_allclose(ds.poses(rows, "T_base_ref"), [T @ T_ee_ref for _, T, *_ in data], atol=EXACT)
        for rel_rgb, rel_depth, (_, _, rgb, depth) in zip(rows["rgb"], rows["depth"], data):
            np.testing.assert_array_equal(ds.rgb(c, rel_rgb), rgb)
            np.testing.assert_allclose(ds.depth_m(c, rel_depth), depth, atol=DEPTH_QUANTUM_M + 1e-7)
    manifest = (ds.shard_dir(0) / "manifest.json").read_text()
    assert '"calibration": 2' in manifest and '"data": 3' in manifest


def test_a_crash_inside_a_shard_publishes_nothing_and_a_rerun_completes_it(tmp_path, rng):
    _real_dataset(tmp_path, n_cameras=1)
    cal, data = _recording(rng)
    with pytest.raises(RuntimeError, match="robot driver lost"):
        _write(tmp_path, 0, cal, data, np.eye(4), crash_after=1)
    shard = ShardWriter(tmp_path, 0)
    assert not shard.final.exists() and not shard.partial.exists() and not shard.complete
    with pytest.raises(DatasetError, match="shard missing"):
        Dataset.open(tmp_path).frames(0)
    # a killed process leaves a .partial folder: not a shard, and the next writer starts it again
    (shard.partial / "rgb").mkdir(parents=True)
    (shard.partial / "rgb" / "calibration_000.png").write_bytes(b"cut short")
    assert not shard.complete
    _write(tmp_path, 0, cal, data, np.eye(4))
    assert shard.complete and not shard.partial.exists()
    assert len(Dataset.open(tmp_path).select(0, "data")["frame"]) == 3


def test_a_shard_without_frames_or_outside_its_block_is_refused(tmp_path, rng):
    _real_dataset(tmp_path, n_cameras=1)
    with pytest.raises(DatasetError, match="no frame table written"):
        with ShardWriter(tmp_path, 0):
            pass
    assert not (tmp_path / "shards" / "cam_0000").exists()
    shard = ShardWriter(tmp_path, 0)
    with pytest.raises(DatasetError, match="inside 'with ShardWriter"):
        shard.write_rgb("data_000", np.zeros((4, 4, 3), np.uint8))
    with pytest.raises(HandEyeInputError, match="uint8 of shape"), shard:
        shard.write_rgb("data_000", np.zeros((4, 4), np.uint8))
    with pytest.raises(HandEyeInputError, match="plain file name"), shard:
        shard.write_depth("../x", np.zeros((4, 4)))
    with pytest.raises(HandEyeInputError, match="q has 2 joint angles"), shard:
        shard.add_frame("data", np.eye(4), rgb=np.zeros((4, 4, 3), np.uint8), q=[0.0, 1.0])
    assert not shard.partial.exists() and not shard_is_complete(shard.final)[0]
