"""The running cell's per-frame check (issue 43) at 256x256 and at a D435's native 848x480: CPU time and what
the statistic says.

Each size gets a short simulated stream of the arm moving between its work configurations (:mod:`sim.stream`,
a preset with no events: the true camera, the sensor's noise; rendered into ``--data`` unless there): 256x256
over 60 degrees (the running-cell benchmark's frames) and 848x480 over 87 degrees horizontal (a D435's depth
stream). On each frame, ``--repeats`` times, what :meth:`handeye.watch.CellWatcher.feed` does per frame before
it decides anything: the surface posed at the frame's joints and :func:`handeye.watch.check.check_frame`, timed
with ``time.process_time`` (run it on one core, numpy on one thread: the command below). Two settings per size:

- ``as given``: the z-buffer stride :func:`handeye.markerless.robot_surface_for` samples the surface for (as
  ``handeye watch`` passes it), the whole surface posed (``CheckOptions.reference_focal_px`` 0: the check before
  it chose its work by the camera);
- ``by focal``: the check's defaults, the stride times ``CheckOptions.factor_for(K)`` and the surface thinned by
  its square, as the watcher poses it.

The statistic's columns: matched points, the step's 1-sigma (rotation, translation), the raw statistic
``delta^T Sigma^-1 delta`` at the truth (its median), the null's scale ``c`` fitted on the frames
(:func:`handeye.watch.change.fit_null`), and the median statistic ``x`` (``chi2(6)`` when nothing moved) of the
same frames with the camera moved by ``--bump-mm`` / ``--bump-deg``: fewer points widen the step's covariance,
so a cut shows here as a smaller ``x`` for the same move.

Example::

    OPENBLAS_NUM_THREADS=1 taskset -c 0 python benchmarks/watch_check_cost.py --data /tmp/watch-check-cost
"""

from __future__ import annotations

import os

if __name__ == "__main__":  # the check on one core: set before numpy starts its thread pools
    for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from dataclasses import replace  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

from benchmarks._report import Report  # noqa: E402
from handeye.core.smoke import smoke_test  # noqa: E402

#: (name, (width, height), horizontal field of view in degrees): the running-cell benchmark's frames, a D435's depth.
SIZES = (("256x256", (256, 256), 60.0), ("848x480", (848, 480), 87.0))


def parse_args(argv=None) -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--data", type=Path, default=None, help="folder of the rendered frames (reused when there)")
    p.add_argument("--sensor", default="d435")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--frames", type=int, default=9, help="frames per size (the arm at different places)")
    p.add_argument("--repeats", type=int, default=10, help="timed checks of each frame")
    p.add_argument("--bump-mm", type=float, default=2.0, help="the moved camera's translation")
    p.add_argument("--bump-deg", type=float, default=0.2, help="the moved camera's rotation")
    Report.add_out(p)
    return p.parse_args(argv)


def frames_dir(data: Path, name: str, size: tuple, fov_deg: float, args) -> Path:
    """A stream of ``args.frames`` frames at ``size`` (no events), rendered unless ``data/NAME/stream.json``
    exists."""
    from sim.stream import generate_stream
    from sim.stream_events import StreamPreset

    root = data / name
    if (root / "stream.json").is_file():
        return root
    rate_hz = 0.6  # a frame every 1.7 s: the arm somewhere else in each
    preset = StreamPreset(
        "check-cost", minutes=args.frames / rate_hz / 60.0, rate_hz=rate_hz, image_size=size, fov_deg=fov_deg
    )
    generate_stream(root, preset, args.seed, args.sensor, workers=1, progress=False)
    return root


def moved(T_base_cam: np.ndarray, mm: float, deg: float) -> np.ndarray:
    """The camera moved by ``mm`` along one fixed direction and turned by ``deg`` about another (camera frame)."""
    from handeye.core.se3 import make_transform, so3_exp

    axis, along = np.array([0.6, 0.0, 0.8]), np.array([0.0, 0.6, 0.8])
    return T_base_cam @ make_transform(so3_exp(np.radians(deg) * axis), 1e-3 * mm * along)


