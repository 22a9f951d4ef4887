"""The markerless page's basin of convergence (``docs/benchmarks/markerless.md``): along the diagonal and mapped."""

from __future__ import annotations

import re
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

from . import common
from .common import RESULTS, Figure, caption, command_of, run_of, tables


def markerless_basin(out: Path) -> Figure:
    """Basin of convergence: the share of starts that succeed, refuse or answer wrong, by how far off they start."""
    sources = [RESULTS / "markerless_paper-sim.md", RESULTS / "markerless_basin_small.md"]
    fig, axes = plt.subplots(1, len(sources), figsize=(10, 3.6), dpi=100)
    for ax, src in zip(axes, sources):
        for heading, header, rows in tables(src):
            if not heading.startswith("Basin"):
                continue
            label = "centroid start beside" if "centroid" in heading else "given start alone"
            off = [int(r[0].split(" mm")[0]) for r in rows]
            total = [int(r[1].split("/")[1].split()[0]) for r in rows]
            ok = [100 * int(r[1].split("/")[0]) / t for r, t in zip(rows, total)]
            wrong = [100 * int(r[header.index("wrong answer")]) / t for r, t in zip(rows, total)]
            refused = [100 * int(r[header.index("refused")]) / t for r, t in zip(rows, total)]
            line = ax.plot(off, ok, "o-", label=f"{label}: success")[0]
            ax.plot(off, refused, "s--", color=line.get_color(), label=f"{label}: refused")
            ax.plot(off, wrong, "x:", color=line.get_color(), label=f"{label}: wrong")
        ax.set_title(f"{src.stem} ({heading.split(',')[0].split(': ')[1]})", fontsize=10)
        ax.set_xlabel("start off by [mm] (and one tenth of it in degrees)")
        ax.set_ylabel("share of trials [%]")
        ax.set_ylim(-5, 105)
        ax.grid(True, alpha=0.3)
    axes[0].legend(fontsize=7)
    return common.save(
        fig,
        out / "markerless_basin.png",
        caption(
            "Markerless basin of convergence: the share of trials that succeed, refuse or answer wrong against how "
            "far the start is off (translation and rotation off together, along the diagonal of the map below).",
            [(src, command_of(src)) for src in sources],
        ),
    )


def basin_map_cells(src: Path) -> dict[str, dict[tuple[int, float], dict[str, int]]]:
    """The basin tables of a map's results file: per start (``"given start alone"`` or ``"centroid start
    beside"``), per cell ``(mm, deg)``, the counts ``n``, ``good``, ``wrong``, ``far`` (wrong and beyond 3 sigma),
    ``refused``."""
    out: dict[str, dict[tuple[int, float], dict[str, int]]] = {}
    for heading, header, rows in tables(src):
        if not heading.startswith("Basin"):
            continue
        start = "centroid start beside" if "centroid" in heading else "given start alone"
        cells = out.setdefault(start, {})
        for r in rows:
            mm, deg = re.fullmatch(r"(\d+) mm, ([0-9.]+) deg", r[0]).groups()
            good, n = (int(v) for v in r[1].split()[0].split("/"))
            cells[(int(mm), float(deg))] = {
                "n": n,
                "good": good,
                "wrong": int(r[header.index("wrong answer")]),
                "far": int(r[header.index("of which beyond 3 sigma")]),
                "refused": int(r[header.index("refused")]),
            }
    return out


def markerless_basin_map(out: Path) -> Figure:
    """Basin of convergence as a map: start translation against start rotation, the given start alone and with
    the centroid start beside; colour the share of trials in the right basin, text the counts."""
    src = RESULTS / "markerless_basin_map_small.md"
    starts = basin_map_cells(src)
    order = [s for s in ("given start alone", "centroid start beside") if s in starts]
    fig, axes = plt.subplots(1, len(order), figsize=(11, 5.0), dpi=100, squeeze=False)
    fig.subplots_adjust(left=0.07, right=0.9, bottom=0.1, top=0.93, wspace=0.18)
    for ax, start in zip(axes[0], order):
        cells = starts[start]
        mms, degs = sorted({mm for mm, _ in cells}), sorted({deg for _, deg in cells})
        share = np.full((len(mms), len(degs)), np.nan)
        for (mm, deg), c in cells.items():
            i, j = mms.index(mm), degs.index(deg)
            share[i, j] = 100 * (c["good"] + c["wrong"] - c["far"]) / c["n"]
            text = [f"{c['good'] + c['wrong'] - c['far']}/{c['n']}", f"{c['good']} in 1 mm"]
            text += [f"{c['refused']} refused"] * bool(c["refused"]) + [f"{c['far']} WRONG"] * bool(c["far"])
            ax.text(
                j,
                i,
                "\n".join(text),
                ha="center",
                va="center",
                fontsize=6.5,
                color="red" if c["far"] else ("white" if share[i, j] < 50 else "black"),
            )
        im = ax.imshow(share, origin="lower", cmap="viridis", vmin=0, vmax=100, aspect="auto")
        ax.set_xticks(range(len(degs)), [f"{d:g}" for d in degs])
        ax.set_yticks(range(len(mms)), [str(m) for m in mms])
        ax.set_xlabel("start rotated off by [deg]")
        ax.set_ylabel("start translated off by [mm]")
        n = next(iter(cells.values()))["n"]
        ax.set_title(f"{start} ({n} trials a cell)", fontsize=10)
    fig.colorbar(im, ax=axes[0].tolist(), fraction=0.03, pad=0.02, label="accepted within 3 sigma of the truth [%]")
    return common.save(
        fig,
        out / "markerless_basin_map.png",
        caption(
            "Markerless basin of convergence on the small preset, mapped: start translation against start rotation "
            "(about a random axis and direction). Colour and first line: the trials accepted within 3 predicted "
            "sigmas of the truth (the right basin); then those also within 1 mm / 0.1 deg, the refusals, and in red "
            f"the answers accepted beyond 3 sigma (a wrong basin). Run {run_of(src)}.",
            [(src, command_of(src))],
        ),
        laid_out=True,
    )
