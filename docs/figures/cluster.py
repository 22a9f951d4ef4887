"""The cluster page (``docs/benchmarks/cluster.md``): Ray against the process pool, and data-parallel training's time
per run against one process."""

from __future__ import annotations

import re
from pathlib import Path

import matplotlib.patches
import matplotlib.pyplot as plt
import numpy as np

from .common import RESULTS, Figure, legend_and_save, tables

#: The throughput columns of ``cluster_engines.md`` the figure draws, one panel each: (column, what it counts).
THROUGHPUT = (("shards/min", "generation"), ("camera poses/min", "labelling"))
#: The engines' colours.
ENGINES = {"pool": "tab:gray", "ray": "tab:blue"}
#: The time columns of ``distributed_training.md``: (column, bar width, opacity): the whole command wide and light,
#: its protocol (training and evaluation) narrow and dark in front of it.
TIMES = (("wall (whole command)", 0.8, 0.35), ("protocol (training and evaluation)", 0.5, 1.0))


def throughput(src: Path) -> tuple[dict[str, dict[str, float]], dict[str, str]]:
    """``cluster_engines.md``'s Throughput table: per engine the columns of :data:`THROUGHPUT`; and the file's
    ratios of Ray's throughput to the pool's, per what they count (``{"generation": "1.198", ...}``)."""
    (_, header, rows), *_ = [t for t in tables(src) if t[0] == "Throughput"]
    cells = {r[0]: {c: float(r[header.index(c)]) for c, _ in THROUGHPUT} for r in rows}
    found = re.search(
        r"^Ray's throughput / the pool's: generation ([0-9.]+), labelling ([0-9.]+)", src.read_text(), re.M
    )
    if found is None:
        raise ValueError(f"{src}: no line of Ray's throughput over the pool's")
    return cells, {"generation": found[1], "labelling": found[2]}


def training_times(src: Path) -> dict[str, dict[str, dict]]:
    """``distributed_training.md``'s time tables: per preset (the file's order), per configuration, the mean and std
    [s] of each column of :data:`TIMES` (``"6.9 ± 0.9"`` -> (6.9, 0.9)) and its ``"speed-up"`` as the file writes
    it (``"0.47x"``)."""
    out: dict[str, dict[str, dict]] = {}
    for heading, header, rows in tables(src):
        m = re.fullmatch(r"Preset (\S+): time per run .*", heading)
        if not m:
            continue
        preset = out.setdefault(m[1], {})
        for r in rows:
            cell = {c: tuple(float(v) for v in r[header.index(c)].split("±")) for c, _, _ in TIMES}
            preset[r[0]] = cell | {"speed-up": r[header.index("speed-up")]}
    return out


def cluster_throughput(out: Path) -> Figure:
    """Shards and camera poses per minute, pool against Ray; and the time per learned run per configuration and
    preset, one process against two, with the std over the seeds."""
    engines, training = RESULTS / "cluster_engines.md", RESULTS / "distributed_training.md"
    cells, ratios = throughput(engines)
    times = training_times(training)
    fig, axes = plt.subplots(1, 3, figsize=(13, 4.2), dpi=100, gridspec_kw={"width_ratios": (1, 1, 2.2)})
    for ax, (column, what) in zip(axes, THROUGHPUT):
        names = list(cells)
        values = [cells[e][column] for e in names]
        ax.bar(names, values, color=[ENGINES[e] for e in names], width=0.6, label=column)
        for k, v in enumerate(values):
            ax.text(k, v, f"{v:.1f}", ha="center", va="bottom", fontsize=8)
        ax.set_ylabel(column)
        ax.set_title(f"{what}: ray / pool {ratios[what]}", fontsize=10)
        ax.set_ylim(0, max(values) * 1.15)
        ax.grid(True, axis="y", alpha=0.3)
    configurations = list(next(iter(times.values())))
    colours = dict(zip(configurations, plt.cm.tab10.colors[1:]))
    step = len(configurations) + 1
    for column, width, alpha in TIMES:
        for j, config in enumerate(configurations):
            x = [i * step + j for i in range(len(times))]
            mean, std = np.array([times[p][config][column] for p in times]).T
            axes[2].bar(
                x, mean, width, yerr=std, capsize=3, color=colours[config], alpha=alpha, label=f"{config}, {column}"
            )
    for i, preset in enumerate(times):
        for j, config in enumerate(configurations):
            top = sum(times[preset][config][TIMES[0][0]])
            axes[2].text(i * step + j, top, times[preset][config]["speed-up"], ha="center", va="bottom", fontsize=7)
    axes[2].set_xticks(
        [i * step + (len(configurations) - 1) / 2 for i in range(len(times))], [f"preset {p}" for p in times]
    )
    axes[2].set_ylabel("time per run [s] (mean ± std over the seeds)")
    axes[2].set_title("data-parallel training on CPU (gloo); above: the protocol's speed-up", fontsize=10)
    axes[2].grid(True, axis="y", alpha=0.3)
    handles = [matplotlib.patches.Patch(color=ENGINES[e], label=f"engine: {e}") for e in ENGINES]
    handles += [matplotlib.patches.Patch(color=colours[c], label=c) for c in configurations]
    handles += [
        matplotlib.patches.Patch(color="0.3", alpha=a, label=f"{c}, {'light' if a < 1 else 'dark'}")
        for c, _, a in TIMES
    ]
    what = (
        "Ray against the process pool and data-parallel training, on 2 CPU cores: left and middle, the throughput "
        "of generating and of labelling the `demo` preset, the pool's and Ray's (each with 2 workers; the file's "
        "ratio above); right, the time per learned run, 1 process against 2 (torchrun, gloo), per configuration "
        "and preset, the mean over the seeds with its std as error bar: the whole command (light) and its "
        "protocol, training and evaluation (dark); above each, the file's speed-up of the protocol over 1 process "
        "on 1 thread."
    )
    return legend_and_save(fig, handles, (4, 0.16), out / "cluster_throughput.png", what, [engines, training])
