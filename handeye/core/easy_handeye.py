"""easy_handeye (ROS 1) and easy_handeye2 (ROS 2) files: sample lists in, calibrations in and out.

Sample lists (what the calibrator recorded), YAML, translations in metres
(ROS), quaternions ``(x, y, z, w)`` by name. easy_handeye2 saves
``~/.ros2/easy_handeye2/samples/<name>.samples`` (its ``SampleList`` message)::

    parameters: {name: ..., calibration_type: eye_on_base, robot_base_frame: ..., ...}   # often left empty
    samples:
    - robot:    {translation: {x: ..., y: ..., z: ...}, rotation: {x: ..., y: ..., z: ..., w: ...}}
      tracking: {translation: ..., rotation: ...}

easy_handeye (ROS 1) keeps its samples in memory; its ``SampleList`` message,
as ``rosservice call <ns>/get_sample_list`` or ``rostopic echo -n 1`` print it,
holds two lists (top level, or under ``samples:``)::

    hand_world_samples: [{translation: ..., rotation: ...}, ...]
    camera_marker_samples: [{translation: ..., rotation: ...}, ...]

The robot transform is looked up in tf as ``(base, effector)`` for eye-in-hand,
``T_base_ee``, and as ``(effector, base)`` for eye-on-base, ``T_ee_base``; the
tracking (camera-marker) transform is ``(tracking_base, tracking_marker)``,
``T_cam_target``. So a sample list is read for a setup: the file's
``calibration_type`` when it names one (``eye_on_base`` is our ``eye_to_hand``),
else the one the caller gives.

Calibrations: easy_handeye2's ``~/.ros2/easy_handeye2/calibrations/<name>.calib``
(its ``HandeyeCalibration`` message)::

    parameters: {name: ..., calibration_type: eye_on_base, robot_base_frame: base_link, robot_effector_frame: tool0,
                 tracking_base_frame: camera_color_optical_frame, tracking_marker_frame: marker, ...}
    transform: {translation: {x, y, z}, rotation: {x, y, z, w}}

is published by its ``publish.launch.py name:=<name>`` from ``robot_base_frame``
(eye-on-base) or ``robot_effector_frame`` (eye-in-hand) to
``tracking_base_frame``: the transform is ``T_base_cam`` or ``T_ee_cam``, our
``X``. easy_handeye (ROS 1) calibrations (``~/.ros/easy_handeye/<ns>.yaml``,
``parameters`` with ``eye_on_hand`` and a flat ``transformation: {x, y, z, qx,
qy, qz, qw}``) are read too. Needs PyYAML (``handeye[ros]``).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from handeye.core.errors import PoseFileError
from handeye.core.poseset import UNIT_SCALE, PoseSet
from handeye.core.safe_write import write_text_atomic
from handeye.core.se3 import invert_transform, make_transform, matrix_from_quat_xyzw, pos_quat_xyzw_from_transform
from handeye.core.setups import UNKNOWN_NAMES, normalize_setup
from handeye.core.yamlfile import YamlMap, line_of, load_yaml

__all__ = [
    "CALIBRATION_TYPES",
    "DEFAULT_FRAMES",
    "EasyHandeyeCalibration",
    "read_easy_handeye_calibration",
    "read_easy_handeye_samples",
    "write_easy_handeye_calibration",
    "write_easy_handeye_samples",
]

#: easy_handeye's calibration_type for each setup.
CALIBRATION_TYPES = {"eye_to_hand": "eye_on_base", "eye_in_hand": "eye_in_hand"}
#: Frame names used when none are given: the project's (conventions page).
DEFAULT_FRAMES = {"base": "base", "ee": "ee", "cam": "cam", "target": "target"}
#: easy_handeye's parameter holding the tf name of each of the project's frames.
_FRAME_PARAMETERS = {
    "base": "robot_base_frame",
    "ee": "robot_effector_frame",
    "cam": "tracking_base_frame",
    "target": "tracking_marker_frame",
}
_QUAT_NORM_TOL = 1e-3


@dataclass
class EasyHandeyeCalibration:
    """A calibration read from an easy_handeye file.

    Attributes
    ----------
    T_parent_cam : array, shape (4, 4)
        The pose of the camera (``tracking_base_frame``) in the robot frame it
        is published from: ``T_base_cam`` for eye-to-hand (eye-on-base),
        ``T_ee_cam`` for eye-in-hand. Metres.
    setup : {"eye_to_hand", "eye_in_hand"}
    frames : dict
        tf frame names by the project's name: ``base``, ``ee``, ``cam``, ``target``.
    name : str
    source : str
    """

    T_parent_cam: np.ndarray
    setup: str
    frames: dict = field(default_factory=lambda: dict(DEFAULT_FRAMES))
    name: str = ""
    source: str = ""

    @property
    def parent_frame(self) -> str:
        """tf frame the transform is published from (``header.frame_id``)."""
        return self.frames["base" if self.setup == "eye_to_hand" else "ee"]

    @property
    def child_frame(self) -> str:
        """tf frame the transform is published to (``child_frame_id``)."""
        return self.frames["cam"]


# ----------------------------------------------------------------------------------------------- reading


def _where(path: Path, container, key=None) -> str:
    line = line_of(container, key)
    return f"{path}, line {line}" if line else str(path)


def _mapping(path: Path, container, key, what: str) -> YamlMap:
    value = container.get(key) if isinstance(container, dict) else None
    if not isinstance(value, dict):
        raise PoseFileError(f"{_where(path, container, key)}: {what} needs a mapping '{key}'")
    return value


def _number(path: Path, container, key, what: str) -> float:
    value = container.get(key) if isinstance(container, dict) else None
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        found = "missing" if value is None else f"{value!r} is not a number"
        raise PoseFileError(f"{_where(path, container, key)}: {what}.{key} {found}")
    if not np.isfinite(value):
        raise PoseFileError(f"{_where(path, container, key)}: {what}.{key} = {value} is not finite")
    return float(value)


def _pose(path: Path, t_xyz, q_xyzw, where: str) -> np.ndarray:
    q = np.asarray(q_xyzw, dtype=float)
    norm = float(np.linalg.norm(q))
    if abs(norm - 1.0) > _QUAT_NORM_TOL:
        raise PoseFileError(f"{where}: quaternion (x, y, z, w) {np.round(q, 4).tolist()} has norm {norm:.4f}, not 1")
    return make_transform(matrix_from_quat_xyzw(q), np.asarray(t_xyz, dtype=float))


def _transform(path: Path, container, key, label: str) -> np.ndarray:
    """``container[key]``, a ``geometry_msgs/Transform`` (``translation: {x, y, z}``, ``rotation: {x, y, z, w}``).

    ``label`` names it in messages (``samples[3].robot``).
    """
    msg = container[key] if isinstance(container, (dict, list)) else None
    if not isinstance(msg, dict):
        raise PoseFileError(
            f"{_where(path, container, key)}: {label} must be a transform "
            f"(translation: {{x, y, z}}, rotation: {{x, y, z, w}})"
        )
    t_map = _mapping(path, msg, "translation", label)
    r_map = _mapping(path, msg, "rotation", label)
    t = [_number(path, t_map, c, f"{label}.translation") for c in "xyz"]
    q = [_number(path, r_map, c, f"{label}.rotation") for c in "xyzw"]
    return _pose(path, t, q, f"{_where(path, container, key)}, {label}")


def _setup_of(path: Path, params, given: str | None) -> str:
    """The setup the file states (``calibration_type`` or ``eye_on_hand``), checked against the one given."""
    stated, key = None, None
    if isinstance(params, dict):
        if params.get("calibration_type"):
            key = "calibration_type"
            kind = params[key]
            stated = {v: k for k, v in CALIBRATION_TYPES.items()}.get(kind)
            if stated is None:
                raise PoseFileError(
                    f"{_where(path, params, key)}: calibration_type {kind!r} is neither "
                    f"{' nor '.join(map(repr, CALIBRATION_TYPES.values()))}"
                )
        elif isinstance(params.get("eye_on_hand"), bool):
            key = "eye_on_hand"
            stated = "eye_in_hand" if params[key] else "eye_to_hand"
    given = normalize_setup(given) if given is not None else None
    if stated is None and given is None:
        raise PoseFileError(
            f"{path}: the file does not say whether it is eye-in-hand or eye-on-base (its robot "
            f"transforms differ); give the setup (--setup)"
        )
    if stated is not None and given is not None and stated != given:
        raise PoseFileError(
            f"{_where(path, params, key)}: the file says {key}: {params[key]} "
            f"({stated.replace('_', '-')}), but the setup given is {given.replace('_', '-')}"
        )
    return stated or given


def _frames_of(params) -> dict:
    """Frame names the parameters give (non-empty ones), by the project's name."""
    if not isinstance(params, dict):
        return {}
    return {ours: str(params[theirs]).lstrip("/") for ours, theirs in _FRAME_PARAMETERS.items() if params.get(theirs)}


