"""Training and evaluation of one network on frames in memory."""

from __future__ import annotations

import sys
from dataclasses import dataclass

import numpy as np
import torch

from handeye.core.errors import HandEyeInputError
from learned import distributed
from learned.data import FrameSet
from learned.device_data import DeviceFrames, keypoint_training_targets, shift_batch, shift_target_batch
from learned.global_batchnorm import global_batchnorm
from learned.losses import chordal_loss, translation_loss
from learned.metrics import rotation_errors_deg, translation_errors_mm
from learned.model import CalibrationNet

__all__ = ["TrainConfig", "train", "batch_loss", "predict", "errors", "default_device"]


def default_device() -> torch.device:
    """CUDA when available (the ``paper`` preset), else the CPU."""
    return torch.device("cuda" if torch.cuda.is_available() else "cpu")


@dataclass(frozen=True)
class TrainConfig:
    """Optimisation settings of one training call.

    Attributes
    ----------
    epochs : int
    batch_size : int
    learning_rate : float
    weight_decay : float
    schedule : {"constant", "cosine"}
        The learning rate over the call's steps: constant, or a cosine decay from ``learning_rate`` to
        zero (each call, i.e. each continual step, starts again from ``learning_rate``).
    heatmap_spread_weight : float
        The keypoint model only: weight of its heatmaps' spread in the loss
        (:func:`learned.keypoints.keypoint_loss`); 0 is off.
    shift_px : int
        The keypoint model only: each training sample's image moved by a random whole number of input
        pixels in ``[-shift_px, shift_px]`` along each axis (the uncovered border empty: black, no depth)
        and its keypoint targets with it (:func:`learned.keypoints.shift_images`); 0 (default) is off.
        A network whose receptive field spans the image can learn where the base sits in each training
        view from the image border rather than find it; random shifts leave it only the robot to go by.
    average_epochs : int
        End the call with the mean of the weights after each of its last this many epochs (stochastic
        weight averaging, Izmailov et al. 2018, ``torch.optim.swa_utils.AveragedModel``; with a constant
        learning rate the iterates scatter about a minimum and their mean lies nearer it), the batch-norm
        statistics then recomputed on the call's frames; 0 (default) keeps the last weights.
    compile : bool
        Run the training's forward passes through ``torch.compile`` (off by default: compiling costs
        seconds to minutes per call and pays only on an accelerator's long calls).
    """

    epochs: int = 10
    batch_size: int = 32
    learning_rate: float = 1e-3
    weight_decay: float = 0.0
    schedule: str = "constant"
    heatmap_spread_weight: float = 0.0
    average_epochs: int = 0
    shift_px: int = 0
    compile: bool = False

    def __post_init__(self):
        if self.schedule not in ("constant", "cosine"):
            raise ValueError(f"schedule must be 'constant' or 'cosine', got {self.schedule!r}")
        if self.average_epochs < 0:
            raise ValueError(f"average_epochs must be 0 (off) or more, got {self.average_epochs}")
        if self.shift_px < 0:
            raise ValueError(f"shift_px must be 0 (off) or more, got {self.shift_px}")


def _device(model: CalibrationNet) -> torch.device:
    return next(model.parameters()).device


def _on_device(model: CalibrationNet, frames, index) -> tuple[DeviceFrames, torch.Tensor]:
    """``(data, positions)``: ``frames`` as they are when already on the device, else uploaded for ``index``."""
    if isinstance(frames, DeviceFrames):
        return frames, index
    data = DeviceFrames.upload(frames, index, _device(model), model.config.kind)
    return data, data.positions(index)


