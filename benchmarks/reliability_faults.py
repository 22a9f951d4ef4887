"""Fault generators of the reliability benchmark: what a hostile user or machine does besides bad files.

Used by ``benchmarks/reliability.py --classes ...`` (issue 40). Each class of fault has a generator that
writes several instances of it into a temporary folder and returns the command lines to run on them:

* ``targets``: each writing command's output is a symlink, a dangling symlink, a FIFO, a character device
  (a copy of ``/dev/full`` made with ``mknod``: the real one is never offered to a root run), a directory or
  a missing folder; "destroyed" is a target whose type or content changed, or a FIFO or device replaced;
* ``concurrent``: ``label`` and ``markerless --write-labels`` on one dataset at once; "lost" is a command that
  exited 0 saying it wrote labels that the final ``cameras.csv`` lacks;
* ``disk``: each writing command under ``RLIMIT_FSIZE`` with ``SIGXFSZ`` ignored (a full disk as the
  process sees it); "destroyed" is a file the failed run left or changed, or a rerun without the limit
  that fails; exit 0 with a file cut at the limit is a silent acceptance;
* ``kill``: ``sim generate`` and ``label`` killed with SIGKILL mid-run; "lost" is a worker still alive 2 s
  later;
* ``numbers``: underscores, full-width and Arabic-Indic digits, hex floats, leading and trailing junk that
  ``float()`` strips, 5000-digit integers, NaN and Infinity constants, in every number-bearing format (pose
  CSV, JSON, easy_handeye YAML, OpenCV YAML, matrix files, dataset tables, ``meta.json``, ``--start``), and
  the same value in plain scientific notation as a control that must be accepted;
* ``depth``: 32FC1 depth in millimetres and 16UC1 in metres in bags, float ``.npy`` in millimetres and a
  16-bit PNG in metres in folders (and the right units as controls);
* ``joints``: NaN, inf, 1e300, degrees and a duplicated joint name, in bags and folders;
* ``placements``: a dataset where one placement's calibration poses are in mm, identical or duplicated;
* ``truth``: a non-orthonormal ``--truth``, camera_info ``fx = 1e-300`` (bag, folder, ``meta.json``), absurd
  translations in the truth columns of ``cameras.csv``;
* ``pairs``: ``calibrate`` on 10^4 and 10^5 poses (under a 4 GB address-space limit, so that a run that
  would exhaust the machine fails instead);
* ``tracebacks``: corrupt MCAP records, a ``.npy`` header declaring 100000^2 pixels, a manifest of the
  wrong type, ``-o`` into a folder that cannot be written, a lock file that is a folder, stdout on a full
  device;
* ``messages``: a FIFO or device where a table or a pose file is expected, a zero quaternion in
  ``--start``, NaN in ``meta.json``'s camera matrix, a UTF-8 BOM in CSV files (accepting it is right).

Every run is classified as: clear (exit 1 or 2, one stderr line starting ``handeye`` that names the file,
at most 300 characters, and says what the case's ``expect`` asks, e.g. "millimetres"), unclear, silent
(exit 0 on bad data), ok (exit 0 where that is right), traceback, timeout or other (a signal or another
status); separately, destroyed/lost, with what.
"""

from __future__ import annotations

import csv
import hashlib
import io
import json
import os
import re
import shutil
import signal
import stat
import subprocess
import sys
import tempfile
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
CLASSES = (
    "targets",
    "concurrent",
    "disk",
    "kill",
    "numbers",
    "depth",
    "joints",
    "placements",
    "truth",
    "pairs",
    "tracebacks",
    "messages",
)
#: The targets of issue 40: every message one line of at most this many characters ...
MAX_LINE = 300
#: ... and every run within this memory (MB) and time (s).
MAX_PEAK_MB = 1024.0
MAX_WALL_S = 30.0
#: Address-space limit of the runs that may allocate without bound (pairs, a device read as a file).
AS_LIMIT = 4 * 2**30
#: Seconds after SIGKILL of the parent at which its workers are counted.
ORPHAN_WAIT_S = 2.0

OUTCOMES = ("clear", "unclear", "silent", "traceback", "timeout", "other", "ok")


@dataclass
class Fault:
    """One command line (or two at once) on one fault, and what happened."""

    fault_class: str
    command: str
    what: str
    argv: list
    names: list
    out_dir: Path
    legit: bool = False
    expect: str = ""
    timeout_s: float = 60.0
    fsize: int | None = None
    as_limit: int | None = None
    stdout_full: bool = False
    watch: list = field(default_factory=list)
    check: Callable | None = None
    rerun: bool = False
    kind: str = "run"
    argv2: list | None = None
    delay_s: float = 0.0
    # results
    outcome: str = ""
    rc: int | None = None
    rc_first: int | None = None
    rc2: int | None = None
    stderr: str = ""
    stdout: str = ""
    peak_mb: float = 0.0
    wall_s: float = 0.0
    longest_line: int = 0
    damage: str = ""
    note: str = ""


# ------------------------------------------------------------------ running


def _python() -> str:
    venv = ROOT / ".venv" / "bin" / "python"
    return str(venv) if venv.exists() else sys.executable


def _env() -> dict:
    return dict(os.environ, PYTHONPATH=str(ROOT), PYTHONDONTWRITEBYTECODE="1")


def _arg(a) -> bytes:
    return os.fsencode(a) if isinstance(a, (str, Path)) else a


#: argv: peak-file fsize as-limit stdout-full command...; sets the limits (SIGXFSZ ignored, so a write past
#: RLIMIT_FSIZE fails with EFBIG as on a full disk), runs the command, writes its peak memory (kB).
_WRAPPER = r"""
import os, resource, signal, subprocess, sys
peak, fsize, aslim, full = sys.argv[1:5]
def limits():
    signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
    if fsize != "-":
        resource.setrlimit(resource.RLIMIT_FSIZE, (int(fsize), int(fsize)))
    if aslim != "-":
        resource.setrlimit(resource.RLIMIT_AS, (int(aslim), int(aslim)))
# the command's stdout and stderr through pipes (RLIMIT_FSIZE applies to regular files, not to pipes or devices)
out = open("/dev/full", "w") if full == "1" else subprocess.PIPE
r = subprocess.run(sys.argv[5:], preexec_fn=limits, stdout=out, stderr=subprocess.PIPE)
sys.stdout.buffer.write(r.stdout or b"")
sys.stderr.buffer.write(r.stderr)
open(peak, "w").write(str(resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss))
sys.exit(r.returncode)
"""


def _command(f: Fault, argv: list) -> list:
    return [_arg(_python()), b"-m", b"handeye.cli", *map(_arg, argv)]


def _snapshot(paths: list) -> dict:
    """Path to (kind, size, digest) of everything under ``paths`` (links not followed)."""
    out = {}
    for top in paths:
        top = Path(top)
        items = [top] + (sorted(top.rglob("*")) if top.is_dir() and not top.is_symlink() else [])
        for p in items:
            try:
                st = p.lstat()
            except OSError:
                continue
            if stat.S_ISREG(st.st_mode):
                digest = hashlib.md5(p.read_bytes()).hexdigest() if st.st_size < 64 * 2**20 else st.st_mtime_ns
                out[str(p)] = ("file", st.st_size, digest)
            elif stat.S_ISLNK(st.st_mode):
                out[str(p)] = ("link", 0, os.readlink(p))
            elif not stat.S_ISDIR(st.st_mode):
                out[str(p)] = (stat.S_IFMT(st.st_mode), 0, "")
    return out


def _changed(before: dict, after: dict) -> list:
    return sorted(p for p in after if before.get(p) != after[p])


def _lines(stderr: str) -> list:
    return [ln for ln in stderr.split("\n") if ln.strip() and not ln.startswith("\r")]


def classify(f: Fault) -> str:
    """The outcome of a finished run from its exit status and stderr (see the module docstring)."""
    lines = _lines(f.stderr)
    f.longest_line = max((len(ln) for ln in lines), default=0)
    if "Traceback (most recent call last)" in f.stderr:
        return "traceback"
    if f.rc == 0:
        return "ok" if f.legit else "silent"
    if f.rc not in (1, 2):
        return "other"
    errors = [ln for ln in lines if not _WARNING.match(ln)]  # warnings about other things are their own lines
    if len(errors) != 1 or not all(ln.startswith("handeye ") and len(ln) <= MAX_LINE for ln in lines):
        return "unclear"
    line = errors[0]
    named = any(n in line for n in f.names)
    said = not f.expect or re.search(f.expect, line, re.IGNORECASE) is not None
    return "clear" if named and said else "unclear"


