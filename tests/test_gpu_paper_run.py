"""The accelerator's prepared run, on the CPU at a tiny size: the frames file written and read back, the
throughput benchmark, and the protocol trained from the file alone."""

from __future__ import annotations

import dataclasses
import os

import numpy as np
import pytest

pytest.importorskip("torch")

from benchmarks import gpu_paper_run, training_throughput  # noqa: E402
from learned.frames_file import read_frames, save_frames, thin_frames  # noqa: E402
from tests.learned._synthetic import count_frames  # noqa: E402


def _same(a, b) -> bool:
    for f in dataclasses.fields(a):
        x, y = getattr(a, f.name), getattr(b, f.name)
        if isinstance(x, np.ndarray):
            if x.dtype != y.dtype or not np.array_equal(x, y, equal_nan=x.dtype.kind == "f"):
                return False
        elif tuple(np.atleast_1d(x)) != tuple(np.atleast_1d(y)):
            return False
    return True


def test_a_frames_file_reads_back_the_frames_it_was_written_from(tmp_path):
    frames = count_frames()
    save_frames(frames, tmp_path / "f.npz")
    back = read_frames(tmp_path / "f.npz")
    assert _same(frames, back) and back.image_size == frames.image_size
    thin = thin_frames(frames, 3)
    assert np.array_equal(np.bincount(thin.camera), np.full(len(frames.cameras()), 3))
    changed = read_frames(tmp_path / "f.npz")
    changed.depth_m = changed.depth_m.astype(np.float32)  # the check sees a precision lost on the way
    assert not _same(frames, changed)


def test_the_throughput_benchmark_counts_flops_and_times_steps():
    import torch

    m = training_throughput.measure("regression", "tiny", "float32", torch.device("cpu"), batch=4, steps=1, warmup=0)
    assert m.gflop_per_sample > 0 and m.samples_per_s > 0 and m.batch == 4


def test_the_run_step_trains_the_protocol_from_the_frames_file_alone(tmp_path, capsys):
    save_frames(thin_frames(count_frames(), 4), tmp_path / "frames.npz")
    out = tmp_path / "out"
    argv = ["run", "--frames", str(tmp_path / "frames.npz"), "--out", str(out), "--preset", "tiny"]
    argv += ["--strategies", "batch", "naive", "--repeats", "1", "--sizes", "tiny", "--steps", "1"]
    assert gpu_paper_run.main(argv) == 0
    text = (out / "gpu_paper_run.md").read_text()
    assert "- batch: batch translation" in text and "- naive: naive translation" in text
    assert (out / "batch" / "results.json").exists() and (out / "naive" / "results.json").exists()
    assert "| regression | tiny | bfloat16 |" in (out / "training_throughput.md").read_text()


def test_a_strategy_the_time_left_cannot_hold_is_named_not_run(tmp_path):
    save_frames(thin_frames(count_frames(), 4), tmp_path / "frames.npz")
    out = tmp_path / "out"
    argv = ["run", "--frames", str(tmp_path / "frames.npz"), "--out", str(out), "--preset", "tiny", "--minutes", "0"]
    argv += ["--strategies", "batch", "--repeats", "1", "--sizes", "tiny", "--steps", "1", "--networks", "regression"]
    assert gpu_paper_run.main(argv) == 0
    assert "- batch: not run" in (out / "gpu_paper_run.md").read_text()


@pytest.mark.slow
def test_the_frames_step_writes_a_file_of_the_dataset_within_its_size(small_dataset, tmp_path):
    path = tmp_path / "frames.npz"
    line = gpu_paper_run.write_frames(small_dataset[0], path, "tiny", "classic", max_mib=1.0, per_camera=None)
    frames = read_frames(path)
    assert path.stat().st_size <= 2**20 and "written" in line
    assert frames.image_size == (32, 32) and len(np.unique(np.bincount(frames.camera))) == 1


def test_a_frames_file_is_written_whole_or_not_at_all(tmp_path):
    from handeye.core.errors import OutputFileError

    frames = count_frames()
    path = tmp_path / "f.npz"
    save_frames(frames, path)
    before = path.read_bytes()

    class Unreadable:
        def __array__(self, *args, **kwargs):
            raise RuntimeError("a failure mid-write")

    broken = dataclasses.replace(frames, depth_m=Unreadable())
    with pytest.raises(RuntimeError, match="mid-write"):
        save_frames(broken, path)
    assert path.read_bytes() == before  # the old file kept, not a truncated one
    with pytest.raises(OutputFileError, match="FIFO"):
        os.mkfifo(tmp_path / "fifo")
        save_frames(frames, tmp_path / "fifo")


def test_frames_over_the_size_are_refused_with_the_old_file_kept(tmp_path, monkeypatch):
    from handeye.core.errors import HandEyeInputError

    monkeypatch.setattr("learned.data.load_frames", lambda *args, **kwargs: count_frames())
    path = tmp_path / "frames.npz"
    path.write_bytes(b"an earlier frames file")
    for per_camera in (None, 2):  # the probe's estimate, and a number asked for
        with pytest.raises(HandEyeInputError, match="MiB"):
            gpu_paper_run.write_frames(tmp_path, path, "tiny", "truth", max_mib=1e-4, per_camera=per_camera)
        assert path.read_bytes() == b"an earlier frames file"
    line = gpu_paper_run.write_frames(tmp_path, path, "tiny", "truth", max_mib=1.0, per_camera=2)
    assert "written" in line and len(read_frames(path)) == 2 * len(count_frames().cameras())


def test_the_float32_peak_is_named_as_tf32s(monkeypatch):
    import torch

    monkeypatch.setattr(torch.cuda, "get_device_name", lambda device=None: "NVIDIA H100 80GB HBM3")
    value, source = training_throughput.peak_tflops(torch.device("cuda"), "float32")
    assert value == 495.0 and "TF32" in source and "H100" in source
    assert "TF32" not in training_throughput.peak_tflops(torch.device("cuda"), "bfloat16")[1]


def test_the_run_steps_args_file_is_not_written_into_a_fifo(tmp_path):
    from handeye.core.errors import OutputFileError

    save_frames(thin_frames(count_frames(), 4), tmp_path / "frames.npz")
    out = tmp_path / "out"
    out.mkdir()
    os.mkfifo(out / "args.json")
    reader = os.open(out / "args.json", os.O_RDONLY | os.O_NONBLOCK)  # a plain write would go in and succeed
    argv = ["run", "--frames", str(tmp_path / "frames.npz"), "--out", str(out), "--preset", "tiny", "--minutes", "0"]
    argv += ["--strategies", "batch", "--repeats", "1", "--sizes", "tiny", "--steps", "1", "--networks", "regression"]
    try:
        with pytest.raises(OutputFileError, match="args.json"):
            gpu_paper_run.main(argv)
    finally:
        os.close(reader)
