"""Hand-eye calibration from board detections and robot poses: the front's pipeline.

Composes :mod:`classic.vision` (detections, PnP, reprojection refinement)
with :func:`classic.calibrate` (pose-based solve, checks, robust fit); it
imports both lazily, as the front does.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from handeye.core.errors import LengthMismatchError, PoseFileError

__all__ = ["ImageCalibration", "pair_robot_poses", "calibrate_from_views", "pnp_noise_model"]


@dataclass
class ImageCalibration:
    """Pose-based result, and the reprojection refinement when run.

    Attributes
    ----------
    pose_based : classic.CalibrationResult
        On the accepted views' PnP poses.
    reprojection : classic.vision.ReprojectionResult or None
    images : list of str
        The accepted views, in the order of the results' per-view arrays.
    rejected : dict
        Image name to rejection reason.
    """

    pose_based: object
    reprojection: object | None
    images: list
    rejected: dict

    @property
    def X(self) -> np.ndarray:
        """Final camera pose: the reprojection refinement's when run."""
        return self.reprojection.X if self.reprojection is not None else self.pose_based.X

    @property
    def Y(self) -> np.ndarray:
        """Final target pose."""
        return self.reprojection.Y if self.reprojection is not None else self.pose_based.Y


def pair_robot_poses(
    images: list[str], robot_images: list[str] | None, T_base_ee: np.ndarray, source: str
) -> np.ndarray:
    """Robot pose of each image: by the robot file's ``image`` column, or by order.

    Parameters
    ----------
    images : list of str
        Image names of the detections, in order.
    robot_images : list of str or None
        The robot file's ``image`` column, if it has one.
    T_base_ee : array, shape (M, 4, 4)
    source : str
        The robot file, for messages.

    Returns
    -------
    T_base_ee : array, shape (len(images), 4, 4)

    Raises
    ------
    LengthMismatchError, PoseFileError
    """
    if robot_images is None:
        if len(images) != len(T_base_ee):
            raise LengthMismatchError(
                f"{len(images)} images but {len(T_base_ee)} robot poses in {source}: with no 'image' column the "
                "poses are paired with the images in name order, one each; add an 'image' column to pair by name"
            )
        return T_base_ee
    index = {}
    for k, name in enumerate(robot_images):
        if name in index:
            raise PoseFileError(f"{source}: image {name!r} appears twice (rows {index[name] + 1} and {k + 1})")
        index[name] = k
    missing = [im for im in images if im not in index]
    if missing:
        raise PoseFileError(
            f"{source}: no robot pose for image(s) {', '.join(missing[:5])}" + (" ..." if len(missing) > 5 else "")
        )
    return T_base_ee[[index[im] for im in images]]


def pnp_noise_model(views, accepted: list, T_cam_target: np.ndarray):
    """The camera noise of the accepted views' PnP poses: each its own covariance from its corners.

    Poor along the optical axis, as PnP is; the common scale is left to the residuals
    (``scale_to_residuals``), since the robot's noise adds to the camera's.

    Parameters
    ----------
    views : classic.vision.views.Views
    accepted : list of int
        The views with a PnP pose, in the order of ``T_cam_target``.
    T_cam_target : array, shape (len(accepted), 4, 4)

    Returns
    -------
    classic.noise_model.NoiseModel
    """
    import classic
    from classic.vision.pose_covariance import pose_covariances

    covs, _ = pose_covariances(
        T_cam_target,
        [views.views[k].detection.ids for k in accepted],
        [views.views[k].detection.corners_px for k in accepted],
        views.spec,
        views.intrinsics,
    )
    return classic.NoiseModel(
        camera_covariance=covs, name="camera, PnP covariance from the corners", scale_to_residuals=True
    )


def calibrate_from_views(
    views,
    T_base_ee: np.ndarray,
    setup: str,
    method: str = "park",
    robust: bool = False,
    reprojection: bool = True,
    refine_intrinsics: bool = False,
) -> ImageCalibration:
    """Calibrate from detected views: pose-based solve, then the corner-reprojection refinement.

    Parameters
    ----------
    views : classic.vision.views.Views
    T_base_ee : array, shape (len(views.views), 4, 4)
        Robot pose of every view (accepted or not), paired.
    setup : {"eye_to_hand", "eye_in_hand"}
    method : str
        Closed form of the pose-based solve.
    robust : bool
        Robust pose-based solve (outlier views excluded from the refinement too).
    reprojection : bool
        Run the reprojection refinement.
    refine_intrinsics : bool
        Refine the intrinsics too.

    Returns
    -------
    ImageCalibration
    """
    import classic
    from classic.vision.reprojection import refine_reprojection

    accepted = [k for k, v in enumerate(views.views) if v.pose.ok]
    rejected = {v.image: v.pose.reason for v in views.views if not v.pose.ok}
    T_cam_target = np.array([views.views[k].pose.T_cam_target for k in accepted]).reshape(-1, 4, 4)
    noise = pnp_noise_model(views, accepted, T_cam_target)
    # with the reprojection refinement to follow, the pose-based fit is its start: a robust loss keeps a
    # view whose PnP pose is off (a grazing board) from pulling it, and the corners then weigh every view
    # for what it holds; without it the pose-based fit is the result, and least squares refuses outliers
    loss = "cauchy" if (reprojection or robust) else "linear"
    res = classic.calibrate(
        T_base_ee[accepted], T_cam_target, setup=setup, method=method, robust=robust, noise=noise, loss=loss
    )
    images = [views.views[k].image for k in accepted]
    rep = None
    if reprojection:
        keep = [k for k, ok in zip(accepted, res.residuals.inliers) if ok]
        rep = refine_reprojection(
            T_base_ee[keep],
            [views.views[k].detection.ids for k in keep],
            [views.views[k].detection.corners_px for k in keep],
            views.spec,
            views.intrinsics,
            res.X,
            res.Y,
            setup=setup,
            refine_intrinsics=refine_intrinsics,
        )
        images = [views.views[k].image for k in keep]
    return ImageCalibration(res, rep, images, rejected)
