"""Benchmark: the Ray engine against the process pool on this machine, and a Ray worker killed mid-run.

Run from the repository root (needs ``pip install -e ".[sim,cluster]"``)::

    python benchmarks/cluster_engines.py --out benchmarks/results/cluster_engines.md     # about 10 minutes

1. Throughput: the same preset generated (``handeye sim generate``) and labelled
   (``handeye label``) with the default pool and with a local Ray cluster, both
   with ``--workers`` processes, alternating engines ``--repeats`` times. The
   Ray cluster is started once before the timed runs (on a cluster it is a
   standing service); its start-up is printed apart. Target (issue 14): Ray's
   throughput within 10 % of the pool's.
2. Fault: generation on Ray with one busy worker killed (SIGKILL) as soon as a
   shard is half-written; the run must complete with every shard byte-identical
   to the pool's, and no ``.partial`` folder left.
"""

from __future__ import annotations

import argparse
import filecmp
import os
import shutil
import signal
import sys
import tempfile
import threading
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

from benchmarks._report import Report  # noqa: E402
from handeye.core.engine_protocol import EngineOptions  # noqa: E402
from handeye.core.ray_pool import LOCAL_WORKER_NICENESS, busy_worker_pids  # noqa: E402
from handeye.core.tables import markdown_table  # noqa: E402
from handeye.labelling import LabelRunOptions, label_dataset  # noqa: E402
from sim.cameras import get_preset  # noqa: E402
from sim.generate import DEFAULT_NOISE, Recipe, generate  # noqa: E402


def differing_files(a: Path, b: Path) -> list[str]:
    """Files under ``a`` missing from ``b`` or with other bytes (and files only in ``b``)."""
    cmp = filecmp.dircmp(a, b)
    bad = [str(a / n) for n in cmp.left_only + cmp.right_only + cmp.funny_files]
    _, mismatch, errors = filecmp.cmpfiles(a, b, cmp.common_files, shallow=False)
    bad += [str(a / n) for n in mismatch + errors]
    for d in cmp.common_dirs:
        bad += differing_files(a / d, b / d)
    return bad


def run_once(engine: str, root: Path, preset: str, workers: int) -> tuple[float, float]:
    """Generate and label ``root`` from nothing; (generation s, labelling s)."""
    shutil.rmtree(root, ignore_errors=True)
    t0 = time.perf_counter()
    options = EngineOptions(workers=workers, progress=False)
    generate(root, Recipe(preset, 0, DEFAULT_NOISE), options=options, engine=engine)
    t1 = time.perf_counter()
    label_dataset(root, workers=workers, progress=False, plot=False, options=LabelRunOptions(engine=engine))
    return t1 - t0, time.perf_counter() - t1


def kill_when_half_written(root: Path, stop: threading.Event, killed: list) -> None:
    """SIGKILL one busy Ray worker as soon as a shard of ``root`` has an image in its ``.partial`` folder."""
    while not stop.is_set():
        if list((root / "shards").glob("*.partial/rgb/*.png")):
            pids = busy_worker_pids()
            if pids:
                os.kill(pids[0], signal.SIGKILL)
                killed.append(pids[0])
                return
        time.sleep(0.05)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--preset", default="demo")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--repeats", type=int, default=2)
    ap.add_argument("--out", help="also write the report here (Markdown)")
    args = ap.parse_args(argv)

    import ray

    rep = Report(
        "Cluster engines: Ray against the process pool", "benchmarks/cluster_engines.py", argv, f"ray {ray.__version__}"
    )
    preset = get_preset(args.preset)
    rep.say(
        f"preset {preset.name}: {preset.n_cameras} camera poses, {preset.calibration_views} calibration views at "
        f"{preset.calibration_image_size[0]} px and {preset.configurations} data frames at {preset.image_size[0]} px "
        f"each; {args.workers} workers; default noise"
    )
    work = Path(tempfile.mkdtemp(prefix="handeye-engines-"))
    os.environ.setdefault(*LOCAL_WORKER_NICENESS)  # as RayEngine starts a local cluster
    t = time.perf_counter()
    ray.init(num_cpus=args.workers, include_dashboard=False, log_to_driver=False, object_store_memory=256 * 2**20)
    start_s = time.perf_counter() - t
    rep.say(f"local Ray cluster start: {start_s:.1f} s (not in the timings below)")
    rep.say()
    times = {"pool": [], "ray": []}
    try:
        for k in range(args.repeats):
            for engine in ("pool", "ray") if k % 2 == 0 else ("ray", "pool"):
                times[engine].append(run_once(engine, work / engine, args.preset, args.workers))
                g, lab = times[engine][-1]
                print(f"  run {k + 1} {engine}: generate {g:.1f} s, label {lab:.1f} s", file=sys.stderr)
        rows = []
        for engine in ("pool", "ray"):
            g = np.array([t[0] for t in times[engine]])
            lab = np.array([t[1] for t in times[engine]])
            rows.append(
                [
                    engine,
                    " / ".join(f"{x:.1f}" for x in g),
                    f"{preset.n_cameras / g.mean() * 60:.1f}",
                    " / ".join(f"{x:.1f}" for x in lab),
                    f"{preset.n_cameras / lab.mean() * 60:.1f}",
                ]
            )
        ratio_g = np.mean([t[0] for t in times["pool"]]) / np.mean([t[0] for t in times["ray"]])
        ratio_l = np.mean([t[1] for t in times["pool"]]) / np.mean([t[1] for t in times["ray"]])
        rep.say("## Throughput")
        rep.say()
        headers = ["engine", "generate s (each run)", "shards/min", "label s (each run)", "camera poses/min"]
        for line in markdown_table(headers, rows):
            rep.say(line)
        rep.say()
        rep.say(f"Ray's throughput / the pool's: generation {ratio_g:.3f}, labelling {ratio_l:.3f} (target >= 0.90)")
        with_start = np.mean([t[0] for t in times["pool"]]) / (np.mean([t[0] for t in times["ray"]]) + start_s)
        rep.say(f"generation, the cluster start added to every Ray run (a cluster per command): {with_start:.3f}")
        same = differing_files(work / "pool" / "shards", work / "ray" / "shards")
        same_labels = filecmp.cmp(work / "pool" / "cameras.csv", work / "ray" / "cameras.csv", shallow=False)
        rep.say(f"datasets byte-identical: shards {not same}, labels (cameras.csv) {same_labels}")
        rep.say()

        rep.say("## A Ray worker killed mid-shard")
        rep.say()
        root = work / "fault"
        shutil.rmtree(root, ignore_errors=True)
        stop, killed = threading.Event(), []
        killer = threading.Thread(target=kill_when_half_written, args=(root, stop, killed))
        killer.start()
        t = time.perf_counter()
        try:
            options = EngineOptions(workers=args.workers, progress=False)
            report = generate(root, Recipe(args.preset, 0, DEFAULT_NOISE), options=options, engine="ray")
        finally:
            stop.set()
            killer.join()
        wall = time.perf_counter() - t
        left = list((root / "shards").glob("*.partial"))
        diff = differing_files(work / "pool" / "shards", root / "shards")
        rep.say(
            f"killed worker pids: {killed}; run completed: {len(report.rendered)} of {preset.n_cameras} shards in "
            f"{wall:.1f} s; .partial folders left: {len(left)}; shards differing from the pool's run: {len(diff)}"
        )
    finally:
        ray.shutdown()
        shutil.rmtree(work, ignore_errors=True)
    return rep.write(args.out)


if __name__ == "__main__":
    sys.exit(main())
