"""The recorded joints' error in the check's covariance: a precise sensor whose pixels' noise no longer hides it.

The check poses the surface at the recorded joints, taken as exact. An encoder's error (or the joint state's time
against the image's while the arm moves) moves the whole posed surface: one error of the frame's step, however many
pixels. With a D435-class sensor it is a tenth of the step's scatter; with a Zivid-class one several times the
pixels' part, its share following the arm's pose, and the running-cell benchmark's ``zivid`` stream alarmed 12
times in 2 minutes (docs/benchmarks/running-cell.md). Here the analytic spheres (tests/watch/test_cell.py) ride a
chain of three joints, recorded with an error while the depth is rendered at the true ones, and seen by a precise
sensor."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
from scipy import stats

from classic.markerless import RobotSurfaceFrames
from handeye.robot.depth_sensors import DepthSensor
from handeye.watch import CellWatcher, Frame, WatchOptions, change
from handeye.watch.check import check_frame
from handeye.watch.wiring import WatchHooks
from tests.classic.test_markerless import K, render_depth, sphere_model
from tests.tolerances import FALSE_ALARM_COUNT_TAIL, JOINT_GAIN_REL, JOINT_VARIANCE_NULL_SIGMA, JOINT_VARIANCE_REL
from tests.watch.test_cell import RATE_HZ, T_TRUE

#: A precise sensor: 0.1 mm at 1 m growing with depth squared (a Zivid-class unit's 0.24 mm, within a factor 3;
#: the spheres' 1.2 to 1.6 m give 0.14 to 0.26 mm).
PRECISE = DepthSensor("precise", "ideal", noise_quadratic_per_m=0.0001)
#: The recorded joints' error, radians per joint: 0.03 deg, at the arm's levers of up to 0.45 m 0.24 mm (the
#: benchmark's streams have 0.01 deg at a UR5's levers of up to 0.8 m); a fresh error every frame, as an encoder's
#: (the depth is rendered at the true joints).
JOINT_SIGMA_RAD = np.radians(0.03)
#: The arm: three spheres on a chain of three joints about the vertical, links this long (metres) from the base's
#: axis, the spheres at these heights: folded, its spheres near the axis and a joint's error moves them little;
#: stretched, 0.45 m out, much. So the joints' share of each frame's step follows the pose, as a UR's does.
LINKS_M, HEIGHTS_M = (0.15, 0.15, 0.15), (0.3, 0.45, 0.6)
#: Frames the arm stays in one pose (dwelling), at 30 Hz a tenth of a second.
DWELL = 3
#: The stated rate, in frames (test_null_streams.py's): 360 per hour at 30 Hz, so that the stream has a count.
FRAMES_PER_ALARM = 300.0
#: The stream's length: 780 frames watched after the first learning's 120.
N_FRAMES = 900


def _chain(q):
    """The joints ``q`` (3,) as the three moving spheres' centres (3, 3) and the joints' axis points (3, 3)."""
    angles = np.cumsum(q)
    steps = np.column_stack([np.cos(angles), np.sin(angles), np.zeros(3)]) * np.asarray(LINKS_M)[:, None]
    axes = np.vstack([np.zeros(3), np.cumsum(steps, axis=0)[:-1]])
    centres = np.cumsum(steps, axis=0) + np.column_stack([np.zeros((3, 2)), HEIGHTS_M])
    return centres, axes


class ArmSpheres:
    """The spheres of tests/watch/test_cell.py's :class:`Spheres` on a chain (:func:`_chain`): the joints are three
    angles, and each sphere's twist per joint is a turn about that joint's vertical axis. The spheres' samples are
    drawn once and moved (``sphere_model`` at each pose was a third of a stream's time)."""

    def __init__(self):
        self._template = sphere_model(np.zeros((1, 4, 3)))

    def posed(self, q, twists=False):
        q = np.atleast_2d(q)
        t, n = self._template, len(q)
        centres = np.zeros((n, 4, 3))
        centres[:, 0] = [0, 0, 0.09]
        chains = [_chain(qi) for qi in q]
        centres[:, 1:] = [c for c, _ in chains]
        points = (t.points_base[None] + centres[:, t.part]).reshape(-1, 3)
        frame = np.repeat(np.arange(n), len(t.part))
        tw = None
        if twists:
            tw = np.zeros((n, 4, 3, 6))
            for i, (_, axes) in enumerate(chains):
                for j in range(3):  # joint j turns the spheres j..2 about the vertical through axes[j]
                    tw[i, j + 1 :, j, :3] = [0, 0, 1.0]
                    tw[i, j + 1 :, j, 3:] = -np.cross([0, 0, 1.0], axes[j])
        normals, part = np.tile(t.normals_base, (n, 1)), np.tile(t.part, n)
        return RobotSurfaceFrames(points, normals, frame, part, joint_twists_base=tw)


def _stream(rng, n):
    """Static scene, the arm in a new pose every DWELL frames; fresh depth noise and joint error every frame."""
    clean, q = None, None
    for i in range(n):
        if i % DWELL == 0:
            q = rng.uniform([-np.pi, -2.5, -2.5], [np.pi, 2.5, 2.5])
            clean = render_depth(np.vstack([[0, 0, 0.09], _chain(q)[0]])[None], T_TRUE)[0]
        z = clean + rng.normal(size=clean.shape) * PRECISE.sigma_m(clean)
        recorded = q + rng.normal(scale=JOINT_SIGMA_RAD, size=3)
        yield Frame(i / RATE_HZ, np.where(clean > 0, z, 0.0), recorded, i)


def _same_calibration(frames, T_start, **kwargs):
    """A recalibration after a false alarm: the truth, at once (the count is of alarms, not of answers)."""
    return SimpleNamespace(ok=True, T_base_cam=T_TRUE, covariance=None, sigma={}, refused=None)


def _count(seed=0):
    options = WatchOptions(
        rate_hz=RATE_HZ,
        false_alarms_per_hour=3600 * RATE_HZ / FRAMES_PER_ALARM,
        null_frames=120,
        recal_frames=4,
        relearn_frames=60,
    )
    w = CellWatcher(ArmSpheres(), K, T_TRUE, PRECISE, options, hooks=WatchHooks(_same_calibration))
    alarms, watched = 0, 0
    for f in _stream(np.random.default_rng(seed), N_FRAMES):
        alarms += sum(e.state == "moved" for e in w.feed(f))
        watched += w.mode in ("watching", "relearning") and w.state not in ("learning", "moved")
    return alarms, watched, w


def _within_the_bound(alarms, watched) -> bool:
    return alarms <= stats.poisson.isf(FALSE_ALARM_COUNT_TAIL, watched / FRAMES_PER_ALARM)


def test_a_precise_sensor_with_joint_noise_keeps_the_stated_rate():
    """Joint errors of 0.03 deg a frame (up to 0.24 mm at the spheres) under 0.1 mm at 1 m of sensor noise: the
    alarms within the Poisson bound of the stated rate over the frames watched (0 on this stream; 13 without the
    joints' error, the test below), the joints' error learnt (its sigma, ``sqrt(joint_variance c)``, within
    JOINT_VARIANCE_REL of the truth)."""
    alarms, watched, w = _count()
    assert _within_the_bound(alarms, watched), (alarms, watched)
    assert watched > 700, watched
    sigma_rad = np.sqrt(w.joint_variance * w.null.scale)
    assert abs(sigma_rad / JOINT_SIGMA_RAD - 1) < JOINT_VARIANCE_REL, np.degrees(sigma_rad)


def test_without_the_joints_error_the_same_stream_exceeds_the_bound(monkeypatch):
    """The planted fault: the joints taken as exact (the watcher before the joints' error was learnt). The pose of
    each dwell sets the joints' share of the step, so the one scale learnt is too small for some poses, for a
    whole dwell: 13 alarms against the bound of 7 the test above holds (seeds 1 to 3: 16 to 21). 3 s, in the default
    run beside the test it shows can fail."""
    monkeypatch.setattr("handeye.watch.cell.fit_joint_variance", lambda *args: 0.0)
    alarms, watched, _ = _count()
    assert not _within_the_bound(alarms, watched), (alarms, watched)


def test_the_joint_gain_is_the_steps_derivative():
    """``FrameCheck.joint_gain`` against finite differences of the step: the surface posed at joints off by 0.05 deg
    (the step moves by ``joint_gain @ dq`` to first order)."""
    rng = np.random.default_rng(5)
    q = rng.uniform([-np.pi, -2.5, -2.5], [np.pi, 2.5, 2.5])
    depth = render_depth(np.vstack([[0, 0, 0.09], _chain(q)[0]])[None], T_TRUE)[0]
    surface = ArmSpheres()
    base = check_frame(depth, K, surface.posed(q[None], twists=True), T_TRUE, PRECISE.sigma_m)
    dq = rng.normal(size=3) * np.radians(0.05)
    moved = check_frame(depth, K, surface.posed((q + dq)[None], twists=True), T_TRUE, PRECISE.sigma_m)
    predicted = base.joint_gain @ dq
    assert np.linalg.norm(moved.delta - base.delta - predicted) < JOINT_GAIN_REL * np.linalg.norm(predicted)


def test_fit_joint_variance_recovers_a_known_variance():
    """300 frames drawn from ``c (Sigma_i + a G_i G_i^T)``, the joints' part as large as the pixels' and varying
    10x with the pose: ``a`` found within JOINT_VARIANCE_REL (in sigma), and within JOINT_VARIANCE_NULL_SIGMA of 0
    where the frames have no joints' part."""
    rng = np.random.default_rng(2)
    n, c, a = 300, 2.5, 1.0
    A = rng.normal(size=(n, 6, 6)) * 1e-3
    cov = A @ A.transpose(0, 2, 1) + 1e-7 * np.eye(6)
    G = rng.normal(size=(n, 6, 6)) * 1e-3 * 10.0 ** rng.uniform(-0.25, 0.25, size=n)[:, None, None]
    total = c * (cov + a * G @ G.transpose(0, 2, 1))
    deltas = np.einsum("nij,nj->ni", np.linalg.cholesky(total), rng.normal(size=(n, 6)))
    found = change.fit_joint_variance(deltas, cov, G)
    assert abs(np.sqrt(found / a) - 1) < JOINT_VARIANCE_REL, found
    alone = np.einsum("nij,nj->ni", np.linalg.cholesky(c * cov), rng.normal(size=(n, 6)))
    assert np.sqrt(change.fit_joint_variance(alone, cov, G) / a) < JOINT_VARIANCE_NULL_SIGMA
