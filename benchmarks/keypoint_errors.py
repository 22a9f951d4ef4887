"""Benchmark: where the keypoint model's pose error comes from, its pixel positions or its depths.

Run from the repository root, on a dataset and a keypoint model trained on it::

    python benchmarks/keypoint_errors.py --data data/paper-sim-noisy --model runs/kp-cpu/batch/keypoints.pt \\
        --out benchmarks/results/keypoint_errors_cpu_paper-sim.md

The model (:mod:`learned.keypoints`) predicts per keypoint (the robot's joint origins, points along
its long links, the flange, the reference point) a normalised image position and a depth on every test frame;
the targets are the keypoints projected with the true ``T_base_cam``. Reported:

1. Per keypoint, over the test frames where its target lies in the image: median pixel error
   at the dataset's native resolution and at the network's input resolution, the same as mm
   across the line of sight (at the keypoint's true depth), and the median signed (predicted
   minus true) and absolute depth error.
2. The model's residual statistics (:func:`learned.keypoints.residual_stats`, estimated after its
   training on its training frames; for a model saved before it kept them, estimated here on the
   ``train`` split): per keypoint the offset and the sigma the placement fit uses.
3. Per camera placement (all its test frames, :func:`learned.keypoints.camera_pose`), the pose
   error against the truth, median and worst over the test placements: with the 3-D to 3-D fit
   from the predicted keypoints, from the true pixel positions with the predicted depths, and from
   the predicted pixel positions with the true depths; and with the offsets removed and the
   maximum-likelihood fit (what the protocol reports).
4. The same likelihood fit from a random 10 % sample of each placement's frames (the paper's novelty
   sample), against all its frames.
5. The likelihood fit's placement errors in the true camera frame, on the test placements and on
   the training placements (the frames the model was trained on): RMS per camera axis, along and
   across the line of sight to the robot, what is left once the rotation error turned about the
   robot (``-w x p_c``) is taken out, and the mean rotation error (a tilt common to the placements).
6. A short interpretation generated from these numbers.
"""

from __future__ import annotations

import argparse
import datetime
import os
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

from benchmarks._machine import machine  # noqa: E402
from handeye.core.dataset import Dataset  # noqa: E402
from handeye.core.se3 import matrix_from_quat_xyzw, so3_log  # noqa: E402
from handeye.learned_frames import load_keypoint_frames  # noqa: E402
from handeye.robot_model import dataset_robot  # noqa: E402
from learned.experiment import load_model  # noqa: E402
from learned.keypoints import camera_pose, keypoint_targets, model_residual_stats, pose_errors  # noqa: E402
from learned.trainer import estimate_residuals, predict  # noqa: E402


def keypoint_stats(pred, tgt, intrinsics_norm, native, network):
    """Per-keypoint medians over the frames where the target lies in the image.

    Parameters
    ----------
    pred, tgt : array, shape (N, K, 3)
        Predicted and true ``(x_n, y_n, z_m)``.
    intrinsics_norm : array, shape (N, 4)
    native, network : (int, int)
        ``(width, height)`` of the dataset's images and of the network's input.

    Returns
    -------
    dict of str to array, shape (K,)
        ``in_view`` (fraction), ``px_native``, ``px_network``, ``lateral_mm``, ``dz_mm`` (signed),
        ``abs_dz_mm``, each a median.
    """
    dx, dy = pred[..., 0] - tgt[..., 0], pred[..., 1] - tgt[..., 1]
    inside = (tgt[..., 0] > 0) & (tgt[..., 0] < 1) & (tgt[..., 1] > 0) & (tgt[..., 1] < 1) & (tgt[..., 2] > 0)
    fx, fy = intrinsics_norm[:, None, 0], intrinsics_norm[:, None, 1]
    per = {
        "px_native": np.hypot(dx * native[0], dy * native[1]),
        "px_network": np.hypot(dx * network[0], dy * network[1]),
        "lateral_mm": np.hypot(dx / fx, dy / fy) * tgt[..., 2] * 1000.0,
        "dz_mm": (pred[..., 2] - tgt[..., 2]) * 1000.0,
    }
    per["abs_dz_mm"] = np.abs(per["dz_mm"])
    out = {
        k: np.array([np.median(v[inside[:, j], j]) if inside[:, j].any() else np.nan for j in range(v.shape[1])])
        for k, v in per.items()
    }
    out["all"] = {k: np.median(v[inside]) for k, v in per.items()}
    out["in_view"] = inside.mean(0)
    return out


