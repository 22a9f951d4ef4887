"""Every method, and OpenCV's, on recordings from physical robots: spread, residuals, hold-out error, sigma.

Run from the repository root::

    python benchmarks/real_recordings.py --out benchmarks/results/real_recordings.md     # the shipped recordings
    python benchmarks/real_recordings.py --rwhe PATH/Datasets/kuka_1 PATH/Datasets/kuka_2   # and images, printed only

Per recording, every method: ``classic.calibrate`` with the default (``auto``, refined), each closed form
refined (``+lm``) and bare (the closed form alone, as OpenCV returns it), the default with ``robust=True``,
and OpenCV 4.x's ``calibrateHandEye`` / ``calibrateRobotWorldHandEye``. Reported:

- ``X`` of each method and its distance from the default's (rotation deg, translation mm): the spread;
- the residuals of ``A_i Y = X B_i`` on all poses (RMS of the rotation deg and translation mm of the camera
  pose predicted from the robot pose, :func:`predicted_camera_poses`, against the measured one);
- a hold-out error: fit on 80 % of the poses, predict the other 20 %'s camera poses from their robot poses,
  ``--splits`` random splits; the median over all held-out predictions;
- the sigma against two disjoint halves: fit each half, their difference over ``sqrt(s1^2 + s2^2)``
  (``s`` the result's 1-sigma, the RMS of the error's norm, so the ratio's RMS is 1 when the sigma is
  right), ``--halves`` random splits; the RMS of the ratio.

A method that refuses (a named error) is counted apart from the answers, with its reason. An image recording
(``--rwhe``) also runs the image path (:func:`handeye.image_calibration.calibrate_from_views`: PnP poses,
then the corners' reprojection refinement) through the same hold-out and halves.
"""

from __future__ import annotations

import argparse
import os
import sys
import warnings
from dataclasses import dataclass

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

import classic  # noqa: E402
from benchmarks._real_data import Recording, load_camodocal, load_ethz_stream, load_rwhe_folder  # noqa: E402
from benchmarks._report import Report  # noqa: E402
from classic.calibrate import initial_estimate  # noqa: E402
from handeye.core.errors import HandEyeInputError  # noqa: E402
from handeye.core.metrics import pose_error  # noqa: E402
from handeye.core.se3 import invert_transform, make_transform, project_to_so3, quat_xyzw_from_matrix  # noqa: E402
from handeye.core.setups import robot_side_poses  # noqa: E402

SCRIPT = "benchmarks/real_recordings.py"
DEFAULT = "handeye default (auto+lm)"
ROBUST = "handeye robust (auto+lm, robust=True)"
IMAGE = "handeye image path (auto, reprojection)"
CLOSED_FORMS = [m for m in classic.METHODS if m != "auto"]
HOLDOUT_FRACTION = 0.2


@dataclass
class Fit:
    """One method's answer (``X``, ``Y``, its sigma when it has one) or its refusal."""

    X: np.ndarray | None = None
    Y: np.ndarray | None = None
    sigma: dict | None = None
    refusal: str | None = None


def y_from_x(A: np.ndarray, B: np.ndarray, X: np.ndarray) -> np.ndarray:
    """The ``Y`` of ``A_i Y = X B_i`` that best fits a given ``X``: the chordal mean of ``A_i^-1 X B_i``.

    Parameters
    ----------
    A, B : array, shape (N, 4, 4)
    X : array, shape (4, 4)

    Returns
    -------
    Y : array, shape (4, 4)
    """
    Ys = invert_transform(A) @ X @ B
    return make_transform(project_to_so3(Ys[:, :3, :3].sum(axis=0)), Ys[:, :3, 3].mean(axis=0))


def predicted_camera_poses(T_base_ee: np.ndarray, setup: str, X: np.ndarray, Y: np.ndarray) -> np.ndarray:
    """The target in the camera predicted from the robot poses: ``B_i = X^-1 A_i Y``.

    Parameters
    ----------
    T_base_ee : array, shape (N, 4, 4)
    setup : {"eye_to_hand", "eye_in_hand"}
    X, Y : array, shape (4, 4)
        ``T_base_cam``, ``T_ee_target`` (eye-to-hand) or ``T_ee_cam``, ``T_base_target`` (eye-in-hand).

    Returns
    -------
    T_cam_target : array, shape (N, 4, 4)
    """
    return invert_transform(X) @ robot_side_poses(T_base_ee, setup) @ Y


