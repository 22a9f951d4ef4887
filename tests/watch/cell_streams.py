"""Streams and stand-ins shared by the watcher's input/output tests: the analytic spheres' bumped stream
(tests/watch/test_cell.py) and a recalibration that answers a known pose without registering."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from handeye.robot.depth_sensors import sensor_profile
from handeye.watch import CellWatcher, WatchOptions
from handeye.watch.wiring import WatchFiles, WatchHooks
from tests.classic.test_markerless import K
from tests.watch.test_cell import BUMP, MAX_DELAY_FRAMES, RATE_HZ, T_TRUE, Spheres, _stream

#: The stream: "nothing moved" learnt from NULL_FRAMES, the camera bumped at BUMP_AT, RECAL_FRAMES collected.
NULL_FRAMES, BUMP_AT, RECAL_FRAMES = 60, 70, 6
#: Frames enough for the alarm (MAX_DELAY_FRAMES, test_cell's bound) and the collection (the spheres move at
#: random, so every frame differs from the others by more than the joint step).
N_FRAMES = BUMP_AT + MAX_DELAY_FRAMES + RECAL_FRAMES + 5
T_BUMPED = T_TRUE @ BUMP


def bumped_frames(seed: int = 0, n: int = N_FRAMES, colour: bool = True) -> list:
    """The spheres' stream with the camera bumped at BUMP_AT; with ``colour``, a grey image per frame whose value
    is the frame's index (what the learner is given)."""
    frames = list(_stream(np.random.default_rng(seed), n, lambda i: T_TRUE if i < BUMP_AT else T_BUMPED))
    for f in frames:
        f.depth_m = f.depth_m.astype(np.float32)  # as every source gives it
        f.rgb = np.full(f.depth_m.shape + (3,), f.index % 256, np.uint8) if colour else None
    return frames


class KnownAnswer:
    """A ``recalibrate`` that accepts T_BUMPED at once and records how it was called."""

    def __init__(self):
        self.calls = []

    def __call__(self, frames, T_start, **kwargs):
        self.calls.append({"frames": [f.index for f in frames], "T_start": T_start, **kwargs})
        return SimpleNamespace(ok=True, T_base_cam=T_BUMPED, covariance=None, sigma={}, refused=None)


def watcher(tmp_path, recalibrate, current_path=None, **hooks) -> CellWatcher:
    """A watcher of the spheres with a history, recalibrating with ``recalibrate``; ``hooks``: the other
    :class:`handeye.watch.wiring.WatchHooks` fields."""
    options = WatchOptions(rate_hz=RATE_HZ, null_frames=NULL_FRAMES, recal_frames=RECAL_FRAMES, relearn_frames=30)
    files = WatchFiles(tmp_path / "h.jsonl", current_path)
    return CellWatcher(
        Spheres(), K, T_TRUE, sensor_profile("ideal"), options, files, hooks=WatchHooks(recalibrate, **hooks)
    )
