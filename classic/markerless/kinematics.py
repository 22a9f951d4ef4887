"""The robot's joint zero offsets as parameters of the registration: model points moved, Jacobian, summary.

The surface is posed by forward kinematics of the recorded joints ``q``; a real arm's joints read ``q`` while
standing at ``q + delta``, its zero offsets ``delta`` of a few tenths of a degree. A tenth of a degree at the
shoulder moves the wrist by a millimetre at 0.6 m, differently in every configuration: taken as exact, the
offsets of issue 41 (0.1-0.3 deg per joint) moved the camera by 4.8 mm while the sigma said tenths.

To first order a point ``p`` (base frame) of part ``k`` at frame ``i`` moves by ``sum_j delta_j (omega_j x p +
v_j)``, with ``(omega_j, v_j)`` the part's twist per joint (:attr:`RobotSurfaceFrames.joint_twists_base`, no
assumption on the robot's structure), and its normal turns by ``sum_j delta_j omega_j x n``. The point-to-plane
residual ``r = n . (x - m(delta))`` then has the columns ``-(n . (omega_j x m + v_j))``; the registration
estimates ``delta`` with the pose under a Gaussian prior about 0 (:data:`JOINT_OFFSET_PRIORS_DEG`), as it does
the intrinsics.

**A joint whose twist is the same on every fitted part in every frame** (the base rotation, joint 1, when only
the moving parts are fitted: its axis stays put in the base frame) moves the whole fitted model rigidly, which is
exactly a motion of the camera: the data cannot tell it from the pose. It is not estimated (its offset held at
0, ``status`` ``"absorbed"``): the answer is the camera in the base frame the robot's own kinematics define,
which is the useful and conventional one. A point the camera sees, then reached by the robot with the same
offset, comes out right; a board's labels computed from the same joint readings absorb it the same way. Where
static parts are fitted as well, its twist differs between them and the arm: it is estimated, and kept only where
the static parts determine it (a round base does not; it is then absorbed as above).

A joint no fitted part moves with (``status`` ``"not seen"``) is not estimated either: it moves nothing the
registration sees. Every other joint is estimated; one the frames leave near its prior (a symmetric last wrist)
keeps the prior's uncertainty, which enters the pose's covariance (marginalised).
"""

from __future__ import annotations

import numpy as np

from classic.markerless.rows import cross_rows

__all__ = [
    "JOINT_OFFSET_PRIORS_DEG",
    "joint_status",
    "joint_offset_prior_deg",
    "moved_model",
    "moved_surface",
    "offset_columns",
    "turned_directions",
    "joint_offsets_summary",
]

#: One sigma of a joint's zero offset per robot profile, degrees. No datasheet states it: issue 41 takes 0.1-0.3
#: deg per joint as an ordinary arm's kinematic error (encoder mounting and zeroing of a UR-class arm, whose
#: per-unit factory calibration is not in the nominal URDF the surface is posed with); 0.2 deg per joint is taken
#: as one sigma, so that the issue's largest offset (0.3) lies within 1.5 sigma of the prior where the frames
#: do not determine a joint. "default" serves any other robot.
JOINT_OFFSET_PRIORS_DEG = {"ur": 0.2, "default": 0.2}


def joint_offset_prior_deg(robot_name) -> float:
    """The prior of :data:`JOINT_OFFSET_PRIORS_DEG` for a robot: its family's (the key its name starts with, "ur5"
    is "ur"), else ``"default"``'s. ``robot_name``: a str, or anything else (a recorded URDF) for the default."""
    name = robot_name.lower() if isinstance(robot_name, str) else ""
    family = next((k for k in JOINT_OFFSET_PRIORS_DEG if k != "default" and name.startswith(k)), "default")
    return JOINT_OFFSET_PRIORS_DEG[family]


#: Twists equal within this (rad/rad and m/rad) on every fitted part and frame: the joint moves them rigidly.
_SAME_TWIST = 1e-7


