"""Benchmark: render the ``paper-sim`` preset on this machine, label it, and see how labels degrade with noise.

Run from the repository root::

    python benchmarks/sim_generation.py                      # the README's figures (about 25 minutes)
    python benchmarks/sim_generation.py --preset small       # a quick look

1. Generation: the whole preset (data and calibration recordings) into
   ``--out`` with ``--workers`` processes; wall time, frames per second and
   the peak resident memory of this process and all its children together
   (sampled every 0.2 s). The output directory is emptied first.
2. Labelling: ``handeye label`` on it; the label error against truth, median
   and worst camera pose.
3. Noise: calibration recordings only, rendered again with each noise setting
   (the data recording does not enter the labels), labelled, same table. Depth
   noise does not enter the labels either (they come from colour images).

Targets (issue 4): generation at most 10 minutes and under 4 GB; noiseless
labels with median error at most 1 mm and 0.1 deg, worst at most 3 mm and 0.3 deg.
"""

from __future__ import annotations

import argparse
import datetime
import os
import shutil
import sys
import threading
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

from benchmarks._machine import machine  # noqa: E402
from handeye.core.engine_protocol import EngineOptions  # noqa: E402
from handeye.labelling import label_dataset  # noqa: E402
from sim.cameras import get_preset  # noqa: E402
from sim.generate import DEFAULT_NOISE, NoiseModel, Recipe, generate  # noqa: E402


class PeakMemory:
    """Peak summed RSS of this process and its descendants, sampled in a thread (Linux /proc)."""

    def __init__(self, interval_s: float = 0.2):
        self.interval_s = interval_s
        self.peak_bytes = 0
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)

    @staticmethod
    def _tree_rss() -> int:
        parents = {}
        for pid in os.listdir("/proc"):
            if pid.isdigit():
                try:
                    with open(f"/proc/{pid}/stat") as f:
                        parents[int(pid)] = int(f.read().rsplit(")", 1)[1].split()[1])
                except (OSError, IndexError, ValueError):
                    pass
        tree, frontier = {os.getpid()}, [os.getpid()]
        while frontier:
            p = frontier.pop()
            for child, parent in parents.items():
                if parent == p and child not in tree:
                    tree.add(child)
                    frontier.append(child)
        total = 0
        for pid in tree:
            try:
                with open(f"/proc/{pid}/status") as f:
                    total += next(int(line.split()[1]) * 1024 for line in f if line.startswith("VmRSS:"))
            except (OSError, StopIteration):
                pass
        return total

    def _run(self):
        while not self._stop.is_set():
            self.peak_bytes = max(self.peak_bytes, self._tree_rss())
            time.sleep(self.interval_s)

    def __enter__(self):
        self._thread.start()
        return self

    def __exit__(self, *exc):
        self._stop.set()
        self._thread.join()


def label_row(name: str, table: dict) -> str:
    ok = np.array([s == "ok" for s in table["label_status"]])
    rot, trans = table["label_error_rot_deg"][ok], table["label_error_trans_mm"][ok]
    return (
        f"| {name} | {ok.sum()}/{len(ok)} | {np.median(rot):.4f} | {np.median(trans):.3f} | {np.max(rot):.4f} | "
        f"{np.max(trans):.3f} | {np.median(table['label_rms_px'][ok]):.3f} |"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--preset", default="paper-sim")
    parser.add_argument("--out", type=Path, default=Path("data/bench"))
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--no-noise-table", action="store_true")
    args = parser.parse_args()
    preset = get_preset(args.preset)
    lines = [
        f"# Simulator benchmark: `python benchmarks/sim_generation.py --preset {args.preset}`",
        "",
        f"{datetime.date.today()}, {machine()}, {args.workers} worker processes",
        "",
    ]

    out = args.out / args.preset
    shutil.rmtree(out, ignore_errors=True)
    with PeakMemory() as mem:
        report = generate(out, Recipe(preset, seed=0), options=EngineOptions(workers=args.workers))
    n_data = preset.n_cameras * preset.configurations
    n_cal = report.frames - n_data
    lines += [
        "## Generation",
        "",
        "| camera poses | data frames | calibration frames | wall time | frames/s | peak memory (all processes) |",
        "|---|---|---|---|---|---|",
        f"| {preset.n_cameras} | {n_data} at {preset.image_size[0]}x{preset.image_size[1]} | {n_cal} at "
        f"{preset.calibration_image_size[0]}x{preset.calibration_image_size[1]} | {report.wall_s:.0f} s "
        f"({report.wall_s / 60:.1f} min) | {report.frames / report.wall_s:.1f} | "
        f"{mem.peak_bytes / 2**30:.2f} GiB |",
        "",
    ]
    print("\n".join(lines), flush=True)

    labels = label_dataset(out, workers=args.workers, progress=True)
    header = [
        "| noise (pixel grey levels, joint deg) | labelled | median deg | median mm | worst deg | worst mm | "
        "median RMS px |",
        "|---|---|---|---|---|---|---|",
    ]
    rows = [label_row("none", labels.table)]
    section = ["## Labels against truth", "", f"Labelling took {labels.wall_s:.0f} s.", ""] + header + rows
    print("\n".join(section), flush=True)
    if not args.no_noise_table:
        settings = [
            ("pixel 2", NoiseModel(pixel_sigma=2.0)),
            ("joints 0.01 deg", NoiseModel(joint_sigma_deg=0.01)),
            ("default: pixel 2, depth 1 mm at 1 m, joints 0.01 deg", DEFAULT_NOISE),
            ("2x default", NoiseModel(4.0, 0.002, 0.02)),
        ]
        for name, noise in settings:
            noisy = args.out / f"{args.preset}-noise"
            shutil.rmtree(noisy, ignore_errors=True)
            generate(noisy, Recipe(preset, 0, noise, ("calibration",)), options=EngineOptions(workers=args.workers))
            rows.append(label_row(name, label_dataset(noisy, workers=args.workers).table))
            print(rows[-1], flush=True)
            shutil.rmtree(noisy, ignore_errors=True)
    lines += (
        [
            "## Labels against truth (calibration recordings; noisy rows rendered again with that noise)",
            "",
            f"Labelling the noiseless dataset took {labels.wall_s:.0f} s.",
            "",
        ]
        + header
        + rows
    )
    text = "\n".join(lines) + "\n"
    print(text)
    results = Path(__file__).parent / "results" / f"sim_generation_{args.preset}.md"
    results.write_text(text)
    print(f"written: {results}")


if __name__ == "__main__":
    main()
