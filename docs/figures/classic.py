"""The classic solvers' page (``docs/benchmarks/classic.md``): the error against the Cramér–Rao bound."""

from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
import matplotlib.ticker
import numpy as np

from . import common
from .common import RESULTS, Figure, caption, command_of, legend_below, pair, tables


def classic_bound(out: Path) -> Figure:
    """RMS error of X against the number of poses beside the Cramér–Rao bound, per noise model."""
    src = RESULTS / "classic_ml.md"
    (_, _, rows), *_ = [t for t in tables(src) if t[0].startswith("Efficiency")]
    models: dict[str, dict] = {}
    for r in rows:
        model, n = r[0].rsplit(" ", 1)
        bound, ml, default = pair(r[1]), pair(r[2]), pair(r[3])
        models.setdefault(model, {})[int(n)] = (bound, ml, default)
    fig, axes = plt.subplots(1, 2, figsize=(10, 3.8), dpi=100)
    for colour, (model, cells) in zip(plt.cm.tab10.colors, models.items()):
        n = sorted(cells)
        for ax, j, unit in ((axes[0], 1, "mm"), (axes[1], 0, "deg")):
            bound = np.array([cells[k][0][j] for k in n])
            ax.plot(n, bound, "-", color=colour, label=f"{model}: bound")
            ax.plot(n, bound * [cells[k][2][j] for k in n], "o", color=colour, label=f"{model}: handeye default")
            ax.set_ylabel(f"RMS error of X [{unit}]")
    for ax, what in zip(axes, ("translation", "rotation")):
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xticks([10, 20, 50], ["10", "20", "50"])
        ax.xaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
        ax.set_xlabel("number of poses")
        ax.set_title(f"{what}: default (dots) on the bound (lines)", fontsize=10)
        ax.grid(True, which="both", alpha=0.3)
    legend_below(fig, *axes[0].get_legend_handles_labels(), ncol=4, height=0.12)
    return common.save(
        fig,
        out / "classic_bound.png",
        caption(
            "RMS error of `T_base_cam` of `calibrate`'s default (robust in the outlier cells) against the number "
            "of poses, over 500 trials per cell (the file's RMS / bound ratio times the bound), beside the Cramér–Rao "
            "bound of each noise model.",
            [(src, command_of(src))],
        ),
        laid_out=True,
    )
