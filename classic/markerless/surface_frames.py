"""The robot's surface posed at every frame, base frame, stacked: what :func:`classic.markerless.register_robot`
registers to the depth.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from handeye.core.errors import HandEyeInputError, NonFiniteError, ShapeError

__all__ = ["RobotSurfaceFrames"]


@dataclass
class RobotSurfaceFrames:
    """The robot's surface at every frame, base frame, stacked.

    Attributes
    ----------
    points_base : array, shape (M, 3)
        Surface samples, metres.
    normals_base : array, shape (M, 3)
        Outward unit normals.
    frame : array of int, shape (M,)
        Frame index (0..N-1) of each sample.
    part : array of int, shape (M,)
        Rigid part (link mesh) of each sample; parts whose position changes between frames
        are "moving" (found from the data, not from names).
    curvatures : array, shape (M, 2), optional
        Principal curvatures ``kappa_1 >= kappa_2`` of each sample, 1/m (convex positive), from
        :func:`classic.markerless.curvature.sample_curvatures`. With them the fine stage's residual
        is second order; without, first order (biased by a fraction of a millimetre on curved links).
    direction_base : array, shape (M, 3), optional
        Unit tangent along ``kappa_1``, base frame; given with ``curvatures``.
    joint_twists_base : array, shape (N_frames, n_parts, n_joints, 6), optional
        Each part's motion per joint at each frame, ``(omega, v)`` in the base frame: a point ``p`` of the part
        moves by ``omega x p + v`` per radian of the joint
        (:meth:`handeye.robot.surface.RobotSurface.joint_twists`). Given, the joints' zero offsets can be
        estimated with the pose (:mod:`classic.markerless.kinematics`).
    """

    points_base: np.ndarray
    normals_base: np.ndarray
    frame: np.ndarray
    part: np.ndarray
    curvatures: np.ndarray | None = None
    direction_base: np.ndarray | None = None
    joint_twists_base: np.ndarray | None = None

    def __post_init__(self):
        m = len(self.points_base)
        for name in ("points_base", "normals_base"):
            setattr(self, name, _surface_array(name, getattr(self, name), (m, 3)))
        for name in ("frame", "part"):
            a = np.asarray(getattr(self, name)).astype(np.int64)
            if a.shape != (m,):
                raise ShapeError(f"surface {name} must be (M,), got {a.shape}")
            setattr(self, name, a)
        if (self.curvatures is None) != (self.direction_base is None):
            raise HandEyeInputError("surface curvatures and direction_base are given together or not at all")
        if self.curvatures is not None:
            for name, cols in (("curvatures", 2), ("direction_base", 3)):
                setattr(self, name, _surface_array(name, getattr(self, name), (m, cols)))
        if self.joint_twists_base is not None:
            self.joint_twists_base = _twists_array(self.joint_twists_base, self.frame, self.part)


def _surface_array(name: str, a, shape: tuple) -> np.ndarray:
    """``a`` as floats of ``shape`` ``(M, k)``, all finite, or the error that names the surface's ``name``."""
    a = np.asarray(a, dtype=float)
    if a.shape != shape:
        raise ShapeError(f"surface {name} must be (M, {shape[1]}), got {a.shape}")
    if not np.all(np.isfinite(a)):
        raise NonFiniteError(f"surface {name} has NaN or inf")
    return a


def _twists_array(a, frame: np.ndarray, part: np.ndarray) -> np.ndarray:
    """``a`` as floats of shape ``(N_frames, n_parts, n_joints, 6)`` covering every ``frame`` and ``part``, all finite,
    or the error that says what the surface's ``joint_twists_base`` must be."""
    a = np.asarray(a, dtype=float)
    need = (int(frame.max()) + 1, int(part.max()) + 1) if len(frame) else (0, 0)
    if a.ndim != 4 or a.shape[3] != 6 or a.shape[0] < need[0] or a.shape[1] < need[1]:
        raise ShapeError(
            f"surface joint_twists_base must be (N_frames >= {need[0]}, n_parts >= {need[1]}, n_joints, 6), "
            f"got {a.shape}"
        )
    if not np.all(np.isfinite(a)):
        raise NonFiniteError("surface joint_twists_base has NaN or inf")
    return a
