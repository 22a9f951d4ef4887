"""``handeye learned``: train the learned continual calibration and report on it.

Example
-------
::

    handeye learned run --data data/paper-sim --preset cpu --strategies batch,naive,reservoir,selection --out runs/sim
    handeye learned report runs/sim
    handeye learned run --data data/paper-sim --preset cpu --protocol paper --out runs/sim-paper
    handeye learned ablation --data data/paper-sim --preset cpu --protocol paper --out runs/sim-ablation
    handeye learned thresholds --data data/paper-sim --preset cpu --protocol paper --out runs/sim-thresholds

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
resolution on a CPU), ``paper`` (the paper's scale and protocol, for a GPU).
``--protocol paper`` runs any preset in the seed paper's protocol as written
(:mod:`learned.protocol`), ``--protocol handeye`` in this project's; ``report``
prints both the paper's layout with its stated figures beside and this
project's own checks. ``ablation`` runs the reservoir over a c1/c2/c3 grid
(the paper's Table 2, Figs. 10-11), ``thresholds`` runs selection at threshold
pairs (its Tables 7-8); both resume a killed sweep.
"""

from __future__ import annotations

import argparse
import dataclasses
from pathlib import Path

from handeye.commands import command_parser
from handeye.core.numbers import cli_float, cli_int

__all__ = ["add_parser", "run_run", "run_report", "run_ablation", "run_thresholds"]


def add_parser(sub) -> argparse.ArgumentParser:
    """Register the command group."""
    p = command_parser(sub, "learned", "train and report the learned continual calibration", __doc__)
    lsub = p.add_subparsers(dest="learned_command", required=True, metavar="LEARNED_COMMAND")
    r = lsub.add_parser("run", help="run the continual-learning protocol on a labelled dataset")
    _add_protocol_args(r)
    r.add_argument("--strategies", default="batch,naive,reservoir,selection")
    r.add_argument("--out", type=Path, required=True, help="run directory")
    r.set_defaults(run=run_run)
    rep = lsub.add_parser("report", help="tables (markdown, CSV) and figures (PNG) of a run")
    rep.add_argument("run_dir", type=Path)
    rep.set_defaults(run=run_report)
    ab = lsub.add_parser(
        "ablation",
        help="the reservoir over a c1/c2/c3 grid (the paper's Table 2, Figs. 10-11): one run per setting",
    )
    _add_protocol_args(ab)
    ab.add_argument("--out", type=Path, required=True, help="sweep directory (one run folder per setting)")
    ab.add_argument(
        "--grid",
        help="settings c1,c2,c3 separated by spaces, c2 a number or 'all' (default: 4,2 x 14,7 x 1.0,0.5, "
        "around the paper's best 4,14,1.0)",
    )
    ab.set_defaults(run=run_ablation)
    th = lsub.add_parser(
        "thresholds", help="selection at threshold pairs (the paper's Tables 7-8: 3 mm / 4 deg and 6 mm / 8 deg)"
    )
    _add_protocol_args(th)
    th.add_argument("--out", type=Path, required=True, help="sweep directory (one run folder per pair)")
    th.add_argument("--pairs", default="3,4 6,8", help="mm,deg pairs separated by spaces (default: 3,4 6,8)")
    th.set_defaults(run=run_thresholds)
    return p


def _add_protocol_args(r: argparse.ArgumentParser) -> None:
    """The arguments every protocol command shares: data, preset, protocol mode, model, seed, thresholds."""
    r.add_argument("--data", type=Path, required=True, help="labelled dataset directory")
    r.add_argument("--preset", default="cpu", help="tiny, demo, cpu (default) or paper")
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
    r.add_argument("--seed", type=cli_int, default=0)
    r.add_argument("--threads", type=cli_int, default=None, help="torch CPU threads")
    r.add_argument(
        "--trunk-dtype",
        choices=("float32", "bfloat16"),
        help="precision of the convolutions: the keypoint model's, or with --family regression the two networks' "
        "encoders, the heads in float32 (default: the preset's; the cpu preset's keypoint bfloat16 is fast on a CPU "
        "with AMX or AVX-512 BF16 and emulated, slower than float32, on one without)",
    )
    r.add_argument(
        "--novelty",
        choices=("frames", "placement"),
        help="how selection judges a new camera pose (default: the preset's, frames): frames, the paper's mean "
        "per-frame error of a 10%% sample; placement (--family keypoints), the error of the one pose fitted to "
        "all its frames",
    )
    r.add_argument(
        "--protocol",
        choices=("paper", "handeye"),
        help="paper: the seed paper's protocol as written (RMSE, normal sampling, c2 = 14, four samples per past "
        "novel pose, the baseline retrained at every step, a small naive batch, per-pose steps of selection, the "
        "paper's labels: 'handeye label --method tsai --repeats 5'); "
        "handeye: this project's (default: the preset's; paper for the paper preset, handeye for the others)",
    )
    r.add_argument(
        "--c2",
        help="past camera poses replayed: a number, or 'all' (default: the protocol's; the paper's real rig: all)",
    )
    r.add_argument(
        "--threshold-mm", type=cli_float, help="selection's novelty threshold, mm (default: the preset's, 3)"
    )
    r.add_argument(
        "--threshold-deg", type=cli_float, help="selection's novelty threshold, deg (default: the preset's, 4)"
    )
    r.add_argument("--quiet", action="store_true")
    r.add_argument(
        "--fresh",
        action="store_true",
        help="discard <out>/checkpoint.pt of an earlier, unfinished run instead of resuming it",
    )


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


