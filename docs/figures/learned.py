"""The learned page (``docs/benchmarks/learned.md``): the error per time step by strategy."""

from __future__ import annotations

import re
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

from . import common
from .common import RESULTS, Figure, caption, command_of, tables


def learned_steps(out: Path) -> Figure:
    """The learned error per time step by strategy, and the paper protocol's naive run beside the paper's figures."""
    src = RESULTS / "learned_keypoints_cpu_paper-sim.md"
    real = RESULTS / "paper_protocol_paper-real_paper_tables.md"
    fig, axes = plt.subplots(1, 3, figsize=(13, 3.8), dpi=100)
    for heading, header, rows in tables(src):
        m = re.match(r"(batch|naive|reservoir|selection), (translation|orientation)", heading)
        if not m:
            continue
        ax = axes[0] if m[2] == "translation" else axes[1]
        steps = [(int(r[0][1:]), float(r[-1])) for r in rows if r[-1] != "-"]
        k, v = np.array(steps).T
        ax.plot(
            k, v, "s" if m[1] == "batch" else "o-", label=m[1] + (" (all data, last step)" if m[1] == "batch" else "")
        )
    for ax, unit in zip(axes[:2], ("mm", "deg")):
        ax.set_yscale("log")
        ax.set_xlabel("time step (after training on region k)")
        ax.set_ylabel(f"mean test error over subsets [{unit}]")
        ax.grid(True, which="both", alpha=0.3)
    axes[0].set_title("keypoint model, paper-sim: translation", fontsize=10)
    axes[1].set_title("keypoint model, paper-sim: orientation", fontsize=10)
    axes[0].legend(fontsize=7)
    (_, header, rows), *_ = [t for t in tables(real) if t[0].startswith("Table 13")]
    ours = [r for r in rows if r[0].startswith("T")]
    paper = [r for r in rows if r[0].startswith("paper")][0]
    for j, (colour, subset) in enumerate(zip(plt.cm.tab10.colors, header[1:]), start=1):
        axes[2].plot(
            range(1, len(ours) + 1), [float(r[j]) for r in ours], "o-", color=colour, label=f"{subset}: this run"
        )
        axes[2].plot([len(ours)], [float(paper[j])], "*", color=colour, ms=14, label=f"{subset}: the paper")
    axes[2].set_yscale("log")
    axes[2].set_xticks(range(1, len(ours) + 1))
    axes[2].set_xlabel("time step")
    axes[2].set_ylabel("RMSE per subset [mm]")
    axes[2].set_title("paper protocol, paper-real, naive (Table 13)", fontsize=10)
    axes[2].grid(True, which="both", alpha=0.3)
    axes[2].legend(fontsize=7, ncol=2)
    proto = RESULTS / "paper_protocol_paper-real.md"
    return common.save(
        fig,
        out / "learned_steps.png",
        caption(
            "Learned continual calibration: mean test error over the subsets after each time step, per strategy "
            "(left, middle); right, the naive strategy per subset against the paper's figures (stars: its text "
            "gives only the final step's; its other cells are not in the results files).",
            [
                (
                    src,
                    "handeye learned run --data data/paper-sim-noisy --preset cpu --family keypoints --out "
                    "runs/kp-cpu --threads 2; handeye learned report runs/kp-cpu",
                ),
                (real, command_of(proto)),
            ],
        ),
    )
