"""Experiment presets: resolution, network size, epochs and strategy parameters, by name.

A configuration module: :mod:`learned.experiment` (the protocol), :mod:`learned.calibrator` and the
command line read their presets from here. ``from learned.experiment import Preset, PRESETS`` still
works (re-exported there for compatibility).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, replace

from handeye.core.errors import HandEyeInputError
from handeye.core.smoke import smoke_test
from learned.model import ModelConfig
from learned.protocol import PROTOCOLS
from learned.trainer import TrainConfig

__all__ = ["Preset", "PRESETS", "get_preset"]


@dataclass(frozen=True)
class Preset:
    """Resolution, network size, epochs and strategy parameters of an experiment.

    Attributes
    ----------
    name : str
    image_size : (int, int)
    channels, hidden : tuple of int
        See :class:`learned.model.ModelConfig`.
    first_epochs, later_epochs, batch_epochs : int
        Epochs of the first time step, of each later one, and of the batch baseline.
    batch_size : int
    learning_rate : float
    c1 : int
    c2 : int or None
    c3 : float
    threshold_mm, threshold_deg : float
        Novelty thresholds of camera-pose selection.
    selection_replay : {"region", "all"}
        What a novel pose's step replays (:class:`learned.strategies.Selection`).
    selection_novelty : {"frames", "placement"}
        How selection measures a pose's novelty (:func:`learned.continual_step.sample_error`): the paper's
        mean per-frame error of a 10 % sample, or (keypoint model) the one pose from all its frames.
    keypoint_epochs : (int, int, int), optional
        First, later and batch epochs of the keypoint model (it learns local features and costs
        several times more per sample); the regression epochs when omitted.
    repeats : int
    keypoint_schedule : {"constant", "cosine"}
        The keypoint model's learning rate within each training call (:class:`learned.trainer.TrainConfig`).
    keypoint_spread_weight : float
        Weight of the keypoint model's heatmap spread in its loss (0: off; :func:`learned.keypoints.keypoint_loss`).
    keypoint_image_size : (int, int), optional
        The keypoint model's input; ``image_size`` when omitted. :meth:`frame_size` gives either. (On
        ``paper-sim`` 96 and 128 pixels did not lower its error: ``benchmarks/keypoint_training.py``.)
    keypoint_channels : tuple of int, optional
        The keypoint model's stride-2 stages (:class:`learned.keypoints.KeypointNet`); ``channels[0]``
        alone when omitted.
    keypoint_batch_size : int, optional
        The keypoint model's batch size; ``batch_size`` when omitted (it underfits, and more, smaller
        steps per sample lower its error at the same cost: ``benchmarks/keypoint_training.py``).
    trunk_dtype : {"float32", "bfloat16"}
        Precision of the regression networks' encoders (:class:`learned.model.ModelConfig`); float32 default.
    compile : bool
        Training through ``torch.compile`` (:attr:`learned.trainer.TrainConfig.compile`); off by default.
    keypoint_trunk_dtype : {"float32", "bfloat16"}
        Precision of the keypoint model's convolutions (:class:`learned.model.ModelConfig`).
    keypoint_shift_px : int
        Random shifts of the keypoint model's training images, input pixels
        (:attr:`learned.trainer.TrainConfig.shift_px`); 0: off.
    keypoint_average_epochs : int
        The keypoint model ends each training call with its weights averaged over this many last epochs
        (:attr:`learned.trainer.TrainConfig.average_epochs`); 0: off.
    keypoint_reference_frames : int
        The number of training frames the keypoint epochs are set for (0: off). A dataset with fewer
        trains each of its calls that many times more epochs, at most :attr:`keypoint_max_epoch_scale`
        times, so that the model takes about as many optimiser steps (:meth:`train_configs`).
    keypoint_max_epoch_scale : float
        The most :attr:`keypoint_reference_frames` multiplies the keypoint epochs by.
    protocol : {"handeye", "paper"}
        The mode the fields below were set by (:meth:`with_protocol`, :mod:`learned.protocol`).
    metric : {"mean", "rmse"}
        The per-subset error the tables lead with (both are recorded).
    sampling : {"uniform", "normal"}
        How the buffer's and the novelty sample's frames are drawn (:func:`learned.replay.draw`).
    batch_every_step : bool
        The batch baseline retrained from scratch at every time step (the paper), or once at the last.
    naive_batch_size : int, optional
        The naive strategy's batch size; the others' when omitted.
    pose_steps : bool
        Record selection's error on every test subset after each camera pose (the paper's Tables 17-18).
    label_method : str
        The closed form of the labels the classic targets must be (``handeye label --method``): ``park``
        (this project's), ``tsai`` (the paper's).
    label_repeats : int
        The labels' repeats (``handeye label --repeats``): 0, this project's label (closed form, maximum
        likelihood, corner reprojection); 5, the paper's (the closed form alone, repeated, averaged). A run
        from the command line refuses a dataset labelled otherwise (:func:`learned.label_kind.check_labels`).
    """

    name: str
    image_size: tuple = (64, 64)
    channels: tuple = (16, 32, 64, 64)
    hidden: tuple = (256, 128)
    first_epochs: int = 20
    later_epochs: int = 10
    batch_epochs: int = 20
    batch_size: int = 32
    learning_rate: float = 1e-3
    c1: int = 4
    c2: int | None = None
    c3: float = 1.0
    threshold_mm: float = 3.0
    threshold_deg: float = 4.0
    selection_replay: str = "region"
    selection_novelty: str = "frames"
    keypoint_epochs: tuple | None = None
    repeats: int = 3
    keypoint_schedule: str = "constant"
    keypoint_spread_weight: float = 0.0
    keypoint_image_size: tuple | None = None
    keypoint_channels: tuple | None = None
    keypoint_batch_size: int | None = None
    keypoint_trunk_dtype: str = "float32"
    trunk_dtype: str = "float32"
    compile: bool = False
    keypoint_average_epochs: int = 0
    keypoint_shift_px: int = 0
    keypoint_reference_frames: int = 0
    keypoint_max_epoch_scale: float = 2.0
    protocol: str = "handeye"
    metric: str = "mean"
    sampling: str = "uniform"
    batch_every_step: bool = False
    naive_batch_size: int | None = None
    pose_steps: bool = False
    label_method: str = "park"
    label_repeats: int = 0

    def __post_init__(self):
        if self.protocol not in PROTOCOLS:
            raise HandEyeInputError(f"unknown protocol {self.protocol!r}: use {', '.join(PROTOCOLS)}")
        if self.metric not in ("mean", "rmse"):
            raise HandEyeInputError(f"unknown metric {self.metric!r}: use mean or rmse")
        if self.sampling not in ("uniform", "normal"):
            raise HandEyeInputError(f"unknown sampling {self.sampling!r}: use uniform or normal")

    def with_protocol(self, name: str) -> "Preset":
        """This preset in a protocol mode (:data:`learned.protocol.PROTOCOLS`): ``paper`` or ``handeye``."""
        if name not in PROTOCOLS:
            raise HandEyeInputError(f"unknown protocol {name!r}: use {', '.join(PROTOCOLS)}")
        return replace(self, protocol=name, **PROTOCOLS[name])

    def smoke(self) -> "Preset":
        """This preset cut to a smoke run's size (:mod:`handeye.core.smoke`): the ``tiny`` preset's 32x32
        frames and networks, one stage in the keypoint model, 2 epochs first and 1 later, one repeat; the same
        name, protocol, strategy parameters and thresholds."""
        return replace(
            self,
            image_size=(32, 32),
            channels=(8, 16, 32),
            hidden=(64, 32),
            first_epochs=2,
            later_epochs=1,
            batch_epochs=2,
            keypoint_epochs=(2, 1, 2) if self.keypoint_epochs else None,
            keypoint_image_size=None,
            keypoint_channels=(8,),
            keypoint_average_epochs=0,
            keypoint_reference_frames=0,
            repeats=1,
        )

    def frame_size(self, family: str = "regression") -> tuple:
        """``(width, height)`` the frames are loaded at for a model family (``regression`` or ``keypoints``)."""
        if family == "keypoints" and self.keypoint_image_size:
            return tuple(int(v) for v in self.keypoint_image_size)
        return tuple(self.image_size)

    def model_config(self, kind: str, offset_mm=(0.0, 0.0, 0.0), n_keypoints: int = 0) -> ModelConfig:
        if kind == "keypoints":  # fully convolutional: its stages' widths (the encoders' first by default), no head
            widths = tuple(int(c) for c in (self.keypoint_channels or self.channels[:1]))
            return ModelConfig(
                kind,
                self.frame_size("keypoints"),
                widths,
                (),
                n_keypoints=int(n_keypoints),
                trunk_dtype=self.keypoint_trunk_dtype,
            )
        return ModelConfig(
            kind,
            tuple(self.image_size),
            tuple(self.channels),
            tuple(self.hidden),
            translation_offset_mm=tuple(float(v) for v in offset_mm),
            trunk_dtype=self.trunk_dtype,
        )

    def epoch_scale(self, kind: str, n_train_frames: int | None) -> float:
        """How many times its epochs a keypoint model trains on a dataset of ``n_train_frames`` training
        frames: ``reference / n``, between 1 and :attr:`keypoint_max_epoch_scale` (1 for the other kinds,
        without a reference, or when ``n_train_frames`` is not given)."""
        if kind != "keypoints" or not self.keypoint_reference_frames or not n_train_frames:
            return 1.0
        ratio = self.keypoint_reference_frames / int(n_train_frames)
        return float(min(max(ratio, 1.0), self.keypoint_max_epoch_scale))

    def train_configs(
        self, strategy: str, kind: str = "translation", n_train_frames: int | None = None
    ) -> tuple[TrainConfig, TrainConfig]:
        """The first and the later training calls' configurations of a strategy and a network kind.

        ``n_train_frames``: the dataset's training frames, for the keypoint model's :meth:`epoch_scale`.
        """
        first_e, later_e, batch_e = self.first_epochs, self.later_epochs, self.batch_epochs
        batch_size, extra = self.batch_size, {}
        if kind == "keypoints":
            extra = {
                "schedule": self.keypoint_schedule,
                "heatmap_spread_weight": self.keypoint_spread_weight,
                "average_epochs": self.keypoint_average_epochs,
                "shift_px": self.keypoint_shift_px,
            }
            if self.keypoint_epochs:
                first_e, later_e, batch_e = self.keypoint_epochs
            batch_size = self.keypoint_batch_size or batch_size
        if strategy == "naive" and self.naive_batch_size:
            batch_size = min(batch_size, int(self.naive_batch_size))
        first_e = batch_e if strategy == "batch" else first_e
        scale = self.epoch_scale(kind, n_train_frames)
        if scale != 1.0:
            first_e, later_e = max(1, round(first_e * scale)), max(1, round(later_e * scale))
        return (
            TrainConfig(first_e, batch_size, self.learning_rate, compile=self.compile, **extra),
            TrainConfig(later_e, batch_size, self.learning_rate, compile=self.compile, **extra),
        )

    def to_dict(self) -> dict:
        return {k: list(v) if isinstance(v, tuple) else v for k, v in asdict(self).items()}

    @classmethod
    def from_dict(cls, doc: dict) -> "Preset":
        """Inverse of :meth:`to_dict`."""
        return cls(**{k: tuple(v) if isinstance(v, list) else v for k, v in doc.items()})


# a test: seconds per strategy on 2 cores
_TINY = Preset(
    "tiny", (32, 32), (8, 16, 32), (64, 32), first_epochs=6, later_epochs=4, batch_epochs=6, batch_size=16, repeats=1
)

PRESETS = {
    "tiny": _TINY,
    # the README's demo: tiny's networks trained longer, on a small dataset: a minute or two on 2 cores
    "demo": replace(_TINY, name="demo", first_epochs=30, later_epochs=15, batch_epochs=30),
    # the paper-sim protocol at reduced resolution and width, all strategies and both networks on a 2-core CPU
    "cpu": Preset(
        "cpu",
        (64, 64),
        (8, 16, 32, 32),
        (128, 64),
        first_epochs=30,
        later_epochs=15,
        batch_epochs=30,
        # each later step of a continual strategy trains 12 epochs: the reservoir then processes about as many
        # samples as the batch model (62,600 against 63,000 on paper-sim); with 8 its worst placement was
        # 31.3 and 21.9 mm on two seeds, with 12 22.9 and 19.5 (benchmarks/results/keypoint_training.md); in
        # the protocol runs the reservoir's median of repeats went 11.8 -> 7.8 mm on paper-sim and 13.6 -> 10.7 on
        # paper-real (README)
        keypoint_epochs=(15, 12, 15),
        # the keypoint model: width 32 with its convolutions in bfloat16 (on this CPU's AMX as fast as width
        # 24 in float32), heatmaps pulled to a peak, batches of 8 (benchmarks/keypoint_training.py, placement
        # median with the 3-D to 3-D fit: 11.8 mm against 39.4 mm for width 8, float32, no spread, batches
        # of 32). With the points along the long links (handeye.robot.model.LINK_FRACTIONS) and the likelihood fit, the
        # protocol's batch repeats on paper-sim are at 5.4-12.1 mm (README).
        keypoint_channels=(32,),
        keypoint_trunk_dtype="bfloat16",
        keypoint_spread_weight=1.0,
        keypoint_batch_size=8,
        # the keypoint epochs are set for paper-sim's 4,200 training frames; paper-real's 1,900 train twice
        # the epochs, as many steps (batch model, two seeds: 13.4 -> 7.3 and 13.9 -> 11.1 mm,
        # benchmarks/results/keypoint_training.md)
        keypoint_reference_frames=4200,
        repeats=3,
    ),
    # the paper's scale (256x256 images, wider encoders, longer training, 3 repeats) and protocol: for a GPU
    "paper": Preset(
        "paper",
        (256, 256),
        (32, 64, 128, 128, 256, 256),
        (512, 256),
        first_epochs=50,
        later_epochs=25,
        batch_epochs=50,
        repeats=3,
    ).with_protocol("paper"),
}


def get_preset(name: str) -> Preset:
    """The preset called ``name``, in a smoke run (:func:`handeye.core.smoke.smoke_test`) cut to its
    :meth:`Preset.smoke` size; an unknown name is refused with the known ones."""
    if name not in PRESETS:
        raise HandEyeInputError(f"unknown learned preset {name!r}: use {', '.join(PRESETS)}")
    return PRESETS[name].smoke() if smoke_test() else PRESETS[name]
