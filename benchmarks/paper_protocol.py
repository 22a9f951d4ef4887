"""Benchmark: the seed paper's protocol as written against this project's, on the paper's two setups.

Run from the repository root on labelled datasets (noisy, as the paper's)::

    handeye sim generate --preset paper-sim --out data/paper-sim-noisy --noise default
    handeye label data/paper-sim-noisy
    handeye sim generate --preset paper-real --out data/paper-real-noisy --noise default
    handeye label data/paper-real-noisy
    python benchmarks/paper_protocol.py --data data/paper-sim-noisy data/paper-real-noisy --preset cpu \\
        --out benchmarks/results/paper_protocol.md

Per dataset, ``handeye learned run`` in both modes (:mod:`learned.protocol`): ``paper`` (the paper's choices;
on the real rig's 3 subsets with c2 = all, "all observed" as the paper there) and ``handeye`` (this project's),
all four strategies, the same seed. On the simulation's 6 subsets also the c1 / c2 / c3 ablation of the
reservoir (the paper's Figs. 10-11) and selection at the paper's two threshold pairs (its Tables 7-8), both in
the paper's mode. Runs go to ``--runs`` and resume when killed. Printed: one row per finding the paper states,
its figure, ours in each mode, the verdict; then each mode's cost; then the sweeps' tables. With ``--out``, each
mode's run in the paper's full layout (every table of the report) is written beside it, ``<out>_<mode>_tables.md``.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from dataclasses import replace
from pathlib import Path

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

from benchmarks._report import Report  # noqa: E402
from handeye.core.tables import markdown_table  # noqa: E402

MODES = ("paper", "handeye")


def versions() -> str:
    import numpy as np
    import torch

    return f"python {sys.version.split()[0]}, numpy {np.__version__}, torch {torch.__version__}"


def demote(markdown: str, by: int = 2) -> str:
    """A report's headings ``by`` levels down, to sit under this page's dataset heading."""
    return "\n".join("#" * by + line if line.startswith("#") else line for line in markdown.splitlines())


def sweep_minutes(folder: Path) -> float:
    """Training and evaluation time of every run of a sweep, minutes (read back from its run folders)."""
    from learned.results import load_results

    settings = json.loads((folder / "sweep.json").read_text())["settings"]
    return sum(r["wall_s"] for s in settings for r in load_results(folder / s["name"])["runs"]) / 60


def labels_line(root: Path) -> str:
    """Which kind of label both modes train on here, and where that is not the paper's mode as written.

    Both modes read the one dataset's classic labels; the paper's mode as written trains on the paper's
    (``handeye label --method tsai --repeats 5``, :mod:`learned.label_kind`), so on this project's labels
    its column is the paper's protocol on other labels, and is said to be.
    """
    from learned.label_kind import PAPER, label_kind

    kind = label_kind(root)
    line = f"Labels: {kind or 'none'} (learned.label_kind), the same for both modes."
    if kind != PAPER:
        line += (
            " The paper's mode as written trains on the paper's labels ('handeye learned run --protocol paper' "
            "refuses these; label a copy with 'handeye label COPY --method tsai --repeats 5'): its column here is "
            "the paper's protocol on other labels."
        )
    return line


def run_mode(frames, preset, mode: str, where: str | None, out: Path, args) -> tuple[dict, float]:
    """One protocol run in ``mode``; its results and wall time (0 when read back from an earlier run)."""
    from learned.experiment import ExperimentOptions, run_experiment
    from learned.results import load_results

    p = preset.with_protocol(mode)
    if mode == "paper" and where == "real":
        p = replace(p, c2=None)  # "all observed camera poses" on the paper's real rig
    if args.repeats:
        p = replace(p, repeats=args.repeats)
    if (out / "results.json").exists():
        return load_results(out), 0.0
    t0 = time.perf_counter()
    options = ExperimentOptions(seed=args.seed)
    results = run_experiment(frames, p, out=out, progress=not args.quiet, threads=args.threads, options=options)
    return results, time.perf_counter() - t0


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--data", type=Path, nargs="+", required=True, help="labelled datasets")
    ap.add_argument("--preset", default="cpu", help="learned preset (default cpu; paper on a GPU)")
    ap.add_argument("--repeats", type=int, help="repeats per strategy (default: the preset's)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--threads", type=int)
    ap.add_argument("--runs", type=Path, default=Path("runs/paper-protocol"), help="where the runs are kept")
    ap.add_argument("--no-sweeps", action="store_true", help="skip the ablation and the threshold pairs")
    ap.add_argument("--quiet", action="store_true")
    ap.add_argument("--out", type=Path, help="results file (markdown)")
    args = ap.parse_args()

    from learned import ablation
    from learned.data import load_frames
    from learned.paper_tables import cost_rows, judge, setting
    from learned.presets import get_preset

    preset = get_preset(args.preset)
    if args.repeats:
        preset = replace(preset, repeats=args.repeats)
    rep = Report("The paper's protocol against this project's", "benchmarks/paper_protocol.py", None, versions())
    emit = rep.say
    emit(
        f"Preset {preset.name} ({preset.repeats} repeats, images {preset.image_size[0]} px), the paper's two "
        "networks (translation, orientation). Errors: RMSE over a subset's test frames (the paper's metric), mean "
        "over repeats. Verdicts by the paper's own comparisons (learned.paper_tables.judge): each with the paper's "
        "figure as the bound, over >= 3 repeats, a verdict only beyond the repeats' spread; selection's eliminations "
        "and data saving not judgeable where the baseline's error is above the threshold."
    )
    for root in args.data:
        frames = load_frames(root, preset.frame_size("regression"), "classic", progress=not args.quiet)
        probe = {"regions": sorted({int(r) for r in frames.region})}
        where = setting(probe)
        name = Path(root).name
        emit()
        emit(f"## {name}: {len(probe['regions'])} subsets ({where or 'neither of the paper setups'})")
        emit()
        emit(labels_line(root))
        emit()
        results, walls = {}, {}
        for mode in MODES:
            results[mode], walls[mode] = run_mode(frames, preset, mode, where, args.runs / name / mode, args)
        found = {m: judge(results[m]) for m in MODES}
        rows = []
        for f, g in zip(found["paper"], found["handeye"]):
            rows.append([f["table"], f["network"], f["finding"], f["paper"], f["ours"], g["ours"], f["verdict"],
                         g["verdict"]])  # fmt: skip
        emit("\n".join(markdown_table(
            ["paper table", "network", "finding", "paper", "ours, paper mode", "ours, handeye mode",
             "verdict, paper mode", "verdict, handeye mode"],
            rows,
        )))  # fmt: skip
        emit()
        emit("Cost of each run (data: training-set sizes summed over the steps, epochs aside):")
        emit()
        crow = []
        for mode in MODES:
            for r in cost_rows(results[mode]):
                crow.append([mode, r["strategy"], r["network"], f"{r['trained_samples']:.0f}",
                             f"{r['processed']:.0f}", f"{r['wall_s']:.0f}", f"{r['error']:.2f}"])  # fmt: skip
        emit("\n".join(markdown_table(
            ["mode", "strategy", "network", "data", "samples processed", "wall s", "final RMSE (mean of subsets)"],
            crow,
        )))  # fmt: skip
        emit()
        for mode in MODES:
            if args.out:  # the run in the paper's layout, every table, beside this page
                from learned.paper_tables import paper_tables

                tables = args.out.with_name(f"{args.out.stem}_{mode}_tables.md")
                tables.write_text(
                    f"# {name}, {mode} mode: the paper's layout\n\n" + "\n".join(paper_tables(results[mode]))
                )
                emit(f"{mode} mode's tables in the paper's layout: {tables}")
        for mode in MODES:
            spent = sum(r["wall_s"] for r in results[mode]["runs"]) / 60
            took = (
                f"; this invocation {walls[mode] / 60:.1f} min" if walls[mode] else " (read back from its run folder)"
            )
            emit(f"{mode} mode: {spent:.1f} min of training and evaluation over all strategies and networks{took}")
        if where != "sim" or args.no_sweeps:
            continue
        paper = preset.with_protocol("paper")
        sweep = {"seed": args.seed, "progress": not args.quiet, "threads": args.threads}
        ablation.run_ablation(frames, paper, args.runs / name / "ablation", **sweep)
        emit()
        emit(demote(ablation.ablation_report(args.runs / name / "ablation")))
        emit(f"ablation: {sweep_minutes(args.runs / name / 'ablation'):.1f} min of training and evaluation")
        ablation.run_thresholds(frames, paper, args.runs / name / "thresholds", **sweep)
        emit()
        emit(demote(ablation.threshold_report(args.runs / name / "thresholds")))
        emit(f"threshold pairs: {sweep_minutes(args.runs / name / 'thresholds'):.1f} min of training and evaluation")
    if args.out:
        args.out.parent.mkdir(parents=True, exist_ok=True)
    return rep.write(str(args.out) if args.out else None)


if __name__ == "__main__":
    sys.exit(main())
