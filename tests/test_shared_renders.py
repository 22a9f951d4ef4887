"""tests/shared_renders.py: one build per run, rebuilt when an earlier builder died before finishing."""

import pickle
from pathlib import Path

import pytest

from tests.shared_renders import DONE, shared_build


class _Factory:
    """The one method of pytest's TempPathFactory that shared_build uses."""

    def __init__(self, base: Path):
        self.base = base

    def getbasetemp(self) -> Path:
        return self.base


def test_built_once_and_value_shared(tmp_path, monkeypatch):
    monkeypatch.delenv("PYTEST_XDIST_WORKER", raising=False)
    calls = []

    def build(folder):
        calls.append(folder)
        (folder / "data.txt").write_text("x")
        return {"n": 3}

    first = shared_build(_Factory(tmp_path), "k", build)
    again = shared_build(_Factory(tmp_path), "k", build)
    assert first == again == (tmp_path / "shared-builds" / "k", {"n": 3})
    assert len(calls) == 1


def test_a_crash_while_writing_the_marker_is_built_again(tmp_path, monkeypatch):
    """A builder killed half-way through writing the finished marker: the next process builds again, where a
    half-written marker was taken as finished and failed to unpickle."""
    monkeypatch.delenv("PYTEST_XDIST_WORKER", raising=False)
    real_write = Path.write_bytes

    def crash_half_way(self, data):
        real_write(self, data[: len(data) // 2])
        raise KeyboardInterrupt("worker killed")

    monkeypatch.setattr(Path, "write_bytes", crash_half_way)
    try:
        shared_build(_Factory(tmp_path), "k", lambda folder: list(range(100)))
    except KeyboardInterrupt:
        pass
    monkeypatch.setattr(Path, "write_bytes", real_write)
    marker = tmp_path / "shared-builds" / "k" / DONE
    if marker.exists():  # a marker left behind must be whole
        assert pickle.loads(marker.read_bytes()) == list(range(100))
    folder, value = shared_build(_Factory(tmp_path), "k", lambda folder: list(range(100)))
    assert value == list(range(100))
    assert folder == tmp_path / "shared-builds" / "k"


@pytest.mark.parametrize("failure", [RuntimeError, KeyboardInterrupt])
def test_a_failed_build_leaves_no_marker(tmp_path, monkeypatch, failure):
    monkeypatch.delenv("PYTEST_XDIST_WORKER", raising=False)

    def broken(folder):
        (folder / "half.txt").write_text("half")
        raise failure("build failed")

    with pytest.raises(failure):
        shared_build(_Factory(tmp_path), "k", broken)
    folder, value = shared_build(_Factory(tmp_path), "k", lambda folder: "ok")
    assert value == "ok" and not (folder / "half.txt").exists()
