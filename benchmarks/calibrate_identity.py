"""Benchmark: ``classic.calibrate`` against an earlier revision of itself, bit for bit and in time.

A refactor of the front (its stages, what it hands down) must not change a single bit of any result, nor make
it slower. This script checks out ``--against`` (a git revision) in a temporary worktree, runs the same
workload of calibrations there and in this tree, each in its own process, and compares:

- every result array (``X``, ``Y``, the covariance, the per-pose residuals and inliers) with ``==``, and the
  diagnostics' JSON text, case by case;
- the time of the whole workload, best of ``--repeats`` runs in each tree, alternating, with the ratio.

The workload covers the front's paths: both setups, all and consecutive pairs, a named closed form without
refinement, a given noise model, outliers with the robust path and refused without it, a metric scale, and a
large set::

    python benchmarks/calibrate_identity.py --against HEAD~1 --out benchmarks/results/calibrate_identity.md
"""

from __future__ import annotations

import argparse
import os
import pickle
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from benchmarks._report import Report  # noqa: E402

#: name -> ((poses, setup) of make_problem, its noise and outlier arguments, calibrate's arguments: those it does not
#: take flat go into a ``CalibrateOptions`` in a tree that has one)
CASES = {
    "eye-to-hand, 15 poses": ((15, "eye_to_hand"), {"camera_noise": (0.1, 0.5)}, {}),
    "eye-in-hand, 20 poses": ((20, "eye_in_hand"), {"camera_noise": (0.1, 0.5)}, {}),
    "consecutive pairs": ((20, "eye_to_hand"), {"camera_noise": (0.1, 0.5)}, {"pairs": "consecutive"}),
    "tsai, no refinement": ((15, "eye_in_hand"), {"camera_noise": (0.1, 0.5)}, {"method": "tsai", "refine": False}),
    "noise given": ((15, "eye_to_hand"), {"camera_noise": (0.1, 0.5)}, {"noise": (np.radians(0.1), 0.0005)}),
    "robot noise too": ((25, "eye_to_hand"), {"camera_noise": (0.05, 0.3), "robot_noise": (0.05, 0.3)}, {}),
    "outliers, robust": ((30, "eye_to_hand"), {"camera_noise": (0.1, 0.5), "outlier_fraction": 0.2}, {"robust": True}),
    "outliers, robust, then least squares": (
        (30, "eye_in_hand"),
        {"camera_noise": (0.1, 0.5), "outlier_fraction": 0.15},
        {"robust": True, "loss": "linear"},
    ),
    "outliers, refused": ((30, "eye_in_hand"), {"camera_noise": (0.1, 0.5), "outlier_fraction": 0.2}, {}),
    "metric scale": ((20, "eye_in_hand"), {"camera_noise": (0.1, 0.5)}, {"estimate_scale": True}),
    "200 poses": ((200, "eye_to_hand"), {"camera_noise": (0.1, 0.5)}, {}),
}

WORKER = r"""
import inspect, json, pickle, sys, time, warnings
import numpy as np
sys.path.insert(0, sys.argv[1])
from classic.calibrate import calibrate
from handeye.core.synthetic import make_problem
cases = pickle.loads(bytes.fromhex(sys.argv[2]))
flat = inspect.signature(calibrate).parameters
if "options" in flat:  # a tree with CalibrateOptions takes the rest in it
    from classic.calibrate import CalibrateOptions
    for name, (shape, gen, kwargs) in cases.items():
        rest = {k: v for k, v in kwargs.items() if k not in flat}
        kwargs = {k: v for k, v in kwargs.items() if k in flat}
        cases[name] = (shape, gen, {**kwargs, "options": CalibrateOptions(**rest)})
repeats = int(sys.argv[3])
out, best = {}, np.inf
warnings.simplefilter("ignore")
problems = {}
for name, ((n, setup), gen, _) in cases.items():
    p = make_problem(n, setup, rng=np.random.default_rng(7), **gen)
    problems[name] = (p, setup)
for r in range(repeats):
    t0 = time.perf_counter()
    for name, (_, _, kwargs) in cases.items():
        p, setup = problems[name]
        try:
            res = calibrate(p.T_base_ee, p.T_cam_target, setup=setup, **kwargs)
            if r == 0:
                out[name] = {
                    "arrays": [res.X, res.Y, res.covariance, res.residuals.rotation_deg,
                               res.residuals.translation_mm, res.residuals.inliers],
                    "method": res.method,
                    "diagnostics": json.dumps(res.diagnostics, sort_keys=True, default=repr),
                }
        except ValueError as exc:
            if r == 0:
                out[name] = {"error": f"{type(exc).__name__}: {exc}"}
    best = min(best, time.perf_counter() - t0)
sys.stdout.buffer.write(pickle.dumps({"results": out, "seconds": best}))
"""


