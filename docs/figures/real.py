"""The real recordings' page (``docs/benchmarks/real.md``): every method's hold-out error and sigma."""

from __future__ import annotations

import re
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

from .common import RESULTS, Figure, legend_and_save, pair, tables

#: The methods of ``real_recordings.md``'s tables, grouped as the figure draws them: (group, colour, marker).
REAL_GROUPS = (
    ("default (auto+lm)", "tab:blue", "o"),
    ("robust=True", "tab:cyan", "v"),
    ("closed forms refined (+lm)", "tab:green", "^"),
    ("closed forms bare, this project", "tab:orange", "s"),
    ("OpenCV's five and two", "tab:brown", "x"),
    ("image path (corners)", "tab:purple", "D"),
)


def real_group(method: str) -> str:
    """The group of :data:`REAL_GROUPS` a method row of ``real_recordings.md`` belongs to."""
    if method.startswith("handeye default"):
        return REAL_GROUPS[0][0]
    if method.startswith("handeye robust"):
        return REAL_GROUPS[1][0]
    if method.startswith("handeye image path"):
        return REAL_GROUPS[5][0]
    if method.startswith("opencv "):
        return REAL_GROUPS[4][0]
    if re.fullmatch(r"handeye \w+\+lm", method):
        return REAL_GROUPS[2][0]
    if method.endswith("(closed form)"):
        return REAL_GROUPS[3][0]
    raise ValueError(f"no group for the method {method!r}")


def real_recordings(paths: list[Path]) -> list[dict]:
    """Each recording of the real-recordings files: its name, poses, setup, answers, refusals and per method its
    group, hold-out median (deg, mm), sigma ratios against disjoint halves (rotation, translation; nan where the
    method has no sigma) and refusals (``refused``: of all the poses; ``holdout``: of the hold-out splits)."""
    out = []
    for path in paths:
        text = path.read_text(encoding="utf-8")
        counts = dict(re.findall(r"^## (\w+): .*?^answers \d+, refusals (\d+)", text, re.M | re.S))
        for heading, header, rows in tables(path):
            if header[0] != "method" or "hold-out median: deg / mm" not in header:
                continue
            name, poses, setup = re.fullmatch(r"(\w+): (\d+) poses, (\S+)", heading).groups()
            hold, halves = (
                header.index("hold-out median: deg / mm"),
                header.index(next(h for h in header if h.startswith("halves"))),
            )
            refused = header.index("refused (all; hold-out)")
            methods = []
            for r in rows:
                ratio = [float(v) for v in r[halves].split(",")] if r[halves] else [float("nan")] * 2
                every, split = (v.strip() for v in r[refused].split(";"))
                methods.append(
                    {
                        "method": r[0],
                        "group": real_group(r[0]),
                        "holdout": pair(r[hold]),
                        "halves": tuple(ratio),
                        "refused": every != "no",
                        "holdout_refused": int(split),
                    }
                )
            out.append(
                {
                    "name": name,
                    "poses": int(poses),
                    "setup": setup,
                    "refusals": int(counts[name]),
                    "methods": methods,
                }
            )
    return out


def real_recordings_figure(out: Path) -> Figure:
    """Per real recording, each method's hold-out error and its sigma against disjoint halves; refusals counted."""
    sources = [RESULTS / "real_recordings.md", RESULTS / "real_recordings_rwhe.md"]
    recordings = real_recordings(sources)
    fig, axes = plt.subplots(1, 3, figsize=(13, 4.6), dpi=100, sharey=True)
    offsets = dict(zip((g for g, _, _ in REAL_GROUPS), np.linspace(-0.3, 0.3, len(REAL_GROUPS))))
    style = {g: (c, m) for g, c, m in REAL_GROUPS}
    for k, rec in enumerate(recordings):
        for m in rec["methods"]:
            y = k + offsets[m["group"]]
            colour, mark = style[m["group"]]
            for ax, value in zip(axes[:2], m["holdout"]):
                ax.plot(value, y, mark, color=colour, ms=5, mfc="none" if mark in "s^v" else colour)
            rot, trans = m["halves"]
            if np.isfinite(rot):
                axes[2].plot([rot, trans], [y, y], "-", color=colour, lw=0.8, alpha=0.5)
                axes[2].plot(rot, y, "o", color=colour, ms=5)
                axes[2].plot(trans, y, "s", color=colour, ms=5, mfc="none")
            if m["refused"] or m["holdout_refused"]:
                for ax in axes:
                    ax.plot(1, y, "X", color="red", ms=8, transform=ax.get_yaxis_transform(), clip_on=False)
    labels = [
        f"{r['name']}\n{r['poses']} poses, {r['setup']}\n{len(r['methods'])} answers, {r['refusals']} refused"
        for r in recordings
    ]
    axes[0].set_yticks(range(len(recordings)), labels, fontsize=8)
    axes[0].set_ylim(len(recordings) - 0.5, -0.5)
    for ax, unit, what in ((axes[0], "deg", "rotation"), (axes[1], "mm", "translation")):
        ax.set_xscale("log")
        ax.set_xlabel(f"hold-out error, median of the splits [{unit}]")
        ax.set_title(f"hold-out: the held-out camera poses' {what}", fontsize=10)
        ax.grid(True, axis="x", which="both", alpha=0.3)
    axes[2].axvline(1, color="0.3", ls="--", lw=1)
    axes[2].set_xlim(0, 2)
    axes[2].set_xlabel("disjoint halves: RMS of difference / sigma [1]")
    axes[2].set_title("sigma against disjoint halves (1: the sigma is right)", fontsize=10)
    axes[2].grid(True, axis="x", alpha=0.3)
    for ax in axes:
        for k in range(1, len(recordings)):
            ax.axhline(k - 0.5, color="0.8", lw=0.8)
    handles = [
        plt.Line2D([], [], marker=m, ls="", color=c, mfc="none" if m in "s^v" else c, label=g)
        for g, c, m in REAL_GROUPS
    ]
    handles += [
        plt.Line2D([], [], marker="o", ls="", color="0.3", label="halves: rotation"),
        plt.Line2D([], [], marker="s", ls="", mfc="none", color="0.3", label="halves: translation"),
    ]
    refusals = sum(r["refusals"] + sum(m["holdout_refused"] for m in r["methods"]) for r in recordings)
    handles.append(
        plt.Line2D([], [], marker="X", ls="", color="red", label=f"refused, at the panel's edge ({refusals} here)")
    )
    what = (
        "Every method on the real recordings: per recording (the answers and refusals on all its poses beside its "
        "name) each method's hold-out error (fit on 80 % of the poses, the other 20 %'s camera poses predicted; the "
        "median over the splits), and, for the methods with a sigma, the RMS over disjoint halves of their "
        "difference over their combined sigma (1 when the sigma is right, above 1 when it is overconfident); "
        f"{refusals} refusals in these runs."
    )
    return legend_and_save(fig, handles, (5, 0.13), out / "real_recordings.png", what, sources)
