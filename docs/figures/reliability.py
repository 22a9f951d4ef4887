"""The reliability page (``docs/benchmarks/reliability.md``): every command's fault runs by outcome."""

from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

from .common import RESULTS, Figure, legend_and_save, tables

#: The outcome columns of ``reliability.md``'s first table, stacked in this order: (column, colour). The first two
#: are right; the others are failures, in warm (warning) colours.
OUTCOMES = (
    ("clear", "tab:blue"),
    ("ok", "lightsteelblue"),
    ("unclear", "gold"),
    ("silent", "tab:red"),
    ("destroyed/lost", "darkred"),
    ("traceback", "tab:orange"),
    ("timeout/other", "orchid"),
)
#: The outcomes that are failures.
FAILURES = tuple(name for name, _ in OUTCOMES[2:])


def fault_rows(src: Path) -> tuple[list[dict], dict]:
    """``reliability.md``'s first table (the fault runs per command): per command row (the file's order) its
    ``command``, ``tried``, each outcome of :data:`OUTCOMES` (counts) and ``targets met`` (``"9 of 9"``); and
    its ``**all**`` row alike. A row whose outcomes do not add up to its runs tried is refused."""
    (_, header, rows), *_ = [t for t in tables(src) if t[1][0] == "command" and "silent" in t[1]]
    out = []
    for r in rows:
        row = {"command": r[0], "tried": int(r[header.index("tried")]), "targets met": r[header.index("targets met")]}
        row |= {name: int(r[header.index(name)]) for name, _ in OUTCOMES}
        if sum(row[name] for name, _ in OUTCOMES) != row["tried"]:
            raise ValueError(f"{src}: {r[0]}'s outcomes do not add up to its {row['tried']} runs")
        out.append(row)
    (total,) = [r for r in out if r["command"] == "**all**"]
    return [r for r in out if r is not total], total


def reliability_outcomes(out: Path) -> Figure:
    """Per command, its fault runs stacked by outcome: clear and ok, then the failures in warning colours."""
    src = RESULTS / "reliability.md"
    rows, total = fault_rows(src)
    fig, ax = plt.subplots(figsize=(10, 6.4), dpi=100)
    y = np.arange(len(rows))
    left = np.zeros(len(rows))
    for name, colour in OUTCOMES:
        counts = np.array([r[name] for r in rows], dtype=float)
        ax.barh(y, counts, left=left, height=0.7, color=colour, label=f"{name}: {total[name]} in all")
        left += counts
    for k, r in enumerate(rows):
        ax.text(r["tried"] + 0.6, k, f"{r['targets met']} met their targets", va="center", fontsize=7, color="0.3")
    failed = sum(total[name] for name in FAILURES)
    ax.set_yticks(y, [r["command"] for r in rows], fontsize=8)
    ax.set_ylim(len(rows) - 0.5, -0.5)
    ax.set_xlim(0, max(r["tried"] for r in rows) * 1.35)
    ax.set_xlabel("fault runs [1]")
    ax.set_title(
        f"{total['tried']} fault runs: {total['clear']} clear, {total['ok']} ok, {failed} failed "
        f"({', '.join(f'{total[n]} {n}' for n in FAILURES)})",
        fontsize=10,
    )
    ax.grid(True, axis="x", alpha=0.3)
    handles = ax.get_legend_handles_labels()[0]
    what = (
        "Every command on generated faults (a target that is a symlink, FIFO or device, a full disk, a kill, "
        "numbers and units that are not what they seem, damaged files): per command, its runs by outcome, "
        f"stacked: clear (refused in one line naming the file), ok (accepted where that is right) and, in warm "
        f"colours, the failures: unclear, silent, destroyed or lost, traceback, timeout or other. {failed} of the "
        f"{total['tried']} runs failed ({total['clear']} clear, {total['ok']} ok, as the table's all row sums them)."
    )
    return legend_and_save(fig, handles, (4, 0.08), out / "reliability_outcomes.png", what, [src])
