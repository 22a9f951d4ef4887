"""Hostile files, built to hurt a reader, and the command lines that read them.

Used by ``benchmarks/reliability.py`` (which measures each command's memory and time on them) and by
``tests/test_hostile_files.py``. Everything is generated: decompression bombs (PNG, JPEG, 16-bit depth PNG),
deeply nested JSON, YAML alias bombs, CSV with enormous headers or fields, NUL bytes or mixed encodings,
absurd numbers, truncated ROS 2 bags (sqlite3 and MCAP), a dataset declaring billions of cameras or
gigapixel images, symlinks that leave a dataset or loop, and model files from elsewhere (one a pickle that
would run a command when unpickled).
"""

from __future__ import annotations

import json
import shutil
import struct
import zlib
from pathlib import Path

import numpy as np

POSE_HEADER = (
    "T_base_ee.x,T_base_ee.y,T_base_ee.z,T_base_ee.qx,T_base_ee.qy,T_base_ee.qz,T_base_ee.qw,"
    "T_cam_target.x,T_cam_target.y,T_cam_target.z,T_cam_target.qx,T_cam_target.qy,T_cam_target.qz,T_cam_target.qw"
)
POSE_ROW = "0.1,0,0.5,0,0,0,1,0.2,0,0.6,0,0,0,1\n"


def _chunk(kind: bytes, data: bytes) -> bytes:
    return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)