def _quiet(fn):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return fn()


def _calibrate(T_base_ee, T_cam_target, setup, **kw) -> Fit:
    try:
        res = _quiet(lambda: classic.calibrate(T_base_ee, T_cam_target, setup=setup, **kw))
    except (HandEyeInputError, ValueError, np.linalg.LinAlgError) as exc:
        return Fit(refusal=f"{type(exc).__name__}: {exc}")
    return Fit(res.X, res.Y, res.sigma)


def _bare(method, T_base_ee, T_cam_target, setup) -> Fit:
    A = robot_side_poses(T_base_ee, setup)
    try:
        X, Y = _quiet(lambda: initial_estimate(A, T_cam_target, method))
    except (HandEyeInputError, ValueError, np.linalg.LinAlgError) as exc:
        return Fit(refusal=f"{type(exc).__name__}: {exc}")
    return Fit(X, Y if Y is not None else y_from_x(A, T_cam_target, X))


def _opencv(method, T_base_ee, T_cam_target, setup) -> Fit:
    from benchmarks._opencv import CV_AXXB, CV_AXYB, cv2
    from handeye.core.conventions import opencv_hand_eye_args

    A = robot_side_poses(T_base_ee, setup)
    try:
        if method in CV_AXXB:
            R, t = cv2.calibrateHandEye(*opencv_hand_eye_args(T_base_ee, T_cam_target, setup), method=CV_AXXB[method])
            X = make_transform(R, t.ravel())
            return Fit(X, y_from_x(A, T_cam_target, X))
        args = ([*A[:, :3, :3]], [*A[:, :3, 3:]], [*T_cam_target[:, :3, :3]], [*T_cam_target[:, :3, 3:]])
        _, _, R, t = cv2.calibrateRobotWorldHandEye(*args, method=CV_AXYB[method])
        X = make_transform(R, t.ravel())
        return Fit(X, y_from_x(A, T_cam_target, X))
    except cv2.error as exc:
        return Fit(refusal=f"cv2.error: {str(exc).strip().splitlines()[-1]}")


def methods(opencv: bool = True) -> dict:
    """Every method by its row name: a function ``(T_base_ee, T_cam_target, setup) -> Fit``."""
    out = {DEFAULT: lambda a, b, s: _calibrate(a, b, s), ROBUST: lambda a, b, s: _calibrate(a, b, s, robust=True)}
    for m in CLOSED_FORMS:
        out[f"handeye {m}+lm"] = lambda a, b, s, m=m: _calibrate(a, b, s, method=m)
    for m in CLOSED_FORMS:
        out[f"handeye {m} (closed form)"] = lambda a, b, s, m=m: _bare(m, a, b, s)
    if opencv:
        for m in CLOSED_FORMS:
            out[f"opencv {m}"] = lambda a, b, s, m=m: _opencv(m, a, b, s)
    return out


def image_method(rec: Recording):
    """The image path as a method over view indices: ``(indices) -> Fit`` (None for a pose recording)."""
    if rec.views is None:
        return None
    from classic.vision.views import Views
    from handeye.image_calibration import calibrate_from_views

    ok = rec.view_index

    def fit(idx) -> Fit:
        keep = [ok[i] for i in idx]
        sub = Views([rec.views.views[k] for k in keep], rec.views.spec, rec.views.intrinsics, rec.views.image_folder)
        try:
            out = _quiet(lambda: calibrate_from_views(sub, rec.T_base_ee_all[keep], rec.setup, method="auto"))
        except (HandEyeInputError, ValueError, np.linalg.LinAlgError) as exc:
            return Fit(refusal=f"{type(exc).__name__}: {exc}")
        sigma = out.reprojection.sigma if out.reprojection is not None else out.pose_based.sigma
        return Fit(out.X, out.Y, sigma)

    return fit


def _errors(rec: Recording, idx, fit: Fit):
    """Rotation deg and translation mm of the predicted against the measured camera poses at ``idx``."""
    pred = predicted_camera_poses(rec.T_base_ee[idx], rec.setup, fit.X, fit.Y)
    return pose_error(pred, rec.T_cam_target[idx])


def _splits(n: int, count: int, rng: np.random.Generator, fraction: float):
    """``count`` random splits of ``range(n)`` into (fit, held out), ``fraction`` held out."""
    k = max(1, int(round(fraction * n)))
    for _ in range(count):
        p = rng.permutation(n)
        yield np.sort(p[k:]), np.sort(p[:k])


