"""Data-parallel training with :mod:`torch.distributed`: the process group, ranks and the collectives it needs.

``torchrun --nproc-per-node N -m handeye learned run ...`` starts N processes with ``WORLD_SIZE``,
``RANK``, ``LOCAL_RANK``, ``MASTER_ADDR`` and ``MASTER_PORT`` set; :func:`init_from_env` joins them
into one group (``nccl`` with each rank on ``cuda:LOCAL_RANK`` when CUDA is present, ``gloo`` on the
CPU otherwise). Every rank then runs the whole protocol with the same seeds, so the replay buffers,
the numpy generators and torch's random state are the same everywhere; only
:func:`learned.trainer.train` splits work (each rank a contiguous slice of every batch, gradients
averaged by :func:`data_parallel`), and only the writer (:func:`is_writer`, rank 0) writes files.

Without torchrun (``WORLD_SIZE`` unset or 1) nothing here does anything: :func:`world_size` is 1,
:func:`is_writer` is True and the collectives return their input.
"""

from __future__ import annotations

import hashlib
import os

import numpy as np
import torch
import torch.distributed as dist

from handeye.core.errors import HandEyeInputError

__all__ = [
    "init_from_env",
    "is_distributed",
    "rank",
    "world_size",
    "is_writer",
    "backend",
    "barrier",
    "destroy",
    "shard",
    "sum_over_ranks",
    "from_writer",
    "check_same",
    "data_parallel",
]

#: What torchrun sets besides ``WORLD_SIZE``; a group cannot be joined without them.
_TORCHRUN_VARIABLES = ("RANK", "LOCAL_RANK", "MASTER_ADDR", "MASTER_PORT")


def init_from_env() -> str | None:
    """Join the process group torchrun describes in the environment, if there is one.

    ``nccl`` when CUDA is available (this rank's device set to ``cuda:LOCAL_RANK``, so
    :func:`learned.trainer.default_device` is that GPU), else ``gloo``. A group that is already
    initialised is kept.

    Returns
    -------
    str or None
        The backend, or None when not distributed (``WORLD_SIZE`` unset or 1).

    Raises
    ------
    HandEyeInputError
        ``WORLD_SIZE`` is not a positive integer, torchrun's other variables are missing, or
        ``LOCAL_RANK`` names a GPU this machine does not have.
    """
    if is_distributed():
        return backend()
    text = os.environ.get("WORLD_SIZE", "1")
    try:
        size = int(text)
    except ValueError:
        size = 0
    if size < 1:
        raise HandEyeInputError(f"WORLD_SIZE={text!r}: expected a positive integer (set by torchrun)")
    if size == 1:
        return None
    missing = [k for k in _TORCHRUN_VARIABLES if k not in os.environ]
    if missing:
        raise HandEyeInputError(
            f"WORLD_SIZE={size} but {', '.join(missing)} not set: start data-parallel runs with "
            "'torchrun --nproc-per-node N -m handeye ...'"
        )
    if not dist.is_available():
        raise HandEyeInputError("this torch build has no torch.distributed: run with one process")
    name = "nccl" if torch.cuda.is_available() else "gloo"
    if name == "nccl":
        local = int(os.environ["LOCAL_RANK"])
        if local >= torch.cuda.device_count():
            raise HandEyeInputError(
                f"LOCAL_RANK={local} but this machine has {torch.cuda.device_count()} CUDA device(s): "
                "start at most one process per GPU (--nproc-per-node)"
            )
        torch.cuda.set_device(local)
    dist.init_process_group(name)
    return name


def is_distributed() -> bool:
    """Whether this process is one rank of an initialised group."""
    return dist.is_available() and dist.is_initialized()


def rank() -> int:
    """This process's rank (0 when not distributed)."""
    return dist.get_rank() if is_distributed() else 0


def world_size() -> int:
    """Processes in the group (1 when not distributed)."""
    return dist.get_world_size() if is_distributed() else 1


def is_writer() -> bool:
    """Whether this process writes files: rank 0, or the only process."""
    return rank() == 0


def backend() -> str | None:
    """The group's backend (``"gloo"``, ``"nccl"``), or None when not distributed."""
    return str(dist.get_backend()) if is_distributed() else None


