"""The paper's protocol: strategies x networks x repeats over region time steps, evaluated on every test subset.

Per strategy, network and repeat: the time-step x test-subset matrix of mean
test error (paper tables 3-8), data and compute (table 11: samples stored,
samples processed, wall time, poses skipped), and per test camera pose the
learned prediction (frame predictions averaged) against the classic label and
the truth. Written to ``<out>/results.json``; the last repeat's networks to
``<out>/<strategy>/<network>.pt``.
"""

from __future__ import annotations

import json
import sys
import time
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from typing import NamedTuple

import numpy as np
import torch

from handeye.core.errors import HandEyeInputError
from handeye.core.safe_write import write_text_atomic
from learned import distributed
from learned.checkpoint import CHECKPOINT_NAME, fingerprint, load_checkpoint, remove_checkpoint, save_checkpoint
from learned.data import FrameSet, load_frames
from learned.metrics import rotation_errors_deg, summarize, translation_errors_mm
from learned.model import KINDS, CalibrationNet, ModelConfig, load_weights, make_network
from learned.presets import PRESETS, Preset, get_preset
from learned.safe_io import load_document, save_document
from learned.strategies import STRATEGIES, make_strategy
from learned.trainer import default_device, errors, placement_error, predict

__all__ = [
    "Preset",
    "PRESETS",
    "get_preset",
    "FAMILIES",
    "ExperimentOptions",
    "run_experiment",
    "camera_predictions",
    "keypoint_camera_predictions",
    "save_model",
    "load_model",
]


def time_steps(frames: FrameSet) -> list[list[int]]:
    """Training camera poses per region, in region order (the time steps S1, S2, ...)."""
    steps = []
    for r in np.unique(frames.region):
        cams = np.unique(frames.camera[(frames.region == r) & (frames.split == "train")])
        steps.append([int(c) for c in cams])
    return steps


def _json_error(e):
    """A subset error as a JSON value: a float, or ``[mm, deg]`` (the keypoint model)."""
    return float(e) if np.ndim(e) == 0 else [float(v) for v in np.ravel(e)]


def _subset_error(model: CalibrationNet, frames: FrameSet, region: int):
    """Mean and root-mean-square test error of a region (the RMS is the paper's metric): floats, or ``[mm, deg]``
    each for the keypoint model."""
    idx = np.flatnonzero((frames.region == region) & (frames.split == "test"))
    if not len(idx):
        nan = float("nan") if model.config.kind != "keypoints" else np.full(2, np.nan)
        return nan, nan
    e = errors(model, frames, idx)
    if e.ndim == 1:
        return float(np.mean(e)), float(np.sqrt(np.mean(e**2)))
    return e.mean(axis=0), np.sqrt((e**2).mean(axis=0))


def _subset_placement_error(model: CalibrationNet, frames: FrameSet, region: int, trained: bool = True):
    """``[mm, deg]``: the median over a region's test placements of the keypoint model's placement error."""
    cams = np.unique(frames.camera[(frames.region == region) & (frames.split == "test")])
    if not trained or not len(cams):
        return np.full(2, np.nan)
    e = np.array([placement_error(model, frames, np.flatnonzero(frames.camera == c)) for c in cams])
    return np.median(e, axis=0)


def average_quaternions(q_xyzw: np.ndarray) -> np.ndarray:
    """Mean rotation of unit quaternions x, y, z, w (eigenvector of the largest eigenvalue of sum q q^T), w >= 0."""
    _, v = np.linalg.eigh(np.einsum("ni,nj->ij", q_xyzw, q_xyzw))
    m = v[:, -1]
    return m if m[3] >= 0 else -m