def _sample_lists(path: Path, doc) -> list[tuple]:
    """Per sample ``(line, (container, key, label) of the robot transform, the same of the tracking one)``."""
    if isinstance(doc, dict) and isinstance(doc.get("samples"), dict):
        doc = doc["samples"]  # the ROS 1 service response: samples: {hand_world_samples, camera_marker_samples}
    if isinstance(doc, dict) and ("hand_world_samples" in doc or "camera_marker_samples" in doc):
        hand = doc.get("hand_world_samples")
        cam = doc.get("camera_marker_samples")
        for key, value in (("hand_world_samples", hand), ("camera_marker_samples", cam)):
            if not isinstance(value, list):
                raise PoseFileError(f"{_where(path, doc, key)}: '{key}' must be a list of transforms")
        if len(hand) != len(cam):
            raise PoseFileError(
                f"{_where(path, doc, 'camera_marker_samples')}: {len(cam)} camera_marker_samples "
                f"but {len(hand)} hand_world_samples; they are paired by index"
            )
        return [
            (line_of(hand, k), (hand, k, f"hand_world_samples[{k}]"), (cam, k, f"camera_marker_samples[{k}]"))
            for k in range(len(hand))
        ]
    if isinstance(doc, dict) and isinstance(doc.get("samples"), list):
        samples = doc["samples"]
        for k, s in enumerate(samples):
            if not isinstance(s, dict):
                raise PoseFileError(f"{_where(path, samples, k)}: samples[{k}] must hold 'robot' and 'tracking'")
        return [
            (line_of(samples, k), (s, "robot", f"samples[{k}].robot"), (s, "tracking", f"samples[{k}].tracking"))
            for k, s in enumerate(samples)
        ]
    raise PoseFileError(
        f"{_where(path, doc)}: not an easy_handeye sample list: expected 'samples' (easy_handeye2: "
        f"a list of robot/tracking transforms) or 'hand_world_samples' and 'camera_marker_samples' "
        f"(easy_handeye)"
    )


