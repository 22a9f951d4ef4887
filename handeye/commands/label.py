"""``handeye label``: the classic calibration of every camera pose of a dataset, as its label.

Example
-------
::

    handeye label data/paper-sim
    handeye label /shared/dense-sim --engine ray --address auto

Per camera pose: ChArUco detection and PnP on the calibration recording,
eye-to-hand solve, corner-reprojection refinement. Writes the label, its
diagnostics and its error against the truth (when known) into
``cameras.csv``, a per-camera report ``labels.md`` and the plot
``label_errors.png``, and prints the summary.

Exits 2 when any camera placement's calibration fails (too few board views, poses in millimetres,
identical poses...): the failed placements and their reasons are printed, the other placements' labels
are still written. Waits up to two minutes, saying so, for another writer of the dataset (``handeye
markerless --write-labels``) before writing ``cameras.csv``.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from handeye.commands import command_parser
from handeye.core.engines import add_engine_arguments
from handeye.core.numbers import cli_int

__all__ = ["add_parser", "run"]


def add_parser(sub) -> argparse.ArgumentParser:
    """Register the command."""
    p = command_parser(sub, "label", "label a dataset: classic calibration per camera pose", __doc__)
    p.add_argument("dataset", type=Path, help="dataset directory")
    add_engine_arguments(p, "labelling")
    p.add_argument("--method", default="park", help="closed form of the pose-based solve (default park)")
    p.add_argument(
        "--repeats",
        type=cli_int,
        default=0,
        help="the seed paper's labels: the closed form alone, repeated this many times on 80 %% of the views and "
        "averaged ('--method tsai --repeats 5' is the paper's); default 0: this project's (closed form, maximum "
        "likelihood, corner reprojection)",
    )
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(run=run)
    return p


def run(args: argparse.Namespace) -> int:
    """Run the command."""
    from handeye.core.optional import require_package

    require_package("cv2", extra="vision", purpose="board detection")
    from handeye.labelling import LabelRunOptions, label_dataset

    report = label_dataset(
        args.dataset,
        workers=args.workers,
        method=args.method,
        progress=not args.quiet,
        repeats=args.repeats,
        options=LabelRunOptions(engine=args.engine, address=args.address),
    )
    if args.repeats:
        print(f"the seed paper's labels: {args.method}'s closed form, {args.repeats} repeats averaged, no sigma")
    print(report.summary())
    print(
        f"written: {report.root / 'cameras.csv'} (label columns), {report.root / 'labels.md'}, "
        f"{report.root / 'label_errors.png'} ({report.wall_s:.1f} s)"
    )
    failed = report.failed()
    if failed:
        import sys

        from handeye.core.limits import MAX_MESSAGE_CHARS, one_line

        n = len(report.table["camera_id"])
        ids = ", ".join(str(c) for c, _ in failed)
        head = f"handeye label: {len(failed)} of {n} camera placements failed, camera {ids} ("
        tail = (
            f"; see labels.md); the other {n - len(failed)} labels are written to {report.root / 'cameras.csv'}; "
            "fix those recordings and rerun"
        )
        reasons = "; ".join(f"{c}: {_short(why)}" for c, why in failed[:2])
        room = max(20, MAX_MESSAGE_CHARS - len(head) - len(tail))  # the path whole, the reasons cut to fit
        if len(reasons) > room:
            reasons = reasons[: room - 3] + "..."
        print(one_line(head + reasons + tail), file=sys.stderr)
        return 2
    return 0


def _short(status: str, limit: int = 40) -> str:
    """A failure's reason cut to its first clause, for the one-line summary."""
    text = status.removeprefix("failed: ")
    for stop in ("; ", ". ", ": "):
        text = text.split(stop)[0]
    return text if len(text) <= limit else text[: limit - 3] + "..."
