"""Hand-eye calibration from board detections and robot poses: the front's pipeline.

Composes :mod:`classic.vision` (detections, PnP, reprojection refinement)
with :func:`classic.calibrate` (pose-based solve, checks, robust fit); it
imports both lazily, as the front does.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from handeye.core.errors import LengthMismatchError, PoseFileError

if TYPE_CHECKING:  # imported where used, as the front does
    from classic.vision.reprojection import ReprojectionOptions

__all__ = [
    "ImageCalibration",
    "HalvesCheck",
    "pair_robot_poses",
    "calibrate_from_views",
    "pnp_noise_model",
    "halves_check",
]


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
    *,
    refinement: ReprojectionOptions | None = None,
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
    refinement : classic.vision.reprojection.ReprojectionOptions, optional
        Its settings (:func:`classic.vision.reprojection.refine_reprojection`): the intrinsics refined, freely or
        under their one-sigma as a prior so that the sigma counts their error (``handeye calibrate
        --detections`` does by default), the loss, and the model of the robot's pose error (estimated from the
        residuals and carried into the sigma by default). Its ``setup`` is replaced by ``setup``. None:
        ``ReprojectionOptions()``'s defaults (the intrinsics taken as exact).

    Returns
    -------
    ImageCalibration
    """
    from dataclasses import replace

    import classic
    from classic.vision.reprojection import ReprojectionOptions, refine_reprojection

    refinement = replace(refinement or ReprojectionOptions(), setup=setup)
    accepted = [k for k, v in enumerate(views.views) if v.pose.ok]
    rejected = {v.image: v.pose.reason for v in views.views if not v.pose.ok}
    T_cam_target = np.array([views.views[k].pose.T_cam_target for k in accepted]).reshape(-1, 4, 4)
    noise = pnp_noise_model(views, accepted, T_cam_target)
    # with the reprojection refinement to follow, the pose-based fit is its start: a robust loss keeps a
    # view whose PnP pose is off (a grazing board) from pulling it, and the corners then weigh every view
    # for what it holds; without it the pose-based fit is the result, and least squares refuses outliers
    loss = "cauchy" if (reprojection or robust) else "linear"
    res = classic.calibrate(
        T_base_ee[accepted],
        T_cam_target,
        setup=setup,
        method=method,
        robust=robust,
        noise=noise,
        options=classic.CalibrateOptions(loss=loss),
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
            refinement,
        )
        images = [views.views[k].image for k in keep]
    return ImageCalibration(res, rep, images, rejected)


@dataclass
class HalvesCheck:
    """Two disjoint halves of the views fitted apart: their disagreement against their own sigma.

    Each half's X is ``calibrate_from_views``'s (the reprojection refinement's, with its sigma); the two
    are independent, so their difference has the covariance ``C_a + C_b`` and an honest sigma gives ratios
    near 1 (the RMS of ``|d| / sqrt(tr(C_a + C_b))`` is 1 for a Gaussian ``d``); an overconfident one gives
    ratios of its overconfidence.

    Attributes
    ----------
    disagreement_deg, disagreement_mm : array, shape (S,)
        Rotation and translation between the two halves' X, per split.
    predicted_deg, predicted_mm : array, shape (S,)
        ``sqrt(sigma_a^2 + sigma_b^2)`` of the halves' reported 1-sigma, per split.
    halves : list of (list of str, list of str)
        The images of each split's two halves.
    """

    disagreement_deg: np.ndarray
    disagreement_mm: np.ndarray
    predicted_deg: np.ndarray
    predicted_mm: np.ndarray
    halves: list

    @property
    def ratio_rotation(self) -> float:
        """RMS disagreement over RMS predicted sigma, rotation."""
        return float(np.sqrt(np.mean(self.disagreement_deg**2) / np.mean(self.predicted_deg**2)))

    @property
    def ratio_translation(self) -> float:
        """RMS disagreement over RMS predicted sigma, translation."""
        return float(np.sqrt(np.mean(self.disagreement_mm**2) / np.mean(self.predicted_mm**2)))

    def to_dict(self) -> dict:
        """JSON-ready (deg, mm)."""
        return {
            "ratio_rotation": self.ratio_rotation,
            "ratio_translation": self.ratio_translation,
            "disagreement_deg": self.disagreement_deg.tolist(),
            "disagreement_mm": self.disagreement_mm.tolist(),
            "predicted_deg": self.predicted_deg.tolist(),
            "predicted_mm": self.predicted_mm.tolist(),
        }


def halves_check(
    views,
    T_base_ee: np.ndarray,
    setup: str,
    method: str = "park",
    n_splits: int = 1,
    rng: np.random.Generator | None = None,
    refine_intrinsics: bool = False,
    robot_noise: str = "estimate",
) -> HalvesCheck:
    """Fit two disjoint halves of the views apart and compare their disagreement with their sigma.

    The first split takes the accepted views alternately (even and odd, in recording order, so that both
    halves span the recording); further splits are random halves drawn with ``rng``. Each half is
    calibrated as :func:`calibrate_from_views` does (pose-based solve, reprojection refinement with the
    robot's pose error estimated).

    Parameters
    ----------
    views : classic.vision.views.Views
    T_base_ee : array, shape (len(views.views), 4, 4)
        Robot pose of every view, paired.
    setup : {"eye_to_hand", "eye_in_hand"}
    method : str
        Closed form of the pose-based solve.
    n_splits : int
        Splits to average over (the ratios are RMS over them).
    rng : numpy.random.Generator, optional
        For the random splits; default ``np.random.default_rng(0)``.
    refine_intrinsics : bool
    robot_noise : {"estimate", "none"}
        The refinement's model of the robot's pose error (``ReprojectionOptions.robot_noise``; "none" shows what the
        corners-only sigma claims).

    Returns
    -------
    HalvesCheck

    Raises
    ------
    HandEyeInputError
        Fewer than 6 accepted views (a half needs 3), or a half the calibration refuses.
    """
    from dataclasses import replace

    from classic.vision.reprojection import ReprojectionOptions
    from handeye.core.errors import HandEyeInputError
    from handeye.core.metrics import pose_error

    rng = np.random.default_rng(0) if rng is None else rng
    accepted = [k for k, v in enumerate(views.views) if v.pose.ok]
    if len(accepted) < 6:
        raise HandEyeInputError(f"the halves check needs at least 6 views with a pose, got {len(accepted)}")
    rows = {name: [] for name in ("dr", "dt", "pr", "pt")}
    halves, refinement = [], ReprojectionOptions(refine_intrinsics=refine_intrinsics, robot_noise=robot_noise)
    for split in range(n_splits):
        order = np.array(accepted) if split == 0 else rng.permutation(accepted)
        parts = (sorted(order[0::2].tolist()), sorted(order[1::2].tolist()))
        fits = []
        for part in parts:
            sub = replace(views, views=[views.views[k] for k in part])
            fits.append(calibrate_from_views(sub, T_base_ee[part], setup, method, refinement=refinement))
        (a, b), s = fits, [f.reprojection.sigma for f in fits]
        rot, trans = pose_error(a.X, b.X)
        rows["dr"].append(float(rot))
        rows["dt"].append(float(trans))
        rows["pr"].append(float(np.hypot(s[0]["X_rotation_deg"], s[1]["X_rotation_deg"])))
        rows["pt"].append(float(np.hypot(s[0]["X_translation_mm"], s[1]["X_translation_mm"])))
        halves.append(tuple([views.views[k].image for k in part] for part in parts))
    return HalvesCheck(*(np.array(rows[name]) for name in ("dr", "dt", "pr", "pt")), halves)
