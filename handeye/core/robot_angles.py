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
``[-180, 180]``; at ``B = +-90`` (gimbal lock) the roll angle is set to 0. The
matrices are scipy's (:class:`scipy.spatial.transform.Rotation`, intrinsic ``"ZYX"``);
this module only names the conventions and orders the angles.
"""

from __future__ import annotations

import warnings

import numpy as np
from scipy.spatial.transform import Rotation

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


def matrix_from_zyx(yaw: np.ndarray, pitch: np.ndarray, roll: np.ndarray) -> np.ndarray:
    """Rotation ``Rz(yaw) @ Ry(pitch) @ Rx(roll)``, angles in radians (scipy's intrinsic ``"ZYX"``).

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
    a = np.stack(np.broadcast_arrays(*(np.asarray(v, dtype=float) for v in (yaw, pitch, roll))), axis=-1)
    return Rotation.from_euler("ZYX", a.reshape(-1, 3)).as_matrix().reshape(a.shape[:-1] + (3, 3))


def zyx_from_matrix(R: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Angles ``(yaw, pitch, roll)`` in radians with ``R = Rz(yaw) @ Ry(pitch) @ Rx(roll)``.

    Parameters
    ----------
    R : array, shape (..., 3, 3)

    Returns
    -------
    yaw, pitch, roll : array, shape (...)
        ``pitch`` in ``[-pi/2, pi/2]``, ``yaw`` and ``roll`` in ``[-pi, pi]``; at gimbal lock
        (``cos(pitch) = 0``) scipy sets ``roll = 0`` and ``yaw`` carries the rest.
    """
    R = np.asarray(R, dtype=float)
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message="Gimbal lock detected")
        a = Rotation.from_matrix(R.reshape(-1, 3, 3)).as_euler("ZYX").reshape(R.shape[:-2] + (3,))
    return a[..., 0], a[..., 1], a[..., 2]


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
