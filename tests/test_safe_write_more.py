"""Every command that writes leaves a whole file or none (issue 40, items 1 and 3): on a full disk (a file-size
limit in a subprocess, or a patched write) ``calibrate -o``, ``detect``, ``intrinsics``, ``board`` and ``label``
print one line naming the file and the cause, exit 2, leave the old file and no ``*.tmp``, and a rerun works;
a target that cannot take a file is refused before the work; the report, its figures and the dataset's image
shards go through the same path."""

from __future__ import annotations

import errno
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from handeye.cli import main
from handeye.core import safe_write
from handeye.core.errors import OutputFileError
from handeye.core.safe_write import check_output_folder, write_figure_atomic

cv2 = pytest.importorskip("cv2")

REPO = Path(__file__).resolve().parents[1]
EXAMPLE = REPO / "handeye" / "data" / "example_eye_to_hand.csv"
#: The file-size limit of the "full disk": below every output the commands write here (a JSON result, a PNG
#: board, a camera file, a detection file, a camera table are each over a kilobyte), above nothing they need.
FULL_DISK_BYTES = 256
#: Views of the synthetic recording, and its image size: enough for the intrinsics calibration to succeed
#: (the rerun must write its file), small enough to render in seconds.
N_VIEWS = 5
IMAGE_SIZE = (320, 240)

_FULL_DISK = (
    "import resource, signal, sys\n"
    "signal.signal(signal.SIGXFSZ, signal.SIG_IGN)\n"  # a write past the limit fails with EFBIG, as on a full disk
    "resource.setrlimit(resource.RLIMIT_FSIZE, (int(sys.argv[1]), int(sys.argv[1])))\n"
    "from handeye.cli import main\n"
    "sys.exit(main(sys.argv[2:]))\n"
)


def _on_a_full_disk(args: list[str], cwd: Path) -> subprocess.CompletedProcess:
    env = dict(os.environ, PYTHONDONTWRITEBYTECODE="1", PYTHONPATH=str(REPO))
    return subprocess.run(
        [sys.executable, "-c", _FULL_DISK, str(FULL_DISK_BYTES), *map(str, args)],
        capture_output=True,
        text=True,
        cwd=cwd,
        env=env,
        timeout=300,
    )


def _temporaries(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.rglob("*") if p.name.endswith(".tmp"))


def _check_refused(proc, path: Path) -> None:
    err = [line for line in proc.stderr.splitlines() if ": error: " in line]  # detect's progress lines aside
    assert proc.returncode == 2, proc.stderr
    assert "Traceback" not in proc.stderr
    assert len(err) == 1 and len(err[0]) <= 300
    assert str(path) in err[0] and "File too large" in err[0]


@pytest.fixture(scope="module")
def recording(tmp_path_factory):
    from classic.vision.synthetic import default_intrinsics, make_image_dataset

    folder = tmp_path_factory.mktemp("recording")
    intr = default_intrinsics(*IMAGE_SIZE)
    make_image_dataset(folder, N_VIEWS, "eye_to_hand", intr=intr, rng=np.random.default_rng(11), noise_gray=2.0)
    return folder


@pytest.mark.parametrize("command", ["calibrate", "board", "intrinsics", "detect"])
def test_a_full_disk_leaves_the_old_file_one_line_and_a_rerun_works(tmp_path, recording, command):
    out = tmp_path / {"calibrate": "result.json", "board": "board.png", "intrinsics": "camera.json"}.get(
        command, "detections.json"
    )
    args = {
        "calibrate": ["calibrate", EXAMPLE, "--setup", "eye-to-hand"],
        "board": ["board"],
        "intrinsics": ["intrinsics", recording / "images", "--board", recording / "board.json"],
        "detect": [
            "detect",
            recording / "images",
            "--board",
            recording / "board.json",
            "--intrinsics",
            recording / "camera.json",
        ],
    }[command] + ["-o", out]
    out.write_text("the old file\n")
    proc = _on_a_full_disk(args, tmp_path)
    _check_refused(proc, out)
    assert out.read_text() == "the old file\n"  # not truncated, not replaced by a part
    assert _temporaries(tmp_path) == []
    if command == "board":
        assert not out.with_suffix(".json").exists()
    assert main([str(a) for a in args]) == 0  # the rerun, with room on the disk
    assert out.stat().st_size > FULL_DISK_BYTES and _temporaries(tmp_path) == []