#: A warning line of a command (``handeye label: warning: ...``), not its error.
_WARNING = re.compile(r"^handeye [\w -]+: warning: ")


def _spawn(f: Fault, argv: list, peak_file: Path, limited: bool = True):
    cmd = [
        _arg(_python()),
        b"-c",
        _WRAPPER.encode(),
        _arg(peak_file),
        str(f.fsize if limited and f.fsize else "-").encode(),
        str(f.as_limit if f.as_limit else "-").encode(),
        b"1" if f.stdout_full else b"0",
        *_command(f, argv),
    ]
    out, err = tempfile.TemporaryFile(), tempfile.TemporaryFile()
    proc = subprocess.Popen(cmd, cwd=f.out_dir, env=_env(), stdout=out, stderr=err)
    return proc, out, err


def _finish(proc, out, err, timeout_s: float, peak_file: Path) -> tuple:
    timer = threading.Timer(timeout_s, proc.kill)
    timer.start()
    try:
        proc.wait()
    finally:
        timer.cancel()
    out.seek(0)
    err.seek(0)
    peak = int(peak_file.read_text()) / 1024.0 if peak_file.is_file() else 0.0
    peak_file.unlink(missing_ok=True)
    text = out.read().decode("utf-8", "replace"), err.read().decode("utf-8", "replace")
    out.close()
    err.close()
    return proc.returncode, text[0], text[1], peak


def run_fault(f: Fault) -> Fault:
    """Run one fault case and classify it (fills the result fields)."""
    try:
        if f.kind == "kill":
            return _run_kill(f)
        return _run(f)
    except Exception as exc:  # the benchmark's own failure is reported, never hidden
        f.outcome, f.damage = "other", f"benchmark error: {type(exc).__name__}: {exc}"
        return f


def _run(f: Fault) -> Fault:
    before = _snapshot(f.watch)
    t0 = time.perf_counter()
    peak1 = f.out_dir / ".peak1"
    p1 = _spawn(f, f.argv, peak1)
    p2 = None
    if f.argv2 is not None:
        time.sleep(f.delay_s)
        p2 = _spawn(f, f.argv2, f.out_dir / ".peak2")
    rc, out, err, peak = _finish(*p1, f.timeout_s, peak1)
    f.wall_s = time.perf_counter() - t0
    timed_out = f.wall_s >= f.timeout_s
    if p2 is not None:
        rc2, out2, err2, peak2 = _finish(*p2, f.timeout_s, f.out_dir / ".peak2")
        f.wall_s = time.perf_counter() - t0
        timed_out = timed_out or f.wall_s >= f.timeout_s + f.delay_s
        f.rc_first, f.rc2 = rc, rc2
        rc = rc if rc != 0 else rc2  # the pair's status: the first failure's
        out, err, peak = out + out2, err + err2, max(peak, peak2)
    f.rc, f.stdout, f.stderr, f.peak_mb = rc, out, err, peak
    f.outcome = "timeout" if timed_out else classify(f)
    after = _snapshot(f.watch)
    damage = []
    if f.fsize and not timed_out:
        changed = [p for p in _changed(before, after) if not p.endswith(".lock")]
        cut = [p for p in changed if after[p][0] == "file" and after[p][1] >= f.fsize]
        temporary = [p for p in changed if p not in cut and _TEMPORARY.search(p[len(str(f.out_dir)) :])]
        if f.rc == 0:  # right only if every file it wrote is whole (below the limit)
            f.outcome = "silent" if cut else f.outcome if f.outcome == "traceback" else "ok"
            if cut:
                damage.append("exit 0 with " + ", ".join(_short(p, f) for p in cut[:3]) + " cut at the limit")
        else:
            if cut or temporary:
                damage.append("left " + ", ".join(_short(p, f) for p in (cut + temporary)[:4]))
            whole = [p for p in changed if p not in cut and p not in temporary]
            if whole:
                f.note = "whole files written before the failure: " + ", ".join(_short(p, f) for p in whole[:4])
    if f.check is not None:
        said = f.check(f)
        if said:
            damage.append(said)
    if f.rerun and f.rc != 0 and f.outcome != "timeout":
        peak_r = f.out_dir / ".peakr"
        rc_r, _, err_r, _ = _finish(*_spawn(f, f.argv, peak_r, limited=False), 300, peak_r)
        if rc_r != 0:
            last = (_lines(err_r) or [""])[-1]
            damage.append(f"rerun without the limit failed (exit {rc_r}): {last[:160]}")
    f.damage = "; ".join(damage)
    return f


#: Names of temporary or half-written files and folders.
_TEMPORARY = re.compile(r"\.tmp|\.partial|\.importing|/\.[^/]*\.|~$")


def _short(p: str, f: Fault) -> str:
    for top in f.watch:
        top = str(top)
        if p.startswith(top):
            return Path(top).name + p[len(top) :]
    return p


def _descendants(pid: int) -> list:
    children: dict = {}
    for d in os.listdir("/proc"):
        if d.isdigit():
            try:
                with open(f"/proc/{d}/stat") as fh:
                    ppid = int(fh.read().rsplit(")", 1)[1].split()[1])
            except (OSError, ValueError, IndexError):
                continue
            children.setdefault(ppid, []).append(int(d))
    out, todo = [], [pid]
    while todo:
        for c in children.get(todo.pop(), []):
            out.append(c)
            todo.append(c)
    return out


def _alive(pid: int) -> bool:
    try:
        with open(f"/proc/{pid}/stat") as fh:
            return fh.read().rsplit(")", 1)[1].split()[0] not in ("Z", "X")
    except OSError:
        return False


def _run_kill(f: Fault) -> Fault:
    """Start the command, SIGKILL it after ``delay_s``, count its descendants alive ``ORPHAN_WAIT_S`` later."""
    t0 = time.perf_counter()
    with tempfile.TemporaryFile() as err:
        proc = subprocess.Popen(_command(f, f.argv), cwd=f.out_dir, env=_env(), stdout=subprocess.DEVNULL, stderr=err)
        deadline = time.perf_counter() + f.timeout_s
        while not _descendants(proc.pid) and proc.poll() is None and time.perf_counter() < deadline:
            time.sleep(0.1)  # until its first child process starts (a loaded machine imports slowly)
        time.sleep(f.delay_s)
        workers = _descendants(proc.pid)
        finished = proc.poll() is not None
        proc.send_signal(signal.SIGKILL)
        proc.wait()
        time.sleep(ORPHAN_WAIT_S)
        left = [p for p in workers if _alive(p)]
        for p in left:  # ours: ended by id
            try:
                os.kill(p, signal.SIGKILL)
            except OSError:
                pass
        err.seek(0)
        f.stderr = err.read().decode("utf-8", "replace")
    f.wall_s = time.perf_counter() - t0
    f.rc = proc.returncode
    f.longest_line = 0  # what a killed command and its orphans print is no message of the command's
    if "Traceback (most recent call last)" in f.stderr:
        f.outcome = "traceback"
    elif finished:
        f.outcome, f.damage = "other", "finished before the kill: not tested"
    elif not workers:
        f.outcome, f.note = "other", "no child process at the kill: not tested"
    else:
        f.outcome = "ok"
        if left:
            f.damage = f"{len(left)} of its {len(workers)} child processes alive {ORPHAN_WAIT_S:g} s after kill -9"
    return f


# ------------------------------------------------------------------ building blocks


class Work:
    """Fresh folders under the benchmark's temporary folder, and the good inputs to damage."""

    def __init__(self, work: Path, good: dict):
        self.root = work / "faults"
        self.root.mkdir(parents=True, exist_ok=True)
        self.good = good
        self.n = 0
        self._cache: dict = {}

    def folder(self, tag: str = "") -> Path:
        self.n += 1
        d = self.root / f"{self.n:04d}{tag}"
        d.mkdir(parents=True)
        return d

    def dataset(self, name: str = "data", labelled: bool = True) -> Path:
        """A private copy of the small dataset (without its label columns if not ``labelled``)."""
        root = self.folder() / name
        shutil.copytree(self.good["dataset"], root, symlinks=True)
        (root / ".lock").unlink(missing_ok=True)
        if not labelled:
            _strip_columns(
                root / "cameras.csv", ("T_base_cam_label.", "label_", "T_base_cam_markerless.", "markerless_")
            )
            for p in ("labels.md", "label_errors.png"):
                (root / p).unlink(missing_ok=True)
        return root

    def fault(self, fault_class: str, command: str, what: str, argv_of, names, **kw) -> Fault:
        out = self.folder()
        return Fault(fault_class, command, what, argv_of(out), list(names), out, **kw)


