"""handeye: robot hand-eye calibration, classic and learned.

This package is the foundation the others share (light: numpy only) and the
user-facing front (the ``handeye`` command).

Conventions, written once (details and the mapping to OpenCV, ROS tf and
pyrender in :mod:`handeye.conventions`):

* ``T_a_b`` is the pose of frame ``b`` in frame ``a``: ``p_a = T_a_b @ p_b``,
  ``T_a_c = T_a_b @ T_b_c``; batched as ``(..., 4, 4)``.
* Frames: ``base``, ``ee`` (flange, ``tool0``), ``ref``, ``cam`` (OpenCV
  optical: x right, y down, z forward), ``target`` (board), ``world``.
* Eye-to-hand: ``X = T_base_cam``, ``Y = T_ee_target``; eye-in-hand:
  ``X = T_ee_cam``, ``Y = T_base_target``; measurements ``T_base_ee`` and
  ``T_cam_target``.
* Metres and radians inside; millimetres and degrees in reports, named so.
* Quaternions ``(x, y, z, w)``, scalar last, ``w >= 0``.
* Bad input raises a :class:`ValueError` subclass from :mod:`handeye.errors`.

Modules: :mod:`~handeye.se3` (rotations, quaternions, transforms),
:mod:`~handeye.validation`, :mod:`~handeye.metrics`, :mod:`~handeye.setups`,
:mod:`~handeye.synthetic` (problems with known truth), :mod:`~handeye.posefile`
(CSV/JSON pose files), :mod:`~handeye.optional`, :mod:`~handeye.cli`.
"""

__version__ = "0.1.0"
