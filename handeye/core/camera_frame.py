"""The camera frame of camera poses: OpenCV's optical frame, or a ROS body frame converted to it.

handeye's camera frame is the optical frame (OpenCV, ROS ``*_optical_frame``): x right, y down, z forward
along the line of sight. ROS drivers also publish a body frame (``camera_link``, REP 103): x forward,
y left, z up. A target pose looked up in tf from ``camera_link`` is in the body frame; taken as optical,
the solvers still fit (the body frame is rigidly attached), but every camera-side quantity is expressed
in the wrong axes: ``T_base_cam`` names the body frame, and the noise model's "along the line of sight"
is the body's z, which is up.

.. math::

    T_{optical\\_target} = T_{optical\\_body} \\, T_{body\\_target}, \\qquad
    R_{optical\\_body} = \\begin{pmatrix} 0 & -1 & 0 \\\\ 0 & 0 & -1 \\\\ 1 & 0 & 0 \\end{pmatrix}

(``x_opt = -y_body``, ``y_opt = -z_body``, ``z_opt = x_body``; REP 103's ``camera_link`` to
``camera_optical_frame`` rotation, no translation).

The data tell which frame they are in: a target the camera sees lies in front of it, far along +z in the
optical frame (within the field of view, ``z > |t| / 2`` for any lens narrower than 120 degrees) and far
along +x in the body frame. :func:`check_camera_frame` refuses poses none of which is in front along z
while nearly all are in front along x.
"""

from __future__ import annotations

import numpy as np

from handeye.core.errors import PoseFileError

__all__ = [
    "CAMERA_FRAMES",
    "FRONT_COSINE",
    "T_OPTICAL_BODY",
    "camera_frame_looks_like_body",
    "check_camera_frame",
    "check_camera_frame_name",
    "to_optical",
]

#: Camera frames a pose file's camera poses may be in.
CAMERA_FRAMES = ("optical", "ros-body")
#: The REP 103 body frame (x forward, y left, z up) in the optical frame (x right, y down, z forward).
T_OPTICAL_BODY = np.array(
    [[0.0, -1.0, 0.0, 0.0], [0.0, 0.0, -1.0, 0.0], [1.0, 0.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0]],
)
#: A target is "in front along an axis" when its direction from the camera is within 60 degrees of it
#: (cosine 0.5): every target of a lens whose field of view is under 120 degrees is in front along the
#: optical z.
FRONT_COSINE = 0.5
#: Share of the poses in front along the body's x, with none in front along z, that names the body frame.
_BODY_SHARE = 0.8


def check_camera_frame_name(camera_frame: str | None, error: type[Exception] = PoseFileError) -> None:
    """Refuse a camera frame name other than ``None``, ``"optical"`` or ``"ros-body"``.

    Raises
    ------
    error
    """
    if camera_frame is not None and camera_frame not in CAMERA_FRAMES:
        raise error(f"camera frame {camera_frame!r} not understood; use one of {', '.join(CAMERA_FRAMES)}")


def to_optical(T_cam_target: np.ndarray, camera_frame: str) -> np.ndarray:
    """Target poses in the optical frame, from poses in ``camera_frame``.

    Parameters
    ----------
    T_cam_target : array, shape (N, 4, 4)
        Target poses in the camera frame named by ``camera_frame``.
    camera_frame : {"optical", "ros-body"}

    Returns
    -------
    T_cam_target : array, shape (N, 4, 4)
        In the optical frame: ``T_optical_body @ T_body_target`` for ``"ros-body"``, unchanged for
        ``"optical"``.

    Raises
    ------
    ValueError
        An unknown frame name.
    """
    if camera_frame not in CAMERA_FRAMES:
        raise ValueError(f"camera frame {camera_frame!r} not understood; use one of {', '.join(CAMERA_FRAMES)}")
    T = np.asarray(T_cam_target, dtype=float)
    return T_OPTICAL_BODY @ T if camera_frame == "ros-body" else T


def camera_frame_looks_like_body(T_cam_target: np.ndarray) -> bool:
    """Whether target positions say the camera frame is a ROS body frame (x forward), not optical (z forward).

    Parameters
    ----------
    T_cam_target : array, shape (N, 4, 4)

    Returns
    -------
    bool
        True when no target is in front along +z (within 60 degrees) and at least 80 % are in front along +x.
    """
    t = np.asarray(T_cam_target, dtype=float)[:, :3, 3]
    norm = np.linalg.norm(t, axis=1)
    keep = norm > 0
    if keep.sum() < 3:
        return False
    direction = t[keep] / norm[keep, None]
    in_front_z = direction[:, 2] > FRONT_COSINE
    in_front_x = direction[:, 0] > FRONT_COSINE
    return not in_front_z.any() and in_front_x.mean() >= _BODY_SHARE


def check_camera_frame(T_cam_target: np.ndarray, source: str, error: type[Exception] = PoseFileError) -> None:
    """Refuse camera poses that look like a ROS body frame, with the fix.

    Parameters
    ----------
    T_cam_target : array, shape (N, 4, 4)
        As read, before any conversion.
    source : str
        The file, for the message.
    error : exception class

    Raises
    ------
    error
        When :func:`camera_frame_looks_like_body`: the message names the share of targets along +x and the
        two ways out (``camera_frame="ros-body"`` to convert, ``"optical"`` to keep the poses as they are).
    """
    if not camera_frame_looks_like_body(T_cam_target):
        return
    t = np.asarray(T_cam_target, dtype=float)[:, :3, 3]
    median = np.median(t, axis=0)
    raise error(
        f"{source}: camera poses in a ROS body frame (x forward), not optical (z forward)? No target is ahead "
        f"along z, the median at [{median[0]:+.3f}, {median[1]:+.3f}, {median[2]:+.3f}]. Convert: --camera-frame "
        "ros-body (camera_frame='ros-body'); keep: --camera-frame optical"
    )