def _strip_columns(path: Path, prefixes: tuple) -> None:
    rows = list(csv.reader(io.StringIO(path.read_text())))
    keep = [k for k, name in enumerate(rows[0]) if not name.startswith(prefixes)]
    buf = io.StringIO()
    csv.writer(buf, lineterminator="\n").writerows([[r[k] for k in keep] for r in rows])
    path.write_text(buf.getvalue())


def set_cell(text: str, row: int, column: str, value: str) -> str:
    """The CSV text with one cell replaced (row counts data rows from 0; ``#`` lines and the header skipped).

    Parameters
    ----------
    text : str
        A CSV file's text.
    row : int
    column : str
        The header's name of the column.
    value : str

    Returns
    -------
    str
    """
    lines = text.splitlines()
    k = next(i for i, ln in enumerate(lines) if ln and not ln.startswith("#"))
    header = lines[k].split(",")
    cells = lines[k + 1 + row].split(",")
    cells[header.index(column)] = value
    lines[k + 1 + row] = ",".join(cells)
    return "\n".join(lines) + "\n"


def _get_cell(text: str, row: int, column: str) -> str:
    lines = text.splitlines()
    k = next(i for i, ln in enumerate(lines) if ln and not ln.startswith("#"))
    return lines[k + 1 + row].split(",")[lines[k].split(",").index(column)]


def _rewrite_manifest(shard: Path) -> None:
    from benchmarks.hostile_corpus import rewrite_manifest

    rewrite_manifest(shard)


def _mknod(path: Path, minor: int) -> str:
    """A character device at ``path`` (a copy of /dev/null 3, /dev/zero 5 or /dev/full 7), or a symlink to the
    real one where this process may not create devices; returns what it is."""
    try:
        os.mknod(path, 0o666 | stat.S_IFCHR, os.makedev(1, minor))
        return "character device"
    except (PermissionError, OSError):
        path.symlink_to({3: "/dev/null", 5: "/dev/zero", 7: "/dev/full"}[minor])
        return "symlink to a device"


def _kind(path: Path) -> str:
    try:
        st = path.lstat()
    except FileNotFoundError:
        return "missing"
    m = st.st_mode
    return (
        "link"
        if stat.S_ISLNK(m)
        else "fifo"
        if stat.S_ISFIFO(m)
        else "chardev"
        if stat.S_ISCHR(m)
        else "dir"
        if stat.S_ISDIR(m)
        else "file"
    )


PRECIOUS = "a file of the user's that no command may destroy\n"


def _target_check(path: Path, kind: str, keep: Path | None = None, keep_on_failure: Path | None = None):
    """A check that the output target ``path`` is still a ``kind``, that ``keep`` (a user's file inside a target
    folder) is unchanged whatever the run did, and ``keep_on_failure`` (the file a symlink target points to)
    unchanged when the run failed."""

    def check(f: Fault) -> str:
        now = _kind(path)
        if now != kind:
            return f"{path.name}: the {kind} became a {now}"
        for p, always in ((keep, True), (keep_on_failure, False)):
            if p is not None and (always or f.rc != 0):
                if not p.is_file() or p.read_text(errors="replace") != PRECIOUS:
                    return f"{p.name} changed or removed" + ("" if always else " by a failed run")
        return ""

    return check


# ------------------------------------------------------------------ the writers


def _small_sim_argv(out) -> list:
    """``handeye sim generate`` of the small preset's first camera into ``out``, one worker."""
    return ["sim", "generate", "--preset", "small", "--cameras", "0:1", "--out", out, "--workers", "1"]


def writers(w: Work) -> dict:
    """Command name to (argv of the output path, output suffix, timeout s); every command with -o/--out."""
    if "writers" in w._cache:
        return w._cache["writers"]
    g = w.good
    ds = w.dataset("markerless_data")
    folder = _recording_folder(w, "good_folder")
    w._cache["writers"] = {
        "calibrate -o": (lambda t: ["calibrate", g["poses"], "--setup", "eye-to-hand", "-o", t], ".json", 60),
        "calibrate --report": (
            lambda t: ["calibrate", g["poses"], "--setup", "eye-to-hand", "--report", t],
            "",
            90,
        ),
        "markerless -o": (lambda t: ["markerless", ds, "--camera", "0", "--quiet", "-o", t], ".json", 120),
        "detect -o": (
            lambda t: ["detect", g["images"], "--board", g["board"], "--intrinsics", g["camera"], "-o", t],
            ".json",
            60,
        ),
        "intrinsics -o": (lambda t: ["intrinsics", g["images"], "--board", g["board"], "-o", t], ".json", 60),
        "board -o": (lambda t: ["board", "-o", t], ".png", 60),
        "plan -o": (
            lambda t: ["plan", g["poses"], "--setup", "eye-to-hand", "--candidates", "200", "-o", t],
            ".csv",
            90,
        ),
        "import folder --out": (
            lambda t: ["import", "folder", folder, "--robot", "ur5", "--out", t, "--quiet"],
            "/",
            120,
        ),
        "sim generate --out": (
            lambda t: [*_small_sim_argv(t), "--quiet"],
            "/",
            180,
        ),
    }
    return w._cache["writers"]


def _special_target(t: Path, what: str) -> tuple[str, str, Path | None]:
    """Make ``t`` a FIFO, a /dev/full device node or a folder holding a precious file: (kind, what, precious)."""
    if what == "FIFO":
        os.mkfifo(t)
        return "fifo", what, None
    if what == "device":
        made = _mknod(t, 7)
        return ("chardev" if made == "character device" else "link"), f"device ({made} of /dev/full)", None
    t.mkdir()
    precious = t / "keep.txt"
    precious.write_text(PRECIOUS)
    return "dir", what, precious


def gen_targets(w: Work) -> list:
    """Output targets: symlink, dangling symlink, FIFO, character device, directory, missing folder."""
    out = []
    for command, (argv_of, suffix, timeout) in writers(w).items():
        is_dir = suffix in ("", "/")
        name = "out" + ("" if is_dir else suffix)
        for what in (
            "symlink to a file",
            "dangling symlink",
            "FIFO",
            "device",
            "directory",
            "regular file",
            "missing folder",
        ):
            if what == "regular file" and not is_dir:
                continue  # a file target is the normal case
            d = w.folder()
            t = d / name
            precious = on_failure = None
            legit = what in ("symlink to a file", "dangling symlink", "missing folder")
            if what == "symlink to a file":
                real = d / ("real" if is_dir else "real" + suffix)
                if is_dir:
                    real.mkdir()
                else:
                    real.write_text(PRECIOUS)
                    on_failure = real
                t.symlink_to(real)
                kind = "link"
            elif what == "dangling symlink":
                t.symlink_to(d / "nowhere" / name)
                kind = "link"
            elif what in ("FIFO", "device", "directory"):
                if what == "directory":
                    legit = is_dir  # a report or a dataset may go into a folder that exists: its files must stay
                kind, what, precious = _special_target(t, what)
                if what == "directory" and is_dir:
                    what = "non-empty directory"
            elif what == "regular file":
                t.write_text(PRECIOUS)
                on_failure, kind = t, "file"
            else:
                t = d / "missing" / name
                kind = None
            check = _target_check(t, kind, precious, on_failure) if kind else None
            out.append(
                Fault(
                    "targets",
                    command,
                    what,
                    argv_of(t),
                    [name, "missing"],
                    d,
                    legit=legit,
                    timeout_s=timeout,
                    check=check,
                )
            )
    # label writes into the dataset: labels.md as each kind of target
    for what in ("FIFO", "device", "directory", "symlink to a file", "dangling symlink"):
        root = w.dataset()
        t = root / "labels.md"
        t.unlink(missing_ok=True)
        precious = on_failure = None
        if what in ("FIFO", "device", "directory"):
            kind, what, precious = _special_target(t, what)
        elif what == "symlink to a file":
            real = root.parent / "real.md"
            real.write_text(PRECIOUS)
            t.symlink_to(real)
            on_failure, kind = real, "link"
        else:
            t.symlink_to(root.parent / "nowhere" / "labels.md")
            kind = "link"
        out.append(
            Fault(
                "targets",
                "label",
                f"labels.md: {what}",
                ["label", root, "--quiet", "--workers", "1"],
                ["labels.md"],
                root.parent,
                legit=what.startswith(("symlink", "dangling")),
                timeout_s=120,
                check=_target_check(t, kind, precious, on_failure),
            )
        )
    return out


