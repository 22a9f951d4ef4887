"""``handeye calibrate ... --report DIR``: the page, its figures, the hold-out check, the images path, a browser."""

from __future__ import annotations

import base64
import html
import json
import re
import shlex
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("matplotlib")

import classic  # noqa: E402
from handeye.cli import build_parser, main  # noqa: E402
from handeye.core.errors import MissingDependencyError, TooFewPosesError  # noqa: E402
from handeye.core.synthetic import make_problem  # noqa: E402
from handeye.report import hold_out_check  # noqa: E402
from handeye.report.from_command import command_line  # noqa: E402
from handeye.report.tables import rpy_deg  # noqa: E402
from tests.test_docs import _browser  # noqa: E402
from tests.tolerances import DEG, FLOAT

DATA = Path(__file__).resolve().parents[1] / "handeye" / "data"
EXAMPLE = DATA / "example_eye_to_hand.csv"
SECTIONS = ("result", "method", "residuals", "frames", "motion", "holdout")
POSE_PNGS = {"residuals.png", "frames.png", "motion.png", "holdout.png"}
IMAGE_PNGS = POSE_PNGS | {"reprojection_rms.png", "overlays.png"}

#: A held-out pose's error norm against its predicted 1-sigma norm (the RMS of that norm). For an
#: isotropic 3-D Gaussian, P(|e| > 4 sigma) = P(chi2_3 > 48) ~ 1e-10; for all the variance on one axis,
#: P(chi2_1 > 16) ~ 6e-5: with 15 poses no correct prediction goes beyond 4 sigma.
HOLDOUT_MAX_SIGMAS = 4.0
#: RMS error / RMS sigma over the example's 15 held-out poses (45 degrees of freedom per kind): its
#: relative spread is about 1 / sqrt(2 * 45) = 0.11; 0.6 to 1.6 is about four spreads each way.
HOLDOUT_RATIO = (0.6, 1.6)
#: Mean chi-square per degree of freedom of the held-out errors over 8 problems of 15 poses (720 degrees
#: of freedom): 1 when the sigma is right, spread sqrt(2 / 720) = 0.053, more with the folds sharing
#: poses; 0.75 to 1.3 is about five spreads. A predicted covariance without the measurement's noise, or
#: without X and Y's uncertainty, gives 3 or more.
CHI2_PER_DOF = (0.75, 1.3)
#: The robot pose moved in the images test: 4 mm puts its view's corners about 1.4 px off (0.6 m away),
#: above the reprojection refinement's outlier threshold (3x the median view RMS, and 1 px).
SHIFT_MM = 4.0


def _images_in(page: str) -> dict[str, bytes]:
    """``data-file`` name -> the bytes of its data URI, for every image of the page."""
    out = {}
    for src, name in re.findall(r'<img src="([^"]*)"[^>]*data-file="([^"]*)"', page):
        assert src.startswith("data:image/png;base64,"), src[:40]
        out[name] = base64.b64decode(src.split(",", 1)[1])
    return out


def _check_page(folder: Path, pngs: set[str], sections: tuple[str, ...]) -> str:
    page = (folder / "index.html").read_text(encoding="utf-8")
    for name in pngs:
        assert (folder / name).stat().st_size > 0, name
    embedded = _images_in(page)
    assert set(embedded) == pngs == {p.name for p in folder.glob("*.png")}
    for name, data in embedded.items():
        assert data == (folder / name).read_bytes(), f"{name}: embedded image differs from the file"
    for anchor in sections:
        assert f'<section id="{anchor}">' in page and f'href="#{anchor}"' in page, anchor
    # self-contained: no script, no stylesheet or font fetched, no address anywhere
    assert "<script" not in page and "http://" not in page and "https://" not in page and "@import" not in page
    assert all(src.startswith("data:") for src in re.findall(r'(?:src|href)="([^"#][^"]*)"', page))
    return page


@pytest.fixture(scope="module")
def example_report(tmp_path_factory):
    folder = tmp_path_factory.mktemp("report") / "rep"
    assert main(["calibrate", str(EXAMPLE), "--setup", "eye-to-hand", "--report", str(folder)]) == 0
    return folder


