"""Render the documentation's pictures: a simulated cell (``docs/img/cell.png``), its frames
(``docs/img/frames.png``) and the benchmark pages' figures drawn from the results files (``docs/figures/``).

Run from the repository root (needs ``pip install -e ".[sim]"``; about a minute on two cores)::

    PYOPENGL_PLATFORM=egl python docs/make_figures.py
    python docs/make_figures.py --results    # only the benchmark figures, from benchmarks/results/ (seconds)

It generates the ``small`` preset's first camera placement with the default sensor noise into a temporary
folder, and draws one calibration view (the ChArUco board on the flange), one data view and its depth, and
the frames of the shipped example pose file's calibration in the robot base.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from figures import draw_all  # noqa: E402

OUT = Path(__file__).resolve().parent / "img"
CAMERA = 0
EXAMPLE = Path(__file__).resolve().parents[1] / "handeye" / "data" / "example_eye_to_hand.csv"


def cell_figure(ds, path: Path) -> Path:
    """One calibration view, one data view and its depth of camera ``CAMERA``, side by side."""
    calib = ds.select(CAMERA, "calibration")
    data = ds.select(CAMERA, "data")
    rgb_calib = ds.rgb(CAMERA, calib["rgb"][0])
    rgb_data = ds.rgb(CAMERA, data["rgb"][0])
    depth = ds.depth_m(CAMERA, data["depth"][0])
    fig, axes = plt.subplots(1, 3, figsize=(10.5, 3.7), dpi=100)
    axes[0].imshow(rgb_calib)
    axes[0].set_title("calibration view: board on the flange", fontsize=10)
    axes[1].imshow(rgb_data)
    axes[1].set_title("data view: RGB", fontsize=10)
    shown = np.where(depth > 0, depth, np.nan)
    im = axes[2].imshow(shown, cmap="viridis")
    axes[2].set_title("data view: depth", fontsize=10)
    fig.colorbar(im, ax=axes[2], fraction=0.046, pad=0.04, label="m")
    for ax in axes:
        ax.set_axis_off()
    fig.tight_layout()
    from handeye.core.safe_write import write_figure_atomic

    write_figure_atomic(fig, path)
    plt.close(fig)
    return path


def frames_of_example(path: Path) -> Path:
    """The frames of the shipped example's calibration (``handeye/data/example_eye_to_hand.csv``)."""
    import classic
    from handeye.core.posefile import read_pose_file
    from handeye.report.frames3d import frames_figure

    poses = read_pose_file(EXAMPLE)
    res = classic.calibrate(poses.T_base_ee, poses.T_cam_target, setup="eye_to_hand")
    return frames_figure(path, "eye_to_hand", res.T_base_cam, res.T_ee_target, poses.T_base_ee)


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--results", action="store_true", help="only the figures drawn from benchmarks/results/")
    ap.add_argument("--out", type=Path, default=OUT, help="folder of the images (default docs/img)")
    args = ap.parse_args(argv)
    for fig in draw_all(args.out):
        print(fig.path)
    if args.results:
        return
    from handeye.core.dataset import Dataset
    from handeye.core.engine_protocol import EngineOptions
    from sim.generate import DEFAULT_NOISE, Recipe, generate

    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp) / "small"
        generate(root, Recipe("small", seed=0, noise=DEFAULT_NOISE), [CAMERA], EngineOptions(workers=1, progress=False))
        ds = Dataset.open(root)
        print(cell_figure(ds, args.out / "cell.png"))
    print(frames_of_example(args.out / "frames.png"))


if __name__ == "__main__":
    main()