def gen_concurrent(w: Work) -> list:
    """label and markerless --write-labels on one unlabelled dataset at once (several start offsets)."""
    out = []
    for first, delay in (("label", 0.0), ("label", 1.0), ("label", 3.0), ("markerless", 1.0)):
        root = w.dataset(labelled=False)
        label = ["label", root, "--quiet", "--workers", "1"]
        mless = ["markerless", root, "--camera", "0", "--write-labels", "--quiet"]
        a, b = (label, mless) if first == "label" else (mless, label)
        f = Fault(
            "concurrent",
            "label + markerless --write-labels",
            f"{first} first, the other {delay:g} s later",
            a,
            [root.name, "cameras.csv", ".lock"],
            root.parent,
            legit=True,
            timeout_s=180,
            argv2=b,
            delay_s=delay,
            check=_lost_labels(root, first),
        )
        out.append(f)
    return out


def _lost_labels(root: Path, first: str):
    def check(f: Fault) -> str:
        rc_label, rc_mless = (f.rc_first, f.rc2) if first == "label" else (f.rc2, f.rc_first)
        text = (root / "cameras.csv").read_text()
        rows = list(csv.DictReader(io.StringIO(text)))
        lost = []
        if rc_label == 0 and not all(r.get("T_base_cam_label.x") for r in rows if r.get("label_status") != "refused"):
            lost.append("label exited 0, its label columns are not in cameras.csv")
        if rc_label == 0 and "T_base_cam_label.x" not in rows[0]:
            lost.append("label exited 0, cameras.csv has no label column")
        cam0 = next((r for r in rows if r["camera_id"] == "0"), {})
        if rc_mless == 0 and not cam0.get("T_base_cam_markerless.x"):
            lost.append("markerless exited 0, its label of camera 0 is not in cameras.csv")
        return "; ".join(lost)

    return check


def gen_disk(w: Work) -> list:
    """Every writing command under RLIMIT_FSIZE (512 B and 16 KiB), SIGXFSZ ignored; then a rerun."""
    out = []
    for limit in (512, 16384):
        for command, (argv_of, suffix, timeout) in writers(w).items():
            d = w.folder()
            t = d / ("out" + ("" if suffix in ("", "/") else suffix))
            out.append(
                Fault(
                    "disk",
                    command,
                    f"file size limit {limit} B",
                    argv_of(t),
                    [t.name],
                    d,
                    fsize=limit,
                    timeout_s=timeout,
                    watch=[d],
                    rerun=True,
                )
            )
        root = w.dataset(labelled=False)
        out.append(
            Fault(
                "disk",
                "label",
                f"file size limit {limit} B",
                ["label", root, "--quiet", "--workers", "1"],
                [root.name, "cameras.csv", "labels.md", "label_errors.png"],
                root.parent,
                fsize=limit,
                timeout_s=120,
                watch=[root],
                rerun=True,
            )
        )
        root = w.dataset(labelled=True)
        out.append(
            Fault(
                "disk",
                "markerless --write-labels",
                f"file size limit {limit} B",
                ["markerless", root, "--camera", "0", "--write-labels", "--quiet"],
                [root.name, "cameras.csv"],
                root.parent,
                fsize=limit,
                timeout_s=120,
                watch=[root],
                rerun=True,
            )
        )
    return out


def gen_kill(w: Work) -> list:
    out = []
    for delay in (0.5, 2.0, 5.0):
        d = w.folder()
        out.append(
            Fault(
                "kill",
                "sim generate",
                f"kill -9 {delay:g} s after its first child process",
                ["sim", "generate", "--preset", "small", "--out", d / "ds", "--quiet", "--workers", "2"],
                [],
                d,
                legit=True,
                kind="kill",
                delay_s=delay,
                timeout_s=60,
            )
        )
    for delay in (0.5, 2.0):
        root = w.dataset(labelled=False)
        out.append(
            Fault(
                "kill",
                "label",
                f"kill -9 {delay:g} s after its first child process",
                ["label", root, "--quiet", "--workers", "2"],
                [],
                root.parent,
                legit=True,
                kind="kill",
                delay_s=delay,
                timeout_s=60,
            )
        )
    return out


# ------------------------------------------------------------------ numbers


def _digits(s: str, zero: int) -> str:
    return "".join(chr(zero + int(c)) if c.isdigit() else c for c in s)


def number_variants(token: str) -> list:
    """(name, text, legit, json_raw) for one plain number ``token``: each a form a strict reader refuses, and the
    plain scientific form of the same value (legit). ``json_raw``: written bare in JSON, else as a string."""
    v = float(token)
    k = next((i for i in range(len(token) - 1) if token[i].isdigit() and token[i + 1].isdigit()), None)
    under = token + "_0" if k is None else token[: k + 1] + "_" + token[k + 1 :]  # between two digits
    return [
        ("underscore", under, False, False),
        ("full-width digits", _digits(token, 0xFF10), False, False),
        ("Arabic-Indic digits", _digits(token, 0x0660), False, False),
        ("hex float", float.hex(v), False, False),
        ("leading no-break space", "\u00a0" + token, False, False),
        ("trailing ideographic space", token + "\u3000", False, False),
        ("5000-digit integer", "9" * 5000, False, True),
        ("NaN constant", "NaN", False, True),
        ("Infinity constant", "Infinity", False, True),
        ("control: the same value in scientific notation", f"{v:.17e}", True, True),
    ]


def _json_with(doc, value: str, raw: bool) -> str:
    """``doc`` (holding the string "@@") as JSON with "@@" replaced by ``value`` (bare or as a JSON string)."""
    text = json.dumps(doc, indent=1)
    return text.replace('"@@"', value if raw else json.dumps(value, ensure_ascii=False))