def read_easy_handeye_samples(path: str | Path, setup: str | None = None, units: str | None = None) -> PoseSet:
    """Read an easy_handeye or easy_handeye2 sample list into paired poses.

    Parameters
    ----------
    path : str or Path
        YAML (formats in this module's docstring).
    setup : {"eye_to_hand", "eye_in_hand"}, optional
        Needed when the file does not name its ``calibration_type`` (easy_handeye
        files never do, easy_handeye2's often leave it empty); refused when it
        contradicts the file.
    units : {"m", "mm"}, optional
        Translation units; default metres (ROS).

    Returns
    -------
    PoseSet
        ``T_base_ee`` and ``T_cam_target``, shape ``(N, 4, 4)`` each, metres;
        ``rows`` the line of each sample; ``frames`` the tf names the file gives.

    Raises
    ------
    PoseFileError
        Naming the file and line: not YAML, not a sample list, a missing or
        non-numeric field, a quaternion that is not unit, lists of different
        lengths, no samples, no setup.
    """
    path = Path(path)
    if units is not None and units not in UNIT_SCALE:
        raise PoseFileError(f"units {units!r} not understood; use 'm' or 'mm'")
    doc = load_yaml(path)
    samples = _sample_lists(path, doc)
    params = doc.get("parameters") if isinstance(doc, dict) else None
    setup = _setup_of(path, params, setup)
    if not samples:
        raise PoseFileError(f"{_where(path, doc)}: the sample list is empty")
    robot = np.array([_transform(path, *robot_at) for _, robot_at, _ in samples])
    tracking = np.array([_transform(path, *tracking_at) for _, _, tracking_at in samples])
    rows = [line for line, _, _ in samples]
    scale = UNIT_SCALE[units or "m"]
    robot[:, :3, 3] *= scale
    tracking[:, :3, 3] *= scale
    # eye-on-base samples hold T_ee_base (easy_handeye looks up (effector, base) to feed OpenCV)
    T_base_ee = robot if setup == "eye_in_hand" else invert_transform(robot)
    return PoseSet(T_base_ee, tracking, str(path), rows, _frames_of(params))


