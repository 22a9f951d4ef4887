"""A robot cell's calibration that keeps learning: Algorithm 2 online, with its state on disk.

>>> cal = ContinualCalibrator(preset="cpu")          # doctest: +SKIP
>>> cal.observe(first_region_frames)                 # trains both networks from scratch
>>> cal.observe(new_pose_frames)                     # novel? then trains with the buffer, else skips
>>> T_base_cam = cal.predict(rgb, depth_m, T_base_ref)
>>> cal.save("cell.pt"); cal = ContinualCalibrator.load("cell.pt")

Each network (translation, orientation) decides novelty on its own (the
paper's thresholds per network: mean error of a 10 % sample above 3 mm or 4
degrees) and keeps its own buffer of ``c1`` samples per camera pose it trained
on. The buffer (:class:`learned.replay.ReplayBuffer` with ``keep_samples``) holds
the samples themselves (images, reference poses, targets), so the calibrator
needs no dataset to keep learning after a restart; each update is
:func:`learned.continual_step.continual_step`, the code the experiment's
strategies run, replaying the whole buffer with the new pose's frames.

The networks live on :func:`learned.trainer.default_device` (CUDA when
available, else the CPU), as the experiment's do; a saved state loads on any
device.
"""

from __future__ import annotations

import json
from dataclasses import asdict
from pathlib import Path

import numpy as np
import torch

from handeye.core.errors import HandEyeInputError
from handeye.core.se3 import make_transform, matrix_from_quat_xyzw
from learned.continual_step import NoveltyRule, ReplayRule, continual_step
from learned.data import FrameSet
from learned.experiment import average_quaternions
from learned.model import KINDS, CalibrationNet, ModelConfig
from learned.presets import Preset, get_preset
from learned.replay import ReplayBuffer
from learned.safe_io import load_document, save_document
from learned.trainer import TrainConfig, default_device, predict, train

__all__ = ["ContinualCalibrator"]

STATE_VERSION = 3  # tensors and JSON (learned.safe_io), buffers of learned.replay; 2 had bare FrameSets, 1 was pickled


