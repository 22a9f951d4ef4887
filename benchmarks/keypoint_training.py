"""What moves the keypoint model's error: width, learning-rate schedule, heatmap spread loss (issue 10).

Each variant trains the keypoint model's batch strategy once (one repeat, the ``cpu`` preset otherwise,
``--threads`` per variant, ``--jobs`` variants at a time) and is measured on the keypoint pixels of the
training and the test frames (median, network input pixels) and on the test placements' poses (one
fit of all a placement's frames against the truth: the robust 3-D to 3-D fit, and the likelihood fit
with the model's residual statistics that the protocol uses, :func:`learned.keypoints.camera_pose`).
Train and test pixel errors that agree say the model underfits rather than fails to generalise to new camera poses.

    python benchmarks/keypoint_training.py --data data/paper-sim-noisy --out benchmarks/results/keypoint_training.md

A variant is ``name:width:epochs:schedule:spread[:size[:batch[:dtype]]]``: ``width`` the first stage's channels, or
``a-b`` for two stride-2 stages of ``a`` and ``b`` channels (:class:`learned.keypoints.KeypointNet`);
``schedule`` constant or cosine (the preset's ``keypoint_schedule``); ``spread`` its
``keypoint_spread_weight``; ``size`` the square input in pixels and ``batch`` the batch size (by default
64 and 32); ``dtype`` the precision of the convolutions, float32 (default) or bfloat16 (the preset's
``keypoint_trunk_dtype``). A variant trains the epochs it names on any dataset (the preset's
``keypoint_reference_frames`` is off here). ``--link-fractions`` sets the keypoints along the long links
(``handeye.robot.model.LINK_FRACTIONS``; given without values, none: the 8 keypoints of the joints, flange and
reference point).
"""

from __future__ import annotations

import argparse
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from dataclasses import replace
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from benchmarks._report import Report  # noqa: E402

DEFAULT_VARIANTS = (
    "width 8 (the cpu preset before):8:15:constant:0",
    "twice as wide:16:15:constant:0",
    "cosine schedule:8:15:cosine:0",
    "heatmap spread:8:15:constant:1",
    "cosine + spread:8:15:cosine:1",
)


def _use_link_fractions(fractions) -> None:
    """Points along the long links at these fractions (``handeye.robot.model.LINK_FRACTIONS``); ``None``: the
    default."""
    if fractions is not None:
        import handeye.robot.model

        handeye.robot.model.LINK_FRACTIONS = tuple(float(f) for f in fractions)


def _train(
    data: Path,
    spec: str,
    out: Path,
    seed: int,
    threads: int,
    average: int,
    shift: int,
    fractions=None,
    strategy: str = "batch",
    later_epochs: int | None = None,
) -> tuple[str, float]:
    from handeye.learned_frames import load_keypoint_frames
    from learned.experiment import ExperimentOptions, run_experiment
    from learned.presets import get_preset

    _use_link_fractions(fractions)  # in the worker process too
    name, width, epochs, schedule, spread, size, batch, dtype = _fields(spec)
    cpu = get_preset("cpu")
    preset = replace(
        cpu,
        keypoint_batch_size=batch,
        keypoint_trunk_dtype=dtype,
        keypoint_average_epochs=average,
        keypoint_shift_px=shift,
        name=f"cpu-{name}",
        keypoint_image_size=(size, size),
        keypoint_channels=tuple(int(w) for w in width.split("-")),
        repeats=1,
        keypoint_epochs=(int(epochs), int(later_epochs or cpu.keypoint_epochs[1]), int(epochs)),
        keypoint_reference_frames=0,  # the variant's epochs as given, whatever the dataset's size
        keypoint_schedule=schedule,
        keypoint_spread_weight=float(spread),
    )
    frames = load_keypoint_frames(data, preset.keypoint_image_size, "classic", progress=False)
    t0 = time.perf_counter()
    options = ExperimentOptions(labels="classic", seed=seed, family="keypoints")
    run_experiment(frames, preset, [strategy], out, progress=False, threads=threads, options=options)
    return spec, time.perf_counter() - t0


def _fields(spec: str) -> tuple:
    """``name, width, epochs, schedule, spread, size, batch, dtype`` of a variant (size and batch ints, 64 and 32
    when not given; dtype float32 when not given)."""
    parts = spec.split(":")
    usage = "name:width:epochs:constant|cosine:spread[:size[:batch[:float32|bfloat16]]]"
    if len(parts) not in (5, 6, 7, 8) or parts[3] not in ("constant", "cosine"):
        raise ValueError(f"variant {spec!r}: expected {usage}")
    dtype = parts[7] if len(parts) > 7 else "float32"
    if dtype not in ("float32", "bfloat16"):
        raise ValueError(f"variant {spec!r}: expected {usage}")
    size, batch = (int(parts[5]) if len(parts) > 5 else 64), (int(parts[6]) if len(parts) > 6 else 32)
    return (*parts[:5], size, batch, dtype)


