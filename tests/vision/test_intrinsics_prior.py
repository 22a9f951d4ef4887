"""The intrinsics' one-sigma travels with them, and the hand-eye sigma counts their error (a prior).

Intrinsics are always estimated; taken as exact, an error of their stated size moves X by many of the sigma
that the corners alone give. With them refined under their one-sigma as a prior, the truth is within the
sigma's bound.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

pytest.importorskip("cv2")

from classic.vision.camera import (  # noqa: E402
    DEFAULT_CENTRE_STD_PX,
    DEFAULT_FOCAL_STD,
    STD_NAMES,
    CameraIntrinsics,
    IntrinsicsError,
)
from classic.vision.detect import Detection, estimate_pose  # noqa: E402
from classic.vision.intrinsics import calibrate_intrinsics  # noqa: E402
from classic.vision.reprojection import ReprojectionOptions, refine_reprojection  # noqa: E402
from classic.vision.views import View, Views  # noqa: E402
from handeye.cli import main  # noqa: E402
from handeye.core.metrics import pose_error  # noqa: E402
from handeye.core.posefile import write_pose_csv  # noqa: E402
from tests.tolerances import ESTIMATED_SIGMA_BOUND  # noqa: E402
from tests.vision._helpers import INTR, SPEC  # noqa: E402
from tests.vision._synthetic_views import ROBOT_ERROR, corner_views  # noqa: E402

SETUP = "eye_in_hand"
N_VIEWS = 12  # as the images guide


def _vendor_intrinsics() -> CameraIntrinsics:
    """The true camera moved by +1 stated default sigma in fx, fy, cx and cy, in a file without std."""
    std, _ = INTR.std_vector()
    K = INTR.K + np.array([[std[0], 0, std[2]], [0, std[1], std[3]], [0, 0, 0]])
    return CameraIntrinsics(K, INTR.dist, INTR.width, INTR.height)


def _views(seed: int):
    return corner_views(SETUP, N_VIEWS, np.random.default_rng(seed), robot_error=(0.0, 0.0))


def test_calibrated_std_is_written_and_read_back(tmp_path):
    ids, uv, *_ = _views(1)
    res = calibrate_intrinsics([Detection(i, u, 0, (INTR.width, INTR.height)) for i, u in zip(ids, uv)], SPEC)
    assert res.intrinsics.std == res.std and set(res.std) == set(STD_NAMES)
    res.intrinsics.save(tmp_path / "camera.json")
    back = CameraIntrinsics.load(tmp_path / "camera.json")
    assert back.std == res.std
    std, source = back.std_vector()
    assert np.array_equal(std, [res.std[n] for n in STD_NAMES]) and "own" in source


def test_opencv_yaml_keeps_the_std(tmp_path):
    std = {n: 0.1 * (k + 1) for k, n in enumerate(STD_NAMES)}
    CameraIntrinsics(INTR.K, INTR.dist, INTR.width, INTR.height, std).save(tmp_path / "camera.yaml")
    assert CameraIntrinsics.load(tmp_path / "camera.yaml").std == std


def test_a_file_without_std_gets_the_stated_default(tmp_path):
    CameraIntrinsics(INTR.K, INTR.dist, INTR.width, INTR.height).save(tmp_path / "camera.json")
    assert "std" not in json.loads((tmp_path / "camera.json").read_text())
    back = CameraIntrinsics.load(tmp_path / "camera.json")
    std, source = back.std_vector()
    assert back.std is None and "not in the intrinsics file" in source
    np.testing.assert_array_equal(
        std[:4], [DEFAULT_FOCAL_STD * INTR.K[0, 0], DEFAULT_FOCAL_STD * INTR.K[1, 1]] + 2 * [DEFAULT_CENTRE_STD_PX]
    )
    assert np.all(std[4:] > 0)


def test_a_std_that_is_not_one_sigma_per_parameter_is_refused():
    with pytest.raises(IntrinsicsError, match="one-sigma"):
        CameraIntrinsics(INTR.K, INTR.dist, INTR.width, INTR.height, {"fx": 1.0})
    with pytest.raises(IntrinsicsError, match="negative"):
        CameraIntrinsics(INTR.K, INTR.dist, INTR.width, INTR.height, {n: -1.0 for n in STD_NAMES})


@pytest.mark.parametrize(
    ("seed", "n_views", "robot_error"), [(2, N_VIEWS, (0.0, 0.0)), (3, N_VIEWS, (0.0, 0.0)), (0, 25, ROBOT_ERROR)]
)
def test_the_prior_covers_intrinsics_off_by_their_sigma(seed, n_views, robot_error):
    """A vendor's intrinsics off by one stated sigma: the prior's result is within ESTIMATED_SIGMA_BOUND of its
    sigma (also with the robot's error estimated and weighed); taken as exact (the old default) the same check
    fails, by the bias the offset leaves (3 px of principal point turn the camera by 3 / 554 rad = 0.3 deg, where
    the corners alone give a sigma of hundredths of a degree)."""
    ids, uv, T_base_ee, X_true, Y_true = corner_views(SETUP, n_views, np.random.default_rng(seed), robot_error)
    given = _vendor_intrinsics()

    def within(opts) -> bool:
        res = refine_reprojection(T_base_ee, ids, uv, SPEC, given, X_true, Y_true, opts)
        rot, trans = pose_error(res.X, X_true)
        return bool(
            rot <= ESTIMATED_SIGMA_BOUND * res.sigma["X_rotation_deg"]
            and trans <= ESTIMATED_SIGMA_BOUND * res.sigma["X_translation_mm"]
        )

    assert within(ReprojectionOptions(setup=SETUP, intrinsics_prior=True))
    assert not within(ReprojectionOptions(setup=SETUP))  # the old default: intrinsics exact, robot error estimated


def test_a_zero_std_holds_its_parameter_without_collapsing_the_sigma():
    """OpenCV writes a zero one-sigma for a parameter its calibration held fixed (CALIB_FIX_K3): the prior holds it
    there, and the pose's sigma still covers the vendor offset. Before, the zero became a prior row of 1e12 and
    the covariance's pseudo-inverse cut the pose's directions: X's sigma 0.0005 deg at 0.197 deg of error."""
    ids, uv, T_base_ee, X_true, Y_true = _views(2)
    vendor = _vendor_intrinsics()
    std = dict(zip(STD_NAMES, map(float, vendor.std_vector()[0])), k3=0.0)
    given = CameraIntrinsics(vendor.K, vendor.dist, vendor.width, vendor.height, std)
    res = refine_reprojection(
        T_base_ee, ids, uv, SPEC, given, X_true, Y_true, ReprojectionOptions(setup=SETUP, intrinsics_prior=True)
    )
    rot, trans = pose_error(res.X, X_true)
    assert rot <= ESTIMATED_SIGMA_BOUND * res.sigma["X_rotation_deg"]
    assert trans <= ESTIMATED_SIGMA_BOUND * res.sigma["X_translation_mm"]
    assert abs(res.intrinsics.dist[4] - given.dist[4]) < res.intrinsics.std["k3"]


def test_calibrate_command_says_how_the_intrinsics_enter(tmp_path, capsys):
    """The echo line keeps the options that change the result; the intrinsics line says which way was taken."""
    ids, uv, T_base_ee, X_true, Y_true = _views(4)
    given = _vendor_intrinsics()
    views = []
    for k, (i, u) in enumerate(zip(ids, uv)):
        det = Detection(i, u, 0, (INTR.width, INTR.height))
        views.append(View(f"view_{k:03d}.png", det, estimate_pose(det, SPEC, given)))
    Views(views, SPEC, given, tmp_path).save(tmp_path / "detections.json")
    write_pose_csv(tmp_path / "robot.csv", T_base_ee, np.tile(np.eye(4), (len(T_base_ee), 1, 1)))
    (tmp_path / "truth.json").write_text(json.dumps({"T_ee_cam": X_true.tolist()}))
    base = [
        "calibrate",
        "--detections",
        str(tmp_path / "detections.json"),
        "--robot-poses",
        str(tmp_path / "robot.csv"),
    ]
    base += ["--setup", "eye-in-hand"]
    for extra, says in (
        ([], "prior of their one-sigma (not in the intrinsics file; taken as 0.5 % of f"),
        (["--refine-intrinsics"], "refined from the corners alone (--refine-intrinsics)"),
        (["--fixed-intrinsics"], "taken as exact (--fixed-intrinsics); the 1-sigma leaves their error out"),
    ):
        assert main([*base, *extra, "--truth", str(tmp_path / "truth.json")]) == 0
        printed = capsys.readouterr().out.splitlines()
        assert printed[0] == " ".join(["handeye", *base, *extra, "--truth", str(tmp_path / "truth.json")])
        assert any(line.startswith("  intrinsics: ") and says in line for line in printed), printed
