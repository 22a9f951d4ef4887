"""``handeye import``: real recordings (ROS 2 bags, folders) to a dataset, checked against a simulated truth.

Two camera placements are rendered as a D435 reports depth (its scale, offset and extrinsic errors drawn
per placement and recorded), written as bags a real cell would write (:mod:`sim.bag_export`: the robot
driving between poses, joint states at 125 Hz with a gripper joint, colour 4 ms after depth; one bag in
sqlite3 with 16UC1 millimetres and raw colour, the other in MCAP with 32FC1 metres and JPEG colour), and
imported. The imported frames are the rendered ones; the board label and the markerless calibration of
the imported dataset recover the truth within their own sigmas; each bad recording is named.
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("pyrender")
pytest.importorskip("rosbags")

from classic.vision.board import BoardSpec  # noqa: E402
from classic.vision.camera import CameraIntrinsics  # noqa: E402
from classic.vision.camera_yaml import write_camera_info_yaml  # noqa: E402
from handeye.cli import main  # noqa: E402
from handeye.core.dataset import Dataset  # noqa: E402
from handeye.core.engine_protocol import EngineOptions  # noqa: E402
from handeye.core.errors import (  # noqa: E402
    BagTopicError,
    DatasetError,
    ImageSizeError,
    JointNamesError,
    UnsynchronisedError,
)
from handeye.core.metrics import pose_error  # noqa: E402
from handeye.core.se3 import make_transform, so3_exp  # noqa: E402
from handeye.import_bag import read_camera_bag  # noqa: E402
from handeye.recording_import import ImportOptions, RecordedPlacement, TimedImages, assemble, import_recordings  # noqa: E402
from handeye.robot.model import load_robot  # noqa: E402
from sim.bag_export import write_placement_bags  # noqa: E402
from sim.cameras import CameraPreset  # noqa: E402
from sim.generate import NoiseModel, Recipe, generate  # noqa: E402
from tests.tolerances import ABSOLUTE_ONLY, FLOAT

#: Two placements, 12 data frames at 160x160 and 8 board views at 480x480.
PRESET = CameraPreset(
    "import", "ur5", ((0.0, 60.0),), (1,), (1,), 12, calibration_views=8, image_size=(160, 160),
    calibration_image_size=(480, 480),
)  # fmt: skip
COLOR, DEPTH, INFO = "/camera/color/image_raw", "/camera/aligned_depth_to_color/image_raw", "/camera/color/camera_info"
#: Depth as a 16UC1 driver gives it: whole millimetres, a uniform rounding error of 1 mm / sqrt(12).
MM = 1e-3


@pytest.fixture(scope="module")
def recorded(tmp_path_factory):
    """The simulated dataset, its placements as bags, the board file."""
    root = tmp_path_factory.mktemp("import")
    noise = NoiseModel(pixel_sigma=2.0, joint_sigma_deg=0.01)
    recipe = Recipe(PRESET, seed=5, noise=noise, sensor="d435")
    generate(root / "sim", recipe, options=EngineOptions(workers=1, progress=False))
    ds = Dataset.open(root / "sim")
    bags = [
        write_placement_bags(ds, 0, root / "bags", "sqlite3", "16UC1", "raw"),
        write_placement_bags(ds, 1, root / "bags", "mcap", "32FC1", "jpeg"),
    ]
    BoardSpec(**ds.meta["board"]).save(root / "board.json")
    return root, ds, bags


@pytest.fixture(scope="module")
def imported(recorded):
    """The bags imported with the command, labelled with the board."""
    root, _, bags = recorded
    out = root / "imported"
    argv = ["import", "bag", str(bags[0]["data"]), str(bags[1]["data"]), "--calibration"]
    argv += [str(bags[0]["calibration"]), str(bags[1]["calibration"])]
    argv += ["--robot", "ur5", "--board", str(root / "board.json"), "--out", str(out), "--quiet"]
    assert main(argv) == 0
    assert main(["label", str(out), "--quiet"]) == 0
    return Dataset.open(out)


def test_the_imported_frames_are_the_recorded_ones(recorded, imported):
    """Joints interpolated at the depth stamps are the still poses' (the gripper joint ignored, the joints
    reordered), T_base_ee is their kinematics, colour and depth are the rendered images (depth within the
    16UC1 rounding, JPEG within its loss)."""
    _, src, _ = recorded
    assert imported.meta["recipe"]["generator"] == "handeye import bag"
    for c in range(len(src)):
        a, b = src.select(c, "data"), imported.select(c, "data")
        assert len(b["frame"]) == len(a["frame"]) == PRESET.configurations
        assert np.allclose(imported.joints(b), src.joints(a), rtol=ABSOLUTE_ONLY, atol=FLOAT)
        assert np.allclose(imported.poses(b, "T_base_ee"), src.poses(a, "T_base_ee"), rtol=ABSOLUTE_ONLY, atol=FLOAT)
        for ra, rb, da, db in zip(a["rgb"], b["rgb"], a["depth"], b["depth"]):
            d0, d1 = src.depth_m(c, da), imported.depth_m(c, db)
            assert np.array_equal(d0 > 0, d1 > 0)
            assert np.abs(d1 - d0).max() <= (MM / 2 if c == 0 else 0) + 1e-4  # + the dataset's 0.1 mm PNG unit
            diff = np.abs(imported.rgb(c, rb).astype(int) - src.rgb(c, ra).astype(int))
            assert diff.max() == 0 if c == 0 else diff.mean() < 3  # raw, or JPEG at quality 95
        assert len(imported.select(c, "calibration")["frame"]) == PRESET.calibration_views


def test_the_board_label_of_the_import_recovers_the_truth(recorded, imported):
    _, src, _ = recorded
    cams = imported.cameras()
    for c in range(len(src)):
        assert cams["label_status"][c] == "ok"
        rot, trans = pose_error(imported.labels()[c], src.truth()[c])
        assert trans < 3 * cams["label_sigma_trans_mm"][c]
        assert rot < 3 * cams["label_sigma_rot_deg"][c]


def test_markerless_on_the_import_recovers_pose_scale_and_offset(recorded, imported, tmp_path):
    """Started 40 mm / 3.5 deg off, the registration of the imported depth lands within 3 of its sigmas of the
    truth, with the unit's depth scale and offset (the extrinsic's z moves the depth like an offset)."""
    _, src, _ = recorded
    truth, cams = src.truth(), src.cameras()
    for c in range(len(src)):
        start = truth[c] @ make_transform(so3_exp(np.array([0.03, -0.05, 0.02])), [0.03, -0.02, 0.03])
        (tmp_path / "start.json").write_text(json.dumps({"T_base_cam": start.tolist()}))
        argv = ["markerless", str(imported.root), "--camera", str(c), "--start", str(tmp_path / "start.json")]
        argv += ["--sensor", "d435", "--quiet", "-o", str(tmp_path / "out.json")]
        assert main(argv) == 0
        res = json.loads((tmp_path / "out.json").read_text())["cameras"][str(c)]
        rot, trans = pose_error(np.array(res["T_base_cam"]["matrix"]), truth[c])
        assert trans < 3 * res["sigma"]["translation_mm"]
        assert rot < 3 * res["sigma"]["rotation_deg"]
        depth = res["depth"]
        assert abs(depth["scale"] - cams["depth_scale_true"][c]) < 3 * depth["scale_sigma"]
        offset_mm = cams["depth_offset_mm_true"][c] + cams["depth_extrinsic_mm_true.z"][c]
        assert abs(depth["offset_mm"] - offset_mm) < 3 * depth["offset_sigma_mm"]


def test_compare_sets_the_two_labels_side_by_side(imported, capsys, tmp_path):
    out = tmp_path / "ds"
    shutil.copytree(imported.root, out)
    start = tmp_path / "start.json"
    start.write_text(json.dumps({"T_base_cam": Dataset.open(out).labels()[0].tolist()}))
    assert main(["markerless", str(out), "--camera", "0", "--start", str(start), "--quiet", "--write-labels"]) == 0
    capsys.readouterr()
    assert main(["compare", str(out), "--split", "all"]) == 0
    text = capsys.readouterr().out
    assert "1 of 2 placements have both labels" in text
    assert "| 1 | " in text and "refused" not in text


def test_tf_instead_of_joints(recorded, tmp_path):
    """T_base_ee from tf (base_link -> tool0) equals the kinematics'; without joint angles the dataset can be
    labelled but the markerless registration says why it cannot run."""
    root, src, bags = recorded
    out = tmp_path / "tf"
    argv = ["import", "bag", str(bags[0]["data"]), "--joints-topic", "none", "--tf", "base_link", "tool0"]
    assert main(argv + ["--robot", "ur5", "--out", str(out), "--quiet"]) == 0
    ds = Dataset.open(out)
    rows = ds.select(0, "data")
    # the same float64 kinematics, through tf's quaternion instead of the table's repr(): rounding only
    tf_poses, kinematics = ds.poses(rows, "T_base_ee"), src.poses(src.select(0, "data"), "T_base_ee")
    np.testing.assert_allclose(tf_poses, kinematics, atol=FLOAT, rtol=ABSOLUTE_ONLY)
    assert np.isnan(ds.joints(rows)).all()
    from handeye.markerless import calibrate_camera, robot_surface_for

    with pytest.raises(DatasetError, match="without joint angles"):
        calibrate_camera(ds, 0, robot_surface_for(ds)[0])


def test_every_bad_recording_is_named(recorded, tmp_path, capsys):
    root, _, bags = recorded
    robot = load_robot("ur5")
    data = bags[0]["data"]
    assert (
        main(["import", "bag", str(data), "--depth-topic", "/nope", "--robot", "ur5", "--out", str(tmp_path / "a")])
        == 2
    )
    err = capsys.readouterr().err
    assert "no topic '/nope'" in err and COLOR in err and err.count("\n") == 1
    with pytest.raises(BagTopicError, match="holds sensor_msgs/msg/JointState"):
        read_camera_bag(data, "/joint_states", INFO, DEPTH)

    def part():
        return read_camera_bag(data, COLOR, INFO, DEPTH)

    renamed = part()
    renamed.joints.names = [f"ur_{n}" for n in renamed.joints.names]
    with pytest.raises(JointNamesError, match="shoulder_pan_joint.*not recorded.*ur_shoulder_pan_joint"):
        import_recordings(tmp_path / "b", [renamed], robot, "ur5")
    smaller = part()
    smaller.intrinsics = CameraIntrinsics(smaller.intrinsics.K, np.zeros(5), 120, 160)
    with pytest.raises(ImageSizeError, match="depth image is 160x160, the camera_info is for 120x160"):
        import_recordings(tmp_path / "c", [smaller], robot, "ur5")
    late = part()
    late.color.times_s = late.color.times_s + 0.5  # the colour on another clock
    with pytest.raises(
        UnsynchronisedError, match=r"12 of 12 frames have no colour image \(/camera/color/image_raw\) within 20 ms"
    ):
        import_recordings(tmp_path / "d", [late], robot, "ur5")
    gap = part()
    keep = np.abs(gap.joints.times_s % 1.5 - 1.25) > 0.1  # joint states lost around the frames: never bridged
    gap.joints.times_s, gap.joints.q = gap.joints.times_s[keep], gap.joints.q[keep]
    with pytest.raises(UnsynchronisedError, match="no robot state"):
        import_recordings(tmp_path / "e", [gap], robot, "ur5")
    with pytest.raises(DatasetError, match="not empty"):
        import_recordings(root / "sim", [part()], robot, "ur5")


def _write_folder(src: Dataset, c: int, folder, npy: bool) -> None:
    """A placement as plain files: camera_info YAML, joints.csv, rgb/ PNG, depth/ 16-bit mm PNG or float NPY."""
    from PIL import Image

    (folder / "rgb").mkdir(parents=True)
    (folder / "depth").mkdir()
    write_camera_info_yaml(folder / "intrinsics.yaml", CameraIntrinsics.from_dict(src.meta["intrinsics"]))
    rows = src.select(c, "data")
    names = [str(n) for n in src.meta["joint_names"]]
    lines = ["frame," + ",".join(reversed(names))]
    for k, (rgb, depth, q) in enumerate(zip(rows["rgb"], rows["depth"], src.joints(rows))):
        name = f"f{k:03d}"
        lines.append(name + "," + ",".join(repr(float(v)) for v in q[::-1]))
        Image.fromarray(src.rgb(c, rgb)).save(folder / "rgb" / f"{name}.png")
        d = src.depth_m(c, depth)
        if npy:
            np.save(folder / "depth" / f"{name}.npy", d)
        else:
            Image.fromarray(np.rint(d * 1e3).astype(np.uint16)).save(folder / "depth" / f"{name}.png")
    (folder / "joints.csv").write_text("\n".join(lines) + "\n")


def test_folders_import_the_same_frames(recorded, tmp_path, capsys):
    _, src, _ = recorded
    folders = [tmp_path / "p0", tmp_path / "p1"]
    for c, folder in enumerate(folders):
        _write_folder(src, c, folder, npy=bool(c))
    out = tmp_path / "ds"
    assert main(["import", "folder", *map(str, folders), "--robot", "ur5", "--out", str(out), "--quiet"]) == 0
    ds = Dataset.open(out)
    for c in range(2):
        a, b = src.select(c, "data"), ds.select(c, "data")
        assert np.allclose(ds.joints(b), src.joints(a), rtol=ABSOLUTE_ONLY, atol=FLOAT)
        assert np.allclose(ds.poses(b, "T_base_ee"), src.poses(a, "T_base_ee"), rtol=ABSOLUTE_ONLY, atol=FLOAT)
        d0, d1 = src.depth_m(c, a["depth"][0]), ds.depth_m(c, b["depth"][0])
        assert np.abs(d1 - d0).max() <= (MM / 2 if c == 0 else 0) + 1e-4
    (folders[0] / "rgb" / "f003.png").unlink()
    assert main(["import", "folder", str(folders[0]), "--robot", "ur5", "--out", str(tmp_path / "x")]) == 2
    assert "frame 'f003' has no image" in capsys.readouterr().err


def test_distortion_is_removed_from_the_data_frames():
    """A depth square seen through barrel distortion lands where the pinhole of the same K puts it; no depth
    value is invented (nearest-neighbour), the colour follows it."""
    import cv2

    K = np.array([[100.0, 0, 79.5], [0, 100.0, 59.5], [0, 0, 1]])
    dist = np.array([-0.25, 0.05, 0.0, 0.0, 0.0])
    intr = CameraIntrinsics(K, dist, 160, 120)
    depth = np.zeros((120, 160), np.float32)
    depth[85:95, 125:135] = 1.25  # a patch near the corner, where the distortion is large
    rgb = np.zeros((120, 160, 3), np.uint8)
    rgb[depth > 0] = 255
    part = RecordedPlacement(
        "synthetic",
        intr,
        TimedImages([0.0], [rgb], "colour"),
        TimedImages([0.0], [depth], "depth"),
        poses=__import__("handeye.recording_import", fromlist=["PoseSamples"]).PoseSamples(
            np.array([0.0]), np.eye(4)[None], "poses"
        ),
    )
    frames, dropped = assemble(part, load_robot("ur5"), ImportOptions(sync_tolerance_s=0, joint_tolerance_s=0))
    assert dropped == 0
    out = frames[0]["depth_m"]
    assert set(np.unique(out)) <= {0.0, np.float32(1.25)}
    centre = cv2.undistortPoints(np.array([[[129.5, 89.5]]]), K, dist, P=K)[0, 0]
    ys, xs = np.nonzero(out)
    assert np.hypot(xs.mean() - centre[0], ys.mean() - centre[1]) < 0.5
    ys, xs = np.nonzero(frames[0]["rgb"][..., 0] > 127)  # bilinear: its edge differs by a pixel, not its centre
    assert np.hypot(xs.mean() - centre[0], ys.mean() - centre[1]) < 0.5


def test_the_sim_bag_command_writes_the_placements_bags_and_the_board(recorded, tmp_path, capsys):
    """``handeye sim bag`` (the markerless guide's step, parsed there: tests/test_docs_shell.py): the bags of the
    placement named, as :func:`sim.bag_export.write_placement_bags` writes them with the same settings, and the
    board file."""
    root, _, bags = recorded
    argv = ["sim", "bag", str(root / "sim"), "--camera", "0", "--out", str(tmp_path / "bags")]
    assert main([*argv, "--board-out", str(tmp_path / "board.json")]) == 0
    for kind, path in bags[0].items():
        ours = tmp_path / "bags" / Path(path).relative_to(root / "bags")
        files = sorted(p.relative_to(path) for p in Path(path).rglob("*"))
        assert sorted(p.relative_to(ours) for p in ours.rglob("*")) == files, kind
    assert (tmp_path / "board.json").read_text() == (root / "board.json").read_text()
    assert "written: " in capsys.readouterr().out
