"""The fault classifier of benchmarks/reliability_faults.py on canned outputs and on small fake commands.

Each check is one the benchmark's table rests on: a refusal is clear only as one line naming the file; exit 0
on bad data is silent; a file cut at RLIMIT_FSIZE with exit 0 is silent, a temporary file left by a failed
run is counted; a FIFO replaced by a regular file is destroyed; labels said written and absent are lost; the
number variants are ones Python's float() accepts (so they test the reader's grammar, not float's).
"""

from __future__ import annotations

import os
import sys

import pytest

from benchmarks import reliability_faults as F


def _fault(tmp_path, **kw) -> F.Fault:
    base = dict(fault_class="numbers", command="calibrate", what="x", argv=[], names=["poses.csv"], out_dir=tmp_path)
    base.update(kw)
    return F.Fault(**base)


@pytest.mark.parametrize(
    ("rc", "stderr", "legit", "expect", "outcome"),
    [
        (2, "handeye calibrate: error: /a/poses.csv, line 4: '0_2' is not a number\n", False, "", "clear"),
        (2, "handeye calibrate: error: File too large\n", False, "", "unclear"),  # names no file
        (2, "handeye calibrate: error: /a/poses.csv: bad\nhandeye calibrate: error: again\n", False, "", "unclear"),
        (2, "handeye label: warning: pose 1 beyond\nhandeye label: error: /a/poses.csv: bad\n", False, "", "clear"),
        (2, "handeye calibrate: error: /a/poses.csv: " + "x" * 300 + "\n", False, "", "unclear"),  # too long
        (2, "handeye calibrate: error: /a/poses.csv: no such file\n", False, "FIFO|pipe", "unclear"),
        (2, "handeye calibrate: error: /a/poses.csv: a FIFO, not a file\n", False, "FIFO|pipe", "clear"),
        (1, "Traceback (most recent call last):\n  File x\nValueError: y\n", False, "", "traceback"),
        (0, "", False, "", "silent"),
        (0, "", True, "", "ok"),
        (-9, "", False, "", "other"),
    ],
)
def test_classify(tmp_path, rc, stderr, legit, expect, outcome):
    f = _fault(tmp_path, legit=legit, expect=expect)
    f.rc, f.stderr = rc, stderr
    assert F.classify(f) == outcome


def test_number_variants_are_what_float_accepts():
    """Each variant but the NaN/inf/huge ones parses with float() to the original value: a reader built on
    float() takes them silently, which is what the benchmark looks for. The control is the same value."""
    token = "0.30752812852271205"
    variants = {name: text for name, text, _, _ in F.number_variants(token)}
    for name in ("underscore", "full-width digits", "Arabic-Indic digits", "leading no-break space",
                 "trailing ideographic space", "control: the same value in scientific notation"):  # fmt: skip
        assert float(variants[name]) == float(token), name
    assert float.fromhex(variants["hex float"]) == float(token)
    assert len(variants["5000-digit integer"]) == 5000
    legit = [name for name, _, ok, _ in F.number_variants(token) if ok]
    assert legit == ["control: the same value in scientific notation"]


def _fake(monkeypatch, code: str) -> None:
    """Run ``code`` in Python instead of the handeye command."""
    monkeypatch.setattr(F, "_command", lambda f, argv: [os.fsencode(sys.executable), b"-c", code.encode()])


def test_full_disk_exit_0_with_a_cut_file_is_silent(tmp_path, monkeypatch):
    _fake(monkeypatch, "try:\n with open('out.json','w') as fh: fh.write('x'*4096)\nexcept OSError: pass\n")
    f = F.run_fault(_fault(tmp_path, fsize=1000, watch=[tmp_path], names=["out.json"]))
    assert (tmp_path / "out.json").stat().st_size == 1000
    assert f.outcome == "silent" and "cut at the limit" in f.damage


def test_full_disk_whole_small_file_is_ok_and_a_temporary_left_is_counted(tmp_path, monkeypatch):
    _fake(monkeypatch, "open('out.json','w').write('{}')")
    assert F.run_fault(_fault(tmp_path, fsize=1000, watch=[tmp_path])).outcome == "ok"
    d = tmp_path / "second"
    d.mkdir()
    _fake(
        monkeypatch,
        "import sys\ntry:\n with open('out.json.tmp','w') as fh: fh.write('x'*4096)\nexcept OSError:\n"
        " sys.exit('handeye calibrate: error: out.json: cannot write (File too large)')\n",
    )
    f = F.run_fault(_fault(d, fsize=1000, watch=[d], names=["out.json"]))
    assert f.outcome == "clear" and "out.json.tmp" in f.damage


def test_a_fifo_target_replaced_by_a_file_is_destroyed(tmp_path):
    t = tmp_path / "out.json"
    os.mkfifo(t)
    check = F._target_check(t, "fifo")
    assert check(_fault(tmp_path)) == ""
    t.unlink()
    t.write_text("{}")
    assert "fifo became a file" in check(_fault(tmp_path))


def test_labels_said_written_and_absent_are_lost(tmp_path):
    root = tmp_path / "data"
    root.mkdir()
    header = "camera_id,T_base_cam_label.x,label_status,T_base_cam_markerless.x\n"
    (root / "cameras.csv").write_text(header + "0,0.5,ok,\n1,0.6,ok,\n")
    f = _fault(tmp_path)
    f.rc_first, f.rc2 = 0, 0  # label first, then markerless: both exit 0
    assert "markerless exited 0" in F._lost_labels(root, "label")(f)
    (root / "cameras.csv").write_text(header + "0,0.5,ok,1.1\n1,0.6,ok,\n")
    assert F._lost_labels(root, "label")(f) == ""
    f.rc_first = 2  # label refused: its columns may be absent
    (root / "cameras.csv").write_text("camera_id,T_base_cam_markerless.x\n0,1.1\n1,\n")
    assert F._lost_labels(root, "label")(f) == ""


def test_corrupt_mcap_changes_only_the_named_record(tmp_path):
    pytest.importorskip("rosbags")
    import struct

    import numpy as np
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore

    ts = get_typestore(Stores.ROS2_HUMBLE)
    M, kind = ts.types, "sensor_msgs/msg/JointState"
    path = tmp_path / "whole"
    with Writer(path, version=9, storage_plugin=StoragePlugin.MCAP) as writer:
        conn = writer.add_connection("/joint_states", kind, typestore=ts)
        for k in range(20):
            header = M["std_msgs/msg/Header"](M["builtin_interfaces/msg/Time"](1, k), "")
            writer.write(
                conn,
                10**9 + k,
                ts.serialize_cdr(M[kind](header, ["a"], np.array([0.1]), np.zeros(0), np.zeros(0)), kind),
            )
    data = next(path.glob("*.mcap")).read_bytes()
    for how in F.MCAP_DAMAGE:
        bad = F.corrupt_mcap(data, how)
        diff = [k for k in range(len(data)) if data[k] != bad[k]]
        assert len(bad) == len(data) and 1 <= len(diff) <= 8, how
    bad = F.corrupt_mcap(data, F.MCAP_DAMAGE[0])
    diff = [k for k in range(len(data)) if data[k] != bad[k]]
    assert struct.unpack_from("<H", bad, diff[-1] - 1)[0] == 0xFFFF  # the channel id now unknown
