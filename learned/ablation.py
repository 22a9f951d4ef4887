"""Parameter sweeps of the protocol: the reservoir's c1 / c2 / c3 grid (the paper's Table 2 and Figs. 10-11) and
selection's threshold pairs (its Tables 7-8).

Each setting is one :func:`learned.experiment.run_experiment` in its own folder under the sweep's folder, so
a sweep killed part-way resumes where it stopped (finished settings are read back, the unfinished one resumes
from its checkpoint). The sweep's ``sweep.json`` lists the settings; :func:`ablation_report` and
:func:`threshold_report` read the runs back and write the tables and figures.

Every error is the paper's metric, the RMSE over a subset's test frames, mean over repeats.
"""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import numpy as np

from handeye.core.errors import HandEyeInputError
from handeye.core.smoke import smoke_test
from handeye.core.tables import markdown_table
from learned.paper_tables import PAPER_TEXT, rmse, setting
from learned.results import NETS, UNIT, load_results

__all__ = [
    "DEFAULT_GRID",
    "DEFAULT_THRESHOLDS",
    "parse_grid",
    "parse_thresholds",
    "run_ablation",
    "run_thresholds",
    "ablation_report",
    "threshold_report",
]

#: c1 (samples per past pose), c2 (past poses, None: all), c3 (share of the current data): 2 x 2 x 2 around the
#: paper's best (4, 14, 100 %); its text names c3 = 50 % and a smaller buffer as the settings that cost accuracy.
DEFAULT_GRID = [(c1, c2, c3) for c1 in (4, 2) for c2 in (14, 7) for c3 in (1.0, 0.5)]
#: The paper's two threshold pairs (mm, deg).
DEFAULT_THRESHOLDS = [(3.0, 4.0), (6.0, 8.0)]


def parse_grid(text: str) -> list[tuple]:
    """``"4,14,1.0 2,all,0.5"`` -> ``[(4, 14, 1.0), (2, None, 0.5)]``; refuses what is not c1,c2,c3."""
    grid = []
    for item in text.split():
        parts = item.split(",")
        try:
            c1, c2, c3 = int(parts[0]), (None if parts[1] == "all" else int(parts[1])), float(parts[2])
        except (ValueError, IndexError):
            raise HandEyeInputError(f"grid setting {item!r}: write c1,c2,c3 (e.g. 4,14,1.0 or 4,all,0.5)") from None
        if len(parts) != 3 or c1 < 1 or (c2 is not None and c2 < 1) or not 0 < c3 <= 1:
            raise HandEyeInputError(f"grid setting {item!r}: c1 >= 1, c2 >= 1 or all, 0 < c3 <= 1")
        grid.append((c1, c2, c3))
    if not grid:
        raise HandEyeInputError("the grid is empty")
    return grid


def parse_thresholds(text: str) -> list[tuple]:
    """``"3,4 6,8"`` -> ``[(3.0, 4.0), (6.0, 8.0)]`` (mm, deg); each positive."""
    pairs = []
    for item in text.split():
        try:
            mm, deg = (float(v) for v in item.split(","))
        except ValueError:
            raise HandEyeInputError(f"threshold pair {item!r}: write mm,deg (e.g. 3,4)") from None
        if not (mm > 0 and deg > 0):
            raise HandEyeInputError(f"threshold pair {item!r}: both must be positive")
        pairs.append((mm, deg))
    if not pairs:
        raise HandEyeInputError("no threshold pairs")
    return pairs


def _name(c1, c2, c3) -> str:
    return f"c1_{c1}_c2_{'all' if c2 is None else c2}_c3_{c3:g}"


def _label(c1, c2, c3) -> str:
    return f"c1={c1}, c2={'all' if c2 is None else c2}, c3={c3 * 100:g}%"


def _sweep(frames, preset, settings: list, out: Path, strategies, progress=True, threads=None, **run) -> list[dict]:
    from learned.experiment import ExperimentOptions, run_experiment

    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    options = ExperimentOptions(**run)
    for name, _, changes in settings:
        if not (out / name / "results.json").exists():  # a finished setting is read back, not trained again
            run_experiment(
                frames,
                replace(preset, **changes),
                strategies,
                out / name,
                progress=progress,
                threads=threads,
                options=options,
            )
    done = [{"name": name, "label": label, **changes} for name, label, changes in settings]
    (out / "sweep.json").write_text(json.dumps({"settings": done}, indent=1))
    return done


def run_ablation(frames, preset, out, grid=DEFAULT_GRID, **run) -> list[dict]:
    """The reservoir at every ``(c1, c2, c3)`` of ``grid``, one run folder each under ``out``.

    ``frames``: a loaded :class:`learned.data.FrameSet`; ``run``: ``run_experiment``'s ``progress`` and
    ``threads``, and the fields of its :class:`learned.experiment.ExperimentOptions` (seed, family, labels, resume).
    """
    if smoke_test() and len(grid) > 2:  # a smoke run: the grid's first and last settings (the same sweep and report)
        grid = [grid[0], grid[-1]]
    settings = [(_name(*g), _label(*g), {"c1": g[0], "c2": g[1], "c3": g[2]}) for g in grid]
    return _sweep(frames, preset, settings, out, ("reservoir",), **run)