def _loss(
    model: CalibrationNet,
    frames: DeviceFrames | FrameSet,
    index,
    net: torch.nn.Module | None = None,
    spread_weight: float = 0.0,
    shifts: torch.Tensor | None = None,
    shift_px: int = 0,
):
    """The training loss of a batch and how many terms it averages.

    ``frames`` and ``index``: the call's :class:`learned.device_data.DeviceFrames` and the batch's
    positions in it (a tensor), or a FrameSet and the batch's frame indices (uploaded here).
    ``net`` runs the forward pass (the data-parallel or compiled wrapper of ``model``; ``model`` by
    default); ``spread_weight`` is :attr:`TrainConfig.heatmap_spread_weight`; ``shifts`` (len(index), 2),
    the keypoint model only: whole input pixels ``(dx, dy)`` each frame's image and targets are moved by,
    at most ``shift_px``. The count is the samples, or for the keypoint model the keypoints inside the
    image (a tensor: read it only where needed); an empty ``index`` gives a zero loss that still reaches
    every parameter (a rank's empty slice of a batch).
    """
    data, pos = _on_device(model, frames, index)
    net = model if net is None else net
    rgb, depth, ref = data.batch(pos)
    if model.config.kind == "keypoints":
        from learned.keypoints import inside_image, keypoint_loss

        target = data.target[pos]
        if shifts is not None and len(pos):
            shifts = torch.as_tensor(shifts).to(rgb.device)
            rgb, depth = shift_batch(rgb, depth, shifts, shift_px or int(shifts.abs().max()))
            target = shift_target_batch(target, shifts, model.config.image_size)
        out, prob = net(rgb, depth, ref, heatmaps=True)
        if len(pos) == 0:
            return out.sum() * 0.0, 0
        target = target.float()
        loss = keypoint_loss(out, target, model.config.image_size, prob, spread_weight)
        return loss, inside_image(target).sum()
    out = net(rgb, depth, ref)
    if len(pos) == 0:
        return out.sum() * 0.0, 0
    if model.config.kind == "translation":
        return translation_loss(out, data.target[pos]), len(pos)
    return chordal_loss(out, data.target[pos]), len(pos)


def _slice_loss(
    net: torch.nn.Module,
    model: CalibrationNet,
    frames: DeviceFrames | FrameSet,
    batch,
    spread_weight: float = 0.0,
    shifts: torch.Tensor | None = None,
    shift_px: int = 0,
) -> torch.Tensor:
    """This rank's share of a global batch's loss, weighted so that the ranks' average gradient is the batch's.

    ``frames``, ``batch``: as :func:`_loss`'s ``frames`` and ``index``. The loss on the slice averages
    ``n_r`` terms (samples, or keypoints in the image) of the batch's ``n``; weighted by
    ``n_r / n * world_size``, the mean over ranks of the slices' gradients (what
    DistributedDataParallel computes) is the gradient of the whole batch's mean loss.
    """
    data, pos = _on_device(model, frames, batch)
    mine = torch.from_numpy(distributed.shard(np.arange(len(pos)))).to(pos.device)
    shifts = None if shifts is None else torch.as_tensor(shifts).to(pos.device)[mine]
    loss, count = _loss(model, data, pos[mine], net, spread_weight, shifts, shift_px)
    count = int(count)
    total = len(pos) if model.config.kind != "keypoints" else distributed.sum_over_ranks(count)
    return loss * (count / max(total, 1) * distributed.world_size())