def png_bomb(side: int = 60_000, bit_depth: int = 8, colour_type: int = 2) -> bytes:
    """A PNG of a few hundred bytes whose header declares ``side`` x ``side`` pixels (data: a few rows of
    zeros, highly compressed)."""
    ihdr = struct.pack(">IIBBBBB", side, side, bit_depth, colour_type, 0, 0, 0)
    row = b"\x00" * (1 + side * (3 if colour_type == 2 else 1) * bit_depth // 8)
    idat = zlib.compress(row * 4, 9)
    return b"\x89PNG\r\n\x1a\n" + _chunk(b"IHDR", ihdr) + _chunk(b"IDAT", idat) + _chunk(b"IEND", b"")


def jpeg_bomb(side: int = 60_000) -> bytes:
    """A small JPEG whose frame header is patched to declare ``side`` x ``side`` pixels."""
    import cv2

    data = bytearray(cv2.imencode(".jpg", np.zeros((16, 16, 3), np.uint8))[1].tobytes())
    k = data.index(b"\xff\xc0")
    data[k + 5 : k + 9] = struct.pack(">HH", side, side)
    return bytes(data)


def nested_json(depth: int) -> str:
    return "[" * depth + "]" * depth


def yaml_alias_bomb(levels: int = 10) -> str:
    lines = ['a0: &a0 ["x", "x", "x", "x", "x", "x", "x", "x", "x"]']
    for k in range(1, levels):
        lines.append(f"a{k}: &a{k} [" + ", ".join([f"*a{k - 1}"] * 9) + "]")
    return "\n".join(lines) + "\n"


#: Pose files of :func:`pose_csvs` that are legitimate (a reader must accept them).
LEGIT_POSE_FILES = ("subnormal_negative_zero.csv",)


def pose_csvs() -> dict:
    """Hostile pose files: name to bytes."""
    from handeye.core.se3 import pos_quat_xyzw_from_transform
    from handeye.core.synthetic import make_problem

    p = make_problem(8, "eye_to_hand", np.random.default_rng(0))
    good_rows = []
    for A, B in zip(p.T_base_ee, p.T_cam_target):
        values = [*np.concatenate(pos_quat_xyzw_from_transform(A)), *np.concatenate(pos_quat_xyzw_from_transform(B))]
        good_rows.append(",".join(repr(float(v)) for v in values))
    absurd = list(good_rows)
    absurd[2] = "1e308," + absurd[2].split(",", 1)[1]
    # a flange at y = -0.0 and one at z = 5e-321 (a subnormal), each with the camera's view that the problem's X
    # and Y give it (eye-to-hand: T_cam_target = X^-1 A Y): legitimate numbers, the file must be accepted
    tiny = list(good_rows)
    for row, (axis, value, text) in ((3, (1, -0.0, "-0.0")), (4, (2, 5e-321, "5e-321"))):
        A = p.T_base_ee[row].copy()
        A[axis, 3] = value
        B = np.linalg.inv(p.X_true) @ A @ p.Y_true
        values = [*np.concatenate(pos_quat_xyzw_from_transform(A)), *np.concatenate(pos_quat_xyzw_from_transform(B))]
        cells = [repr(float(v)) for v in values]
        cells[axis] = text
        tiny[row] = ",".join(cells)
    return {
        "wide_header.csv": (",".join(f"c{k}" for k in range(300_000)) + "\n" + POSE_ROW).encode(),
        "huge_field.csv": (POSE_HEADER + "\n" + "9" * 1_000_000 + POSE_ROW[3:]).encode(),
        "nul.csv": (POSE_HEADER + "\n" + POSE_ROW * 3).encode().replace(b"0.5", b"0\x005", 1),
        "mixed_encoding.csv": (POSE_HEADER + "\n" + POSE_ROW).encode() + "0.1,0,0.5 # café\n".encode("latin-1"),
        "absurd_1e308.csv": (POSE_HEADER + "\n" + "\n".join(absurd) + "\n").encode(),
        "subnormal_negative_zero.csv": (POSE_HEADER + "\n" + "\n".join(tiny) + "\n").encode(),
        "nested.json": nested_json(100_000).encode(),
        "nested_200.json": ('{"poses": ' + nested_json(200) + "}").encode(),
        "alias_bomb.yaml": yaml_alias_bomb().encode(),
    }


def rewrite_manifest(shard: Path) -> None:
    """The shard's manifest made to match its damaged files (so that the reader, not the size check, is tested)."""
    from handeye.core.dataset import write_manifest

    manifest = json.loads((shard / "manifest.json").read_text())
    write_manifest(shard, manifest["camera_id"], manifest["frames"])


def hostile_datasets(good: Path, folder: Path) -> dict:
    """Copies of a good dataset, each damaged one hostile way: name to dataset root."""
    out = {}

    def copy(name):
        root = folder / name
        shutil.copytree(good, root, symlinks=True)
        out[name] = root
        return root

    root = copy("depth_bomb")
    shard = root / "shards" / "cam_0000"
    sorted((shard / "depth").glob("data_*.png"))[0].write_bytes(png_bomb(bit_depth=16, colour_type=0))
    rewrite_manifest(shard)
    root = copy("rgb_bomb")
    shard = root / "shards" / "cam_0000"
    sorted((shard / "rgb").glob("calibration_*.png"))[0].write_bytes(png_bomb())
    rewrite_manifest(shard)
    for key, value in (("cameras", 3_000_000_000), ("n_joints", 10**9)):
        root = copy(f"meta_{key}_billions")
        meta = json.loads((root / "meta.json").read_text())
        meta[key] = value
        (root / "meta.json").write_text(json.dumps(meta))
    root = copy("meta_gigapixel")
    meta = json.loads((root / "meta.json").read_text())
    meta["intrinsics"]["width"] = meta["intrinsics"]["height"] = 1_000_000
    (root / "meta.json").write_text(json.dumps(meta))
    root = copy("meta_nested")
    (root / "meta.json").write_text(nested_json(100_000))
    root = copy("table_wide_header")
    (root / "cameras.csv").write_text(",".join(f"c{k}" for k in range(300_000)) + "\n")
    root = copy("symlink_leaves")
    depth = sorted((root / "shards" / "cam_0000" / "depth").glob("data_*.png"))[0]
    outside = folder / "outside.png"
    shutil.copy(depth, outside)
    depth.unlink()
    depth.symlink_to(outside)
    root = copy("symlink_loop")
    loop = root / "shards" / "cam_0000" / "depth"
    shutil.rmtree(loop)
    loop.symlink_to(loop)
    return out


def hostile_models(folder: Path) -> dict:
    """Model folders that are not handeye's: name to folder (needs torch)."""
    import torch

    out = {}
    pickled = folder / "pickle_payload"
    pickled.mkdir()

    class Payload:  # unpickled, it would create a file: a model loader must never unpickle
        def __reduce__(self):
            import os

            return (os.system, (f"touch {folder / 'payload_ran'}",))

    torch.save({"state_dict": Payload()}, pickled / "translation.pt")
    torch.save({"state_dict": Payload()}, pickled / "orientation.pt")
    out["pickle payload"] = pickled
    other = folder / "other_tool"
    other.mkdir()
    for name in ("translation.pt", "orientation.pt"):
        torch.save({"weights": torch.zeros(3), "epoch": 7}, other / name)
    out["another tool's checkpoint"] = other
    return out


def truncated_bag(folder: Path, storage: str) -> Path:
    """A ROS 2 bag of 200 joint states with its data file cut in half."""
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore

    ts = get_typestore(Stores.ROS2_HUMBLE)
    M = ts.types
    path = folder / f"truncated_{storage}"
    plugin = {"sqlite3": StoragePlugin.SQLITE3, "mcap": StoragePlugin.MCAP}[storage]
    kind = "sensor_msgs/msg/JointState"
    with Writer(path, version=9, storage_plugin=plugin) as writer:
        conn = writer.add_connection("/joint_states", kind, typestore=ts)
        for k in range(200):
            header = M["std_msgs/msg/Header"](M["builtin_interfaces/msg/Time"](1_700_000_000, k * 1000), "")
            msg = M[kind](header, ["a"], np.array([0.1 * k]), np.zeros(0), np.zeros(0))
            writer.write(conn, 1_700_000_000 * 10**9 + k * 1000, ts.serialize_cdr(msg, kind))
    data = next(p for p in path.iterdir() if p.suffix in (".db3", ".mcap"))
    data.write_bytes(data.read_bytes()[: data.stat().st_size // 2])
    return path
