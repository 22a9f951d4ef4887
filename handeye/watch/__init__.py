"""Watch a running cell's calibration: notice a moved camera, recalibrate without a board, keep every version.

:class:`CellWatcher` takes frames (:class:`Frame`: depth, joints, time) from any source (a dataset replayed,
:func:`dataset_frames`; a ROS 2 bag, :func:`handeye.watch.source.bag_frames`; live ROS 2 topics,
:class:`handeye.watch.ros2.Ros2Frames`; the Python API) and returns events
(:class:`Event`, one line each). Its parts, one job each: the per-frame check (:mod:`.check`), "nothing
moved" and the change test (:mod:`.change`), the frame states (:mod:`.states`), the versions' history
(:mod:`.history`); its outputs beside the history: the static transform (:mod:`.ros2`) and the continual
learner (:mod:`.learner`).
"""

from handeye.watch.cell import CellWatcher, WatchOptions, markerless_recalibration
from handeye.watch.events import Event
from handeye.watch.history import History, Version
from handeye.watch.source import Frame, dataset_frames

__all__ = [
    "CellWatcher",
    "WatchOptions",
    "markerless_recalibration",
    "Event",
    "History",
    "Version",
    "Frame",
    "dataset_frames",
]