def measure(root: Path, setting: str, args) -> dict:
    """Times and statistics of one size's frames under ``setting`` (``as given`` or ``by focal``)."""
    from handeye.core.dataset import Dataset
    from handeye.markerless import robot_surface_for
    from handeye.robot.depth_sensors import sensor_profile
    from handeye.watch import dataset_frames
    from handeye.watch.change import fit_null
    from handeye.watch.check import CheckOptions, check_frame
    from sim.stream import read_stream

    ds = Dataset.open(root)
    K = np.array(ds.meta["intrinsics"]["K"], dtype=float)
    T_true = ds.truth()[0]
    T_moved = moved(T_true, args.bump_mm, args.bump_deg)
    sigma_m = sensor_profile(read_stream(root)["sensor"]).sigma_m
    surface, stride = robot_surface_for(ds)
    options = CheckOptions(zbuffer_stride=stride)
    if setting == "as given":
        options = replace(options, reference_focal_px=0.0)
    factor = options.factor_for(K)
    posing = surface.thinned(factor**2)
    frames = list(dataset_frames(root))
    cpu, checks, shifted = [], [], []
    for f in frames:
        q = np.asarray(f.joints, dtype=float)[None]
        for _ in range(args.repeats):
            c0 = time.process_time()
            posed = posing.posed(q, twists=True)  # as the watcher poses it: the joints' error is learnt
            check = check_frame(f.depth_m, K, posed, T_true, sigma_m, options)
            cpu.append(time.process_time() - c0)
        checks.append(check)
        shifted.append(check_frame(f.depth_m, K, posed, T_moved, sigma_m, options))
    ok = [c for c in checks if c.delta is not None]
    row = {
        "stride": options.stride_for(K),
        "posed": len(posed.points_base),
        "cpu_ms": 1e3 * np.array(cpu),
        "matched": float(np.median([c.n_matched for c in checks])),
        "frames": len(frames),
        "stepped": len(ok),
    }
    if len(ok) >= 6:
        sd = np.sqrt(np.array([np.diag(c.covariance) for c in ok]))
        row["sigma_mdeg"] = float(np.median(np.degrees(np.linalg.norm(sd[:, :3], axis=1)))) * 1e3
        row["sigma_mm"] = float(np.median(np.linalg.norm(sd[:, 3:], axis=1))) * 1e3
        row["chi2_raw"] = float(np.median([c.chi2 for c in ok]))
        null = fit_null(np.array([c.delta for c in ok]), np.array([c.covariance for c in ok]))
        row["scale"] = null.scale
        row["x_true"] = float(np.median([null.statistic(c.delta, c.covariance) for c in ok]))
        moved_x = [null.statistic(c.delta, c.covariance) for c in shifted if c.delta is not None]
        row["x_moved"] = float(np.median(moved_x))
    return row


def _versions() -> str:
    return f"numpy {np.__version__}"


def main(argv=None) -> int:
    args = parse_args(argv)
    Report.cut(args, frames=6, repeats=2)
    title = "The running cell's check per frame, by image size"
    rep = Report(title, "benchmarks/watch_check_cost.py", argv, _versions())
    rep.say(
        f"simulated frames (sim.stream, no events, sensor {args.sensor}, seed {args.seed}); per frame: the surface "
        "posed at its joints and check_frame, CPU time (time.process_time); "
        f"OPENBLAS_NUM_THREADS={os.environ.get('OPENBLAS_NUM_THREADS', 'unset')}, "
        f"CPUs allowed: {len(os.sched_getaffinity(0))}, load {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores"
    )
    rep.say()
    data = args.data or Path(tempfile.mkdtemp(prefix="watch-check-cost-"))
    sizes = SIZES if not smoke_test() else (("96x96", (96, 96), 60.0), ("160x96", (160, 96), 87.0))
    rep.say(
        "| image | setting | z-buffer stride | points posed | CPU ms median | CPU ms 95th pct | matched | step 1-sigma "
        f"(mdeg / mm) | raw statistic at truth | null scale c | x at truth | x moved {args.bump_mm:g} mm / "
        f"{args.bump_deg:g} deg |"
    )
    rep.say("|---|---|---|---|---|---|---|---|---|---|---|---|")
    for name, size, fov_deg in sizes:
        root = frames_dir(data, name, size, fov_deg, args)
        for setting in ("as given", "by focal"):
            r = measure(root, setting, args)
            stats = "| - | - | - | - | - |"
            if "scale" in r:
                stats = (
                    f"| {r['sigma_mdeg']:.1f} / {r['sigma_mm']:.2f} | {r['chi2_raw']:.0f} | {r['scale']:.0f} "
                    f"| {r['x_true']:.1f} | {r['x_moved']:.0f} |"
                )
            rep.say(
                f"| {name} over {fov_deg:g} deg | {setting} | {r['stride']} | {r['posed']} "
                f"| {np.median(r['cpu_ms']):.1f} | {np.percentile(r['cpu_ms'], 95):.1f} | {r['matched']:.0f} " + stats
            )
    rep.say()
    rep.say(
        f"{args.frames} frames per size, {args.repeats} timed checks each; matched: median over the frames; "
        "1-sigma: the step's, pixels counted as independent (median); x: the statistic after the null fitted on "
        "the same frames (chi2(6), median 5.3, when nothing moved), medians over the frames"
    )
    return rep.write(args.out)


if __name__ == "__main__":
    sys.exit(main())
