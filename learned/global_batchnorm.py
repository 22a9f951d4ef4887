"""Batch normalisation over the global batch of a data-parallel step, on any device and backend.

Each rank of a data-parallel step (:mod:`learned.distributed`) holds a slice of the batch. Batch
norm on the slice alone would normalise with the slice's statistics: another function of the
weights than the one-process network computes on the whole batch, so another gradient, and
running statistics that differ between ranks. :class:`torch.nn.SyncBatchNorm` fixes this on GPUs
only: torch 2.13 refuses CPU tensors ("SyncBatchNorm expected input tensor to be on GPU"), and the
gloo runs on the CPU are where this project trains and tests. :class:`GlobalBatchNorm` does the
same on every device with one differentiable all-reduce per layer and pass: the per-channel sums of
``d`` and ``d^2`` and the sample count, summed over ranks, give the global mean and (biased)
variance, used to normalise, and its unbiased form for the running variance. ``d`` is the input less
the running mean, which is the same on every rank: once it tracks the batch mean, ``E[d^2] - E[d]^2``
loses nothing to cancellation (the shifted-data algorithm); the sums are accumulated in float64.
Gradients flow through the all-reduce (:func:`all_reduce`, whose backward all-reduces the gradient,
as the deprecated ``torch.distributed.nn.functional.all_reduce`` does), so each rank's backward gives
its slice's share of the gradient of the global-batch loss, what :class:`torch.nn.SyncBatchNorm`
gives on GPUs. In evaluation mode it is plain batch norm with the running statistics.

:func:`global_batchnorm` swaps every batch-norm layer of a network for one of these for the
duration of a training call and puts the originals back; the two share parameters and buffers,
so the originals end with the trained values.
"""

from __future__ import annotations

import contextlib

import torch
import torch.distributed as dist
from torch import nn

__all__ = ["GlobalBatchNorm", "global_batchnorm", "all_reduce"]


class _SumOverRanks(torch.autograd.Function):
    """A tensor summed over all ranks; the gradient likewise (every rank's output depends on every input)."""

    @staticmethod
    def forward(ctx, tensor: torch.Tensor) -> torch.Tensor:
        out = tensor.clone(memory_format=torch.contiguous_format)
        dist.all_reduce(out)
        return out

    @staticmethod
    def backward(ctx, grad: torch.Tensor) -> torch.Tensor:
        grad = grad.clone(memory_format=torch.contiguous_format)
        dist.all_reduce(grad)
        return grad


def all_reduce(tensor: torch.Tensor) -> torch.Tensor:
    """The sum over ranks of ``tensor``, differentiable (shape unchanged)."""
    return _SumOverRanks.apply(tensor)


class GlobalBatchNorm(nn.modules.batchnorm._BatchNorm):
    """Batch norm whose training statistics are those of the batch summed over all ranks.

    Built by :meth:`sharing`, from a batch-norm layer whose parameters and buffers it uses.
    Inputs of shape (B, C, ...) with B possibly 0 on some ranks (as long as the global batch has
    more than one value per channel).
    """

    def _check_input_dim(self, input: torch.Tensor) -> None:
        if input.dim() < 2:
            raise ValueError(f"expected at least 2-D input (B, C, ...), got {input.dim()}-D")

    @classmethod
    def sharing(cls, bn: nn.modules.batchnorm._BatchNorm) -> "GlobalBatchNorm":
        """A layer with ``bn``'s settings, holding the very same parameter and buffer tensors."""
        new = cls(bn.num_features, bn.eps, bn.momentum, bn.affine, bn.track_running_stats)
        for name, p in bn.named_parameters(recurse=False):
            setattr(new, name, p)
        for name, b in bn.named_buffers(recurse=False):
            setattr(new, name, b)
        new.train(bn.training)
        return new

    def forward(self, input: torch.Tensor) -> torch.Tensor:
        """Normalise ``input`` (B, C, ...) per channel; the global batch's statistics when training."""
        self._check_input_dim(input)
        if not self.training or not (dist.is_available() and dist.is_initialized()):
            return super().forward(input)
        c = input.shape[1]
        dims = [0, *range(2, input.dim())]
        shape = [1, c] + [1] * (input.dim() - 2)
        # shifted by the running mean (the same on every rank, a constant here): no cancellation in
        # E[d^2] - E[d]^2 once it tracks the batch mean
        shift = self.running_mean if self.running_mean is not None else input.new_zeros(c)
        d = input - shift.detach().to(input.dtype).reshape(shape)
        n_local = torch.full((1,), float(input.numel() // c if c else 0), dtype=torch.float64, device=input.device)
        stats = all_reduce(
            torch.cat([d.sum(dims, dtype=torch.float64), (d * d).sum(dims, dtype=torch.float64), n_local])
        )
        n = float(stats[2 * c].item())
        if n <= 1:
            raise ValueError(f"expected more than 1 value per channel over all ranks when training, got {n:.0f}")
        m1, m2 = stats[:c] / n, stats[c : 2 * c] / n
        var = (m2 - m1 * m1).clamp_min(0.0)
        if self.track_running_stats:
            self._update_running_stats(m1.detach() + shift.detach().double(), var.detach(), n)
        y = (d - m1.to(input.dtype).reshape(shape)) * torch.rsqrt(var + self.eps).to(input.dtype).reshape(shape)
        if self.affine:
            y = y * self.weight.reshape(shape) + self.bias.reshape(shape)
        return y

    @torch.no_grad()
    def _update_running_stats(self, mean: torch.Tensor, var: torch.Tensor, n: float) -> None:
        """As :func:`torch.nn.functional.batch_norm`: the unbiased variance into the running average."""
        self.num_batches_tracked.add_(1)
        factor = 1.0 / float(self.num_batches_tracked.item()) if self.momentum is None else self.momentum
        self.running_mean.mul_(1.0 - factor).add_(mean.to(self.running_mean.dtype), alpha=factor)
        unbiased = var * (n / (n - 1.0))
        self.running_var.mul_(1.0 - factor).add_(unbiased.to(self.running_var.dtype), alpha=factor)


@contextlib.contextmanager
def global_batchnorm(model: nn.Module):
    """Within the block, every batch-norm layer of ``model`` is a :class:`GlobalBatchNorm` sharing its tensors.

    The original layers are put back on leaving (also on an error); having shared parameters and
    buffers with their stand-ins, they hold what training made of them.

    Yields
    ------
    torch.nn.Module
        ``model`` itself, changed in place.
    """
    swapped = []
    for parent in list(model.modules()):
        for name, child in list(parent.named_children()):
            if isinstance(child, nn.modules.batchnorm._BatchNorm) and not isinstance(child, GlobalBatchNorm):
                setattr(parent, name, GlobalBatchNorm.sharing(child))
                swapped.append((parent, name, child))
    try:
        yield model
    finally:
        for parent, name, child in swapped:
            child.train(getattr(parent, name).training)
            setattr(parent, name, child)
