"""The robot's surface as points with outward normals, posed by forward kinematics.

Each link's visual mesh is sampled once, area-weighted, at a spacing near the
depth camera's pixel footprint, in the mesh's own frame; posing a frame's
configuration moves those samples with the link (no re-sampling). The result
is what :func:`classic.markerless.register_robot` registers to depth.
"""

from __future__ import annotations

import copy

import numpy as np

from classic.markerless import RobotSurfaceFrames
from classic.markerless.curvature import sample_curvatures
from handeye.core.errors import HandEyeInputError, ShapeError
from handeye.core.optional import require_package
from handeye.robot.meshes import load_link_mesh

__all__ = ["RobotSurface", "spacing_for_camera"]


def spacing_for_camera(K: np.ndarray, nearest_m: float, fraction: float = 0.7) -> float:
    """Sample spacing (m) of a fraction of the pixel footprint at the nearest distance the robot is seen."""
    return float(fraction * nearest_m / max(K[0, 0], K[1, 1]))


class RobotSurface:
    """Surface samples of a robot's visual meshes.

    Parameters
    ----------
    robot : handeye.robot.model.Robot
    spacing_m : float
        Mean distance between samples.
    seed : int

    Raises
    ------
    HandEyeInputError
        A mesh file that cannot be read, named.
    """

    def __init__(self, robot, spacing_m: float = 0.005, seed: int = 0):
        trimesh = require_package("trimesh", extra="robot", purpose="robot meshes")
        if not np.isfinite(spacing_m) or spacing_m <= 0:
            raise HandEyeInputError(f"surface spacing must be > 0 m, got {spacing_m}")
        self.robot = robot
        self.spacing_m = float(spacing_m)
        self.parts = []  # (name, points in mesh frame (k, 3), normals (k, 3))
        self.curvatures = []  # (kappa (k, 2) in 1/m, first principal direction (k, 3) in the mesh frame)
        rng = np.random.default_rng(seed)
        for name, path, _ in robot.link_poses(np.zeros(robot.nq)):
            try:
                mesh = load_link_mesh(path)
            except Exception as exc:  # trimesh raises many types for unreadable files
                raise HandEyeInputError(f"{path}: cannot read the mesh of {name} ({exc})") from None
            if not isinstance(mesh, trimesh.Trimesh) or len(mesh.faces) == 0:
                raise HandEyeInputError(f"{path}: the mesh of {name} has no triangles")
            n = max(int(np.ceil(mesh.area / self.spacing_m**2)), 10)
            points, face = trimesh.sample.sample_surface(mesh, n, seed=int(rng.integers(2**31)))
            points = np.asarray(points, dtype=float)
            normals = np.asarray(mesh.face_normals[face], dtype=float)
            self.parts.append((name, points, normals))
            # curvature at the scale of the samples, for the fine stage's second-order residual
            self.curvatures.append(sample_curvatures(points, normals, radius_m=2.5 * self.spacing_m))

    @property
    def n_points(self) -> int:
        """Samples per frame."""
        return sum(len(p) for _, p, _ in self.parts)

    def thinned(self, every: int) -> "RobotSurface":
        """The same surface with every ``every``-th sample of each part: the samples are drawn at random over the
        area, so these are again such a sample, ``sqrt(every)`` times as far apart (a z-buffer that many times
        coarser suits it). ``every`` 1 gives ``self``."""
        every = int(every)
        if every < 1:
            raise HandEyeInputError(f"thinned: every must be >= 1, got {every}")
        if every == 1:
            return self
        out = copy.copy(self)
        out.spacing_m = self.spacing_m * float(np.sqrt(every))
        cut = np.s_[::every]  # copied whole: posing a strided view costs twice as much
        out.parts = [(name, p[cut].copy(), n[cut].copy()) for name, p, n in self.parts]
        out.curvatures = [(c[cut].copy(), e[cut].copy()) for c, e in self.curvatures]
        return out

    def joint_twists(self, q: np.ndarray) -> np.ndarray:
        """Each part's motion per joint at each configuration: twists in the base frame.

        A point ``p`` of part ``k`` (base frame) moves by ``dp / dq_j = omega x p + v`` per radian of joint ``j``
        (:meth:`handeye.robot.model.Robot.link_twists`, pinocchio's joint Jacobians; a mesh's scale does not enter).

        Parameters
        ----------
        q : array, shape (N, nq)
            Joint angles, radians.

        Returns
        -------
        array, shape (N, n_parts, nq, 6)
            ``(omega, v)``: rad/rad and m/rad.
        """
        q = np.atleast_2d(np.asarray(q, dtype=float))
        return np.stack([self.robot.link_twists(qi) for qi in q])

    def posed(self, q: np.ndarray, twists: bool = True) -> RobotSurfaceFrames:
        """The surface at each configuration, stacked.

        Parameters
        ----------
        q : array, shape (N, nq)
            Joint angles of N frames, radians.
        twists : bool
            Carry each part's twist per joint (:meth:`joint_twists`), with which the registration estimates the
            joints' zero offsets (:mod:`classic.markerless.kinematics`).

        Returns
        -------
        RobotSurfaceFrames
            Points and outward normals in the base frame, with frame and part indices (and ``joint_twists_base``).

        Raises
        ------
        ShapeError
            When the joint count does not fit the robot.
        """
        q = np.atleast_2d(np.asarray(q, dtype=float))
        if q.ndim != 2 or q.shape[1] != self.robot.nq:
            raise ShapeError(f"joint angles must be (N, {self.robot.nq}) for {self.robot.name}, got {q.shape}")
        pts, nrm, frame, part, kappa, direction = [], [], [], [], [], []
        for i, qi in enumerate(q):
            for k, ((_, _, T), (_, p, n), (c, e)) in enumerate(
                zip(self.robot.link_poses(qi), self.parts, self.curvatures)
            ):
                A = T[:3, :3]
                pts.append(p @ A.T + T[:3, 3])
                nk = n @ np.linalg.inv(A)  # normals move with the inverse transpose (meshes may be scaled)
                nrm.append(nk / np.linalg.norm(nk, axis=1, keepdims=True))
                ek = e @ A.T  # tangents move with the link; a uniformly scaled mesh's curvature scales inversely
                direction.append(ek / np.linalg.norm(ek, axis=1, keepdims=True))
                kappa.append(c / np.cbrt(abs(np.linalg.det(A))))
                frame.append(np.full(len(p), i))
                part.append(np.full(len(p), k))
        return RobotSurfaceFrames(
            np.concatenate(pts),
            np.concatenate(nrm),
            np.concatenate(frame),
            np.concatenate(part),
            curvatures=np.concatenate(kappa),
            direction_base=np.concatenate(direction),
            joint_twists_base=self.joint_twists(q) if twists else None,
        )
