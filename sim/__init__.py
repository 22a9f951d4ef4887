"""Simulator (pyrender scenes of a Pinocchio robot) and labelled datasets.

The robot, its surface and the depth sensors' profiles are not the simulator's: they live in
:mod:`handeye.robot` (a real cell's calibration needs them without rendering), which this package uses.

Modules: :mod:`sim.cameras` (placement presets on a
hemisphere by azimuth region), :mod:`sim.scene` and :mod:`sim.render` (the
pyrender cell: links, gripper, asymmetric lab, board on the flange),
:mod:`sim.opengl` (the one OpenGL/OpenCV camera conversion; this package is
the only place that sees an OpenGL pose), :mod:`sim.recording` (board views
and data configurations per camera pose), :mod:`sim.sensors` (a depth profile's errors applied to rendered
depth), :mod:`sim.generate` (sharded,
resumable, multi-process dataset generation in the format of
:mod:`handeye.core.dataset`), :mod:`sim.stream` with :mod:`sim.stream_events`, :mod:`sim.stream_timeline`
and :mod:`sim.stream_render` (a running cell recorded for minutes, bumped, occluded, drifting).
"""