def predicted_and_true(model, frames, index):
    """A keypoint model's predictions for the frames at ``index`` and their true ``(x_n, y_n, z_m)``, (N, K, 3) each."""
    pred = predict(model, frames, index)
    tgt = keypoint_targets(
        frames.keypoints_base[index].astype(float),
        frames.truth_t_base_cam_mm[index],
        frames.truth_q_base_cam_xyzw[index],
        frames.intrinsics_norm[index],
    )
    return pred, tgt


def placement_errors(kp, frames, index, stats=None):
    """Pose error of each camera placement from keypoints ``kp`` of the frames at ``index``.

    ``stats``: residual statistics for :func:`learned.keypoints.camera_pose` (``None``: the 3-D to 3-D fit).

    Returns
    -------
    array, shape (P, 2)
        Translation mm and rotation deg per placement, in the order of ``np.unique(frames.camera[index])``.
    """
    rows = []
    for c in np.unique(frames.camera[index]):
        m = frames.camera[index] == c
        T, _ = camera_pose(
            kp[m], frames.keypoints_base[index][m].astype(float), frames.intrinsics_norm[index][m], stats=stats
        )
        i0 = index[m][0]
        et, er = pose_errors(T[None], frames.truth_t_base_cam_mm[[i0]], frames.truth_q_base_cam_xyzw[[i0]])
        rows.append((et[0], er[0]))
    return np.array(rows)


def camera_frame_errors(kp, frames, index, stats) -> np.ndarray:
    """Each placement's likelihood-fit error in its true camera frame, and the part its rotation error explains.

    The fit's ``T_base_cam`` is the truth times an error ``(w, e)`` in the camera frame. Turning the camera
    by ``w`` about the robot, seen at ``p_c`` (the keypoints' mean in the camera frame), moves it by
    ``-w x p_c``: a rotation error ``w`` read from the robot's shape shows as that translation.

    Returns
    -------
    array, shape (P, 10)
        Per placement ``e`` (mm, 3), ``w`` (deg, 3), ``-w x p_c`` (mm, 3) and ``|p_c|`` (mm).
    """
    rows = []
    for c in np.unique(frames.camera[index]):
        m = frames.camera[index] == c
        p_base = frames.keypoints_base[index][m].astype(float)
        T_base_cam, _ = camera_pose(kp[m], p_base, frames.intrinsics_norm[index][m], stats=stats)
        i0 = index[m][0]
        R_base_cam = matrix_from_quat_xyzw(frames.truth_q_base_cam_xyzw[i0])  # the truth; quaternion (x, y, z, w)
        t_base_cam_mm = frames.truth_t_base_cam_mm[i0]
        e = R_base_cam.T @ (T_base_cam[:3, 3] * 1000.0 - t_base_cam_mm)
        w = so3_log(R_base_cam.T @ T_base_cam[:3, :3])
        p_c = (R_base_cam.T @ (p_base.reshape(-1, 3) * 1000.0 - t_base_cam_mm).T).T.mean(0)
        rows.append(np.r_[e, np.degrees(w), -np.cross(w, p_c), np.linalg.norm(p_c)])
    return np.array(rows)


def camera_frame_row(name: str, ce: np.ndarray) -> str:
    """One table row of :func:`camera_frame_errors`: RMS per axis, along and across the line of sight, left."""
    e, w, rot, dist = ce[:, 0:3], ce[:, 3:6], ce[:, 6:9], ce[:, 9]
    rms = np.sqrt((e**2).mean(0))
    along = np.sqrt((e[:, 2] ** 2).mean())
    across = np.sqrt((e[:, 0] ** 2 + e[:, 1] ** 2).mean())
    left = np.sqrt(((e - rot) ** 2).sum(1).mean())
    total = np.sqrt((e**2).sum(1).mean())
    return (
        f"| {name} | {len(ce)} | {rms[0]:.1f} / {rms[1]:.1f} / {rms[2]:.1f} | {along:.1f} / {across:.1f} | "
        f"{total:.1f} | {left:.1f} | {w[:, 0].mean():+.3f} / {w[:, 1].mean():+.3f} / {w[:, 2].mean():+.3f} | "
        f"{np.median(dist):.0f} |"
    )


