"""Reliability of every ``handeye`` command against bad input: a clear one-line error, or a traceback?

Example
-------
::

    python benchmarks/reliability.py --out benchmarks/results/reliability.md

builds good inputs once in a temporary folder (a pose file, a synthetic board recording with its
detections, the ``small`` simulated dataset, labelled), damages them one way at a time (binary garbage,
an empty file, a directory where a file is expected, no read permission, non-UTF-8 and unicode names,
a truncated PNG, a ``../`` image path, NaN and inf in a pose file and in a dataset table, a 100 MB
sparse file, ...), runs each command on each in a subprocess with a timeout, and classifies the outcome:

* clear: exit 2, stderr one line starting with ``handeye `` that names the file, no traceback;
* unclear: exit 2 without a traceback, but not one line naming the file;
* traceback; other: another exit status; timeout;
* accepted: exit 0 on a bad input; ok: exit 0 on an input that only looks bad (valid content under a
  unicode or non-UTF-8 name), which is the right answer;
* leftovers: files left in the output folder by a failed run (a partial output).

Shard files are damaged with the manifest rewritten to match, so the table or image reader is tested,
not only the manifest's size check. Running as root, "no read permission" cannot be tested (root reads
anything); the case is then reported as not testable instead of faked.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

from benchmarks import reliability_faults as faults  # noqa: E402
from benchmarks._report import Report  # noqa: E402
from benchmarks.reliability_faults import set_cell  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
MB100 = 100 * 1024 * 1024
IS_ROOT = hasattr(os, "geteuid") and os.geteuid() == 0


@dataclass
class Case:
    """One command line on one bad input."""

    command: str
    what: str
    argv: list
    names: list[str]
    out_dir: Path
    legit: bool = False
    skip: str = ""
    timeout_s: float = 120.0
    hostile: bool = False
    input_mb: float = 0.0
    # filled by run_case
    outcome: str = ""
    rc: int | None = None
    stderr: str = ""
    leftovers: list = field(default_factory=list)
    peak_mb: float = 0.0
    wall_s: float = 0.0
    longest_line: int = 0
    leaked: int = 0


# ------------------------------------------------------------------ good inputs


def _python() -> str:
    venv = ROOT / ".venv" / "bin" / "python"
    return str(venv) if venv.exists() else sys.executable


def _handeye(argv: list, cwd: Path | None = None, timeout: float = 600) -> subprocess.CompletedProcess:
    env = dict(os.environ, PYTHONPATH=str(ROOT), PYTHONWARNINGS="ignore")
    return subprocess.run(
        [_python(), "-m", "handeye.cli", *argv], cwd=cwd or ROOT, env=env, capture_output=True, timeout=timeout
    )


def build_good_inputs(work: Path) -> dict:
    """A pose file, a board recording with detections, and the small labelled dataset."""
    from classic.vision.synthetic import make_image_dataset
    from handeye.core.posefile import write_pose_csv
    from handeye.core.synthetic import make_problem

    good = {}
    p = make_problem(12, "eye_to_hand", np.random.default_rng(0), camera_noise=(0.05, 0.5))
    good["poses"] = work / "good" / "poses.csv"
    good["poses"].parent.mkdir(parents=True)
    write_pose_csv(good["poses"], p.T_base_ee, p.T_cam_target)
    rec = work / "good" / "rec"
    make_image_dataset(rec, 8, "eye_to_hand", rng=np.random.default_rng(1))
    good.update(images=rec / "images", board=rec / "board.json", camera=rec / "camera.json", robot=rec / "robot.csv")
    good["detections"] = rec / "detections.json"
    r = _handeye(
        [
            "detect",
            str(good["images"]),
            "--board",
            str(good["board"]),
            "--intrinsics",
            str(good["camera"]),
            "-o",
            str(good["detections"]),
        ]
    )
    if r.returncode != 0:
        raise RuntimeError(f"detect on the good recording failed: {r.stderr.decode()}")
    data = work / "good" / "small"
    for argv in (
        ["sim", "generate", "--preset", "small", "--out", str(data), "--quiet"],
        ["label", str(data), "--quiet"],
    ):
        r = _handeye(argv)
        if r.returncode != 0:
            raise RuntimeError(f"{' '.join(argv)} failed: {r.stderr.decode()}")
    (data / ".lock").unlink(missing_ok=True)
    good["dataset"] = data
    return good


# ------------------------------------------------------------------ bad inputs


class Maker:
    """Writes bad inputs into fresh folders under ``work``."""

    def __init__(self, work: Path):
        self.work = work
        self.n = 0
        self.rng = np.random.default_rng(0)

    def folder(self) -> Path:
        self.n += 1
        d = self.work / "cases" / f"{self.n:04d}"
        d.mkdir(parents=True)
        return d

    def garbage(self, suffix: str, size: int = 4096) -> Path:
        p = self.folder() / f"garbage{suffix}"
        p.write_bytes(self.rng.integers(0, 256, size, dtype=np.uint8).tobytes())
        return p

    def empty(self, suffix: str) -> Path:
        p = self.folder() / f"empty{suffix}"
        p.write_bytes(b"")
        return p

    def directory(self, suffix: str) -> Path:
        p = self.folder() / f"adir{suffix}"
        p.mkdir()
        return p

    def big(self, suffix: str) -> Path:
        p = self.folder() / f"big{suffix}"
        with p.open("wb") as f:
            f.truncate(MB100)
        return p

    def copy(self, good: Path, name) -> Path:
        """``good`` (file or folder) copied under ``name`` (str, or bytes for a non-UTF-8 name)."""
        d = self.folder()
        dst = Path(os.fsdecode(os.path.join(os.fsencode(d), name if isinstance(name, bytes) else os.fsencode(name))))
        (shutil.copytree if good.is_dir() else shutil.copy)(good, dst)
        return dst

    def noperm(self, good: Path) -> Path:
        p = self.copy(good, "noperm" + good.suffix)
        os.chmod(p, 0)
        return p

    def text_edit(self, good: Path, name: str, edit) -> Path:
        p = self.folder() / name
        p.write_text(edit(good.read_text()))
        return p


def file_cases(mk: Maker, good: Path, suffix: str) -> list[tuple[str, Path, list[str], bool, str]]:
    """(what, path, name tokens, legit, skip) for the bad inputs every file argument gets."""
    out = [
        ("binary garbage", mk.garbage(suffix), ["garbage"], False, ""),
        ("empty file", mk.empty(suffix), ["empty"], False, ""),
        ("directory", mk.directory(suffix), ["adir"], False, ""),
        ("100 MB file", mk.big(suffix), ["big"], False, ""),
    ]
    if IS_ROOT:
        out.append(("no read permission", mk.folder() / f"noperm{suffix}", ["noperm"], False, "not testable as root"))
    else:
        out.append(("no read permission", mk.noperm(good), ["noperm"], False, ""))
    out.append(("non-UTF-8 name, valid content", mk.copy(good, b"name_\xff" + suffix.encode()), ["name_"], True, ""))
    out.append(
        (
            "unicode name, valid content",
            mk.copy(good, "p\u00f3s\u00e9_\u6570\u636e" + suffix),
            ["p\u00f3s\u00e9_"],
            True,
            "",
        )
    )
    return out


def pose_file_cases(mk: Maker, good: Path) -> list:
    """The generic file cases plus the pose-file grammar's own: NaN, inf, truncated rows, bad JSON."""
    out = file_cases(mk, good, ".csv")
    out += [
        (
            "NaN in a pose file",
            mk.text_edit(good, "nan.csv", lambda t: set_cell(t, 3, "T_base_ee.x", "nan")),
            ["nan.csv"],
            False,
            "",
        ),
        (
            "inf in a pose file",
            mk.text_edit(good, "inf.csv", lambda t: set_cell(t, 5, "T_cam_target.qw", "inf")),
            ["inf.csv"],
            False,
            "",
        ),
        (
            "-inf translation",
            mk.text_edit(good, "minf.csv", lambda t: set_cell(t, 0, "T_cam_target.z", "-inf")),
            ["minf.csv"],
            False,
            "",
        ),
        ("truncated last row", mk.text_edit(good, "trunc.csv", lambda t: t[: len(t) - 40]), ["trunc.csv"], False, ""),
        (
            "not a number",
            mk.text_edit(good, "word.csv", lambda t: set_cell(t, 2, "T_base_ee.y", "abc")),
            ["word.csv"],
            False,
            "",
        ),
        (
            "header only",
            mk.text_edit(good, "header.csv", lambda t: "\n".join(t.splitlines()[:2]) + "\n"),
            ["header.csv"],
            False,
            "",
        ),
        ("binary garbage .json", mk.garbage(".json"), ["garbage"], False, ""),
        ("JSON NaN matrix", _json_pose_file(mk, "nan.json", float("nan")), ["nan.json"], False, ""),
        ("JSON inf translation", _json_pose_file(mk, "inf.json", float("inf")), ["inf.json"], False, ""),
        ("binary garbage .yaml", mk.garbage(".yaml"), ["garbage"], False, ""),
    ]
    return out


