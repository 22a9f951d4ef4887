"""Continual-learning strategies (paper section 3): what each time step trains on.

A strategy owns one network and its buffer and is stepped through the time
steps (one region's training camera poses per step). All randomness comes from
the generator it is given.

- :class:`Batch`: the baseline, trained from scratch on all training data at the
  last time step (the paper's baseline); nothing before.
- :class:`Naive`: fine-tuning on the current step's data only.
- :class:`Reservoir`: Algorithm 1, reservoir buffer with class balance: the
  current step's data (a fraction ``c3``) plus ``c1`` stored samples from each
  of ``c2`` past camera poses (``None``: all); after training, ``c1`` samples
  of each current camera pose join the buffer.
- :class:`Selection`: Algorithm 2, reservoir buffer with class balance and
  camera-pose selection: the first step as :class:`Reservoir`; afterwards
  each camera pose is its own time step: a ``sample_fraction`` sample of its
  frames is evaluated with the current network, and only if the mean error
  exceeds the threshold (mm for translation, degrees for orientation) is the
  pose novel, trained on with the buffer, and added to it; else it is skipped.
  A novel pose's step replays a share of the buffer, ``1 / (poses in its
  region)`` of what :class:`Reservoir` replays per region (at least ``c1``
  samples): a region whose poses are all novel then costs what one reservoir
  step costs, and every skipped pose is saved work, which is what the paper's
  claim that selection processes less data implies. Replaying the whole buffer
  at every pose (``replay_share="all"``, this project's first version) made a
  region of 14 poses cost about five reservoir steps.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from learned.data import FrameSet
from learned.model import CalibrationNet, ModelConfig, make_network
from learned.trainer import TrainConfig, default_device, errors, train

__all__ = ["Strategy", "Batch", "Naive", "Reservoir", "Selection", "STRATEGIES", "make_strategy", "random_fraction",
           "per_camera_sample", "sample_error"]


def random_fraction(index: np.ndarray, fraction: float, rng: np.random.Generator) -> np.ndarray:
    """A random share of ``index`` (at least one), sorted; all of it for ``fraction >= 1`` (no draw)."""
    index = np.asarray(index)
    if fraction >= 1.0:
        return index
    return np.sort(rng.choice(index, max(1, int(round(fraction * len(index)))), replace=False))


def per_camera_sample(index: np.ndarray, camera: np.ndarray, c1: int, rng: np.random.Generator) -> dict:
    """Class balance: up to ``c1`` random entries of ``index`` per camera pose (``camera[index]``), sorted."""
    index = np.asarray(index)
    out = {}
    for c in np.unique(camera[index]):
        idx = index[camera[index] == c]
        out[int(c)] = np.sort(rng.choice(idx, min(c1, len(idx)), replace=False))
    return out


def sample_error(model: CalibrationNet, frames: FrameSet, index: np.ndarray, fraction: float,
                 rng: np.random.Generator):
    """Algorithm 2's novelty measure: mean error of a random ``fraction`` of ``index``, and the sample's size.

    The mean is mm or deg (a float) for the paper's networks, and ``(mm, deg)`` (an array) for the
    keypoint model, whose one network gives both.
    """
    sample = random_fraction(index, fraction, rng)
    e = errors(model, frames, sample)
    return (float(np.mean(e)) if e.ndim == 1 else e.mean(axis=0)), len(sample)


@dataclass
class Strategy:
    """Base: a network, its buffer (camera id -> frame indices) and counters.

    Attributes
    ----------
    config : ModelConfig
    first : TrainConfig
        Training of the first time step (from scratch).
    later : TrainConfig
        Training of each later time step.
    rng : numpy.random.Generator
    model : CalibrationNet
    buffer : dict
        Camera id to stored frame indices.
    processed : int
        Samples processed by training (epochs times training-set sizes).
    evaluated : int
        Samples evaluated for novelty.
    skipped : list of int
        Camera poses judged not novel.
    trained_on : list of list of int
        Per time step, the camera poses whose current data were trained on.
    """

    config: ModelConfig
    first: TrainConfig
    later: TrainConfig
    rng: np.random.Generator
    progress: bool = False
    model: CalibrationNet = field(init=False)
    buffer: dict = field(init=False, default_factory=dict)
    processed: int = field(init=False, default=0)
    evaluated: int = field(init=False, default=0)
    skipped: list = field(init=False, default_factory=list)
    trained_on: list = field(init=False, default_factory=list)
    name = "base"

    def __post_init__(self):
        self.model = make_network(self.config).to(default_device())

    @property
    def stored(self) -> int:
        """Samples held in the buffer."""
        return int(sum(len(v) for v in self.buffer.values()))

    def _frames_of(self, frames: FrameSet, cameras) -> np.ndarray:
        return np.flatnonzero(np.isin(frames.camera, list(cameras)) & (frames.split == "train"))

    def _train(self, frames: FrameSet, index: np.ndarray, step: int) -> None:
        cfg = self.first if step == 0 else self.later
        self.processed += train(self.model, frames, index, cfg, self.rng, self.progress,
                                desc=f"{self.name} {self.config.kind} step {step + 1}")

    def step(self, step: int, cameras: list, frames: FrameSet, last: bool) -> None:
        """Train for one time step (the training camera poses of one region)."""
        raise NotImplementedError


@dataclass
class Batch(Strategy):
    """The baseline: at the last time step, from scratch on all training data seen (nothing before)."""

    seen: list = field(init=False, default_factory=list)
    name = "batch"

    def step(self, step, cameras, frames, last):
        self.seen += list(cameras)
        if last:
            self.model = make_network(self.config).to(default_device())
            self._train(frames, self._frames_of(frames, self.seen), 0)
        self.trained_on.append(list(self.seen) if last else [])

    @property
    def stored(self) -> int:
        return 0  # keeps all the data, not a buffer: reported as the data it trains on


class Naive(Strategy):
    """Fine-tune on the current step's data only."""

    name = "naive"

    def step(self, step, cameras, frames, last):
        self._train(frames, self._frames_of(frames, cameras), step)
        self.trained_on.append(list(cameras))