def joint_status(twists: np.ndarray, frames: np.ndarray, parts: np.ndarray) -> list[str]:
    """Per joint: ``"estimated"``, ``"absorbed"`` (one rigid motion of everything fitted) or ``"not seen"``.

    Parameters
    ----------
    twists : array, shape (N_frames, n_parts, n_joints, 6)
    frames, parts : array of int, shape (P,)
        The (frame, part) pairs the registration fits.

    Returns
    -------
    list of str, length n_joints
    """
    # each (frame, part) once, in order: a count per pair (no sort of the millions of points)
    key = np.flatnonzero(np.bincount(np.asarray(frames) * twists.shape[1] + np.asarray(parts)))
    t = twists.reshape(-1, *twists.shape[2:])[key]  # (P, n_joints, 6)
    out = []
    for j in range(t.shape[1]):
        tj = t[:, j]
        if not np.any(np.abs(tj) > _SAME_TWIST):
            out.append("not seen")
        elif np.all(np.abs(tj - tj[0]) < _SAME_TWIST):
            out.append("absorbed")
        else:
            out.append("estimated")
    return out


def moved_model(points: np.ndarray, normals: np.ndarray, twists: np.ndarray, delta: np.ndarray):
    """Model points and normals moved by the joint offsets ``delta``, to first order.

    Parameters
    ----------
    points, normals : array, shape (N, 3)
        Posed at the recorded joints, base frame.
    twists : array, shape (N, J, 6)
    delta : array, shape (J,)
        Offsets, radians (true joint = recorded + delta).

    Returns
    -------
    points, normals : array, shape (N, 3)
        Moved; the normals unit length.
    """
    delta = np.asarray(delta, dtype=float)
    if not np.any(delta):
        return points, normals
    return _moved(points, normals, np.einsum("njk,j->nk", twists, delta))


def turned_directions(directions: np.ndarray, twists: np.ndarray, delta: np.ndarray) -> np.ndarray:
    """Tangent directions turned with the surface by the joint offsets ``delta``, to first order, as
    :func:`moved_model` turns the normals (so a direction orthogonal to its normal stays so, to first order).

    Parameters
    ----------
    directions : array, shape (N, 3)
        Unit tangents posed at the recorded joints, base frame.
    twists : array, shape (N, J, 6)
    delta : array, shape (J,)
        Offsets, radians.

    Returns
    -------
    array, shape (N, 3)
        Turned, unit length.
    """
    delta = np.asarray(delta, dtype=float)
    if not np.any(delta):
        return directions
    omega = np.einsum("njk,j->nk", twists[:, :, :3], delta)
    d = directions + cross_rows(omega, directions)
    return d / np.sqrt(np.einsum("ij,ij->i", d, d))[:, None]


def offset_columns(grad: np.ndarray, points: np.ndarray, twists: np.ndarray) -> np.ndarray:
    """Columns of the Jacobian of ``r = n . (x - m(delta))`` in ``delta``: ``-(n . (omega_j x m + v_j))``.

    Parameters
    ----------
    grad : array, shape (N, 3)
        ``dr / dx`` per residual (the normal, or the second-order residual's gradient), base frame.
    points : array, shape (N, 3)
        The model points ``m`` (moved by the current offsets), base frame.
    twists : array, shape (N, J, 6)

    Returns
    -------
    array, shape (N, J)
        Metres per radian.
    """
    # n . (omega x m + v) = omega . (m x n) + v . n: one cross product per point, not per joint
    return -(
        np.einsum("nk,njk->nj", cross_rows(points, grad), twists[:, :, :3])
        + np.einsum("nk,njk->nj", grad, twists[:, :, 3:])
    )