def run_tree(tree: Path, repeats: int) -> dict:
    """The workload in ``tree``'s code, in a fresh process: results by case and the best time."""
    env = {**os.environ, "PYTHONPATH": str(tree), "OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1"}
    args = [sys.executable, "-c", WORKER, str(tree), pickle.dumps(CASES).hex(), str(repeats)]
    done = subprocess.run(args, capture_output=True, env=env, cwd=tree, check=True)
    return pickle.loads(done.stdout)


def same(a: dict, b: dict) -> tuple[bool, str]:
    """Whether two cases' outcomes are identical bit for bit, and what differs."""
    if "error" in a or "error" in b:
        return a.get("error") == b.get("error"), "refusal" if a.get("error") == b.get("error") else "refusal differs"
    for k, (x, y) in enumerate(zip(a["arrays"], b["arrays"])):
        if x.shape != y.shape or not np.array_equal(x, y):
            diff = np.max(np.abs(np.asarray(x, float) - np.asarray(y, float))) if x.shape == y.shape else np.inf
            return False, f"array {k} differs by up to {diff:.3g}"
    if a["method"] != b["method"]:
        return False, "method name differs"
    if a["diagnostics"] != b["diagnostics"]:
        return False, "diagnostics differ"
    return True, "identical"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--against", default="HEAD", help="the git revision to compare with (default HEAD)")
    ap.add_argument("--repeats", type=int, default=10, help="runs of the workload per tree; the best is kept")
    ap.add_argument("--rounds", type=int, default=5, help="alternating rounds of both trees")
    ap.add_argument("--out", type=Path)
    args = ap.parse_args(argv)
    Report.cut(args, repeats=1, rounds=1)
    with tempfile.TemporaryDirectory() as tmp:
        old = Path(tmp) / "old"
        subprocess.run(
            ["git", "-C", str(ROOT), "worktree", "add", "-q", "--detach", str(old), args.against], check=True
        )
        try:
            runs = {"old": [], "new": []}
            for _ in range(args.rounds):
                runs["old"].append(run_tree(old, args.repeats))
                runs["new"].append(run_tree(ROOT, args.repeats))
        finally:
            subprocess.run(["git", "-C", str(ROOT), "worktree", "remove", "--force", str(old)], check=False)
    old_res, new_res = runs["old"][0]["results"], runs["new"][0]["results"]
    t_old = min(r["seconds"] for r in runs["old"])
    t_new = min(r["seconds"] for r in runs["new"])
    rev = subprocess.run(["git", "-C", str(ROOT), "rev-parse", "--short", args.against], capture_output=True, text=True)
    import scipy

    versions = f"python {sys.version.split()[0]}, numpy {np.__version__}, scipy {scipy.__version__}"
    report = Report("classic.calibrate against an earlier revision", "benchmarks/calibrate_identity.py", argv, versions)
    report.say(
        f"Against {args.against} ({rev.stdout.strip()}); this tree may hold uncommitted changes. "
        "Each case's result compared bit for bit (arrays with ==, the diagnostics as JSON text)."
    )
    rows = []
    for name in CASES:
        ok, what = same(old_res[name], new_res[name])
        rows.append((name, "yes" if ok else "NO", what))
    report.say()
    report.say("| case | bit-identical | outcome |")
    report.say("|---|---|---|")
    for row in rows:
        report.say("| " + " | ".join(row) + " |")
    report.say()
    report.say(
        f"Whole workload ({len(CASES)} calibrations), best of {args.repeats} x {args.rounds} alternating rounds, "
        f"one thread: earlier {t_old * 1e3:.1f} ms, this tree {t_new * 1e3:.1f} ms, ratio {t_new / t_old:.3f}."
    )
    report.write(args.out)
    return 0 if all(r[1] == "yes" for r in rows) else 1


if __name__ == "__main__":
    raise SystemExit(main())
