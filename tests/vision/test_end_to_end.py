"""From PNG files to X and Y: read, detect, PnP, pose-based calibration, reprojection refinement."""

from __future__ import annotations

import numpy as np
import pytest

import classic
from classic.vision import ReprojectionOptions, detect_board, estimate_pose, read_image, refine_reprojection
from classic.vision.detect import project_points
from handeye.core.validation import MIN_POSES
from tests.tolerances import ESTIMATED_SIGMA_BOUND
from tests.vision._helpers import (
    INTR,
    SPEC,
    handeye_jacobian,
    rotation_error_rad,
    translation_error_m,
)
from tests.vision.conftest import HANDEYE_VIEWS

SETUPS = ["eye_to_hand", "eye_in_hand"]


def _mean_shift_effect(p, dets, X, Y, setup):
    """Effect on (wX, vX, wY, vY) of each view's mean corner error, the part the noise model leaves out.

    A shift common to a view's corners is invisible in the per-corner noise
    estimate yet moves the fit as much as its 2 M components together; it is
    measured against the true projections and propagated linearly.
    """
    ids = [d.ids for d in dets]
    J = handeye_jacobian(p.T_base_ee, ids, X, Y, setup)
    delta = []
    for k, d in enumerate(dets):
        if len(d.ids):
            err = d.corners_px - project_points(SPEC.corners_target()[d.ids], p.T_cam_target[k], INTR)
            delta.append(np.tile(err.mean(axis=0), len(d.ids)))
    e = np.linalg.pinv(J) @ np.concatenate(delta)
    return np.linalg.norm(e.reshape(4, 3), axis=1)


@pytest.mark.parametrize("setup", SETUPS)
def test_images_to_hand_eye(handeye_recordings, setup):
    rec = handeye_recordings[setup]
    p = rec.problem
    assert len(rec.paths) == HANDEYE_VIEWS and all(path.suffix == ".png" for path in rec.paths)

    images = [read_image(path) for path in rec.paths]
    assert all(im.dtype == np.uint8 and im.shape == (INTR.height, INTR.width) for im in images)
    dets = [detect_board(im, SPEC) for im in images]
    poses = [estimate_pose(d, SPEC, INTR) for d in dets]
    ok = np.array([v.ok for v in poses])
    assert ok.sum() >= MIN_POSES, [v.reason for v in poses]

    cal = classic.calibrate(p.T_base_ee[ok], np.stack([v.T_cam_target for v in poses if v.ok]), setup=setup)
    # the refinement takes every view's corners, accepted by PnP or not
    use = [d.reason is None for d in dets]
    ids = [d.ids if u else np.zeros(0, int) for d, u in zip(dets, use)]
    corners = [d.corners_px if u else np.zeros((0, 2)) for d, u in zip(dets, use)]
    res = refine_reprojection(p.T_base_ee, ids, corners, SPEC, INTR, cal.X, cal.Y, ReprojectionOptions(setup=setup))
    assert res.outlier_views == []

    s = res.sigma
    sigma = np.array(
        [
            np.radians(s["X_rotation_deg"]),
            s["X_translation_mm"] / 1000,
            np.radians(s["Y_rotation_deg"]),
            s["Y_translation_mm"] / 1000,
        ]
    )
    floor = _mean_shift_effect(p, dets, res.X, res.Y, setup)
    errors = np.array(
        [
            rotation_error_rad(res.X, p.X_true),
            translation_error_m(res.X, p.X_true),
            rotation_error_rad(res.Y, p.Y_true),
            translation_error_m(res.Y, p.Y_true),
        ]
    )
    bound = ESTIMATED_SIGMA_BOUND * sigma + floor
    assert np.all(errors <= bound), (errors, sigma, floor)
    # the bound is a bound on something small: hundredths of a degree, tenths of a millimetre
    assert bound[0] < np.radians(0.1) and bound[1] < 1e-3

    # the pose-based calibration on the PnP poses is sound too, if less accurate (its own sigma)
    c = cal.sigma
    assert rotation_error_rad(cal.X, p.X_true) <= ESTIMATED_SIGMA_BOUND * np.radians(c["X_rotation_deg"])
    assert translation_error_m(cal.X, p.X_true) <= ESTIMATED_SIGMA_BOUND * c["X_translation_mm"] / 1000
