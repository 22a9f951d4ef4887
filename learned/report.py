"""Reports of an experiment: the paper's tables (markdown and CSV) and figures (PNG) from ``results.json``.

- per strategy and network, the time-step x test-subset matrix of mean test error (tables 3-8);
- the final step against the batch baseline per test subset (tables 9-10, 19-20);
- data and compute (table 11): samples stored, samples processed, novelty samples evaluated, wall
  time, camera poses skipped;
- per test camera pose: learned against the classic label and the truth, and the label against
  the truth (translation mm, rotation degrees);
- figures: the error on each test subset over the time steps per strategy (like figures 12-13),
  and the final-step comparison with the baseline;
- the run in the paper's own layout and metric, its stated figures beside and its findings judged its way
  (:mod:`learned.paper_tables`), then this project's own checks (:func:`findings`), labelled as such.

The tables above the paper's layout lead with the preset's metric (``Preset.metric``: the mean, or the RMSE in
the paper's protocol mode).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from handeye.core.safe_write import write_figure_atomic, write_text_atomic
from handeye.core.tables import markdown_table, write_csv
from learned.paper_tables import paper_tables
from learned.results import NETS, UNIT, has_rmse, load_results, mean_matrix, metric_key, runs_of

__all__ = ["write_report", "findings"]


def _placement_matrix(results: dict, strategy: str, network: str) -> np.ndarray | None:
    """Mean over repeats of the keypoint model's step x subset placement matrix; None where it was not recorded."""
    m = [r.get("placement_matrix") for r in runs_of(results, strategy, network)]
    if not m or not all(m):
        return None
    return np.array(m, dtype=float).mean(axis=0)


def _cell(mean: float, std: float, repeats: int) -> str:
    if not np.isfinite(mean):
        return "-"
    return f"{mean:.2f} ± {std:.2f}" if repeats > 1 else f"{mean:.2f}"


def findings(results: dict) -> list[str]:
    """The paper's three findings, checked on these results, each with its numbers."""
    lines = []
    strategies = results["strategies"]
    for net in NETS:
        if "naive" in strategies:
            lines += _naive_forgets(results, net)
        if "reservoir" in strategies and "batch" in strategies:
            lines.append(_reservoir_near_batch(results, net))
        if "selection" in strategies and "reservoir" in strategies:
            lines.append(_selection_skips(results, net))
    return lines


def _verdict(ok) -> str:
    return "reproduced" if ok else "NOT reproduced"


def _naive_forgets(results: dict, net: str) -> list[str]:
    """Naive's error on S1 at least doubled by the last step; per placement too where recorded."""
    u = UNIT[net]
    m, _ = mean_matrix(results, "naive", net)
    lines = [
        f"{net}: naive forgets S1: {m[0, 0]:.2f} {u} after step 1, {m[-1, 0]:.2f} {u} at the last "
        f"step ({m[-1, 0] / m[0, 0]:.1f}x; finding needs >= 2x): {_verdict(m[-1, 0] >= 2 * m[0, 0])}"
    ]
    pm = _placement_matrix(results, "naive", net)
    if pm is not None:
        lines.append(
            f"{net}: naive forgets S1, per placement (median of its test placements' one pose): "
            f"{pm[0, 0]:.2f} {u} after step 1, {pm[-1, 0]:.2f} {u} at the last step "
            f"({pm[-1, 0] / pm[0, 0]:.1f}x; finding needs >= 2x): {_verdict(pm[-1, 0] >= 2 * pm[0, 0])}"
        )
    return lines


def _reservoir_near_batch(results: dict, net: str) -> str:
    """The reservoir's final error within 1.5x of the batch baseline's (mean over subsets)."""
    u = UNIT[net]
    r, _ = mean_matrix(results, "reservoir", net)
    b, _ = mean_matrix(results, "batch", net)
    ratio = np.nanmean(r[-1]) / np.nanmean(b[-1])
    return (
        f"{net}: reservoir ends at {np.nanmean(r[-1]):.2f} {u} mean over subsets, batch baseline "
        f"{np.nanmean(b[-1]):.2f} {u} ({ratio:.2f}x; finding needs <= 1.5x): {_verdict(ratio <= 1.5)}"
    )


