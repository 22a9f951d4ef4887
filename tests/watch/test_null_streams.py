"""CellWatcher on null streams with the correlation a static scene has: the arm dwelling in one pose for many
frames, seen by a depth unit whose scale and offset are off, with and without partial occluders in front of the
arm; the false alarms against the stated rate, and a unit's offset told from an occluder."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest
from scipy import stats

from handeye.robot.depth_sensors import sensor_profile
from handeye.watch import CellWatcher, Frame, WatchOptions, change
from handeye.watch.check import check_frame
from handeye.watch.states import StateOptions, screen
from handeye.watch.wiring import WatchHooks
from tests.classic.test_markerless import SIGMA_1M, H, K, W, render_depth
from tests.tolerances import FALSE_ALARM_COUNT_TAIL
from tests.watch.test_cell import RATE_HZ, T_TRUE, Spheres

#: The unit: reports ``SCALE d + OFFSET_M``: 0.5 % and 4 mm, as a D435-class unit may (the static stream's had
#: 0.11 % and 5 mm); at 1.2 m, 10 mm: several sigmas of the spheres' per-frame step.
SCALE, OFFSET_M = 0.995, 0.004
#: Frames the spheres stay in one place (a static scene: the arm dwelling), at 30 Hz a third of a second.
DWELL = 10
#: The stated rate, in frames: one false alarm per FRAMES_PER_ALARM frames (3600 * 30 / 300 = 360 per hour), low
#: so that a stream of some thousand frames has a count to compare.
FRAMES_PER_ALARM = 300.0


#: Partial occluders: in every other dwell a flat plate (a hand, a carried part) this far from the camera, metres
#: (the spheres are 1.2 to 1.6 m away), over a rectangle of this many pixels of the 160 x 120 image: from none of
#: the spheres to half of them hidden.
PLATE_DEPTH_M, PLATE_ROWS, PLATE_COLS = (0.6, 1.0), (15, 40), (15, 50)


def _plate(rng):
    """A plate's rows, columns and depth (:data:`PLATE_DEPTH_M`)."""
    h, w = rng.integers(*PLATE_ROWS), rng.integers(*PLATE_COLS)
    r, c = rng.integers(0, H - h), rng.integers(0, W - w)
    return slice(r, r + h), slice(c, c + w), rng.uniform(*PLATE_DEPTH_M)