def _json_pose_file(mk: Maker, name: str, bad: float) -> Path:
    from handeye.core.synthetic import make_problem

    p = make_problem(6, "eye_to_hand", np.random.default_rng(3))
    poses = [
        {"T_base_ee": {"matrix": a.tolist()}, "T_cam_target": {"matrix": b.tolist()}}
        for a, b in zip(p.T_base_ee, p.T_cam_target)
    ]
    if np.isnan(bad):
        poses[2]["T_base_ee"]["matrix"][0][1] = bad
    else:
        poses[4]["T_cam_target"]["matrix"][1][3] = bad
    path = mk.folder() / name
    path.write_text(json.dumps({"units": "m", "poses": poses}))
    return path


def _rewrite_manifest(shard: Path) -> None:
    from handeye.core.dataset import write_manifest

    doc = json.loads((shard / "manifest.json").read_text())
    write_manifest(shard, doc["camera_id"], doc["frames"])


def dataset_cases(mk: Maker, good: Path) -> list:
    """Damaged copies of the labelled dataset (shard damage with the manifest rewritten to match)."""
    out = [
        ("binary garbage instead of a folder", mk.garbage(""), ["garbage"], False, ""),
        ("empty folder", mk.directory(""), ["adir"], False, ""),
        ("empty file instead of a folder", mk.empty(""), ["empty"], False, ""),
    ]

    def damaged(what: str, edit, token: str, manifest: bool = True):
        root = mk.copy(good, "data")
        shard = root / "shards" / "cam_0000"
        edit(root, shard)
        if manifest:
            _rewrite_manifest(shard)
        out.append((what, root, [token], False, ""))

    def trunc_png(root, shard):
        for rel in ("rgb/calibration_000.png", "rgb/data_000.png", "depth/data_000.png"):
            p = shard / rel
            p.write_bytes(p.read_bytes()[:2000])

    def cell(table: str, row: int, column: str, value: str):
        def edit(root, shard):
            p = (root if table == "cameras.csv" else shard) / table
            p.write_text(set_cell(p.read_text(), row, column, value))

        return edit

    def replace(table: str, data: bytes | None):
        def edit(root, shard):
            p = (root if table in ("cameras.csv", "meta.json") else shard) / table
            if data is None:
                with p.open("wb") as f:
                    f.truncate(MB100)
            else:
                p.write_bytes(data)

        return edit

    garbage = np.random.default_rng(5).integers(0, 256, 4096, dtype=np.uint8).tobytes()
    damaged("meta.json binary garbage", replace("meta.json", garbage), "meta.json")
    damaged("meta.json empty", replace("meta.json", b""), "meta.json")
    damaged("cameras.csv binary garbage", replace("cameras.csv", garbage), "cameras.csv")
    damaged("cameras.csv empty", replace("cameras.csv", b""), "cameras.csv")
    damaged("cameras.csv 100 MB", replace("cameras.csv", None), "cameras.csv")
    damaged("cameras.csv inf in T_base_cam_true.x", cell("cameras.csv", 0, "T_base_cam_true.x", "inf"), "cameras.csv")
    damaged("cameras.csv NaN in radius_m", cell("cameras.csv", 0, "radius_m", "nan"), "cameras.csv")
    damaged("frames.csv binary garbage", replace("frames.csv", garbage), "frames.csv")
    damaged("frames.csv 100 MB", replace("frames.csv", None), "frames.csv")
    damaged("frames.csv NaN in T_base_ee.x", cell("frames.csv", 0, "T_base_ee.x", "nan"), "frames.csv")
    damaged("frames.csv inf in q0", cell("frames.csv", 1, "q0", "inf"), "frames.csv")
    damaged("frames.csv NaN in data q2", cell("frames.csv", 12, "q2", "nan"), "frames.csv")
    damaged("frames.csv ../ image path", cell("frames.csv", 0, "rgb", "../../../meta.json"), "frames.csv")
    damaged(
        "frames.csv ../ data image path", cell("frames.csv", 12, "rgb", "../cam_0001/rgb/data_000.png"), "frames.csv"
    )
    damaged("truncated PNG (manifest rewritten)", trunc_png, ".png")
    damaged("truncated PNG (manifest stale)", trunc_png, ".png", manifest=False)
    out.append(("non-UTF-8 folder name, valid content", mk.copy(good, b"data_\xff"), ["data_"], True, ""))
    out.append(
        ("unicode folder name, valid content", mk.copy(good, "d\u00e4t\u00e4_\u6570"), ["d\u00e4t\u00e4_"], True, "")
    )
    return out


