"""Benchmark: training throughput of the learned networks, samples/s and achieved TFLOP/s against the device's peak.

Run from the repository root (on the CPU, or on a CUDA device when there is one)::

    python benchmarks/training_throughput.py --sizes cpu paper --out benchmarks/results/training_throughput.md

Per network (``regression``: the translation network, the orientation one differs only in its last layer;
``keypoints``: the equivariant keypoint model), preset size (``cpu``, ``paper``, ``tiny``) and precision
(``float32``, ``bfloat16``: the convolutions under autocast, :attr:`learned.model.ModelConfig.trunk_dtype`),
the training step :func:`learned.trainer.train` takes (frames resident on the device, the batch gathered
there, the preset's loss, backward, Adam) is timed over ``--steps`` steps after ``--warmup``. FLOPs per
sample are counted by ``torch.utils.flop_counter.FlopCounterMode`` over one forward and backward pass
(matrix products and convolutions; the element-wise work and the optimiser are not counted, so the
achieved rate is a lower bound). The peak is the device's datasheet dense rate (:data:`PEAK_TFLOPS`);
on a CPU there is no datasheet figure here, and the peak printed is an estimate, stated as one: the rate
of a large matrix product in the same precision on the same threads.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from dataclasses import dataclass, replace

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

from benchmarks._report import Report  # noqa: E402

#: Dense (no sparsity) datasheet peaks, TFLOP/s, by a substring of ``torch.cuda.get_device_name()``, checked
#: in order: bfloat16 tensor cores, and float32 as PyTorch runs it by default, which is TF32 on the tensor
#: cores for convolutions (``torch.backends.cudnn.allow_tf32`` is on by default) and plain float32 for
#: matrix products (``torch.backends.cuda.matmul.allow_tf32`` is off): the float32 rows' peak is TF32's,
#: the higher of the two. NVIDIA H100 and H200 datasheets (SXM: 989 / 495; PCIe and NVL as named).
PEAK_TFLOPS = (
    ("H200 NVL", {"bfloat16": 835.0, "float32": 418.0}),
    ("H200", {"bfloat16": 989.0, "float32": 495.0}),
    ("H100 PCIe", {"bfloat16": 756.0, "float32": 378.0}),
    ("H100 NVL", {"bfloat16": 835.0, "float32": 418.0}),
    ("H100", {"bfloat16": 989.0, "float32": 495.0}),
    ("A100", {"bfloat16": 312.0, "float32": 156.0}),
)

NETWORKS = ("regression", "keypoints")
SIZES = ("tiny", "cpu", "paper")
DTYPES = ("float32", "bfloat16")


@dataclass(frozen=True)
class Measure:
    """One row: a network at a preset's size and a precision on a device."""

    network: str
    size: str
    dtype: str
    batch: int
    gflop_per_sample: float
    samples_per_s: float

    @property
    def tflops(self) -> float:
        """The achieved rate, TFLOP/s (counted FLOPs per sample times samples per second)."""
        return self.gflop_per_sample * self.samples_per_s / 1e3


def _sync(device) -> None:
    import torch

    if device.type == "cuda":
        torch.cuda.synchronize(device)


def _setup(network: str, size: str, dtype: str, batch: int | None, n_keypoints: int, device):
    """The model, its training step's data (random frames resident on the device) and its TrainConfig."""
    import numpy as np
    import torch

    from learned.device_data import DeviceFrames
    from learned.model import make_network
    from learned.presets import PRESETS

    preset = PRESETS[size]
    if network == "keypoints":
        preset = replace(preset, keypoint_trunk_dtype=dtype)
        config = preset.model_config("keypoints", n_keypoints=n_keypoints)
    else:
        config = replace(preset, trunk_dtype=dtype).model_config("translation", (500.0, 0.0, 800.0))
    train_config = preset.train_configs("batch", "keypoints" if network == "keypoints" else "translation")[0]
    batch = int(batch or train_config.batch_size)
    torch.manual_seed(0)
    model = make_network(config).to(device)
    if device.type != "cpu":
        model.to(memory_format=torch.channels_last)  # as learned.trainer.train does on an accelerator
    w, h = config.image_size
    n = 4 * batch
    gen = torch.Generator().manual_seed(0)
    if network == "keypoints":
        xy = torch.rand(n, n_keypoints, 2, generator=gen, dtype=torch.float64)
        target = torch.cat([xy, 1.0 + torch.rand(n, n_keypoints, 1, generator=gen, dtype=torch.float64)], -1)
    else:
        target = 1000.0 * torch.rand(n, 3, generator=gen)
    data = DeviceFrames(
        np.arange(n),
        torch.randint(0, 256, (n, 3, h, w), dtype=torch.uint8, generator=gen).to(device),
        (1.0 + torch.rand(n, 1, h, w, generator=gen)).half().to(device),
        torch.rand(n, 7, generator=gen).to(device),
        target.to(device),
    )
    return model, data, replace(train_config, batch_size=batch)


def _step(model, data, pos, optimizer, config, rng):
    """One training step as :func:`learned.trainer.train` takes it (its loss, backward, Adam)."""
    from learned.trainer import batch_loss

    optimizer.zero_grad()
    loss = batch_loss(model, model, False, data, pos, config, rng)
    loss.backward()
    optimizer.step()


