"""Exceptions and warnings raised on bad input.

Every error a user can cause by passing bad data is a subclass of
:class:`HandEyeInputError`, itself a :class:`ValueError`, so
``except ValueError`` catches them all and ``except DegenerateMotionError``
catches exactly one kind. Messages say what is wrong, where (pose index, file,
row) and what to do about it.
"""

from __future__ import annotations


class HandEyeInputError(ValueError):
    """Base class of all errors caused by bad input data."""


class ShapeError(HandEyeInputError):
    """An array has the wrong shape (for example not ``(N, 4, 4)``)."""


class NonFiniteError(HandEyeInputError):
    """An array holds NaN or infinity."""


class NotARotationError(HandEyeInputError):
    """A rotation block is not orthonormal with determinant +1."""


class LengthMismatchError(HandEyeInputError):
    """Two sequences that must be paired have different lengths."""


class TooFewPosesError(HandEyeInputError):
    """Fewer poses than the problem needs (at least 3)."""


class DuplicatePoseError(HandEyeInputError):
    """The same pose pair appears twice: it adds no information."""


class DegenerateMotionError(HandEyeInputError):
    """The motion set cannot determine the unknowns (e.g. all rotations about one axis)."""


class UnitsError(HandEyeInputError):
    """Translations look like they are not in metres."""


class QuaternionOrderError(HandEyeInputError):
    """Quaternions seem to be given in the other component order (xyzw vs wxyz)."""


class ContaminatedPosesError(HandEyeInputError):
    """Some poses disagree with the rest far beyond the noise: a least-squares fit would be pulled off.

    The message names the poses. Remove them, or calibrate with ``robust=True`` (``--robust``).
    """


class InconsistentPosesError(HandEyeInputError):
    """Robot and camera motions disagree in a way no hand-eye transform can explain.

    Typical causes: poses mis-paired, a pose inverted (``T_target_cam`` passed
    for ``T_cam_target``), or the wrong setup (eye-in-hand vs eye-to-hand).
    """


class PoseFileError(HandEyeInputError):
    """A pose file cannot be read; the message names the file and row."""


class OutputFileError(HandEyeInputError):
    """An output path that cannot take a file (a directory, a device, a FIFO, a missing folder) or a write
    that failed (a full disk, no permission); nothing is left half-written."""


class TruthFileError(HandEyeInputError):
    """A truth file (JSON of true poses by frame name) cannot be read; the message names the file."""


class DatasetError(HandEyeInputError):
    """A dataset directory is incomplete or corrupt; the message names the file (and row)."""


class BagError(HandEyeInputError):
    """A ROS bag cannot give what was asked of it; the message names the bag (and topic or frame)."""


class NotABagError(BagError):
    """The path is not a readable ROS 2 bag (a rosbag2 directory with ``metadata.yaml``)."""


class BagTopicError(BagError):
    """A topic is missing from the bag, or holds a message type that cannot be read; the bag's topics are listed."""


class FramesNotConnectedError(BagError):
    """Two tf frames are not connected in the bag's tf tree; the frames reachable from the first are listed."""


class NoPairsError(BagError):
    """No camera sample has a robot pose within the time tolerance."""


class IntrinsicsError(HandEyeInputError):
    """Camera intrinsics are invalid or cannot be read."""


class RecordingError(HandEyeInputError):
    """A recording (a ROS 2 bag or a folder of frames) cannot be imported as a dataset; the message names the
    file or topic."""


class JointNamesError(RecordingError):
    """The recorded joint names do not cover the robot model's joints; both lists are named."""


class ImageSizeError(RecordingError):
    """An image's size is not its camera's (depth against ``camera_info``, colour against depth)."""


class UnsynchronisedError(RecordingError):
    """Streams that must be paired by time (depth, colour, joints) are further apart than the tolerance."""


class WeakMotionWarning(UserWarning):
    """The motion set is poorly conditioned: the estimate will be noisy."""


class SuspectPosesWarning(UserWarning):
    """Some poses lie beyond the outlier bound but barely move the answer: it is returned, the poses named."""


class MissingDependencyError(ImportError):
    """An optional dependency is missing; the message names the extra to install."""