@dataclass
class Row:
    """What one method gave on one recording."""

    fit: Fit
    holdout: tuple | None = None  # median rotation deg, translation mm over all held-out predictions
    holdout_refused: int = 0
    holdout_reasons: tuple = ()
    halves: tuple | None = None  # RMS ratio rotation, translation; median difference deg, mm; median sigma
    halves_refused: int = 0


def evaluate(rec: Recording, fits: dict, splits: int, halves: int, seed: int) -> dict:
    """Each method on all poses, on ``splits`` hold-out splits, and on ``halves`` pairs of disjoint halves.

    Parameters
    ----------
    rec : Recording
    fits : dict
        Row name to a function of pose indices returning a :class:`Fit`.
    splits, halves : int
    seed : int

    Returns
    -------
    dict
        Row name to :class:`Row`.
    """
    n = len(rec.T_base_ee)
    out = {}
    for name, fn in fits.items():
        print(f"{rec.name}: {name} ...", file=sys.stderr, flush=True)
        row = Row(fn(np.arange(n)))
        rng = np.random.default_rng(seed)
        errs, reasons = [], []
        for train, test in _splits(n, splits, rng, HOLDOUT_FRACTION):
            f = fn(train)
            if f.refusal:
                row.holdout_refused += 1
                reasons.append(f.refusal)
                continue
            errs.append(np.stack(_errors(rec, test, f), axis=-1))
        if errs:
            e = np.concatenate(errs)
            row.holdout = (float(np.median(e[:, 0])), float(np.median(e[:, 1])))
        row.holdout_reasons = tuple(dict.fromkeys(reasons))
        if row.fit.sigma is not None:
            ratios, diffs, sigmas = [], [], []
            for first, second in _splits(n, halves, rng, 0.5):
                f1, f2 = fn(first), fn(second)
                if f1.refusal or f2.refusal:
                    row.halves_refused += 1
                    continue
                d = np.array(pose_error(f1.X, f2.X))
                s = np.array(
                    [
                        np.hypot(f1.sigma["X_rotation_deg"], f2.sigma["X_rotation_deg"]),
                        np.hypot(f1.sigma["X_translation_mm"], f2.sigma["X_translation_mm"]),
                    ]
                )
                ratios.append(d / s)
                diffs.append(d)
                sigmas.append(s / np.sqrt(2))
            if ratios:
                row.halves = (
                    *np.sqrt(np.mean(np.square(ratios), axis=0)),
                    *np.median(diffs, axis=0),
                    *np.median(sigmas, axis=0),
                )
        out[name] = row
    return out


def _pose_fn(rec: Recording, method):
    return lambda idx: method(rec.T_base_ee[idx], rec.T_cam_target[idx], rec.setup)


def report_recording(r: Report, rec: Recording, rows: dict) -> None:
    """The tables of one recording."""
    n = len(rec.T_base_ee)
    r.say(f"## {rec.name}: {n} poses, {rec.setup.replace('_', '-')}")
    r.say(f"source: {rec.source}")
    for note in rec.notes:
        r.say(f"note: {note}")
    r.say()
    ref_name = DEFAULT if not rows[DEFAULT].fit.refusal else ROBUST
    ref = rows[ref_name].fit
    r.say(f"spread: each X against the {ref_name}'s")
    r.say()
    r.say(
        "| method | X translation [m] | X quaternion xyzw | spread: deg / mm | residual RMS: deg / mm "
        "| hold-out median: deg / mm | halves: diff / sigma rot, trans (RMS) | refused (all; hold-out) |"
    )
    r.say("|---|---|---|---|---|---|---|---|")
    answers = refusals = 0
    for name, row in rows.items():
        f = row.fit
        refused = f"{'yes' if f.refusal else 'no'}; {row.holdout_refused}"
        if f.refusal:
            refusals += 1
            r.say(f"| {name} | refused | | | | | | {refused} |")
            continue
        answers += 1
        t = ", ".join(f"{v:+.4f}" for v in f.X[:3, 3])
        q = ", ".join(f"{v:+.4f}" for v in quat_xyzw_from_matrix(f.X[:3, :3]))
        spread = "n/a" if ref.refusal else "{:.3f} / {:.2f}".format(*pose_error(f.X, ref.X))
        e = np.stack(_errors(rec, np.arange(n), f), axis=-1)
        res = f"{np.sqrt(np.mean(e[:, 0] ** 2)):.3f} / {np.sqrt(np.mean(e[:, 1] ** 2)):.2f}"
        hold = "all refused" if row.holdout is None else f"{row.holdout[0]:.3f} / {row.holdout[1]:.2f}"
        halves = "" if row.halves is None else f"{row.halves[0]:.2f}, {row.halves[1]:.2f}"
        r.say(f"| {name} | {t} | {q} | {spread} | {res} | {hold} | {halves} | {refused} |")
    r.say()
    r.say(f"answers {answers}, refusals {refusals} (on all {n} poses)")
    _say_refusals(r, rows)
    r.say()
    r.say(
        "Sigma against disjoint halves (methods with a sigma): RMS over the splits of |X1 - X2| / "
        "sqrt(s1^2 + s2^2); 1 when the sigma is right, above 1 when it is overconfident"
    )
    r.say()
    r.say("| method | ratio rot | ratio trans | median diff deg / mm | median sigma of a half deg / mm | refused |")
    r.say("|---|---|---|---|---|---|")
    for name, row in rows.items():
        if row.halves is not None:
            h = row.halves
            r.say(
                f"| {name} | {h[0]:.2f} | {h[1]:.2f} | {h[2]:.3f} / {h[3]:.2f} | {h[4]:.3f} / {h[5]:.2f} "
                f"| {row.halves_refused} |"
            )
    r.say()


