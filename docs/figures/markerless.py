"""The markerless page's sensor figures (``docs/benchmarks/markerless.md``): the error per depth sensor profile
against the camera's distance, and the real-sensor tables as one figure."""

from __future__ import annotations

import re
from pathlib import Path

import matplotlib.pyplot as plt
import matplotlib.ticker
import numpy as np

from . import common
from .common import RESULTS, Figure, caption, command_of, legend_below, pair, tables

#: The depth sensor profiles, in the order the figures draw them.
SENSORS = ("ideal", "d435", "d455", "l515", "azure-kinect", "zivid", "d435-sgbm")


def markerless_distance(out: Path) -> Figure:
    """Markerless error against the camera's distance per sensor profile, and error over sigma with the 3-sigma band."""
    src = RESULTS / "markerless_sensors.md"
    data: dict[tuple[str, str, str], list] = {}
    for heading, _, rows in tables(src):
        m = re.match(r"(paper-\w+)-\S+: .*cameras ([0-9.]+) m", heading)
        if not m:
            continue
        for r in rows:
            sensor, mode = r[0].split(", ", 1)
            med, z = pair(r[2])[0], pair(r[4])[0]
            data.setdefault((m[1], sensor, mode), []).append((float(m[2]), med, z))
    presets = sorted({k[0] for k in data})
    fig, axes = plt.subplots(len(presets), 2, figsize=(10, 3.6 * len(presets)), dpi=100, squeeze=False)
    for row, preset in zip(axes, presets):
        for colour, sensor in zip(plt.cm.tab10.colors, SENSORS):
            for mode, style in (("self-calibrated", "o-"), ("depth taken as exact", "x:")):
                pts = sorted(data.get((preset, sensor, mode), []))
                if not pts:
                    continue
                d, med, z = np.array(pts).T
                label = f"{sensor}" if mode == "self-calibrated" else None
                if mode == "self-calibrated":
                    row[0].plot(d, med, style, color=colour, label=label)
                row[1].plot(d, z, style, color=colour, label=label)
        row[1].axhspan(0, 3, color="0.85", zorder=0, label="within 3 sigma")
        row[0].set_yscale("log")
        row[0].set_ylabel("median translation error [mm]")
        row[1].set_ylabel("RMS error / predicted sigma")
        row[0].set_title(f"{preset}: error, self-calibrated depth", fontsize=10)
        row[1].set_title(f"{preset}: error over sigma (x: depth taken as exact)", fontsize=10)
        for ax in row:
            ax.set_xlabel("camera distance from the workspace centre [m]")
            ax.grid(True, alpha=0.3)
    axes[0][1].legend(fontsize=7, ncol=2)
    return common.save(
        fig,
        out / "markerless_distance.png",
        caption(
            "Markerless calibration per depth sensor profile against the camera's distance (median over the test "
            "placements); right, the RMS over the placements of error / predicted sigma: 1 when the sigma is right, "
            "the grey band up to 3 sigma. Depth taken as exact (crosses) leaves it.",
            [(src, command_of(src))],
        ),
    )


def charuco_medians(text: str) -> dict[str, float | None]:
    """The ChArUco label's median translation error [mm] under each ``## dataset-band:`` heading of
    ``markerless_sensors.md``'s text; None where the line says none (no board view at that distance)."""
    found = re.findall(r"^## (\S+):.*\n\nChArUco label[^:\n]*: (?:median ([0-9.]+) mm|none)", text, re.M)
    return {name: float(mm) if mm else None for name, mm in found}


def markerless_sensors(out: Path) -> Figure:
    """The real-sensor tables as one figure: per dataset and distance, each profile's median and worst error."""
    src = RESULTS / "markerless_sensors.md"
    charuco = charuco_medians(src.read_text(encoding="utf-8"))
    panels = []
    for heading, _, rows in tables(src):
        m = re.match(r"((paper-\w+)-\S+): .*cameras ([0-9.]+) m", heading)
        if m:
            panels.append((m[2], float(m[3]), m[1], rows))
    presets = sorted({p[0] for p in panels})
    ncol = max(sum(p[0] == preset for p in panels) for preset in presets)
    fig, axes = plt.subplots(
        len(presets), ncol, figsize=(15, 4.2 * len(presets)), dpi=100, squeeze=False, sharex=True, sharey=True
    )
    y = np.arange(len(SENSORS))
    modes = (("self-calibrated", -0.17, "tab:blue", "o"), ("depth taken as exact", 0.17, "tab:red", "x"))
    for row, preset in zip(axes, presets):
        mine = sorted((p for p in panels if p[0] == preset), key=lambda p: p[1])
        for ax, (_, distance, name, rows) in zip(row, mine):
            cells = {tuple(r[0].split(", ", 1)): r for r in rows}
            for k, sensor in enumerate(SENSORS):
                for mode, dy, colour, mark in modes:
                    r = cells.get((sensor, mode))
                    if r is None:
                        continue
                    accepted = r[1]
                    med, worst = pair(r[2])[0], pair(r[3])[0]
                    if np.isfinite(med):
                        ax.plot([med, worst], [k + dy] * 2, "-", color=colour, lw=1, alpha=0.5)
                        ax.plot(med, k + dy, mark, color=colour)
                        ax.plot(worst, k + dy, "|", color=colour, ms=9, mew=2)
                        z, wrong = pair(r[4])[0], int(r[5])
                        note = f"{accepted}, z {z:.1f}" + (f", {wrong} wrong" if wrong else "")
                    else:
                        note = f"{accepted}: all refused"
                    ax.text(
                        900,
                        k + dy,
                        note,
                        va="center",
                        ha="right",
                        fontsize=6.5,
                        color=colour if wrong or "all" in note else "0.35",
                    )
            if charuco.get(name):
                ax.axvline(charuco[name], color="0.4", ls="-.", lw=1)
            ax.axvline(1, color="0.6", ls="--", lw=0.8)
            ax.set_title(f"{preset} at {distance:.2f} m", fontsize=10)
            ax.set_xscale("log")
            ax.set_xlim(0.01, 1000)
            ax.set_xticks([0.01, 0.1, 1, 10], ["0.01", "0.1", "1", "10"])
            ax.xaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
            ax.grid(True, axis="x", which="major", alpha=0.3)
            ax.set_xlabel("translation error [mm]")
        row[0].set_yticks(y, SENSORS, fontsize=8)
        row[0].set_ylim(len(SENSORS) - 0.5, -0.5)
    handles = [
        plt.Line2D([], [], marker="o", ls="", color="tab:blue", label="self-calibrated depth (default): median"),
        plt.Line2D([], [], marker="x", ls="", color="tab:red", label="depth taken as exact: median"),
        plt.Line2D([], [], marker="|", ls="", mew=2, ms=9, color="0.3", label="worst"),
        plt.Line2D([], [], color="0.4", ls="-.", label="ChArUco label's median (none at 0.7 m)"),
        plt.Line2D([], [], color="0.6", ls="--", label="1 mm"),
    ]
    legend_below(fig, handles, [h.get_label() for h in handles], ncol=5, height=0.05)
    return common.save(
        fig,
        out / "markerless_sensors.png",
        caption(
            "The six tables below as one figure, simulated: per dataset and camera distance, each depth sensor "
            "profile's median (dot, cross) and worst (bar) translation error over the test placements, 256x256; "
            "beside it accepted of all, z (the RMS of error over predicted sigma, 1 when the sigma is right) and "
            "the answers accepted beyond 3 sigma (wrong).",
            [(src, command_of(src))],
        ),
        laid_out=True,
    )