def camera_pose_prediction(
    t_model: CalibrationNet, q_model: CalibrationNet, frames: FrameSet, camera: int
) -> tuple[np.ndarray, np.ndarray]:
    """The learned ``T_base_cam`` of one camera pose: its frames' predictions averaged.

    Returns
    -------
    t_base_cam_mm : array, shape (3,)
        Translation, millimetres.
    q_base_cam_xyzw : array, shape (4,)
        Rotation, quaternion (x, y, z, w), w >= 0.
    """
    idx = np.flatnonzero(frames.camera == camera)
    if len(idx) == 0:
        raise HandEyeInputError(f"no frames of camera {camera}")
    return predict(t_model, frames, idx).mean(axis=0), average_quaternions(predict(q_model, frames, idx))


def _per_camera_rows(frames: FrameSet, cameras: list[int], predict_camera) -> dict:
    """The per-camera comparison table, whatever the model: ``predict_camera(idx)`` gives the pose's
    ``(t_mm (3,), q_xyzw (4,))`` and its frames' own ``(t_mm (n, 3), q_xyzw (n, 4))``."""
    out = {
        k: []
        for k in (
            "camera",
            "region",
            "learned_vs_label_mm",
            "learned_vs_label_deg",
            "learned_vs_truth_mm",
            "learned_vs_truth_deg",
            "label_vs_truth_mm",
            "label_vs_truth_deg",
            "per_frame_vs_label_mm",
            "per_frame_vs_label_deg",
        )
    }
    for c in cameras:
        idx = np.flatnonzero(frames.camera == c)
        (t, q), (t_frames, q_frames) = predict_camera(idx)
        k = idx[0]
        lab_t, lab_q = frames.t_base_cam_mm[k], frames.q_base_cam_xyzw[k]
        tru_t, tru_q = frames.truth_t_base_cam_mm[k], frames.truth_q_base_cam_xyzw[k]
        out["camera"].append(int(c))
        out["region"].append(int(frames.region[k]))
        for name, (ref_t, ref_q) in (("learned_vs_label", (lab_t, lab_q)), ("learned_vs_truth", (tru_t, tru_q))):
            out[f"{name}_mm"].append(float(translation_errors_mm(t, ref_t)))
            out[f"{name}_deg"].append(float(rotation_errors_deg(q[None], ref_q[None])[0]))
        out["label_vs_truth_mm"].append(float(translation_errors_mm(lab_t, tru_t)))
        out["label_vs_truth_deg"].append(float(rotation_errors_deg(lab_q[None], tru_q[None])[0]))
        n = len(t_frames)
        out["per_frame_vs_label_mm"].append(
            float(np.mean(translation_errors_mm(t_frames, np.broadcast_to(lab_t, (n, 3))))) if n else float("nan")
        )
        out["per_frame_vs_label_deg"].append(
            float(np.mean(rotation_errors_deg(q_frames, np.broadcast_to(lab_q, (n, 4))))) if n else float("nan")
        )
    return out


def keypoint_camera_predictions(model, frames: FrameSet, cameras: list[int]) -> dict:
    """As :func:`camera_predictions`, for the keypoint model: one pose per camera from all its frames' keypoints.

    The pose is the fit of every frame's predicted keypoints to their base-frame positions, weighed by
    the model's residual statistics (:func:`learned.keypoints.camera_pose`); the per-frame columns use
    each frame's own fit (:func:`learned.keypoints.frame_poses`, the same statistics; frames with fewer
    than three usable keypoints left out).
    """
    from handeye.core.se3 import quat_xyzw_from_matrix
    from learned.keypoints import camera_pose, frame_poses, model_residual_stats

    stats = model_residual_stats(model)

    def predict_camera(idx):
        pred = predict(model, frames, idx)
        T, _ = camera_pose(pred, frames.keypoints_base[idx], frames.intrinsics_norm[idx], stats=stats)
        T_frames = frame_poses(pred, frames.keypoints_base[idx], frames.intrinsics_norm[idx], stats)
        T_frames = T_frames[np.isfinite(T_frames).all(axis=(1, 2))]
        return (
            (T[:3, 3] * 1000.0, quat_xyzw_from_matrix(T[:3, :3])),
            (T_frames[:, :3, 3] * 1000.0, quat_xyzw_from_matrix(T_frames[:, :3, :3])),
        )

    return _per_camera_rows(frames, cameras, predict_camera)