def _measure(frames, native: tuple, model_path: Path) -> dict:
    """Pixel errors of the training and the test frames, and the test placements' pose errors."""
    from benchmarks.keypoint_errors import keypoint_stats, placement_errors, predicted_and_true, residual_stats_of
    from learned.experiment import load_model

    model = load_model(model_path)
    network = tuple(int(v) for v in model.config.image_size)
    out = {}
    for split in ("train", "test"):
        index = np.flatnonzero(frames.split == split)
        pred, tgt = predicted_and_true(model, frames, index)
        stats = keypoint_stats(pred, tgt, frames.intrinsics_norm[index], native, network)
        out[split] = stats["all"]
        out[f"{split}_bias_mm"] = float(np.nanmean(np.abs(stats["dz_mm"])))
        if split == "test":
            out["placements"] = placement_errors(pred, frames, index)
            out["placements_ml"] = placement_errors(pred, frames, index, residual_stats_of(model, frames)[0])
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--data", type=Path, required=True, help="labelled dataset (paper-sim)")
    ap.add_argument("--variants", nargs="+", default=list(DEFAULT_VARIANTS))
    ap.add_argument("--jobs", type=int, default=2, help="variants trained at a time")
    ap.add_argument("--threads", type=int, default=1, help="torch threads per variant")
    ap.add_argument(
        "--average-epochs", type=int, default=0, help="every variant averages its weights over this many last epochs"
    )
    ap.add_argument(
        "--shift-px", type=int, default=0, help="every variant trains on images shifted by up to this many pixels"
    )
    ap.add_argument(
        "--link-fractions",
        type=float,
        nargs="*",
        default=None,
        help="keypoints along the long links at these fractions (handeye.robot.model.LINK_FRACTIONS; none given: "
        "no such keypoints, the set before they were added); default: the robot's",
    )
    ap.add_argument(
        "--strategy",
        choices=("batch", "reservoir"),
        default="batch",
        help="the strategy each variant trains (reservoir: region by region, the final model measured)",
    )
    ap.add_argument(
        "--later-epochs", type=int, default=None, help="epochs of each later training call (default: the preset's)"
    )
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--work", type=Path, default=Path("runs/keypoint_training"), help="where the models go")
    ap.add_argument("--out", type=Path, help="also write the report here")
    ap.add_argument(
        "--measure-only",
        action="store_true",
        help="measure the models an earlier run left in --work (same variants, same order), train nothing",
    )
    args = ap.parse_args(argv)
    for spec in args.variants:
        try:
            _fields(spec)
        except ValueError as exc:
            ap.error(str(exc))
    import torch

    rep = Report(
        f"Keypoint model: what moves its error ({args.data.name}, {args.strategy} strategy, 1 repeat per variant)",
        "benchmarks/keypoint_training.py",
        argv,
        f"torch {torch.__version__}, numpy {np.__version__}",
    )
    emit = rep.say
    dirs = {spec: args.work / f"v{i}" for i, spec in enumerate(args.variants)}
    seconds = {}
    if not args.measure_only:
        with ProcessPoolExecutor(args.jobs) as pool:
            futures = [
                pool.submit(
                    _train,
                    args.data,
                    spec,
                    dirs[spec],
                    args.seed,
                    args.threads,
                    args.average_epochs,
                    args.shift_px,
                    args.link_fractions,
                    args.strategy,
                    args.later_epochs,
                )
                for spec in args.variants
            ]
            seconds = dict(f.result() for f in futures)
    emit(
        "Keypoint errors: medians over the frames' keypoints in view, network input pixels; depth bias: the mean "
        "over keypoints of |median signed depth error|. Placements: the 24 test placements, one pose each from "
        "all its frames, against the truth, by the 3-D to 3-D fit and by the likelihood fit (offsets removed, "
        f"each keypoint weighed by the model's training sigmas). Training times with {args.jobs} variants at a time, "
        f"{args.threads} thread(s) each; seed {args.seed}; weights averaged over the last {args.average_epochs} "
        f"epochs (0: not averaged); training images shifted by up to {args.shift_px} pixels (0: not shifted)."
    )
    import handeye.robot.model

    _use_link_fractions(args.link_fractions)
    from learned.presets import get_preset

    later = args.later_epochs or get_preset("cpu").keypoint_epochs[1]
    emit(
        f"Keypoints along the long links at fractions {handeye.robot.model.LINK_FRACTIONS}; strategy {args.strategy}, "
        f"later training calls {later} epochs."
    )
    emit()
    emit(
        "| variant | input px | width | trunk | epochs | batch | schedule | spread weight | train px | test px | "
        "native px, test | train / test depth bias mm | placement median mm / deg | worst mm / deg | "
        "likelihood fit median / worst mm | train s |"
    )
    emit("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    from handeye.core.dataset import Dataset
    from handeye.learned_frames import load_keypoint_frames

    meta = Dataset.open(args.data).meta["intrinsics"]
    native = (int(meta["width"]), int(meta["height"]))
    frames = {}  # per input size, read once for all its variants
    for spec in args.variants:
        name, width, epochs, schedule, spread, size, batch, dtype = _fields(spec)
        if size not in frames:
            frames[size] = load_keypoint_frames(args.data, (size, size), progress=False)
        m = _measure(frames[size], native, dirs[spec] / args.strategy / "keypoints.pt")
        p, q = m["placements"], m["placements_ml"]
        ml = f"{np.median(q[:, 0]):.1f} / {q[:, 0].max():.1f}"
        emit(
            f"| {name} | {size} | {width} | {dtype} | {epochs} | {batch} | {schedule} | {spread} | "
            f"{m['train']['px_network']:.2f} | {m['test']['px_network']:.2f} | {m['test']['px_native']:.1f} | "
            f"{m['train_bias_mm']:.1f} / {m['test_bias_mm']:.1f} | "
            f"{np.median(p[:, 0]):.1f} / {np.median(p[:, 1]):.2f} | {p[:, 0].max():.1f} / {p[:, 1].max():.2f} | {ml} | "
            f"{f'{seconds[spec]:.0f}' if spec in seconds else '- (measured only)'} |"
        )
    return rep.write(args.out)


if __name__ == "__main__":
    sys.exit(main())