def test_example_report_has_every_section_and_figure(example_report, capsys):
    page = _check_page(example_report, POSE_PNGS, SECTIONS)
    res = classic.calibrate(*_example_poses(), setup="eye_to_hand")
    t_mm = ", ".join(f"{v:+.2f}" for v in 1000 * res.T_base_cam[:3, 3])
    assert t_mm in page and "T_ee_target" in page and f"{res.sigma['X_rotation_deg']:.4f}" in page
    assert "handeye calibrate" in page and "--report" in page  # the captions name the command
    doc = json.loads((example_report / "report.json").read_text())
    assert doc["figures"] == sorted(POSE_PNGS) and doc["result"]["method"] == res.method


def _example_poses():
    from handeye.checked_poses import load_poses

    p = load_poses(EXAMPLE, "eye_to_hand")
    return p.T_base_ee, p.T_cam_target


def test_example_holdout_is_consistent_with_the_noise(example_report):
    h = json.loads((example_report / "report.json").read_text())["holdout"]
    assert h["predicted"] == 15 and sorted(r["index"] for r in h["per_pose"]) == list(range(15))
    assert h["folds"] * h["k"] >= 15 and not h["refused"]
    for r in h["per_pose"]:
        assert r["rotation_deg"] < HOLDOUT_MAX_SIGMAS * r["sigma_rotation_deg"], r
        assert r["translation_mm"] < HOLDOUT_MAX_SIGMAS * r["sigma_translation_mm"], r
    for key in ("ratio_rotation", "ratio_translation"):
        assert HOLDOUT_RATIO[0] < h[key] < HOLDOUT_RATIO[1], (key, h[key])
    # the example's camera noise is 0.1 deg / 1 mm per axis: a prediction cannot beat the measurement's noise
    assert h["rms_sigma_translation_mm"] > np.sqrt(3) * 1.0 * 0.8


@pytest.mark.parametrize("setup", ["eye_to_hand", "eye_in_hand"])
def test_holdout_sigma_is_calibrated_with_robot_noise(setup):
    """Known camera and robot noise: the held-out errors are chi-square distributed under the predicted covariance."""
    model = classic.NoiseModel(np.radians(0.1), 1e-3, np.radians(0.05), 0.5e-3)
    chi2 = []
    for seed in range(8):
        p = make_problem(15, setup, np.random.default_rng(seed), camera_noise=(0.1, 1.0), robot_noise=(0.05, 0.5))

        def fit(keep, p=p):
            return classic.calibrate(p.T_base_ee[keep], p.T_cam_target[keep], setup=setup, noise=model)

        check = hold_out_check(p.T_base_ee, p.T_cam_target, setup, fit)
        assert len(check.indices) == 15 and check.k == 3 and check.n_folds == 5
        chi2.append(check.mahalanobis**2 / 6)
    assert CHI2_PER_DOF[0] < np.mean(chi2) < CHI2_PER_DOF[1], np.mean(chi2)


def test_holdout_refuses_too_few_poses():
    p = make_problem(3, "eye_to_hand", np.random.default_rng(0))
    with pytest.raises(TooFewPosesError, match="at least 4 poses"):
        hold_out_check(p.T_base_ee, p.T_cam_target, "eye_to_hand", lambda keep: None)


def test_robust_report_marks_the_outlier(tmp_path):
    lines = EXAMPLE.read_text().splitlines()
    first = next(k for k, line in enumerate(lines) if line and line[0] in "-0123456789")
    bad = 6
    cells = lines[first + bad].split(",")
    cells[7] = repr(float(cells[7]) + 0.08)  # T_cam_target.x off by 8 cm
    lines[first + bad] = ",".join(cells)
    poses = tmp_path / "poses.csv"
    poses.write_text("\n".join(lines) + "\n")
    folder = tmp_path / "rep"
    assert main(["calibrate", str(poses), "--setup", "eye-to-hand", "--robust", "--report", str(folder)]) == 0
    page = _check_page(folder, POSE_PNGS, SECTIONS)
    doc = json.loads((folder / "report.json").read_text())
    flags = [r["inlier"] for r in doc["result"]["residuals"]["per_pose"]]
    assert flags.count(False) == 1 and not flags[bad]
    assert bad not in [r["index"] for r in doc["holdout"]["per_pose"]]  # outliers are neither fitted nor predicted
    assert "outlier poses" in page and "1 of 15" in page