def camera_predictions(t_model: CalibrationNet, q_model: CalibrationNet, frames: FrameSet, cameras: list[int]) -> dict:
    """Per camera pose: the learned ``T_base_cam`` (frame predictions averaged) against label and truth.

    Returns
    -------
    dict
        Lists per camera: ``camera``, ``region``, ``learned_vs_label_mm/deg``, ``learned_vs_truth_mm/deg``,
        ``label_vs_truth_mm/deg``, ``per_frame_vs_label_mm/deg`` (mean over the pose's frames).
    """

    def predict_camera(idx):
        t, q = predict(t_model, frames, idx), predict(q_model, frames, idx)
        return (t.mean(axis=0), average_quaternions(q)), (t, q)

    return _per_camera_rows(frames, cameras, predict_camera)


#: Model files: tensors and JSON only (:mod:`learned.safe_io`); version 1 files were pickled.
MODEL_FILE_VERSION = 2


def save_model(model: CalibrationNet, path: Path, meta: dict | None = None) -> None:
    """Weights with their config (and any metrics) in one file."""
    save_document(
        path,
        "model",
        MODEL_FILE_VERSION,
        {"config": model.config.to_dict(), "state_dict": dict(model.state_dict()), "meta": meta or {}},
    )


def load_model(path: str | Path, expect: ModelConfig | None = None) -> CalibrationNet:
    """A network saved by :func:`save_model`; with ``expect``, refuse another config.

    Raises
    ------
    HandEyeInputError
        Missing file, or a config other than ``expect`` (naming the fields that differ).
    """
    path = Path(path)
    doc = load_document(path, "model", MODEL_FILE_VERSION)
    config = ModelConfig.from_dict(doc["config"])
    if expect is not None and config != expect:
        diff = [k for k in asdict(config) if getattr(config, k) != getattr(expect, k)]
        what = ", ".join(f"{k}: saved {getattr(config, k)}, expected {getattr(expect, k)}" for k in diff)
        raise HandEyeInputError(f"{path}: saved with another config ({what})")
    model = make_network(config)
    load_weights(model, doc["state_dict"])
    model.eval()
    return model


@dataclass
class RunRecord:
    """One strategy, network and repeat.

    ``processed``: samples trained on, epochs times training-set sizes; ``trained_samples``: the training-set
    sizes summed over the training calls, epochs aside (the seed paper's "data", Tables 2, 11 and 21).

    ``placements``: for the keypoint model, this repeat's model on the test camera placements, one pose
    each from all its frames against the truth: ``median_mm``, ``worst_mm``, ``median_deg``, ``worst_deg``
    (the per-camera tables show the last repeat's model only; one training run's median varies by
    millimetres, so the report gives every repeat's). ``placement_matrix``: for the keypoint model, as
    ``matrix`` but each cell the median over the subset's test placements of the one pose from all its
    frames against the label (:func:`learned.trainer.placement_error`), where the per-frame errors are
    far above the placements' (the forgetting finding, checked where the errors are of its thresholds'
    order). ``rmse_matrix``: as ``matrix`` with each cell the root-mean-square of the subset's per-frame errors,
    the seed paper's metric (``matrix`` holds their mean). ``pose_matrix``: selection with the preset's
    ``pose_steps`` (the paper's Tables 17-18), one entry per camera pose after the first time step:
    ``{"camera", "novel", "matrix", "rmse_matrix"}``, the rows as in ``matrix`` and ``rmse_matrix``, after that
    pose.
    """

    strategy: str
    network: str
    repeat: int
    matrix: list = field(default_factory=list)
    processed: int = 0
    stored: int = 0
    trained_samples: int = 0
    evaluated: int = 0
    skipped: list = field(default_factory=list)
    wall_s: float = 0.0
    placements: dict = field(default_factory=dict)
    placement_matrix: list = field(default_factory=list)
    rmse_matrix: list = field(default_factory=list)
    pose_matrix: list = field(default_factory=list)


