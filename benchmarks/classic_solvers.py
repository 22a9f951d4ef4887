"""Benchmark of the classic solvers against OpenCV 4.x: accuracy, speed, outliers, uncertainty.

Run from the repository root::

    python benchmarks/classic_solvers.py                 # the README's figures (a few minutes)
    python benchmarks/classic_solvers.py --trials 20     # a quick look

Every table comes from one run on synthetic eye-to-hand data
(:func:`handeye.core.synthetic.make_problem`): camera noise per axis on
``T_cam_target``, robot noise per axis on ``T_base_ee``. Errors are those of
``X = T_base_cam`` against the truth. OpenCV gets the same data through its
documented eye-to-hand mapping (``base2gripper`` in the ``gripper2base`` slot).
"""

from __future__ import annotations

import argparse
import datetime
import os
import platform
import sys
import time
import warnings

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

import classic  # noqa: E402
from benchmarks._machine import machine  # noqa: E402
from benchmarks._opencv import CV_AXXB, CV_AXYB, cv2  # noqa: E402
from classic.calibrate import initial_estimate  # noqa: E402
from handeye.core.conventions import opencv_hand_eye_args  # noqa: E402
from handeye.core.errors import WeakMotionWarning  # noqa: E402
from handeye.core.metrics import pose_error  # noqa: E402
from handeye.core.se3 import make_transform  # noqa: E402
from handeye.core.setups import robot_side_poses  # noqa: E402
from handeye.core.synthetic import make_problem  # noqa: E402

SETUP = "eye_to_hand"
ROBOT_NOISE = (0.01, 0.2)  # deg, mm per axis
CAMERA_NOISES = [(0.1, 1.0), (0.5, 5.0)]
POSE_COUNTS = [10, 20, 50]
SPEED_COUNTS = [10, 20, 50, 200]
OUTLIER_FRACTIONS = [0.0, 0.1, 0.2, 0.3]
DEFAULT = f"handeye default ({classic.DEFAULT_METHOD}+lm)"
#: The closed forms both libraries have ("auto" is this project's choice between two of them).
CLOSED_FORMS = [m for m in classic.METHODS if m != "auto"]
ROBUST = "handeye robust (LMedS + cauchy, then least squares on the inliers)"


def opencv_inputs(T_base_ee, T_cam_target):
    """Lists of rotations and translations in OpenCV's eye-to-hand slots (handeye.core.conventions)."""
    A = robot_side_poses(T_base_ee, SETUP)
    return {
        "axxb": opencv_hand_eye_args(T_base_ee, T_cam_target, SETUP),
        "axyb": ([*A[:, :3, :3]], [*A[:, :3, 3:]], [*T_cam_target[:, :3, :3]], [*T_cam_target[:, :3, 3:]]),
    }


def opencv_solve(method, inputs):
    """``T_base_cam`` by OpenCV's implementation of ``method``."""
    if method in CV_AXXB:
        R, t = cv2.calibrateHandEye(*inputs["axxb"], method=CV_AXXB[method])
        return make_transform(R, t.ravel())
    _, _, R, t = cv2.calibrateRobotWorldHandEye(*inputs["axyb"], method=CV_AXYB[method])
    return make_transform(R, t.ravel())


def ours_closed_form(method, T_base_ee, T_cam_target):
    """``T_base_cam`` by this project's closed form (no refinement)."""
    X, _ = initial_estimate(robot_side_poses(T_base_ee, SETUP), T_cam_target, method)
    return X


def problem(n, cam_noise, rng, outliers=0.0):
    return make_problem(n, SETUP, rng, camera_noise=cam_noise, robot_noise=ROBOT_NOISE, outlier_fraction=outliers)


def stats(errors):
    e = np.asarray(errors)
    return np.median(e, axis=0), np.quantile(e, 0.9, axis=0)


def accuracy(trials, seed):
    """Monte Carlo accuracy of every method; also collects predicted sigmas for the uncertainty table."""
    names = [DEFAULT] + [f"handeye {m}" for m in CLOSED_FORMS] + [f"opencv {m}" for m in CLOSED_FORMS]
    table, sigmas, passes = {}, {}, []
    for cam in CAMERA_NOISES:
        for n in POSE_COUNTS:
            print(f"accuracy: camera noise {cam}, {n} poses, {trials} trials ...", file=sys.stderr, flush=True)
            rng = np.random.default_rng(seed)
            errs = {k: [] for k in names}
            pred, actual = [], []
            for _ in range(trials):
                p = problem(n, cam, rng)
                inputs = opencv_inputs(p.T_base_ee, p.T_cam_target)
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore", WeakMotionWarning)
                    res = classic.calibrate(p.T_base_ee, p.T_cam_target, setup=SETUP)
                e = pose_error(res.X, p.X_true)
                errs[DEFAULT].append(e)
                actual.append(e)
                pred.append((res.sigma["X_rotation_deg"], res.sigma["X_translation_mm"]))
                for m in CLOSED_FORMS:
                    errs[f"handeye {m}"].append(pose_error(ours_closed_form(m, p.T_base_ee, p.T_cam_target), p.X_true))
                    errs[f"opencv {m}"].append(pose_error(opencv_solve(m, inputs), p.X_true))
            cell = {k: stats(v) for k, v in errs.items()}
            table[(cam, n)] = cell
            sigmas[(cam, n)] = (np.sqrt(np.mean(np.square(pred), axis=0)), np.sqrt(np.mean(np.square(actual), axis=0)))
            best_cv = (
                min(cell[f"opencv {m}"][0][0] for m in CLOSED_FORMS),
                min(cell[f"opencv {m}"][0][1] for m in CLOSED_FORMS),
            )
            ok = cell[DEFAULT][0][0] <= best_cv[0] and cell[DEFAULT][0][1] <= best_cv[1]
            passes.append(((cam, n), ok, cell[DEFAULT][0], best_cv))
    return names, table, sigmas, passes