def test_rpy_is_ros_convention():
    from scipy.spatial.transform import Rotation

    roll, pitch, yaw = 10.0, -20.0, 30.0
    R = (
        Rotation.from_euler("z", yaw, degrees=True)
        * Rotation.from_euler("y", pitch, degrees=True)
        * Rotation.from_euler("x", roll, degrees=True)
    ).as_matrix()  # Rz(yaw) Ry(pitch) Rx(roll)
    np.testing.assert_allclose(rpy_deg(R), [roll, pitch, yaw], atol=FLOAT / DEG)


def test_command_line_parses_back_to_the_same_arguments():
    argv = [
        "calibrate",
        "my poses.csv",
        "--setup",
        "eye-in-hand",
        "--robust",
        "--camera-noise",
        "0.1",
        "1",
        "3",
        "--units",
        "mm",
        "--report",
        "out dir",
    ]
    args = build_parser().parse_args(argv)
    text = command_line(args)
    assert text.startswith("handeye calibrate 'my poses.csv' --setup eye-in-hand")
    again = build_parser().parse_args(shlex.split(text)[1:])
    kept = lambda ns: {k: v for k, v in vars(ns).items() if k not in ("run", "command_parser")}  # noqa: E731
    assert kept(again) == kept(args)


def test_missing_matplotlib_names_the_extra(monkeypatch):
    from handeye.report.style import pyplot

    monkeypatch.setitem(sys.modules, "matplotlib", None)
    with pytest.raises(MissingDependencyError, match=r"handeye\[sim\]"):
        pyplot()


@pytest.fixture(scope="module")
def image_recording(tmp_path_factory):
    """The recording of tests/test_cli_vision.py (make_image_dataset, eye-in-hand, seed 7), with two faults:
    one image without the board (rejected) and one robot pose moved by SHIFT_MM (an outlier view)."""
    pytest.importorskip("cv2")
    import cv2

    from classic.vision.synthetic import make_image_dataset

    folder = tmp_path_factory.mktemp("recording")
    make_image_dataset(folder, 10, "eye_in_hand", rng=np.random.default_rng(7), noise_gray=2.0)
    blank = folder / "images" / "view_007.png"
    image = cv2.imread(str(blank), cv2.IMREAD_GRAYSCALE)
    assert cv2.imwrite(str(blank), np.full_like(image, 128))
    lines = (folder / "robot.csv").read_text().splitlines()
    cells = lines[1 + 3].split(",")  # view_003
    cells[1] = repr(float(cells[1]) + SHIFT_MM / 1000)
    lines[1 + 3] = ",".join(cells)
    (folder / "robot.csv").write_text("\n".join(lines) + "\n")
    return folder


def test_images_report_overlays_and_statuses(image_recording, tmp_path):
    d = image_recording
    det = tmp_path / "detections.json"
    assert (
        main(
            [
                "detect",
                str(d / "images"),
                "--board",
                str(d / "board.json"),
                "--intrinsics",
                str(d / "camera.json"),
                "-o",
                str(det),
            ]
        )
        == 0
    )
    folder, result = tmp_path / "rep", tmp_path / "result.json"
    assert (
        main(
            [
                "calibrate",
                "--detections",
                str(det),
                "--robot-poses",
                str(d / "robot.csv"),
                "--setup",
                "eye-in-hand",
                "-o",
                str(result),
                "--report",
                str(folder),
            ]
        )
        == 0
    )
    page = _check_page(folder, IMAGE_PNGS, SECTIONS + ("reprojection",))
    doc = json.loads((folder / "report.json").read_text())
    status = {v["image"]: v["status"] for v in doc["views"]}
    assert status["view_007.png"] == "rejected" and status["view_003.png"] == "outlier"
    assert sum(s == "used" for s in status.values()) == 8
    # the overlay's per-view RMS is the refinement's: same X, Y and intrinsics, same corners
    rep = json.loads(result.read_text())["reprojection"]
    for image, rms in rep["per_view_rms_px"].items():
        assert abs(next(v["rms_px"] for v in doc["views"] if v["image"] == image) - rms) < 1e-6, image
    # the hold-out check singles out the moved pose: its prediction is off by about its shift
    per_pose = doc["holdout"]["per_pose"]
    worst = max(per_pose, key=lambda r: r["translation_mm"] / r["sigma_translation_mm"])
    assert worst["index"] == 3 and worst["translation_mm"] > 3 * worst["sigma_translation_mm"]
    assert 0.7 * SHIFT_MM < worst["translation_mm"] < 1.3 * SHIFT_MM
    assert "board not found" in page and "refined on corner reprojection error" in page