class ContinualCalibrator:
    """Continual hand-eye calibration of a static camera from RGB-D images and the reference pose.

    Parameters
    ----------
    preset : str or Preset
        Resolution, network size, epochs, c1, c3 and thresholds (:data:`learned.presets.PRESETS`).
    seed : int
    sample_fraction : float
        Share of a new camera pose's frames evaluated to decide its novelty.
    device : str or torch.device, optional
        Where the networks train and predict; :func:`learned.trainer.default_device` (CUDA when
        available) by default.
    """

    def __init__(
        self,
        preset: str | Preset = "cpu",
        seed: int = 0,
        sample_fraction: float = 0.1,
        device: str | torch.device | None = None,
    ):
        self.preset = get_preset(preset) if isinstance(preset, str) else preset
        self.sample_fraction = sample_fraction
        self.device = default_device() if device is None else torch.device(device)
        self.rng = np.random.default_rng(seed)
        self.models: dict[str, CalibrationNet] = {}
        self.buffers = {k: ReplayBuffer(self.preset.c1, keep_samples=True) for k in KINDS}
        self.history: list[dict] = []

    @property
    def memory(self) -> dict[str, FrameSet | None]:
        """Per network, the samples its buffer holds (None before the first call)."""
        return {k: b.frames() for k, b in self.buffers.items()}

    @property
    def threshold(self) -> dict:
        return {"translation": self.preset.threshold_mm, "orientation": self.preset.threshold_deg}

    def _check(self, frames: FrameSet) -> None:
        if tuple(frames.image_size) != tuple(self.preset.image_size):
            raise HandEyeInputError(
                f"frames are {frames.image_size[0]}x{frames.image_size[1]}, this calibrator "
                f"takes {self.preset.image_size[0]}x{self.preset.image_size[1]}: load them at "
                "that size"
            )

    def _train_fn(self, kind: str, first: bool):
        epochs = self.preset.first_epochs if first else self.preset.later_epochs
        cfg = TrainConfig(epochs, self.preset.batch_size, self.preset.learning_rate)
        return lambda data, index: train(self.models[kind], data, index, cfg, self.rng)

    def observe(self, frames: FrameSet) -> dict:
        """Take a new camera pose's frames (targets: its classic label); learn from them if they are novel.

        The first call trains both networks from scratch on what it is given (typically the first
        region's camera poses). Later calls, one camera pose each, run Algorithm 2 per network.

        Returns
        -------
        dict
            Per network: ``novel`` (bool), ``sample_error`` (mm or deg, None on the first call),
            ``processed`` samples.
        """
        self._check(frames)
        first = not self.models
        if first:
            offset_mm = frames.t_base_cam_mm.mean(axis=0)
            for kind in KINDS:
                self.models[kind] = CalibrationNet(self.preset.model_config(kind, offset_mm)).to(self.device)
        elif len(np.unique(frames.camera)) != 1:
            raise HandEyeInputError(
                "after the first call, observe one camera pose at a time "
                f"(got cameras {np.unique(frames.camera).tolist()})"
            )
        entry = {"cameras": [int(c) for c in np.unique(frames.camera)], "first": first}
        rule = ReplayRule(None, self.preset.c3, 1.0)  # every past pose, all its stored samples
        for kind in KINDS:
            out = continual_step(
                self.models[kind],
                frames,
                np.arange(len(frames)),
                self.buffers[kind],
                self.rng,
                rule,
                self._train_fn(kind, first),
                NoveltyRule(None if first else self.threshold[kind], self.sample_fraction),
            )
            entry[kind] = {"novel": bool(out.novel), "sample_error": out.sample_error, "processed": out.processed}
        self.history.append(entry)
        return entry

    def predict(self, rgb: np.ndarray, depth_m: np.ndarray, pose_base_ref: np.ndarray) -> np.ndarray:
        """``T_base_cam`` from one or more frames of the same camera (predictions averaged).

        Parameters
        ----------
        rgb : array of uint8, shape (N, 3, H, W) or (H, W, 3)
        depth_m : array, shape (N, 1, H, W) or (H, W)
        pose_base_ref : array, shape (N, 7) or (7,)
            ``T_base_ref`` as x, y, z, qx, qy, qz, qw.

        Returns
        -------
        T_base_cam : array, shape (4, 4)
        """
        if not self.models:
            raise HandEyeInputError("the calibrator has not been trained: call observe() first")
        rgb = np.asarray(rgb)
        if rgb.ndim == 3:
            rgb, depth_m, pose_base_ref = (
                rgb.transpose(2, 0, 1)[None],
                np.asarray(depth_m)[None, None],
                np.asarray(pose_base_ref)[None],
            )
        n = len(rgb)
        w, h = self.preset.image_size
        if rgb.shape[1:] != (3, h, w) or np.asarray(depth_m).shape[1:] != (1, h, w):
            raise HandEyeInputError(
                f"images must be {w}x{h} (rgb (N, 3, {h}, {w}), depth (N, 1, {h}, {w})), got "
                f"{rgb.shape} and {np.asarray(depth_m).shape}"
            )
        frames = FrameSet(
            rgb.astype(np.uint8),
            np.asarray(depth_m, np.float16),
            np.asarray(pose_base_ref, np.float32),
            np.zeros((n, 3), np.float32),
            np.zeros((n, 4), np.float32),
            np.zeros(n, int),
            np.zeros(n, int),
            np.array(["test"] * n),
            np.full((n, 3), np.nan),
            np.full((n, 4), np.nan),
            "none",
            (w, h),
        )
        t_base_cam_mm = predict(self.models["translation"], frames).mean(axis=0)
        q_base_cam_xyzw = average_quaternions(predict(self.models["orientation"], frames))
        return make_transform(matrix_from_quat_xyzw(q_base_cam_xyzw), t_base_cam_mm / 1000.0)

    def save(self, path: str | Path) -> None:
        """Weights, configs, buffers, history and the random state, in one file (tensors and JSON)."""
        doc = {
            "preset": self.preset.to_dict(),
            "history": self.history,
            "sample_fraction": self.sample_fraction,
            "rng": json.dumps(self.rng.bit_generator.state),
            "configs": {k: m.config.to_dict() for k, m in self.models.items()},
            "buffers": {},
        }
        for k, m in self.models.items():
            doc[f"weights.{k}"] = {n: t.cpu() for n, t in m.state_dict().items()}
        for k, b in self.buffers.items():
            state = b.state_dict()
            doc["buffers"][k] = state["meta"]
            doc[f"buffer.{k}"] = state["tensors"]
        save_document(path, "calibrator", STATE_VERSION, doc)

    @classmethod
    def load(
        cls, path: str | Path, preset: str | Preset | None = None, device: str | torch.device | None = None
    ) -> "ContinualCalibrator":
        """Restore a saved calibrator (onto ``device``, the default device by default); with ``preset``,
        refuse a state saved with another one."""
        path = Path(path)
        doc = load_document(path, "calibrator", STATE_VERSION)
        saved = Preset.from_dict(doc["preset"])
        if preset is not None:
            want = get_preset(preset) if isinstance(preset, str) else preset
            if want != saved:
                diff = [k for k in asdict(saved) if getattr(saved, k) != getattr(want, k)]
                raise HandEyeInputError(f"{path}: saved with preset {saved.name} (differs in {', '.join(diff)})")
        cal = cls(saved, sample_fraction=doc["sample_fraction"], device=device)
        cal.rng.bit_generator.state = json.loads(doc["rng"])
        cal.history = doc["history"]
        for k, config in doc["configs"].items():
            cal.models[k] = CalibrationNet(ModelConfig.from_dict(config))
            cal.models[k].load_state_dict(doc[f"weights.{k}"])
            cal.models[k].to(cal.device).eval()
        for k, meta in doc["buffers"].items():
            cal.buffers[k].load_state_dict({"meta": meta, "tensors": doc.get(f"buffer.{k}")})
        return cal
