"""Euler angles of robot controllers and URDF, each convention written once.

All three are the same family, ``R = Rz(gamma) @ Ry(beta) @ Rx(alpha)`` (rotate
about the fixed x axis by ``alpha``, then the fixed y by ``beta``, then the fixed z
by ``gamma``; equally: about z, then the new y, then the new x). They differ in the
order the controller lists the angles and in their unit:

=================  ====================  =================================  ============================================
convention         angles, as listed     matrix                             scipy
=================  ====================  =================================  ============================================
KUKA ``A B C``     ``(A, B, C)`` deg     ``Rz(A) Ry(B) Rx(C)``              ``Rotation.from_euler("ZYX", [A, B, C])``
Fanuc ``W P R``    ``(W, P, R)`` deg     ``Rz(R) Ry(P) Rx(W)``              ``Rotation.from_euler("xyz", [W, P, R])``
URDF ``rpy``       ``(r, p, y)`` rad     ``Rz(y) Ry(p) Rx(r)``              ``Rotation.from_euler("xyz", [r, p, y])``
=================  ====================  =================================  ============================================

(scipy: upper-case axes are intrinsic, lower-case extrinsic; ``degrees=True`` for
KUKA and Fanuc.) So KUKA ``(A, B, C)`` and Fanuc ``(W, P, R) = (C, B, A)`` name the
same rotation. ABB's ``q1 q2 q3 q4`` is a quaternion, scalar first ``(w, x, y, z)``:
:func:`handeye.core.se3.quat_wxyz_to_xyzw`.

Every function takes one set of angles or a batch ``(..., 3)`` and returns
rotation matrices ``(..., 3, 3)``, or the inverse. Matrix to angles returns the
controller's range: ``B`` (pitch) in ``[-90, 90]`` degrees, the other two in
``(-180, 180]``; at ``B = +-90`` (gimbal lock) the roll angle is set to 0.
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "fanuc_wpr_from_matrix",
    "kuka_abc_from_matrix",
    "matrix_from_fanuc_wpr",
    "matrix_from_kuka_abc",
    "matrix_from_urdf_rpy",
    "matrix_from_zyx",
    "urdf_rpy_from_matrix",
    "zyx_from_matrix",
]

#: Below this ``cos(pitch)`` the yaw and roll axes coincide (gimbal lock): roll is set to 0.
_GIMBAL_COS = 1e-12


def matrix_from_zyx(yaw: np.ndarray, pitch: np.ndarray, roll: np.ndarray) -> np.ndarray:
    """Rotation ``Rz(yaw) @ Ry(pitch) @ Rx(roll)``, angles in radians.

    Parameters
    ----------
    yaw, pitch, roll : array, shape (...)
        Radians.

    Returns
    -------
    R : array, shape (..., 3, 3)

    Notes
    -----
    .. math:: R = R_z(\\gamma) R_y(\\beta) R_x(\\alpha)
    """
    cz, sz = np.cos(yaw), np.sin(yaw)
    cy, sy = np.cos(pitch), np.sin(pitch)
    cx, sx = np.cos(roll), np.sin(roll)
    R = np.empty(np.broadcast(cz, cy, cx).shape + (3, 3))
    R[..., 0, 0] = cz * cy
    R[..., 0, 1] = cz * sy * sx - sz * cx
    R[..., 0, 2] = cz * sy * cx + sz * sx
    R[..., 1, 0] = sz * cy
    R[..., 1, 1] = sz * sy * sx + cz * cx
    R[..., 1, 2] = sz * sy * cx - cz * sx
    R[..., 2, 0] = -sy
    R[..., 2, 1] = cy * sx
    R[..., 2, 2] = cy * cx
    return R


def zyx_from_matrix(R: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Angles ``(yaw, pitch, roll)`` in radians with ``R = Rz(yaw) @ Ry(pitch) @ Rx(roll)``.

    Parameters
    ----------
    R : array, shape (..., 3, 3)

    Returns
    -------
    yaw, pitch, roll : array, shape (...)
        ``pitch`` in ``[-pi/2, pi/2]``, ``yaw`` and ``roll`` in ``(-pi, pi]``; at
        gimbal lock (``cos(pitch) = 0``) ``roll = 0`` and ``yaw`` carries the rest.
    """
    R = np.asarray(R, dtype=float)
    cos_pitch = np.hypot(R[..., 0, 0], R[..., 1, 0])
    pitch = np.arctan2(-R[..., 2, 0], cos_pitch)
    locked = cos_pitch < _GIMBAL_COS
    yaw = np.where(locked, np.arctan2(-R[..., 0, 1], R[..., 1, 1]), np.arctan2(R[..., 1, 0], R[..., 0, 0]))
    roll = np.where(locked, 0.0, np.arctan2(R[..., 2, 1], R[..., 2, 2]))
    return yaw, pitch, roll


