"""Benchmark of the calibration targets: detection, corner accuracy and hand-eye error from rendered views.

Run from the repository root::

    python benchmarks/targets.py --out benchmarks/results/targets.md        # about a minute
    python benchmarks/targets.py --recordings 2                              # a quick look

For each target (ChArUco, ChArUco with the legacy pattern, plain checkerboard, AprilTag grid), board views
are rendered (:func:`classic.vision.synthetic.render_view`, 2 grey levels of noise, 640x480) at random poses
0.45 to 0.7 m ahead tilted up to 35 deg, and for each of several eye-in-hand recordings of 10 views
(:func:`handeye.core.synthetic.make_problem`) the views are detected, each PnP pose computed and X
calibrated (pose-based, then refined on the corners' reprojection). Reported per target: the detection
rate, the median corner error against the true projection, and the median and worst hand-eye error of
X against the truth over the recordings.
"""

from __future__ import annotations

import argparse
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

import classic  # noqa: E402
from benchmarks._report import Report  # noqa: E402
from classic.vision import BoardSpec, ReprojectionOptions, detect_board, estimate_pose, refine_reprojection  # noqa: E402
from classic.vision.detect import project_points  # noqa: E402
from classic.vision.synthetic import default_intrinsics, render_view  # noqa: E402
from handeye.core.metrics import pose_error  # noqa: E402
from handeye.core.se3 import make_transform, so3_exp  # noqa: E402
from handeye.core.synthetic import make_problem  # noqa: E402

TARGETS = {
    "ChArUco 7x5, 5X5_100": BoardSpec(7, 5, 0.04, 0.03, "5X5_100"),
    "ChArUco legacy 6x6, 4X4_50": BoardSpec(6, 6, 0.04, 0.03, "4X4_50", legacy=True),
    "checkerboard 8x7": BoardSpec.checkerboard(8, 7, 0.035),
    "AprilTag grid 5x4, 36h11": BoardSpec.aruco_grid(5, 4, 0.045, 0.01, "APRILTAG_36h11"),
}
SETUP = "eye_in_hand"
NOISE_GREY = 2.0
VIEWS = 10


def _centre(spec):
    return make_transform(np.eye(3), [-spec.size_m[0] / 2, -spec.size_m[1] / 2, 0.0])


def _view_pose(spec, rng):
    z = rng.uniform(0.45, 0.7)
    axis = rng.normal(size=2)
    w = np.r_[np.radians(rng.uniform(10, 35)) * axis / np.linalg.norm(axis), rng.uniform(-0.5, 0.5)]
    return make_transform(so3_exp(w), [rng.uniform(-0.03, 0.03), rng.uniform(-0.03, 0.03), z]) @ _centre(spec)


def detection(spec, intr, n_views: int, seed: int) -> tuple[float, float]:
    """Detection rate and median corner error (px) over rendered views at random poses."""
    rng = np.random.default_rng(seed)
    found, errors = 0, []
    for _ in range(n_views):
        T = _view_pose(spec, rng)
        det = detect_board(render_view(spec, intr, T, NOISE_GREY, rng), spec)
        if det.reason is None:
            found += 1
            err = det.corners_px - project_points(spec.corners_target()[det.ids], T, intr)
            errors.append(np.linalg.norm(err, axis=1))
    return found / n_views, float(np.median(np.concatenate(errors))) if errors else float("nan")


def hand_eye(spec, intr, seed: int) -> tuple[float, float] | None:
    """Error (deg, mm) of X from one recording of rendered views, or None when it cannot be calibrated."""
    rng = np.random.default_rng(seed)
    p = make_problem(VIEWS, SETUP, rng, max_tilt_deg=30.0)
    C = _centre(spec)
    p.T_cam_target = p.T_cam_target @ C
    p.Y_true = p.Y_true @ C
    dets = [detect_board(render_view(spec, intr, T, NOISE_GREY, rng), spec) for T in p.T_cam_target]
    poses = [estimate_pose(d, spec, intr) for d in dets]
    ok = np.array([v.ok for v in poses])
    if ok.sum() < 4:
        return None
    try:
        cal = classic.calibrate(
            p.T_base_ee[ok],
            np.stack([v.T_cam_target for v in poses if v.ok]),
            setup=SETUP,
            options=classic.CalibrateOptions(loss="cauchy"),
        )
    except ValueError:
        return None
    ids = [d.ids if d.reason is None else np.zeros(0, int) for d in dets]
    uv = [d.corners_px if d.reason is None else np.zeros((0, 2)) for d in dets]
    res = refine_reprojection(p.T_base_ee, ids, uv, spec, intr, cal.X, cal.Y, ReprojectionOptions(setup=SETUP))
    return pose_error(res.X, p.X_true)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--views", type=int, default=40, help="rendered views per target for detection (default 40)")
    ap.add_argument("--recordings", type=int, default=10, help="hand-eye recordings per target (default 10)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--out", help="also write the report to this file")
    args = ap.parse_args(argv)
    import cv2

    report = Report(
        "Calibration targets: detection and hand-eye error from rendered views",
        "benchmarks/targets.py",
        argv,
        f"numpy {np.__version__}, opencv {cv2.__version__}",
    )
    say = report.say
    intr = default_intrinsics()
    say(
        f"{intr.width}x{intr.height} px, noise {NOISE_GREY} grey levels; hand-eye: {SETUP}, {VIEWS} views per "
        f"recording, pose-based start then the reprojection refinement"
    )
    say()
    say(
        "| target | views detected | median corner error px | recordings calibrated | X error median deg / mm | "
        "X error worst deg / mm |"
    )
    say("|---|---|---|---|---|---|")
    for k, (name, spec) in enumerate(TARGETS.items()):
        print(f"{name} ...", file=sys.stderr, flush=True)
        rate, px = detection(spec, intr, args.views, args.seed * 1000 + k)
        errs = [hand_eye(spec, intr, args.seed * 1000 + 100 * k + r) for r in range(args.recordings)]
        done = np.array([e for e in errs if e is not None]).reshape(-1, 2)
        med = np.median(done, axis=0) if len(done) else np.full(2, np.nan)
        worst = done.max(axis=0) if len(done) else np.full(2, np.nan)
        say(
            f"| {name} | {100 * rate:.0f} % of {args.views} | {px:.3f} | {len(done)} of {args.recordings} | "
            f"{med[0]:.4f} / {med[1]:.3f} | {worst[0]:.4f} / {worst[1]:.3f} |"
        )
    return report.write(args.out)


if __name__ == "__main__":
    sys.exit(main())
