"""A training call's frames resident on the training device, its batches gathered and augmented there.

:func:`learned.trainer.train` uploads the rows it trains on once per call (colour as uint8, depth in the
frames' own precision, float16 from :func:`learned.data.load_frames`, the reference poses and the
targets); each batch is then an index into these tensors, and the keypoint model's random shifts
(:attr:`learned.trainer.TrainConfig.shift_px`) move the batch's images and targets on the device. What
crosses from the host per batch is the batch's positions and shifts (a few integers), never an image.
On the CPU the "upload" is one copy of the rows and the values are those the per-batch copies gave.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch
import torch.nn.functional as F

from handeye.core.errors import HandEyeInputError
from learned.data import FrameSet
from learned.keypoints import keypoint_targets

__all__ = ["DeviceFrames", "keypoint_training_targets", "shift_batch", "shift_target_batch"]


def keypoint_training_targets(frames: FrameSet, index: np.ndarray, against: str = "label") -> np.ndarray:
    """The keypoint model's targets of the frames at ``index``: ``(x_n, y_n, z_m)``, shape (N, K, 3), float64.

    The keypoints' projections under the label's ``T_base_cam`` (``against="truth"``: the truth's)
    (:func:`learned.keypoints.keypoint_targets`); frames without keypoints are refused.
    """
    if frames.keypoints_base.shape[1] == 0:
        raise HandEyeInputError(
            "the keypoint model needs the keypoints' base-frame positions (learned.data."
            "with_keypoints; 'handeye learned run --family keypoints' fills them)"
        )
    t, q = (
        (frames.t_base_cam_mm, frames.q_base_cam_xyzw)
        if against == "label"
        else (frames.truth_t_base_cam_mm, frames.truth_q_base_cam_xyzw)
    )
    return keypoint_targets(frames.keypoints_base[index], t[index], q[index], frames.intrinsics_norm[index])


@dataclass
class DeviceFrames:
    """Rows of a :class:`learned.data.FrameSet` as tensors on one device.

    Attributes
    ----------
    rows : array of int, shape (M,)
        The frames held (indices into the FrameSet, sorted, unique).
    rgb : tensor of uint8, shape (M, 3, H, W)
    depth_m : tensor, shape (M, 1, H, W)
        The FrameSet's depth precision (float16 as loaded); :meth:`batch` gives float32.
    ref : tensor of float32, shape (M, 7)
        ``T_base_ref``: x, y, z (m), qx, qy, qz, qw.
    target : tensor or None
        The training target of each row: ``t_base_cam_mm`` (M, 3) for ``translation``,
        ``q_base_cam_xyzw`` (M, 4) for ``orientation``, the keypoints' ``(x_n, y_n, z_m)`` (M, K, 3) in
        float64 for ``keypoints`` (shifted in float64, as the host's targets were); None for prediction.
    """

    rows: np.ndarray
    rgb: torch.Tensor
    depth_m: torch.Tensor
    ref: torch.Tensor
    target: torch.Tensor | None = None

    @classmethod
    def upload(
        cls, frames: FrameSet, index: np.ndarray, device: torch.device, kind: str | None = None
    ) -> "DeviceFrames":
        """The frames at ``index`` (duplicates held once) on ``device``, with ``kind``'s targets (None: none).

        Parameters
        ----------
        frames : FrameSet
        index : array of int, shape (N,)
        device : torch.device
        kind : {"translation", "orientation", "keypoints"}, optional

        Returns
        -------
        DeviceFrames
        """
        rows = np.unique(np.asarray(index, dtype=np.int64))

        def put(a: np.ndarray) -> torch.Tensor:
            return torch.from_numpy(np.ascontiguousarray(a[rows])).to(device)

        target = None
        if kind == "translation":
            target = put(frames.t_base_cam_mm)
        elif kind == "orientation":
            target = put(frames.q_base_cam_xyzw)
        elif kind == "keypoints":
            target = torch.from_numpy(keypoint_training_targets(frames, rows)).to(device)
        return cls(rows, put(frames.rgb), put(frames.depth_m), put(frames.pose_base_ref), target)

    def __len__(self) -> int:
        return len(self.rows)

    def positions(self, index: np.ndarray) -> torch.Tensor:
        """Where the frames at ``index`` (FrameSet indices, all held) are in these tensors, on the device."""
        pos = np.searchsorted(self.rows, np.asarray(index, dtype=np.int64))
        return torch.from_numpy(pos).to(self.rgb.device)

    def batch(self, pos: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
        """Colour (uint8), depth (float32, m) and reference pose of the rows at ``pos``."""
        return self.rgb[pos], self.depth_m[pos].float(), self.ref[pos]


def shift_batch(
    rgb: torch.Tensor, depth_m: torch.Tensor, shifts: torch.Tensor, pad: int
) -> tuple[torch.Tensor, torch.Tensor]:
    """Each image moved by whole pixels on its device, the uncovered border empty (0: black, no depth).

    The same values as :func:`learned.keypoints.shift_images`, in one gather instead of a loop over the
    batch.

    Parameters
    ----------
    rgb : tensor, shape (B, 3, H, W)
    depth_m : tensor, shape (B, 1, H, W)
    shifts : tensor of int, shape (B, 2)
        ``(dx, dy)``: what was at pixel ``(u, v)`` is at ``(u + dx, v + dy)``; ``|dx|, |dy| <= pad``.
    pad : int
        The largest shift allowed (:attr:`learned.trainer.TrainConfig.shift_px`).

    Returns
    -------
    rgb, depth_m : tensors of the input shapes and dtypes
    """
    if pad == 0 or len(rgb) == 0:
        return rgb, depth_m
    h, w = rgb.shape[-2:]
    b = torch.arange(len(rgb), device=rgb.device)[:, None, None]
    ys = (pad - shifts[:, 1])[:, None] + torch.arange(h, device=rgb.device)  # (B, H)
    xs = (pad - shifts[:, 0])[:, None] + torch.arange(w, device=rgb.device)  # (B, W)

    def moved(image: torch.Tensor) -> torch.Tensor:
        padded = F.pad(image, (pad, pad, pad, pad))
        # advanced indices on dims 0, 2, 3 around the channel slice: the result is (B, H, W, C)
        return padded[b, :, ys[:, :, None], xs[:, None, :]].permute(0, 3, 1, 2)

    return moved(rgb), moved(depth_m)


def shift_target_batch(target: torch.Tensor, shifts: torch.Tensor, image_size: tuple) -> torch.Tensor:
    """Keypoint targets ``(x_n, y_n, z_m)`` (B, K, 3) of images moved by :func:`shift_batch`, in the
    targets' precision (float64: the values of :func:`learned.keypoints.shift_targets`)."""
    w, h = image_size
    step = shifts.to(target.dtype) / target.new_tensor([float(w), float(h)])
    out = target.clone()
    out[..., :2] += step[:, None, :]
    return out
