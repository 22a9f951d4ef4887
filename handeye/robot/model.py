"""The robot: a UR arm from ``example-robot-data``, or any URDF with visual meshes, through Pinocchio.

Frames: ``base`` is the model's world frame (the robot base), ``ee`` is
Pinocchio's ``tool0`` frame (the flange), ``ref`` a point on the tool at
``T_ee_ref`` (the reference point the learned model is given).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import lru_cache

import numpy as np

from handeye.core.errors import HandEyeInputError
from handeye.core.optional import require_package
from handeye.core.se3 import invert_transform, make_transform, so3_log

__all__ = ["IK_SEEDS", "ROBOTS", "Robot", "load_robot", "load_robot_entry", "load_robot_urdf"]

ROBOTS = ("ur5", "ur3")
_LOADERS = {"ur5": "UR5Loader", "ur3": "UR3Loader"}
#: Home configurations the inverse kinematics starts from (elbow up, wrist down or out), radians.
IK_SEEDS = np.array(
    [
        [0.0, -1.3, 1.6, -1.9, -1.57, 0.0],
        [0.0, -1.0, 1.2, -0.2, 1.57, 0.0],
        [0.0, -1.8, 1.9, -1.6, -1.57, 0.0],
        [0.0, -1.2, 1.4, 0.9, 1.57, 0.0],
    ]
)
#: The reference point: the tip of a 12 cm tool along the flange's z axis.
DEFAULT_T_EE_REF = make_transform(np.eye(3), [0.0, 0.0, 0.12])
#: Links whose two joint origins lie at least this far apart (metres) get keypoints along the segment between
#: them (:meth:`Robot.keypoints_base`): on a UR the upper arm and the forearm.
LONG_LINK_M = 0.2
#: Where along such a segment, from its first joint's origin (0) to the next one's (1).
LINK_FRACTIONS = (0.25, 0.5, 0.75)


@dataclass
class Robot:
    """A Pinocchio robot with its flange and reference frames.

    Attributes
    ----------
    name : str
    model, data : pinocchio.Model, pinocchio.Data
    visual_model : pinocchio.GeometryModel
    ee_frame : int
        Frame id of ``tool0``.
    T_ee_ref : array, shape (4, 4)
    shoulder_m : array, shape (3,)
        The shoulder joint's origin in the base frame.
    reach_m : float
        Distance from the shoulder to the flange with the arm stretched.
    """

    name: str
    model: object
    data: object
    visual_model: object
    ee_frame: int
    T_ee_ref: np.ndarray = field(default_factory=lambda: DEFAULT_T_EE_REF.copy())
    shoulder_m: np.ndarray = field(default_factory=lambda: np.zeros(3))
    reach_m: float = 0.0
    _link_points_cache: list | None = field(default=None, repr=False, compare=False)

    @property
    def pin(self):
        """The pinocchio module."""
        return require_package("pinocchio", extra="robot")

    @property
    def nq(self) -> int:
        """Number of joints."""
        return int(self.model.nq)

    def fk(self, q: np.ndarray) -> np.ndarray:
        """Flange poses ``T_base_ee`` of joint configurations.

        Parameters
        ----------
        q : array, shape (..., nq)
            Joint angles, radians.

        Returns
        -------
        T_base_ee : array, shape (..., 4, 4)
        """
        pin = self.pin
        q = np.asarray(q, dtype=float)
        flat = q.reshape(-1, self.nq)
        out = np.empty((len(flat), 4, 4))
        for k, qk in enumerate(flat):
            pin.framesForwardKinematics(self.model, self.data, qk)
            out[k] = self.data.oMf[self.ee_frame].homogeneous
        return out.reshape(q.shape[:-1] + (4, 4))

    @property
    def keypoint_names(self) -> list[str]:
        """Names of :meth:`keypoints_base`: every joint's origin, the points along the long links
        (``shoulder_lift@0.50``: half-way from ``shoulder_lift_joint``'s origin to the next joint's), the
        flange, the reference point."""
        joints = [str(self.model.names[j]) for j in range(1, self.model.njoints)]
        links = [f"{joints[a].removesuffix('_joint')}@{f:.2f}" for a, f in self._link_points()]
        return joints + links + ["flange", "ref"]

    def _link_points(self) -> list[tuple[int, float]]:
        """``(a, f)`` per point along a long link: the point ``(1 - f) o_a + f o_(a+1)`` of joint origins ``o``
        (0-based joint indices), for the links of :data:`LONG_LINK_M` or longer. Joint ``a + 1``'s origin is
        fixed in joint ``a``'s link, so the distance, and each point's place in that link, do not depend on
        the joints: read once, at the model's neutral configuration."""
        if self._link_points_cache is None:
            pin = self.pin
            pin.forwardKinematics(self.model, self.data, pin.neutral(self.model))
            o = np.array([self.data.oMi[j].translation for j in range(1, self.model.njoints)])
            long = [a for a in range(len(o) - 1) if np.linalg.norm(o[a + 1] - o[a]) >= LONG_LINK_M]
            self._link_points_cache = [(a, float(f)) for a in long for f in LINK_FRACTIONS]
        return self._link_points_cache

    def keypoints_base(self, q: np.ndarray) -> np.ndarray:
        """Points on the arm known from the joints, base frame (names: :attr:`keypoint_names`).

        What the learned keypoint model finds in the image (``learned.keypoints``): every joint's origin,
        points along the long links (:data:`LINK_FRACTIONS` of the way between two joint origins at least
        :data:`LONG_LINK_M` apart, inside the link like the joints' origins: more points spread over the
        arm), the flange and the reference point.

        Parameters
        ----------
        q : array, shape (..., nq)

        Returns
        -------
        p_base : array, shape (..., K, 3)
            Metres; ``K = nq + len(link points) + 2``.
        """
        pin = self.pin
        q = np.asarray(q, dtype=float)
        flat = q.reshape(-1, self.nq)
        links = self._link_points()
        nj = self.model.njoints - 1
        out = np.empty((len(flat), nj + len(links) + 2, 3))
        for k, qk in enumerate(flat):
            pin.framesForwardKinematics(self.model, self.data, qk)
            out[k, :nj] = [self.data.oMi[j].translation for j in range(1, self.model.njoints)]
            for i, (a, f) in enumerate(links):
                out[k, nj + i] = (1.0 - f) * out[k, a] + f * out[k, a + 1]
            T_base_ee = self.data.oMf[self.ee_frame].homogeneous
            out[k, -2] = T_base_ee[:3, 3]
            out[k, -1] = (T_base_ee @ self.T_ee_ref)[:3, 3]
        return out.reshape(q.shape[:-1] + out.shape[1:])

    def fk_ref(self, q: np.ndarray) -> np.ndarray:
        """Reference-point poses ``T_base_ref = T_base_ee @ T_ee_ref``, shape (..., 4, 4)."""
        return self.fk(q) @ self.T_ee_ref

    def link_poses(self, q: np.ndarray) -> list[tuple[str, str, np.ndarray]]:
        """Visual geometry of one configuration: (name, mesh path, ``T_base_geom``) per mesh.

        Parameters
        ----------
        q : array, shape (nq,)

        Returns
        -------
        list of (str, str, array (4, 4))
        """
        pin = self.pin
        pin.forwardKinematics(self.model, self.data, np.asarray(q, dtype=float))
        out = []
        for g in self.visual_model.geometryObjects:
            T = (self.data.oMi[g.parentJoint] * g.placement).homogeneous
            S = np.diag(list(np.asarray(g.meshScale, dtype=float)) + [1.0])
            out.append((g.name, g.meshPath, T @ S))
        return out

    def link_twists(self, q: np.ndarray) -> np.ndarray:
        """How each visual geometry of :meth:`link_poses` moves per radian of each joint, base frame.

        Pinocchio's joint Jacobian of the geometry's parent joint in the ``WORLD`` frame: ``(omega_j, v_j)`` such
        that a point ``p`` (base frame) of the geometry moves by ``omega_j x p + v_j`` (``v_j`` the velocity of
        the point at the base's origin).

        Parameters
        ----------
        q : array, shape (nq,)

        Returns
        -------
        array, shape (n_geometries, nv, 6)
            ``(omega, v)``: rad/rad and m/rad; zeros for a geometry on the base.
        """
        pin = self.pin
        pin.computeJointJacobians(self.model, self.data, np.asarray(q, dtype=float))
        out = np.zeros((len(self.visual_model.geometryObjects), self.model.nv, 6))
        for k, g in enumerate(self.visual_model.geometryObjects):
            if g.parentJoint > 0:
                J = pin.getJointJacobian(self.model, self.data, g.parentJoint, pin.WORLD)  # rows [v; omega]
                out[k, :, :3], out[k, :, 3:] = J[3:].T, J[:3].T
        return out

    def ik(
        self,
        T_base_ee: np.ndarray,
        q0: np.ndarray,
        tol: float = 1e-10,
        max_iterations: int = 200,
        damping: float = 1e-6,
    ) -> np.ndarray | None:
        """Joint angles reaching a flange pose (damped least squares on SE(3)), or None.

        Parameters
        ----------
        T_base_ee : array, shape (4, 4)
        q0 : array, shape (nq,)
            Start; the solution found is the one this start converges to.
        tol : float
            Pose error norm (radians and metres) accepted.
        max_iterations : int
        damping : float

        Returns
        -------
        q : array, shape (nq,), or None when it did not converge or left the joint limits.
        """
        pin = self.pin
        q = np.asarray(q0, dtype=float).copy()
        target = pin.SE3(np.asarray(T_base_ee, dtype=float))
        for _ in range(max_iterations):
            pin.framesForwardKinematics(self.model, self.data, q)
            err_T = self.data.oMf[self.ee_frame].actInv(target)  # current^-1 * target, in the flange frame
            err = pin.log6(err_T).vector
            if np.linalg.norm(err) < tol:
                lo, hi = self.model.lowerPositionLimit, self.model.upperPositionLimit
                return q if np.all(q >= lo) and np.all(q <= hi) else None
            J = pin.computeFrameJacobian(self.model, self.data, q, self.ee_frame, pin.LOCAL)
            J = pin.Jlog6(err_T) @ J
            dq = J.T @ np.linalg.solve(J @ J.T + damping * np.eye(6), err)
            q = pin.integrate(self.model, q, dq)
        return None

    def pose_jacobians(self, q: np.ndarray) -> np.ndarray:
        """How joint errors move the flange pose, in the robot-noise convention of :mod:`classic.noise_model`.

        Rows ``[w, n]``: a flange rotation ``R <- R exp(w)`` (flange frame) and translation
        ``t <- t + n`` (base frame) per radian of each joint; pinocchio's frame Jacobian in the
        ``LOCAL`` frame, its linear rows turned into the base frame. Feed it to
        :func:`classic.noise_model.joint_noise_covariance` with the encoders' noise.

        Parameters
        ----------
        q : array, shape (N, nq)

        Returns
        -------
        array, shape (N, 6, nq)
        """
        pin = self.pin
        flat = np.asarray(q, dtype=float).reshape(-1, self.nq)
        out = np.empty((len(flat), 6, self.nq))
        for k, qk in enumerate(flat):
            pin.framesForwardKinematics(self.model, self.data, qk)
            R = self.data.oMf[self.ee_frame].rotation.copy()
            J = pin.computeFrameJacobian(self.model, self.data, qk, self.ee_frame, pin.LOCAL)  # [v; omega], local
            out[k, :3] = J[3:]
            out[k, 3:] = R @ J[:3]
        return out

    def pose_error(self, q: np.ndarray, T_base_ee: np.ndarray) -> tuple[float, float]:
        """Rotation (rad) and translation (m) error of ``fk(q)`` against a flange pose."""
        D = invert_transform(self.fk(q)) @ T_base_ee
        return float(np.linalg.norm(so3_log(D[:3, :3]))), float(np.linalg.norm(D[:3, 3]))


