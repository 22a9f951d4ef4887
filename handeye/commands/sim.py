"""``handeye sim generate``: render a simulated, labelled-ready dataset.

Example
-------
::

    handeye sim generate --preset paper-sim --out data/paper-sim
    handeye sim generate --preset small --out data/small --noise default

Per camera pose of the preset: a calibration recording (the ChArUco board on
the flange in reachable views facing the camera) and a data recording (RGB,
depth, joints, ``T_base_ee``, ``T_base_ref``). Run it again on the same
``--out`` to resume: complete shards are kept, half-written ones are rendered
again. Then ``handeye label`` the result.
"""

from __future__ import annotations

import argparse
from pathlib import Path

__all__ = ["add_parser", "run"]


def add_parser(sub) -> argparse.ArgumentParser:
    """Register the command group."""
    p = sub.add_parser(
        "sim",
        help="the simulator: render datasets of a UR robot seen by many camera poses",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    simsub = p.add_subparsers(dest="sim_command", required=True, metavar="SIM_COMMAND")
    g = simsub.add_parser(
        "generate",
        help="render a dataset (resumable)",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    g.add_argument("--preset", default="small", help="paper-sim, paper-real or small (default)")
    g.add_argument("--out", type=Path, required=True, help="dataset directory")
    g.add_argument("--seed", type=int, default=0)
    g.add_argument("--workers", type=int, default=2, help="rendering processes (default 2)")
    g.add_argument(
        "--noise",
        default="none",
        help="'none', 'default' (pixel 2 grey levels, depth 1 mm at 1 m, joints 0.01 deg) or "
        "PIXEL,DEPTH_M_AT_1M,JOINT_DEG",
    )
    g.add_argument("--recordings", default="calibration,data", help="calibration,data (default) or one of them")
    g.add_argument("--quiet", action="store_true", help="no progress bar")
    g.set_defaults(run=run)
    return p


def parse_noise(text: str):
    """``none``, ``default`` or three comma-separated numbers -> NoiseModel."""
    from handeye.core.errors import HandEyeInputError
    from sim.generate import DEFAULT_NOISE, NoiseModel

    if text == "none":
        return NoiseModel()
    if text == "default":
        return DEFAULT_NOISE
    try:
        pixel, depth, joint = (float(v) for v in text.split(","))
    except ValueError:
        raise HandEyeInputError(f"--noise {text!r}: use none, default, or PIXEL,DEPTH_M_AT_1M,JOINT_DEG") from None
    return NoiseModel(pixel, depth, joint)


def run(args: argparse.Namespace) -> int:
    """Run the command."""
    from handeye.core.optional import require_package

    require_package("pyrender", extra="sim", purpose="rendering")
    from sim.generate import generate

    report = generate(
        args.out,
        args.preset,
        seed=args.seed,
        noise=parse_noise(args.noise),
        workers=args.workers,
        recordings=tuple(r.strip() for r in args.recordings.split(",")),
        progress=not args.quiet,
    )
    print(report.summary())
    print(f"next: handeye label {args.out}")
    return 0
