"""What every benchmark figure shares: the results files' tables read (:func:`tables`, :func:`sections`), the
:class:`Figure` drawn and its caption (:func:`caption`: the results file and the command that made it), the legend
under the panels and the PNG written whole (:func:`save`).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import matplotlib.pyplot as plt

ROOT = Path(__file__).resolve().parents[2]
RESULTS = ROOT / "benchmarks" / "results"
DRAWN_BY = "python docs/make_figures.py --results"


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


def pair(cell: str) -> tuple[float, float]:
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


def caption(what: str, files: list[tuple[Path, str]]) -> str:
    made = "; ".join(f"`{p.relative_to(ROOT)}`, made by `{cmd}`" for p, cmd in files)
    return f"{what} From {made}; drawn by `{DRAWN_BY}`."


def command_of_section(path: Path, heading: str) -> str:
    """The command of the first report in ``path`` with a table under a heading starting ``heading``."""
    for command, found in sections(path):
        if command and any(h.startswith(heading) for h, _, _ in found):
            return command
    raise ValueError(f"{path}: no report with a table under {heading!r}")


def legend_and_save(
    fig, handles: list, layout: tuple[int, float], path: Path, what: str, sources: list[Path]
) -> Figure:
    """The legend of ``handles`` under the panels (``layout``: its columns and height), then the figure saved with
    its caption: ``what`` it shows, and each results file of ``sources`` with the command its first lines name."""
    ncol, height = layout
    legend_below(fig, handles, [h.get_label() for h in handles], ncol=ncol, height=height)
    return save(fig, path, caption(what, [(src, command_of(src)) for src in sources]), laid_out=True)


def legend_below(fig, handles: list, labels: list[str], *, ncol: int, height: float) -> None:
    """One legend for the whole figure under its panels, which are laid out above ``height`` (figure fraction)."""
    fig.legend(handles, labels, loc="lower center", ncol=ncol, fontsize=8)
    fig.tight_layout(rect=(0, height, 1, 1))


def save(fig, path: Path, text: str, *, laid_out: bool = False) -> Figure:
    """``fig`` laid out (unless ``laid_out``) and written whole to ``path``, closed; the :class:`Figure` with
    its caption ``text``. The figure modules call it as ``common.save``: a test patches it in one place."""
    if not laid_out:
        fig.tight_layout()
    from handeye.core.safe_write import write_figure_atomic

    write_figure_atomic(fig, path, metadata={"Software": None})  # whole or not at all; a FIFO or device refused
    plt.close(fig)
    return Figure(path, text)
