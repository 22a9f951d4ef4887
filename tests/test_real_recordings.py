"""Real recordings shipped with the benchmarks (benchmarks/data/real) and benchmarks/real_recordings.py."""

from __future__ import annotations

import functools
import warnings

import numpy as np
import pytest

import classic
from benchmarks._real_data import DATA, load_camodocal, load_ethz_stream
from handeye.core.errors import ContaminatedPosesError
from handeye.core.metrics import pose_error
from handeye.core.synthetic import make_problem
from tests.tolerances import EXACT, FLOAT, HOLDOUT_OVER_RESIDUAL, METRIC_RANGE_M, RECORDED_ROTATION

#: The shipped recordings: loader, pose count, and the pose its SOURCE names as an outlier.
SHIPPED = {
    "camodocal_artag": (functools.cache(load_camodocal), 42, 36),
    "ethz_robot_arm": (functools.cache(load_ethz_stream), 98, None),
}
HOLDOUT_SPLITS = 5


@pytest.mark.parametrize("name", sorted(SHIPPED))
def test_a_shipped_recording_has_its_source_and_licence(name):
    folder = DATA / name
    source = (folder / "SOURCE").read_text()
    for field in ("origin", "commit", "licence", "changed"):
        assert f"\n{field}" in source, (name, field)
    assert (folder / "LICENSE").read_text().strip()


@pytest.mark.parametrize("name", sorted(SHIPPED))
def test_a_shipped_recording_loads_finite_metric_and_optical(name):
    load, count, _ = SHIPPED[name]
    rec = load()
    assert rec.T_base_ee.shape == rec.T_cam_target.shape == (count, 4, 4)
    for T in (rec.T_base_ee, rec.T_cam_target):
        assert np.isfinite(T).all()
        R = T[:, :3, :3]
        np.testing.assert_allclose(
            R @ R.transpose(0, 2, 1), np.broadcast_to(np.eye(3), R.shape), atol=RECORDED_ROTATION
        )
        np.testing.assert_allclose(np.linalg.det(R), 1.0, atol=RECORDED_ROTATION)
        d = np.linalg.norm(T[:, :3, 3], axis=1)
        assert METRIC_RANGE_M[0] < d.min() and d.max() < METRIC_RANGE_M[1], (name, d.min(), d.max())
    # the optical frame: every target in front of the camera, along +z
    t = rec.T_cam_target[:, :3, 3]
    assert (t[:, 2] > np.linalg.norm(t, axis=1) / 2).all()


def _fit(rec, setup, robust=False):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return classic.calibrate(rec.T_base_ee, rec.T_cam_target, setup=setup, robust=robust)


def _holdout_and_residual(rec, setup, robust, rng):
    """Median hold-out error and the all-pose residual RMS (deg, mm) of the default fit."""
    from benchmarks.real_recordings import predicted_camera_poses

    n = len(rec.T_base_ee)
    res = _fit(rec, setup, robust)
    e = np.array(pose_error(predicted_camera_poses(rec.T_base_ee, setup, res.X, res.Y), rec.T_cam_target))
    rms = np.sqrt(np.mean(e**2, axis=1))
    held = []
    for _ in range(HOLDOUT_SPLITS):
        p = rng.permutation(n)
        test, train = p[: n // 5], p[n // 5 :]
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            r = classic.calibrate(rec.T_base_ee[train], rec.T_cam_target[train], setup=setup, robust=robust)
        held.append(pose_error(predicted_camera_poses(rec.T_base_ee[test], setup, r.X, r.Y), rec.T_cam_target[test]))
    return np.median(np.concatenate(held, axis=1), axis=1), rms


@pytest.mark.parametrize("name", sorted(SHIPPED))
def test_the_default_answers_a_shipped_recording_and_predicts_held_out_poses(name):
    load, _, outlier = SHIPPED[name]
    rec = load()
    robust = False
    try:
        _fit(rec, rec.setup)
    except ContaminatedPosesError as exc:  # a refusal must name the recording's own outlier; robust answers
        assert outlier is not None and str(outlier) in str(exc)
        robust = True
    median, rms = _holdout_and_residual(rec, rec.setup, robust, np.random.default_rng(0))
    assert (median < HOLDOUT_OVER_RESIDUAL * rms).all(), (median, rms)


@pytest.mark.parametrize("name", sorted(SHIPPED))
def test_the_wrong_setup_fails_the_same_bound(name):
    """The bound can fail: the recording read with the other setup is refused or predicts far worse."""
    load, _, _ = SHIPPED[name]
    rec = load()
    wrong = "eye_in_hand" if rec.setup == "eye_to_hand" else "eye_to_hand"
    good, _ = _holdout_and_residual(rec, rec.setup, True, np.random.default_rng(0))
    try:
        median, _ = _holdout_and_residual(rec, wrong, True, np.random.default_rng(0))
    except ValueError:  # refused: the motions disagree
        return
    assert (median > 10 * good).any(), (median, good)


def test_predicted_camera_poses_and_y_from_x_recover_the_truth():
    from benchmarks.real_recordings import predicted_camera_poses, y_from_x
    from handeye.core.setups import robot_side_poses

    for setup in ("eye_to_hand", "eye_in_hand"):
        p = make_problem(8, setup, np.random.default_rng(1))
        pred = predicted_camera_poses(p.T_base_ee, setup, p.X_true, p.Y_true)
        np.testing.assert_allclose(pred, p.T_cam_target, atol=EXACT)
        Y = y_from_x(robot_side_poses(p.T_base_ee, setup), p.T_cam_target, p.X_true)
        np.testing.assert_allclose(Y, p.Y_true, atol=EXACT)
        assert np.abs(Y[:3, :3] @ Y[:3, :3].T - np.eye(3)).max() < FLOAT


def test_the_benchmark_runs_in_a_smoke_run(monkeypatch, tmp_path, capsys):
    from benchmarks.real_recordings import DEFAULT, ROBUST, main
    from handeye.core.smoke import ENV, NOTICE

    monkeypatch.setenv(ENV, "1")
    out = tmp_path / "real.md"
    assert main(["--out", str(out)]) == 0
    text = out.read_text()
    assert NOTICE in text and "command: python benchmarks/real_recordings.py" in text
    assert "## camodocal_artag: 16 poses, eye-to-hand" in text and "## ethz_robot_arm: 16 poses, eye-in-hand" in text
    assert "note: cut to 16 of its 42 poses" in text
    for row in (DEFAULT, ROBUST, "handeye tsai (closed form)", "opencv tsai", "opencv li"):
        assert f"| {row} |" in text, row
    assert "hold-out: 2 splits" in text and "answers " in text and "refusals " in text
