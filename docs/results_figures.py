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
import matplotlib.patches
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
    return _tables_in(path.read_text(encoding="utf-8").splitlines())


def sections(path: Path) -> list[tuple[str, list[tuple[str, list[str], list[list[str]]]]]]:
    """The reports a results file puts together, split at its ``---`` lines: ``(command, its tables)`` each.

    The command is the ``command:`` line of the report's first four lines, ``""`` where it has none (a reading
    written by hand).
    """
    out, chunk = [], []
    for line in path.read_text(encoding="utf-8").splitlines() + ["---"]:
        if line.strip() != "---":
            chunk.append(line)
            continue
        head = [c.split(":", 1)[1].strip() for c in chunk[:4] if c.startswith("command:")]
        out.append((head[0] if head else "", _tables_in(chunk)))
        chunk = []
    return out


def _tables_in(lines: list[str]) -> list[tuple[str, list[str], list[list[str]]]]:
    out, heading = [], ""
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


def run_of(path: Path) -> str:
    """``"<date> on <machine>"`` from a results file's ``date:`` and ``machine:`` lines (its first four)."""
    head = dict(line.split(": ", 1) for line in path.read_text(encoding="utf-8").splitlines()[:4] if ": " in line)
    return f"{head['date']} on {head['machine']}"


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
    _legend_below(fig, *axes[0].get_legend_handles_labels(), ncol=4, height=0.12)
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
    return _save(
        fig,
        out / "markerless_basin_map.png",
        _caption(
            "Markerless basin of convergence on the small preset, mapped: start translation against start rotation "
            "(about a random axis and direction). Colour and first line: the trials accepted within 3 predicted "
            "sigmas of the truth (the right basin); then those also within 1 mm / 0.1 deg, the refusals, and in red "
            f"the answers accepted beyond 3 sigma (a wrong basin). Run {run_of(src)}.",
            [(src, command_of(src))],
        ),
        laid_out=True,
    )


def _placements(cell: str) -> tuple[np.ndarray, np.ndarray]:
    """``"2.06 (1.82), 1.79 (2.24)"`` (translation error mm (sigma mm) per placement) -> (errors, sigmas)."""
    pairs = re.findall(r"([0-9.]+) \(([0-9.]+)\)", cell)
    if not pairs:
        raise ValueError(f"no 'error (sigma)' pairs in {cell!r}")
    return np.array(pairs, dtype=float).T


def _error_rows(src: Path, preset: str) -> list[dict]:
    """The rows of ``markerless_errors.md``'s run of ``preset`` at the front's defaults (all cases, no option)."""
    runs = [
        rows
        for command, found in sections(src)
        if command and not re.search(r"--(cases|option|pixel-effect-px|seed|shared-intrinsics)\b", command)
        for heading, header, rows in found
        if heading.startswith(f"{preset}-1.2:") and header[0] == "error the method is not told"
    ]
    if len(runs) != 1:
        raise ValueError(f"{src}: {len(runs)} runs of {preset} at the front's defaults, not one")
    return [
        {
            "row": r[0],
            "accepted": int(r[1].split("/")[0]),
            "placements": int(r[1].split("/")[1]),
            "median": _pair(r[2])[0],
            "worst": _pair(r[3])[0],
            "beyond": int(r[4]),
            "sigma": float("nan"),
        }
        for r in runs[0]
    ]


def _pool_of(command: str) -> str | None:
    """Which pool a ``markerless_errors.md`` run at the front's default from four placements
    (``--shared-intrinsics --pixel-effect-px 2``, a unit per placement) measured: ``"five"``, the tables' five
    test placements; ``"whole"``, every placement of the dataset (``--pool-train``, or more test placements than
    five: ``--max-placements 24``, all of ``paper-sim``'s); None for any other run (one unit, another option)."""
    if "--shared-intrinsics --pixel-effect-px 2" not in command or "--one-unit" in command:
        return None
    wider = re.search(r"--max-placements (\d+)", command)
    return "whole" if "--pool-train" in command or (wider and int(wider[1]) > 5) else "five"