def gen_numbers(w: Work) -> list:
    from handeye.core.easy_handeye import write_easy_handeye_samples
    from handeye.core.posefile import write_pose_csv
    from handeye.core.synthetic import make_problem

    g = w.good
    out = []
    p = make_problem(12, "eye_to_hand", np.random.default_rng(0), camera_noise=(0.05, 0.5))
    base = w.folder("_numbers")
    write_pose_csv(base / "poses.csv", p.T_base_ee, p.T_cam_target)
    csv_text = (base / "poses.csv").read_text()
    write_easy_handeye_samples(base / "samples.yaml", p.T_base_ee, p.T_cam_target, "eye_to_hand")
    yaml_text = (base / "samples.yaml").read_text()
    cal = ["--setup", "eye-to-hand"]

    def add(command, fmt, name, make, argv_of, names, legit, timeout=60):
        d = w.folder()
        path = make(d)
        out.append(Fault("numbers", command, f"{fmt}: {name}", argv_of(path), names, d, legit=legit, timeout_s=timeout))

    token = _get_cell(csv_text, 2, "T_base_ee.x")
    for name, text, legit, raw in number_variants(token):

        def pose_csv(d, text=text):
            (d / "poses.csv").write_text(set_cell(csv_text, 2, "T_base_ee.x", text), encoding="utf-8")
            return d / "poses.csv"

        add("calibrate", "pose CSV", name, pose_csv, lambda q: ["calibrate", q, *cal], ["poses.csv"], legit)

        def pose_json(d, text=text, raw=raw):
            poses = [
                {"T_base_ee": {"matrix": a.tolist()}, "T_cam_target": {"matrix": b.tolist()}}
                for a, b in zip(p.T_base_ee, p.T_cam_target)
            ]
            poses[2]["T_base_ee"]["matrix"][0][3] = "@@"
            (d / "poses.json").write_text(_json_with({"units": "m", "poses": poses}, text, raw), encoding="utf-8")
            return d / "poses.json"

        add("calibrate", "pose JSON", name, pose_json, lambda q: ["calibrate", q, *cal], ["poses.json"], legit)

        def easy_yaml(d, text=text, name=name):
            lines = yaml_text.splitlines()
            hits = [i for i, ln in enumerate(lines) if re.match(r"^\s+x: -?[0-9]", ln)]
            i = hits[4]  # a translation x of the third sample
            indent, value = lines[i].split("x: ")
            yaml_value = {"NaN constant": ".nan", "Infinity constant": ".inf"}.get(name, text)
            lines[i] = f"{indent}x: {yaml_value}"
            (d / "samples.yaml").write_text("\n".join(lines) + "\n", encoding="utf-8")
            return d / "samples.yaml"

        add(
            "calibrate", "easy_handeye YAML", name, easy_yaml, lambda q: ["calibrate", q, *cal], ["samples.yaml"], legit
        )

        def opencv_yaml(d, text=text):
            lines = ["%YAML:1.0", "---", f"frameCount: {len(p.T_base_ee)}"]
            for i, (a, b) in enumerate(zip(p.T_base_ee, p.T_cam_target)):
                for key, T in (("T1", a), ("T2", b)):
                    vals = [repr(float(x)) for x in T.reshape(-1)]
                    if i == 2 and key == "T1":
                        vals[3] = text
                    lines += [
                        f"{key}_{i}: !!opencv-matrix",
                        "   rows: 4",
                        "   cols: 4",
                        "   dt: d",
                        f"   data: [ {', '.join(vals)} ]",
                    ]
            (d / "pairs.yml").write_text("\n".join(lines) + "\n", encoding="utf-8")
            return d / "pairs.yml"

        add("calibrate", "OpenCV YAML", name, opencv_yaml, lambda q: ["calibrate", q, *cal], ["pairs.yml"], legit)

        def matrices(d, text=text):
            for fname, Ts in (("robot.txt", p.T_base_ee), ("camera.txt", p.T_cam_target)):
                rows = [[repr(float(x)) for x in T.reshape(-1)] for T in Ts]
                if fname == "robot.txt":
                    rows[2][3] = text
                (d / fname).write_text("\n".join(" ".join(r) for r in rows) + "\n", encoding="utf-8")
            return d

        add(
            "calibrate",
            "matrix files",
            name,
            matrices,
            lambda q: ["calibrate", "--robot-poses", q / "robot.txt", "--camera-poses", q / "camera.txt", *cal],
            ["robot.txt"],
            legit,
        )

    ds_csv = (g["dataset"] / "cameras.csv").read_text()
    tok = _get_cell(ds_csv, 0, "T_base_cam_true.x")
    for name, text, legit, raw in number_variants(tok):
        root = w.dataset()
        (root / "cameras.csv").write_text(set_cell(ds_csv, 0, "T_base_cam_true.x", text), encoding="utf-8")
        out.append(
            Fault(
                "numbers",
                "label",
                f"cameras.csv: {name}",
                ["label", root, "--quiet", "--workers", "1"],
                ["cameras.csv"],
                root.parent,
                legit=legit,
                timeout_s=120,
            )
        )
    frames = (g["dataset"] / "shards" / "cam_0000" / "frames.csv").read_text()
    tok = _get_cell(frames, 1, "T_base_ee.x")
    for name, text, legit, raw in number_variants(tok):
        root = w.dataset()
        shard = root / "shards" / "cam_0000"
        (shard / "frames.csv").write_text(set_cell(frames, 1, "T_base_ee.x", text), encoding="utf-8")
        _rewrite_manifest(shard)
        out.append(
            Fault(
                "numbers",
                "label",
                f"frames.csv: {name}",
                ["label", root, "--quiet", "--workers", "1"],
                ["frames.csv"],
                root.parent,
                legit=legit,
                timeout_s=120,
            )
        )
    meta = json.loads((g["dataset"] / "meta.json").read_text())
    fx = repr(float(meta["calibration_intrinsics"]["K"][0][0]))  # label reads the board camera's
    for name, text, legit, raw in number_variants(fx):
        root = w.dataset()
        doc = json.loads(json.dumps(meta))
        doc["calibration_intrinsics"]["K"][0][0] = "@@"
        (root / "meta.json").write_text(_json_with(doc, text, raw), encoding="utf-8")
        out.append(
            Fault(
                "numbers",
                "label",
                f"meta.json: {name}",
                ["label", root, "--quiet", "--workers", "1"],
                ["meta.json"],
                root.parent,
                legit=legit,
                timeout_s=120,
            )
        )
    start_T = _true_pose(g["dataset"], 0)
    for name, text, legit, raw in number_variants(repr(float(start_T[0, 3]))):
        d = w.folder()
        M = start_T.tolist()
        M[0][3] = "@@"
        (d / "start.json").write_text(_json_with({"T_base_cam": M}, text, raw), encoding="utf-8")
        out.append(
            Fault(
                "numbers",
                "markerless --start",
                f"--start JSON: {name}",
                ["markerless", g["dataset"], "--camera", "0", "--start", d / "start.json", "--quiet"],
                ["start.json"],
                d,
                legit=legit,
                timeout_s=120,
            )
        )
    return out


def _true_pose(root: Path, camera: int) -> np.ndarray:
    from handeye.core.se3 import transform_from_pos_quat_xyzw

    row = next(
        r for r in csv.DictReader(io.StringIO((root / "cameras.csv").read_text())) if r["camera_id"] == str(camera)
    )
    t = [float(row[f"T_base_cam_true.{a}"]) for a in "xyz"]
    q = [float(row[f"T_base_cam_true.{a}"]) for a in ("qx", "qy", "qz", "qw")]
    return transform_from_pos_quat_xyzw(np.array(t), np.array(q))


# ------------------------------------------------------------------ recordings (bags and folders)


class _Proxy:
    """A dataset seen through changes: depth scaled, intrinsics replaced."""

    def __init__(self, ds, depth_scale: float = 1.0, intrinsics: dict | None = None):
        self._ds, self._scale = ds, depth_scale
        self.meta = dict(ds.meta)
        if intrinsics is not None:
            self.meta["intrinsics"] = intrinsics
            self.meta.pop("calibration_intrinsics", None)

    def __getattr__(self, name):
        return getattr(self._ds, name)

    def depth_m(self, c, name):
        return self._ds.depth_m(c, name) * self._scale


_BAG_LOCK = threading.Lock()


def _bag(w: Work, storage="sqlite3", encoding="16UC1", depth_scale=1.0, joint_hook=None, intrinsics=None) -> Path:
    """Camera 0's data recording of the small dataset as a ROS 2 bag, changed as asked."""
    import sim.bag_export as be
    from handeye.core.dataset import Dataset

    ds = _Proxy(Dataset.open(w.good["dataset"]), depth_scale, intrinsics)
    d = w.folder("_bag")
    with _BAG_LOCK:
        original = be.BagWriter.add
        if joint_hook is not None:

            def add(self, topic, msgtype, stamp_ns, msg):
                if topic == "/joint_states":
                    names, pos = joint_hook(list(msg.name), np.array(msg.position, dtype=float), stamp_ns)
                    msg = self.M[msgtype](msg.header, names, pos, np.zeros(0), np.zeros(0))
                original(self, topic, msgtype, stamp_ns, msg)

            be.BagWriter.add = add
        try:
            written = be.write_placement_bags(ds, 0, d, storage, encoding, "raw")
        finally:
            be.BagWriter.add = original
    return written["data"]


def _recording_folder(w: Work, name: str, depth: str = "png_mm", joints=None, intrinsics_edit=None) -> Path:
    """Camera 0's data frames of the small dataset as an import folder (intrinsics.yaml, joints.csv, rgb/,
    depth/); ``depth`` is png_mm, png_m, npy_m or npy_mm; ``joints`` edits (names, q) -> (names, q)."""
    from PIL import Image

    from classic.vision.camera import CameraIntrinsics
    from classic.vision.camera_yaml import write_camera_info_yaml
    from handeye.core.dataset import Dataset

    src = Dataset.open(w.good["dataset"])
    folder = w.folder() / name
    (folder / "rgb").mkdir(parents=True)
    (folder / "depth").mkdir()
    write_camera_info_yaml(folder / "intrinsics.yaml", CameraIntrinsics.from_dict(src.meta["intrinsics"]))
    if intrinsics_edit is not None:
        p = folder / "intrinsics.yaml"
        p.write_text(intrinsics_edit(p.read_text()))
    rows = src.select(0, "data")
    names = [str(n) for n in src.meta["joint_names"]]
    q = np.asarray(src.joints(rows), dtype=object)
    if joints is not None:
        names, q = joints(names, q)
    lines = ["frame," + ",".join(names)]
    for k, (rgb, dep) in enumerate(zip(rows["rgb"], rows["depth"])):
        frame = f"f{k:03d}"
        lines.append(frame + "," + ",".join(v if isinstance(v, str) else repr(float(v)) for v in q[k]))
        Image.fromarray(src.rgb(0, rgb)).save(folder / "rgb" / f"{frame}.png")
        dm = src.depth_m(0, dep)
        if depth == "npy_m":
            np.save(folder / "depth" / f"{frame}.npy", dm.astype(np.float32))
        elif depth == "npy_mm":
            np.save(folder / "depth" / f"{frame}.npy", (dm * 1e3).astype(np.float32))
        elif depth == "png_m":
            Image.fromarray(np.rint(dm).astype(np.uint16)).save(folder / "depth" / f"{frame}.png")
        else:
            Image.fromarray(np.rint(dm * 1e3).astype(np.uint16)).save(folder / "depth" / f"{frame}.png")
    (folder / "joints.csv").write_text("\n".join(lines) + "\n")
    return folder


