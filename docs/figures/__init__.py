"""The benchmark pages' figures, drawn from the shipped results files (``benchmarks/results/*.md``) alone.

Each function reads its results file's tables (:func:`common.tables`), draws one PNG and returns a
:class:`common.Figure` whose caption names the file and the command that made it. Nothing here runs a benchmark: a
figure shows only what its file holds. ``python docs/make_figures.py --results`` draws them all (a few seconds;
matplotlib only). One module per benchmark page (or family of figures on one), :mod:`common` what they share.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")  # before any module of the package imports pyplot

from . import common  # noqa: E402
from .basin import markerless_basin, markerless_basin_map  # noqa: E402
from .classic import classic_bound  # noqa: E402
from .cluster import cluster_throughput  # noqa: E402
from .common import Figure  # noqa: E402
from .learned import learned_steps  # noqa: E402
from .markerless import markerless_distance, markerless_sensors  # noqa: E402
from .planning import plan_poses  # noqa: E402
from .real import real_recordings_figure  # noqa: E402
from .real_cell import markerless_errors  # noqa: E402
from .reliability import reliability_outcomes  # noqa: E402
from .simulation import simulation_labels  # noqa: E402
from .vision import vision_errors  # noqa: E402

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
    simulation_labels,
    cluster_throughput,
    reliability_outcomes,
)


def draw_all(out: Path) -> list[Figure]:
    """Draw every figure of :data:`RESULT_FIGURES` into ``out``; return them with their captions."""
    out.mkdir(parents=True, exist_ok=True)
    return [draw(out) for draw in RESULT_FIGURES]


__all__ = ["RESULT_FIGURES", "Figure", "common", "draw_all"]