def _pooled_rows(src: Path, preset: str, pool: str) -> tuple[dict[str, dict], str, list[str]]:
    """The front's default per row of ``markerless_errors.md`` from its runs of ``pool`` (:func:`_pool_of`): the
    rows ``, intrinsics shared``, by row name; the pool's size as the reports' heading says it (``"5 + 19"``:
    test placements and the further ones pooled); and the runs' commands."""
    out, size, commands = {}, "", []
    for command, found in sections(src):
        if _pool_of(command) != pool:
            continue
        commands.append(command)
        for heading, header, rows in found:
            m = re.match(rf"{preset}-1\.2(?:-with-train)?: (\d+) test placements(?:, (\d+) more in the pool)?", heading)
            if not m or header[0] != "error the method is not told":
                continue
            size = f"{m[1]} + {m[2]}" if m[2] else m[1]
            for r in rows:
                if r[0].endswith(", intrinsics shared"):
                    name = r[0].removesuffix(", intrinsics shared")
                    out[name] = {"median": _pair(r[2])[0], "worst": _pair(r[3])[0], "beyond": int(r[4])}
    return out, size, commands


def _sigma_rows(src: Path) -> dict[str, dict]:
    """Today's sigma per resolution and row: ``markerless_resolution.md``'s 'before -> after' table, seed 0.

    Keyed ``"256x256, none (d435 as is)"``; each the per-placement errors' median and worst, the per-placement
    sigmas' median and the beyond-3-sigma count after.
    """
    (_, _, rows), *_ = [t for t in tables(src) if t[1][:3] == ["resolution, row", "before", "after"]]
    out = {}
    for r in rows:
        if "seed 1" in r[0]:
            continue
        errors, sigmas = _placements(r[2])
        out[r[0].replace(", seed 0", "")] = {
            "median": float(np.median(errors)),
            "worst": float(errors.max()),
            "sigma": float(np.median(sigmas)),
            "beyond": int(r[3].split("->")[-1].strip(" *")),
            "placements": len(errors),
        }
    return out


def _errors_panels(src: Path, res: Path) -> tuple[list, list, dict, list, list]:
    """:func:`markerless_errors`'s three panels ``(title, rows)`` read from its two files, the rows' labels, the
    pools' sizes per preset, and the commands of the five-placement and whole-dataset pooled runs."""
    sig = _sigma_rows(src=res)
    panels, pools = [], {}
    for preset in ("paper-real", "paper-sim"):
        rows = _error_rows(src, preset)
        shared, _, shared_commands = _pooled_rows(src, preset, "five")
        whole, pools[preset], whole_commands = _pooled_rows(src, preset, "whole")
        for r in rows:
            r["shared"] = shared.get(r["row"])
            r["whole"] = whole.get(r["row"])
        if preset == "paper-real":
            for r in rows:
                key = next((k for k in sig if k.startswith("256x256, ") and r["row"].startswith(k[9:])), None)
                if key is None:
                    continue
                if (round(sig[key]["median"], 2), round(sig[key]["worst"], 2)) != (r["median"], r["worst"]):
                    raise ValueError(f"{res}: {key}'s placements do not give {src.name}'s {r['row']!r}")
                r["sigma"] = sig[key]["sigma"]
        panels.append((f"{preset}, 256x256 (f 222 px)", rows))
    labels = [r["row"] for r in panels[0][1]]
    (_, _, run1), *_ = [t for t in tables(res) if t[0].startswith("paper-real-1.2-848:")]
    accepted = {r[0]: r[1] for r in run1}
    wide = []
    for row in labels:
        key = next((k for k in sig if k.startswith("848x480, ") and row.startswith(k[9:])), None)
        if key is None:
            wide.append(None)
            continue
        acc, n = (int(v) for v in accepted[row].split("/"))
        wide.append({"row": row, "accepted": acc, **sig[key], "placements": n})
    panels.append(("paper-real, 848x480 (f 447 px)", wide))
    return panels, labels, pools, shared_commands, whole_commands


