"""``handeye compare``: per test camera pose, the learned calibration against the classic label and the truth.

Example
-------
::

    handeye compare data/paper-sim --model runs/sim/reservoir
    handeye compare data/my-cell --split all        # no model: the board's label against the markerless one

``--model`` is a directory with ``translation.pt`` and ``orientation.pt`` (as
``handeye learned run`` writes per strategy), or with ``keypoints.pt`` (``--family
keypoints``). The learned ``T_base_cam`` of a camera pose is its frames'
predictions averaged, or for the keypoint model one fit of all its frames'
keypoints. The hybrid column is the
markerless registration of the robot's surface to the pose's depth frames,
started from that learned prediction (``handeye markerless``); ``--no-hybrid``
leaves it out.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from handeye.commands import command_parser

__all__ = ["add_parser", "run", "compare_table"]


def add_parser(sub) -> argparse.ArgumentParser:
    """Register the command."""
    p = command_parser(sub, "compare", "learned vs classic label vs truth, per test camera pose", __doc__)
    p.add_argument("dataset", type=Path)
    p.add_argument(
        "--model",
        type=Path,
        help="directory with translation.pt and orientation.pt (or keypoints.pt); without it, the board's label "
        "against the markerless label (a real cell: 'handeye label', then 'handeye markerless --write-labels')",
    )
    p.add_argument("--split", default="test", choices=("test", "train", "all"))
    p.add_argument("--no-hybrid", action="store_true", help="leave out the markerless hybrid column")
    p.set_defaults(run=run)
    return p


def compare_table(pc: dict, hybrid=None) -> str:
    """Markdown table of :func:`learned.experiment.camera_predictions` output.

    With ``hybrid`` (a :class:`handeye.markerless.MarkerlessRun` of the same cameras), a column of the
    learned start refined on the robot's surface, against the truth.
    """
    from handeye.core.tables import markdown_table

    headers = ["camera", "subset", "learned vs classic (mm / deg)", "learned vs truth"]
    headers += ["hybrid vs truth"] if hybrid is not None else []
    rows = []
    for i, c in enumerate(pc["camera"]):
        row = [
            c,
            f"S{pc['region'][i] + 1}",
            f"{pc['learned_vs_label_mm'][i]:.2f} / {pc['learned_vs_label_deg'][i]:.2f}",
            f"{pc['learned_vs_truth_mm'][i]:.2f} / {pc['learned_vs_truth_deg'][i]:.2f}",
        ]
        if hybrid is not None:
            res, err = hybrid.results.get(c), hybrid.errors.get(c)
            row.append(
                f"{err[1]:.3f} / {err[0]:.4f}"
                if err
                else f"refused ({res.refused.split(':')[0]})"
                if res is not None and not res.ok
                else "-"
            )
        rows.append(row + [f"{pc['label_vs_truth_mm'][i]:.3f} / {pc['label_vs_truth_deg'][i]:.4f}"])
    return "\n".join(markdown_table(headers + ["classic vs truth"], rows))


def keypoint_solve_table(model, frames, cameras: list[int]) -> str:
    """Per camera, the classic cross-frame keypoint solve (:func:`classic.keypoint_pose.solve_keypoint_pose`):
    its pose against the truth, its sigma, the keypoints that agree, or its refusal.

    The keypoints' offsets measured on the model's training frames
    (:func:`learned.keypoints.residual_stats`) are removed first and, with the sigmas measured there, the
    pose is the maximum-likelihood fit of the agreeing keypoints' image positions and depths, as in the
    learned placement fit; a model without them is fitted 3-D to 3-D.
    """
    import numpy as np

    from classic.keypoint_pose import KeypointPoseOptions, solve_keypoint_pose
    from handeye.core.metrics import pose_error
    from handeye.core.se3 import transform_from_pos_quat_xyzw
    from handeye.core.tables import markdown_table
    from learned.keypoints import CONSENSUS_M, backproject_keypoints, model_residual_stats, remove_offsets
    from learned.trainer import predict

    stats = model_residual_stats(model)
    rows = []
    for c in cameras:
        idx = np.flatnonzero(frames.camera == c)
        pred, usable = remove_offsets(predict(model, frames, idx), stats)
        p_cam = backproject_keypoints(pred, frames.intrinsics_norm[idx]).reshape(-1, 3)
        k = pred.shape[1]
        measured = (
            {
                "meas": pred.reshape(-1, 3),
                "intrinsics_norm": np.repeat(frames.intrinsics_norm[idx].astype(float), k, axis=0),
                "sigma": np.broadcast_to(stats[1], pred.shape).reshape(-1, 3),
            }
            if usable
            else {}
        )
        res = solve_keypoint_pose(
            p_cam,
            frames.keypoints_base[idx].reshape(-1, 3),
            np.repeat(np.arange(len(idx)), k),
            **measured,
            options=KeypointPoseOptions(inlier_m=CONSENSUS_M),
        )
        if not res.ok:
            rows.append([c, f"refused: {res.refused}", "-", "-"])
            continue
        truth = transform_from_pos_quat_xyzw(
            frames.truth_t_base_cam_mm[idx[0]] / 1000.0, frames.truth_q_base_cam_xyzw[idx[0]]
        )
        deg, mm = pose_error(res.T_base_cam, truth)
        rows.append(
            [
                c,
                f"{mm:.1f} / {deg:.2f}",
                f"{res.sigma['translation_mm']:.1f} / {res.sigma['rotation_deg']:.2f}",
                f"{int(res.inliers.sum())} of {len(res.inliers)}",
            ]
        )
    return "\n".join(
        markdown_table(["camera", "keypoint solve vs truth (mm / deg)", "sigma (mm / deg)", "keypoints agreeing"], rows)
    )


def run(args: argparse.Namespace) -> int:
    """Run the command."""
    import numpy as np

    from handeye.core.optional import require_package

    if args.model is None:
        from handeye.core.dataset import Dataset
        from handeye.label_agreement import agreement_table

        print(agreement_table(Dataset.open(args.dataset), args.split))
        return 0
    require_package("torch", extra="learned", purpose="the learned calibration")
    from learned.data import load_frames
    from learned.experiment import camera_predictions, keypoint_camera_predictions, load_model

    if (args.model / "keypoints.pt").is_file():  # the equivariant keypoint model
        require_package("pinocchio", extra="robot", purpose="the arm's keypoints from its kinematics")
        from handeye.learned_frames import load_keypoint_frames

        model = load_model(args.model / "keypoints.pt")
        frames = load_keypoint_frames(args.dataset, model.config.image_size, "classic", progress=False)
        cams = frames.cameras(None if args.split == "all" else args.split)
        pc = keypoint_camera_predictions(model, frames, [int(c) for c in cams])
        print(keypoint_solve_table(model, frames, [int(c) for c in cams]))
    else:
        t_model = load_model(args.model / "translation.pt")
        q_model = load_model(args.model / "orientation.pt")
        if t_model.config.image_size != q_model.config.image_size:
            from handeye.core.errors import HandEyeInputError

            raise HandEyeInputError(f"{args.model}: the two networks take different image sizes")
        frames = load_frames(args.dataset, t_model.config.image_size, "classic", progress=False)
        cams = frames.cameras(None if args.split == "all" else args.split)
        pc = camera_predictions(t_model, q_model, frames, [int(c) for c in cams])
    hybrid, note = None, None
    if not args.no_hybrid:
        require_package("pinocchio", extra="robot", purpose="the robot model of the hybrid column")
        from classic.markerless import MarkerlessOptions
        from classic.markerless.shared_intrinsics import MIN_OTHERS, first_pass_options
        from handeye.markerless import markerless_dataset
        from handeye.markerless_shared import share_intrinsics, shared_note, shared_options

        # as handeye markerless does: with 4+ placements, each again with the others' intrinsics as its prior
        opts = shared_options(MarkerlessOptions(), len(pc["camera"]))
        first_opts = first_pass_options(opts) if len(pc["camera"]) > MIN_OTHERS else opts
        first = markerless_dataset(args.dataset, pc["camera"], model_dir=args.model, options=first_opts)
        hybrid = share_intrinsics(args.dataset, first, options=opts)
        note = shared_note(hybrid, opts.pixel_effect_px)
    print(compare_table(pc, hybrid))
    if note:
        print(note)
    for key in ("learned_vs_label", "learned_vs_truth", "label_vs_truth"):
        print(
            f"median {key.replace('_', ' ')}: {np.median(pc[key + '_mm']):.2f} mm, "
            f"{np.median(pc[key + '_deg']):.3f} deg"
        )
    if hybrid is not None and hybrid.errors:
        e = np.array(list(hybrid.errors.values()))
        print(
            f"median hybrid vs truth: {np.median(e[:, 1]):.3f} mm, {np.median(e[:, 0]):.4f} deg "
            f"({len(hybrid.errors)} of {len(hybrid.results)} accepted)"
        )
    return 0