def _split(angles: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    angles = np.asarray(angles, dtype=float)
    if angles.shape[-1:] != (3,):
        raise ValueError(f"expected angles of shape (..., 3), got {angles.shape}")
    return angles[..., 0], angles[..., 1], angles[..., 2]


def matrix_from_kuka_abc(abc_deg: np.ndarray) -> np.ndarray:
    """Rotation of KUKA ``A, B, C`` angles: ``R = Rz(A) @ Ry(B) @ Rx(C)``.

    Parameters
    ----------
    abc_deg : array, shape (..., 3)
        ``(A, B, C)`` in degrees, as the controller lists them.

    Returns
    -------
    R : array, shape (..., 3, 3)
        Same as ``scipy.spatial.transform.Rotation.from_euler("ZYX", abc_deg, degrees=True)``.
    """
    a, b, c = _split(np.radians(abc_deg))
    return matrix_from_zyx(a, b, c)


def kuka_abc_from_matrix(R: np.ndarray) -> np.ndarray:
    """KUKA ``(A, B, C)`` in degrees of a rotation, inverse of :func:`matrix_from_kuka_abc`.

    Parameters
    ----------
    R : array, shape (..., 3, 3)

    Returns
    -------
    abc_deg : array, shape (..., 3)
    """
    yaw, pitch, roll = zyx_from_matrix(R)
    return np.degrees(np.stack([yaw, pitch, roll], axis=-1))


def matrix_from_fanuc_wpr(wpr_deg: np.ndarray) -> np.ndarray:
    """Rotation of Fanuc ``W, P, R`` angles (fixed axes x, y, z): ``R = Rz(R) @ Ry(P) @ Rx(W)``.

    Parameters
    ----------
    wpr_deg : array, shape (..., 3)
        ``(W, P, R)`` in degrees, as the controller lists them.

    Returns
    -------
    R : array, shape (..., 3, 3)
        Same as ``scipy.spatial.transform.Rotation.from_euler("xyz", wpr_deg, degrees=True)``.
    """
    w, p, r = _split(np.radians(wpr_deg))
    return matrix_from_zyx(r, p, w)


def fanuc_wpr_from_matrix(R: np.ndarray) -> np.ndarray:
    """Fanuc ``(W, P, R)`` in degrees of a rotation, inverse of :func:`matrix_from_fanuc_wpr`.

    Parameters
    ----------
    R : array, shape (..., 3, 3)

    Returns
    -------
    wpr_deg : array, shape (..., 3)
    """
    yaw, pitch, roll = zyx_from_matrix(R)
    return np.degrees(np.stack([roll, pitch, yaw], axis=-1))


def matrix_from_urdf_rpy(rpy: np.ndarray) -> np.ndarray:
    """Rotation of a URDF ``<origin rpy="r p y">``: fixed axes x, y, z, ``R = Rz(y) @ Ry(p) @ Rx(r)``.

    Parameters
    ----------
    rpy : array, shape (..., 3)
        Roll, pitch, yaw in radians.

    Returns
    -------
    R : array, shape (..., 3, 3)
        Same as ``scipy.spatial.transform.Rotation.from_euler("xyz", rpy)``.
    """
    r, p, y = _split(rpy)
    return matrix_from_zyx(y, p, r)


def urdf_rpy_from_matrix(R: np.ndarray) -> np.ndarray:
    """URDF ``(roll, pitch, yaw)`` in radians of a rotation, inverse of :func:`matrix_from_urdf_rpy`.

    Parameters
    ----------
    R : array, shape (..., 3, 3)

    Returns
    -------
    rpy : array, shape (..., 3)
    """
    yaw, pitch, roll = zyx_from_matrix(R)
    return np.stack([roll, pitch, yaw], axis=-1)
