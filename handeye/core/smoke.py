"""Smoke runs: every named preset cut to a few seconds' work, so that a documented pipeline runs end to end.

With ``HANDEYE_SMOKE_TEST=1`` in the environment, the simulator's camera presets
(:func:`sim.cameras.get_preset`), the learned presets (:func:`learned.presets.get_preset`) and the
benchmarks' sizes are cut down: the same commands, the same code paths and the same files, on a handful of
placements, frames and epochs. The documentation's long commands (a paper preset's rendering, the ``cpu``
preset's training, the benchmarks) are executed this way by ``tests/test_docs_shell.py``, so that what the
documentation prints cannot go stale; a user can do the same to try a pipeline before a run of hours. The
figures such a run prints mean nothing, and every run says so: the command line prints :data:`NOTICE` on
standard error and a benchmark's report puts it in its header. Ray's documentation tests its examples the
same way (its ``SMOKE_TEST`` variable).

Nothing here reads a preset: each package cuts its own (:meth:`sim.cameras.CameraPreset.smoke`,
:meth:`learned.presets.Preset.smoke`), asking :func:`smoke_test` whether to.
"""

from __future__ import annotations

import os

__all__ = ["ENV", "NOTICE", "smoke_test"]

#: The environment variable that turns smoke runs on (any value but empty or ``0``).
ENV = "HANDEYE_SMOKE_TEST"
#: What every smoke run prints.
NOTICE = f"{ENV} is set: every preset is cut to a smoke run's size; the figures printed mean nothing"


def smoke_test() -> bool:
    """Whether this process runs in smoke mode (:data:`ENV` set, not empty and not ``0``)."""
    return os.environ.get(ENV, "").strip() not in ("", "0")