FAMILIES = ("regression", "keypoints")


def _split_keypoint_record(rec: "RunRecord") -> list:
    """The keypoint model's record as the tables' two rows: translation (mm) and orientation (deg) errors.

    One network gives both, so both rows carry the same samples, buffer and wall time.
    """
    out, per_pose = [], ("matrix", "rmse_matrix")
    for col, network in enumerate(("translation", "orientation")):
        fields = {k: _column(getattr(rec, k), col) for k in ("matrix", "placement_matrix", "rmse_matrix")}
        fields["pose_matrix"] = [{**p, **{k: _column([p[k]], col)[0] for k in per_pose}} for p in rec.pose_matrix]
        out.append(replace(rec, network=network, skipped=list(rec.skipped), placements=dict(rec.placements), **fields))
    return out


def _column(rows: list, col: int) -> list:
    """Column ``col`` (0: mm, 1: deg) of rows of subset errors; a scalar (NaN where batch has not trained) as it is."""
    return [[float(np.ravel(e)[col]) if np.ndim(e) else float(e) for e in row] for row in rows]


def _pose_recorder(strat, frames: FrameSet, regions: list, rec: "RunRecord"):
    """Selection's ``after_pose``: the error on every test subset after each camera pose, into ``rec.pose_matrix``."""

    def record(camera: int, novel: bool) -> None:
        cells = [_subset_error(strat.model, frames, r) for r in regions]
        rec.pose_matrix.append(
            {
                "camera": camera,
                "novel": novel,
                "matrix": [_json_error(mean) for mean, _ in cells],
                "rmse_matrix": [_json_error(rms) for _, rms in cells],
            }
        )

    return record


def _replicated_state(strat) -> bytes:
    """What must be the same on every rank after a time step: generator, replay buffer, weights and buffers."""
    buffer = strat.buffer.state_dict()
    parts = [
        json.dumps(strat.rng.bit_generator.state).encode(),
        json.dumps(buffer["meta"], sort_keys=True).encode(),
        *(t.numpy().tobytes() for _, t in sorted(buffer["tensors"].items())),
        *(t.detach().cpu().numpy().tobytes() for t in strat.model.state_dict().values()),
    ]
    return b"\0".join(parts)


@dataclass(frozen=True, kw_only=True)
class ExperimentOptions:
    """What :func:`run_experiment` trains on and with, its seed, and whether it resumes.

    Attributes
    ----------
    labels : {"classic", "truth"}
        Training targets.
    seed : int
        Repeat r uses ``default_rng([seed, r, strategy index, network index])``.
    family : {"regression", "keypoints"}
        The paper's two networks (translation, orientation), or the equivariant keypoint model
        (:mod:`learned.keypoints`; the frames must carry ``keypoints_base``). The keypoint model is one
        network whose poses give both the translation and the orientation rows of every table.
    resume : bool
        Resume from ``<out>/checkpoint.pt`` when there is one (one of another run is refused);
        ``False`` discards it and starts over.
    """

    labels: str = "classic"
    seed: int = 0
    family: str = "regression"
    resume: bool = True


