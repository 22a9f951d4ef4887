"""Benchmark: ``classic.markerless.register_robot`` against an earlier revision of itself, bit for bit and in time.

Where code only moved (a module split, stages named), no bit of any registration may change. This script checks
out ``--against`` (a git revision) in a temporary worktree, runs the same registrations there and in this tree,
each tree in its own process, and compares each case's ``T_base_cam``, covariance and per-frame residuals with
``==`` (NaN equal to NaN) and its whole :meth:`~classic.markerless.MarkerlessResult.to_dict` (sigma, depth,
intrinsics, joint offsets, diagnostics) as JSON text; and the time of the workload in each tree.

The workload is the analytic scenes of the tests (ray-cast spheres over a floor, ``tests/classic/``), through
the registration's paths: the depth noise measured or given, the depth and intrinsics fixed, a stereo matcher's
bias, a coarser z-buffer with image tiles and static parts, a given start without the split check, a start
outside the basin (refused), joint offsets with moving and with static parts, two starts, curvatures, a depth error
per 2 px image cell marginalised, and no robot in view (refused)::

    python benchmarks/markerless_identity.py --against HEAD --out benchmarks/results/markerless_identity.md
"""

from __future__ import annotations

import argparse
import os
import pickle
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from benchmarks._report import Report  # noqa: E402

#: Runs the workload in the tree on sys.path; prints the pickled results by case and the workload's time.
WORKER = r"""
import json, pickle, sys, time, warnings
import numpy as np
from classic.markerless import MarkerlessOptions, RobotSurfaceFrames, register_robot
from classic.markerless.curvature import sample_curvatures
from tests.classic.test_markerless import F_PX, K, _scene
from tests.classic.test_markerless_joint_offsets import arm_scene
warnings.simplefilter("ignore")
S, O = 0.001, MarkerlessOptions
depth, surface, T = _scene(np.random.default_rng(0))
arm_depth, arm, _, T_kin, _ = arm_scene(np.random.default_rng(3))
far = T.copy()
far[:3, 3] += [0.4, -0.3, 0.2]
d1, s1, _ = _scene(np.random.default_rng(1), noise=False)
kappa, direction = np.zeros((len(s1.part), 2)), np.zeros((len(s1.part), 3))
for key in np.unique(s1.part * 100 + s1.frame):
    sel = s1.part * 100 + s1.frame == key
    kappa[sel], direction[sel] = sample_curvatures(s1.points_base[sel], s1.normals_base[sel], 2.5 * 0.7 * 0.8 / F_PX)
curved = RobotSurfaceFrames(s1.points_base, s1.normals_base, s1.frame, s1.part, kappa, direction)
cases = {  # name: (depth, surface, starts, options, centroid start)
    "noise measured": (depth, surface, None, O(), True),
    "noise given": (depth, surface, None, O(depth_sigma_m_at_1m=S), True),
    "depth and intrinsics fixed": (depth, surface, None, O(depth_model="fixed", intrinsics_model="fixed"), True),
    "stereo matcher's bias": (depth, surface, None, O(stereo_fb_px_m=447 * 0.05), True),
    "z-buffer stride 2, tiles, static parts": (
        depth, surface, None, O(zbuffer_stride=2, image_tiles=4, static_parts=True), True),
    "given start, no split check": (depth, surface, {"user": T}, O(split_check=False), False),
    "start outside the basin": (depth, surface, {"far": far}, O(), False),
    "joint offsets": (arm_depth, arm, None, O(depth_sigma_m_at_1m=S), True),
    "joint offsets, static parts": (arm_depth, arm, None, O(depth_sigma_m_at_1m=S, static_parts=True), True),
    "two starts": (arm_depth, arm, {"good": T_kin, "far": far}, O(depth_sigma_m_at_1m=S), False),
    "curvatures": (d1, curved, None, O(depth_sigma_m_at_1m=S), True),
    "a depth error per 2 px cell": (depth, surface, None, O(pixel_effect_px=2), True),
    "no robot in view": (np.ones_like(depth), surface, None, O(), True),
}
out = {}
t0 = time.perf_counter()
for name, (d, s, starts, options, centroid) in cases.items():
    r = register_robot(d, K, s, starts=starts, options=options, centroid_start=centroid)
    arrays = [np.full((4, 4), np.nan) if r.T_base_cam is None else r.T_base_cam, r.covariance, r.residual_mm_per_frame]
    out[name] = {"arrays": arrays, "json": json.dumps(r.to_dict(), sort_keys=True, default=repr), "refused": r.refused}
sys.stdout.buffer.write(pickle.dumps({"results": out, "seconds": time.perf_counter() - t0}))
"""


def run_tree(tree: Path) -> dict:
    """The workload in ``tree``'s code, in a fresh process on one thread: results by case and its time."""
    env = {**os.environ, "PYTHONPATH": str(tree), "OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1"}
    done = subprocess.run([sys.executable, "-c", WORKER], capture_output=True, env=env, cwd=tree, check=True)
    return pickle.loads(done.stdout)


def compare(a: dict, b: dict) -> str:
    """``"identical"``, or what differs between two outcomes of one case."""
    import numpy as np

    for name, x, y in zip(("T_base_cam", "covariance", "residuals"), a["arrays"], b["arrays"]):
        if x.shape != y.shape or not np.array_equal(x, y, equal_nan=True):
            return f"{name} differs"
    return "identical" if a["json"] == b["json"] else "to_dict differs"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--against", default="HEAD", help="the git revision to compare with (default HEAD)")
    ap.add_argument("--out", type=Path)
    args = ap.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        old = Path(tmp) / "old"
        subprocess.run(
            ["git", "-C", str(ROOT), "worktree", "add", "-q", "--detach", str(old), args.against], check=True
        )
        try:
            before = run_tree(old)
        finally:
            subprocess.run(["git", "-C", str(ROOT), "worktree", "remove", "--force", str(old)], check=False)
    after = run_tree(ROOT)
    rev = subprocess.run(["git", "-C", str(ROOT), "rev-parse", "--short", args.against], capture_output=True, text=True)
    import numpy as np
    import scipy

    versions = f"python {sys.version.split()[0]}, numpy {np.__version__}, scipy {scipy.__version__}"
    report = Report(
        "classic.markerless against an earlier revision", "benchmarks/markerless_identity.py", argv, versions
    )
    report.say(
        f"Against {args.against} ({rev.stdout.strip()}); this tree may hold uncommitted changes. Each case's "
        "T_base_cam, covariance and residuals compared with == (NaN equal to NaN), its to_dict() as JSON text."
    )
    report.say()
    report.say("| case | outcome | bit-identical |")
    report.say("|---|---|---|")
    outcomes = {name: compare(before["results"][name], after["results"][name]) for name in after["results"]}
    for name, what in outcomes.items():
        refused = after["results"][name]["refused"]
        report.say(f"| {name} | {'refused' if refused else 'accepted'} | {'yes' if what == 'identical' else what} |")
    report.say()
    report.say(
        f"Whole workload ({len(outcomes)} registrations), one run per tree, one thread, on a shared machine: "
        f"earlier {before['seconds']:.1f} s, this tree {after['seconds']:.1f} s."
    )
    report.write(args.out)
    return 0 if all(what == "identical" for what in outcomes.values()) else 1


if __name__ == "__main__":
    raise SystemExit(main())
