"""Learned continual hand-eye calibration (torch): the paper's regression networks and strategies.

Modules: :mod:`learned.model` (RGB and depth encoders keeping spatial layout,
reference pose, fully connected head; translation and orientation networks),
:mod:`learned.quaternion` (the 10-D quaternion layer), :mod:`learned.losses`,
:mod:`learned.metrics` (eq. 2), :mod:`learned.data` (frames of a labelled
dataset), :mod:`learned.trainer`, :mod:`learned.strategies` (batch, naive,
reservoir with class balance, camera-pose selection), :mod:`learned.replay` (the one
class-balanced replay buffer), :mod:`learned.continual_step` (Algorithms 1 and 2's step,
written once), :mod:`learned.presets` (the experiment presets), :mod:`learned.experiment`
(the protocol), :mod:`learned.checkpoint` (its per-step checkpoint, for resuming),
:mod:`learned.report` (tables and figures), :mod:`learned.calibrator` (the online
:class:`ContinualCalibrator`), :mod:`learned.distributed` (data-parallel training under torchrun)
with :mod:`learned.global_batchnorm` (batch norm over the whole batch of a data-parallel step).

It never imports :mod:`sim` or :mod:`classic`: it reads datasets and their labels
through :mod:`handeye.core.dataset`.
"""
