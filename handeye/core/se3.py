"""Batched rotations, quaternions and rigid transforms.

Convention (see :mod:`handeye`): ``T_a_b`` is the pose of frame ``b`` in frame
``a``, ``p_a = T_a_b @ p_b``. Every function accepts one item or a batch:
rotations ``(..., 3, 3)``, transforms ``(..., 4, 4)``, rotation vectors and
translations ``(..., 3)``, quaternions ``(..., 4)`` in **(x, y, z, w)** order,
scalar last, returned canonical with ``w >= 0``.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = [
    "hat",
    "vee",
    "so3_exp",
    "so3_log",
    "rotvec_from_quat_xyzw",
    "rotation_angle",
    "project_to_so3",
    "quat_xyzw_from_matrix",
    "matrix_from_quat_xyzw",
    "quat_wxyz_to_xyzw",
    "quat_xyzw_to_wxyz",
    "quat_multiply_wxyz",
    "make_transform",
    "invert_transform",
    "transform_from_pos_quat_xyzw",
    "pos_quat_xyzw_from_transform",
    "transform_from_rotvec_translation",
]


def hat(v: np.ndarray) -> np.ndarray:
    """Skew-symmetric matrix of a vector: ``hat(a) @ b == cross(a, b)``.

    Parameters
    ----------
    v : array, shape (..., 3)

    Returns
    -------
    S : array, shape (..., 3, 3)
    """
    v = np.asarray(v, dtype=float)
    S = np.zeros(v.shape[:-1] + (3, 3))
    S[..., 0, 1] = -v[..., 2]
    S[..., 0, 2] = v[..., 1]
    S[..., 1, 0] = v[..., 2]
    S[..., 1, 2] = -v[..., 0]
    S[..., 2, 0] = -v[..., 1]
    S[..., 2, 1] = v[..., 0]
    return S


def vee(S: np.ndarray) -> np.ndarray:
    """Vector of the antisymmetric part of a matrix, the inverse of :func:`hat`.

    Parameters
    ----------
    S : array, shape (..., 3, 3)

    Returns
    -------
    v : array, shape (..., 3)
    """
    S = np.asarray(S, dtype=float)
    return 0.5 * np.stack(
        [S[..., 2, 1] - S[..., 1, 2], S[..., 0, 2] - S[..., 2, 0], S[..., 1, 0] - S[..., 0, 1]],
        axis=-1,
    )


def so3_exp(rotvec: np.ndarray) -> np.ndarray:
    """Rotation matrix of a rotation vector (Rodrigues' formula).

    Parameters
    ----------
    rotvec : array, shape (..., 3)
        Axis times angle in radians.

    Returns
    -------
    R : array, shape (..., 3, 3)
    """
    rotvec = np.asarray(rotvec, dtype=float)
    if rotvec.shape == (3,):  # one rotation (each step of a refinement): scalar arithmetic, several times faster
        return _so3_exp_one(float(rotvec[0]), float(rotvec[1]), float(rotvec[2]))
    theta = np.linalg.norm(rotvec, axis=-1)[..., None, None]
    K = hat(rotvec)
    small = theta < 1e-8
    safe = np.where(small, 1.0, theta)
    a = np.where(small, 1.0 - theta**2 / 6.0, np.sin(safe) / safe)
    b = np.where(small, 0.5 - theta**2 / 24.0, (1.0 - np.cos(safe)) / safe**2)
    return np.eye(3) + a * K + b * (K @ K)


def _so3_exp_one(x: float, y: float, z: float) -> np.ndarray:
    """:func:`so3_exp` of one rotation vector, the same formula on Python floats, shape (3, 3)."""
    t2 = x * x + y * y + z * z
    if t2 < 1e-16:  # theta < 1e-8, as in so3_exp
        a, b = 1.0 - t2 / 6.0, 0.5 - t2 / 24.0
    else:
        t = math.sqrt(t2)
        a, b = math.sin(t) / t, (1.0 - math.cos(t)) / t2
    # I + a K + b K^2, with K^2 = v v^T - |v|^2 I
    return np.array(
        [
            [1.0 + b * (x * x - t2), b * x * y - a * z, b * x * z + a * y],
            [b * x * y + a * z, 1.0 + b * (y * y - t2), b * y * z - a * x],
            [b * x * z - a * y, b * y * z + a * x, 1.0 + b * (z * z - t2)],
        ]
    )


def quat_xyzw_from_matrix(R: np.ndarray) -> np.ndarray:
    """Unit quaternion (x, y, z, w) of a rotation matrix, canonical ``w >= 0``.

    Uses Shepperd's method (the largest of the four candidates), accurate for
    every angle including pi; where the trace is positive (``w >= 1/2``) the
    trace branch is taken without comparing the candidates.

    Parameters
    ----------
    R : array, shape (..., 3, 3)

    Returns
    -------
    q_xyzw : array, shape (..., 4)
        Scalar last; ``w >= 0``.
    """
    R = np.asarray(R, dtype=float)
    tr = R[..., 0, 0] + R[..., 1, 1] + R[..., 2, 2]
    trace = tr > 0.0  # w >= 1/2: the trace branch alone is well conditioned (most rotations; 3x faster)
    if not np.all(trace):
        if not np.any(trace):
            return _quat_shepperd(R)
        q = np.empty(R.shape[:-2] + (4,))
        q[trace] = quat_xyzw_from_matrix(R[trace])
        q[~trace] = _quat_shepperd(R[~trace])
        return q
    S = 2.0 * np.sqrt(1.0 + tr)  # 4 w
    q = np.stack(
        [R[..., 2, 1] - R[..., 1, 2], R[..., 0, 2] - R[..., 2, 0], R[..., 1, 0] - R[..., 0, 1], 0.25 * S * S], -1
    )
    q /= S[..., None]
    q /= np.sqrt(np.einsum("...i,...i->...", q, q))[..., None]
    return q


def _quat_shepperd(R: np.ndarray) -> np.ndarray:
    """:func:`quat_xyzw_from_matrix` by Shepperd's method for any angle, shape (..., 4)."""
    R = np.asarray(R, dtype=float)
    r00, r11, r22 = R[..., 0, 0], R[..., 1, 1], R[..., 2, 2]
    tr = r00 + r11 + r22
    cand = np.stack([tr, r00, r11, r22], axis=-1)
    k = np.argmax(cand, axis=-1)
    c_k = np.take_along_axis(cand, k[..., None], -1)[..., 0]
    S = 2.0 * np.sqrt(np.maximum(1.0 + 2.0 * c_k - tr, 1e-300))  # 4 * |largest component|
    d21, d02, d10 = R[..., 2, 1] - R[..., 1, 2], R[..., 0, 2] - R[..., 2, 0], R[..., 1, 0] - R[..., 0, 1]
    s21, s02, s10 = R[..., 2, 1] + R[..., 1, 2], R[..., 0, 2] + R[..., 2, 0], R[..., 1, 0] + R[..., 0, 1]
    # row k: (x, y, z, w) times S when candidate k is the largest; the rows gathered by k in one step
    table = np.stack(
        [
            np.stack([d21, d02, d10, 0.25 * S * S], axis=-1),
            np.stack([0.25 * S * S, s10, s02, d21], axis=-1),
            np.stack([s10, 0.25 * S * S, s21, d02], axis=-1),
            np.stack([s02, s21, 0.25 * S * S, d10], axis=-1),
        ],
        axis=-2,
    )
    q = np.take_along_axis(table, k[..., None, None], axis=-2)[..., 0, :] / S[..., None]
    q /= np.linalg.norm(q, axis=-1, keepdims=True)
    q *= np.where(q[..., 3:4] < 0, -1.0, 1.0)
    return q


def matrix_from_quat_xyzw(q_xyzw: np.ndarray, normalize: bool = True) -> np.ndarray:
    """Rotation matrix of a quaternion in (x, y, z, w) order.

    Parameters
    ----------
    q_xyzw : array, shape (..., 4)
        Scalar last.
    normalize : bool
        Normalise first (default); pass False only for quaternions known to be unit.

    Returns
    -------
    R : array, shape (..., 3, 3)
    """
    q = np.asarray(q_xyzw, dtype=float)
    if normalize:
        q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    x, y, z, w = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    R = np.empty(q.shape[:-1] + (3, 3))
    R[..., 0, 0] = 1 - 2 * (y * y + z * z)
    R[..., 0, 1] = 2 * (x * y - z * w)
    R[..., 0, 2] = 2 * (x * z + y * w)
    R[..., 1, 0] = 2 * (x * y + z * w)
    R[..., 1, 1] = 1 - 2 * (x * x + z * z)
    R[..., 1, 2] = 2 * (y * z - x * w)
    R[..., 2, 0] = 2 * (x * z - y * w)
    R[..., 2, 1] = 2 * (y * z + x * w)
    R[..., 2, 2] = 1 - 2 * (x * x + y * y)
    return R


def quat_wxyz_to_xyzw(q_wxyz: np.ndarray) -> np.ndarray:
    """Reorder quaternions from (w, x, y, z) to (x, y, z, w).

    Parameters
    ----------
    q_wxyz : array, shape (..., 4)

    Returns
    -------
    q_xyzw : array, shape (..., 4)
    """
    q = np.asarray(q_wxyz, dtype=float)
    return np.concatenate([q[..., 1:], q[..., :1]], axis=-1)


def quat_xyzw_to_wxyz(q_xyzw: np.ndarray) -> np.ndarray:
    """Reorder quaternions from (x, y, z, w) to (w, x, y, z).

    Parameters
    ----------
    q_xyzw : array, shape (..., 4)

    Returns
    -------
    q_wxyz : array, shape (..., 4)
    """
    q = np.asarray(q_xyzw, dtype=float)
    return np.concatenate([q[..., 3:], q[..., :3]], axis=-1)


def quat_multiply_wxyz(p_wxyz: np.ndarray, q_wxyz: np.ndarray) -> np.ndarray:
    """Hamilton product ``p * q`` of quaternions in (w, x, y, z) order.

    The scalar-first order is used internally by the dual-quaternion and
    quaternion solvers, where the algebra is written that way; public
    functions take (x, y, z, w).

    Parameters
    ----------
    p_wxyz, q_wxyz : array, shape (..., 4)

    Returns
    -------
    pq_wxyz : array, shape (..., 4)
    """
    p0, pv = p_wxyz[..., :1], p_wxyz[..., 1:]
    q0, qv = q_wxyz[..., :1], q_wxyz[..., 1:]
    w = p0 * q0 - np.sum(pv * qv, axis=-1, keepdims=True)
    v = p0 * qv + q0 * pv + np.cross(pv, qv)
    return np.concatenate([w, v], axis=-1)


def so3_log(R: np.ndarray) -> np.ndarray:
    """Rotation vector (axis times angle, radians) of a rotation matrix.

    Accurate at all angles, including near 0 and pi: up to 120 degrees from
    the skew part, ``theta / sin(theta) * vee(R - R^T) / 2`` (relative accuracy
    near 0), beyond that through the quaternion (Shepperd), where the skew part
    vanishes. Residual rotations are almost all small, so the quaternion path
    (three times slower) is rarely taken.

    Parameters
    ----------
    R : array, shape (..., 3, 3)

    Returns
    -------
    rotvec : array, shape (..., 3)
        Angle in ``[0, pi]``.
    """
    R = np.asarray(R, dtype=float)
    s = vee(R)  # sin(theta) * axis
    c = 0.5 * (R[..., 0, 0] + R[..., 1, 1] + R[..., 2, 2] - 1.0)
    sin = np.sqrt(np.einsum("...i,...i->...", s, s))
    theta = np.arctan2(sin, c)
    small = sin < 1e-8
    factor = np.where(small, 1.0 + theta * theta / 6.0, theta / np.where(small, 1.0, sin))
    out = s * factor[..., None]
    far = c < -0.5  # beyond 120 degrees
    if np.any(far):
        out[far] = rotvec_from_quat_xyzw(quat_xyzw_from_matrix(R[far]))
    return out


def rotvec_from_quat_xyzw(q_xyzw: np.ndarray) -> np.ndarray:
    """Rotation vector (axis times angle, radians) of a unit quaternion (x, y, z, w).

    Parameters
    ----------
    q_xyzw : array, shape (..., 4)

    Returns
    -------
    rotvec : array, shape (...,  3)
        Angle in ``[0, pi]`` (the sign of ``q`` does not matter).
    """
    q = np.asarray(q_xyzw, dtype=float)
    q = q * np.where(q[..., 3:4] < 0, -1.0, 1.0)
    v = q[..., :3]
    s = np.linalg.norm(v, axis=-1)
    theta = 2.0 * np.arctan2(s, q[..., 3])
    small = s < 1e-12
    scale = np.where(small, 2.0, theta / np.where(small, 1.0, s))
    return v * scale[..., None]


def rotation_angle(R: np.ndarray) -> np.ndarray:
    """Rotation angle in radians, in ``[0, pi]``, accurate near 0 and pi.

    Parameters
    ----------
    R : array, shape (..., 3, 3)

    Returns
    -------
    angle_rad : array, shape (...)
    """
    R = np.asarray(R, dtype=float)
    sin_part = np.linalg.norm(vee(R), axis=-1)
    cos_part = 0.5 * (np.trace(R, axis1=-2, axis2=-1) - 1.0)
    return np.arctan2(sin_part, cos_part)


def project_to_so3(M: np.ndarray) -> np.ndarray:
    """Nearest rotation matrix in the Frobenius norm (SVD, determinant +1).

    Parameters
    ----------
    M : array, shape (..., 3, 3)

    Returns
    -------
    R : array, shape (..., 3, 3)
    """
    U, _, Vt = np.linalg.svd(np.asarray(M, dtype=float))
    d = np.sign(np.linalg.det(U @ Vt))
    d = np.where(d == 0, 1.0, d)
    D = np.ones(U.shape[:-2] + (3,))
    D[..., 2] = d
    return (U * D[..., None, :]) @ Vt


def make_transform(R: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Homogeneous transform from a rotation and a translation.

    Parameters
    ----------
    R : array, shape (..., 3, 3)
    t : array, shape (..., 3)
        Metres.

    Returns
    -------
    T : array, shape (..., 4, 4)
    """
    R = np.asarray(R, dtype=float)
    t = np.asarray(t, dtype=float)
    shape = np.broadcast_shapes(R.shape[:-2], t.shape[:-1])
    T = np.zeros(shape + (4, 4))
    T[..., :3, :3] = R
    T[..., :3, 3] = t
    T[..., 3, 3] = 1.0
    return T


def invert_transform(T_a_b: np.ndarray) -> np.ndarray:
    """Inverse of a rigid transform: ``T_b_a`` from ``T_a_b``.

    Parameters
    ----------
    T_a_b : array, shape (..., 4, 4)

    Returns
    -------
    T_b_a : array, shape (..., 4, 4)
    """
    T_a_b = np.asarray(T_a_b, dtype=float)
    R_t = np.swapaxes(T_a_b[..., :3, :3], -1, -2)
    t = -(R_t @ T_a_b[..., :3, 3:4])[..., 0]
    return make_transform(R_t, t)


def transform_from_pos_quat_xyzw(t: np.ndarray, q_xyzw: np.ndarray) -> np.ndarray:
    """Transform from a translation and an (x, y, z, w) quaternion.

    Parameters
    ----------
    t : array, shape (..., 3)
        Metres.
    q_xyzw : array, shape (..., 4)
        Scalar last.

    Returns
    -------
    T : array, shape (..., 4, 4)
    """
    return make_transform(matrix_from_quat_xyzw(q_xyzw), t)


def pos_quat_xyzw_from_transform(T: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Translation and (x, y, z, w) quaternion (``w >= 0``) of a transform.

    Parameters
    ----------
    T : array, shape (..., 4, 4)

    Returns
    -------
    t : array, shape (..., 3)
    q_xyzw : array, shape (..., 4)
    """
    T = np.asarray(T, dtype=float)
    return T[..., :3, 3].copy(), quat_xyzw_from_matrix(T[..., :3, :3])


def transform_from_rotvec_translation(rotvec: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Transform from a rotation vector (radians) and a translation (metres).

    Parameters
    ----------
    rotvec : array, shape (..., 3)
    t : array, shape (..., 3)

    Returns
    -------
    T : array, shape (..., 4, 4)
    """
    return make_transform(so3_exp(rotvec), t)