def _selection_skips(results: dict, net: str) -> str:
    """Selection skips camera poses and processes fewer samples than the reservoir."""
    s = runs_of(results, "selection", net)
    r = runs_of(results, "reservoir", net)
    skipped = np.mean([len(x["skipped"]) for x in s])
    proc_s, proc_r = np.mean([x["processed"] for x in s]), np.mean([x["processed"] for x in r])
    es = np.nanmean(mean_matrix(results, "selection", net)[0][-1])
    er = np.nanmean(mean_matrix(results, "reservoir", net)[0][-1])
    preset = results.get("preset", {})
    how = (
        "the one pose from all its frames"
        if preset.get("selection_novelty") == "placement"
        else "its frames' mean error"
    )
    mm, deg = f"{preset.get('threshold_mm', 3.0):g} mm", f"{preset.get('threshold_deg', 4.0):g} deg"
    limit = f"{mm} or {deg}" if results.get("family") == "keypoints" else (mm if net == "translation" else deg)
    return (
        f"{net}: selection (novel: {how} above {limit}) skipped {skipped:.1f} camera poses, "
        f"processed {proc_s:.0f} samples against reservoir's {proc_r:.0f} ({proc_s / proc_r:.2f}x), "
        f"final error {es:.2f} against {er:.2f} {UNIT[net]}: {_verdict(skipped > 0 and proc_s < proc_r)} "
        "(skips and less data)"
    )


def write_report(run_dir: str | Path, figures: bool = True) -> str:
    """Write ``report.md``, ``*.csv`` and (with ``figures``) ``*.png`` into the run directory; return the markdown."""
    run = _Run.read(Path(run_dir))
    md = _title(run) + _step_matrices(run) + _placement_matrices(run) + _final_step(run)
    _final_step_rmse(run)
    md += paper_tables(run.results)
    md += _compute(run)
    md += _per_camera_summary(run) + _repeat_placements(run.results) + _per_camera_tables(run)
    md += _own_checks(run.results)
    text = "\n".join(md)
    write_text_atomic(run.dir / "report.md", text)
    if figures:
        _figures(run.results, run.dir)
    return text


# -- the sections of write_report(), in its order


@dataclass
class _Run:
    """What every section reads: the results, the run directory the tables go to, the test subsets' names,
    the number of repeats and the metric's key (``matrix`` or ``rmse_matrix``)."""

    results: dict
    dir: Path
    subsets: list
    repeats: int
    key: str

    @classmethod
    def read(cls, run_dir: Path) -> "_Run":
        results = load_results(run_dir)
        subsets = [f"S{r + 1}" for r in results["regions"]]
        return cls(results, run_dir, subsets, results["preset"]["repeats"], metric_key(results))

    def cells(self, mean: np.ndarray, std: np.ndarray, k: int) -> list[str]:
        """Row ``k``'s cells, one per subset: mean ± std over the repeats."""
        return [_cell(mean[k, j], std[k, j], self.repeats) for j in range(len(self.subsets))]


def _title(run: _Run) -> list[str]:
    """The heading and what the tables hold: the metric, the repeats, when batch trains."""
    results = run.results
    what = "Root-mean-square (the paper's metric)" if run.key == "rmse_matrix" else "Mean"
    batch_when = (
        "batch trains from scratch on all data seen at every step"
        if results["preset"].get("batch_every_step")
        else "batch trains from scratch on all training data at the last step"
    )
    return [
        f"# Learned continual calibration: preset {results['preset']['name']}, labels {results['labels']}, "
        f"model {results.get('family', 'regression')}",
        "",
        f"{what} test error per subset (mean ± std over {run.repeats} repeats where > 1); rows: time steps "
        f"(after training on region k); {batch_when}.",
        "",
    ]


