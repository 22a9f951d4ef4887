"""Does the markerless registration's depth unit lie within its own sigma on few frames (issue 41)?

The running-cell watcher recalibrates from 20 frames of a 30 Hz stream
(:func:`handeye.watch.cell.markerless_recalibration`) and found the registration's depth scale and offset 5 to 6
of their own sigmas off. This benchmark renders a quiet
stream (no bump, occlusion or dropout; :func:`sim.stream.generate_stream`) per seed with a depth sensor profile,
takes sets of ``--frames`` frames from it as the watcher collects them (each new frame's joints at least
``recal_min_joint_step_rad`` from every one kept, :class:`handeye.watch.cell.WatchOptions`), the sets starting at
evenly spaced frames, registers each as the watcher does (started from the truth: the watcher starts from its last
calibration), and compares the reported scale, offset and pose with the simulator's truth (``cameras.csv``) in units
of the reported sigmas. Printed per frame count: the sets registered and refused, how many of the accepted ones
are more than 3 sigmas off in the scale, the offset, either of them, and the pose (rotation or translation, against
the RMS sigma the result reports), the RMS and largest of those ratios, the median noise bias the registration
took out (``diagnostics["noise_bias"]``, where it reports one), and the median sigmas of the scale and the offset.

Example::

    python benchmarks/markerless_depth_unit_sigma.py --seeds 1 2 --frames 20 30 60 --sets 8 \\
        --out benchmarks/results/markerless_depth_unit_sigma.md

``--data DIR`` reuses the streams a previous run rendered there (one folder per seed, ``quiet-SENSOR-seedN``), or
renders them there when missing.
"""

from __future__ import annotations

import os

if __name__ == "__main__":  # one core: set before numpy starts its thread pools
    for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import csv  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

from benchmarks._report import Report  # noqa: E402
from handeye.core.metrics import pose_error  # noqa: E402

#: More than this many of its own sigmas from the truth: a wrong answer reported as a success (as
#: benchmarks/markerless_sensors.py and benchmarks/running_cell.py count them).
WRONG_SIGMAS = 3.0


def parse_args(argv=None) -> argparse.Namespace:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--seeds", type=int, nargs="+", default=[1, 2], help="one stream (one sensor unit) per seed")
    ap.add_argument("--sensor", default="d435", help="depth sensor profile (handeye.robot.depth_sensors.PROFILES)")
    ap.add_argument("--size", type=int, default=128, help="image width = height, pixels")
    ap.add_argument("--rate", type=float, default=10.0, help="the stream's frame rate, Hz")
    ap.add_argument("--seconds", type=float, default=45.0, help="the stream's length")
    ap.add_argument("--frames", type=int, nargs="+", default=[20, 30, 60], help="frames per registration")
    ap.add_argument("--sets", type=int, default=8, help="registrations per frame count and seed")
    ap.add_argument("--data", type=Path, default=None, help="folder of rendered streams to reuse or fill")
    Report.add_out(ap)
    return ap.parse_args(argv)


def versions() -> str:
    import scipy

    return f"numpy {np.__version__}, scipy {scipy.__version__}"


def stream(args, seed: int, data: Path) -> Path:
    """The quiet stream of ``seed``: reused from ``data`` where rendered, else rendered there."""
    from sim.stream import generate_stream
    from sim.stream_events import StreamPreset

    root = data / f"quiet-{args.sensor}-seed{seed}"
    if (root / "stream.json").is_file():
        return root
    preset = StreamPreset(
        "quiet", minutes=args.seconds / 60, rate_hz=args.rate, image_size=(args.size, args.size), sensor=args.sensor
    )
    generate_stream(root, preset, seed=seed, workers=1, progress=False)
    return root


def frame_sets(frames: list, count: int, sets: int, step_rad: float) -> list[list]:
    """Up to ``sets`` sets of ``count`` frames, as the watcher collects them (each frame's joints at least
    ``step_rad`` from every one kept), starting at evenly spaced frames; a start too late for ``count`` is left out."""
    out = []
    for start in np.linspace(0, len(frames), sets, endpoint=False).astype(int):
        kept = []
        for f in frames[start:]:
            if (f.depth_m > 0).any() and all(np.abs(f.joints - g.joints).max() >= step_rad for g in kept):
                kept.append(f)
            if len(kept) == count:
                out.append(kept)
                break
    return out