def read_easy_handeye_calibration(path: str | Path) -> EasyHandeyeCalibration:
    """Read an easy_handeye2 ``.calib`` or an easy_handeye (ROS 1) calibration YAML.

    Parameters
    ----------
    path : str or Path

    Returns
    -------
    EasyHandeyeCalibration

    Raises
    ------
    PoseFileError
        Naming the file and line.
    """
    path = Path(path)
    doc = load_yaml(path)
    params = _mapping(path, doc, "parameters", "an easy_handeye calibration") if isinstance(doc, dict) else None
    if params is None:
        raise PoseFileError(
            f"{_where(path, doc)}: not an easy_handeye calibration: expected 'parameters' and "
            f"'transform' (easy_handeye2) or 'transformation' (easy_handeye)"
        )
    setup = _setup_of(path, params, None)
    if "transform" in doc:
        T = _transform(path, doc, "transform", "transform")
    elif "transformation" in doc:
        flat = _mapping(path, doc, "transformation", "a calibration")
        T = _pose(
            path,
            [_number(path, flat, c, "transformation") for c in "xyz"],
            [_number(path, flat, f"q{c}", "transformation") for c in "xyzw"],
            _where(path, doc, "transformation"),
        )
    else:
        raise PoseFileError(f"{_where(path, doc)}: no 'transform' (easy_handeye2) or 'transformation' (easy_handeye)")
    name = params.get("name") or str(params.get("namespace") or "").strip("/").split("/")[-1]
    return EasyHandeyeCalibration(T, setup, {**DEFAULT_FRAMES, **_frames_of(params)}, str(name or path.stem), str(path))


# ----------------------------------------------------------------------------------------------- writing


def _check_frames(frames: dict | None) -> dict:
    out = dict(DEFAULT_FRAMES)
    for key, value in (frames or {}).items():
        if key not in DEFAULT_FRAMES:
            raise ValueError(f"unknown frame {key!r}; frames are named {', '.join(DEFAULT_FRAMES)}")
        out[key] = str(value)
    for key, value in out.items():
        if not value or any(c.isspace() for c in value):
            raise PoseFileError(f"frame name {value!r} (for {key}) must be non-empty, without spaces")
    return out


def _transform_dict(T: np.ndarray) -> dict:
    t, q = pos_quat_xyzw_from_transform(np.asarray(T, dtype=float))
    return {
        "translation": {c: float(v) for c, v in zip("xyz", t)},
        "rotation": {c: float(v) for c, v in zip("xyzw", q)},
    }


def _parameters(setup: str, frames: dict, name: str) -> dict:
    return {
        "name": name,
        "calibration_type": CALIBRATION_TYPES[setup],
        **{theirs: frames[ours] for ours, theirs in _FRAME_PARAMETERS.items()},
        "freehand_robot_movement": True,
        "move_group_namespace": "/",
        "move_group": "manipulator",
    }