def run_experiment(
    data: str | Path | FrameSet,
    preset: str | Preset = "cpu",
    strategies=("batch", "naive", "reservoir", "selection"),
    out: str | Path | None = None,
    *,
    progress: bool = True,
    threads: int | None = None,
    options: ExperimentOptions | None = None,
) -> dict:
    """Run the protocol; write ``results.json`` and the last repeat's networks under ``out``.

    With ``out``, a checkpoint (:mod:`learned.checkpoint`) is written after every time step of every
    strategy, network and repeat, and removed when ``results.json`` is written; a run killed at any
    point and started again with the same arguments resumes from it and ends with the results an
    uninterrupted run gives (same seed and threads; wall times aside).

    Parameters
    ----------
    data : path of a labelled dataset, or a FrameSet
    preset : str or Preset
    strategies : iterable of str
    out : path, optional
    progress : bool
    threads : int, optional
        torch CPU threads.
    options : ExperimentOptions, optional
        The training targets (classic labels or the truth), the seed, the model family (the paper's
        regression networks or the keypoint model) and whether a checkpoint is resumed; None:
        :class:`ExperimentOptions`' defaults.

    Returns
    -------
    dict
        The results (as written to ``results.json``).

    Notes
    -----
    Under ``torchrun`` (:mod:`learned.distributed`) every rank runs the whole protocol with the
    same seeds, training data-parallel (:func:`learned.trainer.train`) and evaluating on its own; the
    generators, replay buffers and weights are checked to be the same on every rank after every
    time step, and only rank 0 writes (checkpoints, networks, ``results.json``). A checkpoint
    resumes with any number of processes; the exact equality of a resumed run with an uninterrupted
    one holds for the same number of processes (others agree to float32 rounding).
    """
    options = options or ExperimentOptions()
    labels, seed, family, resume = options.labels, options.seed, options.family, options.resume
    preset, strategies = _checked_arguments(preset, strategies, family)
    progress = progress and distributed.is_writer()
    if threads:
        torch.set_num_threads(threads)
    frames = _frames_of(data, preset, labels, family, progress)
    run = _Run(preset, strategies, family, labels, seed, progress, frames, out)
    state = _checkpoint_state(run, resume)
    records, validation = _train_all(run, state)
    results = _results(run, records, validation)
    _write_results(run, results)
    return results


# -- the stages of run_experiment(), in its order


def _checked_arguments(preset, strategies, family: str) -> tuple[Preset, list]:
    """The preset by name and the strategies as a list; an unknown family or strategy raises."""
    preset = get_preset(preset) if isinstance(preset, str) else preset
    if family not in FAMILIES:
        raise HandEyeInputError(f"unknown model family {family!r}: use {', '.join(FAMILIES)}")
    strategies = list(strategies)
    unknown = [s for s in strategies if s not in STRATEGIES]
    if unknown:
        raise HandEyeInputError(f"unknown strategies {unknown}: use {', '.join(STRATEGIES)}")
    return preset, strategies


def _frames_of(data, preset: Preset, labels: str, family: str, progress: bool) -> FrameSet:
    """The frames (read at the preset's size when ``data`` is a path); frames of another size are refused."""
    size = preset.frame_size(family)
    frames = data if isinstance(data, FrameSet) else load_frames(data, size, labels, progress=progress)
    if tuple(frames.image_size) != size:
        raise HandEyeInputError(f"frames are {frames.image_size}, preset {preset.name} needs {size} for {family}")
    return frames