def _import(kind: str, src: Path):
    return lambda out: ["import", kind, src, "--robot", "ur5", "--out", out / "ds", "--quiet"]


def gen_depth(w: Work) -> list:
    out = []
    cases = [
        ("bag sqlite3, 32FC1 in millimetres", dict(storage="sqlite3", encoding="32FC1", depth_scale=1e3), False),
        ("bag mcap, 32FC1 in millimetres", dict(storage="mcap", encoding="32FC1", depth_scale=1e3), False),
        ("bag sqlite3, 16UC1 in metres", dict(storage="sqlite3", encoding="16UC1", depth_scale=1e-3), False),
        ("bag mcap, 16UC1 in metres", dict(storage="mcap", encoding="16UC1", depth_scale=1e-3), False),
        ("control: bag 16UC1 in millimetres", dict(storage="sqlite3", encoding="16UC1"), True),
        ("control: bag 32FC1 in metres", dict(storage="mcap", encoding="32FC1"), True),
    ]
    for what, kw, legit in cases:
        bag = _bag(w, **kw)
        out.append(
            w.fault(
                "depth",
                "import bag",
                what,
                _import("bag", bag),
                [bag.name, "depth"],
                legit=legit,
                expect="" if legit else "millimet|metre|meter|unit",
                timeout_s=120,
            )
        )
    for what, depth, legit in (
        ("folder, float .npy in millimetres", "npy_mm", False),
        ("folder, 16-bit PNG in metres", "png_m", False),
        ("control: folder, float .npy in metres", "npy_m", True),
        ("control: folder, 16-bit PNG in millimetres", "png_mm", True),
    ):
        folder = _recording_folder(w, f"depth_{depth}", depth)
        out.append(
            w.fault(
                "depth",
                "import folder",
                what,
                _import("folder", folder),
                [folder.name, ".npy", ".png"],
                legit=legit,
                expect="" if legit else "millimet|metre|meter|unit",
                timeout_s=120,
            )
        )
    return out


def _bag_joint_hooks() -> dict:
    """What a joint-state stream can hold that the arm cannot: name to hook(names, q, stamp) -> (names, q)."""

    def one(value):
        def hook(names, q, stamp):
            q = q.copy()
            q[names.index("elbow_joint")] = value
            return names, q

        return hook

    def degrees(names, q, stamp):
        return names, np.degrees(q)

    def duplicate(names, q, stamp):
        k = names.index("elbow_joint")
        return names + ["elbow_joint"], np.concatenate([q, [q[k] + 0.5]])

    return {
        "NaN elbow_joint": one(float("nan")),
        "inf elbow_joint": one(float("inf")),
        "elbow_joint 1e300 rad": one(1e300),
        "joints in degrees": degrees,
        "duplicated joint name (second value 0.5 rad off)": duplicate,
    }


def gen_joints(w: Work) -> list:
    out = []
    for what, hook in _bag_joint_hooks().items():
        bag = _bag(w, storage="sqlite3", joint_hook=hook)
        out.append(
            w.fault(
                "joints",
                "import bag",
                what,
                _import("bag", bag),
                [bag.name, "/joint_states"],
                expect="joint",
                timeout_s=120,
            )
        )

    def cell(value):
        def edit(names, q):
            q = q.copy()
            q[3, names.index("elbow_joint")] = value
            return names, q

        return edit

    def degrees(names, q):
        return names, np.degrees(q.astype(float))

    def duplicate(names, q):
        k = names.index("elbow_joint")
        return names + ["elbow_joint"], np.concatenate([q, q[:, k : k + 1].astype(float) + 0.5], axis=1)

    for what, edit in (
        ("NaN cell", cell("nan")),
        ("inf cell", cell("inf")),
        ("1e300 rad", cell("1e300")),
        ("joints in degrees", degrees),
        ("duplicated joint column (second 0.5 rad off)", duplicate),
    ):
        folder = _recording_folder(w, "joints", joints=edit)
        out.append(
            w.fault(
                "joints",
                "import folder",
                what,
                _import("folder", folder),
                ["joints.csv"],
                expect="joint",
                timeout_s=120,
            )
        )
    return out


def gen_placements(w: Work) -> list:
    out = []

    def edit_rows(root: Path, fn) -> None:
        shard = root / "shards" / "cam_0000"
        text = (shard / "frames.csv").read_text()
        rows = list(csv.reader(io.StringIO(text)))
        header, body = rows[0], rows[1:]
        body = fn(header, body)
        buf = io.StringIO()
        csv.writer(buf, lineterminator="\n").writerows([header] + body)
        (shard / "frames.csv").write_text(buf.getvalue())
        _rewrite_manifest(shard)

    def mm(header, body):
        for r in body:
            if r[header.index("recording")] == "calibration":
                for a in "xyz":
                    k = header.index(f"T_base_ee.{a}")
                    r[k] = repr(float(r[k]) * 1e3)
        return body

    def identical(header, body):
        cal = [r for r in body if r[header.index("recording")] == "calibration"]
        cols = [k for k, n in enumerate(header) if n.startswith(("T_base_ee.", "q"))]
        for r in cal[1:]:
            for k in cols:
                r[k] = cal[0][k]
        return body

    def duplicated(header, body):
        cal = [r for r in body if r[header.index("recording")] == "calibration"]
        return body + [list(r) for r in cal]

    for what, fn in (("poses in mm", mm), ("identical poses", identical), ("duplicated frames", duplicated)):
        root = w.dataset(labelled=False)
        edit_rows(root, fn)
        out.append(
            Fault(
                "placements",
                "label",
                f"camera 0: {what}",
                ["label", root, "--quiet", "--workers", "1"],
                [root.name, "cam_0000", "camera 0", "frames.csv"],
                root.parent,
                expect="camera|placement|cam_0000",
                timeout_s=120,
            )
        )
    return out


def gen_truth(w: Work) -> list:
    from handeye.core.synthetic import make_problem

    g = w.good
    out = []
    p = make_problem(12, "eye_to_hand", np.random.default_rng(0), camera_noise=(0.05, 0.5))
    X = p.X_true
    bad = {
        "rotation scaled by 1.1": lambda T: np.block([[T[:3, :3] * 1.1, T[:3, 3:]], [T[3:]]]),
        "rotation sheared": lambda T: np.block([[T[:3, :3] + np.triu(np.ones((3, 3)), 1) * 0.2, T[:3, 3:]], [T[3:]]]),
        "reflection (det -1)": lambda T: np.diag([1.0, 1.0, -1.0, 1.0]) @ T,
        "bottom row not 0 0 0 1": lambda T: np.vstack([T[:3], [[0.1, 0, 0, 1]]]),
    }
    for what, fn in bad.items():
        d = w.folder()
        (d / "truth.json").write_text(json.dumps({"T_base_cam": fn(np.asarray(X)).tolist()}))
        out.append(
            Fault(
                "truth",
                "calibrate --truth",
                what,
                ["calibrate", g["poses"], "--setup", "eye-to-hand", "--truth", d / "truth.json"],
                ["truth.json"],
                d,
                expect="",
                timeout_s=60,
            )
        )
    from handeye.core.dataset import Dataset

    intr = dict(Dataset.open(g["dataset"]).meta["intrinsics"])
    for fx in (1e-300, 0.0, -500.0, 1e300):
        K = np.asarray(intr["K"], dtype=float).copy()
        K[0, 0] = fx
        bag = _bag(w, intrinsics=dict(intr, K=K.tolist()))
        out.append(
            w.fault(
                "truth",
                "import bag",
                f"camera_info fx = {fx:g}",
                _import("bag", bag),
                [bag.name, "camera_info", "/camera/color/camera_info"],
                timeout_s=120,
            )
        )
    for fx in ("1e-300", "0"):
        folder = _recording_folder(w, "fx", intrinsics_edit=lambda t, fx=fx: _yaml_fx(t, fx))
        out.append(
            w.fault(
                "truth",
                "import folder",
                f"intrinsics.yaml fx = {fx}",
                _import("folder", folder),
                ["intrinsics.yaml"],
                timeout_s=120,
            )
        )
        root = w.dataset()
        meta = json.loads((root / "meta.json").read_text())
        meta["calibration_intrinsics"]["K"][0][0] = float(fx)
        (root / "meta.json").write_text(json.dumps(meta))
        out.append(
            Fault(
                "truth",
                "label",
                f"meta.json fx = {fx}",
                ["label", root, "--quiet", "--workers", "1"],
                ["meta.json"],
                root.parent,
                timeout_s=120,
            )
        )
    ds_csv = (g["dataset"] / "cameras.csv").read_text()
    for value in ("1000", "-250", "1e6"):
        root = w.dataset()
        (root / "cameras.csv").write_text(set_cell(ds_csv, 0, "T_base_cam_true.x", value))
        out.append(
            Fault(
                "truth",
                "label",
                f"cameras.csv T_base_cam_true.x = {value} m",
                ["label", root, "--quiet", "--workers", "1"],
                ["cameras.csv"],
                root.parent,
                timeout_s=120,
            )
        )
    return out


