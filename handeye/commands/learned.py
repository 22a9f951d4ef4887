"""``handeye learned``: train the learned continual calibration and report on it.

Example
-------
::

    handeye learned run --data data/paper-sim --preset cpu --strategies batch,naive,reservoir,selection --out runs/sim
    handeye learned report runs/sim

``run`` trains each strategy's translation and orientation networks over the
time steps (one region each), evaluates every test subset after each step,
and writes ``results.json`` and the networks (``<out>/<strategy>/*.pt``);
``report`` writes the tables (``report.md``, CSV) and figures (PNG).
``run`` keeps ``<out>/checkpoint.pt`` after every time step: a run that was
killed resumes when started again with the same arguments and ``--out``, and
ends with the results of an uninterrupted run; ``--fresh`` discards the
checkpoint and starts over.
``torchrun --nproc-per-node N -m handeye learned run ...`` trains each time
step data-parallel on N processes (gloo on the CPU, nccl with one GPU per
process); rank 0 alone writes, and the results agree with one process's to
float32 rounding.
Presets: ``tiny`` (tests), ``demo``, ``cpu`` (the paper-sim protocol at reduced
resolution on a CPU), ``paper`` (the paper's scale, for a GPU).
"""

from __future__ import annotations

import argparse
import dataclasses
from pathlib import Path

__all__ = ["add_parser", "run_run", "run_report"]


def add_parser(sub) -> argparse.ArgumentParser:
    """Register the command group."""
    p = sub.add_parser(
        "learned",
        help="train and report the learned continual calibration",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    lsub = p.add_subparsers(dest="learned_command", required=True, metavar="LEARNED_COMMAND")
    r = lsub.add_parser("run", help="run the continual-learning protocol on a labelled dataset")
    r.add_argument("--data", type=Path, required=True, help="labelled dataset directory")
    r.add_argument("--preset", default="cpu", help="tiny, demo, cpu (default) or paper")
    r.add_argument("--strategies", default="batch,naive,reservoir,selection")
    r.add_argument(
        "--labels",
        default="classic",
        choices=("classic", "truth", "markerless"),
        help="training targets; markerless: classic labels in the first region, the markerless "
        "labels after it (no board)",
    )
    r.add_argument(
        "--family",
        default="regression",
        choices=("regression", "keypoints"),
        help="regression: the paper's two networks (default); keypoints: the equivariant model that "
        "finds the arm's joints in the image and solves the camera pose",
    )
    r.add_argument("--out", type=Path, required=True, help="run directory")
    r.add_argument("--seed", type=int, default=0)
    r.add_argument("--threads", type=int, default=None, help="torch CPU threads")
    r.add_argument(
        "--trunk-dtype",
        choices=("float32", "bfloat16"),
        help="precision of the keypoint model's convolutions (default: the preset's; the cpu preset's bfloat16 "
        "is fast on a CPU with AMX or AVX-512 BF16 and emulated, slower than float32, on one without)",
    )
    r.add_argument(
        "--novelty",
        choices=("frames", "placement"),
        help="how selection judges a new camera pose (default: the preset's, frames): frames, the paper's mean "
        "per-frame error of a 10%% sample; placement (--family keypoints), the error of the one pose fitted to "
        "all its frames",
    )
    r.add_argument("--threshold-mm", type=float, help="selection's novelty threshold, mm (default: the preset's, 3)")
    r.add_argument("--threshold-deg", type=float, help="selection's novelty threshold, deg (default: the preset's, 4)")
    r.add_argument("--quiet", action="store_true")
    r.add_argument(
        "--fresh",
        action="store_true",
        help="discard <out>/checkpoint.pt of an earlier, unfinished run instead of resuming it",
    )
    r.set_defaults(run=run_run)
    rep = lsub.add_parser("report", help="tables (markdown, CSV) and figures (PNG) of a run")
    rep.add_argument("run_dir", type=Path)
    rep.set_defaults(run=run_report)
    return p


def run_run(args: argparse.Namespace) -> int:
    """``handeye learned run``; data-parallel under ``torchrun`` (:mod:`learned.distributed`)."""
    from handeye.core.optional import require_package

    require_package("torch", extra="learned", purpose="the learned calibration")
    from learned import distributed

    backend = distributed.init_from_env()
    try:
        if backend is not None and distributed.is_writer():
            print(f"data-parallel training: {distributed.world_size()} processes, backend {backend}", flush=True)
        return _run(args, distributed.is_writer())
    finally:
        distributed.destroy()


def _run(args: argparse.Namespace, writer: bool) -> int:
    """The protocol and its findings; ``writer``: this process prints (rank 0, or the only one)."""
    from handeye.core.errors import HandEyeInputError
    from learned.experiment import run_experiment
    from learned.presets import get_preset
    from learned.report import findings

    data = args.data
    preset = get_preset(args.preset)
    if args.trunk_dtype:
        if args.family != "keypoints":
            raise HandEyeInputError("--trunk-dtype is for the keypoint model: add --family keypoints")
        preset = dataclasses.replace(preset, keypoint_trunk_dtype=args.trunk_dtype)
    if args.novelty == "placement" and args.family != "keypoints":
        raise HandEyeInputError("--novelty placement needs the keypoint model's one pose: add --family keypoints")
    for name, value in (("threshold_mm", args.threshold_mm), ("threshold_deg", args.threshold_deg)):
        if value is not None and not value > 0:
            raise HandEyeInputError(f"--{name.replace('_', '-')} must be positive, got {value}")
    changes = {
        "selection_novelty": args.novelty,
        "threshold_mm": args.threshold_mm,
        "threshold_deg": args.threshold_deg,
    }
    preset = dataclasses.replace(preset, **{k: v for k, v in changes.items() if v is not None})
    if args.family == "keypoints":
        from handeye.core.optional import require_package

        require_package("pinocchio", extra="sim", purpose="the arm's keypoints from its kinematics")
        from handeye.learned_frames import load_keypoint_frames

        data = load_keypoint_frames(
            args.data, preset.frame_size("keypoints"), args.labels, progress=writer and not args.quiet
        )
    results = run_experiment(
        data,
        preset,
        [s.strip() for s in args.strategies.split(",")],
        args.out,
        args.labels,
        args.seed,
        progress=not args.quiet,
        threads=args.threads,
        family=args.family,
        resume=not args.fresh,
    )
    if writer:
        for line in findings(results):
            print(line)
        print(f"written: {args.out / 'results.json'}; next: handeye learned report {args.out}")
    return 0


def run_report(args: argparse.Namespace) -> int:
    """``handeye learned report``."""
    from learned.report import write_report

    text = write_report(args.run_dir)
    start = text.find("## Final step")
    print(text[start : text.find("## Per test camera pose")] if start >= 0 else text)
    print(f"written: {args.run_dir / 'report.md'}, CSV tables and PNG figures in {args.run_dir}")
    return 0
