"""The markerless calibration of rendered camera placements: the UR5's own surface registered to depth."""

from __future__ import annotations

import json

import numpy as np
import pytest

from tests.tolerances import ABSOLUTE_ONLY, FLOAT, FLOAT32_POSITION_MM, SHARED_POOL_ERROR_SHARE, SIGMA_BOUND

pytest.importorskip("pinocchio")

#: The model's sampling bias (tests/classic/test_markerless.py): F^2 / (8 r) with F the pixel footprint at the
#: farthest robot pixel (2 m at fx = 111 px in the small preset) and r = 4 cm, the UR5's thinnest tube.
SAMPLING_BIAS_MM = (2.0 / 110.85) ** 2 / (8 * 0.04) * 1e3
SAMPLING_BIAS_DEG = np.degrees(SAMPLING_BIAS_MM / 1e3 / 0.3)  # over the arm's 30 cm of motion at least


def test_recovers_rendered_camera_poses_without_a_start(small_dataset):
    from handeye.markerless import markerless_dataset

    out = markerless_dataset(small_dataset[0], cameras=[0, 3])
    for c, res in out.results.items():
        assert res.ok, res.refused
        rot_deg, trans_mm = out.errors[c]
        assert trans_mm <= SIGMA_BOUND * res.sigma["translation_mm"] + SAMPLING_BIAS_MM
        assert rot_deg <= SIGMA_BOUND * res.sigma["rotation_deg"] + SAMPLING_BIAS_DEG


def test_cli_writes_results_and_refusals_exit_1(small_dataset, tmp_path, capsys):
    from handeye.cli import main

    out = tmp_path / "ml.json"
    assert main(["markerless", str(small_dataset[0]), "--camera", "1", "-o", str(out), "--quiet"]) == 0
    doc = json.loads(out.read_text())
    cam = doc["cameras"]["1"]
    assert cam["status"] == "ok" and len(cam["T_base_cam"]["matrix"]) == 4 and "error_vs_truth" in cam
    printed = capsys.readouterr().out
    assert "| 1 | ok |" in printed
    # the summary line repeats the one placement's error as both median and worst
    mm = f"{cam['error_vs_truth']['mm']:.3f} mm"
    assert "accepted 1 of 1 placements" in printed and f"markerless vs truth over 1: median {mm}" in printed
    assert f"worst {mm}" in printed
    # the intrinsics estimated with the pose (the default), as the JSON holds them
    intr = cam["intrinsics"]
    changes = " ".join(f"{intr[n]['change']:+.1f}" for n in ("fx", "fy", "cx", "cy"))
    assert "intrinsics change px" in printed and changes in printed


def test_start_file_and_its_errors(small_dataset, tmp_path):
    from handeye.core.dataset import Dataset
    from handeye.core.errors import HandEyeInputError
    from handeye.core.se3 import pos_quat_xyzw_from_transform
    from handeye.markerless import read_start

    T = Dataset.open(small_dataset[0]).truth()[0]
    t, q = pos_quat_xyzw_from_transform(T)
    good = tmp_path / "start.json"
    good.write_text(json.dumps({"translation_m": t.tolist(), "quaternion_xyzw": q.tolist()}))
    assert np.allclose(read_start(good), T, rtol=ABSOLUTE_ONLY, atol=FLOAT)
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps({"T_base_cam": [[1, 0], [0, 1]]}))
    with pytest.raises(HandEyeInputError, match="bad.json"):
        read_start(bad)
    binary = tmp_path / "binary.json"
    binary.write_bytes(b"\xff\xfe\x00garbage")
    with pytest.raises(HandEyeInputError, match="binary.json"):
        read_start(binary)
    with pytest.raises(HandEyeInputError, match="no such start file"):
        read_start(tmp_path / "missing.json")