@dataclass
class _Run:
    """What every stage of :func:`run_experiment` reads: its arguments, the frames and what follows from them
    (time steps, test subsets and cameras, the networks to train, the run's fingerprint), where it writes."""

    preset: Preset
    strategies: list
    family: str
    labels: str
    seed: int
    progress: bool
    frames: FrameSet
    out: str | Path | None
    steps: list = field(init=False)
    regions: list = field(init=False)
    test_cams: list = field(init=False)
    offset_mm: np.ndarray = field(init=False)
    kinds: tuple = field(init=False)
    n_keypoints: int = field(init=False)
    run_id: dict = field(init=False)
    writer: bool = field(init=False)

    def __post_init__(self):
        frames = self.frames
        self.steps = time_steps(frames)
        self.regions = [int(r) for r in np.unique(frames.region)]
        self.test_cams = [int(c) for c in frames.cameras("test")]
        # the translation network's output offset: the first time step's mean camera position (known at step 1)
        self.offset_mm = frames.t_base_cam_mm[np.isin(frames.camera, self.steps[0])].mean(axis=0)
        self.out = Path(self.out) if self.out is not None else None
        self.kinds = KINDS if self.family == "regression" else ("keypoints",)
        self.n_keypoints = frames.keypoints_base.shape[1]
        if self.family == "keypoints" and self.n_keypoints < 3:
            raise HandEyeInputError(
                "the keypoint model needs the keypoints' base-frame positions in the frames "
                "(learned.data.with_keypoints; 'handeye learned run --family keypoints' fills them)"
            )
        self.run_id = fingerprint(
            preset=self.preset.to_dict(),
            strategies=self.strategies,
            labels=self.labels,
            seed=self.seed,
            family=self.family,
            steps=self.steps,
            frames=len(frames),
            test_cameras=self.test_cams,
        )
        self.writer = self.out is not None and distributed.is_writer()  # data-parallel: rank 0 alone writes

    def save_checkpoint(self, unit: int, step: int, records: list, rec=None, strat=None) -> None:
        """A checkpoint (rank 0 alone writes): ``unit`` and ``step`` to go on from, the records so far and,
        within a unit, its record and strategy so far."""
        if not self.writer:
            return
        partial = () if rec is None else (asdict(rec), strat.state_dict())
        save_checkpoint(self.out, self.run_id, unit, step, [asdict(r) for r in records], *partial)


class _Unit(NamedTuple):
    """One strategy, network and repeat: its place in the run, the names and indices that seed it."""

    index: int
    strategy_index: int
    strategy: str
    kind_index: int
    kind: str
    repeat: int


def _checkpoint_state(run: _Run, resume: bool) -> dict | None:
    """The checkpoint to resume from (None without one, or with ``resume`` False: removed), read by every rank;
    torch seeded for the first network when starting afresh."""
    state = None
    if run.out is not None:
        if run.writer and not resume:
            remove_checkpoint(run.out)
        distributed.barrier()  # removed before any rank reads
        state = load_checkpoint(run.out, run.run_id)
        distributed.barrier()  # read by every rank before rank 0 writes the next one
    if state is not None and run.progress:
        print(f"resuming from {run.out / CHECKPOINT_NAME}: {len(state['records'])} runs done", file=sys.stderr)
    if state is None:
        torch.manual_seed(run.seed)  # the first network's initial weights; torch seeds itself at random otherwise
    return state


def _units(run: _Run) -> list[_Unit]:
    """Every strategy, network and repeat, in the order they run."""
    units = [
        (si, name, ki, kind, rep)
        for si, name in enumerate(run.strategies)
        for ki, kind in enumerate(run.kinds)
        for rep in range(run.preset.repeats)
    ]
    return [_Unit(u, *unit) for u, unit in enumerate(units)]


def _train_all(run: _Run, state: dict | None) -> tuple[list, dict]:
    """Every unit from the checkpoint's on: the records (the checkpoint's first), and the last repeat's networks
    per strategy and network (those finished before read from disk)."""
    records = [RunRecord(**r) for r in state["records"]] if state else []
    validation = {}
    for unit in _units(run):
        done = bool(state) and unit.index < state["unit"]
        if done and unit.repeat == run.preset.repeats - 1:  # finished before: its network is on disk
            path = run.out / unit.strategy / f"{unit.kind}.pt"
            validation.setdefault(unit.strategy, {})[unit.kind] = load_model(path).to(default_device())
        if not done:
            resumed = state if state and unit.index == state["unit"] else None
            _train_unit(run, unit, resumed, records, validation)
    return records, validation