def image_folder_cases(mk: Maker, good_images: Path) -> list:
    def folder_with(name: str, edit) -> Path:
        d = mk.copy(good_images, "images")
        edit(d)
        return d

    def trunc(d: Path):
        p = sorted(d.glob("*.png"))[0]
        p.write_bytes(p.read_bytes()[:1500])

    def garbage_png(d: Path):
        sorted(d.glob("*.png"))[1].write_bytes(np.random.default_rng(6).integers(0, 256, 4096, np.uint8).tobytes())

    def empty_png(d: Path):
        sorted(d.glob("*.png"))[2].write_bytes(b"")

    def big_png(d: Path):
        with sorted(d.glob("*.png"))[3].open("r+b") as f:
            f.truncate(MB100)

    return [
        ("file instead of a folder", mk.garbage(""), ["garbage"], False, ""),
        ("empty folder", mk.directory(""), ["adir"], False, ""),
        ("a truncated PNG", folder_with("trunc", trunc), [".png"], False, ""),
        ("a garbage PNG", folder_with("garbage", garbage_png), [".png"], False, ""),
        ("an empty PNG", folder_with("empty", empty_png), [".png"], False, ""),
        # a valid PNG padded with zeros: decoders stop at its IEND chunk, so the image is intact and used
        ("a valid PNG padded to 100 MB with zeros", folder_with("big", big_png), [".png"], True, ""),
        ("non-UTF-8 folder name, valid images", mk.copy(good_images, b"imgs_\xff"), ["imgs_"], True, ""),
        ("unicode folder name, valid images", mk.copy(good_images, "b\u00eflder_\u56fe"), ["b\u00eflder_"], True, ""),
    ]


# ------------------------------------------------------------------ the cases