def _prepare(args: argparse.Namespace, writer: bool):
    """The preset the arguments ask for and the frames to run it on (the keypoint model's with keypoints)."""
    from handeye.core.errors import HandEyeInputError
    from learned.presets import get_preset

    preset = get_preset(args.preset)
    if args.protocol:
        preset = preset.with_protocol(args.protocol)
    if args.c2 is not None:
        preset = dataclasses.replace(preset, c2=_parse_c2(args.c2))
    if args.trunk_dtype:
        field = "keypoint_trunk_dtype" if args.family == "keypoints" else "trunk_dtype"
        preset = dataclasses.replace(preset, **{field: args.trunk_dtype})
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
    from learned.label_kind import check_labels

    check_labels(preset, args.data, args.labels)  # the paper's protocol trains on the paper's labels (Tsai x5)
    data = args.data
    if args.family == "keypoints":
        from handeye.core.optional import require_package

        require_package("pinocchio", extra="robot", purpose="the arm's keypoints from its kinematics")
        from handeye.learned_frames import load_keypoint_frames

        data = load_keypoint_frames(
            args.data, preset.frame_size("keypoints"), args.labels, progress=writer and not args.quiet
        )
    return preset, data


def _run(args: argparse.Namespace, writer: bool) -> int:
    """The protocol and its findings; ``writer``: this process prints (rank 0, or the only one)."""
    from learned.experiment import ExperimentOptions, run_experiment
    from learned.paper_tables import paper_findings
    from learned.report import findings

    preset, data = _prepare(args, writer)
    results = run_experiment(
        data,
        preset,
        [s.strip() for s in args.strategies.split(",")],
        args.out,
        progress=not args.quiet,
        threads=args.threads,
        options=ExperimentOptions(labels=args.labels, seed=args.seed, family=args.family, resume=not args.fresh),
    )
    if writer:
        print("the paper's findings, judged as the paper judges them:")
        for line in paper_findings(results):
            print(f"  {line}")
        print("this project's own checks (its bars, not the paper's):")
        for line in findings(results):
            print(f"  {line}")
        print(f"written: {args.out / 'results.json'}; next: handeye learned report {args.out}")
    return 0


def _sweep(args: argparse.Namespace, kind: str) -> int:
    """``handeye learned ablation`` and ``handeye learned thresholds``: one run per setting, then the report."""
    from handeye.core.optional import require_package

    require_package("torch", extra="learned", purpose="the learned calibration")
    from learned import ablation
    from learned.data import load_frames

    # parse the settings before loading anything: a typo is refused at once
    settings = (
        (ablation.parse_grid(args.grid) if args.grid else ablation.DEFAULT_GRID)
        if kind == "ablation"
        else ablation.parse_thresholds(args.pairs)
    )
    preset, data = _prepare(args, True)
    if not hasattr(data, "camera"):
        data = load_frames(data, preset.frame_size(args.family), args.labels, progress=not args.quiet)
    run = {
        "labels": args.labels,
        "seed": args.seed,
        "progress": not args.quiet,
        "threads": args.threads,
        "family": args.family,
        "resume": not args.fresh,
    }
    if kind == "ablation":
        ablation.run_ablation(data, preset, args.out, settings, **run)
        text = ablation.ablation_report(args.out)
    else:
        ablation.run_thresholds(data, preset, args.out, settings, **run)
        text = ablation.threshold_report(args.out)
    print(text)
    print(f"written: {args.out / 'report.md'}")
    return 0


def run_ablation(args: argparse.Namespace) -> int:
    """``handeye learned ablation``."""
    return _sweep(args, "ablation")


def run_thresholds(args: argparse.Namespace) -> int:
    """``handeye learned thresholds``."""
    return _sweep(args, "thresholds")


def _parse_c2(text: str) -> int | None:
    """``--c2``: a positive number of past camera poses, or ``all`` (None)."""
    from handeye.core.errors import HandEyeInputError

    if text.strip().lower() == "all":
        return None
    try:
        value = int(text)
    except ValueError:
        raise HandEyeInputError(f"--c2 must be a number of camera poses or 'all', got {text!r}") from None
    if value < 1:
        raise HandEyeInputError(f"--c2 must be at least 1 camera pose, got {value}")
    return value


def run_report(args: argparse.Namespace) -> int:
    """``handeye learned report``."""
    from learned.report import write_report

    text = write_report(args.run_dir)
    start = text.find("## Final step")
    print(text[start : text.find("## Per test camera pose")] if start >= 0 else text)
    print(f"written: {args.run_dir / 'report.md'}, CSV tables and PNG figures in {args.run_dir}")
    return 0