def train(
    model: CalibrationNet,
    frames: FrameSet,
    index: np.ndarray,
    config: TrainConfig,
    rng: np.random.Generator,
    progress: bool = False,
    desc: str = "train",
) -> int:
    """Train on the frames at ``index`` (a fresh Adam per call); returns the samples processed.

    In a process group of more than one rank (:mod:`learned.distributed`) the training is
    data-parallel: every rank draws the same batches from ``rng`` (which must be in the same state on
    every rank), computes the loss of its contiguous slice of each batch with batch norm over the
    whole batch (:mod:`learned.global_batchnorm`), and DistributedDataParallel averages the
    gradients, so each step is the one-process step on the whole batch up to float32 rounding. The
    model is wrapped for the call only; it ends with the same parameters on every rank.

    The frames at ``index`` are uploaded to the model's device once per call and every batch is
    gathered (and, for the keypoint model, shifted) there (:mod:`learned.device_data`).

    Parameters
    ----------
    model : CalibrationNet
    frames : FrameSet
    index : array of int
    config : TrainConfig
    rng : numpy.random.Generator
        Shuffles the batches (torch's own generator is seeded from it).
    progress : bool
    desc : str

    Returns
    -------
    int
        ``epochs * len(index)``.
    """
    index = np.asarray(index)
    if len(index) == 0:
        return 0
    torch.manual_seed(int(rng.integers(2**31)))
    if _device(model).type != "cpu":  # channels-last convolutions (NHWC): the tensor cores' layout
        model.to(memory_format=torch.channels_last)
    data = DeviceFrames.upload(frames, index, _device(model), model.config.kind)
    if distributed.world_size() > 1:
        with global_batchnorm(model):
            net = _compiled(distributed.data_parallel(model), config)
            mean = _epochs(model, net, data, index, config, rng, progress, desc)
    else:
        mean = _epochs(model, _compiled(model, config), data, index, config, rng, progress, desc)
    if mean is not None:
        _take_average(model, mean, data, data.positions(index), config.batch_size)
    model.eval()
    if model.config.kind == "keypoints":
        estimate_residuals(model, frames, index)
    return config.epochs * len(index)


#: Training frames on which :func:`estimate_residuals` measures the keypoint model (evenly spaced).
RESIDUAL_FRAMES = 256


@torch.no_grad()
def estimate_residuals(model: CalibrationNet, frames: FrameSet, index: np.ndarray) -> None:
    """Set a keypoint model's ``residual_stats`` from its residuals on (up to 256 of) the frames at ``index``.

    The frames are evenly spaced over ``index`` (no random draw, so the training's random stream and
    every rank's result are unchanged); the targets are the training targets (the label's projection).
    """
    from learned.keypoints import residual_stats

    index = np.asarray(index)
    if len(index) > RESIDUAL_FRAMES:
        index = index[np.linspace(0, len(index) - 1, RESIDUAL_FRAMES).round().astype(int)]
    stats = residual_stats(predict(model, frames, index), keypoint_training_targets(frames, index))
    model.residual_stats.copy_(torch.from_numpy(stats))


def batch_loss(
    model: CalibrationNet,
    net: torch.nn.Module,
    sliced: bool,
    data: DeviceFrames,
    pos: torch.Tensor,
    config: TrainConfig,
    rng: np.random.Generator,
) -> torch.Tensor:
    """The loss of one training batch as :func:`train` computes it (what its step differentiates).

    Parameters
    ----------
    model : CalibrationNet
    net : torch.nn.Module
        Runs the forward pass: ``model``, or its compiled or data-parallel wrapper.
    sliced : bool
        Data-parallel: this rank's weighted share of the batch (:func:`_slice_loss`).
    data : DeviceFrames
    pos : tensor of int, shape (B,)
        The batch's positions in ``data``.
    config : TrainConfig
    rng : numpy.random.Generator
        The keypoint model's shifts are drawn from it, for the whole batch and only when
        ``config.shift_px`` is on (the stream is unchanged when off).

    Returns
    -------
    tensor
        A scalar.
    """
    spread = config.heatmap_spread_weight
    shifts = (
        torch.from_numpy(rng.integers(-config.shift_px, config.shift_px + 1, size=(len(pos), 2)))
        if config.shift_px > 0 and model.config.kind == "keypoints"
        else None
    )
    if sliced:
        return _slice_loss(net, model, data, pos, spread, shifts, config.shift_px)
    return _loss(model, data, pos, net, spread, shifts, config.shift_px)[0]


def _compiled(net: torch.nn.Module, config: TrainConfig) -> torch.nn.Module:
    """``net`` through ``torch.compile`` when ``config.compile``, else ``net`` itself."""
    return torch.compile(net) if config.compile else net