def build_cases(work: Path, good: dict, quick: bool) -> list[Case]:
    mk = Maker(work)
    cases: list[Case] = []

    def add(command: str, items: list, argv_of, outputs: bool = True, timeout_s: float = 120.0):
        for what, path, names, legit, skip in items:
            out_dir = mk.folder()
            cases.append(Case(command, what, argv_of(path, out_dir), names, out_dir, legit, skip, timeout_s))

    pose_items = pose_file_cases(mk, good["poses"])
    add("calibrate POSES", pose_items, lambda p, o: ["calibrate", p, "--setup", "eye-to-hand", "-o", o / "result.json"])
    add(
        "calibrate --truth",
        file_cases(mk, good["board"], ".json"),
        lambda p, o: ["calibrate", good["poses"], "--setup", "eye-to-hand", "--truth", p, "-o", o / "result.json"],
    )
    det_items = file_cases(mk, good["detections"], ".json")
    add(
        "calibrate --detections",
        det_items,
        lambda p, o: [
            "calibrate",
            "--detections",
            p,
            "--robot-poses",
            good["robot"],
            "--setup",
            "eye-to-hand",
            "-o",
            o / "result.json",
        ],
    )
    robot_items = file_cases(mk, good["robot"], ".csv") + [
        (
            "NaN in robot poses",
            mk.text_edit(good["robot"], "nan.csv", lambda t: set_cell(t, 1, "T_base_ee.x", "nan")),
            ["nan.csv"],
            False,
            "",
        ),
        (
            "inf in robot poses",
            mk.text_edit(good["robot"], "inf.csv", lambda t: set_cell(t, 2, "T_base_ee.qz", "inf")),
            ["inf.csv"],
            False,
            "",
        ),
        (
            "image column names a missing file",
            mk.text_edit(good["robot"], "img.csv", lambda t: set_cell(t, 0, "image", "../../etc/passwd")),
            ["img.csv"],
            False,
            "",
        ),
    ]
    add(
        "calibrate --robot-poses",
        robot_items,
        lambda p, o: [
            "calibrate",
            "--detections",
            good["detections"],
            "--robot-poses",
            p,
            "--setup",
            "eye-to-hand",
            "-o",
            o / "result.json",
        ],
    )
    add(
        "plan POSES",
        pose_items,
        lambda p, o: ["plan", p, "--setup", "eye-to-hand", "--candidates", "200", "-o", o / "plan.csv"],
    )
    img_items = image_folder_cases(mk, good["images"])
    board_items = file_cases(mk, good["board"], ".json")
    add(
        "detect IMAGES",
        img_items,
        lambda p, o: ["detect", p, "--board", good["board"], "--intrinsics", good["camera"], "-o", o / "det.json"],
    )
    add(
        "detect --board",
        board_items,
        lambda p, o: ["detect", good["images"], "--board", p, "--intrinsics", good["camera"], "-o", o / "det.json"],
    )
    add(
        "detect --intrinsics",
        file_cases(mk, good["camera"], ".json"),
        lambda p, o: ["detect", good["images"], "--board", good["board"], "--intrinsics", p, "-o", o / "det.json"],
    )
    add(
        "intrinsics IMAGES",
        img_items,
        lambda p, o: ["intrinsics", p, "--board", good["board"], "-o", o / "camera.json"],
    )
    add(
        "intrinsics --board",
        board_items,
        lambda p, o: ["intrinsics", good["images"], "--board", p, "-o", o / "camera.json"],
    )

    # board: where the output goes
    f = mk.garbage("")
    board_out = [
        ("output folder missing", mk.folder() / "missing" / "b.png", ["b.png"], False, ""),
        ("output is a directory", mk.directory(".png"), ["adir"], False, ""),
        ("output under a file", f / "b.png", ["b.png"], False, ""),
        ("output suffix not an image", mk.folder() / "b.txt", ["b.txt"], False, ""),
        ("non-UTF-8 output name", Path(os.fsdecode(os.fsencode(mk.folder()) + b"/b_\xff.png")), ["b_"], True, ""),
        ("unicode output name", mk.folder() / "b\u00f6ard_\u677f.png", ["b\u00f6ard_"], True, ""),
    ]
    add("board -o", board_out, lambda p, o: ["board", "-o", p])

    # sim generate: a bad --out
    sim_out = [
        ("--out is a file", mk.garbage(""), ["garbage"], False, ""),
        ("--out under a file", mk.garbage("") / "data", ["garbage"], False, ""),
        ("--out holds a garbage meta.json", _garbage_meta(mk), ["meta.json"], False, ""),
        ("--out holds an empty meta.json", _garbage_meta(mk, b""), ["meta.json"], False, ""),
    ]
    add("sim generate --out", sim_out, lambda p, o: ["sim", "generate", "--preset", "small", "--out", p, "--quiet"])

    data_items = dataset_cases(mk, good["dataset"])
    # label writes into the dataset: its own copies
    label_items = [
        (w, mk.copy(p, "data") if p.is_dir() and p.name == "data" else p, n, legit, s)
        for w, p, n, legit, s in data_items
    ]
    add("label DATASET", label_items, lambda p, o: ["label", p, "--quiet", "--workers", "1"])
    add("show DATASET", data_items, lambda p, o: ["show", p, "--camera", "0", "-o", o / "cam0.png"])
    start = work / "good" / "start.json"
    cams = json.loads((good["dataset"] / "meta.json").read_text())
    start.write_text(json.dumps({"T_base_cam": np.eye(4).tolist()}))
    add(
        "markerless DATASET",
        data_items if not quick else data_items[:4],
        lambda p, o: ["markerless", p, "--camera", "0", "--quiet", "-o", o / "m.json"],
        timeout_s=180,
    )
    del cams
    add(
        "markerless --start",
        file_cases(mk, start, ".json"),
        lambda p, o: ["markerless", good["dataset"], "--camera", "0", "--start", p, "--quiet", "-o", o / "m.json"],
        timeout_s=180,
    )
    model_items = [
        ("model folder empty", mk.directory(""), ["adir"], False, ""),
        ("model is a file", mk.garbage(""), ["garbage"], False, ""),
        ("model files binary garbage", _garbage_model(mk), ["translation.pt"], False, ""),
    ]
    add("compare --model", model_items, lambda p, o: ["compare", good["dataset"], "--model", p, "--no-hybrid"])

    bag_items = [
        ("binary garbage", mk.garbage(""), ["garbage"], False, ""),
        ("empty folder", mk.directory(""), ["adir"], False, ""),
        ("100 MB file", mk.big(".mcap"), ["big"], False, ""),
        ("metadata.yaml binary garbage", _garbage_bag(mk, None), ["metadata.yaml", "/bag"], False, ""),
        ("metadata.yaml empty", _garbage_bag(mk, b""), ["metadata.yaml", "/bag"], False, ""),
    ]
    add(
        "bag-poses BAG",
        bag_items,
        lambda p, o: [
            "bag-poses",
            p,
            "--base",
            "base_link",
            "--ee",
            "tool0",
            "--marker-topic",
            "/marker",
            "-o",
            o / "poses.csv",
        ],
    )

    learned_data = data_items[:3] + [
        x for x in data_items if x[0] in ("meta.json binary garbage", "cameras.csv binary garbage")
    ]
    add(
        "learned run --data",
        learned_data,
        lambda p, o: [
            "learned",
            "run",
            "--data",
            p,
            "--preset",
            "tiny",
            "--strategies",
            "naive",
            "--quiet",
            "--out",
            o / "run",
        ],
        timeout_s=180,
    )
    run_items = [
        ("run dir empty", mk.directory(""), ["adir"], False, ""),
        ("run dir is a file", mk.garbage(""), ["garbage"], False, ""),
        ("results.json binary garbage", _garbage_run(mk), ["results.json"], False, ""),
    ]
    add("learned report RUN", run_items, lambda p, o: ["learned", "report", p])
    return cases