def test_label_on_a_full_disk_keeps_cameras_csv_and_a_rerun_works(small_copy):
    before = (small_copy / "cameras.csv").read_bytes()
    proc = _on_a_full_disk(["label", small_copy, "--workers", "1", "--quiet"], small_copy)
    _check_refused(proc, small_copy / "cameras.csv")
    assert (small_copy / "cameras.csv").read_bytes() == before
    assert _temporaries(small_copy) == []
    assert main(["label", str(small_copy), "--workers", "1", "--quiet"]) == 0


@pytest.mark.parametrize(
    "args",
    [
        ["calibrate", EXAMPLE, "--setup", "eye-to-hand", "-o", "{dir}"],
        ["detect", "no-such-images", "--board", "no-such-board.json", "-o", "{dir}"],
        ["intrinsics", "no-such-images", "--board", "no-such-board.json", "-o", "{dir}"],
        ["board", "-o", "{dir}"],
    ],
    ids=["calibrate", "detect", "intrinsics", "board"],
)
def test_a_target_that_is_a_folder_is_refused_before_the_work(tmp_path, capsys, args):
    target = tmp_path / "taken.png"
    target.mkdir()
    # the inputs do not exist: the refusal names the output, so it came before any input was read
    assert main([str(a).replace("{dir}", str(target)) for a in args]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and f"{target}: a directory, not a file to write" in err


def test_calibrate_report_into_a_file_is_refused_before_the_work(tmp_path, capsys):
    report = tmp_path / "report"
    report.write_text("a file, not a folder\n")
    assert main(["calibrate", "no-such-poses.csv", "--setup", "eye-to-hand", "--report", str(report)]) == 2
    assert f"{report}: exists and is not a folder" in capsys.readouterr().err


def test_label_refuses_an_output_that_cannot_take_a_file_before_labelling(small_copy, capsys, monkeypatch):
    import handeye.labelling as labelling

    (small_copy / "label_errors.png").unlink(missing_ok=True)
    (small_copy / "label_errors.png").mkdir()
    monkeypatch.setattr(labelling, "run_tasks", lambda *a, **k: pytest.fail("labelled before the check"))
    assert main(["label", str(small_copy), "--quiet"]) == 2
    assert "label_errors.png: a directory, not a file to write" in capsys.readouterr().err


def test_check_output_folder(tmp_path):
    assert check_output_folder(tmp_path / "new" / "report") == tmp_path / "new" / "report"
    (tmp_path / "file").write_text("x")
    with pytest.raises(OutputFileError, match="exists and is not a folder"):
        check_output_folder(tmp_path / "file")
    with pytest.raises(OutputFileError, match="is not a folder"):
        check_output_folder(tmp_path / "file" / "report")


def _full_disk(*args, **kwargs):
    raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))


def test_a_figure_is_written_whole_or_not_at_all(tmp_path, monkeypatch):
    matplotlib = pytest.importorskip("matplotlib")
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(2, 2))
    ax.plot([0, 1], [0, 1])
    path = tmp_path / "figure.png"
    write_figure_atomic(fig, path, dpi=50)
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    old = path.read_bytes()
    monkeypatch.setattr(safe_write.os, "fsync", _full_disk)
    with pytest.raises(OutputFileError, match=r"figure.png: cannot write \(No space left on device\)"):
        write_figure_atomic(fig, path, dpi=80)
    plt.close(fig)
    assert path.read_bytes() == old and _temporaries(tmp_path) == []


def test_a_shard_image_that_cannot_be_written_publishes_nothing_and_a_rerun_completes_it(tmp_path, monkeypatch, rng):
    from handeye.core import shard_writer
    from handeye.core.dataset import shard_is_complete
    from tests.test_shard_writer import _real_dataset, _recording, _write

    _real_dataset(tmp_path, n_cameras=1)
    cal, data = _recording(rng)
    T_ee_ref = np.eye(4)
    monkeypatch.setattr(shard_writer, "open", _full_disk, raising=False)
    with pytest.raises(OutputFileError, match=r"calibration_000.png: cannot write \(No space left on device\)"):
        _write(tmp_path, 0, cal, data, T_ee_ref)
    assert sorted(p.name for p in (tmp_path / "shards").iterdir()) == []  # no .partial folder, nothing published
    monkeypatch.undo()
    _write(tmp_path, 0, cal, data, T_ee_ref)
    assert shard_is_complete(tmp_path / "shards" / "cam_0000")[0]
