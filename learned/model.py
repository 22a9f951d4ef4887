"""The regression architecture (paper section 2.2): RGB and depth encoders, reference pose, fully connected head.

Each encoder is a stack of strided convolutions whose output is flattened, not
pooled: global average pooling would throw away where the robot is in the
image, which is what tells the camera's pose. The two feature vectors and the
reference point's pose (x, y, z in metres, quaternion xyzw) go through three
fully connected layers. Two networks: ``translation`` (3 outputs, the camera
position in the base frame, mm) and ``orientation`` (10 outputs mapped to a
unit quaternion by :mod:`learned.quaternion`).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import torch
from torch import nn

from learned.quaternion import quaternion_from_10

__all__ = ["ModelConfig", "CalibrationNet", "KINDS", "make_network", "load_weights"]

KINDS = ("translation", "orientation")
#: Every network kind: the paper's two, and the equivariant keypoint model (:mod:`learned.keypoints`).
ALL_KINDS = KINDS + ("keypoints",)


@dataclass(frozen=True)
class ModelConfig:
    """Everything that fixes a network's shape and scaling (saved with its weights).

    Attributes
    ----------
    kind : {"translation", "orientation", "keypoints"}
    image_size : (int, int)
        ``(width, height)`` of the inputs.
    channels : tuple of int
        Output channels of each stride-2 convolution of an encoder.
    hidden : tuple of int
        Widths of the fully connected layers before the output.
    translation_scale_mm : float
        The translation network's raw output times this, plus the offset, is millimetres (keeps raw
        outputs near 0 and of order 1).
    translation_offset_mm : (float, float, float)
        Usually the mean camera position of the first time step's training data.
    depth_scale_m : float
        Depth is divided by this before the encoder.
    n_keypoints : int
        Keypoints of the ``keypoints`` kind (0 for the others).
    trunk_dtype : {"float32", "bfloat16"}
        The convolutions run in this precision (``torch.autocast``). The keypoint model's heads, the
        soft-argmax and the depths stay float32 (bfloat16 holds a normalised coordinate to 1/256 and a
        depth of 2 m to 8 mm); on a CPU with AMX a width-32 model trained in 270 against 311 s in float32
        (``benchmarks/results/keypoint_training.md``). The regression networks' encoders run in it, their
        fully connected head in float32 (``benchmarks/training_throughput.py``).
    """

    kind: str
    image_size: tuple = (64, 64)
    channels: tuple = (16, 32, 64, 64)
    hidden: tuple = (256, 128)
    translation_scale_mm: float = 500.0
    translation_offset_mm: tuple = (0.0, 0.0, 0.0)
    depth_scale_m: float = 3.0
    n_keypoints: int = 0
    trunk_dtype: str = "float32"

    def __post_init__(self):
        if self.kind not in ALL_KINDS:
            raise ValueError(f"kind must be one of {ALL_KINDS}, got {self.kind!r}")
        if self.trunk_dtype not in ("float32", "bfloat16"):
            raise ValueError(f"trunk_dtype must be 'float32' or 'bfloat16', got {self.trunk_dtype!r}")
        if self.kind == "keypoints":
            if self.n_keypoints < 3:
                raise ValueError(f"the keypoint model needs at least 3 keypoints, got {self.n_keypoints}")
            w, h = self.image_size
            stride = 2 ** (len(self.channels) + 1)  # the stages, then the trunk's own stride 2
            if w % stride or h % stride:
                raise ValueError(
                    f"image size {w}x{h} must be divisible by {stride} for the keypoint model "
                    f"({len(self.channels)} stride-2 stages and the trunk)"
                )
            return
        w, h = self.image_size
        stride = 2 ** len(self.channels)
        if w % stride or h % stride:
            raise ValueError(f"image size {w}x{h} must be divisible by {stride} ({len(self.channels)} stride-2 layers)")

    def to_dict(self) -> dict:
        return {k: list(v) if isinstance(v, tuple) else v for k, v in asdict(self).items()}

    @classmethod
    def from_dict(cls, doc: dict) -> "ModelConfig":
        return cls(**{k: tuple(v) if isinstance(v, list) else v for k, v in doc.items()})


def _encoder(in_channels: int, channels: tuple) -> nn.Sequential:
    layers, c = [], in_channels
    for k, out in enumerate(channels):
        layers += [
            nn.Conv2d(c, out, kernel_size=5 if k == 0 else 3, stride=2, padding=2 if k == 0 else 1),
            nn.BatchNorm2d(out),
            nn.ReLU(inplace=True),
        ]
        c = out
    return nn.Sequential(*layers, nn.Flatten())


class CalibrationNet(nn.Module):
    """One network of the pair: translation or orientation of ``T_base_cam`` from RGB-D and ``T_base_ref``.

    Parameters
    ----------
    config : ModelConfig
    """

    def __init__(self, config: ModelConfig):
        super().__init__()
        self.config = config
        w, h = config.image_size
        cells = (w // 2 ** len(config.channels)) * (h // 2 ** len(config.channels))
        features = 2 * config.channels[-1] * cells + 7
        self.rgb_encoder = _encoder(3, config.channels)
        self.depth_encoder = _encoder(1, config.channels)
        layers, width = [], features
        for hdim in config.hidden:
            layers += [nn.Linear(width, hdim), nn.ReLU(inplace=True)]
            width = hdim
        layers.append(nn.Linear(width, 3 if config.kind == "translation" else 10))
        self.head = nn.Sequential(*layers)

    def forward(self, rgb: torch.Tensor, depth_m: torch.Tensor, ref: torch.Tensor) -> torch.Tensor:
        """Predict.

        Parameters
        ----------
        rgb : tensor of uint8 or float, shape (B, 3, H, W)
            uint8 is scaled to [0, 1].
        depth_m : tensor, shape (B, 1, H, W)
        ref : tensor, shape (B, 7)

        Returns
        -------
        tensor, shape (B, 3)
            Translation in mm (``translation``), or shape (B, 4), unit quaternions xyzw (``orientation``).
        """
        x = rgb.float() / 255.0 if rgb.dtype == torch.uint8 else rgb.float()
        d = depth_m.float() / self.config.depth_scale_m
        # channels-last (NHWC) on an accelerator (learned.trainer.train turns the weights so); on the CPU the
        # default layout, whose float32 rounding the project's CPU results were made with
        layout = torch.contiguous_format if x.device.type == "cpu" else torch.channels_last
        x, d = x.contiguous(memory_format=layout), d.contiguous(memory_format=layout)
        with torch.autocast(x.device.type, dtype=torch.bfloat16, enabled=self.config.trunk_dtype == "bfloat16"):
            encoded = [self.rgb_encoder(x), self.depth_encoder(d)]
        features = torch.cat([e.float() for e in encoded] + [ref.float()], dim=1)  # the head in float32
        out = self.head(features)
        if self.config.kind == "translation":
            return out * self.config.translation_scale_mm + out.new_tensor(self.config.translation_offset_mm)
        return quaternion_from_10(out)


def make_network(config: ModelConfig) -> nn.Module:
    """The network of a config: :class:`CalibrationNet` or :class:`learned.keypoints.KeypointNet`."""
    if config.kind == "keypoints":
        from learned.keypoints import KeypointNet

        return KeypointNet(config)
    return CalibrationNet(config)


#: Buffers a file may lack: written by later versions, filled with their "unknown" value on load.
OPTIONAL_BUFFERS = ("residual_stats",)


def load_weights(model: nn.Module, state_dict: dict) -> None:
    """``model.load_state_dict(state_dict)``, strict except for :data:`OPTIONAL_BUFFERS`.

    A keypoint model saved before it kept its ``residual_stats`` loads with them unknown (NaN): its
    placement fit is then the 3-D to 3-D fit alone, as when it was saved.
    """
    missing, unexpected = model.load_state_dict(state_dict, strict=False)
    missing = [k for k in missing if k not in OPTIONAL_BUFFERS]
    if missing or unexpected:
        raise RuntimeError(f"weights do not fit the network: missing {missing}, unexpected {unexpected}")