#: Put into a copy of the page: records errors (scripts, resources, console) and each image's natural size.
_PROBE = """<script>
window.__errors = [];
window.addEventListener('error', e => window.__errors.push(String(e.message || (e.target && e.target.src)
  || e).slice(0, 200)), true);
for (const k of ['error', 'warn']) { const f = console[k]; console[k] = (...a) => { window.__errors.push(k + ': ' +
  a.join(' ')); f.apply(console, a); }; }
window.addEventListener('load', () => { const pre = document.createElement('pre'); pre.id = 'probe';
  pre.textContent = JSON.stringify({errors: window.__errors, images: Array.from(document.images).map(
    i => [i.dataset.file, i.complete, i.naturalWidth, i.naturalHeight])});
  document.body.appendChild(pre); });
</script>"""


@pytest.mark.skipif(
    _browser() is None,
    reason="no headless browser (chromium, chromium-browser, google-chrome; or HANDEYE_TEST_BROWSER) is installed",
)
def test_page_loads_in_a_headless_browser(example_report, tmp_path):
    page = (example_report / "index.html").read_text(encoding="utf-8")
    probe = tmp_path / "probe.html"
    probe.write_text(page.replace("<head>", "<head>" + _PROBE, 1), encoding="utf-8")
    run = subprocess.run(
        [
            _browser(),
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--enable-logging=stderr",
            "--virtual-time-budget=10000",
            "--dump-dom",
            probe.as_uri(),
        ],
        capture_output=True,
        text=True,
        timeout=120,
    )
    found = re.search(r'<pre id="probe">(.*?)</pre>', run.stdout, re.S)
    assert found, f"no probe in the dumped page (exit {run.returncode}): {run.stderr[-2000:]}"
    result = json.loads(html.unescape(found.group(1)))
    assert result["errors"] == [], result["errors"]
    assert "Uncaught" not in run.stderr
    assert {name for name, *_ in result["images"]} == POSE_PNGS
    for name, complete, width, height in result["images"]:
        assert complete and width > 0 and height > 0, name


def test_report_shows_the_error_against_the_truth(example_report, tmp_path):
    """``--truth``: the report's error is the angle and distance of the result from the truth file's poses,
    computed here apart (scipy's rotation angle); without ``--truth`` the report shows none."""
    from scipy.spatial.transform import Rotation

    truth_file = DATA / "example_eye_to_hand_truth.json"
    folder = tmp_path / "rep"
    args = ["calibrate", str(EXAMPLE), "--setup", "eye-to-hand", "--truth", str(truth_file), "--report", str(folder)]
    assert main(args) == 0
    res = classic.calibrate(*_example_poses(), setup="eye_to_hand")
    truth = json.loads(truth_file.read_text())
    doc = json.loads((folder / "report.json").read_text())["truth_error"]
    page = (folder / "index.html").read_text(encoding="utf-8")
    for name, T in (("T_base_cam", res.T_base_cam), ("T_ee_target", res.T_ee_target)):
        T_true = np.asarray(truth[name])
        angle = np.degrees(Rotation.from_matrix(T[:3, :3].T @ T_true[:3, :3]).magnitude())
        dist = 1000 * np.linalg.norm(T[:3, 3] - T_true[:3, 3])
        assert doc[name]["rotation_deg"] == pytest.approx(angle, abs=FLOAT)
        assert doc[name]["translation_mm"] == pytest.approx(dist, abs=FLOAT)
        assert f"error vs truth {name}" in page and f"{dist:.3f}" in page
    assert json.loads((example_report / "report.json").read_text())["truth_error"] is None
    assert "error vs truth" not in (example_report / "index.html").read_text(encoding="utf-8")