def measure(
    network: str,
    size: str,
    dtype: str,
    device,
    batch: int | None = None,
    steps: int = 10,
    warmup: int = 2,
    n_keypoints: int = 16,
) -> Measure:
    """Counted FLOPs per sample and timed samples per second of one network's training steps.

    Parameters
    ----------
    network : {"regression", "keypoints"}
    size : {"tiny", "cpu", "paper"}
        The preset whose resolution, widths, batch size and keypoint loss settings are used.
    dtype : {"float32", "bfloat16"}
    device : torch.device
    batch : int, optional
        The preset's batch size by default.
    steps, warmup : int
    n_keypoints : int
        The keypoint model's outputs.

    Returns
    -------
    Measure
    """
    import numpy as np
    import torch
    from torch.utils.flop_counter import FlopCounterMode

    model, data, config = _setup(network, size, dtype, batch, n_keypoints, device)
    rng = np.random.default_rng(0)
    optimizer = torch.optim.Adam(model.parameters(), lr=config.learning_rate)
    pos = torch.arange(config.batch_size, device=device)
    model.train()
    counter = FlopCounterMode(display=False)
    with counter:
        _step(model, data, pos, optimizer, config, rng)
    flops = counter.get_total_flops() / config.batch_size
    for _ in range(warmup):
        _step(model, data, pos, optimizer, config, rng)
    _sync(device)
    t0 = time.perf_counter()
    for k in range(steps):
        start = (k * config.batch_size) % (len(data) - config.batch_size + 1)
        _step(model, data, pos + start, optimizer, config, rng)
    _sync(device)
    elapsed = time.perf_counter() - t0
    return Measure(network, size, dtype, config.batch_size, flops / 1e9, steps * config.batch_size / elapsed)


def peak_tflops(device, dtype: str) -> tuple[float | None, str]:
    """The device's peak rate in ``dtype`` and where the figure comes from (float32: TF32's, named so)."""
    import torch

    if device.type == "cuda":
        name = torch.cuda.get_device_name(device)
        for key, peaks in PEAK_TFLOPS:
            if key in name:
                precision = "TF32 tensor cores, as float32 convolutions run" if dtype == "float32" else dtype
                return peaks[dtype], f"datasheet, {key}, {precision}"
        return None, f"unknown ({name} not in the table)"
    return _matmul_rate(dtype, device), "estimate: a 2048^2 matrix product's measured rate"


def _matmul_rate(dtype: str, device, n: int = 2048, repeats: int = 3) -> float:
    """TFLOP/s of an ``n x n`` matrix product in ``dtype`` on ``device``, the best of ``repeats``."""
    import torch

    a = torch.rand(n, n, device=device, dtype=getattr(torch, dtype))
    b = torch.rand(n, n, device=device, dtype=getattr(torch, dtype))
    best = float("inf")
    for _ in range(repeats):
        _sync(device)
        t0 = time.perf_counter()
        a @ b
        _sync(device)
        best = min(best, time.perf_counter() - t0)
    return 2 * n**3 / best / 1e12


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--networks", nargs="+", default=list(NETWORKS), choices=NETWORKS)
    ap.add_argument("--sizes", nargs="+", default=["cpu", "paper"], choices=SIZES)
    ap.add_argument("--dtypes", nargs="+", default=list(DTYPES), choices=DTYPES)
    ap.add_argument("--batch", type=int, help="batch size (default: each preset's)")
    ap.add_argument("--steps", type=int, default=10, help="timed steps per row (default 10)")
    ap.add_argument("--warmup", type=int, default=2, help="untimed steps first (default 2)")
    ap.add_argument("--keypoints", type=int, default=16, help="the keypoint model's outputs (default 16)")
    ap.add_argument("--threads", type=int, help="torch CPU threads")
    ap.add_argument("--out", help="write the report here (markdown)")
    args = ap.parse_args(argv)
    import torch

    from learned.trainer import default_device

    if args.threads:
        torch.set_num_threads(args.threads)
    device = default_device()
    name = torch.cuda.get_device_name(device) if device.type == "cuda" else "CPU"
    report = Report("Training throughput", "benchmarks/training_throughput.py", argv, f"torch {torch.__version__}")
    report.say(f"device: {name}, torch threads {torch.get_num_threads()}")
    peaks = {d: peak_tflops(device, d) for d in args.dtypes}
    for d, (value, source) in peaks.items():
        report.say(f"peak {d}: " + (f"{value:.3g} TFLOP/s ({source})" if value else source))
    report.say()
    report.say("| network | size | precision | batch | GFLOP/sample | samples/s | TFLOP/s | % of peak |")
    report.say("|---|---|---|---:|---:|---:|---:|---:|")
    for network in args.networks:
        for size in args.sizes:
            for dtype in args.dtypes:
                m = measure(network, size, dtype, device, args.batch, args.steps, args.warmup, args.keypoints)
                peak = peaks[dtype][0]
                share = f"{100 * m.tflops / peak:.2g}" if peak else "unknown"
                report.say(
                    f"| {network} | {size} | {dtype} | {m.batch} | {m.gflop_per_sample:.4g} | "
                    f"{m.samples_per_s:.4g} | {m.tflops:.3g} | {share} |"
                )
    report.say()
    report.say(
        "GFLOP/sample: counted (torch.utils.flop_counter, one forward and backward; matrix products and "
        "convolutions only), so TFLOP/s is a lower bound. regression: the translation network."
    )
    return report.write(args.out)


if __name__ == "__main__":
    sys.exit(main())