def _step_matrices(run: _Run) -> list[str]:
    """Per network and strategy, the time-step x subset matrix (tables 3-8); each also to ``matrix_*.csv``."""
    md = []
    for net in NETS:
        for strategy in run.results["strategies"]:
            mean, std = mean_matrix(run.results, strategy, net, run.key)
            rows, md_rows = [], []
            for k in range(len(mean)):
                avg = np.nanmean(mean[k]) if np.isfinite(mean[k]).any() else float("nan")
                md_rows.append([f"T{k + 1}", *run.cells(mean, std, k), _cell(avg, 0.0, 1)])
                rows.append([k + 1, *mean[k], *std[k]])
            md += [f"## {strategy}, {net} ({UNIT[net]})", ""] + markdown_table(["step", *run.subsets, "mean"], md_rows)
            md.append("")
            write_csv(
                run.dir / f"matrix_{strategy}_{net}.csv",
                ["step", *[f"{s}_mean" for s in run.subsets], *[f"{s}_std" for s in run.subsets]],
                rows,
            )
    return md


def _placement_matrices(run: _Run) -> list[str]:
    """The keypoint model's per-placement matrices, per strategy (none for the regression networks)."""
    placement = {st: _placement_matrix(run.results, st, "translation") for st in run.results["strategies"]}
    placement = {st: pm for st, pm in placement.items() if pm is not None}
    if not placement:
        return []
    md = [
        "## Per placement, after each time step (keypoint model)",
        "",
        "Median over each subset's test placements of the one pose from all its frames against the label, mm "
        "(mean over repeats): the forgetting the per-frame tables above cannot show at this model's errors.",
        "",
    ]
    for st, pm in placement.items():
        rows = [[f"T{k + 1}", *[_cell(v, 0.0, 1) for v in pm[k]]] for k in range(len(pm))]
        md += [f"### {st}", ""] + markdown_table(["step", *run.subsets], rows) + [""]
    return md


def _final_step(run: _Run) -> list[str]:
    """The final step against the baseline per subset (tables 9-10); also ``final_step.csv``."""
    md = ["## Final step per test subset (tables 9-10)", ""]
    final_rows = []
    for net in NETS:
        md_rows = []
        for strategy in run.results["strategies"]:
            mean, std = mean_matrix(run.results, strategy, net, run.key)
            md_rows.append([strategy, *run.cells(mean, std, -1), f"{np.nanmean(mean[-1]):.2f}"])
            final_rows.append([net, strategy, *mean[-1], float(np.nanmean(mean[-1]))])
        md += [f"### {net} ({UNIT[net]})", ""] + markdown_table(["strategy", *run.subsets, "mean"], md_rows) + [""]
    write_csv(run.dir / "final_step.csv", ["network", "strategy", *run.subsets, "mean"], final_rows)
    return md


def _final_step_rmse(run: _Run) -> None:
    """``final_step_rmse.csv``: the final step's RMSE per subset and its mean less batch's (with RMSE and batch)."""
    results = run.results
    if not (has_rmse(results) and "batch" in results["strategies"]):
        return
    rmse_rows = []
    for net in NETS:
        base = np.nanmean(mean_matrix(results, "batch", net, "rmse_matrix")[0][-1])
        for strategy in results["strategies"]:
            rm = mean_matrix(results, strategy, net, "rmse_matrix")[0][-1]
            avg = float(np.nanmean(rm))
            rmse_rows.append([net, strategy, *rm, avg, avg - base])
    header = ["network", "strategy", *run.subsets, "mean", "minus_batch"]
    write_csv(run.dir / "final_step_rmse.csv", header, rmse_rows)


