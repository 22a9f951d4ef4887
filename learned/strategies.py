"""Continual-learning strategies (paper section 3): what each time step trains on.

A strategy owns one network and its buffer and is stepped through the time
steps (one region's training camera poses per step). All randomness comes from
the generator it is given.

- :class:`Batch`: the baseline, trained from scratch on all training data at the
  last time step; nothing before. With ``every_step`` (the paper's mode), from
  scratch on all the data seen so far at every time step, as the paper's Table 2
  describes its baseline.
- :class:`Naive`: fine-tuning on the current step's data only.
- :class:`Reservoir`: Algorithm 1, reservoir buffer with class balance: the
  current step's data (a fraction ``c3``; the first step all of it, as naive
  trains it, as the paper does) plus ``c1`` stored samples from each of ``c2``
  past camera poses (``None``: all); after training, ``c1`` samples of each
  current camera pose join the buffer.
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
  region of 14 poses cost about five reservoir steps. With ``novelty="placement"``
  (keypoint model) a pose is judged by the one pose fitted to all its frames
  (:func:`learned.trainer.placement_error`) instead of its frames' mean error.
  An ``after_pose(camera, novel)`` callback, when set, is called after each pose (the paper's
  per-pose time steps, its Tables 17-18).

``sampling`` (``uniform`` or the paper's ``normal``, :func:`learned.replay.draw`) decides how the
buffer's entries and the novelty sample are drawn.

The buffer is :class:`learned.replay.ReplayBuffer` (frame indices) and each step of reservoir and
selection is :func:`learned.continual_step.continual_step`, the same code the online
:class:`learned.calibrator.ContinualCalibrator` runs. Its draws take the new data's ``c3`` share
before the replay's; this project's first selection drew the replay first, which only matters for
``c3 < 1`` (no preset): the same seed then picks other, equally distributed, samples.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field

import numpy as np

from learned.continual_step import NOVELTY, NoveltyRule, ReplayRule, continual_step
from learned.data import FrameSet
from learned.model import CalibrationNet, ModelConfig, load_weights, make_network
from learned.replay import ReplayBuffer
from learned.trainer import TrainConfig, default_device, train

__all__ = [
    "Strategy",
    "Batch",
    "Naive",
    "Reservoir",
    "Selection",
    "STRATEGIES",
    "make_strategy",
]


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
    progress : bool
    sampling : {"uniform", "normal"}
        How the buffer draws its entries (:func:`learned.replay.draw`).
    model : CalibrationNet
    buffer : ReplayBuffer
        Camera id to stored frame indices (:mod:`learned.replay`; empty for batch and naive).
    processed : int
        Samples processed by training (epochs times training-set sizes).
    trained_samples : int
        Training-set sizes summed over the training calls, epochs aside (the seed paper's "data").
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
    sampling: str = "uniform"
    model: CalibrationNet = field(init=False)
    buffer: ReplayBuffer = field(init=False)
    processed: int = field(init=False, default=0)
    trained_samples: int = field(init=False, default=0)
    evaluated: int = field(init=False, default=0)
    skipped: list = field(init=False, default_factory=list)
    trained_on: list = field(init=False, default_factory=list)
    name = "base"

    def __post_init__(self):
        self.model = make_network(self.config).to(default_device())
        self.buffer = ReplayBuffer(getattr(self, "c1", 0), sampling=self.sampling)

    @property
    def stored(self) -> int:
        """Samples held in the buffer."""
        return self.buffer.size

    #: Attributes beyond the model, buffer and generator that a checkpoint keeps (JSON values).
    _counters = ("processed", "trained_samples", "evaluated", "skipped", "trained_on")

    def state_dict(self) -> dict:
        """Everything a resumed run needs between time steps: weights, buffer, generator, counters.

        Values are tensors, flat dicts of tensors or JSON values (:mod:`learned.safe_io`). Training
        makes a fresh optimiser per call (:func:`learned.trainer.train`), so between steps there is no
        optimiser state to keep.
        """
        buffer = self.buffer.state_dict()
        return {
            "weights": dict(self.model.state_dict()),
            "buffer_tensors": buffer["tensors"],
            "buffer": buffer["meta"],
            "rng": json.dumps(self.rng.bit_generator.state),
            "counters": {k: getattr(self, k) for k in self._counters},
        }

    def load_state_dict(self, state: dict) -> None:
        """Inverse of :meth:`state_dict`."""
        load_weights(self.model, state["weights"])
        self.model.eval()
        self.buffer.load_state_dict({"meta": state["buffer"], "tensors": state.get("buffer_tensors")})
        self.rng.bit_generator.state = json.loads(state["rng"])
        for k, v in state["counters"].items():
            setattr(self, k, v)

    def _frames_of(self, frames: FrameSet, cameras) -> np.ndarray:
        return np.flatnonzero(np.isin(frames.camera, list(cameras)) & (frames.split == "train"))

    def _train(self, frames: FrameSet, index: np.ndarray, step: int) -> int:
        cfg = self.first if step == 0 else self.later
        n = train(
            self.model,
            frames,
            index,
            cfg,
            self.rng,
            self.progress,
            desc=f"{self.name} {self.config.kind} step {step + 1}",
        )
        self.processed += n
        self.trained_samples += len(index)
        return n

    def step(self, step: int, cameras: list, frames: FrameSet, last: bool) -> None:
        """Train for one time step (the training camera poses of one region)."""
        raise NotImplementedError


@dataclass
class Batch(Strategy):
    """The baseline: from scratch on all training data seen, at the last time step (``every_step``: at each)."""

    every_step: bool = False
    seen: list = field(init=False, default_factory=list)
    name = "batch"
    _counters = Strategy._counters + ("seen",)

    def step(self, step, cameras, frames, last):
        self.seen += list(cameras)
        trains = last or self.every_step
        if trains:
            self.model = make_network(self.config).to(default_device())
            self._train(frames, self._frames_of(frames, self.seen), 0)
        self.trained_on.append(list(self.seen) if trains else [])

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
    """Algorithm 1: current data (fraction c3 after the first step) plus c1 samples from each of c2 past poses."""

    c1: int = 4
    c2: int | None = None
    c3: float = 1.0
    name = "reservoir"

    def _rule(self, share: float = 1.0, step: int = 1) -> ReplayRule:
        """The step's replay rule; the first step trains on all its data, as naive does (the paper applies
        ``c3`` to the later steps' current data only)."""
        return ReplayRule(self.c2, self.c3 if step else 1.0, share)

    def _train_fn(self, step: int):
        return lambda data, index: self._train(data, index, step)

    def step(self, step, cameras, frames, last):
        continual_step(
            self.model,
            frames,
            self._frames_of(frames, cameras),
            self.buffer,
            self.rng,
            self._rule(step=step),
            self._train_fn(step),
        )
        self.trained_on.append(list(cameras))