def _yaml_fx(text: str, fx: str) -> str:
    """A camera_info YAML with K's first entry replaced."""
    return re.sub(r"(camera_matrix:\s*\n(?:.*\n)*?\s*data:\s*\[\s*)([^,\]]+)", lambda m: m.group(1) + fx, text, count=1)


def gen_pairs(w: Work) -> list:
    from handeye.core.posefile import write_pose_csv
    from handeye.core.synthetic import make_problem

    out = []
    for n in (10_000, 100_000):
        d = w.folder()
        p = make_problem(n, "eye_to_hand", np.random.default_rng(1), camera_noise=(0.05, 0.5))
        write_pose_csv(d / f"poses_{n}.csv", p.T_base_ee, p.T_cam_target)
        out.append(
            Fault(
                "pairs",
                "calibrate",
                f"{n} poses, default pairs",
                ["calibrate", d / f"poses_{n}.csv", "--setup", "eye-to-hand"],
                [f"poses_{n}.csv"],
                d,
                legit=True,
                as_limit=AS_LIMIT,
                timeout_s=120,
            )
        )
    return out


def gen_tracebacks(w: Work) -> list:
    g = w.good
    out = []
    good_mcap = _bag(w, storage="mcap")
    for how in MCAP_DAMAGE:
        bag = w.folder() / "corrupt_mcap"
        shutil.copytree(good_mcap, bag)
        data = next(bag.glob("*.mcap"))
        data.write_bytes(corrupt_mcap(data.read_bytes(), how))
        out.append(
            w.fault(
                "tracebacks",
                "import bag",
                f"MCAP: {how}",
                _import("bag", bag),
                ["corrupt_mcap", ".mcap"],
                timeout_s=120,
            )
        )
    for shape, dtype in (((100_000, 100_000), "<f4"), ((100_000, 100_000), "<u2"), ((3,), "<f4")):
        folder = _recording_folder(w, "npy_header", depth="npy_m")
        target = sorted((folder / "depth").glob("*.npy"))[0]
        with target.open("wb") as fh:
            np.lib.format.write_array_header_1_0(fh, {"descr": dtype, "fortran_order": False, "shape": shape})
            fh.write(b"\0" * 64)
        out.append(
            w.fault(
                "tracebacks",
                "import folder",
                f".npy header declaring {shape} {dtype}",
                _import("folder", folder),
                [target.name],
                timeout_s=120,
            )
        )
    for what, doc in (("a list", []), ("a string", "frames"), ("a number", 42), ("frames a string", "@frames")):
        root = w.dataset()
        man = root / "shards" / "cam_0000" / "manifest.json"
        if doc == "@frames":
            m = json.loads(man.read_text())
            m["frames"] = "all"
            doc = m
        man.write_text(json.dumps(doc))
        out.append(
            Fault(
                "tracebacks",
                "label",
                f"manifest.json {what}",
                ["label", root, "--quiet", "--workers", "1"],
                ["manifest.json"],
                root.parent,
                timeout_s=120,
            )
        )
    for command, (argv_of, suffix, timeout) in writers(w).items():
        t = Path("/proc") / ("handeye_fault_out" + ("" if suffix in ("", "/") else suffix))
        out.append(
            w.fault(
                "tracebacks",
                command,
                "output in a folder that cannot be written (/proc)",
                lambda o, a=argv_of, t=t: a(t),
                [t.name, "/proc"],
                timeout_s=timeout,
            )
        )
    for what in ("a folder", "a FIFO"):
        root = w.dataset(labelled=False)
        lock = root / ".lock"
        lock.mkdir() if what == "a folder" else os.mkfifo(lock)
        out.append(
            Fault(
                "tracebacks",
                "label",
                f"the lock file is {what}",
                ["label", root, "--quiet", "--workers", "1"],
                [".lock"],
                root.parent,
                timeout_s=60,
            )
        )
    stdout_cmds = {
        "calibrate": lambda o: ["calibrate", g["poses"], "--setup", "eye-to-hand"],
        "plan": lambda o: ["plan", g["poses"], "--setup", "eye-to-hand", "--candidates", "200"],
        "board": lambda o: ["board", "-o", o / "b.png"],
        "sim generate": lambda o: _small_sim_argv(o / "ds"),
        "label": lambda o: ["label", w.dataset(labelled=False), "--workers", "1"],
    }
    for command, argv_of in stdout_cmds.items():
        out.append(
            w.fault(
                "tracebacks",
                command,
                "stdout on /dev/full",
                argv_of,
                ["stdout", "standard output", "/dev/full", "output"],
                stdout_full=True,
                timeout_s=180,
            )
        )
    return out


#: Damage inside an MCAP file's records (not in a message's payload, whose decoding is guarded separately).
MCAP_DAMAGE = (
    "a message record's channel id unknown",
    "a message record's length past its chunk",
    "the chunk's records length past the file",
    "a channel record's schema id unknown",
)