def load_robot(name: str, T_ee_ref: np.ndarray | None = None) -> Robot:
    """Load ``ur5`` or ``ur3`` from ``example-robot-data``.

    Parameters
    ----------
    name : {"ur5", "ur3"}
    T_ee_ref : array, shape (4, 4), optional
        Reference point on the tool; default 12 cm along the flange's z.

    Returns
    -------
    Robot

    Raises
    ------
    HandEyeInputError
        For another name.
    MissingDependencyError
        Without ``handeye[robot]``.
    """
    if name not in ROBOTS:
        raise HandEyeInputError(f"unknown robot {name!r}: use one of {', '.join(ROBOTS)}")
    model, visual_model = _description(name)
    # each Robot its own copies (and data): one caller's robot never sees another's
    return _robot(name, model.copy(), visual_model.copy(), "tool0", T_ee_ref)


@lru_cache(maxsize=None)
def _description(name: str):
    """The robot's kinematic and visual models as ``example-robot-data`` describes them, parsed once a process
    (the URDF's parse takes 0.7 s, and a run loads the same arm again and again: a benchmark 8 times)."""
    require_package("pinocchio", extra="robot", purpose="the robot model")
    erd = require_package("example_robot_data", extra="robot", purpose="the UR robot description")
    # the loader classes, not erd.load(name): example-robot-data-loaders 5.0 maps "ur3" to the UR5 loader
    wrapper = getattr(erd.robots_loader, _LOADERS[name])().robot
    return wrapper.model, wrapper.visual_model


