"""The distance bands the sensor benchmarks put cameras in, written once (``imported_bag``, ``markerless_sensors``)."""

from __future__ import annotations

#: Camera distance from the workspace centre, metres, per band.
BANDS_M = {"0.7": (0.65, 0.75), "1.2": (1.15, 1.25), "1.8": (1.75, 1.85)}
#: At 0.7 m the camera is inside the arm's reach: the simulator finds no board pose the arm can hold in its view
#: (the board would have to be closer than the arm can fold), so that band has no calibration recording.
WITH_BOARD = {"0.7": False, "1.2": True, "1.8": True}