def _garbage_meta(mk: Maker, data: bytes | None = None) -> Path:
    d = mk.folder() / "out"
    d.mkdir()
    (d / "meta.json").write_bytes(
        np.random.default_rng(7).integers(0, 256, 2048, np.uint8).tobytes() if data is None else data
    )
    return d


def _garbage_model(mk: Maker) -> Path:
    d = mk.folder() / "model"
    d.mkdir()
    for name in ("translation.pt", "orientation.pt"):
        (d / name).write_bytes(np.random.default_rng(8).integers(0, 256, 4096, np.uint8).tobytes())
    return d


def _garbage_bag(mk: Maker, data: bytes | None) -> Path:
    d = mk.folder() / "bag"
    d.mkdir()
    (d / "metadata.yaml").write_bytes(
        np.random.default_rng(9).integers(0, 256, 2048, np.uint8).tobytes() if data is None else data
    )
    return d


def _garbage_run(mk: Maker) -> Path:
    d = mk.folder() / "run"
    d.mkdir()
    (d / "results.json").write_bytes(np.random.default_rng(10).integers(0, 256, 2048, np.uint8).tobytes())
    return d


# ------------------------------------------------------------------ hostile files

#: The bounds a command must stay within on a hostile input of at most ``HOSTILE_INPUT_MB``.
HOSTILE_INPUT_MB = 10.0
HOSTILE_PEAK_MB = 1024.0
HOSTILE_WALL_S = 30.0


def _size_mb(path: Path) -> float:
    path = Path(path)
    if path.is_symlink() or not path.exists():
        return 0.0
    if path.is_file():
        return path.stat().st_size / 2**20
    return sum(p.stat().st_size for p in path.rglob("*") if p.is_file() and not p.is_symlink()) / 2**20


