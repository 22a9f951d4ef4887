"""``handeye show``: a contact sheet of one camera pose of a dataset.

Example
-------
::

    handeye show data/paper-sim --camera 17 -o cam17.png

Top row: data frames (colour, and the depth of the first). Bottom row:
calibration views with the detected ChArUco corners (green) and the corners
projected through the label (red); the title gives the label against the truth.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from handeye.commands import command_parser
from handeye.core.numbers import cli_int

__all__ = ["add_parser", "run"]


def add_parser(sub) -> argparse.ArgumentParser:
    """Register the command."""
    p = command_parser(sub, "show", "contact sheet of a camera pose: views, detections, label vs truth", __doc__)
    p.add_argument("dataset", type=Path, help="dataset directory")
    p.add_argument("--camera", type=cli_int, required=True, help="camera id")
    p.add_argument("-o", "--output", type=Path, default=None, help="PNG path (default cam<N>.png)")
    p.set_defaults(run=run)
    return p


def run(args: argparse.Namespace) -> int:
    """Run the command."""
    from handeye.contact_sheet import contact_sheet
    from handeye.core.safe_write import check_output_path

    out = args.output or Path(f"cam{args.camera}.png")
    check_output_path(out)  # refused before the images are read
    text = contact_sheet(args.dataset, args.camera, out)
    print(text)
    print(f"written: {out}")
    return 0