def _robot(name: str, model, visual_model, ee_frame: str, T_ee_ref: np.ndarray | None) -> Robot:
    """A :class:`Robot` with its shoulder (second joint's origin) and reach measured with all joints at zero."""
    robot = Robot(name, model, model.createData(), visual_model, model.getFrameId(ee_frame))
    if T_ee_ref is not None:
        robot.T_ee_ref = np.asarray(T_ee_ref, dtype=float)
    q_stretched = np.zeros(robot.nq)
    robot.pin.forwardKinematics(model, robot.data, q_stretched)
    robot.shoulder_m = robot.data.oMi[min(2, model.njoints - 1)].translation.copy()
    robot.reach_m = float(np.linalg.norm(robot.fk(q_stretched)[:3, 3] - robot.shoulder_m))
    return robot


def load_robot_urdf(urdf_path, package_dirs=(), ee_frame: str = "tool0", T_ee_ref: np.ndarray | None = None) -> Robot:
    """Load any robot from a URDF with visual meshes (for the markerless calibration of your own arm).

    Parameters
    ----------
    urdf_path : str or Path
    package_dirs : sequence of str or Path
        Folders where ``package://`` mesh paths are looked up (the folder above the package).
    ee_frame : str
        The flange frame's name in the URDF.
    T_ee_ref : array, shape (4, 4), optional

    Returns
    -------
    Robot

    Raises
    ------
    HandEyeInputError
        Missing or unreadable URDF, a mesh file that does not exist, no such flange frame (each named).
    """
    from pathlib import Path

    pin = require_package("pinocchio", extra="robot", purpose="the robot model")
    path = Path(urdf_path)
    if not path.is_file():
        raise HandEyeInputError(f"{path}: no such URDF file")
    try:
        model, _, visual = pin.buildModelsFromUrdf(str(path), [str(d) for d in package_dirs])
    except Exception as exc:  # pinocchio raises ValueError/RuntimeError with the parser's text
        raise HandEyeInputError(
            f"{path}: cannot load the URDF ({str(exc).splitlines()[0] if str(exc) else exc})"
        ) from None
    for g in visual.geometryObjects:
        if not Path(g.meshPath).is_file():
            raise HandEyeInputError(f"{path}: mesh of {g.name} not found: {g.meshPath}")
    if not model.existFrame(ee_frame):
        raise HandEyeInputError(f"{path}: no frame {ee_frame!r} (the flange); pass ee_frame")
    return _robot(path.stem, model, visual, ee_frame, T_ee_ref)


def load_robot_entry(entry) -> Robot:
    """The robot of a dataset's ``meta["robot"]``: a UR's name, or ``{"urdf": path, "package_dirs": [...],
    "ee_frame": name}`` (an imported recording's).

    Raises
    ------
    HandEyeInputError
        An entry of neither form, an unknown robot, a missing URDF or mesh.
    """
    if isinstance(entry, str):
        return load_robot(entry)
    if isinstance(entry, dict) and isinstance(entry.get("urdf"), str):
        return load_robot_urdf(entry["urdf"], entry.get("package_dirs", ()), entry.get("ee_frame", "tool0"))
    raise HandEyeInputError(f"meta.json: robot {str(entry)[:80]!r} is neither a UR's name nor {{'urdf': path, ...}}")
