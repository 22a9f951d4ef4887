"""Benchmark: data-parallel training of the learned protocol (``torchrun``) against one process: time and results.

Run from the repository root::

    python benchmarks/distributed_training.py                 # the tiny preset, 3 seeds: a minute or two
    python benchmarks/distributed_training.py --presets tiny demo --out benchmarks/results/distributed_training.md

Every configuration runs ``handeye learned run`` (through ``torchrun --standalone -m handeye`` when it
has several processes) on the same dataset for every seed, all strategies, each run in a fresh output
directory; the runs of one seed follow each other, so a change of the machine's load falls on all
configurations alike.

- On the CPU (``--device cpu``, the default without CUDA): 1 process on 1 thread, 1 process on P
  threads and P processes (gloo) on 1 thread each, for P in ``--processes``: the same cores used by
  threads or by processes.
- With CUDA (``--device cuda``, the default where it is present): 1, 2, ... processes up to the GPU
  count (or ``--processes``), one GPU each (nccl), and the speed-up per added GPU.

Reported: wall time per run (the whole command: start, data loading, training, evaluation) and the
protocol's time (the runs' ``wall_s`` summed: training and evaluation only); the final median test
errors (translation mm, rotation deg) of every strategy per configuration (mean over seeds), the
largest difference between one process and P processes of the same seed, the same between 1 and P
threads of one process (the float32 rounding a change of summation order alone makes), and the
spread across seeds (largest minus smallest, one process).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from benchmarks._report import Report  # noqa: E402
from handeye.core.errors import HandEyeInputError  # noqa: E402

NETWORKS = {"translation": "mm", "orientation": "deg"}


@dataclass(frozen=True)
class Config:
    """One way to run: ``processes`` ranks of ``threads`` torch threads each, on ``device``."""

    processes: int
    threads: int
    device: str

    @property
    def name(self) -> str:
        if self.device == "cuda":
            return f"{self.processes} GPU" + ("s" if self.processes > 1 else "")
        return f"{self.processes} proc x {self.threads} thread" + ("s" if self.threads > 1 else "")


def configs(device: str, processes: list[int]) -> list[Config]:
    """The configurations of a device: see the module's docstring."""
    if device == "cuda":
        return [Config(p, 1, "cuda") for p in sorted(set([1, *processes]))]
    out = [Config(1, 1, "cpu")]
    for p in processes:
        if p > 1:
            out += [Config(1, p, "cpu"), Config(p, 1, "cpu")]
    return out


def command(cfg: Config, args: argparse.Namespace, preset: str, seed: int, out: Path) -> list[str]:
    """The command line of one run."""
    cli = ["learned", "run", "--data", str(args.data), "--preset", preset, "--strategies", args.strategies]
    cli += ["--seed", str(seed), "--out", str(out), "--quiet", "--fresh", "--threads", str(cfg.threads)]
    if cfg.processes == 1:
        return [sys.executable, "-m", "handeye", *cli]
    launcher = [sys.executable, "-m", "torch.distributed.run", "--standalone", "--nproc-per-node", str(cfg.processes)]
    return [*launcher, "-m", "handeye", *cli]


def run_once(cfg: Config, args: argparse.Namespace, preset: str, seed: int, tmp: Path) -> dict:
    """One run: its wall time, the protocol's time and the final median errors per strategy and network."""
    out = tmp / f"{preset}-{cfg.processes}x{cfg.threads}-{cfg.device}-seed{seed}"
    env = dict(os.environ, OMP_NUM_THREADS=str(cfg.threads))
    if cfg.device == "cpu":
        env["CUDA_VISIBLE_DEVICES"] = ""
    start = time.perf_counter()
    proc = subprocess.run(command(cfg, args, preset, seed, out), cwd=ROOT, env=env, capture_output=True, text=True)
    wall = time.perf_counter() - start
    if proc.returncode != 0:
        raise SystemExit(f"{preset}, {cfg.name}, seed {seed} failed:\n{(proc.stdout + proc.stderr)[-4000:]}")
    results = json.loads((out / "results.json").read_text())
    if results["world_size"] != cfg.processes:
        raise SystemExit(f"{cfg.name}: results.json says world size {results['world_size']}")
    return {
        "wall_s": wall,
        "protocol_s": float(sum(r["wall_s"] for r in results["runs"])),
        "median": {(s, n): results["summary"][s][n]["median"] for s in results["summary"] for n in NETWORKS},
    }


def _time_table(say, preset: str, cfgs: list[Config], runs: dict, seeds: list[int]) -> None:
    base = np.mean([runs[cfgs[0], s]["protocol_s"] for s in seeds])
    cuda = cfgs[0].device == "cuda"
    say(f"## Preset {preset}: time per run (s; mean ± std over the seeds)")
    say()
    extra = " | speed-up per added GPU" if cuda else ""
    say(f"| configuration | wall (whole command) | protocol (training and evaluation) | speed-up{extra} |")
    say("|---|---|---|---|" + ("---|" if cuda else ""))
    previous = 1.0
    for cfg in cfgs:
        wall = [runs[cfg, s]["wall_s"] for s in seeds]
        prot = [runs[cfg, s]["protocol_s"] for s in seeds]
        speedup = base / np.mean(prot)
        row = f"| {cfg.name} | {np.mean(wall):.1f} ± {np.std(wall):.1f} | {np.mean(prot):.1f} ± {np.std(prot):.1f} "
        row += f"| {speedup:.2f}x |"
        if cuda:
            row += f" {speedup - previous:+.2f}x |" if cfg.processes > 1 else " - |"
            previous = speedup
        say(row)
    say()
    if not cuda:
        say(
            "Note: on the CPU every batch (16 samples in these presets) is split into slices of 8, and each step "
            "adds collectives over gloo (the gradient all-reduce, one all-reduce per batch-norm layer in the "
            "forward and one in the backward pass, a buffer broadcast); evaluation is replicated on every rank."
        )
        say()