def test_bad_robot_and_dataset_inputs_are_named(small_copy, tmp_path):
    from handeye.core.errors import HandEyeInputError, ShapeError
    from handeye.markerless import RobotURDF, markerless_dataset
    from handeye.robot.model import load_robot_urdf

    with pytest.raises(HandEyeInputError, match="no such URDF"):
        markerless_dataset(small_copy, cameras=[0], urdf=RobotURDF(tmp_path / "missing.urdf"))
    urdf = tmp_path / "arm.urdf"
    urdf.write_text(
        '<robot name="arm"><link name="base"><visual><geometry><mesh filename="/nope/base.stl"/>'
        "</geometry></visual></link></robot>"
    )
    with pytest.raises(HandEyeInputError, match="base.stl|cannot load"):
        load_robot_urdf(urdf)
    # intrinsics of another size than the depth images
    meta_path = small_copy / "meta.json"
    meta = json.loads(meta_path.read_text())
    meta["intrinsics"]["width"] = 2 * meta["intrinsics"]["width"]
    meta_path.write_text(json.dumps(meta))
    with pytest.raises(ShapeError, match="intrinsics"):
        markerless_dataset(small_copy, cameras=[0])
    # a robot model whose joint count does not fit the dataset
    meta["intrinsics"]["width"] //= 2
    meta["n_joints"] = 7
    meta_path.write_text(json.dumps(meta))
    with pytest.raises(ShapeError, match="7 joints, the robot model ur5 has 6"):
        markerless_dataset(small_copy, cameras=[0])


def test_markerless_labels_feed_the_board_free_continual_run(small_copy):
    """--write-labels fills cameras.csv; relabelling keeps them; labels='markerless' trains on them after region 0."""
    pytest.importorskip("torch")
    from handeye.core.dataset import Dataset
    from handeye.labelling import label_dataset
    from handeye.markerless import markerless_dataset, write_markerless_labels
    from learned.data import load_frames

    run = markerless_dataset(small_copy)
    write_markerless_labels(small_copy, run)
    label_dataset(small_copy, workers=1, progress=False)  # relabelling keeps the markerless columns
    ds = Dataset.open(small_copy)
    cams = ds.cameras()
    assert list(cams["markerless_status"]) == ["ok"] * len(ds)
    ml, classic = ds.markerless_labels(), ds.labels()
    for c, res in run.results.items():
        np.testing.assert_allclose(ml[c], res.T_base_cam, atol=FLOAT)
        assert cams["markerless_error_trans_mm"][c] == pytest.approx(run.errors[c][1])
    frames = load_frames(small_copy, (32, 32), "markerless", progress=False)
    for c in range(len(ds)):
        k = np.flatnonzero(frames.camera == c)[0]
        expected = classic[c] if cams["region"][c] == 0 else ml[c]
        np.testing.assert_allclose(frames.t_base_cam_mm[k], expected[:3, 3] * 1e3, atol=FLOAT32_POSITION_MM)


def test_posed_surface_carries_curvatures_that_move_with_the_links():
    """The UR5's samples: curvatures do not change with the pose, the first principal direction stays a unit
    tangent, and the upper arm's tube (radius 5-7 cm) curves by 1/r across its axis."""
    from handeye.robot.model import load_robot
    from handeye.robot.surface import RobotSurface

    robot = load_robot("ur5")
    surface = RobotSurface(robot, spacing_m=0.006)
    q = np.random.default_rng(0).uniform(-np.pi, np.pi, size=(2, robot.nq))
    posed = surface.posed(q)
    first, second = posed.frame == 0, posed.frame == 1
    np.testing.assert_allclose(posed.curvatures[first], posed.curvatures[second], rtol=FLOAT, atol=FLOAT)
    np.testing.assert_allclose(np.linalg.norm(posed.direction_base, axis=1), 1.0, atol=FLOAT)
    np.testing.assert_allclose(np.einsum("ij,ij->i", posed.direction_base, posed.normals_base), 0.0, atol=FLOAT)
    names = [name for name, _, _ in surface.parts]
    upper = first & (posed.part == names.index(next(n for n in names if n.startswith("upper_arm"))))
    assert 1 / 0.07 <= np.median(posed.curvatures[upper, 0]) <= 1 / 0.05