def markerless_errors(out: Path) -> Figure:
    """A real cell's errors, one row each: median and worst error, the median sigma and its 3-sigma band."""
    src, res = RESULTS / "markerless_errors.md", RESULTS / "markerless_resolution.md"
    panels, labels, pools, shared_commands, whole_commands = _errors_panels(src, res)
    fig, axes = plt.subplots(1, 3, figsize=(14, 5.2), dpi=100, sharey=True, sharex=True)
    y = np.arange(len(labels))
    for ax, (title, rows) in zip(axes, panels):
        for k, r in enumerate(rows):
            if r is None:
                ax.text(4, k, "not run at this size", va="center", fontsize=7, color="0.5")
                continue
            if np.isfinite(r["sigma"]):
                ax.barh(k, 3 * r["sigma"], height=0.6, color="tab:green", alpha=0.18, zorder=0)
                ax.plot([r["sigma"]] * 2, [k - 0.3, k + 0.3], "-", color="tab:green", lw=2)
            ax.plot([r["median"], r["worst"]], [k, k], "-", color="0.6", lw=1, zorder=1)
            ax.plot(r["median"], k, "o", color="tab:blue", zorder=2)
            ax.plot(r["worst"], k, "s", mfc="none", color="tab:red", zorder=2)
            if r.get("shared"):
                ax.plot([r["shared"]["median"], r["shared"]["worst"]], [k + 0.25] * 2, "-", color="tab:purple", lw=1)
                ax.plot(r["shared"]["median"], k + 0.25, "D", color="tab:purple", ms=4, zorder=2)
            if r.get("whole"):
                ax.plot([r["whole"]["median"], r["whole"]["worst"]], [k - 0.25] * 2, "-", color="tab:orange", lw=1)
                ax.plot(r["whole"]["median"], k - 0.25, "v", color="tab:orange", ms=5, zorder=2)
            refused = r["placements"] - r["accepted"]
            ax.text(
                23.7,
                k,
                f"{refused} refused, {r['beyond']} > 3σ",
                va="center",
                ha="right",
                fontsize=7,
                color="tab:red" if refused or r["beyond"] else "0.3",
            )
        ax.axvline(1, color="tab:blue", ls="--", lw=1)
        ax.axvline(3, color="tab:red", ls=":", lw=1)
        ax.set_title(title, fontsize=10)
        ax.set_xlabel("translation error against the truth [mm]")
        ax.set_xlim(0, 24)
        ax.grid(True, axis="x", alpha=0.3)
    axes[0].set_yticks(y, labels, fontsize=8)
    axes[0].set_ylim(len(labels) - 0.5, -0.5)
    handles = [
        plt.Line2D([], [], marker="o", ls="", color="tab:blue", label="median over the placements"),
        plt.Line2D([], [], marker="s", ls="", mfc="none", color="tab:red", label="worst"),
        plt.Line2D(
            [], [], marker="D", ms=4, color="tab:purple", label="intrinsics shared, 2 px cells: median to worst"
        ),
        plt.Line2D(
            [], [], marker="v", ms=5, color="tab:orange", label="the same, every placement pooled: median to worst"
        ),
        plt.Line2D([], [], color="tab:green", lw=2, label="median sigma (where the file records it)"),
        matplotlib.patches.Patch(color="tab:green", alpha=0.18, label="0 to 3 sigma (> 3σ: accepted beyond it)"),
        plt.Line2D([], [], color="tab:blue", ls="--", label="target: median 1 mm"),
        plt.Line2D([], [], color="tab:red", ls=":", label="target: worst 3 mm"),
    ]
    _legend_below(fig, handles, [h.get_label() for h in handles], ncol=4, height=0.09)
    commands = "; ".join(c for c, _ in sections(src) if c and not re.search(r"--(cases|option|pixel-effect-px)", c))
    return _save(
        fig,
        out / "markerless_errors.png",
        _caption(
            "A real cell's errors, simulated: the `d435` profile (all together: `d435-real-cell`) at 1.2 m, "
            "256x256 (right: `paper-real` at 848x480, the sensors' first draw), five test placements per row, the "
            "front's defaults for a placement alone; in purple the front's default from four placements (each "
            "registered again with the others' intrinsics as its prior, a depth error per 2 px cell marginalised), "
            "in orange the same with every placement of the dataset in the pool, as `handeye markerless` pools a "
            f"dataset's placements (`paper-real`: {pools['paper-real']} placements, the train ones' first pass "
            f"pooled only; `paper-sim`: all {pools['paper-sim']} test placements); "
            "the sigma, recorded for three rows only, is the median of the per-placement sigmas "
            "in the resolution file's table of the repeated-error term (after: today's default).",
            [
                (src, commands),
                (src, "; ".join(shared_commands)),
                (src, "; ".join(whole_commands)),
                (res, command_of_section(res, "paper-real-1.2-848:")),
            ],
        ),
        laid_out=True,
    )