def _static_frames(rng, n, scale=SCALE, offset_m=OFFSET_M, plates=False):
    """Null frames: the spheres jump to a new place every DWELL frames and stay; fresh sensor noise each frame;
    with ``plates``, a plate in front in every other dwell (:data:`PLATE_DEPTH_M`)."""
    clean, q, plate = None, None, None
    for i in range(n):
        if i % DWELL == 0:
            q = rng.uniform([-0.3, -0.3, 0.25], [0.3, 0.3, 0.65], size=(3, 3))
            clean = render_depth(np.vstack([[0, 0, 0.09], q])[None], T_TRUE)[0]
            plate = _plate(rng) if plates and (i // DWELL) % 2 else None
        noise = rng.normal(size=clean.shape) * SIGMA_1M * clean**2
        depth = np.where(clean > 0, scale * (clean + noise) + offset_m, 0.0)
        if plate is not None:
            depth[plate[0], plate[1]] = scale * plate[2] + offset_m
        yield Frame(i / RATE_HZ, depth, q.ravel(), i)


class DwellSpheres(Spheres):
    """:class:`Spheres` posed once per dwell: the joints stay the same for DWELL frames, and so does the model
    (built again each frame it was two fifths of a stream's time; the same arrays, so the counts are unchanged)."""

    def __init__(self):
        self._last = None, None

    def posed(self, q, twists=False):
        key = (np.asarray(q, dtype=float).tobytes(), twists)
        if self._last[0] != key:
            self._last = key, super().posed(q, twists)
        return self._last[1]


def _same_calibration(frames, T_start, **kwargs):
    """A recalibration after a false alarm: the truth, at once (the count is of alarms, not of answers)."""
    return SimpleNamespace(ok=True, T_base_cam=T_TRUE, covariance=None, sigma={}, refused=None)


def null_options() -> WatchOptions:
    """The watcher's options on these streams: the stated rate one alarm per FRAMES_PER_ALARM frames."""
    return WatchOptions(
        rate_hz=RATE_HZ,
        false_alarms_per_hour=3600 * RATE_HZ / FRAMES_PER_ALARM,
        null_frames=120,
        recal_frames=4,
        relearn_frames=60,
    )


def _count(tmp_path, n_frames, seed=0, plates=False):
    options = null_options()
    w = CellWatcher(DwellSpheres(), K, T_TRUE, sensor_profile("ideal"), options, hooks=WatchHooks(_same_calibration))
    alarms, watched = 0, 0
    for f in _static_frames(np.random.default_rng(seed), n_frames, plates=plates):
        alarms += sum(e.state == "moved" for e in w.feed(f))
        watched += w.mode in ("watching", "relearning") and w.state not in ("learning", "moved")
    return alarms, watched, w


def test_false_alarms_on_a_correlated_static_stream_stay_within_the_stated_rate(tmp_path):
    """3000 frames of a static scene through a unit 0.5 % / 4 mm off: the alarms no more than Poisson's
    FALSE_ALARM_COUNT_TAIL upper quantile of the stated rate's mean (the CUSUM's bound is a mean rate, the count of rare
    alarms Poisson at most). Without the depth unit's correction the statistic follows the spheres' pose, the
    same for DWELL frames (the fault benchmarks/running_cell.py's static stream showed); the planted-fault test
    below shows that count exceeds this bound."""
    alarms, watched, w = _count(tmp_path, 3000)
    bound = stats.poisson.isf(FALSE_ALARM_COUNT_TAIL, watched / FRAMES_PER_ALARM)
    assert watched > 2000, watched
    assert alarms <= bound, (alarms, watched, bound)
    k, c = w.depth_correction  # the unit's correction was learnt: k = 1 / SCALE, c = -OFFSET / SCALE
    assert abs(k - 1 / SCALE) < 0.5 * abs(1 / SCALE - 1) and abs(c + OFFSET_M / SCALE) < 0.5 * OFFSET_M


@pytest.mark.slow
def test_without_the_unit_correction_the_same_stream_exceeds_the_bound(tmp_path, monkeypatch):
    """The planted fault: the depth unit left uncorrected (fit_depth_unit returning no change). It shows the test
    above can fail, as the partial occluders' planted fault below does: CI's run (its 3000 frames are 13 s of a
    core); the test above checks the correction itself (k and c learnt) in the default run."""
    import handeye.watch.cell as cell

    monkeypatch.setattr(cell, "fit_depth_unit", lambda d, c, g: (np.zeros(2), d))
    alarms, watched, _ = _count(tmp_path, 3000)
    assert alarms > stats.poisson.isf(FALSE_ALARM_COUNT_TAIL, watched / FRAMES_PER_ALARM), (alarms, watched)


#: The partial occluders' stream: seed 1, the one that showed a reference learnt from one dwell (38 alarms against
#: a bound of 14 while the reference's error counted its frames, not their distinct poses).
PLATES_SEED = 1


def _scale_as_learnt(monkeypatch):
    """The null's scale as the learning fitted it, neither bounded nor learnt on from the frames watched
    (:class:`handeye.watch.change.NullScale`): the count then tells the reference's own error. (The scale learnt on
    absorbs a reference's excess: the planted fault below gives 0 alarms with it, its estimate 7 % up.)"""
    monkeypatch.setattr(change, "SCALE_Z", 0.0)
    monkeypatch.setattr(change.NullScale, "keep", lambda self: self.drop() or False)


def _plates_within_the_bound(tmp_path):
    alarms, watched, _ = _count(tmp_path, 3000, PLATES_SEED, plates=True)
    return alarms <= stats.poisson.isf(FALSE_ALARM_COUNT_TAIL, watched / FRAMES_PER_ALARM), (alarms, watched)


def test_partial_occluders_in_front_of_the_arm_keep_the_stated_rate(tmp_path, monkeypatch):
    """The same stream with a plate in front in every other dwell (PLATE_DEPTH_M): the plate's pixels are screened
    one by one (in front of the model by more than the match window), the step uses the pixels left with their own
    covariance, and a frame mostly hidden is 'occluded'; the alarms within the same Poisson bound of the stated
    rate over the frames watched, with the scale as learnt (_scale_as_learnt: the reference's error alone)."""
    _scale_as_learnt(monkeypatch)
    ok, (alarms, watched) = _plates_within_the_bound(tmp_path)
    assert watched > 1500, watched
    assert ok, (alarms, watched)


@pytest.mark.slow
def test_the_partial_occluders_check_fails_on_a_planted_fault(tmp_path, monkeypatch):
    """The check above can fail: the relearnt reference's frames counted as independent (one dwell's 10 frames as
    10 poses) gives 38 alarms against a bound of 14. (The plate's pixels taken as matched, a match window of 1000
    sigmas with only the Cauchy loss against them, is not told by this stream: 14 alarms against a bound of 18.)"""
    import handeye.watch.cell as cell

    _scale_as_learnt(monkeypatch)
    monkeypatch.setattr(cell, "replace", lambda null, ref_covariance: null)
    ok, counts = _plates_within_the_bound(tmp_path)
    assert not ok, counts


def test_a_depth_unit_off_is_a_consistent_offset_not_an_occluder():
    """A unit 2 % short (24 mm at 1.2 m, beyond the match window) puts every model pixel in front: one offset,
    not "occluded"; a box over part of the arm is."""
    rng = np.random.default_rng(3)
    q = rng.uniform([-0.3, -0.3, 0.25], [0.3, 0.3, 0.65], size=(3, 3))
    clean = render_depth(np.vstack([[0, 0, 0.09], q])[None], T_TRUE)[0]
    posed = Spheres().posed(q.ravel()[None])
    short = check_frame(np.where(clean > 0, 0.98 * clean, 0.0), K, posed, T_TRUE, sensor_profile("ideal").sigma_m)
    assert short.fraction(short.n_occluders) > StateOptions().occluded_fraction  # what read as "occluded"
    assert screen(short, StateOptions()) is None
    boxed = clean.copy()
    boxed[30:90, 40:110] = 0.6
    box = check_frame(boxed, K, posed, T_TRUE, sensor_profile("ideal").sigma_m)
    assert screen(box, StateOptions())[0] == "occluded"
