"""``handeye intrinsics``: calibrate the camera (K and distortion) from board images.

Example
-------
::

    handeye intrinsics images/ --board board.json -o camera.json

prints the RMS reprojection error and the one-sigma of fx, fy, cx, cy, so a
person can judge the calibration: below 0.5 px RMS and sigmas of a pixel or
two are typical of a good one. The one-sigma of every parameter is written into the file
(``std``): ``handeye detect`` carries it into detections.json, and ``handeye calibrate --detections``
refines the intrinsics with it as their prior, so that the hand-eye sigma counts their error.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from handeye.commands import command_parser

__all__ = ["add_parser", "run"]


def add_parser(sub) -> argparse.ArgumentParser:
    """Register the command."""
    p = command_parser(sub, "intrinsics", "calibrate camera intrinsics from board images", __doc__)
    p.add_argument("images", type=Path, help="folder of PNG/JPEG images")
    p.add_argument("--board", type=Path, required=True, help="board spec written by 'handeye board'")
    p.add_argument(
        "-o",
        "--output",
        type=Path,
        default=Path("camera.json"),
        help="camera.json (default); a .yaml/.yml name writes OpenCV FileStorage YAML",
    )
    p.set_defaults(run=run)
    return p


def run(args: argparse.Namespace) -> int:
    """Run the command."""
    from classic.vision.board import BoardSpec
    from classic.vision.detect import detect_board
    from classic.vision.images import list_images, read_image
    from classic.vision.intrinsics import calibrate_intrinsics
    from handeye.core.errors import HandEyeInputError
    from handeye.core.safe_write import check_output_path

    check_output_path(args.output)  # refused before the calibration, not after it
    spec = BoardSpec.load(args.board)
    files = list_images(args.images)
    detections = [detect_board(read_image(f), spec) for f in files]
    try:
        res = calibrate_intrinsics(detections, spec)
    except HandEyeInputError as exc:
        raise HandEyeInputError(f"{args.images} with board {args.board}: {exc}") from None
    print(res.summary())
    for k, rms in zip(res.used, res.per_view_rms_px):
        print(f"  {files[k].name}: {rms:.3f} px")
    skipped = sorted(set(range(len(files))) - set(res.used))
    for k in skipped:
        print(f"  {files[k].name}: not used ({detections[k].reason or 'too few or collinear corners'})")
    res.intrinsics.save(args.output)
    print(f"  written: {args.output} (with their one-sigma: the prior 'handeye calibrate --detections' takes)")
    return 0