def build_hostile_cases(work: Path, good: dict) -> list[Case]:
    """Every command that reads a user's file on the hostile corpus (:mod:`benchmarks.hostile_corpus`)."""
    from benchmarks import hostile_corpus as hc

    mk = Maker(work / "hostile")  # its own folders beside the sweep's
    cases: list[Case] = []

    def add(command, what, argv_of, path, names, legit=False):
        out_dir = mk.folder()
        cases.append(
            Case(command, what, argv_of(out_dir), names, out_dir, legit, hostile=True, input_mb=_size_mb(path))
        )

    for name, data in (
        ("png", hc.png_bomb()),
        ("jpg", hc.jpeg_bomb()),
        ("png", hc.png_bomb(bit_depth=16, colour_type=0)),
    ):
        folder = mk.folder() / f"bomb_{name}_{len(cases)}"
        folder.mkdir()
        (folder / f"bomb.{name}").write_bytes(data)
        add(
            "detect",
            f"{name} bomb",
            lambda o, f=folder: ["detect", f, "--board", good["board"], "-o", o / "d.json"],
            folder,
            ["bomb"],
        )
    for name, data in hc.pose_csvs().items():
        path = mk.folder() / name
        path.write_bytes(data)
        add(
            "calibrate POSES",
            name,
            lambda o, p=path: ["calibrate", p, "--setup", "eye-to-hand", "-o", o / "r.json"],
            path,
            [name],
            name in hc.LEGIT_POSE_FILES,
        )
    start = mk.folder() / "nested_start.json"
    start.write_text(hc.nested_json(100_000))
    add(
        "markerless --start",
        "nested JSON",
        lambda o: ["markerless", good["dataset"], "--start", start, "--camera", "0", "--quiet"],
        start,
        [start.name],
    )
    # labelling reads no depth, the markerless registration no colour: such a dataset is theirs to accept
    unread = {"label DATASET": ("depth_bomb", "symlink_leaves"), "markerless DATASET": ("rgb_bomb",)}
    for name, root in hc.hostile_datasets(good["dataset"], mk.folder()).items():
        argvs = {
            "label DATASET": lambda o, r=root: ["label", r, "--quiet"],
            "markerless DATASET": lambda o, r=root: ["markerless", r, "--camera", "0", "--quiet"],
        }
        for command, argv_of in argvs.items():
            add(command, name, argv_of, root, [root.name], name in unread[command])
    for storage in ("sqlite3", "mcap"):
        bag = hc.truncated_bag(mk.folder(), storage)
        add(
            "import bag",
            f"truncated {storage}",
            lambda o, b=bag: ["import", "bag", b, "--robot", "ur5", "--out", o / "ds"],
            bag,
            [bag.name],
        )
        add(
            "bag-poses",
            f"truncated {storage}",
            lambda o, b=bag: ["bag-poses", b, "--base", "a", "--ee", "b", "--marker-topic", "/m", "-o", o / "p.csv"],
            bag,
            [bag.name],
        )
    folder = mk.folder() / "placement"
    (folder / "rgb").mkdir(parents=True)
    (folder / "depth").mkdir()
    shutil.copy(good["camera"], folder / "intrinsics.json")
    (folder / "joints.csv").write_text("frame,a\nf0,0.1\n")
    (folder / "rgb" / "f0.png").write_bytes(hc.png_bomb())
    (folder / "depth" / "f0.png").write_bytes(hc.png_bomb(bit_depth=16, colour_type=0))
    add(
        "import folder",
        "png bombs",
        lambda o: ["import", "folder", folder, "--robot", "ur5", "--out", o / "ds"],
        folder,
        ["f0.png"],
    )
    try:
        models = hc.hostile_models(mk.folder())
    except ImportError:
        models = {}
    for name, model in models.items():
        add(
            "compare --model",
            name,
            lambda o, m=model: ["compare", good["dataset"], "--model", m, "--no-hybrid"],
            model,
            [model.name],
        )
    return cases


# ------------------------------------------------------------------ running and classifying


def _arg(a) -> bytes:
    return os.fsencode(a) if isinstance(a, (str, Path)) else a


#: Runs argv[2:] and writes its peak resident memory (kB, the child's own: this wrapper is small) to argv[1].
_PEAK_WRAPPER = (
    "import resource, subprocess, sys; r = subprocess.run(sys.argv[2:]); "
    "open(sys.argv[1], 'w').write(str(resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss)); "
    "sys.exit(r.returncode)"
)