def _error_tables(say, preset: str, cfgs: list[Config], runs: dict, seeds: list[int], strategies: list[str]) -> None:
    one = cfgs[0]
    parallel = [c for c in cfgs if c.processes > 1]
    threaded = {c.threads: c for c in cfgs if c.processes == 1 and c.threads > 1}  # by their thread count
    for network, unit in NETWORKS.items():
        say(f"## Preset {preset}: final median test error, {network} ({unit}; mean over the seeds)")
        say()
        say(
            f"max abs diff: the largest difference from {one.name} of the same seed; spread: largest minus "
            f"smallest over the seeds, {one.name}."
        )
        say()
        head = [c.name for c in cfgs]
        for c in parallel:
            head.append(f"max abs diff, {c.name}")
            if c.processes in threaded:
                head.append(f"max abs diff, {threaded[c.processes].name}")
        head.append("spread across seeds")
        say("| strategy | " + " | ".join(head) + " |")
        say("|---|" + "---|" * len(head))
        for strategy in strategies:
            value = {(c, s): runs[c, s]["median"][strategy, network] for c in cfgs for s in seeds}
            cells = [f"{np.mean([value[c, s] for s in seeds]):.3f}" for c in cfgs]
            for c in parallel:
                cells.append(f"{max(abs(value[c, s] - value[one, s]) for s in seeds):.2g}")
                if c.processes in threaded:
                    t = threaded[c.processes]
                    cells.append(f"{max(abs(value[t, s] - value[one, s]) for s in seeds):.2g}")
            ones = [value[one, s] for s in seeds]
            cells.append(f"{max(ones) - min(ones):.3g}")
            say(f"| {strategy} | " + " | ".join(cells) + " |")
        say()


def main(argv=None) -> int:
    import torch

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, default=ROOT / "data" / "small-noisy", help="labelled dataset")
    ap.add_argument("--presets", nargs="+", default=["tiny"], help="learned presets, one section each (default tiny)")
    ap.add_argument("--strategies", default="batch,naive,reservoir,selection")
    ap.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2])
    ap.add_argument("--processes", type=int, nargs="+", default=None, help="CPU: 2; CUDA: 1 .. GPU count")
    ap.add_argument("--device", choices=("auto", "cpu", "cuda"), default="auto")
    ap.add_argument("--out", help="also write the report to this file")
    args = ap.parse_args(argv)
    device = ("cuda" if torch.cuda.is_available() else "cpu") if args.device == "auto" else args.device
    if device == "cuda" and not torch.cuda.is_available():
        raise HandEyeInputError("--device cuda: no CUDA device here")
    if not (args.data / "cameras.csv").is_file():
        raise HandEyeInputError(
            f"{args.data}: not a labelled dataset (make one with 'handeye sim' and 'handeye label')"
        )
    gpus = torch.cuda.device_count() if device == "cuda" else 0
    processes = args.processes or (list(range(1, gpus + 1)) if device == "cuda" else [2])
    if device == "cuda" and max(processes) > gpus:
        raise HandEyeInputError(f"--processes up to {max(processes)} but {gpus} GPU(s): one process per GPU")
    cfgs = configs(device, processes)
    strategies = [s.strip() for s in args.strategies.split(",")]
    report = Report(
        "Data-parallel training (torchrun) against one process: time and results",
        "benchmarks/distributed_training.py",
        argv,
        f"torch {torch.__version__}, numpy {np.__version__}",
    )
    say = report.say
    if device == "cuda":
        say(f"GPUs: {gpus} x {torch.cuda.get_device_name(0)}; backend nccl, one process per GPU")
    else:
        say("CPU, backend gloo; CUDA hidden from every run")
    say(
        f"dataset {args.data.name}, strategies {', '.join(strategies)}, seeds {' '.join(map(str, args.seeds))}; "
        f"configurations: {', '.join(c.name for c in cfgs)}"
    )
    say()
    for preset in args.presets:
        runs = {}
        with tempfile.TemporaryDirectory() as tmp:
            for seed in args.seeds:
                for cfg in cfgs:
                    print(f"{preset}, seed {seed}, {cfg.name} ...", file=sys.stderr, flush=True)
                    runs[cfg, seed] = run_once(cfg, args, preset, seed, Path(tmp))
        _time_table(say, preset, cfgs, runs, args.seeds)
        _error_tables(say, preset, cfgs, runs, args.seeds, strategies)
    return report.write(args.out)


if __name__ == "__main__":
    try:
        sys.exit(main())
    except HandEyeInputError as exc:
        print(f"error: {exc}", file=sys.stderr)
        sys.exit(2)