def residual_stats_of(model, frames) -> tuple[np.ndarray, str]:
    """A keypoint model's residual statistics (2, K, 3) and where they come from.

    A model saved before models kept them gets them estimated on the ``train`` split, as its training
    would have (:func:`learned.trainer.estimate_residuals`).
    """
    stats = model_residual_stats(model)
    if stats is not None:
        return stats, "kept in the model (its last training call's frames)"
    estimate_residuals(model, frames, np.flatnonzero(frames.split == "train"))
    return model_residual_stats(model), "estimated here on the train split (the model was saved without them)"


def interpretation(variants, stats, names):
    """One paragraph reading the tables: which error, pixels or depth, the pose error comes from.

    Parameters
    ----------
    variants : dict of str to array, shape (P, 2)
            ``"pred"``, ``"true_px"`` (true pixels, predicted depth), ``"true_z"`` (predicted pixels, true depth),
        with the 3-D to 3-D fit; ``"ml"``, the predicted keypoints with the likelihood fit.
    stats : dict
        :func:`keypoint_stats`.
    names : list of str
    """
    p, a, b = (np.median(variants[k][:, 0]) for k in ("pred", "true_px", "true_z"))
    pr = np.median(variants["pred"][:, 1])
    text = (
        f"Per placement the predicted keypoints give a median error of {p:.1f} mm / {pr:.2f} deg. "
        f"With the true pixel positions (so only the depth error left) it is {a:.1f} mm ({a / p:.0%} of it); "
        f"with the true depths (only the pixel error left) {b:.1f} mm ({b / p:.0%}). "
    )
    if abs(a - b) < 0.1 * p:
        text += "Pixel and depth errors contribute about equally"
    else:
        text += f"The {'pixel' if a < b else 'depth'} error is the larger source"
    if min(a, b) > 0.5 * p:
        text += f", but removing it alone still leaves {min(a, b) / p:.0%} of the error: both matter. "
    else:
        text += ". "
    al = stats["all"]
    text += (
        f"Over all keypoints in view, the median pixel error ({al['px_native']:.1f} native px) amounts to "
        f"{al['lateral_mm']:.1f} mm across the line of sight, against {al['abs_dz_mm']:.1f} mm along it "
        f"(median signed depth error {al['dz_mm']:+.1f} mm). "
    )
    ml, mlw, pw = np.median(variants["ml"][:, 0]), variants["ml"][:, 0].max(), variants["pred"][:, 0].max()
    text += (
        f"Removing the offsets measured on the training frames and weighing each keypoint's pixels and depth "
        f"by its training sigma (the likelihood fit) gives {ml:.1f} mm median and {mlw:.1f} mm worst, against "
        f"{p:.1f} and {pw:.1f} mm for the 3-D to 3-D fit. "
    )
    jp, jz = int(np.nanargmax(stats["px_native"])), int(np.nanargmax(stats["abs_dz_mm"]))
    text += (
        f"The largest pixel error is at {names[jp]} ({stats['px_native'][jp]:.1f} px), the largest depth error "
        f"at {names[jz]} ({stats['abs_dz_mm'][jz]:.1f} mm)."
    )
    return text