def _train_unit(run: _Run, unit: _Unit, resumed: dict | None, records: list, validation: dict) -> None:
    """One unit's time steps (from the checkpoint's step when ``resumed``), each recorded and checkpointed;
    its records appended to ``records``, its network (last repeat) to ``validation``."""
    if resumed:  # as it was when the checkpoint was written (loading networks drew)
        torch.set_rng_state(resumed["torch_rng"])
    strat = _strategy(run, unit)
    rec, start = RunRecord(unit.strategy, unit.kind, unit.repeat), 0
    if resumed and resumed.get("strategy"):
        strat.load_state_dict(resumed["strategy"])
        torch.set_rng_state(resumed["torch_rng"])
        rec, start = RunRecord(**resumed["partial"]), resumed["step"]
    if unit.strategy == "selection" and run.preset.pose_steps:
        strat.after_pose = _pose_recorder(strat, run.frames, run.regions, rec)
    t0, spent = time.perf_counter(), rec.wall_s
    for k in range(start, len(run.steps)):
        last = k == len(run.steps) - 1
        strat.step(k, run.steps[k], run.frames, last=last)
        if distributed.world_size() > 1:
            distributed.check_same(
                _replicated_state(strat), f"{unit.strategy} {unit.kind} repeat {unit.repeat + 1} step {k + 1}"
            )
        _record_step(run, unit, strat, rec, k)
        rec.wall_s = spent + time.perf_counter() - t0
        _print_step(run, unit, rec, k)
        if not last:
            run.save_checkpoint(unit.index, k + 1, records, rec, strat)
        else:
            _finish_unit(run, unit, strat, rec, records, validation)


def _strategy(run: _Run, unit: _Unit):
    """The unit's strategy, its network fresh, its generator ``default_rng([seed, repeat, strategy, network])``."""
    preset = run.preset
    rng = np.random.default_rng([run.seed, unit.repeat, unit.strategy_index, unit.kind_index])
    first, later = preset.train_configs(unit.strategy, unit.kind, int((run.frames.split == "train").sum()))
    return make_strategy(
        unit.strategy,
        preset.model_config(unit.kind, run.offset_mm, run.n_keypoints),
        first,
        later,
        rng,
        run.progress,
        c1=preset.c1,
        c2=preset.c2,
        c3=preset.c3,
        threshold_mm=preset.threshold_mm,
        threshold_deg=preset.threshold_deg,
        replay_share=preset.selection_replay,
        novelty=preset.selection_novelty,
        sampling=preset.sampling,
        every_step=preset.batch_every_step,
    )


def _record_step(run: _Run, unit: _Unit, strat, rec: RunRecord, k: int) -> None:
    """After time step ``k``: the error on every test subset (NaN where batch has not trained yet) and the
    strategy's counts, into ``rec``."""
    frames, regions = run.frames, run.regions
    trained = unit.strategy != "batch" or run.preset.batch_every_step or k == len(run.steps) - 1
    cells = [_subset_error(strat.model, frames, r) if trained else (float("nan"),) * 2 for r in regions]
    rec.matrix.append([_json_error(mean) for mean, _ in cells])
    rec.rmse_matrix.append([_json_error(rms) for _, rms in cells])
    if unit.kind == "keypoints":
        rec.placement_matrix.append(
            [_json_error(_subset_placement_error(strat.model, frames, r, trained)) for r in regions]
        )
    rec.processed, rec.stored, rec.evaluated = strat.processed, strat.stored, strat.evaluated
    rec.trained_samples = strat.trained_samples
    rec.skipped = list(strat.skipped)


def _print_step(run: _Run, unit: _Unit, rec: RunRecord, k: int) -> None:
    """With ``progress``, the step's error per test subset (the first column for the keypoint model) on stderr."""
    if run.progress:
        row = " ".join(f"S{r + 1} {np.ravel(e)[0]:7.2f}" for r, e in zip(run.regions, rec.matrix[-1]))
        print(f"{unit.strategy:9s} {unit.kind:11s} repeat {unit.repeat + 1} step {k + 1}: {row}", file=sys.stderr)


