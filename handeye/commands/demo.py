"""``handeye demo``: the whole pipeline on a small simulated cell, in minutes on a laptop CPU.

Example
-------
::

    handeye demo                       # data in data/demo, run in runs/demo

1. renders the ``demo`` preset (a UR5 seen from 14 camera poses, 6 to train and
   1 to test in each of 2 azimuth regions; 10 board views and 20 data frames
   per camera pose), resumable;
2. labels every camera pose with the classic calibration (ChArUco, PnP,
   eye-to-hand solve, reprojection refinement) and prints the label errors;
3. trains the learned calibration continually (region by region) with each
   strategy, on the classic labels;
4. prints, per test camera pose, the learned calibration against the classic
   label and the truth, the hybrid (the learned start refined by registering
   the robot's surface to the depth frames, no board), and the paper's
   findings on this run.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from handeye.commands import command_parser

__all__ = ["add_parser", "run"]


def add_parser(sub) -> argparse.ArgumentParser:
    """Register the command."""
    p = command_parser(sub, "demo", "small dataset -> labels -> continual training -> comparison", __doc__)
    p.add_argument("--data", type=Path, default=Path("data/demo"))
    p.add_argument("--out", type=Path, default=Path("runs/demo"))
    p.add_argument("--sim-preset", default="demo")
    p.add_argument("--preset", default="demo", help="learned preset (default demo)")
    p.add_argument("--strategies", default="batch,naive,reservoir,selection")
    p.add_argument("--quiet", action="store_true")
    p.set_defaults(run=run)
    return p


def run(args: argparse.Namespace) -> int:
    """Run the command."""
    import time

    from handeye.core.optional import require_package

    require_package("pyrender", extra="sim", purpose="rendering")
    require_package("torch", extra="learned", purpose="the learned calibration")
    from handeye.commands.compare import compare_table
    from handeye.core.engine_protocol import EngineOptions
    from handeye.labelling import label_dataset
    from learned.experiment import run_experiment
    from learned.report import findings, write_report
    from sim.generate import Recipe, generate

    t0 = time.perf_counter()
    print(f"[1/4] rendering the {args.sim_preset} preset into {args.data}")
    report = generate(args.data, Recipe(args.sim_preset), options=EngineOptions(progress=not args.quiet))
    print("      " + report.summary())
    print("[2/4] labelling every camera pose (classic calibration)")
    labels = label_dataset(args.data, progress=not args.quiet)
    print("      " + labels.summary().replace("\n", "\n      "))
    print(f"[3/4] continual training, preset {args.preset}, strategies {args.strategies}")
    results = run_experiment(
        args.data,
        args.preset,
        [s.strip() for s in args.strategies.split(",")],
        args.out,
        progress=not args.quiet,
        threads=2,
    )
    write_report(args.out)
    print("[4/4] per test camera pose, translation mm / rotation deg:")
    from handeye.markerless import markerless_dataset

    hybrid = {}
    for strategy, pc in results["per_camera"].items():
        hybrid[strategy] = markerless_dataset(args.data, pc["camera"], model_dir=args.out / strategy)
        print(f"\n{strategy}:\n{compare_table(pc, hybrid[strategy])}")
    print()
    for line in findings(results):
        print(line)
    print(f"\nreport: {args.out / 'report.md'} (figures beside it); total {time.perf_counter() - t0:.0f} s")
    return 0
