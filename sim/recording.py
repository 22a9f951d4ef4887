"""What the robot does in front of each camera: board views for calibration, configurations for data.

Calibration recording: the ChArUco board replaces the tool on the flange
(``T_ee_target``); each view places the board in front of the camera, tilted
15-40 degrees from facing it about a random axis and turned in its plane (the
rotation diversity the solvers' diagnostics ask for), reached by inverse
kinematics, with every part of the arm above the floor and the whole board in
the image. Whether the arm hides part of the board is checked on the rendered
depth by the generator.

Data recording: joint configurations drawn over the workspace (the arm above
the floor, the tool in front of the camera).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from handeye.core.errors import HandEyeInputError
from handeye.core.se3 import invert_transform, make_transform, so3_exp
from handeye.robot.model import IK_SEEDS

__all__ = [
    "DEFAULT_BOARD",
    "board_mount",
    "camera_matrix",
    "CalibrationView",
    "sample_calibration_view",
    "sample_data_configuration",
    "in_image",
]

#: The calibration board: 7 x 5 squares of 6 cm (42 x 30 cm), 4.5 cm markers of ArUco 4x4.
DEFAULT_BOARD = dict(squares_x=7, squares_y=5, square_length_m=0.06, marker_length_m=0.045, dictionary="4X4_50")
#: Gap between the flange face and the board's printed face, metres.
BOARD_STANDOFF_M = 0.01


def board_mount(size_m: tuple[float, float], standoff_m: float = BOARD_STANDOFF_M) -> np.ndarray:
    """``T_ee_target`` of a board centred on the flange axis, facing out along the flange's z.

    The target frame (OpenCV board frame: origin at the top-left corner, x
    along columns, y down the rows, z into the board) has its z against the
    flange's z, so the printed face looks away from the robot.

    Parameters
    ----------
    size_m : (float, float)
        Board width and height, metres.
    standoff_m : float

    Returns
    -------
    T_ee_target : array, shape (4, 4)
    """
    w, h = size_m
    R = np.diag([1.0, -1.0, -1.0])
    centre_ee = np.array([0.0, 0.0, standoff_m])
    return make_transform(R, centre_ee - R @ np.array([w / 2, h / 2, 0.0]))


def camera_matrix(width: int, height: int, fov_deg: float) -> np.ndarray:
    """Pinhole ``K`` (OpenCV, pixel centres at integers) with a horizontal field of view, square pixels.

    Parameters
    ----------
    width, height : int
    fov_deg : float

    Returns
    -------
    K : array, shape (3, 3)
    """
    if not 1.0 < fov_deg < 179.0:
        raise HandEyeInputError(f"field of view {fov_deg} deg: use 1 to 179 degrees")
    f = (width / 2) / np.tan(np.radians(fov_deg) / 2)
    return np.array([[f, 0.0, (width - 1) / 2], [0.0, f, (height - 1) / 2], [0.0, 0.0, 1.0]])


def in_image(p_cam: np.ndarray, K: np.ndarray, width: int, height: int, margin_px: float = 0.0) -> np.ndarray:
    """Whether camera-frame points lie in front of the camera and inside the image by a margin.

    Parameters
    ----------
    p_cam : array, shape (N, 3)
    K : array, shape (3, 3)
    width, height : int
    margin_px : float

    Returns
    -------
    array of bool, shape (N,)
    """
    z = p_cam[:, 2]
    with np.errstate(divide="ignore", invalid="ignore"):
        u = K[0, 0] * p_cam[:, 0] / z + K[0, 2]
        v = K[1, 1] * p_cam[:, 1] / z + K[1, 2]
    return (
        (z > 0.05)
        & (u >= margin_px - 0.5)
        & (u <= width - 0.5 - margin_px)
        & (v >= margin_px - 0.5)
        & (v <= height - 0.5 - margin_px)
    )


def _above_floor(robot, q: np.ndarray, min_z_m: float) -> bool:
    """Every joint origin and the flange above the floor."""
    pin = robot.pin
    pin.forwardKinematics(robot.model, robot.data, q)
    z = [robot.data.oMi[j].translation[2] for j in range(2, robot.model.njoints)]
    return min(z) > min_z_m


@dataclass
class CalibrationView:
    """One planned board view: joints and the board pose they give."""

    q: np.ndarray
    T_base_ee: np.ndarray
    T_base_target: np.ndarray


def sample_calibration_view(
    robot,
    T_base_cam: np.ndarray,
    K: np.ndarray,
    size: tuple[int, int],
    T_ee_target: np.ndarray,
    board_size_m: tuple[float, float],
    rng: np.random.Generator,
    max_tries: int = 200,
) -> CalibrationView:
    """Draw a reachable board pose in front of the camera, fully in the image.

    Parameters
    ----------
    robot : handeye.robot.model.Robot
    T_base_cam : array, shape (4, 4)
    K : array, shape (3, 3)
    size : (int, int)
        Image ``(width, height)``.
    T_ee_target : array, shape (4, 4)
    board_size_m : (float, float)
    rng : numpy.random.Generator
    max_tries : int

    Returns
    -------
    CalibrationView

    Raises
    ------
    HandEyeInputError
        When no pose was found in ``max_tries`` draws (the camera sees too little of the workspace).
    """
    w, h = board_size_m
    outline = np.array([[0, 0, 0, 1], [w, 0, 0, 1], [w, h, 0, 1], [0, h, 0, 1]], dtype=float)
    cam = T_base_cam[:3, 3]
    T_cam_base = invert_transform(T_base_cam)
    T_target_ee = invert_transform(T_ee_target)
    shoulder = robot.shoulder_m
    reach = robot.reach_m
    toward = cam[:2] / np.linalg.norm(cam[:2])
    for _ in range(max_tries):
        # board centre: in front of the robot on the camera's side, 0.2-0.65 m up
        lateral = np.array([-toward[1], toward[0]])
        xy = toward * rng.uniform(0.15, 0.55) * reach + lateral * rng.uniform(-0.4, 0.4) * reach
        centre = np.array([xy[0], xy[1], rng.uniform(0.2, 0.65)])
        n0 = (cam - centre) / np.linalg.norm(cam - centre)  # printed face towards the camera
        axis = np.cross(n0, rng.normal(size=3))
        axis /= np.linalg.norm(axis)
        n = so3_exp(axis * np.radians(rng.uniform(15.0, 40.0))) @ n0
        z = -n  # target z points into the board
        x = np.cross([0.0, 0.0, 1.0], z)
        x /= np.linalg.norm(x)
        x = so3_exp(z * rng.uniform(-np.pi / 3, np.pi / 3)) @ x
        R = np.column_stack([x, np.cross(z, x), z])
        T_base_target = make_transform(R, centre - R @ np.array([w / 2, h / 2, 0.0]))
        corners_cam = (T_cam_base @ T_base_target @ outline.T).T[:, :3]
        if not in_image(corners_cam, K, *size, margin_px=0.03 * size[0]).all():
            continue
        T_base_ee = T_base_target @ T_target_ee
        if np.linalg.norm(T_base_ee[:3, 3] - shoulder) > 0.92 * reach:
            continue
        for seed in IK_SEEDS:
            q0 = seed.copy()
            q0[0] = np.arctan2(T_base_ee[1, 3], T_base_ee[0, 3]) + np.pi  # shoulder turned towards the board
            q0[0] = (q0[0] + np.pi) % (2 * np.pi) - np.pi
            q = robot.ik(T_base_ee, q0, tol=1e-9)
            if q is not None and _above_floor(robot, q, 0.05):
                return CalibrationView(q, robot.fk(q), T_base_target)
    raise HandEyeInputError(
        f"no reachable board pose in front of the camera at {np.round(cam, 2).tolist()} in {max_tries} draws"
    )


def sample_data_configuration(
    robot, T_base_cam: np.ndarray, K: np.ndarray, size: tuple[int, int], rng: np.random.Generator, max_tries: int = 500
) -> np.ndarray:
    """Draw joint angles over the workspace: arm above the floor, tool in the image.

    Parameters
    ----------
    robot : handeye.robot.model.Robot
    T_base_cam : array, shape (4, 4)
    K : array, shape (3, 3)
    size : (int, int)
    rng : numpy.random.Generator
    max_tries : int

    Returns
    -------
    q : array, shape (nq,)
    """
    T_cam_base = invert_transform(T_base_cam)
    for _ in range(max_tries):
        q = np.array(
            [
                rng.uniform(-np.pi, np.pi),
                rng.uniform(-2.4, -0.6),
                rng.uniform(-2.4, 2.4),
                rng.uniform(-np.pi, np.pi),
                rng.uniform(-np.pi, np.pi),
                rng.uniform(-np.pi, np.pi),
            ]
        )
        if not _above_floor(robot, q, 0.08):
            continue
        p_ref = (T_cam_base @ robot.fk_ref(q))[:3, 3]
        if in_image(p_ref[None], K, *size, margin_px=0.05 * size[0])[0]:
            return q
    raise HandEyeInputError(f"no robot configuration with the tool in the image in {max_tries} draws")