def register_sets(root: Path, counts: list[int], sets: int) -> list[dict]:
    """Every set of every frame count of one stream registered; per set its errors over the reported sigmas."""
    from handeye.core.dataset import Dataset
    from handeye.markerless import robot_surface_for
    from handeye.robot.depth_sensors import sensor_profile
    from handeye.watch import dataset_frames
    from handeye.watch.cell import WatchOptions, markerless_recalibration
    from sim.stream import read_stream

    ds, doc = Dataset.open(root), read_stream(root)
    K = np.array(ds.meta["intrinsics"]["K"], dtype=float)
    surface, stride = robot_surface_for(ds)
    recalibrate = markerless_recalibration(surface, K, sensor_profile(doc["sensor"]), zbuffer_stride=stride)
    with open(root / "cameras.csv", newline="") as fh:
        camera = next(csv.DictReader(fh))  # a quiet stream: one segment, one camera
    scale_true, offset_mm_true = float(camera["depth_scale_true"]), float(camera["depth_offset_mm_true"])
    T_true = ds.truth()[0]
    frames = list(dataset_frames(root))
    rows = []
    for count in counts:
        for kept in frame_sets(frames, count, sets, WatchOptions().recal_min_joint_step_rad):
            t0 = time.perf_counter()
            res = recalibrate(kept, T_true)
            row = {"frames": count, "seconds": time.perf_counter() - t0, "ok": res.ok}
            if res.ok:
                d = res.depth
                rot_deg, trans_mm = pose_error(res.T_base_cam, T_true)
                row.update(
                    {
                        "scale_z": (d["scale"] - scale_true) / d["scale_sigma"],
                        "offset_z": (d["offset_mm"] - offset_mm_true) / d["offset_sigma_mm"],
                        "rotation_z": rot_deg / res.sigma["rotation_deg"],
                        "translation_z": trans_mm / res.sigma["translation_mm"],
                        "scale_error": d["scale"] - scale_true,
                        "scale_sigma": d["scale_sigma"],
                        "offset_sigma_mm": d["offset_sigma_mm"],
                        "offset_error_mm": d["offset_mm"] - offset_mm_true,
                        "bias_scale": (res.diagnostics.get("noise_bias") or {}).get("scale", np.nan),
                    }
                )
            rows.append(row)
    return rows


def table(rows: list[dict], counts: list[int]) -> list[str]:
    """The per-frame-count summary (module docstring)."""
    lines = [
        "| frames | sets | refused | scale > 3 sigma | offset > 3 sigma | either | pose > 3 sigma | RMS / max "
        "scale z | RMS / max offset z | median scale error | median noise bias taken out | median scale / offset "
        "sigma | s per set |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for count in counts:
        mine = [r for r in rows if r["frames"] == count]
        ok = [r for r in mine if r["ok"]]
        if not mine:
            continue
        z = {k: np.array([r[k] for r in ok]) for k in ("scale_z", "offset_z", "rotation_z", "translation_z")}
        beyond = {k: int(np.sum(np.abs(v) > WRONG_SIGMAS)) for k, v in z.items()}
        either = int(np.sum((np.abs(z["scale_z"]) > WRONG_SIGMAS) | (np.abs(z["offset_z"]) > WRONG_SIGMAS)))
        pose = int(np.sum((z["rotation_z"] > WRONG_SIGMAS) | (z["translation_z"] > WRONG_SIGMAS)))

        def rms_max(v):
            return f"{np.sqrt(np.mean(v**2)):.1f} / {np.max(np.abs(v)):.1f}" if len(v) else "-"

        bias = np.array([r["bias_scale"] for r in ok])
        bias_text = f"{np.median(bias) * 100:+.3f} %" if np.isfinite(bias).any() else "none"
        median_scale = f"{np.median([r['scale_error'] for r in ok]) * 100:+.3f} %" if ok else "-"
        sigmas = (
            f"{np.median([r['scale_sigma'] for r in ok]) * 100:.3f} % / "
            f"{np.median([r['offset_sigma_mm'] for r in ok]):.2f} mm"
            if ok
            else "-"
        )
        lines.append(
            f"| {count} | {len(mine)} | {len(mine) - len(ok)} | {beyond['scale_z']} | {beyond['offset_z']} | "
            f"{either} | {pose} | {rms_max(z['scale_z'])} | {rms_max(z['offset_z'])} | {median_scale} | {bias_text} | "
            f"{sigmas} | {np.median([r['seconds'] for r in mine]):.1f} |"
        )
    return lines


def main(argv=None) -> int:
    args = parse_args(argv)
    rep = Report(
        "Markerless depth unit against its sigma on few frames",
        "benchmarks/markerless_depth_unit_sigma.py",
        argv,
        versions(),
    )
    data = args.data or Path(tempfile.mkdtemp(prefix="markerless-depth-unit-"))
    data.mkdir(parents=True, exist_ok=True)
    rep.say(
        f"streams: quiet preset (no event), sensor {args.sensor}, {args.size}x{args.size} pixels, {args.rate:g} Hz, "
        f"{args.seconds:g} s, seeds {' '.join(map(str, args.seeds))}; registered as the watcher recalibrates "
        "(handeye.watch.cell.markerless_recalibration), started from the truth"
    )
    rows = []
    for seed in args.seeds:
        t0 = time.perf_counter()
        root = stream(args, seed, data)
        rendered = time.perf_counter() - t0
        mine = register_sets(root, args.frames, args.sets)
        for r in mine:
            r["seed"] = seed
        rows += mine
        rep.say(f"seed {seed}: {root} ({rendered:.0f} s to render or find), {len(mine)} registrations")
    rep.say()
    rep.say("z: (estimate - truth) / the reported sigma; pose: the error over the reported RMS sigma; beyond")
    rep.say(f"{WRONG_SIGMAS:g}: a wrong answer reported as a success")
    rep.say()
    for line in table(rows, args.frames):
        rep.say(line)
    return rep.write(args.out)


if __name__ == "__main__":
    sys.exit(main())