def _compute(run: _Run) -> list[str]:
    """Data and compute per strategy and network (table 11); also ``compute.csv``."""
    compute_rows, md_rows = [], []
    for strategy in run.results["strategies"]:
        for net in NETS:
            runs = runs_of(run.results, strategy, net)
            vals = [np.mean([r[k] for r in runs]) for k in ("stored", "processed", "evaluated", "wall_s")]
            skipped = np.mean([len(r["skipped"]) for r in runs])
            md_rows.append([strategy, net, *[f"{v:.0f}" for v in vals], f"{skipped:.1f}"])
            compute_rows.append([strategy, net, *vals, skipped])
    header = [
        "strategy",
        "network",
        "samples stored",
        "samples processed",
        "samples evaluated for novelty",
        "wall time s",
        "camera poses skipped",
    ]
    write_csv(
        run.dir / "compute.csv",
        ["strategy", "network", "stored", "processed", "evaluated", "wall_s", "skipped"],
        compute_rows,
    )
    return ["## Data and compute", ""] + markdown_table(header, md_rows) + [""]


def _per_camera_summary(run: _Run) -> list[str]:
    """Per strategy, its last networks on the test camera poses against the truth, and the inference times."""
    how = "the frame predictions of the pose averaged"
    if run.results.get("family", "regression") == "keypoints":
        from learned.keypoints import CONSENSUS_M

        how = (
            "the keypoints of all the pose's frames fitted at once (learned.keypoints.camera_pose: the model's "
            f"offsets removed, the keypoints within {CONSENSUS_M:g} m of a robust 3-D to 3-D fit, their pixels "
            "and depths weighed by its sigmas; robust 3-D to 3-D for a model saved without them)"
        )
    md_rows = []
    for strategy, pc in run.results["per_camera"].items():
        inf = run.results.get("inference", {}).get(strategy, {})
        t_mm, r_deg = np.asarray(pc["learned_vs_truth_mm"]), np.asarray(pc["learned_vs_truth_deg"])
        lab_mm, lab_deg = np.asarray(pc["label_vs_truth_mm"]), np.asarray(pc["label_vs_truth_deg"])
        md_rows.append(
            [
                strategy,
                f"{np.median(t_mm):.2f} / {np.median(r_deg):.2f}",
                f"{t_mm.max():.2f} / {r_deg.max():.2f}",
                f"{np.median(lab_mm):.3f} / {np.median(lab_deg):.4f}",
                f"{inf.get('per_frame_ms', float('nan')):.1f}",
                f"{inf.get('per_camera_ms', float('nan')):.0f}",
            ]
        )
    header = [
        "strategy",
        "median vs truth",
        "worst vs truth",
        "label median vs truth",
        "inference ms per frame",
        "ms per camera pose",
    ]
    md = ["## Per test camera pose: learned vs classic label vs truth", "", f"Learned: {how}. mm / deg.", ""]
    return md + markdown_table(header, md_rows) + [""]


def _per_camera_tables(run: _Run) -> list[str]:
    """Per strategy, every test camera pose: learned against label and truth, label against truth; also
    ``per_camera.csv``."""
    md, keys, csv_rows = [], None, []
    for strategy, pc in run.results["per_camera"].items():
        md_rows = []
        for i, c in enumerate(pc["camera"]):
            md_rows.append(
                [
                    c,
                    f"S{pc['region'][i] + 1}",
                    f"{pc['learned_vs_label_mm'][i]:.2f} / {pc['learned_vs_label_deg'][i]:.2f}",
                    f"{pc['learned_vs_truth_mm'][i]:.2f} / {pc['learned_vs_truth_deg'][i]:.2f}",
                    f"{pc['label_vs_truth_mm'][i]:.3f} / {pc['label_vs_truth_deg'][i]:.4f}",
                    f"{pc['per_frame_vs_label_mm'][i]:.2f} / {pc['per_frame_vs_label_deg'][i]:.2f}",
                ]
            )
            keys = keys or list(pc)
            csv_rows.append([strategy, *[pc[k][i] for k in keys]])
        header = ["camera", "subset", "learned vs label", "learned vs truth", "label vs truth", "per-frame vs label"]
        md += [f"### {strategy}", ""] + markdown_table(header, md_rows) + [""]
    write_csv(run.dir / "per_camera.csv", ["strategy", *(keys or [])], csv_rows)
    return md


