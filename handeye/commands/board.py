"""``handeye board``: a printable board (ChArUco, checkerboard or ArUco/AprilTag grid) and its spec.

Example
-------
::

    handeye board --squares 7x5 --square 0.04 --marker 0.03 --dict 5X5_100 --dpi 300 -o board.png
    handeye board --kind checkerboard --squares 10x7 --square 0.025 -o checker.png
    handeye board --kind aruco-grid --squares 5x4 --square 0.05 --marker 0.04 --dictionary APRILTAG_36h11 -o grid.png
    handeye board --legacy --squares 6x6 --square 0.04 --marker 0.03 -o legacy.png
    handeye board --kind asymmetric-circles --squares 4x11 --square 0.02 --marker 0.015 -o acircles.png

For ``aruco-grid``, ``--squares`` counts markers and ``--square`` is the marker pitch (marker plus gap).
A checkerboard needs one even and one odd square count (its corner order is otherwise ambiguous).
For ``circles`` and ``asymmetric-circles``, ``--squares`` is circles a row x rows, ``--square`` the
spacing (an asymmetric grid's row pitch; circles of a row are twice that apart) and ``--marker`` the
circle diameter; an asymmetric grid needs an odd number of rows, a symmetric one two different counts
(:mod:`classic.vision.circle_grid`).

writes ``board.png`` (print it at 100 % scale, at the given dpi) and
``board.json`` (the spec every other command reads). Measure a printed square
and edit ``square_length_m`` / ``marker_length_m`` in the JSON if the
printer scaled it.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from handeye.commands import command_parser
from handeye.core.numbers import cli_float

__all__ = ["add_parser", "run"]

INCH_M = 0.0254


def add_parser(sub) -> argparse.ArgumentParser:
    """Register the command."""
    p = command_parser(sub, "board", "write a printable ChArUco board (PNG) and its spec (JSON)", __doc__)
    p.add_argument(
        "--kind",
        default="charuco",
        choices=["charuco", "checkerboard", "aruco-grid", "circles", "asymmetric-circles"],
        help="board kind (default charuco)",
    )
    p.add_argument("--legacy", action="store_true", help="ChArUco: OpenCV's legacy pattern (setLegacyPattern)")
    p.add_argument("--squares", default="7x5", help="squares (aruco-grid: markers) along x and y, e.g. 7x5")
    p.add_argument("--square", type=cli_float, default=0.04, help="square side (aruco-grid: marker pitch) in metres")
    p.add_argument("--marker", type=cli_float, default=0.03, help="marker side in metres")
    p.add_argument(
        "--dict",
        "--dictionary",
        dest="dict",
        default=None,
        help="ArUco or AprilTag dictionary, e.g. 5X5_100, 4X4_50, APRILTAG_36h11 (default 5X5_100; "
        "APRILTAG_36h11 for aruco-grid)",
    )
    p.add_argument("--dpi", type=cli_float, default=300.0, help="printer resolution")
    p.add_argument("--margin", type=cli_float, default=0.01, help="white margin around the board, metres")
    p.add_argument("-o", "--output", type=Path, default=Path("board.png"), help="PNG path; the spec goes beside it")
    p.set_defaults(run=run)
    return p


def run(args: argparse.Namespace) -> int:
    """Run the command."""
    import cv2

    from classic.vision.board import BoardSpec, BoardSpecError
    from handeye.core.safe_write import check_output_path, write_bytes_atomic

    json_path = args.output.with_suffix(".json")
    if json_path == args.output:
        raise BoardSpecError(f"{args.output}: the spec is written beside the image as .json; name the image .png")
    for path in (args.output, json_path):  # both targets checked before anything is written
        check_output_path(path)
    try:
        sx, sy = (int(v) for v in args.squares.lower().split("x"))
    except ValueError:
        raise BoardSpecError(f"--squares {args.squares!r}: expected COLUMNSxROWS, e.g. 7x5") from None
    kind = args.kind.replace("-", "_")
    if kind == "checkerboard":
        spec = BoardSpec.checkerboard(sx, sy, args.square)
    elif kind in ("circles", "asymmetric_circles"):
        spec = BoardSpec.circle_grid(sx, sy, args.square, args.marker, asymmetric=kind == "asymmetric_circles")
    else:
        dictionary = args.dict or ("APRILTAG_36h11" if kind == "aruco_grid" else "5X5_100")
        spec = BoardSpec(sx, sy, args.square, args.marker, dictionary, kind=kind, legacy=bool(args.legacy))
    ppm = args.dpi / INCH_M
    image = spec.render(ppm, margin_px=int(round(args.margin * ppm)))
    try:  # encoded in memory: cv2.imwrite crashes on a file name that is not UTF-8
        ok, png = cv2.imencode(args.output.suffix or ".png", image)
    except cv2.error:
        ok = False
    if not ok:
        raise BoardSpecError(f"{args.output}: cannot encode an image with suffix {args.output.suffix!r}; use .png")
    write_bytes_atomic(args.output, png.tobytes())
    printed_square_m = spec.pixels_per_square(ppm) / ppm
    if abs(printed_square_m - spec.square_length_m) > 0.001 * spec.square_length_m:
        print(
            f"warning: at {args.dpi:g} dpi a square is {spec.pixels_per_square(ppm)} px = "
            f"{1000 * printed_square_m:.3f} mm, not {1000 * spec.square_length_m:.3f} mm; measure the print "
            "and correct square_length_m / marker_length_m in the JSON"
        )
    spec.save(json_path)
    w_m, h_m = spec.size_m
    what = f"{spec.kind}{' (legacy)' if spec.legacy else ''} board {sx}x{sy} squares of {1000 * args.square:.1f} mm"
    if spec.kind in ("circles", "asymmetric_circles"):
        what = f"{spec.kind.replace('_', ' ')[:-1]} grid {sx}x{sy} circles of {1000 * args.marker:.1f} mm, spacing "
        what += f"{1000 * args.square:.1f} mm"
    elif spec.kind != "checkerboard":
        what += f", markers {1000 * args.marker:.1f} mm, dictionary {spec.dictionary}"
    points = "circles" if "circles" in spec.kind else "corners"
    print(f"{what}: {1000 * w_m:.0f} x {1000 * h_m:.0f} mm, {spec.n_corners} {points}")
    print(f"  written: {args.output} ({image.shape[1]}x{image.shape[0]} px at {args.dpi:g} dpi; print at 100 %)")
    print(f"  written: {json_path}")
    return 0