def _dump(path: Path, header: str, doc: dict) -> None:
    from handeye.core.optional import require_package

    yaml = require_package("yaml", extra="ros", purpose="writing easy_handeye files")
    text = yaml.safe_dump(doc, sort_keys=False, default_flow_style=False, allow_unicode=True)
    write_text_atomic(path, "".join(f"# {line}\n" for line in header.splitlines()) + text)


def write_easy_handeye_calibration(
    path: str | Path, T_parent_cam: np.ndarray, setup: str, frames: dict | None = None, name: str | None = None
) -> None:
    """Write an easy_handeye2 calibration (``HandeyeCalibration`` as YAML, a ``.calib`` file).

    Parameters
    ----------
    path : str or Path
        easy_handeye2 publishes ``~/.ros2/easy_handeye2/calibrations/<name>.calib``
        with ``ros2 launch easy_handeye2 publish.launch.py name:=<name>``.
    T_parent_cam : array, shape (4, 4)
        ``T_base_cam`` (eye-to-hand) or ``T_ee_cam`` (eye-in-hand), metres.
    setup : {"eye_to_hand", "eye_in_hand"}
        Written as ``calibration_type`` ``eye_on_base`` or ``eye_in_hand``.
    frames : dict, optional
        tf names by the project's frame name (``base``, ``ee``, ``cam``,
        ``target``); missing ones default to the project's names.
    name : str, optional
        The calibration's name; default the file name without its suffix.
    """
    setup = normalize_setup(setup)
    frames = _check_frames(frames)
    name = name or Path(path).stem
    x_name = UNKNOWN_NAMES[setup][0]
    parent = frames["base" if setup == "eye_to_hand" else "ee"]
    header = (
        f"easy_handeye2 calibration written by handeye: transform = {x_name}, the pose of\n"
        f"'{frames['cam']}' in '{parent}' (metres, quaternion x y z w)"
    )
    doc = {"parameters": _parameters(setup, frames, name), "transform": _transform_dict(T_parent_cam)}
    _dump(Path(path), header, doc)


def write_easy_handeye_samples(
    path: str | Path,
    T_base_ee: np.ndarray,
    T_cam_target: np.ndarray,
    setup: str,
    frames: dict | None = None,
    name: str | None = None,
    ros: int = 2,
) -> None:
    """Write paired poses as an easy_handeye2 (``ros=2``) or easy_handeye (``ros=1``) sample list.

    Parameters
    ----------
    path : str or Path
    T_base_ee, T_cam_target : array, shape (N, 4, 4)
        Metres. Eye-to-hand samples store ``T_ee_base``, as easy_handeye does.
    setup : {"eye_to_hand", "eye_in_hand"}
    frames : dict, optional
        tf names (``ros=2`` only: ROS 1 sample lists have no parameters).
    name : str, optional
        Default the file name without its suffix.
    ros : {1, 2}
    """
    setup = normalize_setup(setup)
    T_base_ee = np.asarray(T_base_ee, dtype=float).reshape(-1, 4, 4)
    T_cam_target = np.asarray(T_cam_target, dtype=float).reshape(-1, 4, 4)
    robot = T_base_ee if setup == "eye_in_hand" else invert_transform(T_base_ee)
    robot_name = "T_base_ee" if setup == "eye_in_hand" else "T_ee_base"
    header = (
        f"easy_handeye{'2' if ros == 2 else ''} sample list written by handeye: robot = {robot_name}, "
        f"tracking = T_cam_target (metres, quaternion x y z w)"
    )
    if ros == 1:
        doc = {
            "hand_world_samples": [_transform_dict(T) for T in robot],
            "camera_marker_samples": [_transform_dict(T) for T in T_cam_target],
        }
    elif ros == 2:
        doc = {
            "parameters": _parameters(setup, _check_frames(frames), name or Path(path).stem),
            "samples": [
                {"robot": _transform_dict(A), "tracking": _transform_dict(B)} for A, B in zip(robot, T_cam_target)
            ],
        }
    else:
        raise ValueError(f"ros must be 1 or 2, got {ros!r}")
    _dump(Path(path), header, doc)
