"""One time step of continual learning with replay, written once (paper Algorithms 1 and 2).

Used by :class:`learned.strategies.Reservoir`, :class:`learned.strategies.Selection` and
:class:`learned.calibrator.ContinualCalibrator`:

1. (Algorithm 2 only) novelty: the mean error of the current network on a random
   ``sample_fraction`` of the new frames; at or below ``threshold`` the step is skipped;
2. the training set: a share ``c3`` of the new frames, then the replay: the buffer's entries of all
   (or ``c2`` random) past camera poses, of which a share is kept (at least ``per_class`` entries);
3. training on it, then the new frames' class-balanced sample joins the buffer.

Random draws, in this order, all from the one generator passed in: novelty sample, ``c3`` share,
``c2`` poses, replay share, training, buffer insertion.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from learned import distributed
from learned.data import FrameSet, concat
from learned.model import CalibrationNet
from learned.replay import ReplayBuffer, random_fraction
from learned.trainer import errors, placement_error

__all__ = ["ReplayRule", "NoveltyRule", "StepOutcome", "sample_error", "training_set", "continual_step"]


@dataclass(frozen=True)
class ReplayRule:
    """What a step replays with its new data.

    Attributes
    ----------
    c2 : int or None
        Past camera poses replayed (``None``: all).
    c3 : float
        Share of the new frames trained on.
    share : float
        Share of the replay kept, at least ``per_class`` entries (1: all of it). Camera-pose selection
        replays ``1 / (poses in the region)`` per pose, so a region costs one reservoir step.
    """

    c2: int | None = None
    c3: float = 1.0
    share: float = 1.0


@dataclass(frozen=True)
class NoveltyRule:
    """Whether a step trains (Algorithm 2's novelty test; the default trains always, Algorithm 1).

    Attributes
    ----------
    threshold : float or array, optional
        Novel when any component of the mean sample error exceeds it; ``None``: always train.
    sample_fraction : float
        Share of the new frames the error is measured on (``measure="frames"``).
    measure : {"frames", "placement"}
        The novelty measure (:func:`sample_error`'s ``novelty``).
    sampling : {"uniform", "normal"}
        How the novelty sample is drawn (the buffer draws as it was made to).
    """

    threshold: float | np.ndarray | None = None
    sample_fraction: float = 0.1
    measure: str = "frames"
    sampling: str = "uniform"


@dataclass(frozen=True)
class StepOutcome:
    """What a step did: ``novel`` (always True without a threshold), the novelty ``sample_error`` (mm or
    deg; ``(mm, deg)`` for the keypoint model; None without a threshold), frames ``evaluated`` for
    novelty and samples ``processed`` by training."""

    novel: bool
    sample_error: float | np.ndarray | None
    evaluated: int
    processed: int


#: How a new camera pose's novelty is measured: ``frames``, the paper's mean per-frame error of a sample;
#: ``placement``, the keypoint model's one pose from all the pose's frames (:func:`learned.trainer.placement_error`).
NOVELTY = ("frames", "placement")


def sample_error(
    model: CalibrationNet,
    frames: FrameSet,
    index: np.ndarray,
    fraction: float,
    rng: np.random.Generator,
    novelty: str = "frames",
    sampling: str = "uniform",
):
    """Algorithm 2's novelty measure, and the number of frames it evaluated.

    ``novelty="frames"``: the mean error of a random ``fraction`` of ``index``, mm or deg (a float) for the
    paper's networks and ``(mm, deg)`` (an array) for the keypoint model, whose one network gives both.
    ``novelty="placement"`` (keypoint model): the error ``(mm, deg)`` of the one pose fitted to all of
    ``index`` (one camera pose's frames; ``fraction`` is not used and nothing is drawn): a pose from a
    10 % sample, five frames, is noise-dominated (a median of 23.6 mm where all 50 frames give 5.4 on
    ``paper-sim``: ``benchmarks/keypoint_errors.py``). ``sampling``: how the sample is drawn
    (:func:`learned.replay.draw`).
    """
    if novelty not in NOVELTY:
        raise ValueError(f"unknown novelty measure {novelty!r}: use {', '.join(NOVELTY)}")
    if novelty == "placement":
        return placement_error(model, frames, index), len(index)
    sample = random_fraction(index, fraction, rng, sampling)
    e = errors(model, frames, sample)
    return (float(np.mean(e)) if e.ndim == 1 else e.mean(axis=0)), len(sample)


def training_set(
    frames: FrameSet, current: np.ndarray, buffer: ReplayBuffer, rng: np.random.Generator, rule: ReplayRule
) -> tuple[FrameSet, np.ndarray]:
    """The new frames' ``c3`` share followed by the replay: ``(frames, index)`` to train on.

    With an index buffer the result indexes ``frames``; with a sample buffer it is a new FrameSet
    (the new frames, then the stored samples) and ``arange`` over it.
    """
    cur = random_fraction(current, rule.c3, rng)
    replay = buffer.replay(rng, rule.c2)
    n = 0 if replay is None else len(replay)
    if rule.share < 1.0 and n:
        fraction = max(rule.share, buffer.per_class / n)
        replay = (
            replay.subset(random_fraction(np.arange(n), fraction, rng))
            if buffer.keep_samples
            else random_fraction(replay, fraction, rng)
        )
    if buffer.keep_samples:
        data = concat([frames.subset(cur), replay])
        return data, np.arange(len(data))
    return frames, np.concatenate([cur, replay])


def continual_step(
    model: CalibrationNet,
    frames: FrameSet,
    current: np.ndarray,
    buffer: ReplayBuffer,
    rng: np.random.Generator,
    rule: ReplayRule,
    train_fn: Callable[[FrameSet, np.ndarray], int],
    novelty: NoveltyRule | None = None,
) -> StepOutcome:
    """Algorithm 2's step (Algorithm 1's without a ``novelty`` threshold) on the new frames ``current``.

    Parameters
    ----------
    model : CalibrationNet
        Judges novelty; ``train_fn`` trains it.
    frames : FrameSet
    current : array of int
        The new frames (indices into ``frames``).
    buffer : ReplayBuffer
    rng : numpy.random.Generator
    rule : ReplayRule
    train_fn : callable ``(frames, index) -> samples processed``
    novelty : NoveltyRule, optional
        The threshold, the sample's share, the measure and how the sample is drawn; None: ``NoveltyRule()``,
        no threshold (always train).

    Returns
    -------
    StepOutcome
    """
    novelty = novelty or NoveltyRule()
    mean, n = None, 0
    if novelty.threshold is not None:
        mean, n = sample_error(model, frames, current, novelty.sample_fraction, rng, novelty.measure, novelty.sampling)
        mean = distributed.from_writer(mean)  # data-parallel: every rank takes rank 0's decision
        if not np.any(np.asarray(mean) > novelty.threshold):
            return StepOutcome(False, mean, n, 0)
    data, index = training_set(frames, current, buffer, rng, rule)
    processed = train_fn(data, index)
    buffer.update(frames, current, rng)
    return StepOutcome(True, mean, n, int(processed))
