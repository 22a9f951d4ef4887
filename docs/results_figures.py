"""The benchmark pages' figures, drawn from the shipped results files (``benchmarks/results/*.md``) alone.

Each function reads its results file's tables (:func:`tables`), draws one PNG and returns a :class:`Figure`
whose caption names the file and the command that made it. Nothing here runs a benchmark: a figure shows only
what its file holds. ``python docs/make_figures.py --results`` draws them all (a few seconds; matplotlib only).
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

import matplotlib
import matplotlib.ticker

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "benchmarks" / "results"
DRAWN_BY = "python docs/make_figures.py --results"
SENSORS = ("ideal", "d435", "d455", "l515", "azure-kinect", "zivid", "d435-sgbm")


@dataclass
class Figure:
    """A figure drawn: its file and its caption (the results file and the command that made it)."""

    path: Path
    caption: str


def tables(path: Path) -> list[tuple[str, list[str], list[list[str]]]]:
    """Every Markdown table of a results file: ``(heading above it, header cells, rows of cells)``."""
    out, heading, lines = [], "", path.read_text(encoding="utf-8").splitlines()
    k = 0
    while k < len(lines):
        line = lines[k]
        if line.startswith("#"):
            heading = line.lstrip("#").strip()
        if line.startswith("|") and k + 1 < len(lines) and lines[k + 1].startswith("|---"):
            header = _cells(line)
            rows, k = [], k + 2
            while k < len(lines) and lines[k].startswith("|"):
                rows.append(_cells(lines[k]))
                k += 1
            out.append((heading, header, rows))
            continue
        k += 1
    return out


def _cells(line: str) -> list[str]:
    return [c.strip() for c in line.strip().strip("|").split("|")]


def _pair(cell: str) -> tuple[float, float]:
    """``"0.1223 / 1.715"`` -> (0.1223, 1.715); ``"-"`` -> (nan, nan)."""
    parts = cell.split("/")
    if len(parts) != 2 or "-" == cell.strip():
        return float("nan"), float("nan")
    return float(parts[0]), float(parts[1])


def command_of(path: Path) -> str:
    """The ``command:`` line a results file starts with."""
    for line in path.read_text(encoding="utf-8").splitlines()[:4]:
        if line.startswith("command:"):
            return line.split(":", 1)[1].strip()
    raise ValueError(f"{path}: no 'command:' line in its first four lines")


def _caption(what: str, files: list[tuple[Path, str]]) -> str:
    made = "; ".join(f"`{p.relative_to(ROOT)}`, made by `{cmd}`" for p, cmd in files)
    return f"{what} From {made}; drawn by `{DRAWN_BY}`."


def classic_bound(out: Path) -> Figure:
    """RMS error of X against the number of poses beside the Cramér–Rao bound, per noise model."""
    src = RESULTS / "classic_ml.md"
    (_, _, rows), *_ = [t for t in tables(src) if t[0].startswith("Efficiency")]
    models: dict[str, dict] = {}
    for r in rows:
        model, n = r[0].rsplit(" ", 1)
        bound, ml, default = _pair(r[1]), _pair(r[2]), _pair(r[3])
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
    handles, labels = axes[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=4, fontsize=8)
    fig.tight_layout(rect=(0, 0.12, 1, 1))
    return _save(
        fig,
        out / "classic_bound.png",
        _caption(
            "RMS error of `T_base_cam` of `calibrate`'s default (robust in the outlier cells) against the number "
            "of poses, over 500 trials per cell (the file's RMS / bound ratio times the bound), beside the Cramér–Rao "
            "bound of each noise model.",
            [(src, command_of(src))],
        ),
        laid_out=True,
    )


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
            med, z = _pair(r[2])[0], _pair(r[4])[0]
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
    return _save(
        fig,
        out / "markerless_distance.png",
        _caption(
            "Markerless calibration per depth sensor profile against the camera's distance (median over the test "
            "placements); right, the RMS over the placements of error / predicted sigma: 1 when the sigma is right, "
            "the grey band up to 3 sigma. Depth taken as exact (crosses) leaves it.",
            [(src, command_of(src))],
        ),
    )


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
    return _save(
        fig,
        out / "learned_steps.png",
        _caption(
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
    return _save(
        fig,
        out / "markerless_basin.png",
        _caption(
            "Markerless basin of convergence: the share of trials that succeed, refuse or answer wrong against how "
            "far the start is off (translation and rotation together: the results hold these four cells, not a "
            "two-dimensional map).",
            [(src, command_of(src)) for src in sources],
        ),
    )


def _save(fig, path: Path, caption: str, *, laid_out: bool = False) -> Figure:
    if not laid_out:
        fig.tight_layout()
    from handeye.core.safe_write import write_figure_atomic

    write_figure_atomic(fig, path, metadata={"Software": None})  # whole or not at all; a FIFO or device refused
    plt.close(fig)
    return Figure(path, caption)


#: Every figure drawn from the results files, in the order the pages show them.
RESULT_FIGURES = (classic_bound, markerless_distance, learned_steps, markerless_basin)


def draw_all(out: Path) -> list[Figure]:
    """Draw every figure of :data:`RESULT_FIGURES` into ``out``; return them with their captions."""
    out.mkdir(parents=True, exist_ok=True)
    return [draw(out) for draw in RESULT_FIGURES]
