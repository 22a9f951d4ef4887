"""The markerless page's real cell (``docs/benchmarks/markerless.md``, 'A real cell's errors'): the errors per
row, read from ``markerless_errors.md`` and checked against ``markerless_resolution.md``'s placements."""

from __future__ import annotations

import re
from pathlib import Path

import matplotlib.patches
import matplotlib.pyplot as plt
import numpy as np

from . import common
from .common import RESULTS, Figure, caption, command_of_section, legend_below, pair, sections, tables


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
            "median": pair(r[2])[0],
            "worst": pair(r[3])[0],
            "beyond": int(r[4]),
            "sigma": float("nan"),
        }
        for r in runs[0]
    ]


def _pool_of(command: str) -> str | None:
    """Which pool a ``markerless_errors.md`` run at the front's default from four placements
    (``--shared-intrinsics --pixel-effect-px 2``, a unit per placement) measured: ``"five"``, the tables' five
    test placements; ``"whole"``, every placement of the dataset (``--pool-train``, or more test placements than
    five: ``--max-placements 24``, all of ``paper-sim``'s); None for any other run (one unit, another option,
    another draw of the sensors than the default's, ``--seed`` other than 0 alone)."""
    if "--shared-intrinsics --pixel-effect-px 2" not in command or "--one-unit" in command:
        return None
    seeds = re.search(r"--seed((?:\s+\d+)+)", command)
    if seeds and seeds[1].split() != ["0"]:
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
                    out[name] = {"median": pair(r[2])[0], "worst": pair(r[3])[0], "beyond": int(r[4])}
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
    legend_below(fig, handles, [h.get_label() for h in handles], ncol=4, height=0.09)
    commands = "; ".join(c for c, _ in sections(src) if c and not re.search(r"--(cases|option|pixel-effect-px)", c))
    return common.save(
        fig,
        out / "markerless_errors.png",
        caption(
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
