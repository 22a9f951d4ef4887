"""The simulation page (``docs/benchmarks/simulation.md``): the labels' error against the simulator's truth."""

from __future__ import annotations

import re
import textwrap
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

from . import common
from .common import RESULTS, Figure, caption, legend_below, tables

#: The columns of the labels table the figure draws, per panel: (panel title, unit, median column, worst column).
LABEL_PANELS = (
    ("rotation", "deg", "median deg", "worst deg"),
    ("translation", "mm", "median mm", "worst mm"),
)


def label_rows(src: Path) -> list[dict]:
    """The 'Labels against truth' table of ``sim_generation_<preset>.md``: per noise row (in the file's order) its
    ``noise``, ``labelled`` (``"108/108"``), each column of :data:`LABEL_PANELS` as a float (deg or mm) and
    ``text``, those cells as the file writes them."""
    (_, header, rows), *_ = [t for t in tables(src) if t[0].startswith("Labels against truth")]
    columns = [c for _, _, median, worst in LABEL_PANELS for c in (median, worst)]
    return [
        {"noise": r[0], "labelled": r[header.index("labelled")], "text": {c: r[header.index(c)] for c in columns}}
        | {c: float(r[header.index(c)]) for c in columns}
        for r in rows
    ]


def title_command(src: Path) -> str:
    """The command in backticks on a results file's first line (``# Simulator benchmark: `python ...```)."""
    first = src.read_text(encoding="utf-8").splitlines()[0]
    found = re.search(r"`([^`]+)`", first)
    if found is None:
        raise ValueError(f"{src}: no command in backticks on its first line")
    return found[1]


def simulation_labels(out: Path) -> Figure:
    """Per noise row, the labels' median and worst error against the truth, in rotation and translation."""
    src = RESULTS / "sim_generation_paper-sim.md"
    rows = label_rows(src)
    fig, axes = plt.subplots(1, len(LABEL_PANELS), figsize=(11, 3.9), dpi=100, sharey=True)
    y = np.arange(len(rows))
    for ax, (what, unit, median, worst) in zip(axes, LABEL_PANELS):
        low, high = [r[median] for r in rows], [r[worst] for r in rows]
        ax.hlines(y, low, high, color="0.6", lw=1, zorder=1)
        ax.plot(low, y, "o", color="tab:blue", zorder=2, label="median over the camera poses")
        ax.plot(high, y, "s", mfc="none", color="tab:red", zorder=2, label="worst camera pose")
        for k, r in enumerate(rows):
            ax.text(r[median] / 1.12, k, r["text"][median], ha="right", va="center", fontsize=7, color="tab:blue")
            ax.text(r[worst] * 1.12, k, r["text"][worst], ha="left", va="center", fontsize=7, color="tab:red")
        ax.set_xscale("log")
        ax.set_xlim(min(low) / 3, max(high) * 3)
        ax.set_xlabel(f"label error against the truth [{unit}]")
        ax.set_title(f"{what} [{unit}]", fontsize=10)
        ax.grid(True, axis="x", which="major", alpha=0.3)
    labels = [textwrap.fill(r["noise"], 26) + f"\n{r['labelled']} labelled" for r in rows]
    axes[0].set_yticks(y, labels, fontsize=8)
    axes[0].set_ylim(len(rows) - 0.5, -0.5)
    axes[0].set_ylabel("noise (pixel grey levels, joint deg)")
    legend_below(fig, *axes[0].get_legend_handles_labels(), ncol=2, height=0.08)
    what = (
        "Labels against the truth, simulated (`paper-sim`): per noise setting, the median over the camera poses "
        "(dot) and the worst camera pose (square) of the label's error against the simulator's truth, in rotation "
        "and translation (log scale); the noisy rows are the calibration recordings rendered again with that noise."
    )
    return common.save(fig, out / "simulation_labels.png", caption(what, [(src, title_command(src))]), laid_out=True)
