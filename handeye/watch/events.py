"""What the watcher reports: one event per change of a frame's state, printed as one line."""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["Event", "STATES"]

#: The states a frame is put in (:mod:`handeye.watch.states`), and the watcher's own (:mod:`handeye.watch.cell`).
STATES = (
    "learning",  # the first frames: "nothing moved" is being learnt from them
    "ok",  # the calibration fits the frame
    "drift",  # a slow consistent trend of the correction, below the alarm
    "occluded",  # something in front of the arm, or an alarm without a consistent direction
    "out_of_view",  # too few model points in the image
    "dropout",  # most model pixels without depth
    "moved",  # the change test alarmed with a consistent correction: recalibration starts
    "recalibrated",  # a validated new calibration was committed
    "refused",  # the recalibration's answer was refused: still stale
    "replaced",  # another process appended a version to the history (a rollback): taken, not validated here
)


@dataclass
class Event:
    """A change of state at a frame.

    Attributes
    ----------
    t : float
        The frame's time, seconds from the stream's start.
    state, previous : str
        One of :data:`STATES`.
    detail : str
        What made it (counts, the statistic, the refusal's reason).
    stale_since : float or None
        Time of the "moved" alarm while no validated calibration has replaced the one it found off (at a stale
        start, the earlier run's time, from the current JSON: :class:`handeye.watch.CellWatcher`).
    version : int or None
        The calibration version in use (the history's), when there is a history.
    """

    t: float
    state: str
    previous: str
    detail: str = ""
    stale_since: float | None = None
    version: int | None = None

    def line(self) -> str:
        """One line: ``t=12.345s moved (was ok) cusum 14.2 >= 11.6; calibration stale since 12.345s``."""
        out = f"t={self.t:.3f}s {self.state} (was {self.previous})"
        if self.detail:
            out += f" {self.detail}"
        if self.version is not None:
            out += f"; version {self.version}"
        if self.stale_since is not None:
            out += f"; calibration stale since {self.stale_since:.3f}s"
        return out
