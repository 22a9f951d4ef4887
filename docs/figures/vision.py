"""The image path's page (``docs/benchmarks/vision.md``): the error against the corners' and the robot's noise."""

from __future__ import annotations

import re
from pathlib import Path

import matplotlib.pyplot as plt
import matplotlib.ticker
import numpy as np

from .common import RESULTS, Figure, legend_and_save, pair, tables


def _numbers_of(text: str) -> list[float]:
    """The numbers in ``text``, in order: ``"0.05 deg, 0.5 mm"`` -> [0.05, 0.5]."""
    return [float(v) for v in re.findall(r"-?\d+(?:\.\d+)?", text)]


def vision_errors(out: Path) -> Figure:
    """The image path against its error sources: X's error against the corners' noise per method, and the sigma
    against the robot's pose error (RMS of error / sigma and the 3-sigma coverage) with and without its model."""
    repro, robot = RESULTS / "vision_reprojection.md", RESULTS / "vision_robot_noise.md"
    fig, axes = plt.subplots(1, 3, figsize=(13, 4.8), dpi=100)
    (_, header, rows), *_ = [t for t in tables(repro) if t[1][0] == "corner noise px"]
    methods = [h for h in header[2:] if h != "most accurate"]
    colours = ("tab:cyan", "tab:orange", "tab:green", "tab:olive", "tab:purple", "tab:brown")
    for j, (colour, mark, method) in enumerate(zip(colours, "os^vxD", methods), start=2):
        for views, ls in (("15", "--"), ("30", "-")):
            cells = [(float(r[0]), pair(r[j])[1]) for r in rows if r[1].split()[0] == views]
            noise, mm = np.array(cells).T
            label = method if views == "30" else None
            axes[0].plot(noise, mm, ls, marker=mark, color=colour, ms=5, mfc="none", label=label)
    axes[0].set_xscale("log")
    axes[0].set_yscale("log")
    axes[0].set_xticks([0.1, 0.3, 1.0], ["0.1", "0.3", "1"])
    axes[0].xaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
    axes[0].set_xlabel("corner noise per axis [px]")
    axes[0].set_ylabel("median translation error of X [mm]")
    axes[0].set_title("error against the corners' noise (solid 30 views, dashed 15)", fontsize=10)
    axes[0].grid(True, which="both", alpha=0.3)
    (_, header, rows), *_ = [t for t in tables(robot) if t[1][:3] == ["setup", "robot error per axis", "model"]]
    levels = sorted(dict.fromkeys(r[1] for r in rows), key=lambda lv: _numbers_of(lv))
    components = ("X rotation", "X translation", "Y rotation", "Y translation")
    models = {"estimate": "tab:blue", "none": "tab:red"}
    setups = {"eye-to-hand": ("-", -0.08), "eye-in-hand": (":", 0.08)}
    for model, colour in models.items():
        for setup, (ls, dx) in setups.items():
            mine = {r[1]: r for r in rows if r[0] == setup and r[2] == model}
            x = np.arange(len(levels)) + dx
            z = np.array([[float(v) for v in mine[lv][header.index("RMS error / sigma")].split("/")] for lv in levels])
            cover = np.array(
                [[float(v.strip(" %")) for v in mine[lv][header.index("3-sigma coverage")].split("/")] for lv in levels]
            )
            for c, mark in zip(range(len(components)), "os^D"):
                axes[1].plot(x, z[:, c], ls, marker=mark, color=colour, ms=5, mfc="none", lw=1)
                axes[2].plot(x, cover[:, c], ls, marker=mark, color=colour, ms=5, mfc="none", lw=1)
    axes[1].axhline(1, color="0.3", ls="--", lw=1)
    axes[1].set_ylabel("RMS of error / sigma over the trials [1]")
    axes[1].set_title("sigma against the robot's pose error (1: right)", fontsize=10)
    axes[2].axhline(95, color="0.3", ls="--", lw=1)
    axes[2].set_ylim(0, 105)
    axes[2].set_ylabel("truth within 3 sigma [% of the trials]")
    axes[2].set_title("3-sigma coverage (dashed: the target, 95 %)", fontsize=10)
    ticks = [lv.replace("0.0 deg, 0.0 mm", "exact robot") for lv in levels]
    for ax in axes[1:]:
        ax.set_xticks(range(len(levels)), ticks)
        ax.set_xlabel("robot's pose error per axis, not told to the solver")
        ax.grid(True, alpha=0.3)
    handles = axes[0].get_lines()[1::2]
    handles += [plt.Line2D([], [], color=c, label=f"robot's error: {m}") for m, c in models.items()]
    handles += [plt.Line2D([], [], color="0.3", ls=ls, label=s) for s, (ls, _) in setups.items()]
    handles += [
        plt.Line2D([], [], marker=mark, ls="", mfc="none", color="0.3", label=c) for c, mark in zip(components, "os^D")
    ]
    what = (
        "The image path against its two error sources, simulated: left, the median translation error of "
        "`X = T_base_cam` over 100 trials against the corners' noise, per method (the pose-based fit with the PnP "
        "covariances and the reprojection refinement lie together, about ten times below the others); middle "
        "and right, against the robot's pose error the solver is not told (25 views, corners 0.1 px), the RMS "
        "over 100 trials of error / reported sigma and the share of trials whose truth lies within 3 sigma, per "
        "component of `X` and `Y`, with the robot's error estimated (the default) and left out."
    )
    return legend_and_save(fig, handles, (4, 0.2), out / "vision_errors.png", what, [repro, robot])
