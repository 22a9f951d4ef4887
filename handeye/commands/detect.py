"""``handeye detect``: find the board in every image and estimate each view's pose.

Example
-------
::

    handeye detect images/ --board board.json [--intrinsics camera.json] -o detections.json

``--intrinsics`` also takes a ROS ``camera_info`` or an OpenCV FileStorage YAML
file (``.yaml``, ``.yml``; :mod:`classic.vision.camera_yaml`).

writes ``detections.json`` (corners, poses, reasons; what ``handeye
calibrate --detections`` reads) and ``detections.csv`` (one row per image:
corners found, RMS reprojection error in pixels, ``T_cam_target`` or the
reason the image was rejected). Without ``--intrinsics`` they are calibrated
from the same images first (see ``handeye intrinsics``) and written to
``camera.json`` beside the output.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from handeye.commands import command_parser

__all__ = ["add_parser", "run"]


def add_parser(sub) -> argparse.ArgumentParser:
    """Register the command."""
    p = command_parser(sub, "detect", "detect the board in a folder of images and estimate poses", __doc__)
    p.add_argument("images", type=Path, help="folder of PNG/JPEG images")
    p.add_argument("--board", type=Path, required=True, help="board spec written by 'handeye board'")
    p.add_argument(
        "--intrinsics",
        type=Path,
        help="camera.json, or a ROS camera_info / OpenCV FileStorage .yaml; calibrated from the images when omitted",
    )
    p.add_argument("-o", "--output", type=Path, default=Path("detections.json"))
    p.set_defaults(run=run)
    return p


def run(args: argparse.Namespace) -> int:
    """Run the command."""
    from classic.vision.board import BoardSpec
    from classic.vision.camera import CameraIntrinsics
    from classic.vision.views import detect_folder
    from handeye.core.safe_write import check_output_path

    # every target checked before the detection: a bad one is refused in one line, not after the work
    check_output_path(args.output)
    check_output_path(args.output.with_suffix(".csv"))
    if not args.intrinsics:
        check_output_path(args.output.parent / "camera.json")
    spec = BoardSpec.load(args.board)
    intr = CameraIntrinsics.load(args.intrinsics) if args.intrinsics else None
    views, calibrated = detect_folder(args.images, spec, intr)
    if calibrated is not None:
        cam_path = args.output.parent / "camera.json"
        calibrated.intrinsics.save(cam_path)
        print(calibrated.summary())
        print(f"  written: {cam_path}")
    width = max(len(v.image) for v in views.views)
    for v in views.views:
        if v.pose.ok:
            t = v.pose.T_cam_target[:3, 3]
            print(
                f"  {v.image:<{width}}  {len(v.detection.ids):3d} corners  {v.pose.rms_px:6.3f} px  "
                f"t = [{t[0]:+.4f}, {t[1]:+.4f}, {t[2]:+.4f}] m"
            )
        else:
            print(f"  {v.image:<{width}}  rejected: {v.pose.reason}")
    csv_path = views.save(args.output)
    print(f"{len(views.accepted)} of {len(views.views)} images accepted")
    print(f"  written: {args.output}, {csv_path}")
    if not views.accepted:
        from handeye.core.errors import HandEyeInputError

        reasons = sorted({v.pose.reason for v in views.views})
        raise HandEyeInputError(
            f"{args.board}: no image of {args.images} gave a board pose with this spec ({reasons[0][:100]}"
            f"{f'; {len(reasons) - 1} other reasons' if len(reasons) > 1 else ''}); check its dictionary and square "
            "counts"
        )
    return 0
