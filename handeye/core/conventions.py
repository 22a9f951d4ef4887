"""Conventions of handeye, written once, and their mapping to OpenCV, ROS tf and pyrender.

Poses
-----
``T_a_b`` is a 4x4 homogeneous transform, the pose of frame ``b`` in frame
``a``: it maps coordinates of a point in ``b`` to ``a``, ``p_a = T_a_b @ p_b``,
and chains as ``T_a_c = T_a_b @ T_b_c``; ``T_b_a = inv(T_a_b)``
(:func:`handeye.core.se3.invert_transform`). Arrays are batched ``(..., 4, 4)``.

Frames: ``base`` (robot base), ``ee`` (flange, Pinocchio/URDF frame
``tool0``), ``ref`` (reference point on the end-effector), ``cam`` (OpenCV
optical frame: x right, y down, z forward), ``target`` (calibration board,
OpenCV's board frame), ``world``.

Units: metres and radians inside; reports in millimetres and degrees, and the
name says so (``translation_mm``, ``rotation_deg``).

Quaternions: ``(x, y, z, w)``, scalar last (scipy, ROS), canonical ``w >= 0``;
converters for other orders are named (:func:`handeye.core.se3.quat_wxyz_to_xyzw`).

Setups
------
==============  =================================  =============================
setup           unknown camera pose ``X``           unknown target pose ``Y``
==============  =================================  =============================
eye-to-hand     ``T_base_cam`` (static camera)      ``T_ee_target`` (board on flange)
eye-in-hand     ``T_ee_cam`` (camera on flange)     ``T_base_target`` (static board)
==============  =================================  =============================

Measurements are always ``T_base_ee`` (robot) and ``T_cam_target`` (board
detection); :mod:`handeye.core.setups` reduces both setups to ``A_i Y = X B_i``.

OpenCV
------
OpenCV names a transform ``R_x2y, t_x2y`` when it maps points from ``x`` to
``y``: ``R_x2y`` is the rotation of ``T_y_x``. So ``R_gripper2base`` is the
rotation of ``T_base_ee`` and ``R_target2cam`` that of ``T_cam_target``
(``rvec, tvec`` of ``solvePnP``). With ``cv2.calibrateHandEye``:

* eye-in-hand: pass ``T_base_ee`` as ``gripper2base`` and ``T_cam_target``
  as ``target2cam``; the output ``cam2gripper`` is ``T_ee_cam``.
* eye-to-hand: pass ``inv(T_base_ee)`` (``base2gripper``) in the
  ``gripper2base`` slot; the output ``cam2gripper`` is then ``T_base_cam``.

:func:`opencv_hand_eye_args` builds these lists; the tests check the mapping
against OpenCV. ``cv2.calibrateRobotWorldHandEye(R_world2cam, ...,
R_base2gripper, ...)`` solves ``A X = Z B``; see :func:`classic.shah` for
the mapping of our ``A_i X = Y B_i``.

ROS tf
------
A tf ``lookupTransform(target_frame="a", source_frame="b")`` returns
``T_a_b`` (the pose of ``b`` in ``a``), translation plus quaternion
``(x, y, z, w)``: ``T_base_cam`` is ``lookup("base", "camera_optical_frame")``.
ROS camera *body* frames (x forward, z up) differ from the optical frame
used here by a fixed rotation; use the ``*_optical_frame``.

easy_handeye samples hold the robot transform as ``T_base_ee`` (eye-in-hand)
but ``T_ee_base`` (eye-on-base, our eye-to-hand), and the tracking transform
as ``T_cam_target``; its calibration ``transform`` is our ``X``
(:mod:`handeye.core.easy_handeye`). tf2_ros ``static_transform_publisher
--x .. --qw .. --frame-id a --child-frame-id b`` publishes ``T_a_b``.

Robot controllers and URDF
--------------------------
Euler angles are one family, ``R = Rz(gamma) Ry(beta) Rx(alpha)``, listed in
different orders (:mod:`handeye.core.robot_angles`, tested against scipy):

* KUKA ``A, B, C`` (degrees): ``R = Rz(A) Ry(B) Rx(C)``, scipy
  ``Rotation.from_euler("ZYX", [A, B, C], degrees=True)`` (intrinsic);
* Fanuc ``W, P, R`` (degrees, fixed axes): ``R = Rz(R) Ry(P) Rx(W)``, scipy
  ``Rotation.from_euler("xyz", [W, P, R], degrees=True)`` (extrinsic); so
  Fanuc ``(W, P, R)`` is KUKA ``(C, B, A)``;
* URDF ``<origin rpy="r p y">`` (radians, fixed axes): ``R = Rz(y) Ry(p) Rx(r)``,
  scipy ``Rotation.from_euler("xyz", [r, p, y])``; ``xyz`` is the translation
  of ``T_parent_child`` in metres;
* ABB ``q1, q2, q3, q4``: a quaternion with the scalar first, ``(w, x, y, z)``.

These controllers report millimetres: pose-file columns in these forms are read
in millimetres unless ``--units`` says otherwise (:mod:`handeye.core.posefile`).

pyrender / OpenGL
-----------------
An OpenGL camera looks down its -z axis with y up. The pose of the OpenCV
camera in the OpenGL camera frame is ``diag(1, -1, -1, 1)``, so
``T_world_cvcam = T_world_glcam @ diag(1, -1, -1, 1)``. That conversion
happens once, in :mod:`sim`; nothing outside ``sim/`` sees an OpenGL pose.
"""

from __future__ import annotations

import numpy as np

from handeye.core.se3 import invert_transform
from handeye.core.setups import normalize_setup

__all__ = ["opencv_hand_eye_args"]


def opencv_hand_eye_args(T_base_ee: np.ndarray, T_cam_target: np.ndarray, setup: str) -> tuple[list, list, list, list]:
    """The four input lists of ``cv2.calibrateHandEye`` for a setup.

    Parameters
    ----------
    T_base_ee : array, shape (N, 4, 4)
    T_cam_target : array, shape (N, 4, 4)
    setup : {"eye_to_hand", "eye_in_hand"}

    Returns
    -------
    R_gripper2base, t_gripper2base, R_target2cam, t_target2cam : list of arrays
        Rotations ``(3, 3)`` and translations ``(3, 1)``. For eye-to-hand the
        first two hold ``inv(T_base_ee)``, and OpenCV's ``cam2gripper`` output
        is ``T_base_cam``; for eye-in-hand it is ``T_ee_cam``.
    """
    G = T_base_ee if normalize_setup(setup) == "eye_in_hand" else invert_transform(T_base_ee)
    return [*G[:, :3, :3]], [*G[:, :3, 3:]], [*T_cam_target[:, :3, :3]], [*T_cam_target[:, :3, 3:]]
