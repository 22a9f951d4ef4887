"""``handeye compare``: per test camera pose, the learned calibration against the classic label and the truth.

Example
-------
::

    handeye compare data/paper-sim --model runs/sim/reservoir

``--model`` is a directory with ``translation.pt`` and ``orientation.pt`` (as
``handeye learned run`` writes per strategy). The learned ``T_base_cam`` of a
camera pose is its frames' predictions averaged.
"""

from __future__ import annotations

import argparse
from pathlib import Path

__all__ = ["add_parser", "run", "compare_table"]


def add_parser(sub) -> argparse.ArgumentParser:
    """Register the command."""
    p = sub.add_parser("compare", help="learned vs classic label vs truth, per test camera pose",
                       description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("dataset", type=Path)
    p.add_argument("--model", type=Path, required=True, help="directory with translation.pt and orientation.pt")
    p.add_argument("--split", default="test", choices=("test", "train", "all"))
    p.set_defaults(run=run)
    return p


def compare_table(pc: dict) -> str:
    """Markdown table of :func:`learned.experiment.camera_predictions` output."""
    lines = ["| camera | subset | learned vs classic (mm / deg) | learned vs truth | classic vs truth |",
             "|---|---|---|---|---|"]
    for i, c in enumerate(pc["camera"]):
        lines.append(f"| {c} | S{pc['region'][i] + 1} | {pc['learned_vs_label_mm'][i]:.2f} / "
                     f"{pc['learned_vs_label_deg'][i]:.2f} | {pc['learned_vs_truth_mm'][i]:.2f} / "
                     f"{pc['learned_vs_truth_deg'][i]:.2f} | {pc['label_vs_truth_mm'][i]:.3f} / "
                     f"{pc['label_vs_truth_deg'][i]:.4f} |")
    return "\n".join(lines)


def run(args: argparse.Namespace) -> int:
    """Run the command."""
    import numpy as np

    from handeye.core.optional import require_package

    require_package("torch", extra="learned", purpose="the learned calibration")
    from learned.data import load_frames
    from learned.experiment import camera_predictions, load_model

    t_model = load_model(args.model / "translation.pt")
    q_model = load_model(args.model / "orientation.pt")
    if t_model.config.image_size != q_model.config.image_size:
        from handeye.core.errors import HandEyeInputError

        raise HandEyeInputError(f"{args.model}: the two networks take different image sizes")
    frames = load_frames(args.dataset, t_model.config.image_size, "classic", progress=False)
    cams = frames.cameras(None if args.split == "all" else args.split)
    pc = camera_predictions(t_model, q_model, frames, [int(c) for c in cams])
    print(compare_table(pc))
    for key in ("learned_vs_label", "learned_vs_truth", "label_vs_truth"):
        print(f"median {key.replace('_', ' ')}: {np.median(pc[key + '_mm']):.2f} mm, "
              f"{np.median(pc[key + '_deg']):.3f} deg")
    return 0