def print_accuracy(names, table, passes, trials):
    print(f"\n## Accuracy of X = T_base_cam: median / 90th percentile over {trials} trials")
    print(f"robot noise {ROBOT_NOISE[0]} deg / {ROBOT_NOISE[1]} mm per axis; eye-to-hand; all motion pairs\n")
    for cam in CAMERA_NOISES:
        print(f"camera noise {cam[0]} deg / {cam[1]} mm per axis\n")
        head = "| method | " + " | ".join(f"{n} poses: rot deg | {n} poses: trans mm" for n in POSE_COUNTS) + " |"
        print(head)
        print("|---" * (1 + 2 * len(POSE_COUNTS)) + "|")
        for k in names:
            cells = []
            for n in POSE_COUNTS:
                med, p90 = table[(cam, n)][k]
                cells += [f"{med[0]:.4f} / {p90[0]:.4f}", f"{med[1]:.3f} / {p90[1]:.3f}"]
            print(f"| {k} | " + " | ".join(cells) + " |")
        print()
    print("Target: the default method's median is no worse than the best OpenCV method's median, every cell.\n")
    print("| camera noise | poses | default median rot / trans | best OpenCV median rot / trans | target |")
    print("|---|---|---|---|---|")
    for (cam, n), ok, d, b in passes:
        print(
            f"| {cam[0]} deg / {cam[1]} mm | {n} | {d[0]:.4f} deg / {d[1]:.3f} mm | {b[0]:.4f} deg / {b[1]:.3f} mm "
            f"| {'met' if ok else 'MISSED'} |"
        )


def _time(fn, repeats):
    fn()  # warm-up
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return float(np.median(times))