def run_thresholds(frames, preset, out, pairs=DEFAULT_THRESHOLDS, **run) -> list[dict]:
    """Selection at each ``(mm, deg)`` threshold pair, one run folder each under ``out``."""
    settings = [
        (f"threshold_{mm:g}mm_{deg:g}deg", f"{mm:g} mm / {deg:g} deg", {"threshold_mm": mm, "threshold_deg": deg})
        for mm, deg in pairs
    ]
    return _sweep(frames, preset, settings, out, ("selection",), **run)


def _load(out: Path) -> list[tuple[dict, dict]]:
    path = Path(out) / "sweep.json"
    if not path.exists():
        raise HandEyeInputError(f"{path}: missing; run the sweep first")
    settings = json.loads(path.read_text())["settings"]
    return [(s, load_results(Path(out) / s["name"])) for s in settings]


def ablation_report(out, figures: bool = True) -> str:
    """``report.md`` (and ``ablation.png``) of a c1 / c2 / c3 sweep: per setting, the average RMSE over the test
    subsets after each time step (the paper's Figs. 10-11) and at the last; returns the markdown."""
    out = Path(out)
    runs = _load(out)
    md = [
        "# Reservoir: the c1 / c2 / c3 ablation (the paper's Table 2, Figs. 10-11)",
        "",
        "Average RMSE over the test subsets after each time step, mean over repeats. The paper: no significant "
        "difference in translation; in orientation c1 = 4, c2 = 14, c3 = 100 % best, a smaller c3 or buffer "
        "worse (its cells are not given in the text).",
        "",
    ]
    curves = {}
    for net in NETS:
        rows = []
        for s, res in runs:
            avg = np.nanmean(rmse(res, "reservoir", net), axis=1)
            curves.setdefault(net, []).append((s["label"], avg))
            rows.append([s["label"], *[f"{v:.2f}" for v in avg]])
        steps = [f"T{k + 1}" for k in range(len(curves[net][0][1]))]
        best = min(curves[net], key=lambda c: c[1][-1])
        md += [f"## {net} ({UNIT[net]})", ""] + markdown_table(["setting", *steps], rows) + [""]
        md += [f"Best at the last step: {best[0]} ({best[1][-1]:.2f} {UNIT[net]}).", ""]
    text = "\n".join(md)
    (out / "report.md").write_text(text)
    if figures:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        fig, axes = plt.subplots(1, 2, figsize=(10, 3.8))
        for ax, net in zip(axes, NETS):
            for label, avg in curves[net]:
                ax.plot(np.arange(1, len(avg) + 1), avg, "o-", label=label)
            ax.set_xlabel("time step")
            ax.set_ylabel(f"average RMSE over the test subsets ({UNIT[net]})")
            ax.set_yscale("log")
            ax.set_title(net)
            ax.grid(alpha=0.3)
        axes[1].legend(fontsize=7)
        fig.tight_layout()
        fig.savefig(out / "ablation.png", dpi=110)
        plt.close(fig)
    return text


def threshold_report(out) -> str:
    """``report.md`` of a threshold sweep: selection's final step per subset at each pair and the camera poses
    it eliminated, the paper's counts beside (its Tables 7-8); returns the markdown."""
    out = Path(out)
    runs = _load(out)
    where = setting(runs[0][1])
    given = PAPER_TEXT.get(where, {}).get("eliminated", {})
    subsets = [f"S{r + 1}" for r in runs[0][1]["regions"]]
    poses = sum(len(s) for s in runs[0][1]["steps"][1:])
    md = [
        "# Selection at the paper's threshold pairs (its Tables 7-8)",
        "",
        f"Final-step RMSE per test subset (mean over repeats) and camera poses eliminated of {poses}; the paper's "
        "counts where its text gives them (its cells are not).",
        "",
    ]
    for net in NETS:
        key = "threshold_mm" if net == "translation" else "threshold_deg"
        rows = []
        for s, res in runs:
            final = rmse(res, "selection", net)[-1]
            runs_net = [r for r in res["runs"] if r["network"] == net]
            skipped = np.mean([len(r["skipped"]) for r in runs_net])
            thr = float(s[key])
            paper = f"{given[net][thr]} of {PAPER_TEXT[where]['poses']}" if thr in given.get(net, {}) else "-"
            rows.append([f"{thr:g} {UNIT[net]}", *[f"{v:.2f}" for v in final], f"{np.nanmean(final):.2f}",
                         f"{skipped:.1f}", paper])  # fmt: skip
        table = 7 if net == "translation" else 8
        name = f"Table {table}: " if where == "sim" else ""  # the real rig ran one pair only
        md += [f"## {name}{net} ({UNIT[net]})", ""]
        md += markdown_table(["threshold", *subsets, "mean", "eliminated", "paper: eliminated"], rows) + [""]
    text = "\n".join(md)
    (out / "report.md").write_text(text)
    return text
