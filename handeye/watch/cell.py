"""A running cell's calibration, watched frame by frame: :class:`CellWatcher`.

Per frame (:meth:`CellWatcher.feed`): the check of the current ``T_base_cam`` (:mod:`handeye.watch.check`),
then

- **learning** for the first ``WatchOptions.null_frames`` usable frames: "nothing moved" is fitted on them
  (:func:`handeye.watch.change.fit_null`); nothing is decided yet;
- **watching**: the frame's state (:mod:`handeye.watch.states`) with the CUSUM at the stated false-alarm rate;
- on **moved**: the calibration is stale from that frame's time. The next usable frames with enough joint
  diversity (each differs from all collected by at least ``recal_min_joint_step_rad`` in some joint) are
  collected; with ``recal_frames`` of them, ``recalibrate(frames, T_start)`` is called (by default the
  markerless registration from the last calibration, :func:`markerless_recalibration`). Its answer is taken
  only when the registration accepted it (its sigma and split check passed, ``result.ok``) and the frames'
  first and second halves, registered alone, agree within their sigmas (:mod:`handeye.watch.halves`: a second
  move while they were collected; refused, the later half kept to start the next collection): then it is
  committed to the history and published; then **relearning**: the null's bias anew against the new
  calibration (its own error, within its sigma, is "nothing moved" from now on), its scale kept (a camera
  move does not change the sensor's noise), the change test re-armed and **watching through it**: after
  ``relearn_min_frames`` usable frames (blind until then: "learning") each frame is tested against the mean
  of those before it, weighted by their information (its error counted in, as from as many frames as they hold
  distinct arm poses, :meth:`handeye.watch.change.NullModel.statistic`), until ``relearn_frames`` fix the bias.
- the end of the first learning also estimates the recorded joints' error (:func:`handeye.watch.change.
  fit_joint_variance`, where the surface carries its joint twists: one error of each frame's whole step, which
  the pixels' covariance does not hold; with a precise sensor most of the step's scatter, its share following
  the arm's pose), counted in every frame's covariance from then on (:func:`handeye.watch.check.with_joint_noise`),
  and the depth unit's correction (:func:`handeye.watch.change.
  fit_depth_unit`: a wrong scale or offset makes the statistic depend on the arm's pose, correlated from frame
  to frame, and the stated rate fails), applies it, and relearns the bias against it as after a commit. A
  starting calibration that fits none of ``null_frames`` frames in a row (lost, or a consistent offset) is
  "moved".
  A refusal is an event with the reason, and the collection starts again; until a validated answer exists
  every event says "calibration stale since t".
- a version **another process appended** to the history (``handeye watch rollback`` while this watcher runs):
  seen at the next frame (the history file's ``stat`` changed and its latest version is not the one in use),
  taken as a commit is (a stale calibration no longer stale: a person chose it), published (the current JSON,
  the ``on_commit`` hooks with no frames) and relearnt; the event is ``replaced``. It is not validated here: the
  change test, after the relearning, is what checks it.
- a **stale start**: a watcher started on the history's latest version while the current JSON says an earlier run
  found it off (``stale_since``, :meth:`handeye.watch.history.History.recorded_stale`) is stale from its first
  frame, with that ``stale_since`` (the earlier run's stream time), and starts by collecting frames to
  recalibrate, as after a ``moved`` (its first event says so). The check on the first frames cannot validate it:
  the null's bias is learnt on them, so a pose a few millimetres off would be learnt as "nothing moved". Only a
  validated recalibration (or a version appended by a person: ``replaced``) ends it. Any other start publishes
  the current JSON from the history (valid).

Events are returned on every change of state (and on learning's end, a recalibration, a refusal).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from classic.markerless import MarkerlessOptions, register_robot
from handeye.watch.change import Cusum, NullModel, NullScale, fit_depth_unit, fit_joint_variance, fit_null
from handeye.watch.check import CheckOptions, FrameCheck, check_frame, unit_correction, with_joint_noise
from handeye.watch.events import Event
from handeye.watch.halves import halves_disagree
from handeye.watch.history import History
from handeye.watch.source import Frame
from handeye.watch.states import FrameStates, StateOptions, is_lost, screen
from handeye.watch.wiring import WatchFiles, WatchHooks

__all__ = ["WatchOptions", "WatchFiles", "WatchHooks", "CellWatcher", "markerless_recalibration"]

#: The depth correction has settled when a new fit would move the frames' steps by less than this many of their
#: sigmas (median over the frames); at most ``UNIT_ROUNDS`` fits (the first learning's and the relearnings').
UNIT_SETTLED = 0.5
UNIT_ROUNDS = 4


@dataclass(frozen=True)
class WatchOptions:
    """Settings of :class:`CellWatcher`.

    Attributes
    ----------
    rate_hz : float
        The stream's frame rate (turns the false-alarm rate into frames).
    false_alarms_per_hour : float
        The change test's false-alarm rate (0.1 by default: one in ten hours, so that an hour passes without one;
        at 1 per hour the CUSUM's threshold is 2.3 lower, which a 2 mm bump crosses one or two frames sooner):
        an upper bound while the frames' statistic follows the null learnt
        (independent frames, ``chi2(6)`` after the fit; :mod:`handeye.watch.change`); correlated frames, the
        error of the null learnt and unmodelled changes raise it (the scale's error, 17 % for a median of 20
        frames, is covered: it is used at its upper bound, :class:`handeye.watch.change.NullScale`): the measured
        rate is in
        docs/benchmarks/running-cell.md. A depth unit left uncorrected made the frames correlated (the statistic
        follows the arm's pose); the first learning fits it (:func:`handeye.watch.change.fit_depth_unit`).
    null_frames : int
        Usable frames "nothing moved" is learnt from (about the first 10 s at 30 Hz by default).
    relearn_frames : int
        Usable frames the null's bias is learnt from after a recalibration (3 s at 30 Hz by default).
    relearn_min_frames : int
        Of those, the first ones taken before the change test resumes (blind for so long: 0.2 s at 30 Hz).
    rho : float
        The CUSUM's alternative (:class:`handeye.watch.change.Cusum`).
    recal_frames : int
        Frames collected for a recalibration.
    recal_min_joint_step_rad : float
        Joint diversity of those frames.
    check, states : CheckOptions, StateOptions
    """

    rate_hz: float = 30.0
    false_alarms_per_hour: float = 0.1
    null_frames: int = 300
    relearn_frames: int = 90
    relearn_min_frames: int = 6
    rho: float = 1.0
    recal_frames: int = 30
    recal_min_joint_step_rad: float = 0.05
    check: CheckOptions = field(default_factory=CheckOptions)
    states: StateOptions = field(default_factory=StateOptions)

    def __post_init__(self):
        if not self.rate_hz > 0 or not self.false_alarms_per_hour > 0:
            raise ValueError(f"rate ({self.rate_hz} Hz) and false alarms per hour must be > 0")
        if self.null_frames < 6 or self.recal_frames < 2:
            raise ValueError(
                f"null_frames >= 6 and recal_frames >= 2 needed, got {self.null_frames}, {self.recal_frames}"
            )

    @property
    def frames_per_false_alarm(self) -> float:
        return 3600.0 * self.rate_hz / self.false_alarms_per_hour


def markerless_recalibration(
    robot_surface, K: np.ndarray, sensor, options: MarkerlessOptions | None = None, zbuffer_stride: int = 1
):
    """The default ``recalibrate``: :func:`classic.markerless.register_robot` on the collected frames.

    Started from the last calibration, any ``extra_starts`` (the learned model's prediction,
    :meth:`handeye.watch.learner.BackgroundLearner.starts`) and the moving pixels' centroids. Unless ``options``
    are given: the camera matrix and the joints taken as exact, as the check takes them, the depth's scale and
    offset estimated (the check then uses them), and the sensor profile's depth noise and depth-to-colour
    extrinsic bounds (the rotation's a real unit's:
    :attr:`handeye.robot.depth_sensors.DepthSensor.registration_roll_bound_deg`).
    """
    if options is None:
        # the check takes the camera matrix and the joints as given and corrects the depth by the scale and offset
        # the registration finds; the two must agree on what fits, or the new calibration's own model
        # difference would read as a move
        options = MarkerlessOptions(
            depth_sigma_m_at_1m=float(sensor.sigma_m(1.0)),
            intrinsics_model="fixed",
            zbuffer_stride=zbuffer_stride,
            joint_offsets_model="fixed",
            depth_extrinsic_sigma_m=sensor.extrinsic_sigma_m,
            depth_extrinsic_sigma_deg=sensor.registration_roll_bound_deg,  # a real unit's, as the front's --sensor
        )

    def recalibrate(frames: list[Frame], T_start: np.ndarray, extra_starts: dict | None = None):
        depth = np.stack([f.depth_m for f in frames])
        q = np.stack([f.joints for f in frames])
        starts = {"last": T_start, **(extra_starts or {})}
        return register_robot(depth, K, robot_surface.posed(q), starts=starts, options=options)

    return recalibrate


class CellWatcher:
    """Watch a running cell's calibration (module docstring).

    Parameters
    ----------
    robot_surface : handeye.robot.surface.RobotSurface
        Anything with ``posed(q (N, nq), twists=True)`` giving points and normals in the base frame (and,
        where it gives ``joint_twists_base``, the joints' error is learnt). The check
        poses it thinned (``thinned(factor ** 2)``, where it has that method) for a focal length ``factor`` times
        the check's reference (:meth:`handeye.watch.check.CheckOptions.factor_for`): an 848x480 depth image
        over 87 degrees checks as many points as 256x256 over 60 at the same cost; the recalibration takes it
        whole.
    K : array, shape (3, 3)
        The depth images' camera matrix.
    T_base_cam : array, shape (4, 4), or None
        The calibration to start from; None: the history's latest version.
    sensor : handeye.robot.depth_sensors.DepthSensor
        Its ``sigma_m`` is the check's noise.
    options : WatchOptions, optional
    files : WatchFiles, optional
        ``history_path``, the versions' history, and ``current_path``, the current calibration's JSON
        (:class:`handeye.watch.history.History`); a ``current_path`` needs a ``history_path``. None: neither.
    depth_correction : (float, float), optional
        ``(k, c)``: the true depth is ``k z_obs + c`` (:func:`handeye.watch.check.check_frame`), until a
        recalibration estimates it anew. None: the version started from's own (its history record's
        ``depth_correction_k_c_m``), else ``(1, 0)``.
    hooks : WatchHooks, optional
        What the watcher calls; None: :func:`markerless_recalibration` and nothing else. Its fields:

        ``recalibrate``: ``recalibrate(frames, T_start) -> result`` with ``ok``, ``T_base_cam``, ``covariance``,
        ``sigma`` and ``refused`` (a :class:`classic.markerless.MarkerlessResult`); :func:`markerless_recalibration`
        when None. Where its ``depth`` has ``scale`` and ``offset_mm`` they replace the depth correction.

        ``on_commit``: each called ``hook(T_base_cam, frames, version)`` after a validated calibration is committed
        (and published to ``current_path``): :class:`handeye.watch.ros2.TfPublisher`,
        :class:`handeye.watch.learner.BackgroundLearner` (which returns at once and trains in the background).

        ``extra_starts``: ``extra_starts(frames) -> {name: T_base_cam}``, more starts for a recalibration beside the
        last calibration (:meth:`handeye.watch.learner.BackgroundLearner.starts`); passed as
        ``recalibrate(frames, T_start, extra_starts=...)`` when it gives any.

        ``on_stale``: each called ``hook(stale_since, version)`` when the calibration in use becomes stale (a
        ``moved``), after ``current_path``'s JSON says so (:meth:`handeye.watch.history.History.mark_stale`):
        :meth:`handeye.watch.ros2.TfPublisher.stale`.
    """

    def __init__(
        self,
        robot_surface,
        K: np.ndarray,
        T_base_cam: np.ndarray | None,
        sensor,
        options: WatchOptions | None = None,
        files: WatchFiles | None = None,
        depth_correction: tuple | None = None,
        hooks: WatchHooks | None = None,
    ):
        self.surface = robot_surface
        self.K = np.asarray(K, dtype=float)
        self.sensor = sensor
        self.options = options or WatchOptions()
        hooks = hooks or WatchHooks()
        self.history = _history(files or WatchFiles())
        latest = None if self.history is None else self.history.latest()
        T_base_cam, self.version = self._start_version(T_base_cam, latest)
        self.T_base_cam = np.array(T_base_cam, dtype=float)
        self.depth_correction = _start_correction(depth_correction, latest, self.version)
        self._check_surface = _thinned(robot_surface, self.options.check.factor_for(self.K))
        stride = self.options.check.zbuffer_stride
        self.recalibrate = hooks.recalibrate or markerless_recalibration(
            robot_surface, self.K, sensor, zbuffer_stride=stride
        )
        self.on_commit, self.on_stale = tuple(hooks.on_commit), tuple(hooks.on_stale)
        self.extra_starts = hooks.extra_starts
        self.mode = "learning"
        self.state = "learning"
        self.stale_since: float | None = None
        self._start_note, self._earlier = "", ""  # said with the first event of a stale start, and in its commit
        if self.history is not None and self.history.latest() is not None:
            self._start_from_record()
        self.null: NullModel | None = None
        self.states: FrameStates | None = None
        self.last_check: FrameCheck | None = None
        self._null_checks: list[FrameCheck] = []
        self._poses: list[np.ndarray] = []  # the distinct arm poses of the relearning's pool (_pool)
        self._note = ""  # said with the first frame watched after the first learning
        self._settling, self._unit_rounds = False, 0  # the depth correction fitted again after the first learning
        self._misfits = 0  # frames in a row the calibration fits nowhere (lost, or occluded), while learning
        self._last_q: np.ndarray | None = None  # the previous frame's joints (a new arm pose for the null's scale)
        # the recorded joints' error (per joint, the null's units): learnt once, at the end of the first learning
        # (0 until then, or where the surface carries no joint twists)
        self.joint_variance, self._joints_learnt = 0.0, False
        self._collected: list[Frame] = []
        self._history_stamp = None if self.history is None else self.history.stamp()

    def _start_version(self, T_base_cam: np.ndarray | None, latest) -> tuple[np.ndarray, int | None]:
        """The calibration started from and its version: the history's latest, or ``T_base_cam`` (appended to the
        history unless it is the latest)."""
        if T_base_cam is None:
            if latest is None:
                raise ValueError("no calibration to start from: give T_base_cam or a history with a version")
            return latest.T_base_cam, latest.version
        if self.history is None:
            return T_base_cam, None
        if latest is not None and np.allclose(latest.T_base_cam, T_base_cam, atol=1e-12):
            return T_base_cam, latest.version
        return T_base_cam, self.history.append(T_base_cam, "start", stream_t=0.0).version

    def _start_from_record(self) -> None:
        """A stale start (module docstring) when the current JSON says the version in use is stale, else the current
        JSON written from the history."""
        stale = self.history.recorded_stale() if self.version == self.history.latest().version else None
        if stale is None:
            self.history.publish()
            return
        self.mode, self.stale_since, self._earlier = "collecting", stale, " of an earlier run"
        self._start_note = (
            f"version {self.version} was found off at t={stale:.3f}s of an earlier run ({self.history.current_path}"
            "'s stale_since): recalibrating before it is called valid; "
        )

    def _check(self, frame: Frame) -> FrameCheck:
        """The frame's check, the joints' error in its covariance once the first learning has learnt it."""
        posed = self._check_surface.posed(np.asarray(frame.joints, dtype=float)[None], twists=True)
        check = check_frame(
            frame.depth_m,
            self.K,
            posed,
            self.T_base_cam,
            self.sensor.sigma_m,
            self.options.check,
            self.depth_correction,
        )
        return with_joint_noise(check, self.joint_variance)

    def feed(self, frame: Frame) -> list[Event]:
        """Check one frame; the events it causes (often none).

        Parameters
        ----------
        frame : Frame

        Returns
        -------
        list of Event
        """
        events = self._follow_history(frame.t)
        check = self._check(frame)
        self.last_check = check
        was_stale = self.stale_since is not None
        q = np.asarray(frame.joints, dtype=float)
        step = self.options.recal_min_joint_step_rad
        new_pose = self._last_q is None or bool(np.abs(q - self._last_q).max() >= step)
        self._last_q = q
        if self.mode == "learning":
            state, detail = self._learn(check, frame)
        elif self.mode in ("watching", "relearning"):
            if self.mode == "watching":
                state, detail = self.states.classify(check, new_pose=new_pose)
            else:
                state, detail = self._relearn(check, frame, new_pose)
            if state == "moved":
                self.mode, self.stale_since, self._collected, self._null_checks = "collecting", frame.t, [], []
        else:
            state, detail = self._collect(frame, check)
        if state != self.state or state in ("recalibrated", "refused"):
            detail, self._start_note = self._start_note + detail, ""
            events.append(self._event(frame.t, state, detail))
            self.state = state
        if self.stale_since is not None and not was_stale:
            self._mark_stale()
        return events

    def _mark_stale(self) -> None:
        """Say on every output that the calibration in use is stale: the current JSON, then the hooks."""
        if self.history is not None:
            self.history.mark_stale(self.stale_since)
        for hook in self.on_stale:
            hook(self.stale_since, self.version)

    def _follow_history(self, t: float) -> list[Event]:
        """Take a version another process appended to the history since the last look (module docstring)."""
        if self.history is None:
            return []
        stamp = self.history.stamp()
        if stamp == self._history_stamp:
            return []
        self._history_stamp = stamp
        latest = self.history.latest()
        if latest is None or latest.version == self.version:  # this watcher's own append
            return []
        self.version, self.T_base_cam = latest.version, np.array(latest.T_base_cam)
        self.depth_correction = _recorded_correction(latest, self.depth_correction)
        self._restart()
        event = self._event(t, "replaced", f"version {latest.version} appended to the history: {latest.reason}")
        self.state = "replaced"
        self.history.publish()  # the current JSON: this version, not stale
        for hook in self.on_commit:
            hook(self.T_base_cam, [], self.version)
        return [event]

    def _restart(self) -> None:
        """After a new calibration: not stale; the bias learnt anew, watching through it (the null first, if none)."""
        self.stale_since, self._collected, self._start_note, self._earlier = None, [], "", ""
        self._misfits, self._null_checks = 0, []
        if self.states is None:  # the first calibration replaced before any null: learn it
            self.mode = "learning"
        else:  # the bias of the new calibration, watching through it
            self.mode = "relearning"
            self.states.rearm()

    def _event(self, t: float, state: str, detail: str) -> Event:
        return Event(t, state, self.state, detail, self.stale_since, self.version)

    def _learn(self, check: FrameCheck, frame: Frame) -> tuple[str, str]:
        t = frame.t
        unusable = screen(check, self.options.states)
        lost = is_lost(check, self.options.states)
        if unusable is None and not lost:
            self._pool(check, frame)  # its distinct arm poses counted (the scale's, NullScale)
            self._misfits = 0
        elif unusable is None or unusable[0] == "occluded":
            self._misfits += 1
        n, need = len(self._null_checks), self.options.null_frames
        if self._misfits >= need:  # the calibration fits no frame: moved (or a depth unit far off)
            self.mode, self.stale_since, self._collected, self._null_checks = "collecting", t, [], []
            return "moved", f"the calibration fits none of the last {self._misfits} frames (lost or occluded)"
        if n < need:
            return "learning", f"{n} of {need} frames for the null"
        checks, self._null_checks = self._null_checks, []
        deltas, unit_gains = np.stack([c.delta for c in checks]), np.stack([c.unit_gain for c in checks])
        if not self._joints_learnt and all(c.joint_gain is not None for c in checks):
            self._joints_learnt = True  # a fit of 0 (a noisy sensor hides the joints' part) is learnt too
            covariances = np.stack([c.covariance for c in checks])
            joint_gains = np.stack([c.joint_gain for c in checks])
            self.joint_variance = fit_joint_variance(deltas, covariances, joint_gains, unit_gains)
            checks = [with_joint_noise(c, self.joint_variance) for c in checks]
        covariances = np.stack([c.covariance for c in checks])
        u, deltas = fit_depth_unit(deltas, covariances, unit_gains)
        k, c0 = self.depth_correction
        self.depth_correction = (k + float(u[0]), c0 + float(u[1]))
        self.null = fit_null(deltas, covariances)
        cusum = Cusum(self.options.frames_per_false_alarm, self.options.rho)
        scale = NullScale(self.null.samples, len(self._poses))
        self.states = FrameStates(self.null, cusum, self.options.states, scale)
        self.mode, self._settling = "relearning", True  # the bias anew against the corrected depth, watching on
        self._note = (
            f"null learnt from {n} frames: chi2 scale {self.null.scale:.2f} (used at its upper bound "
            f"{scale.bound:.2f} from {scale.poses} arm poses, narrowed as frames are watched), threshold {cusum.h:.2f} "
            f"(designed for {self.options.false_alarms_per_hour:g} false alarm per hour at {self.options.rate_hz:g} Hz "
            f"while the frames follow the null learnt: the measured rate is in "
            f"docs/benchmarks/running-cell.md); the joints' error {self._joint_sigma_deg():.4f} deg (in each frame's "
            f"covariance); depth correction now k {self.depth_correction[0]:.5f}, "
            f"c {self.depth_correction[1] * 1e3:+.2f} mm (changed by {u[0]:+.5f}, {u[1] * 1e3:+.2f} mm); "
        )
        return "learning", f"null learnt from {n} frames; the bias against the corrected depth next"

    def _joint_sigma_deg(self) -> float:
        """The recorded joints' error learnt, degrees per joint: ``sqrt(joint_variance c)``, ``c`` the null's scale."""
        return float(np.degrees(np.sqrt(self.joint_variance * self.null.scale)))

    def _relearn(self, check: FrameCheck, frame: Frame, new_pose: bool = True) -> tuple[str, str]:
        """The bias of a new calibration (or depth correction) learnt while the change test watches on (its error
        counted over the pool's distinct arm poses, :meth:`_pool_null`). Frames in a row that fit nowhere before
        it watches are "moved" after ``relearn_frames`` of them, or while the first learning's depth correction
        settles, after ``null_frames`` (the calibration has just fit that many: it is the first learning's
        question, over its window; a person passing for 5 s read as a move at 2 Hz)."""
        o, pool = self.options, self._null_checks
        n, unusable = len(pool), screen(check, o.states)
        usable = unusable is None and not is_lost(check, o.states)
        if n < o.relearn_min_frames:
            if usable:
                self._pool(check, frame)
                self._misfits = 0
            elif unusable is None or unusable[0] == "occluded":
                self._misfits += 1
            if self._misfits >= (o.null_frames if self._settling else o.relearn_frames):  # moved again meanwhile
                return "moved", f"the calibration fits none of the last {self._misfits} frames (lost or occluded)"
            return "learning", f"{len(pool)} of {o.relearn_min_frames} frames before watching the new bias again"
        self.states.null = self._pool_null(self.states.null.scale)  # the scale in use (NullScale's bound)
        state, detail = self.states.classify(check, drift=False, new_pose=new_pose)
        detail, self._note = self._note + detail, ""
        if usable and state == "ok":
            self._pool(check, frame)
        need = o.null_frames if self._settling else o.relearn_frames
        if len(pool) >= need:
            detail += "; " + self._fix_reference(pool)
        return state, f"{detail} (bias from {n} of {need} frames)"

    def _pool(self, check: FrameCheck, frame: Frame) -> None:
        """Add a frame to the relearning's pool, noting its arm pose if it differs from every pose noted by at least
        ``recal_min_joint_step_rad`` in some joint."""
        if not self._null_checks:
            self._poses = []
        q = np.asarray(frame.joints, dtype=float)
        if all(np.abs(q - p).max() >= self.options.recal_min_joint_step_rad for p in self._poses):
            self._poses.append(q)
        self._null_checks.append(check)

    def _pool_null(self, scale: float | None) -> NullModel:
        """The null's reference from the relearning's pool (:func:`handeye.watch.change.fit_null`; its scale too
        when ``scale`` is None), the reference's covariance counted over the pool's distinct poses: frames of one
        pose share its part of the step's error (the model's sampling, the depth correction's residue, a partial
        occluder's cut), so a reference from N frames of k poses is off as one from k frames, not N (counted as N,
        a watcher on a static scene with partial occluders, the arm dwelling 10 frames at 30 Hz, learnt its
        reference from one dwell and alarmed 38 times in 3000 frames against a bound of 14)."""
        pool = self._null_checks
        null = fit_null(np.stack([c.delta for c in pool]), np.stack([c.covariance for c in pool]), scale)
        return replace(null, ref_covariance=null.ref_covariance * len(pool) / max(len(self._poses), 1))

    def _fix_reference(self, pool: list[FrameCheck]) -> str:
        """The end of a relearning: the bias fixed (the scale kept), or while the depth correction settles, the
        unit fitted again on exact checks: applied and relearnt while it moves the steps by more than
        ``UNIT_SETTLED`` of their sigma (a linearised fit is off for a unit off by more than the match window),
        else the null refitted, scale and all, on these frames."""
        deltas = np.stack([c.delta for c in pool])
        if not self._settling:
            self.null, self._null_checks = self._pool_null(self.states.null.scale), []
            self.states.null, self.mode = self.null, "watching"
            return f"bias learnt from {len(pool)} frames"
        covariances, gains = np.stack([c.covariance for c in pool]), np.stack([c.unit_gain for c in pool])
        u, corrected = fit_depth_unit(deltas, covariances, gains)
        shift = gains @ u
        moved = np.median(np.einsum("ni,ni->n", shift, np.linalg.solve(covariances, shift[..., None])[..., 0]))
        self._unit_rounds += 1
        settled = self._pool_null(None)
        self._null_checks = []
        if np.sqrt(moved / self.null.scale) > UNIT_SETTLED and self._unit_rounds < UNIT_ROUNDS:
            k, c = self.depth_correction
            self.depth_correction = (k + float(u[0]), c + float(u[1]))
            self.states.rearm()
            return f"depth correction changed by {u[0]:+.5f}, {u[1] * 1e3:+.2f} mm: the bias relearnt against it"
        self.null, self._settling = settled, False
        self.states.scale = NullScale(settled.samples, len(self._poses))  # the scale anew at the settled unit
        self.states.rearm(self.null)
        self.mode = "watching"
        return (
            f"null refitted from {len(pool)} frames at the settled depth correction (k {self.depth_correction[0]:.5f},"
            f" c {self.depth_correction[1] * 1e3:+.2f} mm): chi2 scale {self.null.scale:.2f}, used at its upper bound "
            f"{self.states.scale.bound:.2f} from {self.states.scale.poses} arm poses"
        )

    def _collect(self, frame: Frame, check: FrameCheck) -> tuple[str, str]:
        unusable = screen(check, self.options.states, occlusion=False)  # the registration is robust to occluders
        if unusable is not None:
            return unusable
        q = np.asarray(frame.joints, dtype=float)
        step = self.options.recal_min_joint_step_rad
        if all(np.abs(q - f.joints).max() >= step for f in self._collected):
            self._collected.append(frame)
        n = len(self._collected)
        if n < self.options.recal_frames:
            return "moved", f"collecting frames to recalibrate: {n} of {self.options.recal_frames}"
        frames, self._collected = self._collected, []
        extra = self.extra_starts(frames) if self.extra_starts is not None else {}
        result = self.recalibrate(frames, self.T_base_cam, **({"extra_starts": extra} if extra else {}))
        if not getattr(result, "ok", False):
            reason = getattr(result, "refused", None) or "no answer"
            return "refused", f"recalibration from {len(frames)} frames refused: {reason}; collecting again"
        two_poses = halves_disagree(self.recalibrate, frames, result)
        if two_poses is not None:  # the camera as it is now: the later half's frames start the next collection
            self._collected = frames[len(frames) // 2 :]
            return "refused", (
                f"recalibration from {len(frames)} frames refused: {two_poses}; collecting again from the latest "
                f"{len(self._collected)}"
            )
        return self._commit(frame, frames, result)

    def _committed_unit(self, depth: dict) -> str:
        """The depth correction after a commit (a note for its event). A camera move does not change the sensor's
        depth unit: the one this watcher fitted on its first learning's frames (``null_frames`` of them, many arm
        poses, refitted on exact checks until it settled: :func:`handeye.watch.change.fit_depth_unit`) is kept
        where the registration's (from ``recal_frames`` frames) gives depths within the check's match window of
        it at both ends of the registration's matched depths (``range_m``): the check then matches what the
        registration matched, and the two differ by less than the check tells a move from an unmoved arm. Else (a
        unit that changed by more, no unit fitted here yet, or no range given) the registration's is taken.
        Why not the registration's always: its few frames leave loose the combination of scale and offset that
        moves the arm's depths alike. The registration takes the depth noise's own bias out of it
        (:meth:`classic.markerless.problem.Problem.depth_debiased`), but not its scatter along that combination:
        on 20 d435 frames it still lies beyond 3 of its own sigmas in 2 of 16 sets
        (``benchmarks/results/markerless_depth_unit_sigma.md``). A unit off along it makes each frame's step
        follow the arm's pose (:func:`handeye.watch.change.fit_depth_unit`): the bias relearnt from the first
        poses after the commit does not hold for the next ones, and the check reads a move where there is none.
        The fitted unit comes from more frames over more poses."""
        if "scale" not in depth or "offset_mm" not in depth:
            return ""
        k1, c1 = unit_correction(depth["scale"], depth["offset_mm"] * 1e-3)
        k0, c0 = self.depth_correction
        if self.states is not None and len(depth.get("range_m") or ()) == 2:
            z = np.asarray(depth["range_m"], dtype=float)
            apart_m = np.abs((k1 - k0) * z + (c1 - c0))
            window_m = self.options.check.window_sigmas * np.asarray(self.sensor.sigma_m(z)) + (
                self.options.check.window_floor_m
            )
            if np.all(apart_m < window_m):
                return (
                    f"; depth unit kept (the registration's scale {depth['scale']:.5f}, offset "
                    f"{depth['offset_mm']:+.2f} mm: {apart_m.max() * 1e3:.1f} mm from it over "
                    f"{z[0]:.2f}-{z[1]:.2f} m, within the match window)"
                )
        self.depth_correction = (k1, c1)
        return f"; depth unit the registration's: scale {depth['scale']:.5f}, offset {depth['offset_mm']:+.2f} mm"

    def _commit(self, frame: Frame, frames: list[Frame], result) -> tuple[str, str]:
        self.T_base_cam = np.array(result.T_base_cam, dtype=float)
        unit_note = self._committed_unit(getattr(result, "depth", None) or {})
        sigma = np.sqrt(np.diag(result.covariance)) if getattr(result, "covariance", None) is not None else None
        if self.history is not None:
            v = self.history.append(
                self.T_base_cam,
                f"moved at t={self.stale_since:.3f}s{self._earlier}",
                sigma,
                [f.index for f in frames],
                stream_t=frame.t,
                extra={
                    "sigma_summary": dict(getattr(result, "sigma", {}) or {}),
                    "depth_correction_k_c_m": list(self.depth_correction),
                },
            )
            self.version = v.version
        stale = self.stale_since
        self._restart()
        s = getattr(result, "sigma", {}) or {}
        detail = f"new calibration from {len(frames)} frames (stale since {stale:.3f}s)"
        if "rotation_deg" in s and "translation_mm" in s:
            detail += f", sigma {s['rotation_deg']:.3f} deg, {s['translation_mm']:.2f} mm"
        detail += unit_note
        for hook in self.on_commit:
            hook(self.T_base_cam, frames, self.version)
        return "recalibrated", detail


def _history(files: WatchFiles) -> History | None:
    """The versions' history of ``files``; None without a ``history_path``."""
    if files.history_path is None and files.current_path is not None:  # else it would silently never be written
        raise ValueError(
            f"the current calibration ({files.current_path}) is published from a history: give history_path"
        )
    return None if files.history_path is None else History(files.history_path, files.current_path)


def _start_correction(depth_correction: tuple | None, latest, version: int | None) -> tuple:
    """The depth correction ``(k, c)`` started with: the one given, else the version in use's own (as a rollback's,
    ``_follow_history``), else ``(1, 0)``."""
    if depth_correction is None:
        started = latest if latest is not None and latest.version == version else None
        depth_correction = (1.0, 0.0) if started is None else _recorded_correction(started)
    return tuple(float(v) for v in depth_correction)


def _thinned(robot_surface, factor: float):
    """The surface the check poses: thinned by ``factor ** 2`` where it can be and ``factor > 1``."""
    thin = getattr(robot_surface, "thinned", None)
    return thin(factor**2) if factor > 1 and thin is not None else robot_surface


def _recorded_correction(version, default: tuple = (1.0, 0.0)) -> tuple:
    """A history version's depth correction ``(k, c)`` (``depth_correction_k_c_m``), else ``default``."""
    correction = version.extra.get("depth_correction_k_c_m")
    return default if correction is None else tuple(float(v) for v in correction)