def command_of_section(path: Path, heading: str) -> str:
    """The command of the first report in ``path`` with a table under a heading starting ``heading``."""
    for command, found in sections(path):
        if command and any(h.startswith(heading) for h, _, _ in found):
            return command
    raise ValueError(f"{path}: no report with a table under {heading!r}")


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
                    med, worst = _pair(r[2])[0], _pair(r[3])[0]
                    if np.isfinite(med):
                        ax.plot([med, worst], [k + dy] * 2, "-", color=colour, lw=1, alpha=0.5)
                        ax.plot(med, k + dy, mark, color=colour)
                        ax.plot(worst, k + dy, "|", color=colour, ms=9, mew=2)
                        z, wrong = _pair(r[4])[0], int(r[5])
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
    _legend_below(fig, handles, [h.get_label() for h in handles], ncol=5, height=0.05)
    return _save(
        fig,
        out / "markerless_sensors.png",
        _caption(
            "The six tables below as one figure, simulated: per dataset and camera distance, each depth sensor "
            "profile's median (dot, cross) and worst (bar) translation error over the test placements, 256x256; "
            "beside it accepted of all, z (the RMS of error over predicted sigma, 1 when the sigma is right) and "
            "the answers accepted beyond 3 sigma (wrong).",
            [(src, command_of(src))],
        ),
        laid_out=True,
    )


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
                        "holdout": _pair(r[hold]),
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
    return _legend_and_save(fig, handles, (5, 0.13), out / "real_recordings.png", what, sources)


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
            cells = [(float(r[0]), _pair(r[j])[1]) for r in rows if r[1].split()[0] == views]
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
    return _legend_and_save(fig, handles, (4, 0.2), out / "vision_errors.png", what, [repro, robot])


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
    return _legend_and_save(fig, handles, (6, 0.09), out / "plan_poses.png", what, [src])


def _legend_and_save(
    fig, handles: list, layout: tuple[int, float], path: Path, what: str, sources: list[Path]
) -> Figure:
    """The legend of ``handles`` under the panels (``layout``: its columns and height), then the figure saved with
    its caption: ``what`` it shows, and each results file of ``sources`` with the command its first lines name."""
    ncol, height = layout
    _legend_below(fig, handles, [h.get_label() for h in handles], ncol=ncol, height=height)
    return _save(fig, path, _caption(what, [(src, command_of(src)) for src in sources]), laid_out=True)


def _legend_below(fig, handles: list, labels: list[str], *, ncol: int, height: float) -> None:
    """One legend for the whole figure under its panels, which are laid out above ``height`` (figure fraction)."""
    fig.legend(handles, labels, loc="lower center", ncol=ncol, fontsize=8)
    fig.tight_layout(rect=(0, height, 1, 1))


def _save(fig, path: Path, caption: str, *, laid_out: bool = False) -> Figure:
    if not laid_out:
        fig.tight_layout()
    from handeye.core.safe_write import write_figure_atomic

    write_figure_atomic(fig, path, metadata={"Software": None})  # whole or not at all; a FIFO or device refused
    plt.close(fig)
    return Figure(path, caption)


#: Every figure drawn from the results files, in the order the pages show them.
RESULT_FIGURES = (
    classic_bound,
    markerless_distance,
    markerless_sensors,
    learned_steps,
    markerless_basin,
    markerless_basin_map,
    markerless_errors,
    real_recordings_figure,
    vision_errors,
    plan_poses,
)


def draw_all(out: Path) -> list[Figure]:
    """Draw every figure of :data:`RESULT_FIGURES` into ``out``; return them with their captions."""
    out.mkdir(parents=True, exist_ok=True)
    return [draw(out) for draw in RESULT_FIGURES]
