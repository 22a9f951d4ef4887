"""Property-based tests of the two file grammars: pose files and dataset tables.

Valid files in every form round-trip to 1e-12 against an independent reference (scipy's
``Rotation``); corrupted files raise the grammar's named error (``PoseFileError``, ``DatasetError``)
and never another exception. Deterministic (``derandomize=True``): CI sees the same examples every run.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from handeye.core.dataset import read_table, write_table
from handeye.core.errors import DatasetError, PoseFileError
from handeye.core.posefile import POSE_NAMES, read_pose_file, read_robot_poses, write_pose_csv
from tests.tolerances import ABSOLUTE_ONLY, FLOAT, RELATIVE_ONLY

ROUND_TRIP = FLOAT  # values written with repr(): the only error is one rounding in the reader's arithmetic
PROPS = settings(
    max_examples=150, deadline=None, derandomize=True, suppress_health_check=[HealthCheck.function_scoped_fixture]
)

FORMS = ("quat_named", "quat_positional", "rotvec", "json_matrix", "json_quaternion", "json_rotvec")


def _poses(seed: int, n: int, scale: float):
    """``n`` random poses: translations (metres) of magnitude ``scale`` and scipy rotations."""
    rng = np.random.default_rng(seed)
    t = rng.normal(size=(n, 3)) * scale
    R = Rotation.random(n, random_state=seed)
    return t, R


def _truth(t, R) -> np.ndarray:
    T = np.tile(np.eye(4), (len(t), 1, 1))
    T[:, :3, :3] = R.as_matrix()
    T[:, :3, 3] = t
    return T


def _write(path_stem, form: str, units: str, order: str, poses: dict):
    """A pose file in ``form``; ``poses`` maps name -> (t metres, Rotation). Returns the path."""
    k = 1e3 if units == "mm" else 1.0
    if form.startswith("json"):
        entries = []
        for i in range(len(next(iter(poses.values()))[0])):
            entry = {}
            for name, (t, R) in poses.items():
                if form == "json_matrix":
                    T = _truth(t[i : i + 1], R[i]).reshape(4, 4)
                    T[:3, 3] *= k
                    entry[name] = {"matrix": T.tolist()}
                elif form == "json_quaternion":
                    q = R[i].as_quat()
                    q = q if order == "xyzw" else np.roll(q, 1)
                    entry[name] = {"translation": (t[i] * k).tolist(), "quaternion": q.tolist()}
                else:
                    entry[name] = {"translation": (t[i] * k).tolist(), "rotvec": R[i].as_rotvec().tolist()}
            entries.append(entry)
        path = path_stem.with_suffix(".json")
        path.write_text(json.dumps({"units": units, "quaternion_order": order, "poses": entries}))
        return path
    header, cols = [], []
    for name, (t, R) in poses.items():
        header += [f"{name}.{c}" for c in "xyz"]
        cols.append(t * k)
        if form == "quat_named":
            header += [f"{name}.q{c}" for c in "xyzw"]
            cols.append(R.as_quat())
        elif form == "quat_positional":
            header += [f"{name}.q{j}" for j in range(4)]
            q = R.as_quat()
            cols.append(q if order == "xyzw" else np.roll(q, 1, axis=1))
        else:
            header += [f"{name}.r{c}" for c in "xyz"]
            cols.append(R.as_rotvec())
    values = np.concatenate(cols, axis=1)
    lines = ["# written by a property test", ",".join(header)]
    lines += [",".join(repr(float(v)) for v in row) for row in values]
    path = path_stem.with_suffix(".csv")
    path.write_text("\n".join(lines) + "\n")
    return path


@PROPS
@given(
    seed=st.integers(0, 2**31),
    n=st.integers(1, 8),
    form=st.sampled_from(FORMS),
    units=st.sampled_from(["m", "mm"]),
    order=st.sampled_from(["xyzw", "wxyz"]),
    scale=st.sampled_from([0.0, 1e-6, 0.3, 2.0, 50.0]),
)
def test_valid_pose_files_round_trip(tmp_path, seed, n, form, units, order, scale):
    poses = {name: _poses(seed + j, n, scale) for j, name in enumerate(POSE_NAMES)}
    path = _write(tmp_path / f"poses_{form}", form, units, order, poses)
    got = read_pose_file(
        path,
        quat_order=order if form == "quat_positional" else None,
        units=units if not form.startswith("json") else None,
    )
    for name in POSE_NAMES:
        np.testing.assert_allclose(
            getattr(got, name), _truth(*poses[name]), rtol=ABSOLUTE_ONLY, atol=ROUND_TRIP * max(1, scale)
        )
    assert len(got.rows) == n
    robot = read_robot_poses(
        path,
        quat_order=order if form == "quat_positional" else None,
        units=units if not form.startswith("json") else None,
    )
    np.testing.assert_array_equal(robot.T_base_ee, got.T_base_ee)


@PROPS
@given(seed=st.integers(0, 2**31), n=st.integers(1, 8), scale=st.sampled_from([0.0, 1e-6, 0.3, 2.0, 50.0]))
def test_write_pose_csv_round_trips(tmp_path, seed, n, scale):
    T1, T2 = _truth(*_poses(seed, n, scale)), _truth(*_poses(seed + 1, n, scale))
    path = tmp_path / "written.csv"
    write_pose_csv(path, T1, T2, comment="two\nlines")
    got = read_pose_file(path)
    np.testing.assert_allclose(got.T_base_ee, T1, rtol=ABSOLUTE_ONLY, atol=ROUND_TRIP * max(1, scale))
    np.testing.assert_allclose(got.T_cam_target, T2, rtol=ABSOLUTE_ONLY, atol=ROUND_TRIP * max(1, scale))


def _valid_csv(seed: int) -> str:
    poses = {name: _poses(seed + j, 5, 0.5) for j, name in enumerate(POSE_NAMES)}
    lines = [",".join(f"{name}.{c}" for name in POSE_NAMES for c in ("x", "y", "z", "qx", "qy", "qz", "qw"))]
    values = np.concatenate([np.concatenate([t, R.as_quat()], axis=1) for t, R in poses.values()], axis=1)
    return "\n".join(lines + [",".join(repr(float(v)) for v in row) for row in values]) + "\n"


def _cell(text: str, row: int, col: int, value: str) -> str:
    lines = text.splitlines()
    cells = lines[1 + row].split(",")
    cells[col] = value
    lines[1 + row] = ",".join(cells)
    return "\n".join(lines) + "\n"


BAD_CELLS = ["nan", "NaN", "inf", "-inf", "+Infinity", "", "abc", "1.2.3", "0x10", "1e400", "--1", "\u00e9", '"']


@PROPS
@given(seed=st.integers(0, 1000), row=st.integers(0, 4), col=st.integers(0, 13), bad=st.sampled_from(BAD_CELLS))
def test_a_bad_cell_is_refused_naming_line_and_column(tmp_path, seed, row, col, bad):
    path = tmp_path / "bad.csv"
    path.write_text(_cell(_valid_csv(seed), row, col, bad))
    with pytest.raises(PoseFileError) as info:
        read_pose_file(path)
    assert str(path) in str(info.value) and f"line {row + 2}" in str(info.value)


@PROPS
@given(seed=st.integers(0, 1000), row=st.integers(0, 4), extra=st.integers(-3, 3).filter(lambda k: k != 0))
def test_wrong_field_count_is_refused(tmp_path, seed, row, extra):
    lines = _valid_csv(seed).splitlines()
    cells = lines[1 + row].split(",")
    cells = cells[:extra] if extra < 0 else cells + ["0.5"] * extra
    lines[1 + row] = ",".join(cells)
    path = tmp_path / "ragged.csv"
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(PoseFileError, match=f"line {row + 2}"):
        read_pose_file(path)


@PROPS
@given(seed=st.integers(0, 1000), cut=st.floats(0.0, 1.0), suffix=st.sampled_from([".csv", ".json"]))
def test_truncated_files_read_or_raise_pose_file_error(tmp_path, seed, cut, suffix):
    """A file cut anywhere: either still a valid file (cut at a row boundary) or a PoseFileError."""
    if suffix == ".csv":
        text = _valid_csv(seed)
    else:
        poses = {name: _poses(seed + j, 4, 0.5) for j, name in enumerate(POSE_NAMES)}
        text = _write(tmp_path / "full", "json_quaternion", "m", "xyzw", poses).read_text()
    path = tmp_path / f"cut{suffix}"
    path.write_text(text[: int(cut * len(text))])
    try:
        got = read_pose_file(path)
    except PoseFileError as exc:
        assert str(path) in str(exc)
    else:
        assert np.isfinite(got.T_base_ee).all() and np.isfinite(got.T_cam_target).all()


@PROPS
@given(data=st.binary(min_size=0, max_size=2000), suffix=st.sampled_from([".csv", ".json", ".txt"]))
def test_random_bytes_raise_pose_file_error(tmp_path, data, suffix):
    path = tmp_path / f"random{suffix}"
    path.write_bytes(data)
    with pytest.raises(PoseFileError):
        read_pose_file(path)
    with pytest.raises(PoseFileError):
        read_robot_poses(path)


@PROPS
@given(
    seed=st.integers(0, 1000),
    k=st.integers(0, 3),
    name=st.sampled_from(POSE_NAMES),
    bad=st.sampled_from([float("nan"), float("inf"), -float("inf")]),
    form=st.sampled_from(["json_matrix", "json_quaternion", "json_rotvec"]),
)
def test_non_finite_json_is_refused_naming_the_entry(tmp_path, seed, k, name, bad, form):
    poses = {n: _poses(seed + j, 4, 0.5) for j, n in enumerate(POSE_NAMES)}
    path = _write(tmp_path / "p", form, "m", "xyzw", poses)
    doc = json.loads(path.read_text())
    entry = doc["poses"][k][name]
    key = list(entry)[k % len(entry)]
    if key == "matrix":
        entry["matrix"][k % 3][(k + 1) % 4] = bad
    else:
        entry[key][k % 3] = bad
    path.write_text(json.dumps(doc))  # Python's json writes NaN and Infinity
    with pytest.raises(PoseFileError, match=rf"poses\[{k}\]\.{name}"):
        read_pose_file(path)


# ------------------------------------------------------------------ dataset tables

_INT = ["camera_id", "frame"]
_STR = ["split", "rgb"]
_FLOAT = ["q0", "T_base_ee.x", "radius_m"]
_text = st.text(st.characters(blacklist_categories=("Cs",), blacklist_characters="\x00"), max_size=12)


@st.composite
def tables(draw):
    n = draw(st.integers(0, 6))
    table = {}
    for c in _INT:
        table[c] = np.array(draw(st.lists(st.integers(-(2**40), 2**40), min_size=n, max_size=n)), dtype=int)
    for c in _STR:
        table[c] = np.array(draw(st.lists(_text, min_size=n, max_size=n)), dtype=object)
    finite = st.floats(allow_nan=False, allow_infinity=False)
    for c in _FLOAT:
        table[c] = np.array(draw(st.lists(st.one_of(finite, st.just(np.nan)), min_size=n, max_size=n)), dtype=float)
    return table


@PROPS
@given(table=tables())
def test_dataset_tables_round_trip(tmp_path, table):
    path = tmp_path / "t.csv"
    write_table(path, table)
    back = read_table(path, list(table))
    assert list(back) == list(table)
    for c in _INT:
        np.testing.assert_array_equal(back[c], table[c])
    for c in _STR:
        assert list(back[c]) == list(table[c])
    for c in _FLOAT:
        np.testing.assert_allclose(back[c], table[c], rtol=ROUND_TRIP, atol=RELATIVE_ONLY, equal_nan=True)


def _valid_table_text(tmp_path, seed: int) -> str:
    rng = np.random.default_rng(seed)
    table = {
        "camera_id": np.arange(4),
        "frame": np.arange(4),
        "split": np.array(["train"] * 4, dtype=object),
        "rgb": np.array([f"rgb/{i}.png" for i in range(4)], dtype=object),
        "q0": rng.normal(size=4),
        "T_base_ee.x": rng.normal(size=4),
        "radius_m": rng.uniform(1, 2, 4),
    }
    path = tmp_path / "valid.csv"
    write_table(path, table)
    return path.read_text()


@PROPS
@given(
    seed=st.integers(0, 1000),
    row=st.integers(0, 3),
    col=st.sampled_from(["camera_id", "frame", *_FLOAT]),
    bad=st.sampled_from(["nan", "inf", "-inf", "Infinity", "abc", "1.5x", "\u00e9", "1e400"]),
)
def test_a_bad_table_cell_is_refused_naming_row_and_column(tmp_path, seed, row, col, bad):
    text = _valid_table_text(tmp_path, seed)
    lines = text.splitlines()
    header = lines[0].split(",")
    cells = lines[1 + row].split(",")
    cells[header.index(col)] = bad
    lines[1 + row] = ",".join(cells)
    path = tmp_path / "bad.csv"
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(DatasetError) as info:
        read_table(path, ["camera_id"])
    assert str(path) in str(info.value) and f"row {row + 2}" in str(info.value) and col in str(info.value)


@PROPS
@given(seed=st.integers(0, 1000), cut=st.floats(0.0, 1.0))
def test_truncated_tables_read_or_raise_dataset_error(tmp_path, seed, cut):
    text = _valid_table_text(tmp_path, seed)
    path = tmp_path / "cut.csv"
    path.write_text(text[: int(cut * len(text))])
    try:
        back = read_table(path, ["camera_id", "frame", "split", "rgb", *_FLOAT])
    except DatasetError as exc:
        assert str(path) in str(exc)
    else:
        assert all(len(v) == len(back["camera_id"]) for v in back.values())


@PROPS
@given(data=st.binary(min_size=0, max_size=2000))
def test_random_bytes_raise_dataset_error(tmp_path, data):
    path = tmp_path / "random.csv"
    path.write_bytes(data)
    with pytest.raises(DatasetError):
        read_table(path, ["camera_id", "frame"])