@dataclass
class Selection(Reservoir):
    """Algorithm 2: after the first step, each camera pose is a time step, trained on only if novel."""

    threshold_mm: float = 3.0
    threshold_deg: float = 4.0
    sample_fraction: float = 0.1
    replay_share: str = "region"
    novelty: str = "frames"
    name = "selection"
    #: Called as ``after_pose(camera, novel)`` after each pose of a later step; not part of the state.
    after_pose = None

    def __post_init__(self):
        super().__post_init__()
        if self.novelty not in NOVELTY:
            raise ValueError(f"unknown novelty measure {self.novelty!r}: use {', '.join(NOVELTY)}")
        if self.novelty == "placement" and self.config.kind != "keypoints":
            raise ValueError("placement novelty needs the keypoint model: the paper's networks judge it per frame")

    @property
    def threshold(self):
        if self.config.kind == "keypoints":
            return np.array([self.threshold_mm, self.threshold_deg])
        return self.threshold_mm if self.config.kind == "translation" else self.threshold_deg

    def step(self, step, cameras, frames, last):
        if step == 0:
            return super().step(step, cameras, frames, last)
        share = 1.0 / len(cameras) if self.replay_share == "region" else 1.0
        novel = []
        for c in cameras:
            outcome = continual_step(
                self.model,
                frames,
                self._frames_of(frames, [c]),
                self.buffer,
                self.rng,
                self._rule(share),
                self._train_fn(step),
                NoveltyRule(self.threshold, self.sample_fraction, self.novelty, self.sampling),
            )
            self.evaluated += outcome.evaluated
            (novel if outcome.novel else self.skipped).append(int(c))
            if self.after_pose is not None:
                self.after_pose(int(c), bool(outcome.novel))
        self.trained_on.append(novel)


STRATEGIES = {"batch": Batch, "naive": Naive, "reservoir": Reservoir, "selection": Selection}


def make_strategy(
    name: str,
    config: ModelConfig,
    first: TrainConfig,
    later: TrainConfig,
    rng: np.random.Generator,
    progress: bool = False,
    **params,
) -> Strategy:
    """A strategy by name; ``params`` are its own (c1, c2, c3, thresholds), ignored by those without them."""
    if name not in STRATEGIES:
        raise ValueError(f"unknown strategy {name!r}: use {', '.join(STRATEGIES)}")
    cls = STRATEGIES[name]
    own = {k: v for k, v in params.items() if k in getattr(cls, "__dataclass_fields__", {})}
    return cls(config, first, later, rng, progress, **own)
