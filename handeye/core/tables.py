"""The one table writer of the reports: markdown for reading, CSV for tools.

Every report (labels, the learned protocol's tables, ``compare``, ``markerless``, ``plan``) builds
its rows as lists of cells and hands them here, so a table is written one way everywhere.
"""

from __future__ import annotations

import csv
import io
from pathlib import Path

from handeye.core.safe_write import write_text_atomic

__all__ = ["markdown_table", "write_csv"]


def markdown_table(headers: list, rows: list) -> list[str]:
    """Lines of a markdown table: the header, the rule and one line per row.

    Parameters
    ----------
    headers : list of str
    rows : list of lists
        Cells, already formatted (``str(cell)`` is written); each row as long as ``headers``.

    Returns
    -------
    list of str

    Raises
    ------
    ValueError
        A row of the wrong length.
    """
    out = ["| " + " | ".join(str(h) for h in headers) + " |", "|" + "---|" * len(headers)]
    for k, row in enumerate(rows):
        if len(row) != len(headers):
            raise ValueError(f"row {k} has {len(row)} cells for {len(headers)} columns")
        out.append("| " + " | ".join(str(c) for c in row) + " |")
    return out


def write_csv(path: str | Path, headers: list, rows: list) -> Path:
    """Write a CSV table (``csv`` module, header line first).

    Parameters
    ----------
    path : str or Path
    headers : list of str
    rows : list of lists
        Values as they should appear (numbers are written with ``repr``-exact ``str``).

    Returns
    -------
    Path
    """
    path = Path(path)
    buffer = io.StringIO(newline="")  # built in memory, written whole (handeye.core.safe_write)
    w = csv.writer(buffer)
    w.writerow(headers)
    w.writerows(rows)
    write_text_atomic(path, buffer.getvalue())
    return path
