"""Where to move next, for a real cell: X and Y to plan with, reachable candidate poses, the plan with joints.

The planning math is :mod:`classic.planning` (greedy choice on the predicted covariance) and
:mod:`classic.target_views` (views the camera sees, the flange poses they need); this module adds what
needs the user's cell:

* **X and Y to plan with** (:func:`unknowns_for_plan`): a calibration of the recorded poses when they
  determine X (three or more poses with rotations about two axes); otherwise guesses. Eye-to-hand the
  camera guess is its position in the base frame, looking at ``look_at`` (default: 0.35 m from the
  base towards the camera, 0.3 m up), and the target sits on the flange facing out along its z; eye-in-hand
  the target guess is its centre in the base frame, lying face up, and the camera sits on the flange
  looking along its z. With some recorded poses but not enough, the unknown that was not guessed is
  fitted to them.
* **Candidates** (:func:`sample_candidates`): views sampled in the camera's field of view
  (:func:`classic.target_views.sample_views`), turned into flange poses through X and Y; for a UR model
  (``handeye.robot.model``), only those the inverse kinematics reaches within the joint limits, with the arm's
  joints, the flange and the target above the floor, keeping the joint targets.
* **The plan** (:func:`plan_next_poses`): :func:`classic.planning.plan_poses` on the candidates.

Not modelled: the arm or the cell hiding the target from the camera, collisions of the board or the
camera with the arm, and the path between poses (each joint target is the inverse kinematics' first
solution from fixed seeds, not the one nearest the previous pose).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, replace

import numpy as np

from classic.noise_model import NoiseModel
from classic.planning import DEFAULT_MIN_GAIN, PlanOptions, PosePlan, plan_poses
from classic.target_views import ViewLimits, flange_poses, sample_views, views_of
from handeye.core.errors import HandEyeInputError
from handeye.core.se3 import invert_transform, make_transform, project_to_so3
from handeye.core.setups import normalize_setup, robot_side_poses

__all__ = [
    "DEFAULT_NOISE",
    "Unknowns",
    "Candidates",
    "PlannedPoses",
    "camera_looking_at",
    "target_on_flange",
    "camera_on_flange",
    "target_on_table",
    "unknowns_for_plan",
    "view_distances",
    "limits_for",
    "sample_candidates",
    "plan_next_poses",
]

#: The noise a plan assumes unless told: a good camera's PnP pose and a UR arm's repeatability, per axis.
DEFAULT_NOISE = NoiseModel(
    camera_rot_rad=np.radians(0.1),
    camera_trans_m=1e-3,
    robot_rot_rad=np.radians(0.01),
    robot_trans_m=0.2e-3,
    name="planning default (camera 0.1 deg / 1 mm, robot 0.01 deg / 0.2 mm per axis)",
)
#: Default point the eye-to-hand camera looks at: this far from the base towards the camera, this high (m).
LOOK_AT_REACH_M, LOOK_AT_HEIGHT_M = 0.35, 0.3
#: Default target offset on the flange (eye-to-hand) and camera offset on the flange (eye-in-hand), metres.
DEFAULT_TARGET_ON_FLANGE_M = (0.0, 0.0, 0.01)
DEFAULT_CAMERA_ON_FLANGE_M = (0.0, 0.08, 0.04)
#: Lowest the arm's joints, the flange and the target may go, metres above the base plane.
MIN_HEIGHT_M = 0.05
#: How far inside the field of view and the tilt limit the views planned from a guess stay, degrees.
GUESS_MARGIN_DEG = 5.0


def camera_looking_at(position_base, look_at_base=None) -> np.ndarray:
    """``T_base_cam`` of a static camera at a position, looking at a point, its x axis horizontal.

    Parameters
    ----------
    position_base : array, shape (3,)
        The camera's position in the base frame, metres.
    look_at_base : array, shape (3,), optional
        What it looks at; default :data:`LOOK_AT_REACH_M` from the base towards the camera, at
        :data:`LOOK_AT_HEIGHT_M`.

    Returns
    -------
    T_base_cam : array, shape (4, 4)
    """
    from handeye.robot.look_at import look_at

    c = np.asarray(position_base, dtype=float)
    return look_at(c, _look_at_point(c, look_at_base))


def _look_at_point(position_base: np.ndarray, look_at_base=None) -> np.ndarray:
    """The point a camera guess looks at (the default of :func:`camera_looking_at`), shape (3,)."""
    c = np.asarray(position_base, dtype=float)
    if look_at_base is None:
        horizontal = np.linalg.norm(c[:2])
        toward = c[:2] / horizontal if horizontal > 1e-9 else np.array([1.0, 0.0])
        look_at_base = np.r_[LOOK_AT_REACH_M * toward, LOOK_AT_HEIGHT_M]
    point = np.asarray(look_at_base, dtype=float)
    if np.linalg.norm(point - c) < 0.1:
        raise HandEyeInputError("the camera guess is within 10 cm of the point it looks at: give --look-at")
    return point


def target_on_flange(position_ee=DEFAULT_TARGET_ON_FLANGE_M) -> np.ndarray:
    """``T_ee_target`` of a board on the flange, its printed face looking out along the flange's z.

    The target's z points into the board (OpenCV), so against the flange's z: ``R = diag(1, -1, -1)``.

    Parameters
    ----------
    position_ee : array, shape (3,)
        The board's centre in the flange frame, metres.

    Returns
    -------
    T_ee_target : array, shape (4, 4)
    """
    return make_transform(np.diag([1.0, -1.0, -1.0]), np.asarray(position_ee, dtype=float))


def camera_on_flange(position_ee=DEFAULT_CAMERA_ON_FLANGE_M) -> np.ndarray:
    """``T_ee_cam`` of a camera on the flange looking along the flange's z (its axes those of the flange).

    Parameters
    ----------
    position_ee : array, shape (3,)
        The camera's optical centre in the flange frame, metres.

    Returns
    -------
    T_ee_cam : array, shape (4, 4)
    """
    return make_transform(np.eye(3), np.asarray(position_ee, dtype=float))


def target_on_table(position_base) -> np.ndarray:
    """``T_base_target`` of a board lying face up: its z (into the board) points down.

    Parameters
    ----------
    position_base : array, shape (3,)
        The board's centre in the base frame, metres.

    Returns
    -------
    T_base_target : array, shape (4, 4)
    """
    return make_transform(np.diag([1.0, -1.0, -1.0]), np.asarray(position_base, dtype=float))


@dataclass
class Unknowns:
    """X and Y to plan with, and where they come from.

    Attributes
    ----------
    X : array, shape (4, 4)
        ``T_base_cam`` (eye-to-hand) or ``T_ee_cam`` (eye-in-hand).
    Y : array, shape (4, 4)
        ``T_ee_target`` (eye-to-hand) or ``T_base_target`` (eye-in-hand).
    source : str
        One line for the user.
    look_distance_m : float or None
        Eye-to-hand camera guess: its distance to the point it looks at.
    guessed : bool
        X or Y is a guess (not a calibration of recorded poses): plan with a margin (:func:`limits_for`).
    """

    X: np.ndarray
    Y: np.ndarray
    source: str
    look_distance_m: float | None = None
    guessed: bool = True


def _mean_pose(T: np.ndarray) -> np.ndarray:
    """Chordal mean of poses, shape (4, 4) from (N, 4, 4)."""
    return make_transform(project_to_so3(T[:, :3, :3].sum(axis=0)), T[:, :3, 3].mean(axis=0))


def unknowns_for_plan(
    setup: str, T_base_ee: np.ndarray, T_cam_target: np.ndarray, camera_guess=None, target_guess=None, look_at=None
) -> Unknowns:
    """X and Y for the planner: calibrated from the recorded poses when they determine X, else guessed.

    Parameters
    ----------
    setup : {"eye_to_hand", "eye_in_hand"}
    T_base_ee, T_cam_target : array, shape (N, 4, 4)
        The poses recorded so far (``N`` may be 0).
    camera_guess : array, shape (3,), optional
        The camera's position: in the base frame eye-to-hand (required unless the poses calibrate),
        in the flange frame eye-in-hand (default :data:`DEFAULT_CAMERA_ON_FLANGE_M`).
    target_guess : array, shape (3,), optional
        The target's centre: in the flange frame eye-to-hand (default :data:`DEFAULT_TARGET_ON_FLANGE_M`),
        in the base frame eye-in-hand (required unless the poses calibrate).
    look_at : array, shape (3,), optional
        Eye-to-hand: the point the camera looks at (:func:`camera_looking_at`).

    Returns
    -------
    Unknowns

    Raises
    ------
    HandEyeInputError
        When neither the poses nor the guesses give X.
    """
    import classic

    setup = normalize_setup(setup)
    T_base_ee = np.asarray(T_base_ee, dtype=float).reshape(-1, 4, 4)
    T_cam_target = np.asarray(T_cam_target, dtype=float).reshape(-1, 4, 4)
    n = len(T_base_ee)
    why = f"{n} recorded poses are too few to calibrate"
    if n >= 3:
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                res = classic.calibrate(T_base_ee, T_cam_target, setup=setup)
            return Unknowns(res.X, res.Y, f"calibration of the {n} recorded poses", guessed=False)
        except HandEyeInputError as exc:
            why = f"the {n} recorded poses do not calibrate ({str(exc).splitlines()[0]})"
    A = robot_side_poses(T_base_ee, setup)
    if setup == "eye_to_hand":
        if camera_guess is None:
            raise HandEyeInputError(f"{why}: give --camera-guess X Y Z (the camera's position in the base frame, m)")
        X = camera_looking_at(camera_guess, look_at)
        d = float(np.linalg.norm(_look_at_point(camera_guess, look_at) - np.asarray(camera_guess, dtype=float)))
        if n:  # Y_i = A_i^-1 X B_i
            return Unknowns(
                X,
                _mean_pose(invert_transform(A) @ X @ T_cam_target),
                f"{why}; camera guess, target fitted to the recorded poses",
                d,
            )
        Y = target_on_flange(DEFAULT_TARGET_ON_FLANGE_M if target_guess is None else target_guess)
        return Unknowns(X, Y, f"{why}; camera guess and target on the flange", d)
    if target_guess is None:
        raise HandEyeInputError(f"{why}: give --target-guess X Y Z (the target's centre in the base frame, m)")
    Y = target_on_table(target_guess)
    if n:  # X_i = A_i Y B_i^-1
        return Unknowns(
            _mean_pose(A @ Y @ invert_transform(T_cam_target)),
            Y,
            f"{why}; target guess, camera fitted to the recorded poses",
        )
    X = camera_on_flange(DEFAULT_CAMERA_ON_FLANGE_M if camera_guess is None else camera_guess)
    return Unknowns(X, Y, f"{why}; target guess and camera on the flange")


def view_distances(setup: str, unknowns: Unknowns, T_cam_target: np.ndarray) -> tuple[float, float]:
    """Default depth range of the planned views, metres.

    The recorded views' range widened by 0.1 m each way when there are recorded poses (the camera sees
    the robot there); else eye-to-hand around the point the camera guess looks at (0.3 m nearer, 0.2 m
    farther, where the default look-at keeps the target within a UR5's reach); else eye-in-hand
    0.3 to 0.6 m above the board.

    Parameters
    ----------
    setup : {"eye_to_hand", "eye_in_hand"}
    unknowns : Unknowns
    T_cam_target : array, shape (N, 4, 4)
        The recorded views (``N`` may be 0).

    Returns
    -------
    (float, float)
    """
    z = np.asarray(T_cam_target, dtype=float).reshape(-1, 4, 4)[:, 2, 3]
    if len(z):
        return max(0.15, float(z.min()) - 0.1), float(z.max()) + 0.1
    if normalize_setup(setup) == "eye_to_hand" and unknowns.look_distance_m is not None:
        return max(0.2, unknowns.look_distance_m - 0.3), unknowns.look_distance_m + 0.2
    return 0.3, 0.6


def limits_for(limits: ViewLimits, unknowns: Unknowns, margin_deg: float = GUESS_MARGIN_DEG) -> ViewLimits:
    """The view limits to sample in: ``limits`` less ``margin_deg`` in angle when X or Y is a guess.

    A guessed camera orientation a few degrees off moves every view by as much in the image: planned at the
    edge of the field of view (where the informative views are), it would fall outside. The margin keeps
    them in view for a guess within ``margin_deg``.

    Parameters
    ----------
    limits : ViewLimits
        The camera's real limits.
    unknowns : Unknowns
    margin_deg : float

    Returns
    -------
    ViewLimits
    """
    if not unknowns.guessed or margin_deg <= 0:
        return limits
    shrink = min(margin_deg, 0.8 * min(limits.half_fov_x_deg, limits.half_fov_y_deg))
    return replace(
        limits,
        half_fov_x_deg=limits.half_fov_x_deg - shrink,
        half_fov_y_deg=limits.half_fov_y_deg - shrink,
        max_tilt_deg=max(limits.max_tilt_deg - margin_deg, 0.0),
    )


@dataclass
class Candidates:
    """Flange poses with the target in view (and reachable, with a robot model).

    Attributes
    ----------
    T_base_ee : array, shape (K, 4, 4)
    T_cam_target : array, shape (K, 4, 4)
        The view expected at each, through the X and Y planned with.
    q : array, shape (K, nq), or None
        Joint targets (radians) when a robot model was given.
    n_sampled : int
        Views sampled before the reachability filter.
    robot : str
        The robot model's name, or ``"none"``.
    """

    T_base_ee: np.ndarray
    T_cam_target: np.ndarray
    q: np.ndarray | None
    n_sampled: int
    robot: str = "none"

    def __len__(self) -> int:
        return len(self.T_base_ee)


def _reach(robot, T_base_ee: np.ndarray, T_base_target: np.ndarray | None, min_height_m: float) -> np.ndarray | None:
    """Joint angles reaching a flange pose with the arm (and a target on the flange) above the floor, or None."""
    from handeye.robot.model import IK_SEEDS

    if T_base_ee[2, 3] < min_height_m or (T_base_target is not None and T_base_target[2, 3] < min_height_m):
        return None
    if np.linalg.norm(T_base_ee[:3, 3] - robot.shoulder_m) > 0.95 * robot.reach_m:
        return None
    for seed in IK_SEEDS:
        q0 = seed.copy()
        q0[0] = (np.arctan2(T_base_ee[1, 3], T_base_ee[0, 3]) + 2 * np.pi) % (2 * np.pi) - np.pi  # face the pose
        q = robot.ik(T_base_ee, q0)
        if q is None:
            continue
        wrapped = (q + np.pi) % (2 * np.pi) - np.pi  # the same arm pose, joints in [-pi, pi)
        if np.all(wrapped >= robot.model.lowerPositionLimit) and np.all(wrapped <= robot.model.upperPositionLimit):
            q = wrapped
        if np.all(robot.keypoints_base(q)[1:-1, 2] > min_height_m):
            return q
    return None


def sample_candidates(
    setup: str,
    unknowns: Unknowns,
    rng: np.random.Generator,
    n_views: int = 1500,
    limits: ViewLimits = ViewLimits(),
    robot=None,
    min_height_m: float = MIN_HEIGHT_M,
) -> Candidates:
    """Flange poses that put the target in the camera's view, reachable by the robot when one is given.

    Parameters
    ----------
    setup : {"eye_to_hand", "eye_in_hand"}
    unknowns : Unknowns
        X and Y the views are turned into flange poses with.
    rng : numpy.random.Generator
    n_views : int
        Views sampled (:func:`classic.target_views.sample_views`).
    limits : ViewLimits
    robot : handeye.robot.model.Robot, optional
        Keep only poses its inverse kinematics reaches (within joint limits, arm, flange and target above
        ``min_height_m``), with their joints.
    min_height_m : float

    Returns
    -------
    Candidates
    """
    setup = normalize_setup(setup)
    views = sample_views(rng, n_views, limits)
    T_base_ee = flange_poses(views, unknowns.X, unknowns.Y, setup)
    if robot is None:
        return Candidates(T_base_ee, views, None, n_views)
    T_base_target = T_base_ee @ unknowns.Y if setup == "eye_to_hand" else [None] * n_views  # on the flange: check it
    keep, joints = [], []
    for k in range(n_views):
        q = _reach(robot, T_base_ee[k], T_base_target[k], min_height_m)
        if q is not None:
            keep.append(k)
            joints.append(q)
    q = np.array(joints).reshape(-1, robot.nq)
    return Candidates(T_base_ee[keep], views[keep], q, n_views, robot.name)


@dataclass
class PlannedPoses:
    """A plan for the cell: which poses to record next, in order, and what they are predicted to give.

    Attributes
    ----------
    plan : classic.planning.PosePlan
        Chosen candidate indices, predicted sigmas per step, the stop advice.
    T_base_ee : array, shape (k, 4, 4)
        The flange poses to move to, in order.
    T_cam_target : array, shape (k, 4, 4)
        The view expected at each.
    q : array, shape (k, nq), or None
        Joint targets, radians (with a robot model).
    unknowns : Unknowns
    candidates : Candidates
    noise : NoiseModel
    n_recorded : int
    """

    plan: PosePlan
    T_base_ee: np.ndarray
    T_cam_target: np.ndarray
    q: np.ndarray | None
    unknowns: Unknowns
    candidates: Candidates
    noise: NoiseModel
    n_recorded: int


def plan_next_poses(
    setup: str,
    T_base_ee: np.ndarray,
    T_cam_target: np.ndarray,
    unknowns: Unknowns,
    candidates: Candidates,
    n: int = 8,
    noise: NoiseModel | None = None,
    min_gain: float = DEFAULT_MIN_GAIN,
) -> PlannedPoses:
    """The next poses to record: :func:`classic.planning.plan_poses` on the candidates.

    Parameters
    ----------
    setup : {"eye_to_hand", "eye_in_hand"}
    T_base_ee, T_cam_target : array, shape (N, 4, 4)
        Recorded so far (``N`` may be 0; ``T_cam_target`` is not used: the prediction is at X and Y).
    unknowns : Unknowns
    candidates : Candidates
    n : int
        Most poses to plan.
    noise : NoiseModel, optional
        Default :data:`DEFAULT_NOISE`.
    min_gain : float
        Stop when one more pose shrinks the predicted workspace sigma by less than this fraction.

    Returns
    -------
    PlannedPoses
    """
    setup = normalize_setup(setup)
    noise = DEFAULT_NOISE if noise is None else noise
    if len(candidates) == 0:
        raise HandEyeInputError(
            f"none of the {candidates.n_sampled} sampled views is reachable by the "
            f"{candidates.robot}: check the guesses (is the camera looking at the robot's "
            "workspace?) and the view distances"
        )
    A_recorded = robot_side_poses(np.asarray(T_base_ee, dtype=float).reshape(-1, 4, 4), setup)
    plan = plan_poses(
        A_recorded,
        robot_side_poses(candidates.T_base_ee, setup),
        unknowns.X,
        unknowns.Y,
        noise,
        setup,
        n=n,
        options=PlanOptions(min_gain=min_gain),
    )
    idx = plan.chosen
    q = None if candidates.q is None else candidates.q[idx]
    return PlannedPoses(
        plan,
        candidates.T_base_ee[idx],
        views_of(candidates.T_base_ee[idx], unknowns.X, unknowns.Y, setup),
        q,
        unknowns,
        candidates,
        noise,
        len(A_recorded),
    )