def _collective_device() -> torch.device:
    """Where the tensors of a collective live: this rank's GPU under nccl, else the CPU."""
    return torch.device("cuda", torch.cuda.current_device()) if backend() == "nccl" else torch.device("cpu")


def barrier() -> None:
    """Wait until every rank is here (nothing when not distributed)."""
    if is_distributed():
        if backend() == "nccl":
            dist.barrier(device_ids=[torch.cuda.current_device()])
        else:
            dist.barrier()


def destroy() -> None:
    """Leave and destroy the process group (nothing when not distributed)."""
    if is_distributed():
        dist.destroy_process_group()


def shard(batch: np.ndarray) -> np.ndarray:
    """This rank's contiguous slice of a global batch.

    Slices differ in size by at most one sample (``numpy.array_split``); a rank gets an empty slice
    only when the batch has fewer samples than there are ranks.

    Parameters
    ----------
    batch : array, shape (B,)

    Returns
    -------
    array, shape (B_rank,)
        The whole batch when not distributed.
    """
    return np.array_split(np.asarray(batch), world_size())[rank()]


def sum_over_ranks(value: float) -> float:
    """The sum of a number over all ranks (the number itself when not distributed)."""
    if not is_distributed():
        return float(value)
    t = torch.tensor([float(value)], dtype=torch.float64, device=_collective_device())
    dist.all_reduce(t)
    return float(t.item())


def from_writer(value):
    """Rank 0's value of a float or array on every rank (the value itself when not distributed).

    Decisions taken on the evaluation of a network (camera-pose novelty) are made the same on every
    rank this way, even where the ranks' predictions could differ in the last bit (other GPUs,
    non-deterministic kernels): ranks that disagreed would run different collectives and hang.

    Parameters
    ----------
    value : float or array, shape (K,)

    Returns
    -------
    float or array, shape (K,)
        The same type and shape as ``value``.
    """
    if not is_distributed():
        return value
    scalar = np.ndim(value) == 0
    t = torch.as_tensor(np.atleast_1d(np.asarray(value, dtype=np.float64)), device=_collective_device()).clone()
    dist.broadcast(t, src=0)
    out = t.cpu().numpy()
    return float(out[0]) if scalar else out.reshape(np.shape(value))


def check_same(state: str | bytes, what: str) -> None:
    """Refuse to go on when a state differs between ranks.

    The ranks must draw the same random numbers and keep the same replay buffers and weights; a
    difference would make them train on different batches without any error, so it is checked (a
    56-bit digest per rank, gathered) and stopped here.

    Parameters
    ----------
    state : str or bytes
        The state, e.g. a generator's state and a buffer's contents as JSON, weights as bytes.
    what : str
        What it is, for the message.

    Raises
    ------
    RuntimeError
        The ranks hold different states (a bug, not bad input).
    """
    if world_size() == 1:
        return
    data = state.encode() if isinstance(state, str) else bytes(state)
    digest = int.from_bytes(hashlib.blake2b(data, digest_size=7).digest(), "little")
    t = torch.tensor([digest], dtype=torch.int64, device=_collective_device())
    parts = [torch.zeros_like(t) for _ in range(world_size())]
    dist.all_gather(parts, t)
    digests = [int(p.item()) for p in parts]
    if len(set(digests)) > 1:
        raise RuntimeError(f"{what} differs between ranks (digests {digests}): the ranks have diverged")


def data_parallel(model: torch.nn.Module) -> torch.nn.parallel.DistributedDataParallel:
    """``model`` wrapped in :class:`~torch.nn.parallel.DistributedDataParallel` (gradients averaged over ranks).

    The wrapper shares the model's parameters and buffers (rank 0's are broadcast to the others when
    it is built), so the model itself stays the object the rest of the code uses; the wrapper is
    only for the forward passes whose gradients are to be averaged.

    Parameters
    ----------
    model : torch.nn.Module
        On this rank's device (``cuda:LOCAL_RANK`` under nccl, the CPU under gloo).

    Raises
    ------
    RuntimeError
        Not distributed.
    """
    if not is_distributed():
        raise RuntimeError("data_parallel needs an initialised process group (learned.distributed.init_from_env)")
    device = next(model.parameters()).device
    ids = [device.index if device.index is not None else torch.cuda.current_device()] if device.type == "cuda" else None
    return torch.nn.parallel.DistributedDataParallel(model, device_ids=ids)
