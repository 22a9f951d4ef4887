"""benchmarks/running_cell.py builds its watcher as ``handeye watch`` does (issue 43): the same options, the check's
z-buffer stride among them, and the same recalibration, at the stride the robot surface was sampled for. On a
stream wider than 160 pixels that stride is 2; the benchmark used to check and recalibrate at 1 (finer than the
surface's sampling, where hidden points show through), a configuration no user ran."""

from __future__ import annotations

import pytest

import handeye.watch
from benchmarks.running_cell import parse_args, replay
from handeye.cli import main
from handeye.watch import cell

#: Wider than the 160 pixels up to which :func:`handeye.markerless.robot_surface_for` samples for stride 1.
WIDE_SIZE = (192, 144)
WIDE_STRIDE = 2
#: Two frames at the smoke preset's 2 Hz: the watchers are built, never fed.
MINUTES = 1 / 60
#: The recalibration the spies wrap (taken before any test patches it).
RECALIBRATION = cell.markerless_recalibration


class _Built(Exception):
    """Raised once a watcher is built: nothing is fed."""


@pytest.fixture(scope="module")
def wide_stream(tmp_path_factory):
    pytest.importorskip("pyrender")
    from sim.stream import StreamOverrides, generate_stream

    root = tmp_path_factory.mktemp("wide") / "stream"
    overrides = StreamOverrides(minutes=MINUTES, image_size=WIDE_SIZE)
    generate_stream(root, "smoke", seed=0, overrides=overrides, workers=1, progress=False)
    return root


def _built(monkeypatch, build) -> dict:
    """The watcher ``build()`` makes (its options) and the z-buffer strides its recalibration was made with."""
    seen = {"recal_strides": [], "recal_spacing_m": []}

    def spy(surface, K, sensor, options=None, zbuffer_stride=1):
        seen["recal_strides"].append(zbuffer_stride)
        seen["recal_spacing_m"].append(surface.spacing_m)
        return RECALIBRATION(surface, K, sensor, options, zbuffer_stride)

    class Spy(cell.CellWatcher):
        def __init__(self, *args, **kwargs):
            super().__init__(*args, **kwargs)
            seen["watcher"] = self
            raise _Built

    monkeypatch.setattr(cell, "markerless_recalibration", spy)
    monkeypatch.setattr(handeye.watch, "CellWatcher", Spy)
    with pytest.raises(_Built):
        build()
    return seen


def test_the_benchmark_builds_the_watcher_as_handeye_watch_does(wide_stream, monkeypatch):
    args = parse_args([])
    bench = _built(monkeypatch, lambda: replay(wide_stream, args))
    same = [
        *("--false-alarms-per-hour", str(args.false_alarms_per_hour), "--null-seconds", str(args.null_seconds)),
        *("--relearn-seconds", str(args.relearn_seconds), "--recal-frames", str(args.recal_frames)),
    ]
    command = _built(monkeypatch, lambda: main(["watch", str(wide_stream), "--truth-start", *same]))
    assert bench["watcher"].options == command["watcher"].options
    assert command["watcher"].options.check.zbuffer_stride == WIDE_STRIDE  # the surface's, as the command takes it
    assert bench["recal_strides"] == command["recal_strides"] == [WIDE_STRIDE]
    assert bench["recal_spacing_m"] == command["recal_spacing_m"]