def run_case(case: Case) -> Case:
    if case.skip:
        case.outcome = "not testable"
        return case
    before = set(case.out_dir.rglob("*"))
    env = dict(os.environ, PYTHONPATH=str(ROOT))  # no PYTHONWARNINGS: a leaked warning is counted
    cmd = [_arg(_python()), b"-m", b"handeye.cli", *map(_arg, case.argv)]
    if case.hostile:  # a small wrapper forks the command, so its peak memory does not start at this process's
        cmd = [_arg(_python()), b"-c", _PEAK_WRAPPER.encode(), _arg(case.out_dir / ".peak_kb"), *cmd]
    t0 = time.perf_counter()
    with tempfile.TemporaryFile() as out, tempfile.TemporaryFile() as err:
        proc = subprocess.Popen(cmd, cwd=case.out_dir, env=env, stdout=out, stderr=err)
        timer = threading.Timer(case.timeout_s, proc.kill)
        timer.start()
        try:
            _, status, usage = os.wait4(proc.pid, 0)  # this child's own peak memory, not the pool's
        finally:
            timer.cancel()
        proc.returncode = os.waitstatus_to_exitcode(status)
        case.wall_s = time.perf_counter() - t0
        case.peak_mb = usage.ru_maxrss / 1024.0  # kilobytes on Linux
        peak_file = case.out_dir / ".peak_kb"
        if case.hostile and peak_file.is_file():
            case.peak_mb = int(peak_file.read_text()) / 1024.0
            peak_file.unlink()
        err.seek(0)
        stderr = err.read()
    if case.wall_s >= case.timeout_s:
        case.outcome = "timeout"
        return case
    case.rc = proc.returncode
    case.stderr = stderr.decode("utf-8", "replace")
    if case.rc != 0:
        case.leftovers = sorted(
            str(p.relative_to(case.out_dir)) for p in set(case.out_dir.rglob("*")) - before if p.is_file()
        )
    # progress lines (redrawn with a carriage return) are not messages
    lines = [ln for ln in case.stderr.split("\n") if ln.strip() and not ln.startswith("\r")]
    case.longest_line = max((len(ln) for ln in lines), default=0)
    case.leaked = sum(
        bool(re.search(r"\w+Warning\b|warnings\.warn", ln)) and not ln.startswith("handeye ") for ln in lines
    )
    if "Traceback" in case.stderr:
        case.outcome = "traceback"
    elif case.rc == 0:
        case.outcome = "ok" if case.legit else "accepted"
    elif case.rc == 2:
        clear = len(lines) == 1 and lines[0].startswith("handeye ") and any(n in lines[0] for n in case.names)
        case.outcome = "clear" if clear else "unclear"
    else:
        case.outcome = "other"
    return case


def command_line(case: Case, work: Path) -> str:
    parts = []
    for a in case.argv:
        s = os.fsdecode(_arg(a)).replace(str(work), "$TMP")
        parts.append(s.encode("utf-8", "backslashreplace").decode())
    return "handeye " + " ".join(parts)


COLUMNS = ("clear", "unclear", "traceback", "other", "timeout", "accepted", "ok", "not testable")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", help="also write the report here (Markdown)")
    ap.add_argument("--workers", type=int, default=max(1, min(4, os.cpu_count() or 1)))
    ap.add_argument("--quick", action="store_true", help="fewer markerless cases, half the fault instances")
    ap.add_argument("--keep", action="store_true", help="keep the temporary folder")
    ap.add_argument("--hostile-only", action="store_true", help="only the hostile corpus (with its cost)")
    ap.add_argument(
        "--classes",
        help="only these fault classes of issue 40, comma-separated (no bad-file sweep, no hostile corpus): "
        + ", ".join(faults.CLASSES)
        + "; 'all' for every class; default: the sweep, the hostile corpus and every class",
    )
    args = ap.parse_args(argv)
    classes = faults.CLASSES if args.classes in (None, "all") else tuple(c.strip() for c in args.classes.split(","))
    unknown = sorted(set(classes) - set(faults.CLASSES))
    if unknown:
        ap.error(f"unknown fault classes {', '.join(unknown)}; known: {', '.join(faults.CLASSES)}")
    only_faults = args.classes is not None
    import numpy

    rep = Report(
        "Reliability: every command on bad input",
        "benchmarks/reliability.py",
        argv,
        f"numpy {numpy.__version__}; python {sys.version.split()[0]}",
    )
    work = Path(tempfile.mkdtemp(prefix="handeye-reliability-"))
    t0 = time.perf_counter()
    try:
        good = build_good_inputs(work)
        cases = [] if args.hostile_only or only_faults else build_cases(work, good, args.quick)
        cases += [] if only_faults else build_hostile_cases(work, good)
        fault_cases = [] if args.hostile_only else faults.build_faults(work, good, classes, args.quick)
        with ThreadPoolExecutor(args.workers) as pool:
            done = list(pool.map(run_case, cases))
            # the slowest first, so that the two workers finish together
            fault_done = list(pool.map(faults.run_fault, sorted(fault_cases, key=lambda f: -f.timeout_s)))
        fault_done.sort(key=lambda f: (faults.CLASSES.index(f.fault_class), f.command))
        faults_ok = faults.report_faults(rep, fault_done, work) if fault_done else True
        if only_faults:
            rep.say(f"{len(fault_done)} fault runs, {time.perf_counter() - t0:.0f} s")
            rep.write(args.out)
            return 0 if faults_ok else 1
        hostile_ok = report_hostile(rep, [c for c in done if c.hostile], work)
        done = [c for c in done if not c.hostile]
        wall = time.perf_counter() - t0
        rep.say(
            f"{len(done)} command lines, {wall:.0f} s; running as root: {'yes' if IS_ROOT else 'no'} "
            f"(no read permission {'not testable' if IS_ROOT else 'tested'})"
        )
        rep.say(
            "clear: exit 2, one stderr line 'handeye ...' naming the file; unclear: exit 2 otherwise; "
            "accepted: exit 0 on a bad input; ok: exit 0 on valid content under an unusual name or form (right); "
            "leftovers: a failed run left a file in its output folder"
        )
        rep.say()
        rep.say("| command | inputs tried | " + " | ".join(COLUMNS) + " | leftovers |")
        rep.say("|---" * (len(COLUMNS) + 3) + "|")
        commands = list(dict.fromkeys(c.command for c in done))
        totals = dict.fromkeys(COLUMNS, 0)
        for command in commands:
            mine = [c for c in done if c.command == command]
            counts = {k: sum(c.outcome == k for c in mine) for k in COLUMNS}
            for k in COLUMNS:
                totals[k] += counts[k]
            left = sum(bool(c.leftovers) for c in mine)
            rep.say(f"| {command} | {len(mine)} | " + " | ".join(str(counts[k]) for k in COLUMNS) + f" | {left} |")
        rep.say(
            f"| **all** | {len(done)} | "
            + " | ".join(str(totals[k]) for k in COLUMNS)
            + f" | {sum(bool(c.leftovers) for c in done)} |"
        )
        for title, keep in (
            ("Tracebacks", ("traceback",)),
            ("Unclear, other exit status, timeouts", ("unclear", "other", "timeout")),
            ("Bad inputs accepted", ("accepted",)),
        ):
            rep.say()
            rep.say(f"## {title}")
            rep.say()
            bad = [c for c in done if c.outcome in keep]
            if not bad:
                rep.say("none")
            for c in bad:
                last = [ln for ln in c.stderr.splitlines() if ln.strip()][-1:] or [""]
                rep.say(f"- {c.command}, {c.what} (exit {c.rc}, {c.outcome}): `{command_line(c, work)}`")
                rep.say(f"  - {last[0].replace(str(work), '$TMP')[:300]}")
        rep.say()
        rep.say("## Partial outputs left by a failed run")
        rep.say()
        left = [c for c in done if c.leftovers]
        if not left:
            rep.say("none")
        for c in left:
            rep.say(f"- {c.command}, {c.what}: {', '.join(c.leftovers)}")
        rep.say()
        rep.say("## Every case")
        rep.say()
        for c in done:
            rep.say(
                f"- {c.command} | {c.what} | {c.outcome}"
                + (f" ({c.skip})" if c.skip else "")
                + (f" | exit {c.rc}" if c.rc is not None else "")
            )
    finally:
        if args.keep:
            print(f"kept: {work}", file=sys.stderr)
        else:
            for p in work.rglob("*"):  # chmod 000 files (non-root runs) must be removable
                if p.is_file() and not p.is_symlink():
                    os.chmod(p, 0o600)
            shutil.rmtree(work, ignore_errors=True)
    rep.write(args.out)
    return 0 if hostile_ok and faults_ok else 1