def joint_offsets_summary(
    delta: np.ndarray,
    status: list[str],
    covariance: np.ndarray | None,
    covariance_frames: np.ndarray | None,
    prior_sigma: np.ndarray,
    determined_share: float,
) -> dict:
    """Per joint: the offset in degrees, its sigma, the prior's, and whether the frames determined it.

    Parameters
    ----------
    delta : array, shape (n_joints,)
        The offsets, radians (0 where not estimated).
    status : list of str, length n_joints
        :func:`joint_status`.
    covariance, covariance_frames : array, shape (E, E) or None
        Of the ``E`` estimated joints' offsets (radians), two-way and clustered by frame only (which decides
        whether the frames determined a joint).
    prior_sigma : array, shape (n_joints,)
        Radians.
    determined_share : float
        Determined where the frames leave the sigma below this share of the prior's.

    Returns
    -------
    dict
        ``model`` ``"estimated"``, ``joints``: a list of dicts per joint (``joint``, 1-based; ``status``;
        ``estimate_deg``; ``sigma_deg``; ``prior_sigma_deg``; ``ratio``; ``determined``; ``sigma_deg`` and
        ``ratio`` None where not estimated), and ``note`` on the absorbed joints.
    """
    est = [j for j, s in enumerate(status) if s == "estimated"]
    sd = np.full(len(est), np.nan) if covariance is None else np.sqrt(np.maximum(np.diag(covariance), 0.0))
    frames = covariance if covariance_frames is None else covariance_frames
    sd_f = np.full(len(est), np.nan) if frames is None else np.sqrt(np.maximum(np.diag(frames), 0.0))
    joints = []
    for j, s in enumerate(status):
        row = {"joint": j + 1, "status": s, "estimate_deg": 0.0, "prior_sigma_deg": float(np.degrees(prior_sigma[j]))}
        if s == "estimated":
            i = est.index(j)
            ratio = float(sd_f[i] / prior_sigma[j])
            row.update(
                estimate_deg=float(np.degrees(delta[j])),
                sigma_deg=float(np.degrees(sd[i])),
                ratio=ratio,
                determined=bool(ratio < determined_share),
            )
        else:
            row.update(sigma_deg=None, ratio=None, determined=False)  # None, not NaN: the JSON stays standard
        joints.append(row)
    out = {"model": "estimated", "joints": joints}
    absorbed = [j + 1 for j, s in enumerate(status) if s == "absorbed"]
    if absorbed:
        out["note"] = (
            f"joint(s) {absorbed} move every fitted moving part rigidly (a rotation about the base's fixed axis) and "
            "nothing fitted tells their offsets from the camera's pose: held at 0, and the pose is the camera in the "
            "base frame the robot's own kinematics define"
        )
    return out


def moved_surface(
    points: np.ndarray,
    normals: np.ndarray | None,
    frame: np.ndarray,
    part: np.ndarray,
    twists: np.ndarray,
    delta: np.ndarray,
):
    """The whole stacked surface moved by the joint offsets ``delta``, to first order.

    Per (frame, part) the offsets move the part rigidly by ``sum_j delta_j (omega_j, v_j)``; that motion is
    applied to its points (``omega x p + v``) and normals (``omega x n``).

    Parameters
    ----------
    points : array, shape (M, 3)
        Base frame, posed at the recorded joints.
    normals : array, shape (M, 3), or None
        Their normals; None where only the points are wanted (they are then returned as None).
    frame, part : array of int, shape (M,)
    twists : array, shape (N_frames, n_parts, n_joints, 6)
    delta : array, shape (n_joints,)
        Radians.

    Returns
    -------
    points, normals : array, shape (M, 3) (normals None where not given)
    """
    delta = np.asarray(delta, dtype=float)
    if not np.any(delta):
        return points, normals
    n_parts = twists.shape[1]
    # each (frame, part)'s motion, gathered per point: (M, 6)
    return _moved(points, normals, np.einsum("fpjk,j->fpk", twists, delta).reshape(-1, 6)[frame * n_parts + part])


def _moved(points: np.ndarray, normals: np.ndarray | None, motion: np.ndarray):
    """Points moved by ``omega x p + v`` and normals turned by ``omega x n`` (unit again; None where ``normals``
    is), ``motion`` (N, 6) the ``(omega, v)`` of each."""
    moved = points + cross_rows(motion[:, :3], points) + motion[:, 3:]
    if normals is None:
        return moved, None
    n = normals + cross_rows(motion[:, :3], normals)
    return moved, n / np.sqrt(np.einsum("ij,ij->i", n, n))[:, None]
