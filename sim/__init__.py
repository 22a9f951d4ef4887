"""Simulator (Pinocchio UR robot, pyrender scenes) and labelled datasets.

Modules: :mod:`handeye.robot.model` (UR5/UR3 from example-robot-data through Pinocchio:
FK, IK, the reference point), :mod:`sim.cameras` (placement presets on a
hemisphere by azimuth region), :mod:`sim.scene` and :mod:`sim.render` (the
pyrender cell: links, gripper, asymmetric lab, board on the flange),
:mod:`sim.opengl` (the one OpenGL/OpenCV camera conversion; this package is
the only place that sees an OpenGL pose), :mod:`sim.recording` (board views
and data configurations per camera pose), :mod:`sim.generate` (sharded,
resumable, multi-process dataset generation in the format of
:mod:`handeye.core.dataset`).
"""
