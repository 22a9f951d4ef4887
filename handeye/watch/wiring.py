"""What a :class:`handeye.watch.cell.CellWatcher` is wired to: its files (:class:`WatchFiles`) and the callables
it calls beside its own work (:class:`WatchHooks`)."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

__all__ = ["WatchFiles", "WatchHooks"]


@dataclass(frozen=True)
class WatchFiles:
    """Where a watcher keeps its calibrations (:class:`handeye.watch.history.History`); none by default.

    Attributes
    ----------
    history_path : str or Path, optional
        The versions' history (JSON lines, append-only).
    current_path : str or Path, optional
        The current calibration's JSON, published from the history: it needs a ``history_path``
        (:class:`handeye.watch.cell.CellWatcher` refuses it without one).
    """

    history_path: str | Path | None = None
    current_path: str | Path | None = None


@dataclass(frozen=True)
class WatchHooks:
    """The callables a watcher calls (:class:`handeye.watch.cell.CellWatcher`'s parameters say when).

    Attributes
    ----------
    recalibrate : callable, optional
        ``recalibrate(frames, T_start) -> result``; None: :func:`handeye.watch.cell.markerless_recalibration`.
    extra_starts : callable, optional
        ``extra_starts(frames) -> {name: T_base_cam}``, more starts for a recalibration.
    on_commit : sequence of callable
        Each called ``hook(T_base_cam, frames, version)`` after a validated calibration is committed.
    on_stale : sequence of callable
        Each called ``hook(stale_since, version)`` when the calibration in use becomes stale.
    """

    recalibrate: Callable | None = None
    extra_starts: Callable | None = None
    on_commit: Sequence[Callable] = ()
    on_stale: Sequence[Callable] = ()
