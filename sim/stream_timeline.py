"""A stream preset turned into per-frame truth: joints, camera pose, occluder, light, lost depth, events.

Frame ``k`` is at ``t = k / rate_hz``; an event stated at ``t_s`` takes effect at the first frame at or after
it, ``ceil(t_s rate_hz)``, and the event list records that frame and its time. Everything is drawn from the
stream's seed, so the same preset and seed give the same timeline.

The arm works: it moves between joint configurations drawn as the data recording draws them
(:func:`sim.recording.sample_data_configuration`: the arm above the floor, the tool in the first placement's
image), along a minimum-jerk profile in joint space (the wrist and base joints the short way round) at
``joint_speed_rad_s`` for the joint that moves most, pausing ``dwell_s`` at each.

The camera: its first placement looks at ``look_at_m`` from the preset's azimuth, elevation and distance.
A bump composes a rigid motion in the camera frame, ``T_base_cam <- T_base_cam @ dT_cam``, with the stated
rotation about a seeded axis through the optical centre and the stated translation in a seeded direction, so
``inv(T_before) @ T_after = dT_cam`` exactly. Drift adds ``rate * step_s`` along ``direction_base`` (base frame)
at every step. Each bump and each drift step starts a new segment (one shard of the dataset).

An occluder crosses the line of sight from the camera to the tool sideways (horizontally, perpendicular to
it) at half the distance, 2 m in its duration, and is on that line at the occlusion's middle frame.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from handeye.core.errors import HandEyeInputError
from handeye.core.se3 import make_transform, so3_exp
from sim.cameras import camera_on_sphere
from sim.recording import camera_matrix, sample_data_configuration
from sim.stream_events import OCCLUDER_SHAPES, PERSON_HEIGHT_M, StreamPreset

__all__ = ["Timeline", "build_timeline", "frame_at", "first_placement", "OCCLUDER_SWEEP_M", "WRAPPED_JOINTS"]

#: How far an occluder travels across the line of sight during its occlusion, metres.
OCCLUDER_SWEEP_M = 2.0
#: Joints that turn freely (UR base and wrists): moved the short way round.
WRAPPED_JOINTS = (0, 3, 4, 5)
#: Shortest move between work configurations, seconds.
MIN_MOVE_S = 0.5


def frame_at(t_s: float, rate_hz: float) -> int:
    """The first frame at or after ``t_s``: ``ceil(t_s rate_hz)`` (a hair of rounding forgiven)."""
    return int(math.ceil(t_s * rate_hz - 1e-9))


def first_placement(preset: StreamPreset) -> np.ndarray:
    """``T_base_cam`` of the camera before any bump or drift, shape (4, 4)."""
    return camera_on_sphere(preset.look_at_m, preset.azimuth_deg, preset.elevation_deg, preset.radius_m)


@dataclass
class Timeline:
    """Per-frame truth of a stream.

    Attributes
    ----------
    rate_hz : float
    q : array, shape (N, nq)
        True joint angles, radians (what is rendered).
    q_recorded : array, shape (N, nq)
        The encoders' readings (with the preset's joint noise): what the dataset records.
    segment : array of int, shape (N,)
        Segment (camera id of the dataset) of each frame.
    segment_first : array of int, shape (S,)
        First frame of each segment.
    T_base_cam : array, shape (S, 4, 4)
        The camera's pose in each segment.
    light : array, shape (N,)
        Light intensity relative to the start.
    depth_lost : array of bool, shape (N,)
    occluder : array of int, shape (N,)
        Index into :data:`sim.stream_events.OCCLUDER_SHAPES`, -1 for none.
    T_base_occluder : array, shape (N, 4, 4)
        The occluder's pose (identity where none).
    events : list of dict
        In frame order (``stream.json``'s event list).
    occlusions : list of dict
        One per occlusion: ``occlusion``, ``shape``, ``first_frame``, ``end_frame``, ``mid_frame``.
    """

    rate_hz: float
    q: np.ndarray
    q_recorded: np.ndarray
    segment: np.ndarray
    segment_first: np.ndarray
    T_base_cam: np.ndarray
    light: np.ndarray
    depth_lost: np.ndarray
    occluder: np.ndarray
    T_base_occluder: np.ndarray
    events: list = field(default_factory=list)
    occlusions: list = field(default_factory=list)

    def __len__(self) -> int:
        return len(self.q)


def _starts(t_s: float, every_s: float | None, end_s: float) -> list[float]:
    """Start times of a possibly repeated event before ``end_s``."""
    if every_s is None:
        return [t_s] if t_s < end_s else []
    return list(np.arange(t_s, end_s, every_s))


def _arm_path(robot, preset: StreamPreset, T_base_cam: np.ndarray, n: int, rng: np.random.Generator) -> np.ndarray:
    """Joint angles of ``n`` frames: minimum-jerk moves between drawn work configurations, with pauses."""
    K = camera_matrix(*preset.image_size, preset.fov_deg)
    t = np.arange(n) / preset.rate_hz
    q = np.empty((n, robot.nq))
    q_a = sample_data_configuration(robot, T_base_cam, K, preset.image_size, rng)
    t0, k = 0.0, 0
    while k < n:
        q_b = sample_data_configuration(robot, T_base_cam, K, preset.image_size, rng)
        d = q_b - q_a
        wrap = [j for j in WRAPPED_JOINTS if j < robot.nq]
        d[wrap] = (d[wrap] + np.pi) % (2 * np.pi) - np.pi
        move_s = max(np.abs(d).max() / preset.joint_speed_rad_s, MIN_MOVE_S)
        while k < n and t[k] < t0 + move_s + preset.dwell_s:
            u = min((t[k] - t0) / move_s, 1.0)
            q[k] = q_a + d * (10 * u**3 - 15 * u**4 + 6 * u**5)
            k += 1
        q_a, t0 = q_a + d, t0 + move_s + preset.dwell_s
    return q


def _bump_motion(bump, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``dT_cam`` of a bump, its translation (m) and rotation vector (rad), directions drawn, sizes stated."""
    direction = rng.normal(size=3)
    axis = rng.normal(size=3)
    translation = direction / np.linalg.norm(direction) * bump.translation_mm * 1e-3
    rotvec = axis / np.linalg.norm(axis) * np.radians(bump.rotation_deg)
    return make_transform(so3_exp(rotvec), translation), translation, rotvec


def _camera(preset: StreamPreset, n: int, seed: int) -> tuple[list, list, list]:
    """Segment first frames, the camera per segment and the bump and drift events."""
    rate, end_s = preset.rate_hz, n / preset.rate_hz
    rng = np.random.default_rng([seed, 3])
    changes = {}  # frame -> list of ("bump", bump, dT, t, r) / ("drift", step)
    for bump in preset.bumps:
        motion = _bump_motion(bump, rng)  # drawn for every bump, in the stream or not, so sizes don't shift draws
        k = frame_at(bump.t_s, rate)
        if 0 < k < n:
            if k in changes:
                raise HandEyeInputError(f"two bumps take effect at frame {k} (t = {k / rate:g} s); space them")
            changes[k] = [("bump", bump, *motion)]
    drift = preset.drift
    if drift is not None and drift.rate_mm_per_min > 0:
        for j, t_s in enumerate(_starts(drift.step_s, drift.step_s, end_s), start=1):
            k = frame_at(t_s, rate)
            if k in changes:
                raise HandEyeInputError(
                    f"a bump and a drift step both at frame {k} (t = {k / rate:g} s); move the bump off the "
                    f"drift's {drift.step_s:g} s steps"
                )
            if k < n:
                changes[k] = [("drift", j)]
    T_bumped = first_placement(preset)
    firsts, poses, events = [0], [T_bumped], []
    drift_step_m = 0.0 if drift is None else drift.rate_mm_per_min * drift.step_s / 60.0 * 1e-3
    direction = np.zeros(3) if drift is None else np.asarray(drift.direction_base, float)
    direction = direction / max(np.linalg.norm(direction), 1e-300)
    steps = 0
    for k in sorted(changes):
        kind, *rest = changes[k][0]
        segment = len(firsts)
        common = {"t_s": k / rate, "frame": k, "segment": segment}
        if kind == "bump":
            bump, dT, translation, rotvec = rest
            T_bumped = T_bumped @ dT
            events.append(
                {
                    "type": "bump",
                    "label": bump.label,
                    **common,
                    "stated_t_s": bump.t_s,
                    "translation_mm": bump.translation_mm,
                    "rotation_deg": bump.rotation_deg,
                    "translation_cam_m": translation.tolist(),
                    "rotvec_cam_rad": rotvec.tolist(),
                }
            )
        else:
            steps = rest[0]
            events.append(
                {
                    "type": "drift",
                    **common,
                    "translation_mm": drift_step_m * 1e3,
                    "total_mm": steps * drift_step_m * 1e3,
                    "direction_base": direction.tolist(),
                }
            )
        T = T_bumped.copy()
        T[:3, 3] += steps * drift_step_m * direction
        firsts.append(k)
        poses.append(T)
    return firsts, poses, events


def _intervals(preset: StreamPreset, n: int) -> tuple[np.ndarray, np.ndarray, list]:
    """Light per frame, lost depth per frame, and the lighting and dropout events."""
    rate, end_s = preset.rate_hz, n / preset.rate_hz
    light, lost, events = np.ones(n), np.zeros(n, bool), []
    changes = []  # (frame, factor)
    for change in preset.lighting:
        for t_s in _starts(change.t_s, change.every_s, end_s):
            changes.append((frame_at(t_s, rate), change.factor))
            if change.duration_s is not None:
                changes.append((frame_at(t_s + change.duration_s, rate), 1.0))
    for k, factor in sorted(changes):
        if k < n:
            light[k:] = factor
            events.append({"type": "lighting", "t_s": k / rate, "frame": k, "factor": factor})
    for dropout in preset.dropouts:
        for t_s in _starts(dropout.t_s, dropout.every_s, end_s):
            k0, k1 = frame_at(t_s, rate), min(frame_at(t_s + dropout.duration_s, rate), n)
            if k0 < k1:
                lost[k0:k1] = True
                events.append({"type": "dropout", "t_s": k0 / rate, "frame": k0, "end_frame": k1, "end_t_s": k1 / rate})
    return light, lost, events


def _occluders(preset, n: int, q: np.ndarray, robot, segment: np.ndarray, T_base_cam: np.ndarray):
    """Occluder shape and pose per frame, the occlusion events and the occlusions' frames."""
    rate, end_s = preset.rate_hz, n / preset.rate_hz
    shape_of = np.full(n, -1)
    T_occ = np.tile(np.eye(4), (n, 1, 1))
    starts = sorted((t_s, o) for o in preset.occlusions for t_s in _starts(o.t_s, o.every_s, end_s))
    events, occlusions = [], []
    for t_s, o in starts:
        k0, k1 = frame_at(t_s, rate), min(frame_at(t_s + o.duration_s, rate), n)
        if k0 >= k1:
            continue
        if (shape_of[k0:k1] >= 0).any():
            raise HandEyeInputError(f"occlusions overlap at t = {t_s:g} s; one occluder at a time")
        i = len(occlusions)
        mid = (k0 + k1 - 1) // 2
        camera = T_base_cam[segment[mid]][:3, 3]
        tool = robot.fk_ref(q[mid])[:3, 3]
        centre = camera + 0.5 * (tool - camera)
        side = np.cross([0.0, 0.0, 1.0], tool - camera)
        side /= np.linalg.norm(side)
        speed = OCCLUDER_SWEEP_M / o.duration_s
        for k in range(k0, k1):
            c = centre + side * speed * (k - mid) / rate
            if o.shape == "person":  # stands on the floor: the cylinder's centre at half its height
                c = np.array([c[0], c[1], PERSON_HEIGHT_M / 2])
            T_occ[k, :3, 3] = c
        shape_of[k0:k1] = OCCLUDER_SHAPES.index(o.shape)
        occlusions.append({"occlusion": i, "shape": o.shape, "first_frame": k0, "end_frame": k1, "mid_frame": mid})
        common = {"occlusion": i, "shape": o.shape}
        events.append({"type": "occlusion_start", "t_s": k0 / rate, "frame": k0, "mid_frame": mid, **common})
        events.append({"type": "occlusion_end", "t_s": k1 / rate, "frame": k1, **common})
    return shape_of, T_occ, events, occlusions


def build_timeline(preset: StreamPreset, seed: int, robot) -> Timeline:
    """Per-frame truth of a stream preset.

    Parameters
    ----------
    preset : StreamPreset
    seed : int
    robot : handeye.robot.model.Robot
        The preset's robot.

    Returns
    -------
    Timeline

    Raises
    ------
    HandEyeInputError
        Two bumps, or a bump and a drift step, at one frame; overlapping occlusions.
    """
    n = preset.n_frames
    firsts, poses, camera_events = _camera(preset, n, seed)
    segment = np.searchsorted(np.asarray(firsts), np.arange(n), side="right") - 1
    T_base_cam = np.array(poses)
    q = _arm_path(robot, preset, T_base_cam[0], n, np.random.default_rng([seed, 0]))
    q_recorded = q + np.random.default_rng([seed, 4]).normal(scale=np.radians(preset.joint_sigma_deg), size=q.shape)
    light, lost, interval_events = _intervals(preset, n)
    occluder, T_occ, occlusion_events, occlusions = _occluders(preset, n, q, robot, segment, T_base_cam)
    events = sorted(camera_events + interval_events + occlusion_events, key=lambda e: (e["frame"], e["type"]))
    return Timeline(
        preset.rate_hz,
        q,
        q_recorded,
        segment,
        np.asarray(firsts),
        T_base_cam,
        light,
        lost,
        occluder,
        T_occ,
        events,
        occlusions,
    )