def speed(seed, repeats):
    print("\n## Speed: all motion pairs, median wall time of repeated calls (ms), same data for both")
    print(
        "handeye = classic.solve(T_base_ee, T_cam_target, setup, method): validation, pose pairs, closed form; "
        "opencv = cv2.calibrateHandEye /"
    )
    print("cv2.calibrateRobotWorldHandEye on lists prepared outside the timing. ratio = opencv / handeye.\n")
    print("| poses | method | handeye ms | opencv ms | ratio |")
    print("|---|---|---|---|---|")
    rows = []
    for n in SPEED_COUNTS:
        p = problem(n, CAMERA_NOISES[0], np.random.default_rng(seed))
        inputs = opencv_inputs(p.T_base_ee, p.T_cam_target)
        for m in CLOSED_FORMS:

            def ours(m=m):
                return classic.solve(p.T_base_ee, p.T_cam_target, SETUP, m)

            reps = repeats if n < 200 else max(3, repeats // 4)
            t_ours = _time(ours, reps)
            t_cv = _time(lambda m=m: opencv_solve(m, inputs), reps)
            rows.append((n, m, t_ours, t_cv))
            print(f"| {n} | {m} | {1000 * t_ours:.3f} | {1000 * t_cv:.3f} | {t_cv / t_ours:.1f}x |")
        t_full = _time(lambda: classic.calibrate(p.T_base_ee, p.T_cam_target, setup=SETUP), max(3, repeats // 4))
        print(
            f"| {n} | full calibrate() default (checks + {classic.DEFAULT_METHOD} start + refinement + covariance) "
            f"| {1000 * t_full:.3f} | - | - |"
        )
    at200 = [(m, c / o) for n, m, o, c in rows if n == 200 and m in CV_AXXB]
    worst = min(at200, key=lambda r: r[1])
    print(
        f"\nTarget: at 200 poses at least 10x faster than OpenCV's same AX=XB method. "
        f"Slowest ratio: {worst[0]} {worst[1]:.1f}x -> {'met' if worst[1] >= 10 else 'MISSED'}"
    )


def outliers(trials, seed):
    n, cam = 20, CAMERA_NOISES[0]
    print(f"\n## Outliers: {n} poses, camera noise {cam[0]} deg / {cam[1]} mm, a fraction of camera poses replaced by")
    print(f"gross errors (rotated 10-90 deg, moved 5-30 cm). Median X error over {trials} trials: rot deg / trans mm\n")
    methods = {
        ROBUST: lambda p: classic.calibrate(p.T_base_ee, p.T_cam_target, setup=SETUP, robust=True).X,
        DEFAULT: lambda p: classic.calibrate(p.T_base_ee, p.T_cam_target, setup=SETUP).X,
        "handeye park (closed form)": lambda p: ours_closed_form("park", p.T_base_ee, p.T_cam_target),
        "handeye shah (closed form)": lambda p: ours_closed_form("shah", p.T_base_ee, p.T_cam_target),
        "opencv park": lambda p: opencv_solve("park", opencv_inputs(p.T_base_ee, p.T_cam_target)),
        "opencv tsai": lambda p: opencv_solve("tsai", opencv_inputs(p.T_base_ee, p.T_cam_target)),
    }
    res = {k: {} for k in methods}
    for frac in OUTLIER_FRACTIONS:
        print(f"outliers: {int(100 * frac)} %, {trials} trials ...", file=sys.stderr, flush=True)
        rng = np.random.default_rng(seed)
        errs = {k: [] for k in methods}
        for _ in range(trials):
            p = problem(n, cam, rng, outliers=frac)
            for k, fn in methods.items():
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore", WeakMotionWarning)
                    try:
                        errs[k].append(pose_error(fn(p), p.X_true))
                    except ValueError:  # a check refused the contaminated data
                        errs[k].append((np.nan, np.nan))
        for k in methods:
            e = np.asarray(errs[k], dtype=float)
            res[k][frac] = (np.nanmedian(e, axis=0), np.mean(np.isnan(e[:, 0])))
    print("| method | " + " | ".join(f"{int(100 * f)} %" for f in OUTLIER_FRACTIONS) + " |")
    print("|---" * (1 + len(OUTLIER_FRACTIONS)) + "|")
    for k in methods:
        cells = []
        for f in OUTLIER_FRACTIONS:
            (r, t), refused = res[k][f]
            cells.append(f"{r:.3f} / {t:.2f}" + (f" ({100 * refused:.0f}% refused)" if refused else ""))
        print(f"| {k} | " + " | ".join(cells) + " |")
    base = res[ROBUST][0.0][0]
    ok = all(np.all(res[ROBUST][f][0] <= 2 * base) for f in (0.1, 0.2))
    print(f"\nTarget: robust error within 2x its outlier-free error up to 20 % -> {'met' if ok else 'MISSED'}")


def uncertainty(sigmas, trials):
    print("\n## Uncertainty: predicted 1-sigma of X (RMS over trials of sqrt(trace) of the covariance blocks) against")
    print(f"the Monte Carlo RMS error of the default method, {trials} trials per cell\n")
    print(
        "| camera noise | poses | predicted rot deg | actual rot deg | ratio | predicted trans mm | actual trans mm "
        "| ratio |"
    )
    print("|---|---|---|---|---|---|---|---|")
    worst = 0.0
    for (cam, n), (pred, act) in sigmas.items():
        ratios = pred / act
        worst = max(worst, float(np.max(np.abs(ratios - 1))))
        print(
            f"| {cam[0]} deg / {cam[1]} mm | {n} | {pred[0]:.4f} | {act[0]:.4f} | {ratios[0]:.2f} | {pred[1]:.3f} "
            f"| {act[1]:.3f} | {ratios[1]:.2f} |"
        )
    print(f"\nTarget: within 30 %. Worst deviation {100 * worst:.0f} % -> {'met' if worst <= 0.3 else 'MISSED'}")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--trials", type=int, default=200, help="Monte Carlo trials per cell (default 200)")
    ap.add_argument("--repeats", type=int, default=20, help="timing repeats (default 20)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--only", choices=["accuracy", "speed", "outliers"], help="run one section")
    args = ap.parse_args(argv)
    import scipy

    print("# handeye classic solvers benchmark")
    args_text = " ".join(argv if argv is not None else sys.argv[1:])
    print(f"command: python benchmarks/classic_solvers.py {args_text}".rstrip())
    print(f"machine: {machine()}")
    print(
        f"python {platform.python_version()}, numpy {np.__version__}, scipy {scipy.__version__}, "
        f"opencv {cv2.__version__}; {datetime.datetime.now(datetime.timezone.utc):%Y-%m-%d %H:%M} UTC"
    )
    t0 = time.perf_counter()
    if args.only in (None, "accuracy"):
        names, table, sigmas, passes = accuracy(args.trials, args.seed)
        print_accuracy(names, table, passes, args.trials)
        uncertainty(sigmas, args.trials)
    if args.only in (None, "speed"):
        speed(args.seed, args.repeats)
    if args.only in (None, "outliers"):
        outliers(args.trials, args.seed)
    print(f"\ntotal benchmark time {time.perf_counter() - t0:.0f} s")


if __name__ == "__main__":
    main()