def _own_checks(results: dict) -> list[str]:
    """This project's own checks (:func:`findings`), labelled as such."""
    return [
        "## This project's own checks",
        "",
        "Bars of this project, not the paper's (naive's error on S1 at least doubled, the reservoir within 1.5x of "
        "the baseline, selection skipping poses and processing less than the reservoir); the paper's own "
        "comparisons are in the section above.",
        "",
        *[f"- {line}" for line in findings(results)],
        "",
    ]


def _figures(results: dict, run_dir: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    regions = results["regions"]
    key = metric_key(results)
    for net in NETS:
        strategies = results["strategies"]
        fig, axes = plt.subplots(1, len(strategies), figsize=(3.6 * len(strategies), 3.2), sharey=True, squeeze=False)
        for ax, strategy in zip(axes[0], strategies):
            mean, _ = mean_matrix(results, strategy, net, key)
            for j, r in enumerate(regions):
                ax.plot(np.arange(1, len(mean) + 1), mean[:, j], "o-", label=f"S{r + 1}")
            ax.set_title(strategy)
            ax.set_xlabel("time step")
            ax.set_yscale("log")
            ax.grid(alpha=0.3)
        axes[0, 0].set_ylabel(f"{'RMS' if key == 'rmse_matrix' else 'mean'} test error ({UNIT[net]})")
        axes[0, -1].legend(fontsize=7)
        fig.suptitle(f"{net}: error on each test subset over the time steps")
        fig.tight_layout()
        write_figure_atomic(fig, run_dir / f"steps_{net}.png", dpi=110)
        plt.close(fig)
    fig, axes = plt.subplots(1, 2, figsize=(9, 3.4))
    for ax, net in zip(axes, NETS):
        width = 0.8 / len(results["strategies"])
        for i, strategy in enumerate(results["strategies"]):
            mean, std = mean_matrix(results, strategy, net, key)
            ax.bar(np.arange(len(regions)) + i * width, mean[-1], width, yerr=std[-1], label=strategy)
        ax.set_xticks(np.arange(len(regions)) + 0.4 - width / 2, [f"S{r + 1}" for r in regions])
        ax.set_ylabel(f"final-step error ({UNIT[net]})")
        ax.set_title(net)
    axes[1].legend(fontsize=7)
    fig.tight_layout()
    write_figure_atomic(fig, run_dir / "final_step.png", dpi=110)
    plt.close(fig)


def _repeat_placements(results: dict) -> list:
    """Markdown lines: every repeat's model on the test placements (keypoint model; empty otherwise)."""
    runs = [r for r in results["runs"] if r.get("placements") and r["network"] == "translation"]
    if not runs:
        return []
    repeats = sorted({r["repeat"] for r in runs})
    rows = []
    for strategy in dict.fromkeys(r["strategy"] for r in runs):
        mine = {r["repeat"]: r["placements"] for r in runs if r["strategy"] == strategy}
        cells = [
            f"{mine[k]['median_mm']:.1f} / {mine[k]['median_deg']:.2f} ({mine[k]['worst_mm']:.1f})"
            if k in mine
            else "-"
            for k in repeats
        ]
        medians = [p["median_mm"] for p in mine.values()]
        worst = [p["worst_mm"] for p in mine.values()]
        rows.append([strategy, *cells, f"{np.median(medians):.1f} ({np.median(worst):.1f})"])
    return (
        [
            "Every repeat's model: median mm / deg over the test placements (worst mm in brackets); one training "
            "run's median varies, and the table above shows the last repeat's model only.",
            "",
        ]
        + markdown_table(["strategy", *[f"repeat {k + 1}" for k in repeats], "median of repeats mm (worst)"], rows)
        + [""]
    )
