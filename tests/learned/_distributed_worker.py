"""One rank of the data-parallel check of ``test_distributed.py``: ``python -m tests.learned._distributed_worker OUT``.

Joins the process group the environment describes (none without ``WORLD_SIZE``: the one-process
reference), and per network kind (translation, orientation, keypoints) builds the same synthetic
frames and network on every rank, then writes ``OUT/<kind>.rank<r>.npz`` with

- ``grad.<name>``: the gradient of the loss of all training frames (one batch) at the initial
  weights, through :func:`learned.trainer._slice_loss` when distributed;
- ``init.<name>``: the initial parameters and buffers;
- ``state.<name>``: the parameters and buffers after one :func:`learned.trainer.train` call (the
  keypoint model's on randomly shifted images, :data:`SHIFT_PX`);
- ``pred``: the trained network's predictions (evaluation mode) for every frame.

An optional second argument sets the batch size (default :data:`BATCH`).
"""

from __future__ import annotations

import copy
import sys
from pathlib import Path

import numpy as np
import torch

from learned import distributed
from learned.data import with_keypoints
from learned.global_batchnorm import global_batchnorm
from learned.model import ModelConfig, make_network
from learned.trainer import TrainConfig, _loss, _slice_loss, predict, train
from tests.learned._synthetic import make_frames

#: 24 training frames in batches of 10 (10, 10, 4: slices of 5 and 2 samples, and on three ranks
#: slices of 4, 3, 3 and 2, 1, 1), 3 epochs: 9 Adam steps of learning rate 1e-3.
EPOCHS, BATCH, LR = 3, 10, 1e-3
KINDS = ("translation", "orientation", "keypoints")
#: Random shifts of the keypoint model's training images (input pixels).
SHIFT_PX = 3


def frames_and_config(kind: str):
    """The synthetic frames (keypoints filled in for the keypoint model) and a small network config."""
    rng = np.random.default_rng(0)
    frames = make_frames(rng, train_per_region=2, test_per_region=1, frames_per_camera=6, size=(32, 32))
    if kind == "keypoints":
        n = len(frames)
        frames.intrinsics_norm = np.tile(np.array([1.0, 1.0, 0.5, 0.5], np.float32), (n, 1))
        # some keypoints fall outside the image: the loss's term count differs between slices
        frames = with_keypoints(frames, rng.uniform(-0.6, 0.6, (n, 5, 3)) + [0.0, 0.0, 0.3])
        return frames, ModelConfig("keypoints", (32, 32), (8,), (), n_keypoints=5)
    return frames, ModelConfig(kind, (32, 32), (8, 16, 32), (64, 32), translation_offset_mm=(500.0, 500.0, 800.0))


def _gradient(model, frames, index) -> dict:
    """The gradient of the loss of the frames at ``index`` (one batch), on a copy of the model."""
    model = copy.deepcopy(model)
    model.train()
    if distributed.world_size() > 1:
        with global_batchnorm(model):
            net = distributed.data_parallel(model)  # kept alive: its hooks average the gradients in backward
            _slice_loss(net, model, frames, index).backward()
    else:
        _loss(model, frames, index)[0].backward()
    return {f"grad.{k}": p.grad.numpy() for k, p in model.named_parameters()}


def run(out: Path, kind: str, batch: int) -> None:
    """The three results of one network kind, written to ``out``."""
    frames, config = frames_and_config(kind)
    index = np.flatnonzero(frames.split == "train")
    torch.manual_seed(0)
    model = make_network(config)
    arrays = _gradient(model, frames, index)
    arrays.update({f"init.{k}": v.detach().numpy().copy() for k, v in model.state_dict().items()})
    # the keypoint model on shifted images: every rank must shift its slice's frames as the one process does
    config = TrainConfig(EPOCHS, batch, LR, shift_px=SHIFT_PX if kind == "keypoints" else 0)
    train(model, frames, index, config, np.random.default_rng(1))
    arrays.update({f"state.{k}": v.detach().numpy() for k, v in model.state_dict().items()})
    arrays["pred"] = predict(model, frames)
    np.savez(out / f"{kind}.rank{distributed.rank()}.npz", **arrays)


def main(out: str, batch: str = str(BATCH)) -> None:
    distributed.init_from_env()
    torch.set_num_threads(1)
    try:
        for kind in KINDS:
            run(Path(out), kind, int(batch))
    finally:
        distributed.destroy()


if __name__ == "__main__":
    main(*sys.argv[1:3])