def corrupt_mcap(data: bytes, how: str) -> bytes:
    """``data`` (an MCAP file with an uncompressed chunk, as rosbags writes it) with one record damaged ``how``
    (one of :data:`MCAP_DAMAGE`); every other byte kept."""
    import struct

    raw = bytearray(data)
    k = 8  # after the magic
    while raw[k] != 0x06:
        k += 9 + struct.unpack_from("<Q", raw, k + 1)[0]
    c = k + 9
    clen = struct.unpack_from("<I", raw, c + 28)[0]
    records_len_at = c + 32 + clen
    if how.startswith("the chunk's records length"):
        struct.pack_into("<Q", raw, records_len_at, 2**40)
        return bytes(raw)
    r, end = records_len_at + 8, records_len_at + 8 + struct.unpack_from("<Q", raw, records_len_at)[0]
    found: dict = {}
    while r < end:
        found.setdefault(raw[r], []).append(r)
        r += 9 + struct.unpack_from("<Q", raw, r + 1)[0]
    message = found[0x05][len(found[0x05]) // 2]
    if how.startswith("a message record's channel id"):
        struct.pack_into("<H", raw, message + 9, 0xFFFF)
    elif how.startswith("a message record's length"):
        struct.pack_into("<Q", raw, message + 1, 2**40)
    else:
        struct.pack_into("<H", raw, found[0x04][0] + 9 + 2, 0xFFFF)
    return bytes(raw)


def gen_messages(w: Work) -> list:
    g = w.good
    out = []
    special = r"FIFO|pipe|not a regular file|device|special"
    for table in ("cameras.csv", "meta.json", "shards/cam_0000/frames.csv"):
        root = w.dataset()
        p = root / table
        p.unlink()
        os.mkfifo(p)
        out.append(
            Fault(
                "messages",
                "label",
                f"{p.name} is a FIFO",
                ["label", root, "--quiet", "--workers", "1"],
                [p.name],
                root.parent,
                expect=special,
                timeout_s=30,
            )
        )
    for what, minor in (("FIFO", None), ("device (/dev/null)", 3), ("device (/dev/zero)", 5)):
        d = w.folder()
        p = d / "poses.csv"
        os.mkfifo(p) if minor is None else _mknod(p, minor)
        out.append(
            Fault(
                "messages",
                "calibrate",
                f"pose file is a {what}",
                ["calibrate", p, "--setup", "eye-to-hand"],
                ["poses.csv"],
                d,
                expect=special,
                timeout_s=30,
                as_limit=AS_LIMIT,
            )
        )
        d = w.folder()
        p = d / "start.json"
        os.mkfifo(p) if minor is None else _mknod(p, minor)
        out.append(
            Fault(
                "messages",
                "markerless --start",
                f"--start is a {what}",
                ["markerless", g["dataset"], "--camera", "0", "--start", p, "--quiet"],
                ["start.json"],
                d,
                expect=special,
                timeout_s=30,
                as_limit=AS_LIMIT,
            )
        )
    T = _true_pose(g["dataset"], 0)
    for what, q in (("zero quaternion", [0, 0, 0, 0]), ("quaternion of norm 1e-200", [0, 0, 0, 1e-200])):
        d = w.folder()
        (d / "start.json").write_text(json.dumps({"translation_m": T[:3, 3].tolist(), "quaternion_xyzw": q}))
        out.append(
            Fault(
                "messages",
                "markerless --start",
                what,
                ["markerless", g["dataset"], "--camera", "0", "--start", d / "start.json", "--quiet"],
                ["start.json"],
                d,
                expect="zero|norm|length|unit",
                timeout_s=60,
            )
        )
    for what, value in (("NaN", float("nan")), ("Infinity", float("inf"))):
        for command in ("label", "markerless"):
            root = w.dataset()
            meta = json.loads((root / "meta.json").read_text())
            meta["calibration_intrinsics" if command == "label" else "intrinsics"]["K"][1][1] = value
            (root / "meta.json").write_text(json.dumps(meta))
            argv = (
                ["label", root, "--quiet", "--workers", "1"]
                if command == "label"
                else ["markerless", root, "--camera", "0", "--quiet"]
            )
            out.append(
                Fault(
                    "messages",
                    command,
                    f"{what} in meta.json's camera matrix",
                    argv,
                    ["meta.json"],
                    root.parent,
                    expect="nan|inf|finite|number|intrinsics|camera matrix|K",
                    timeout_s=120,
                )
            )
    bom = "BOM|byte order"
    root = w.dataset()
    (root / "cameras.csv").write_bytes(b"\xef\xbb\xbf" + (root / "cameras.csv").read_bytes())
    out.append(
        Fault(
            "messages",
            "label",
            "UTF-8 BOM in cameras.csv",
            ["label", root, "--quiet", "--workers", "1"],
            ["cameras.csv"],
            root.parent,
            legit=True,
            expect=bom,
            timeout_s=120,
        )
    )
    root = w.dataset()
    shard = root / "shards" / "cam_0000"
    (shard / "frames.csv").write_bytes(b"\xef\xbb\xbf" + (shard / "frames.csv").read_bytes())
    _rewrite_manifest(shard)
    out.append(
        Fault(
            "messages",
            "label",
            "UTF-8 BOM in frames.csv",
            ["label", root, "--quiet", "--workers", "1"],
            ["frames.csv"],
            root.parent,
            legit=True,
            expect=bom,
            timeout_s=120,
        )
    )
    d = w.folder()
    (d / "poses.csv").write_bytes(b"\xef\xbb\xbf" + Path(g["poses"]).read_bytes())
    out.append(
        Fault(
            "messages",
            "calibrate",
            "UTF-8 BOM in a pose CSV",
            ["calibrate", d / "poses.csv", "--setup", "eye-to-hand"],
            ["poses.csv"],
            d,
            legit=True,
            expect=bom,
        )
    )
    folder = _recording_folder(w, "bom")
    (folder / "joints.csv").write_bytes(b"\xef\xbb\xbf" + (folder / "joints.csv").read_bytes())
    out.append(
        w.fault(
            "messages",
            "import folder",
            "UTF-8 BOM in joints.csv",
            _import("folder", folder),
            ["joints.csv"],
            legit=True,
            expect=bom,
            timeout_s=120,
        )
    )
    return out


GENERATORS = {
    "targets": gen_targets,
    "concurrent": gen_concurrent,
    "disk": gen_disk,
    "kill": gen_kill,
    "numbers": gen_numbers,
    "depth": gen_depth,
    "joints": gen_joints,
    "placements": gen_placements,
    "truth": gen_truth,
    "pairs": gen_pairs,
    "tracebacks": gen_tracebacks,
    "messages": gen_messages,
}


def build_faults(work: Path, good: dict, classes, quick: bool = False) -> list:
    """The fault cases of the named classes (each class's generator, in :data:`CLASSES` order); ``quick``
    keeps every other instance of each command in each class, and every control."""
    w = Work(work, good)
    out = []
    for name in CLASSES:
        if name in classes:
            out += GENERATORS[name](w)
    if quick:
        seen: dict = {}
        kept = []
        for f in out:
            k = seen[f.fault_class, f.command] = seen.get((f.fault_class, f.command), -1) + 1
            if f.legit or k % 2 == 0:
                kept.append(f)
        out = kept
    return out


# ------------------------------------------------------------------ the report


def missed(f: Fault) -> bool:
    """Whether a run misses a target of issue 40."""
    return (
        f.outcome not in ("clear", "ok")
        or bool(f.damage)
        or f.longest_line > MAX_LINE
        or f.peak_mb > MAX_PEAK_MB
        # the time target is for answering a fault; a legitimate run's time is its work (pairs excepted)
        or (f.wall_s > MAX_WALL_S and f.kind != "kill" and (f.outcome != "ok" or f.fault_class == "pairs"))
    )


def report_faults(rep, done: list, work: Path) -> bool:
    """The fault tables (per command, per class), the misses with their message; whether all targets are met."""
    rep.say("## Faults (issue 40)")
    rep.say()
    rep.say(
        f"Targets: 0 silent acceptances, 0 destroyed or lost, 0 tracebacks, every message one line of at most "
        f"{MAX_LINE} characters that names the file, every run within {MAX_PEAK_MB:g} MB and {MAX_WALL_S:g} s. "
        "clear: exit 1/2 and one such line (saying what the case expects, e.g. 'millimetres'); silent: exit 0 on "
        "bad data; ok: exit 0 where that is right (a control, a symlink followed); destroyed/lost: a target's type "
        "or content changed, a partial file left, a rerun refused, labels said written and absent, workers alive "
        "after kill -9. Peak MB: the command's process (ru_maxrss)."
    )
    rep.say()

    def table(key: str, title: str) -> None:
        rep.say(
            f"| {title} | tried | clear | unclear | silent | destroyed/lost | traceback | timeout/other | ok | "
            "longest line | peak MB | max s | targets met |"
        )
        rep.say("|---" * 13 + "|")
        groups = list(dict.fromkeys(getattr(f, key) for f in done))
        for name in groups + ["**all**"]:
            mine = done if name == "**all**" else [f for f in done if getattr(f, key) == name]
            n = {k: sum(f.outcome == k for f in mine) for k in OUTCOMES}
            rep.say(
                f"| {name} | {len(mine)} | {n['clear']} | {n['unclear']} | {n['silent']} | "
                f"{sum(bool(f.damage) for f in mine)} | {n['traceback']} | {n['timeout'] + n['other']} | {n['ok']} | "
                f"{max(f.longest_line for f in mine)} | {max(f.peak_mb for f in mine):.0f} | "
                f"{max(f.wall_s for f in mine):.1f} | {sum(not missed(f) for f in mine)} of {len(mine)} |"
            )
        rep.say()

    table("command", "command")
    table("fault_class", "class")
    bad = [f for f in done if missed(f)]
    rep.say(f"{len(done)} fault runs, {len(bad)} missing a target")
    rep.say()
    for f in bad:
        last = (_lines(f.stderr) or [""])[-1].replace(str(work), "$TMP")
        extra = "".join(f"; {t.replace(str(work), '$TMP')}" for t in (f.damage, f.note) if t)
        rep.say(
            f"- {f.fault_class} / {f.command} / {f.what}: {f.outcome} (exit {f.rc}, {f.peak_mb:.0f} MB, "
            f"{f.wall_s:.1f} s{extra}): `{last[:MAX_LINE]}`"
        )
    rep.say()
    return not bad