def test_a_stereo_sensor_has_its_matchers_bias_estimated_unless_told_not_to(small_dataset, tmp_path, capsys):
    """``--sensor d435`` models the matcher's pull toward whole disparities with the profile's f B (447 px x 50 mm);
    ``--stereo-fb`` sets another camera's, 0 turns it off; the rendered depth has none, so none is found."""
    from handeye.cli import main

    runs = {}
    for name, extra in (("profile", []), ("off", ["--stereo-fb", "0"])):
        out = tmp_path / f"{name}.json"
        assert (
            main(
                [
                    "markerless",
                    str(small_dataset[0]),
                    "--camera",
                    "1",
                    "--sensor",
                    "d435",
                    "-o",
                    str(out),
                    "--quiet",
                    *extra,
                ]
            )
            == 0
        )
        runs[name] = json.loads(out.read_text())["cameras"]["1"]
    locking = runs["profile"]["depth"]["pixel_locking_px"]
    assert abs(locking["sin"]) <= SIGMA_BOUND * locking["sin_sigma"]
    assert abs(locking["cos"]) <= SIGMA_BOUND * locking["cos_sigma"]
    assert "pixel_locking_px" not in runs["off"]["depth"]
    capsys.readouterr()
    assert main(["markerless", str(small_dataset[0]), "--camera", "1", "--stereo-fb", "-1", "--quiet"]) != 0
    assert "--stereo-fb must be a disparity constant >= 0" in capsys.readouterr().err


def test_static_parts_are_left_out_unless_asked_for(small_dataset, tmp_path):
    """The result says which parts the fine stage fitted: the moving ones by default, all with --static-parts."""
    from handeye.cli import main

    fitted = {}
    for name, extra in (("default", []), ("static", ["--static-parts"])):
        out = tmp_path / f"{name}.json"
        assert main(["markerless", str(small_dataset[0]), "--camera", "1", "-o", str(out), "--quiet", *extra]) == 0
        fitted[name] = json.loads(out.read_text())["cameras"]["1"]["diagnostics"]["fitted_parts"]
    assert fitted == {"default": "moving", "static": "all"}


def test_placements_share_the_camera_matrix(small_copy):
    """Told a focal length 0.7 % off (a factory matrix), the placements' pooled estimate is nearer the rendered
    one than the given, each second pass starts from its first answer, and every answer stays within its sigma
    (the front's options: a per-cell depth error marginalised in both passes)."""
    from classic.markerless import MarkerlessOptions
    from classic.markerless.shared_intrinsics import MIN_OTHERS_OWN_SIGMA, first_pass_options
    from handeye.core.dataset import Dataset
    from handeye.markerless import markerless_dataset
    from handeye.markerless_shared import share_intrinsics, shared_note, shared_options

    meta_path = small_copy / "meta.json"
    meta = json.loads(meta_path.read_text())
    K_true = np.array(meta["intrinsics"]["K"], dtype=float)
    meta["intrinsics"]["K"][0][0] *= 1.007
    meta["intrinsics"]["K"][1][1] *= 1.007
    meta_path.write_text(json.dumps(meta))
    opts = shared_options(MarkerlessOptions(), len(Dataset.open(small_copy)))  # as handeye markerless sets them
    assert opts.pixel_effect_px > 0
    first = markerless_dataset(small_copy, options=first_pass_options(opts))  # as handeye markerless runs them
    shared = share_intrinsics(small_copy, first, options=opts)
    note = shared_note(shared, opts.pixel_effect_px)
    assert len(shared.results) == len(Dataset.open(small_copy)) and "pooled: fx" in note
    assert f"per {opts.pixel_effect_px} px image cell" in note
    assert any(p["fx"]["pooled"] for p in shared.intrinsics_priors.values())
    told_error = abs(meta["intrinsics"]["K"][0][0] - K_true[0, 0])
    for c, res in shared.results.items():
        assert res.ok, res.refused
        prior = shared.intrinsics_priors[c]
        if prior["fx"]["pooled"]:
            assert res.start == "first pass" and res.intrinsics["prior"] == "shared"
            # the pooled focal length nearer the rendered one than the matrix told, by what the frames say
            assert abs(prior["fx"]["mean"] - K_true[0, 0]) < SHARED_POOL_ERROR_SHARE * told_error
            # the pool moves the answer; with fewer than MIN_OTHERS_OWN_SIGMA others its sigma stays no narrower than
            # under the stated prior at that answer
            floor = res.diagnostics.get("sigma_shared_floor")
            assert (floor is not None) == (prior["others"] < MIN_OTHERS_OWN_SIGMA)
            for key in ("rotation_deg", "translation_mm") if floor else ():
                assert res.sigma[key] >= floor["floor"][key] * (1 - FLOAT)
        rot_deg, trans_mm = shared.errors[c]
        assert trans_mm <= SIGMA_BOUND * res.sigma["translation_mm"] + SAMPLING_BIAS_MM
        assert rot_deg <= SIGMA_BOUND * res.sigma["rotation_deg"] + SAMPLING_BIAS_DEG