def _say_refusals(r, rows: dict) -> None:
    """Each distinct refusal once, with the methods that gave it (the refined closed forms refuse alike)."""
    by_reason: dict[str, list[str]] = {}
    for name, row in rows.items():
        if row.fit.refusal:
            by_reason.setdefault(row.fit.refusal, []).append(f"{name} (all poses)")
        for reason in row.holdout_reasons[:2]:
            by_reason.setdefault(reason, []).append(f"{name} (hold-out, {row.holdout_refused} of the splits)")
    for reason, names in by_reason.items():
        r.say(f"- refused by {', '.join(names)}: {reason}")


def recordings(args) -> list:
    """The shipped recordings, and those named on the command line."""
    recs = [] if args.no_shipped else [load_camodocal(), load_ethz_stream()]
    for folder in args.rwhe or []:
        print(f"detecting {folder} ...", file=sys.stderr, flush=True)
        recs.append(load_rwhe_folder(folder, progress=True))
    if args.max_poses:
        recs = [
            rec.subset(np.unique(np.linspace(0, len(rec.T_base_ee) - 1, args.max_poses).round().astype(int)))
            if len(rec.T_base_ee) > args.max_poses
            else rec
            for rec in recs
        ]
    return recs


def main(argv=None) -> int:
    """Run the benchmark; returns the exit status."""
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--rwhe", nargs="*", metavar="DIR", help="RWHE-Calib image recordings (Datasets/kuka_1, ...)")
    p.add_argument("--no-shipped", action="store_true", help="only the recordings named on the command line")
    p.add_argument("--splits", type=int, default=30, help="hold-out splits (80 %% fit, 20 %% predicted)")
    p.add_argument("--halves", type=int, default=10, help="random splits into two disjoint halves")
    p.add_argument("--no-opencv", action="store_true", help="leave OpenCV's methods out")
    p.add_argument("--max-poses", type=int, default=None, help="at most this many poses per recording, evenly")
    p.add_argument("--seed", type=int, default=0)
    Report.add_out(p)
    args = p.parse_args(argv)
    Report.cut(args, splits=2, halves=1, max_poses=16)
    import scipy

    versions = f"python {sys.version.split()[0]}, numpy {np.__version__}, scipy {scipy.__version__}"
    if not args.no_opencv:
        from benchmarks._opencv import cv2

        versions += f", opencv {cv2.__version__}"
    r = Report("handeye on real recordings", SCRIPT, argv, versions)
    r.say(
        f"hold-out: {args.splits} splits, {HOLDOUT_FRACTION:.0%} held out; halves: {args.halves} splits; "
        f"seed {args.seed}"
    )
    r.say()
    for rec in recordings(args):
        fits = {name: _pose_fn(rec, m) for name, m in methods(not args.no_opencv).items()}
        image = image_method(rec)
        if image is not None:
            fits[IMAGE] = image
        report_recording(r, rec, evaluate(rec, fits, args.splits, args.halves, args.seed))
    return r.write(args.out)


if __name__ == "__main__":
    sys.exit(main())
