"""The planning page (``docs/benchmarks/planning.md``): planned against random poses."""

from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt

from .common import RESULTS, Figure, legend_and_save, tables

#: The columns of ``plan_poses.md``'s table as the figure draws them: (column, colour, line style, marker).
PLAN_SERIES = (
    ("planned predicted", "tab:blue", "-", "o"),
    ("planned actual", "tab:cyan", ":", "s"),
    ("random predicted", "tab:red", "-", "o"),
    ("random actual", "tab:orange", ":", "s"),
)


def plan_poses_cells(src: Path) -> dict[str, dict[int, tuple[float, float, float]]]:
    """The table of ``plan_poses.md``: per column (``"planned predicted"``, ...), per number of poses, the RMS
    over the cells of X's rotation (deg), translation (mm) and workspace error (mm)."""
    (_, header, rows), *_ = [t for t in tables(src) if t[1][0] == "poses"]
    out: dict[str, dict[int, tuple[float, float, float]]] = {}
    for r in rows:
        for name, cell in zip(header[1:], r[1:]):
            values = tuple(float(v) for v in cell.split("/"))
            if len(values) != 3:
                raise ValueError(f"{src}: {cell!r} is not 'rotation / translation / workspace'")
            out.setdefault(name, {})[int(r[0])] = values
    return out


def plan_poses(out: Path) -> Figure:
    """X's error against the number of poses, planned against random, predicted and actual, per component; dashed,
    the random poses' 15-pose value (the target: planned poses reach it with at most 8)."""
    src = RESULTS / "plan_poses.md"
    cells = plan_poses_cells(src)
    fig, axes = plt.subplots(1, 3, figsize=(13, 4.2), dpi=100)
    panels = (("rotation", "deg"), ("translation", "mm"), ("workspace error", "mm"))
    for j, (ax, (what, unit)) in enumerate(zip(axes, panels)):
        for name, colour, ls, mark in PLAN_SERIES:
            n = sorted(cells[name])
            ax.plot(n, [cells[name][k][j] for k in n], ls, marker=mark, color=colour, ms=5, mfc="none", label=name)
            if name.startswith("random"):
                ax.axhline(cells[name][15][j], color=colour, ls="--", lw=1, label=f"{name}, 15 poses")
        ax.set_xticks(n)
        ax.set_xlabel("number of poses")
        ax.set_ylabel(f"RMS error of X over the cells [{unit}]")
        ax.set_title(f"{what} [{unit}]", fontsize=10)
        ax.set_ylim(bottom=0)
        ax.grid(True, alpha=0.3)
    lines = axes[0].get_lines()
    handles = [ln for ln in lines if ln.get_linestyle() != "--"] + [ln for ln in lines if ln.get_linestyle() == "--"]
    what = (
        "Planned against random poses, simulated: the RMS over 100 UR5 eye-to-hand cells of the error of "
        "`X = T_base_cam` against the number of poses, in rotation, translation and at the workspace, as the "
        "planner predicts it (its sigma, solid) and as `calibrate()` made it (actual, dotted); dashed, the random "
        "poses' 15-pose value, which the planned poses reach with at most 8 (the target)."
    )
    return legend_and_save(fig, handles, (6, 0.09), out / "plan_poses.png", what, [src])