def main(argv=None):
    """Command line: ``--data``, ``--model``, ``--split``, ``--out``."""
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--data", type=Path, required=True, help="dataset the model was trained on")
    ap.add_argument("--model", type=Path, required=True, help="keypoint model (keypoints.pt)")
    ap.add_argument("--split", default="test", help="frames to evaluate (default test)")
    ap.add_argument("--out", type=Path, help="also write the report here")
    args = ap.parse_args(argv)
    lines = []

    def emit(s=""):
        print(s, flush=True)
        lines.append(s)

    emit(f"# Keypoint model errors: pixels against depth ({args.model}, {args.data.name})")
    emit()
    emit(f"command: python benchmarks/keypoint_errors.py {' '.join(argv if argv is not None else sys.argv[1:])}")
    emit(f"machine: {machine()}")
    emit(f"date: {datetime.datetime.now(datetime.UTC):%Y-%m-%d %H:%M} UTC")
    emit()
    model = load_model(args.model)
    if model.config.kind != "keypoints":
        ap.error(f"{args.model}: a {model.config.kind} model, not a keypoint model")
    ds = Dataset.open(args.data)
    native = (int(ds.meta["intrinsics"]["width"]), int(ds.meta["intrinsics"]["height"]))
    network = tuple(int(v) for v in model.config.image_size)
    names = list(dataset_robot(ds).keypoint_names)
    frames = load_keypoint_frames(args.data, network, progress=False)
    index = np.flatnonzero(frames.split == args.split)
    pred, tgt = predicted_and_true(model, frames, index)
    if len(names) != pred.shape[1]:
        names = [f"keypoint {j}" for j in range(pred.shape[1])]
    stats = keypoint_stats(pred, tgt, frames.intrinsics_norm[index], native, network)
    n_cams = len(np.unique(frames.camera[index]))

    emit(
        f"## Per keypoint: {len(index)} {args.split} frames of {n_cams} placements, native {native[0]}x{native[1]}, "
        f"network input {network[0]}x{network[1]}"
    )
    emit()
    emit(
        "Medians over the frames where the keypoint's true position lies in the image; depth error is predicted "
        "minus true; lateral mm is the pixel error at the keypoint's true depth."
    )
    emit()
    emit("| keypoint | in view | px (native) | px (network) | lateral mm | depth mm (signed) | depth mm (abs) |")
    emit("|---|---|---|---|---|---|---|")
    for j, name in enumerate(names):
        emit(
            f"| {name} | {stats['in_view'][j]:.0%} | {stats['px_native'][j]:.2f} | {stats['px_network'][j]:.2f} | "
            f"{stats['lateral_mm'][j]:.1f} | {stats['dz_mm'][j]:+.1f} | {stats['abs_dz_mm'][j]:.1f} |"
        )
    al = stats["all"]
    emit(
        f"| all | {stats['in_view'].mean():.0%} | {al['px_native']:.2f} | {al['px_network']:.2f} | "
        f"{al['lateral_mm']:.1f} | {al['dz_mm']:+.1f} | {al['abs_dz_mm']:.1f} |"
    )
    emit()

    res_stats, source = residual_stats_of(model, frames)
    emit(f"## Residual statistics per keypoint, {source}")
    emit()
    emit("Offset (median of predicted minus target) and sigma (1.4826 MAD), native pixels and mm.")
    emit()
    emit("| keypoint | offset x px | offset y px | offset z mm | sigma x px | sigma y px | sigma z mm |")
    emit("|---|---|---|---|---|---|---|")
    scale = np.array([native[0], native[1], 1000.0])
    for j, name in enumerate(names):
        o, sg = res_stats[0, j] * scale, res_stats[1, j] * scale
        emit(f"| {name} | {o[0]:+.2f} | {o[1]:+.2f} | {o[2]:+.1f} | {sg[0]:.2f} | {sg[1]:.2f} | {sg[2]:.1f} |")
    emit()

    variants = {
        "pred": (pred, None),
        "true_px": (np.concatenate([tgt[..., :2], pred[..., 2:]], axis=-1), None),
        "true_z": (np.concatenate([pred[..., :2], tgt[..., 2:]], axis=-1), None),
        "ml": (pred, res_stats),
        # the true components with the offsets added back, which the likelihood fit then removes
        "ml_true_px": (np.concatenate([tgt[..., :2] + res_stats[0, :, :2], pred[..., 2:]], axis=-1), res_stats),
        "ml_true_z": (np.concatenate([pred[..., :2], tgt[..., 2:] + res_stats[0, :, 2:]], axis=-1), res_stats),
    }
    labels = {
        "pred": "predicted keypoints, 3-D to 3-D fit",
        "true_px": "true pixels + predicted depth, 3-D to 3-D fit",
        "true_z": "predicted pixels + true depth, 3-D to 3-D fit",
        "ml": "predicted keypoints, offsets removed, likelihood fit (the protocol's)",
        "ml_true_px": "true pixels + predicted depth, likelihood fit",
        "ml_true_z": "predicted pixels + true depth, likelihood fit",
    }
    errs = {k: placement_errors(v, frames, index, st) for k, (v, st) in variants.items()}
    emit(f"## Per placement: pose from all {args.split} frames of each of the {n_cams} placements")
    emit()
    emit("| keypoints | median mm | median deg | worst mm | worst deg |")
    emit("|---|---|---|---|---|")
    for k, e in errs.items():
        emit(
            f"| {labels[k]} | {np.median(e[:, 0]):.2f} | {np.median(e[:, 1]):.3f} | {e[:, 0].max():.2f} | "
            f"{e[:, 1].max():.3f} |"
        )
    emit()
    emit("## A 10 % sample of each placement's frames (the paper's novelty sample)")
    emit()
    emit(
        "The likelihood fit of a random tenth of each placement's frames (at least one), 5 draws per placement "
        "(seed 0), against all its frames: why selection's per-placement novelty fits all of a pose's frames "
        "(`learned.continual_step.sample_error`)."
    )
    emit()
    rng = np.random.default_rng(0)
    draws = []
    for _ in range(5):
        sub = np.concatenate(
            [
                rng.choice(idx, max(1, len(idx) // 10), replace=False)
                for idx in (np.flatnonzero(frames.camera[index] == c) for c in np.unique(frames.camera[index]))
            ]
        )
        draws.append(placement_errors(pred[sub], frames, index[sub], res_stats))
    sample = np.median(np.stack(draws), axis=0)  # per placement, the median over the draws
    emit("| frames per placement | median mm | median deg | worst mm | worst deg |")
    emit("|---|---|---|---|---|")
    for name, e in (("all", errs["ml"]), ("a 10 % sample (median of 5 draws)", sample)):
        emit(
            f"| {name} | {np.median(e[:, 0]):.2f} | {np.median(e[:, 1]):.3f} | {e[:, 0].max():.2f} | "
            f"{e[:, 1].max():.3f} |"
        )
    emit()
    emit("## The likelihood fit's error in the camera frame")
    emit()
    emit(
        "Per placement, the error of the fit's pose in the true camera frame (x right, y down, z along the "
        "optical axis), RMS over the placements; the part left once the translation that the rotation error "
        "makes, turning the camera about the robot (`-w x p_c`, `p_c` the keypoints' mean in the camera frame), is "
        "taken out; and the mean rotation error about each camera axis, a tilt the placements share. The "
        "training placements are fitted from the model's predictions on their own frames (the frames it was "
        "trained on)."
    )
    emit()
    emit(
        "| placements | n | RMS x / y / z mm | RMS along z / across mm | RMS mm | RMS left after -w x p_c mm | "
        "mean rotation error about x / y / z deg | median distance mm |"
    )
    emit("|---|---|---|---|---|---|---|---|")
    ce_test = camera_frame_errors(pred, frames, index, res_stats)
    emit(camera_frame_row(f"{args.split} ({args.split} frames)", ce_test))
    train = np.flatnonzero(frames.split == "train")
    if args.split != "train" and len(train):
        ce_train = camera_frame_errors(predicted_and_true(model, frames, train)[0], frames, train, res_stats)
        emit(camera_frame_row("train (training frames)", ce_train))
    emit()
    emit("## Interpretation")
    emit()
    emit(interpretation(errs, stats, names))
    e, rot = ce_test[:, 0:3], ce_test[:, 6:9]
    total, left = np.sqrt((e**2).sum(1).mean()), np.sqrt(((e - rot) ** 2).sum(1).mean())
    emit()
    emit(
        f"In the camera frame the likelihood fit's error is {np.sqrt((e[:, 2] ** 2).mean()):.1f} mm RMS along the "
        f"optical axis and {np.sqrt((e[:, 0] ** 2 + e[:, 1] ** 2).mean()):.1f} mm across it; taking out the "
        f"translation its rotation error makes about the robot leaves {left:.1f} of {total:.1f} mm RMS. Where the "
        "robot is in the camera's frame is known to a few millimetres; its orientation, read from the arm's "
        "shape at the camera's distance, carries the error."
    )
    if args.out:
        args.out.parent.mkdir(parents=True, exist_ok=True)
        args.out.write_text("\n".join(lines) + "\n")
        print(f"written: {args.out}")


if __name__ == "__main__":
    main()
