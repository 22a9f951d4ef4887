"""The paper preset on an accelerator in at most a few minutes: frames prepared here, trained there.

Two steps. Here (the renderer's and the dataset's machine), the frames at the ``paper`` preset's size
written to one file small enough to carry (at most ``--max-mib``, 60 by default; the paper-sim images are
noisy and compress to about 190 kB a frame at 256 x 256, so the file keeps an even spread of a few
frames of each of the dataset's camera poses, the number printed)::

    cp -r data/paper-sim-noisy data/paper-sim-tsai5
    handeye label data/paper-sim-tsai5 --method tsai --repeats 5
    python benchmarks/gpu_paper_run.py frames --data data/paper-sim-tsai5 --out runs/paper_frames.npz

The ``paper`` preset's protocol trains on the paper's labels (Tsai's closed form, 5 repeats averaged, hence
the labelled copy); the frames file keeps the dataset's classic labels, refused when of the other kind than
the preset's protocol trains on (:func:`learned.label_kind.check_labels`; ``--labels truth``: the truth).

There (numpy and torch only: no renderer, Pinocchio or dataset), the training throughput benchmark
(``benchmarks/training_throughput.py`` at the cpu and paper sizes, float32 and bfloat16), then the
``paper`` preset's simulation protocol (bfloat16 encoders), one strategy at a time in the paper's order,
each started only while the time left holds the previous one's wall time; every finished strategy's
``results.json`` and the report are written under ``--out``::

    python benchmarks/gpu_paper_run.py run --frames runs/paper_frames.npz --out "$OUT" --minutes 7

On a machine lent by the project's ``run`` tool: carry the frames file (``carry: ["runs/paper_frames.npz"]``)
and give the command a ``timeout_s`` of about 480. What it prints: per strategy the two networks' mean test
errors over the repeats and the wall time, and the samples per second the protocol achieved; what a
strategy left unfinished is named as not run. The protocol's errors are on the thinned frames (a few of
each camera pose's 50), not the paper's data volume: its wall time, scaled by 50 / frames per pose, is the
full protocol's estimate at the same throughput.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from dataclasses import replace
from pathlib import Path

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

from benchmarks._report import Report  # noqa: E402

#: The strategies in the order they run: the baseline first (the others are judged against it).
ORDER = ("batch", "naive", "reservoir", "selection")

#: Frames of a camera pose in the paper-sim dataset (``handeye sim generate --preset paper-sim``).
FRAMES_PER_POSE = 50


def write_frames(data: Path, out: Path, preset_name: str, labels: str, max_mib: float, per_camera: int | None) -> str:
    """The frames step: read ``data`` at the preset's size, keep what fits in ``max_mib``, write ``out``.

    The frames per camera pose are ``per_camera`` when given, else the most whose compressed size (measured
    on the first camera pose's frames) fits with a 5 % margin; frames that still come out larger are refused
    with ``out`` left as it was (sizes are measured in memory, the file written once). Returns the line to print.
    """
    from handeye.core.errors import HandEyeInputError
    from handeye.core.safe_write import check_output_path, write_bytes_atomic
    from learned.data import load_frames
    from learned.frames_file import frames_bytes, thin_frames
    from learned.label_kind import check_labels
    from learned.presets import get_preset

    preset = get_preset(preset_name)
    check_output_path(out)  # before the dataset is read
    check_labels(preset, data, labels)  # the paper's protocol on the paper's labels, as 'handeye learned run'
    size = preset.frame_size("regression")
    frames = load_frames(data, size, labels, progress=False)
    cameras = frames.cameras()
    if per_camera is None:
        probe = frames.subset(frames.camera == cameras[0])
        per_frame = len(frames_bytes(probe)) / len(probe)
        per_camera = int(0.95 * max_mib * 2**20 // (per_frame * len(cameras)))
        if per_camera < 1:
            raise HandEyeInputError(f"not one frame per camera pose fits in {max_mib} MiB ({per_frame:.0f} B a frame)")
    thin = thin_frames(frames, per_camera)
    content = frames_bytes(thin)
    n = len(content)
    if n > max_mib * 2**20:
        raise HandEyeInputError(f"{out}: {n / 2**20:.1f} MiB is over {max_mib} MiB; ask for fewer --per-camera")
    write_bytes_atomic(out, content)
    return (
        f"written {out}: {len(thin)} frames ({per_camera} of each of {len(cameras)} camera poses) at "
        f"{size[0]}x{size[1]}, labels {labels}, {n / 2**20:.1f} MiB"
    )


def _summary(results: dict) -> str:
    """A finished strategy's mean test error of each network, over the repeats, as one phrase."""
    parts = []
    for strategy, kinds in results["summary"].items():
        for kind, s in kinds.items():
            unit = "mm" if kind == "translation" else "deg"
            parts.append(f"{strategy} {kind} {s['mean']:.4g} {unit}")
    return "; ".join(parts)


def run_protocol(frames_path: Path, out: Path, args, report: Report, deadline: float) -> None:
    """The paper preset's protocol on the frames file, one strategy at a time while the time holds."""
    import torch

    from learned.experiment import ExperimentOptions, run_experiment
    from learned.frames_file import read_frames
    from learned.presets import get_preset

    frames = read_frames(frames_path)
    preset = replace(get_preset(args.preset), trunk_dtype=args.dtype, compile=args.compile)
    if args.repeats:
        preset = replace(preset, repeats=args.repeats)
    per_pose = len(frames) / len(frames.cameras())
    report.say(
        f"protocol: preset {preset.name} ({preset.protocol} mode), {preset.image_size[0]}x{preset.image_size[1]}, "
        f"encoders {preset.trunk_dtype}, compile {preset.compile}, {preset.repeats} repeats; {len(frames)} frames "
        f"({per_pose:.3g} a camera pose of the dataset's {FRAMES_PER_POSE}), device {_device_name(torch)}"
    )
    last = 0.0
    for strategy in args.strategies:
        left = deadline - time.perf_counter()
        if left < last:
            report.say(f"- {strategy}: not run ({left:.0f} s left, the last strategy took {last:.0f} s)")
            continue
        t0 = time.perf_counter()
        options = ExperimentOptions(seed=args.seed)
        results = run_experiment(frames, preset, [strategy], out=out / strategy, progress=False, options=options)
        last = time.perf_counter() - t0
        processed = sum(r["processed"] for r in results["runs"])
        report.say(
            f"- {strategy}: {_summary(results)}; {last:.1f} s, {processed} samples trained, "
            f"{processed / last:.4g} samples/s; full data ({FRAMES_PER_POSE} a pose) about "
            f"{last * FRAMES_PER_POSE / per_pose / 60:.3g} min"
        )


def _device_name(torch) -> str:
    return torch.cuda.get_device_name() if torch.cuda.is_available() else "CPU"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = ap.add_subparsers(dest="step", required=True)
    fr = sub.add_parser("frames", help="here: write the frames file")
    fr.add_argument("--data", type=Path, required=True, help="a labelled dataset")
    fr.add_argument("--out", type=Path, required=True, help="the frames file (.npz)")
    fr.add_argument("--preset", default="paper", help="the preset whose frame size is read (default paper)")
    fr.add_argument("--labels", default="classic", help="training targets: classic (default) or truth")
    fr.add_argument("--max-mib", type=float, default=60.0, help="the file's largest size (default 60 MiB)")
    fr.add_argument("--per-camera", type=int, help="frames per camera pose (default: the most that fit)")
    rn = sub.add_parser("run", help="there: the throughput benchmark, then the protocol")
    rn.add_argument("--frames", type=Path, required=True, help="the frames file of the frames step")
    rn.add_argument("--out", type=Path, required=True, help="folder of the report and the runs")
    rn.add_argument("--minutes", type=float, default=7.0, help="time for the whole step (default 7)")
    rn.add_argument("--preset", default="paper")
    rn.add_argument("--dtype", default="bfloat16", choices=("float32", "bfloat16"), help="encoders' precision")
    rn.add_argument("--compile", action="store_true", help="train through torch.compile")
    rn.add_argument("--repeats", type=int, help="repeats per strategy (default: the preset's)")
    rn.add_argument("--strategies", nargs="+", default=list(ORDER), choices=ORDER)
    rn.add_argument("--seed", type=int, default=0)
    rn.add_argument("--sizes", nargs="+", default=["cpu", "paper"], help="the throughput benchmark's sizes")
    rn.add_argument("--networks", nargs="+", default=["regression", "keypoints"], help="the benchmark's networks")
    rn.add_argument("--steps", type=int, default=20, help="the throughput benchmark's timed steps per row")
    args = ap.parse_args(argv)
    if args.step == "frames":
        print(write_frames(args.data, args.out, args.preset, args.labels, args.max_mib, args.per_camera))
        return 0
    import torch

    from benchmarks import training_throughput
    from handeye.core.safe_write import write_text_atomic

    deadline = time.perf_counter() + 60 * args.minutes
    torch.backends.cudnn.benchmark = True  # fixed input sizes: let cuDNN pick its fastest convolutions
    args.out.mkdir(parents=True, exist_ok=True)
    bench = ["--sizes", *args.sizes, "--networks", *args.networks, "--steps", str(args.steps)]
    training_throughput.main(bench + ["--out", str(args.out / "training_throughput.md")])
    report = Report(
        "The paper preset on an accelerator", "benchmarks/gpu_paper_run.py", argv, f"torch {torch.__version__}"
    )
    run_protocol(args.frames, args.out, args, report, deadline)
    write_text_atomic(args.out / "args.json", json.dumps({k: str(v) for k, v in vars(args).items()}, indent=1))
    return report.write(str(args.out / "gpu_paper_run.md"))


if __name__ == "__main__":
    sys.exit(main())
