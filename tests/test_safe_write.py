"""Output files are written whole or not at all, and only where a regular file belongs (issue 40, item 1 and
part of 3): a directory or a FIFO is refused in one line, a symbolic link is followed and kept, a failed write
leaves the old file and no temporary file behind."""

from __future__ import annotations

import errno
import os
import stat
from pathlib import Path

import pytest

from handeye.cli import main
from handeye.core import safe_write
from handeye.core.errors import OutputFileError
from handeye.core.safe_write import write_text_atomic

EXAMPLE = Path(__file__).resolve().parents[1] / "handeye" / "data" / "example_eye_to_hand.csv"


def _leftovers(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.iterdir() if p.name.endswith(".tmp"))


def test_new_and_replaced_files(tmp_path):
    path = tmp_path / "out.json"
    write_text_atomic(path, "one\n")
    assert path.read_text() == "one\n"
    umask = os.umask(0)
    os.umask(umask)
    assert stat.S_IMODE(path.stat().st_mode) == 0o666 & ~umask  # as open() would have made it
    path.chmod(0o600)
    write_text_atomic(path, "two\n")
    assert path.read_text() == "two\n"
    assert stat.S_IMODE(path.stat().st_mode) == 0o600  # the old file's permissions kept
    assert _leftovers(tmp_path) == []


def test_a_directory_is_refused(tmp_path):
    with pytest.raises(OutputFileError, match="a directory, not a file to write"):
        write_text_atomic(tmp_path, "x")


def test_a_fifo_is_refused_and_left_a_fifo(tmp_path):
    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)
    with pytest.raises(OutputFileError, match="a FIFO, not a file to write"):
        write_text_atomic(fifo, "x")
    assert stat.S_ISFIFO(fifo.stat().st_mode)
    assert _leftovers(tmp_path) == []


def test_a_symbolic_link_is_followed_and_kept(tmp_path):
    target = tmp_path / "real.json"
    target.write_text("old\n")
    link = tmp_path / "link.json"
    link.symlink_to(target)
    write_text_atomic(link, "new\n")
    assert link.is_symlink() and target.read_text() == "new\n"


def test_a_dangling_link_and_a_missing_folder_are_refused(tmp_path):
    link = tmp_path / "dangling.json"
    link.symlink_to(tmp_path / "nowhere" / "x.json")
    with pytest.raises(OutputFileError, match="a symbolic link to nothing"):
        write_text_atomic(link, "x")
    with pytest.raises(OutputFileError, match="does not exist"):
        write_text_atomic(tmp_path / "no" / "such" / "folder.json", "x")


def test_a_failed_write_leaves_the_old_file_and_no_temporary(tmp_path, monkeypatch):
    path = tmp_path / "result.json"
    path.write_text("old\n")

    def full_disk(*args, **kwargs):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(safe_write.os, "replace", full_disk)
    with pytest.raises(OutputFileError, match="No space left on device.*nothing was written"):
        write_text_atomic(path, "new\n")
    assert path.read_text() == "old\n"
    assert _leftovers(tmp_path) == []


@pytest.mark.parametrize("kind", ["fifo", "directory"])
def test_calibrate_output_to_a_non_file_is_refused_in_one_line(tmp_path, capsys, kind):
    target = tmp_path / "out"
    if kind == "fifo":
        os.mkfifo(target)
    else:
        target.mkdir()
    rc = main(["calibrate", str(EXAMPLE), "--setup", "eye-to-hand", "-o", str(target)])
    err = capsys.readouterr().err.strip()
    assert rc != 0
    assert len(err.splitlines()) == 1 and str(target) in err and "not a file to write" in err
    assert (stat.S_ISFIFO if kind == "fifo" else stat.S_ISDIR)(target.stat().st_mode)
