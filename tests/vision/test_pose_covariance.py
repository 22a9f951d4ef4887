"""Each PnP pose's covariance from its corners: what Monte Carlo PnP gives, in the noise model's convention."""

from __future__ import annotations

import numpy as np
import pytest

cv2 = pytest.importorskip("cv2")

from classic.vision.pose_covariance import pose_covariances  # noqa: E402
from handeye.core.errors import HandEyeInputError  # noqa: E402
from handeye.core.se3 import make_transform, so3_log  # noqa: E402
from tests.tolerances import ML_SIGMA_RATIO, POOLED_SIGMA_RTOL  # noqa: E402
from tests.vision._helpers import INTR, SPEC, board_pose, corners_in_image  # noqa: E402

SIGMA_PX = 0.3
TRIALS = 200


def _pnp(ids, uv, T0):
    rvec, _ = cv2.Rodrigues(T0[:3, :3])
    ok, rvec, tvec = cv2.solvePnP(
        SPEC.corners_target()[ids],
        uv,
        INTR.K,
        INTR.dist,
        rvec,
        T0[:3, 3:].copy(),
        useExtrinsicGuess=True,
        flags=cv2.SOLVEPNP_ITERATIVE,
    )
    assert ok
    return make_transform(cv2.Rodrigues(rvec)[0], tvec.ravel())


def test_covariance_matches_monte_carlo_pnp_and_is_worst_along_the_optical_axis():
    rng = np.random.default_rng(0)
    T = board_pose(rng)
    ids, _ = corners_in_image(T)
    errs = []
    for _ in range(TRIALS):
        ids_k, uv = corners_in_image(T, sigma_px=SIGMA_PX, rng=rng)
        T_est = _pnp(ids_k, uv, T)
        # the noise model's convention: R_est = R exp(w) (target frame), t_est = t + n (camera frame)
        errs.append(np.concatenate([so3_log(T[:3, :3].T @ T_est[:3, :3]), T_est[:3, 3] - T[:3, 3]]))
    errs = np.array(errs)
    C, s = pose_covariances(T[None], [ids], [corners_in_image(T)[1]], SPEC, INTR, pixel_sigma=SIGMA_PX)
    predicted = np.sqrt(np.diag(C[0]))
    actual = np.sqrt(np.mean(errs**2, axis=0))
    # per component RMS over 200 trials: relative standard deviation 1 / sqrt(400) = 0.05; ML_SIGMA_RATIO is 5 of them
    np.testing.assert_allclose(actual, predicted, rtol=ML_SIGMA_RATIO)
    assert predicted[5] > 2 * max(predicted[3], predicted[4])  # depth is the poor direction of a PnP pose
    assert s == SIGMA_PX


def test_pooled_pixel_noise_from_the_residuals():
    rng = np.random.default_rng(1)
    Ts, ids, uvs = [], [], []
    for _ in range(6):
        T = board_pose(rng)
        i, uv = corners_in_image(T, sigma_px=SIGMA_PX, rng=rng)
        Ts.append(_pnp(i, uv, T))
        ids.append(i)
        uvs.append(uv)
    _, s = pose_covariances(np.stack(Ts), ids, uvs, SPEC, INTR)
    # per-axis residual RMS pooled over ~6 x 2 x 35 residuals (dof-corrected): within 20 % of the injected noise
    assert s == pytest.approx(SIGMA_PX, rel=POOLED_SIGMA_RTOL)
    with pytest.raises(HandEyeInputError, match="at least 4"):
        pose_covariances(np.stack(Ts[:1]), [ids[0][:3]], [uvs[0][:3]], SPEC, INTR)


def test_corners_on_one_line_are_refused_not_given_sigma_0():
    """Corners on one row of the board leave the turn about that row free: the pseudo-inverse gave it sigma 0."""
    T = board_pose(np.random.default_rng(2))
    ids, uv = corners_in_image(T)
    row = SPEC.corners_target()[ids][:, 1] == SPEC.corners_target()[ids[0]][1]
    assert row.sum() >= 4
    with pytest.raises(HandEyeInputError, match="view 0: its .* corners do not determine the board's pose"):
        pose_covariances(T[None], [ids[row]], [uv[row]], SPEC, INTR, pixel_sigma=SIGMA_PX)
