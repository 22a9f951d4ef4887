"""Real recordings from physical robots for ``benchmarks/real_recordings.py``: the shipped ones and those read
from a path.

Shipped (``benchmarks/data/real/<name>/``, each with a ``SOURCE`` file: origin, commit, licence, frames):

- ``camodocal_artag``: 42 pose pairs, a static camera and an AR tag on the flange (eye-to-hand),
  jhu-lcsr/handeye_calib_camodocal, BSD-2-Clause. Its camera poses are in the ROS body frame
  ``camera_link`` (x forward); :func:`load_camodocal` turns them into the optical frame.
- ``ethz_robot_arm``: a robot arm with an SR300 on its hand (eye-in-hand), an AprilTag grid, streams of
  robot poses (50 Hz) and camera poses (30 Hz) while it moves, ethz-asl/hand_eye_calibration, BSD-3-Clause;
  :func:`load_ethz_stream` estimates the clocks' offset and pairs them.

Read from a path (no licence file, so not shipped; the documentation says where to get them):

- RWHE-Calib's KUKA recordings (github.com/ihtishamaliktk/RWHE-Calib, ``Datasets/kuka_1``, ``kuka_2``):
  eye-in-hand, checkerboard images, ``RobotPosesVec.txt`` (one row-major 4x4 ``T_base_ee`` per line,
  metres) and ``squaresize.txt``; :func:`load_rwhe_folder`.

The benchmarks are not part of the installed package: the files are found beside this module
(:data:`DATA`), which holds in a clone of the repository.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

#: The shipped recordings' folder, beside this module (a clone of the repository has it; the wheel does not).
DATA = Path(__file__).resolve().parent / "data" / "real"
#: Checkerboards of the RWHE-Calib KUKA recordings, squares (x, y), from the images (inner corners
#: 28 x 17 and 24 x 17, found by ``cv2.findChessboardCornersSB``); the square size is the folder's file.
RWHE_BOARDS = {"kuka_1": (29, 18), "kuka_2": (25, 18)}


@dataclass
class Recording:
    """One real recording: paired poses, and the images' views where it has them.

    Attributes
    ----------
    name : str
    setup : {"eye_to_hand", "eye_in_hand"}
    T_base_ee : array, shape (N, 4, 4)
        Robot flange poses in the base frame, metres.
    T_cam_target : array, shape (N, 4, 4)
        Target poses in the camera's optical frame, metres (PnP poses for an image recording).
    source : str
        Where it comes from and under which licence, one line.
    views : classic.vision.views.Views or None
        An image recording's detections (all views; ``T_base_ee`` and ``T_cam_target`` hold the accepted ones).
    T_base_ee_all : array, shape (V, 4, 4) or None
        An image recording's robot pose of every view, accepted or not.
    view_index : array of int, shape (N,) or None
        An image recording's view (index into ``views.views``) of each pose.
    notes : list of str
    """

    name: str
    setup: str
    T_base_ee: np.ndarray
    T_cam_target: np.ndarray
    source: str
    views: object | None = None
    T_base_ee_all: np.ndarray | None = None
    view_index: np.ndarray | None = None
    notes: list = field(default_factory=list)

    def subset(self, idx: np.ndarray) -> "Recording":
        """The recording cut to the poses ``idx`` (a note says so)."""
        n = len(self.T_base_ee)
        return replace(
            self,
            T_base_ee=self.T_base_ee[idx],
            T_cam_target=self.T_cam_target[idx],
            view_index=None if self.view_index is None else self.view_index[idx],
            notes=[*self.notes, f"cut to {len(idx)} of its {n} poses"],
        )


def load_camodocal(folder: str | Path | None = None) -> Recording:
    """camodocal's example recording: ``TransformPairsInput.yml``, 42 pairs, eye-to-hand.

    Parameters
    ----------
    folder : str or Path, optional
        Default: the shipped copy, ``benchmarks/data/real/camodocal_artag``.

    Returns
    -------
    Recording
        ``T_base_ee`` from ``T1_i``; ``T_cam_target`` from ``T2_i`` (tag in ``camera_link``) turned into the
        optical frame.
    """
    from handeye.core.opencv_pose_pairs import read_opencv_pose_pairs

    folder = Path(folder) if folder is not None else DATA / "camodocal_artag"
    pairs = read_opencv_pose_pairs(folder / "TransformPairsInput.yml", camera_frame="ros-body")
    return Recording(
        name="camodocal_artag",
        setup="eye_to_hand",
        T_base_ee=pairs.T_base_ee,
        T_cam_target=pairs.T_cam_target,
        source="jhu-lcsr/handeye_calib_camodocal e387f66, example/TransformPairsInput.yml, BSD-2-Clause (shipped)",
        notes=["camera poses in camera_link (ROS body frame), turned into the optical frame"],
    )


#: Every how many camera poses of the ETH stream one is paired (1,703 poses at 30 Hz: about 100 pairs, 0.57 s
#: apart, so that neighbouring pairs' errors are not the same error twice).
ETHZ_STRIDE = 17


def load_ethz_stream(folder: str | Path | None = None, stride: int = ETHZ_STRIDE) -> Recording:
    """ETH's robot-arm streams, paired: the clocks' offset estimated, the robot interpolated at camera times.

    Parameters
    ----------
    folder : str or Path, optional
        Default: the shipped copy, ``benchmarks/data/real/ethz_robot_arm``.
    stride : int
        Every ``stride``-th camera pose is paired.

    Returns
    -------
    Recording
        ``T_base_ee`` interpolated (:class:`classic.RobotStream`) at the camera times shifted by the offset
        that :func:`classic.calibrate_stream` estimates on the same pairs; ``T_cam_target`` the inverse of the
        file's camera-in-target poses.
    """
    import warnings

    import classic
    from handeye.core.se3 import invert_transform, transform_from_pos_quat_xyzw

    folder = Path(folder) if folder is not None else DATA / "ethz_robot_arm"
    robot = np.loadtxt(folder / "robot_arm_complete_bag_color_and_ir_base_link_sr300_hinge.csv", delimiter=",")
    camera = np.loadtxt(folder / "robot_arm_complete_bag_color_and_ir_target_ir.csv", delimiter=",")[::stride]
    t0 = robot[0, 0]  # seconds since 1970 lose their microseconds in differences of float64: shift first
    t_robot, t_cam = robot[:, 0] - t0, camera[:, 0] - t0
    T_base_ee = transform_from_pos_quat_xyzw(robot[:, 1:4], robot[:, 4:8])
    T_cam_target = invert_transform(transform_from_pos_quat_xyzw(camera[:, 1:4], camera[:, 4:8]))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = classic.calibrate_stream(t_robot, T_base_ee, t_cam, T_cam_target, setup="eye_in_hand")
    offset = res.diagnostics["time_offset"]
    used = np.asarray(offset["poses_used"])
    T_paired, _ = classic.RobotStream(t_robot, T_base_ee).at(t_cam[used] + offset["value_s"])
    return Recording(
        name="ethz_robot_arm",
        setup="eye_in_hand",
        T_base_ee=T_paired,
        T_cam_target=T_cam_target[used],
        source="ethz-asl/hand_eye_calibration 966cd92, robot_arm_w_color_camera_real.zip, BSD-3-Clause (shipped)",
        notes=[
            f"streams paired: every {stride}th camera pose, the robot interpolated at camera time "
            f"{offset['value_s'] * 1e3:+.1f} +- {offset['sigma_s'] * 1e3:.1f} ms (calibrate_stream on the same poses)"
        ],
    )


def _square_size_m(folder: Path) -> float:
    """The square size of an RWHE-Calib folder (``squaresize.txt``, also its misspelt ``sqauresize.txt``)."""
    for name in ("squaresize.txt", "sqauresize.txt", "square size.txt"):
        f = folder / name
        if f.exists():
            m = re.fullmatch(r"\s*([0-9.]+)\s*(mm|m)?\s*", f.read_text())
            if m:
                return float(m.group(1)) / (1000.0 if m.group(2) == "mm" or float(m.group(1)) > 1 else 1.0)
    raise FileNotFoundError(f"{folder}: no squaresize.txt")


def load_rwhe_folder(folder: str | Path, squares: tuple[int, int] | None = None, progress: bool = False) -> Recording:
    """An RWHE-Calib recording (eye-in-hand, checkerboard images and ``RobotPosesVec.txt``).

    Images are paired with the poses' rows by order (``01.png`` with row 1). The intrinsics are calibrated
    from the same images (the folder has none), the board detected, each view's pose found by PnP.

    Parameters
    ----------
    folder : str or Path
        E.g. a clone's ``Datasets/kuka_1``.
    squares : (int, int), optional
        Checkerboard squares (x, y); default from :data:`RWHE_BOARDS` by the folder's name.
    progress : bool

    Returns
    -------
    Recording
    """
    from classic.vision.board import BoardSpec
    from classic.vision.views import detect_folder
    from handeye.core.matrix_poses import read_pose_matrices

    folder = Path(folder)
    squares = squares or RWHE_BOARDS.get(folder.name)
    if squares is None:
        raise ValueError(f"{folder}: board unknown; give its squares (x, y)")
    spec = BoardSpec.checkerboard(squares[0], squares[1], _square_size_m(folder))
    T_base_ee_all, _ = read_pose_matrices(folder / "RobotPosesVec.txt", what="T_base_ee")
    views, _ = detect_folder(folder, spec, progress=progress)
    if len(views.views) != len(T_base_ee_all):
        raise ValueError(f"{folder}: {len(views.views)} images but {len(T_base_ee_all)} robot poses")
    ok = [k for k, v in enumerate(views.views) if v.pose.ok]
    return Recording(
        name=folder.name,
        setup="eye_in_hand",
        T_base_ee=T_base_ee_all[ok],
        T_cam_target=np.array([views.views[k].pose.T_cam_target for k in ok]),
        source=f"github.com/ihtishamaliktk/RWHE-Calib Datasets/{folder.name}, no licence (read from {folder})",
        views=views,
        T_base_ee_all=T_base_ee_all,
        view_index=np.array(ok, dtype=int),
        notes=[views.intrinsics_report, f"{len(ok)} of {len(views.views)} views with a pose"],
    )