def report_hostile(rep: Report, done: list, work: Path) -> bool:
    """The hostile corpus's table (per command: outcomes, longest error line, peak memory, time) and whether
    every run met the targets: no traceback, unclear answer or leaked warning, no line over 300 characters,
    inputs of at most 10 MB within 1 GB and 30 s."""
    rep.say("## Hostile files")
    rep.say()
    rep.say(
        f"Targets: 0 tracebacks, 0 unclear, 0 leaked warnings, no error line over 300 characters; an input of at "
        f"most {HOSTILE_INPUT_MB:g} MB within {HOSTILE_PEAK_MB:g} MB of memory and {HOSTILE_WALL_S:g} s. Peak "
        "memory: the command's process (ru_maxrss, Python and its imports included)."
    )
    rep.say()
    rep.say(
        "| command | inputs tried | clear | unclear | traceback | accepted | leaked warnings | longest line | "
        "peak MB | max s |"
    )
    rep.say("|---|---|---|---|---|---|---|---|---|---|")
    for command in dict.fromkeys(c.command for c in done):
        mine = [c for c in done if c.command == command]
        count = {k: sum(c.outcome == k for c in mine) for k in ("clear", "unclear", "traceback", "accepted")}
        rep.say(
            f"| {command} | {len(mine)} | {count['clear']} | {count['unclear']} | {count['traceback']} | "
            f"{count['accepted']} | {sum(c.leaked for c in mine)} | {max(c.longest_line for c in mine)} | "
            f"{max(c.peak_mb for c in mine):.0f} | {max(c.wall_s for c in mine):.1f} |"
        )
    bad = [
        c for c in done
        if c.outcome not in ("clear", "ok") or c.leaked or c.longest_line > 300
        or (c.input_mb <= HOSTILE_INPUT_MB and (c.peak_mb > HOSTILE_PEAK_MB or c.wall_s > HOSTILE_WALL_S))
    ]  # fmt: skip
    rep.say()
    rep.say(f"{len(done)} hostile inputs, {len(bad)} missing a target")
    for c in bad:
        last = [ln for ln in c.stderr.splitlines() if ln.strip()][-1:] or [""]
        rep.say(
            f"- {c.command}, {c.what}: {c.outcome}, {c.peak_mb:.0f} MB, {c.wall_s:.1f} s, leaked {c.leaked}: "
            f"`{last[0].replace(str(work), '$TMP')[:300]}`"
        )
    rep.say()
    rep.say("Every hostile case:")
    rep.say()
    for c in done:
        rep.say(
            f"- {c.command} | {c.what} | {c.outcome} | {c.input_mb:.2f} MB in | {c.peak_mb:.0f} MB | {c.wall_s:.1f} s"
        )
    rep.say()
    return not bad


if __name__ == "__main__":
    sys.exit(main())