@torch.no_grad()
def _take_average(model, mean, data: DeviceFrames, pos: torch.Tensor, batch_size: int) -> None:
    """Load the averaged weights into ``model`` and recompute its batch-norm statistics on the frames.

    The running statistics of the last weights do not belong to their mean: they are reset and
    accumulated anew (cumulative average, ``momentum=None``) over the frames at ``pos`` (positions in
    ``data``) in ``batch_size`` batches, in order, the same on every rank.
    """
    for p, q in zip(model.parameters(), mean.module.parameters()):
        p.copy_(q)
    norms = [m for m in model.modules() if isinstance(m, torch.nn.modules.batchnorm._BatchNorm)]
    momenta = [m.momentum for m in norms]
    for m in norms:
        m.reset_running_stats()
        m.momentum = None
    model.train()
    for start in range(0, len(pos), batch_size):
        batch = pos[start : start + batch_size]
        if len(batch) >= 2:
            model(*data.batch(batch))
    for m, momentum in zip(norms, momenta):
        m.momentum = momentum


def _epochs(
    model: CalibrationNet,
    net: torch.nn.Module,
    data: DeviceFrames,
    index: np.ndarray,
    config: TrainConfig,
    rng: np.random.Generator,
    progress: bool,
    desc: str,
):
    """The epochs of :func:`train` on ``data`` (the frames at ``index``, on the device).

    ``net`` runs the forward passes (``model``, or its compiled or data-parallel wrapper); data-parallel
    (more than one process), each rank computes its slice of every batch. Every rank draws the same
    permutations from the same generator, so all see the same batches and skip the same ones; each
    rank then computes the loss of its slice (:func:`_slice_loss`). Per epoch the permutation's
    positions go to the device once; per batch only the keypoint model's shifts (when on). Returns
    the mean of the weights over the last ``config.average_epochs`` epochs (an ``AveragedModel``), or
    None when that is 0.
    """
    mean = None
    sliced = distributed.world_size() > 1  # as train wraps net
    optimizer = torch.optim.Adam(model.parameters(), lr=config.learning_rate, weight_decay=config.weight_decay)
    steps = config.epochs * -(-len(index) // config.batch_size)  # a last batch of one, skipped, leaves it above 0
    scheduler = (
        torch.optim.lr_scheduler.CosineAnnealingLR(optimizer, T_max=max(steps, 1))
        if config.schedule == "cosine"
        else None
    )
    model.train()
    bar = None
    if progress:
        from tqdm import tqdm

        bar = tqdm(total=config.epochs, desc=desc, unit="epoch", file=sys.stderr, leave=False)
    for epoch in range(config.epochs):
        order = data.positions(rng.permutation(index))
        for start in range(0, len(order), config.batch_size):
            batch = torch.sort(order[start : start + config.batch_size]).values  # as the frames' order
            if len(batch) < 2:  # batch norm needs two samples
                continue
            optimizer.zero_grad()
            loss = batch_loss(model, net, sliced, data, batch, config, rng)
            loss.backward()
            optimizer.step()
            if scheduler is not None:
                scheduler.step()
        if epoch >= config.epochs - config.average_epochs:
            if mean is None:
                from torch.optim.swa_utils import AveragedModel

                mean = AveragedModel(model)
            mean.update_parameters(model)
        if bar is not None:
            bar.set_postfix(loss=f"{loss.item():.4g}")
            bar.update(1)
    if bar is not None:
        bar.close()
    return mean


@torch.no_grad()
def predict(
    model: CalibrationNet, frames: FrameSet, index: np.ndarray | None = None, batch_size: int = 256
) -> np.ndarray:
    """Predictions for the frames at ``index`` (all by default): (N, 3) mm or (N, 4) quaternions."""
    index = np.arange(len(frames)) if index is None else np.asarray(index)
    model.eval()
    data = DeviceFrames.upload(frames, index, _device(model))
    pos = data.positions(index)
    out = [model(*data.batch(pos[s : s + batch_size])).cpu().numpy() for s in range(0, len(index), batch_size)]
    if model.config.kind == "keypoints":
        return np.concatenate(out) if out else np.zeros((0, model.config.n_keypoints, 3))
    width = 3 if model.config.kind == "translation" else 4
    return np.concatenate(out) if out else np.zeros((0, width))


def errors(
    model: CalibrationNet, frames: FrameSet, index: np.ndarray | None = None, against: str = "label"
) -> np.ndarray:
    """Per-frame error of a network, mm or degrees, against the training targets or the truth.

    Shape (N,), or (N, 2) for the keypoint model: translation mm and rotation deg of each frame's
    own pose (:func:`learned.keypoints.frame_poses`).
    """
    index = np.arange(len(frames)) if index is None else np.asarray(index)
    pred = predict(model, frames, index)
    if model.config.kind == "keypoints":
        from learned.keypoints import model_residual_stats

        return np.column_stack(keypoint_pose_errors(pred, frames, index, against, model_residual_stats(model)))
    if model.config.kind == "translation":
        t_mm = frames.t_base_cam_mm if against == "label" else frames.truth_t_base_cam_mm
        return translation_errors_mm(pred, t_mm[index])
    q_xyzw = frames.q_base_cam_xyzw if against == "label" else frames.truth_q_base_cam_xyzw
    return rotation_errors_deg(pred, q_xyzw[index])


def placement_error(model: CalibrationNet, frames: FrameSet, index: np.ndarray, against: str = "label") -> np.ndarray:
    """The keypoint model's error on one camera placement: its one pose from all of ``index``'s frames.

    The pose is :func:`learned.keypoints.camera_pose` of the frames' predicted keypoints, with the
    model's residual statistics; it is compared with the placement's label (or truth).

    Parameters
    ----------
    model : CalibrationNet
        A keypoint model (``config.kind == "keypoints"``).
    frames : FrameSet
    index : array of int, shape (N,)
        Frames of one camera placement.
    against : {"label", "truth"}

    Returns
    -------
    array, shape (2,)
        Translation error, mm, and rotation error, deg.
    """
    from learned.keypoints import camera_pose, model_residual_stats, pose_errors

    if model.config.kind != "keypoints":
        raise HandEyeInputError(
            "a placement's one pose needs the keypoint model; the paper's networks judge novelty per frame"
        )
    index = np.asarray(index)
    if not len(index) or len(np.unique(frames.camera[index])) != 1:
        raise HandEyeInputError(f"placement_error needs the frames of one camera placement, got {len(index)} frames")
    pred = predict(model, frames, index)
    T, _ = camera_pose(
        pred, frames.keypoints_base[index], frames.intrinsics_norm[index], stats=model_residual_stats(model)
    )
    t, q = (
        (frames.t_base_cam_mm, frames.q_base_cam_xyzw)
        if against == "label"
        else (frames.truth_t_base_cam_mm, frames.truth_q_base_cam_xyzw)
    )
    if not np.isfinite(T).all():
        return np.array([np.inf, 180.0])
    e_t, e_r = pose_errors(T[None], t[index[:1]], q[index[:1]])
    return np.array([e_t[0], e_r[0]])


def keypoint_pose_errors(
    pred: np.ndarray, frames: FrameSet, index: np.ndarray, against: str = "label", stats: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Translation (mm) and rotation (deg) errors of the per-frame poses solved from predicted keypoints.

    ``stats``: the model's residual statistics (:func:`learned.keypoints.residual_stats`): with them each
    frame's offsets are removed and it is fitted by maximum likelihood (:func:`learned.keypoints.frame_poses`).
    """
    from learned.keypoints import frame_poses, pose_errors

    T = frame_poses(pred, frames.keypoints_base[index], frames.intrinsics_norm[index], stats)
    t, q = (
        (frames.t_base_cam_mm, frames.q_base_cam_xyzw)
        if against == "label"
        else (frames.truth_t_base_cam_mm, frames.truth_q_base_cam_xyzw)
    )
    bad = ~np.isfinite(T).all(axis=(1, 2))
    T[bad] = np.eye(4)
    e_t, e_r = pose_errors(T, t[index], q[index])
    e_t[bad], e_r[bad] = np.inf, 180.0
    return e_t, e_r