@dataclass
class Reservoir(Strategy):
    """Algorithm 1: current data (fraction c3) plus c1 samples from each of c2 past camera poses."""

    c1: int = 4
    c2: int | None = None
    c3: float = 1.0
    name = "reservoir"

    def _replay(self) -> np.ndarray:
        past = list(self.buffer)
        if self.c2 is not None and len(past) > self.c2:
            past = list(self.rng.choice(past, self.c2, replace=False))
        return np.concatenate([self.buffer[c] for c in past]) if past else np.zeros(0, int)

    def _current(self, frames, cameras) -> np.ndarray:
        return random_fraction(self._frames_of(frames, cameras), self.c3, self.rng)

    def _store(self, frames, cameras) -> None:
        self.buffer.update(per_camera_sample(self._frames_of(frames, cameras), frames.camera, self.c1, self.rng))

    def step(self, step, cameras, frames, last):
        index = np.concatenate([self._current(frames, cameras), self._replay()])
        self._train(frames, index, step)
        self._store(frames, cameras)
        self.trained_on.append(list(cameras))


@dataclass
class Selection(Reservoir):
    """Algorithm 2: after the first step, each camera pose is a time step, trained on only if novel."""

    threshold_mm: float = 3.0
    threshold_deg: float = 4.0
    sample_fraction: float = 0.1
    replay_share: str = "region"
    name = "selection"

    @property
    def threshold(self):
        if self.config.kind == "keypoints":
            return np.array([self.threshold_mm, self.threshold_deg])
        return self.threshold_mm if self.config.kind == "translation" else self.threshold_deg

    def is_novel(self, frames: FrameSet, camera: int):
        """Mean error of the current network on a random sample of the pose's frames, against the threshold.

        The keypoint model's pose is novel when either its translation or its rotation error is above its
        threshold.
        """
        mean, n = sample_error(self.model, frames, self._frames_of(frames, [camera]), self.sample_fraction, self.rng)
        self.evaluated += n
        return bool(np.any(np.asarray(mean) > self.threshold)), mean

    def step(self, step, cameras, frames, last):
        if step == 0:
            return super().step(step, cameras, frames, last)
        novel = []
        for c in cameras:
            is_novel, _ = self.is_novel(frames, c)
            if not is_novel:
                self.skipped.append(int(c))
                continue
            replay = self._replay()
            if self.replay_share == "region" and len(replay):
                replay = random_fraction(replay, max(1.0 / len(cameras), self.c1 / len(replay)), self.rng)
            index = np.concatenate([self._current(frames, [c]), replay])
            self._train(frames, index, step)
            self._store(frames, [c])
            novel.append(int(c))
        self.trained_on.append(novel)


STRATEGIES = {"batch": Batch, "naive": Naive, "reservoir": Reservoir, "selection": Selection}


def make_strategy(name: str, config: ModelConfig, first: TrainConfig, later: TrainConfig, rng: np.random.Generator,
                  progress: bool = False, **params) -> Strategy:
    """A strategy by name; ``params`` are its own (c1, c2, c3, thresholds), ignored by those without them."""
    if name not in STRATEGIES:
        raise ValueError(f"unknown strategy {name!r}: use {', '.join(STRATEGIES)}")
    cls = STRATEGIES[name]
    own = {k: v for k, v in params.items() if k in getattr(cls, "__dataclass_fields__", {})}
    return cls(config, first, later, rng, progress, **own)