def _finish_unit(run: _Run, unit: _Unit, strat, rec: RunRecord, records: list, validation: dict) -> None:
    """A unit done: the keypoint model's test placements, its records, its network (last repeat: kept for the
    validation and saved) and a checkpoint."""
    if unit.kind == "keypoints":
        pc = keypoint_camera_predictions(strat.model, run.frames, run.test_cams)
        t_mm, r_deg = np.asarray(pc["learned_vs_truth_mm"]), np.asarray(pc["learned_vs_truth_deg"])
        rec.placements = {
            "median_mm": float(np.median(t_mm)),
            "worst_mm": float(t_mm.max()),
            "median_deg": float(np.median(r_deg)),
            "worst_deg": float(r_deg.max()),
        }
    records += _split_keypoint_record(rec) if unit.kind == "keypoints" else [rec]
    if unit.repeat == run.preset.repeats - 1:
        validation.setdefault(unit.strategy, {})[unit.kind] = strat.model
        if run.writer:
            meta = {"preset": run.preset.name, "labels": run.labels, "seed": run.seed}
            save_model(strat.model, run.out / unit.strategy / f"{unit.kind}.pt", meta)
    run.save_checkpoint(unit.index + 1, 0, records)


def _per_camera(run: _Run, validation: dict) -> tuple[dict, dict]:
    """Per strategy, its last networks on the test camera poses (:func:`camera_predictions`) and their
    inference times."""
    frames, test_cams = run.frames, run.test_cams
    per_camera, inference = {}, {}
    test_idx = np.flatnonzero(frames.split == "test")
    for name, m in validation.items():
        t0 = time.perf_counter()
        for net in m.values():
            predict(net, frames, test_idx)
        per_frame_ms = (time.perf_counter() - t0) / max(len(test_idx), 1) * 1e3
        t0 = time.perf_counter()
        if run.family == "keypoints":
            per_camera[name] = keypoint_camera_predictions(m["keypoints"], frames, test_cams)
        else:
            per_camera[name] = camera_predictions(m["translation"], m["orientation"], frames, test_cams)
        inference[name] = {
            "per_frame_ms": per_frame_ms,
            "per_camera_ms": (time.perf_counter() - t0) / max(len(test_cams), 1) * 1e3,
            "frames_per_camera": len(test_idx) / max(len(test_cams), 1),
            "device": str(default_device()),
            "threads": torch.get_num_threads(),
        }
    return per_camera, inference


def _summary(run: _Run, validation: dict) -> dict:
    """Per strategy and network, the last networks' per-frame test errors summarised."""
    test_idx = np.flatnonzero(run.frames.split == "test")
    if run.family == "keypoints":
        summary = {}
        for name, m in validation.items():
            e = errors(m["keypoints"], run.frames, test_idx)
            summary[name] = {"translation": summarize(e[:, 0]), "orientation": summarize(e[:, 1])}
        return summary
    return {
        name: {kind: summarize(errors(validation[name][kind], run.frames, test_idx)) for kind in KINDS}
        for name in validation
    }


def _results(run: _Run, records: list, validation: dict) -> dict:
    """The results as ``results.json`` holds them."""
    per_camera, inference = _per_camera(run, validation)
    frames = run.frames
    return {
        "preset": run.preset.to_dict(),
        "labels": run.labels,
        "seed": run.seed,
        "family": run.family,
        "regions": run.regions,
        "steps": run.steps,
        "test_cameras": run.test_cams,
        "strategies": run.strategies,
        "runs": [asdict(r) for r in records],
        "per_camera": per_camera,
        "test_frames_per_region": {
            int(r): int(np.sum((frames.region == r) & (frames.split == "test"))) for r in run.regions
        },
        "summary": _summary(run, validation),
        "inference": inference,
        "world_size": distributed.world_size(),
    }


def _write_results(run: _Run, results: dict) -> None:
    """``results.json`` written (rank 0) and the checkpoint removed; every rank returns once it is written."""
    if run.writer:
        run.out.mkdir(parents=True, exist_ok=True)
        write_text_atomic(run.out / "results.json", json.dumps(results, indent=1))
        remove_checkpoint(run.out)
    distributed.barrier()  # every rank returns once the results are written
