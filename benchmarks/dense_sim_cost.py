"""Cost of the ``dense-sim`` preset: render some of its shards, time and weigh them, extrapolate to all 1,000.

Run from the repository root::

    python benchmarks/dense_sim_cost.py 8 --out benchmarks/results/dense_sim_cost.md   # the saved figures
    python benchmarks/dense_sim_cost.py 4                                              # a quick look

Renders ``N`` shards (one camera pose each: 15 calibration views at 640x640, 50 data frames at 256x256 with
depth) with :class:`sim.generate.ShardRenderer`, exactly as ``handeye sim generate`` does, in this one
process, into a temporary folder. The cameras are spread over the preset's elevations (lowest to highest) and
its scenes (the ``i``-th camera from scene ``i % scenes``). Per shard: wall seconds, CPU seconds of this
process (all its threads: Mesa's llvmpipe renders on several), frames and bytes on disk; then the means
extrapolated to the whole preset: CPU-hours, wall-hours on one process, and disk.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
os.environ.setdefault("PYOPENGL_PLATFORM", "egl")

from benchmarks._report import Report  # noqa: E402
from handeye.core.dataset import shard_name  # noqa: E402
from sim.cameras import get_preset, place_cameras  # noqa: E402
from sim.generate import DEFAULT_NOISE, NoiseModel, ShardRenderer, dataset_meta  # noqa: E402
from sim.lab import camera_scene  # noqa: E402


def folder_bytes(path: Path) -> int:
    """Bytes of the files under ``path``."""
    return sum(p.stat().st_size for p in path.rglob("*") if p.is_file())


def spread_cameras(cams, scenes: int, n: int) -> list:
    """``n`` camera ids spread over the elevations and the scenes: the ``i``-th from scene ``i % scenes``, at the
    ``i / (n - 1)`` quantile of that scene's elevations."""
    scene = camera_scene(np.arange(len(cams)), scenes)
    ids = []
    for i in range(n):
        in_scene = np.flatnonzero(scene == i % scenes)
        by_elevation = in_scene[np.argsort(cams.elevation_deg[in_scene])]
        ids.append(int(by_elevation[round(i / max(n - 1, 1) * (len(by_elevation) - 1))]))
    return list(dict.fromkeys(ids))


def versions() -> str:
    """numpy, pyrender and PyOpenGL versions."""
    import OpenGL
    import pyrender

    return f"numpy {np.__version__}, pyrender {pyrender.__version__}, PyOpenGL {OpenGL.__version__}"


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("shards", type=int, help="shards to render (e.g. 8)")
    parser.add_argument("--preset", default="dense-sim")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--noise", choices=["none", "default"], default="none", help="sensor noise (default none)")
    parser.add_argument("--out", default=None, help="write the report to this file")
    args = parser.parse_args(argv)
    preset = get_preset(args.preset)
    noise = NoiseModel() if args.noise == "none" else DEFAULT_NOISE
    report = Report(
        f"Cost of the {preset.name} preset, from {args.shards} shards", "benchmarks/dense_sim_cost.py", argv, versions()
    )
    meta = dataset_meta(preset, args.seed, noise, ("calibration", "data"))
    ids = spread_cameras(place_cameras(preset, np.random.default_rng(args.seed)), preset.scenes, args.shards)
    report.say(
        f"preset {preset.name}: {preset.n_cameras} camera poses, {preset.scenes} scenes; per shard "
        f"{preset.calibration_views} calibration views at {preset.calibration_image_size[0]}x"
        f"{preset.calibration_image_size[1]} and {preset.configurations} data frames (RGB PNG + 16-bit depth PNG) at "
        f"{preset.image_size[0]}x{preset.image_size[1]}; noise {args.noise}; one process, shards in turn"
    )
    report.say(f"load average at the start (1, 5, 15 min): {', '.join(f'{v:.1f}' for v in os.getloadavg())}")
    report.say()
    work = Path(tempfile.mkdtemp(prefix="dense_sim_cost_"))
    try:
        (work / "meta.json").write_text(json.dumps(meta))
        t0, c0 = time.perf_counter(), time.process_time()
        worker = ShardRenderer(meta)
        init_wall, init_cpu = time.perf_counter() - t0, time.process_time() - c0
        report.say(
            f"worker start (robot, two renderers, camera placement): {init_wall:.1f} s wall, {init_cpu:.1f} s CPU"
        )
        report.say()
        report.say("| camera | region | scene | elevation deg | distance m | frames | wall s | CPU s | MB |")
        report.say("|---|---|---|---|---|---|---|---|---|")
        rows = []
        for c in ids:
            t0, c0 = time.perf_counter(), time.process_time()
            frames = worker.render_shard(int(c), work)
            wall, cpu = time.perf_counter() - t0, time.process_time() - c0
            size = folder_bytes(work / shard_name(int(c)))
            rows.append((wall, cpu, size, frames))
            cams = worker.cams
            report.say(
                f"| {c} | {cams.region[c]} | {camera_scene(int(c), preset.scenes)} | {cams.elevation_deg[c]:.1f} | "
                f"{cams.radius_m[c]:.2f} | {frames} | {wall:.2f} | {cpu:.2f} | {size / 1e6:.2f} |"
            )
    finally:
        shutil.rmtree(work, ignore_errors=True)
    wall, cpu, size, frames = (np.array(v, dtype=float) for v in zip(*rows))
    n = preset.n_cameras
    report.say()
    report.say(
        f"load average at the end: {', '.join(f'{v:.1f}' for v in os.getloadavg())} (wall seconds grow with other "
        f"work on the machine; CPU seconds much less)"
    )
    report.say(
        f"per shard, mean of {len(rows)} (min-max): {wall.mean():.2f} s wall ({wall.min():.2f}-{wall.max():.2f}), "
        f"{cpu.mean():.2f} s CPU ({cpu.min():.2f}-{cpu.max():.2f}), {size.mean() / 1e6:.2f} MB "
        f"({size.min() / 1e6:.2f}-{size.max() / 1e6:.2f}), {frames.mean():.0f} frames"
    )
    report.say(
        f"extrapolated to all {n} shards: {cpu.mean() * n / 3600:.2f} CPU-hours, {wall.mean() * n / 3600:.2f} h wall "
        f"on one process (divide by the worker processes, up to the cores), {size.mean() * n / 1e9:.2f} GB on disk, "
        f"{frames.mean() * n:.0f} frames"
    )
    return report.write(args.out)


if __name__ == "__main__":
    sys.exit(main())
