"""handeye: robot hand-eye calibration, classic and learned.

Two layers live here, one above and one below the engines (``classic``,
``sim``, ``learned``):

* :mod:`handeye.core`, the foundation every package stands on (numpy only):
  SE(3), errors, validation, metrics, the two setups, pose files, the dataset
  format, synthetic problems. It imports nothing from ``classic``, ``sim``,
  ``learned`` or the front.
* the front, the rest of this package: the ``handeye`` command
  (:mod:`handeye.cli`, :mod:`handeye.commands`) and the modules that compose
  the engines (labelling, image calibration, the checked pose loader, contact
  sheets). It may import everything; nothing imports it.

``tests/test_layers.py`` reads every module's imports and enforces this.

Conventions, written once (details and the mapping to OpenCV, ROS tf and
pyrender in :mod:`handeye.core.conventions`):

* ``T_a_b`` is the pose of frame ``b`` in frame ``a``: ``p_a = T_a_b @ p_b``,
  ``T_a_c = T_a_b @ T_b_c``; batched as ``(..., 4, 4)``.
* Frames: ``base``, ``ee`` (flange, ``tool0``), ``ref``, ``cam`` (OpenCV
  optical: x right, y down, z forward), ``target`` (board), ``world``.
* Eye-to-hand: ``X = T_base_cam``, ``Y = T_ee_target``; eye-in-hand:
  ``X = T_ee_cam``, ``Y = T_base_target``; measurements ``T_base_ee`` and
  ``T_cam_target``.
* Metres and radians inside; millimetres and degrees in reports, named so.
* Quaternions ``(x, y, z, w)``, scalar last, ``w >= 0``.
* Bad input raises a :class:`ValueError` subclass from :mod:`handeye.core.errors`.

Foundation modules: :mod:`~handeye.core.se3` (rotations, quaternions,
transforms), :mod:`~handeye.core.validation`, :mod:`~handeye.core.errors`,
:mod:`~handeye.core.metrics`, :mod:`~handeye.core.setups`,
:mod:`~handeye.core.synthetic` (problems with known truth),
:mod:`~handeye.core.posefile` (CSV/JSON pose files),
:mod:`~handeye.core.dataset`, :mod:`~handeye.core.optional`,
:mod:`~handeye.core.conventions`, :mod:`~handeye.core.rigid`.
Front: :mod:`~handeye.cli`,
:mod:`~handeye.labelling`, :mod:`~handeye.image_calibration`,
:mod:`~handeye.checked_poses`, :mod:`~handeye.contact_sheet`,
:mod:`~handeye.markerless` (the board-free hybrid),
:mod:`~handeye.learned_frames` (frames with the arm's keypoints),
:mod:`~handeye.robot_model` (a dataset's robot).
"""

__version__ = "0.1.0"
