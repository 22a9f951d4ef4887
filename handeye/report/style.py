"""One look for the report: the palette shared by the figures and the page, and the figure helpers."""

from __future__ import annotations

from pathlib import Path

from handeye.core.optional import require_package

__all__ = ["COLORS", "AXIS_COLORS", "pyplot", "save_figure"]

#: Colours of the report, used by the figures and the page's CSS alike.
COLORS = {
    "inlier": "#3a6ea5",
    "outlier": "#d1495b",
    "accent": "#edae49",
    "ok": "#2e8b57",
    "muted": "#7a8591",
    "ink": "#1f2933",
    "grid": "#e3e7eb",
    "paper": "#ffffff",
    "detected": "#00c853",
    "reprojected": "#ff1744",
}
#: Frame axes: x red, y green, z blue.
AXIS_COLORS = ("#e53935", "#43a047", "#1e88e5")

_RC = {
    "font.family": "DejaVu Sans",
    "font.size": 10,
    "axes.titlesize": 11,
    "axes.titleweight": "bold",
    "axes.labelsize": 10,
    "axes.edgecolor": "#9aa5b1",
    "axes.labelcolor": COLORS["ink"],
    "axes.spines.top": False,
    "axes.spines.right": False,
    "axes.grid": True,
    "grid.color": COLORS["grid"],
    "grid.linewidth": 0.8,
    "axes.axisbelow": True,
    "xtick.color": "#52606d",
    "ytick.color": "#52606d",
    "legend.frameon": False,
    "legend.fontsize": 9,
    "figure.facecolor": COLORS["paper"],
    "savefig.facecolor": COLORS["paper"],
}


def pyplot():
    """matplotlib's pyplot on the Agg backend, styled for the report.

    Returns
    -------
    module
        ``matplotlib.pyplot``.

    Raises
    ------
    MissingDependencyError
        Without matplotlib, naming the extra that installs it.
    """
    matplotlib = require_package("matplotlib", extra="sim", purpose="the calibration report (--report)")
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    plt.rcParams.update(_RC)
    return plt


def save_figure(fig, path: str | Path, dpi: int = 110) -> Path:
    """Write a figure as PNG (whole or not at all, :func:`handeye.core.safe_write.write_figure_atomic`) and close it.

    Parameters
    ----------
    fig : matplotlib.figure.Figure
    path : str or Path
    dpi : int

    Returns
    -------
    Path
    """
    import matplotlib.pyplot as plt

    from handeye.core.safe_write import write_figure_atomic

    path = Path(path)
    try:
        write_figure_atomic(fig, path, dpi=dpi, bbox_inches="tight", pad_inches=0.12)
    finally:
        plt.close(fig)
    return path
