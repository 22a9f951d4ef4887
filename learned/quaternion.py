"""The 10-D quaternion layer (Peretroukhin et al. 2020): 10 numbers -> symmetric 4x4 A -> unit quaternion.

The quaternion is the eigenvector of A's smallest eigenvalue, the minimiser of
``q^T A q`` over unit q: smooth in A wherever that eigenvalue is simple, valid
for any network output, and defined up to sign; the sign is fixed to the half
space ``w >= 0`` (the canonical form of :mod:`handeye.core.conventions`). Quaternions
are ``(x, y, z, w)``.
"""

from __future__ import annotations

import torch

__all__ = ["symmetric_from_10", "quaternion_from_10", "canonical"]

_ROWS, _COLS = torch.triu_indices(4, 4)


def symmetric_from_10(a: torch.Tensor) -> torch.Tensor:
    """Symmetric matrices from their upper triangles.

    Parameters
    ----------
    a : tensor, shape (B, 10)

    Returns
    -------
    A : tensor, shape (B, 4, 4)
    """
    if a.shape[-1] != 10:
        raise ValueError(f"the quaternion layer takes 10 values per sample, got shape {tuple(a.shape)}")
    A = a.new_zeros(a.shape[:-1] + (4, 4))
    A[..., _ROWS, _COLS] = a
    A[..., _COLS, _ROWS] = a
    return A


def canonical(q: torch.Tensor) -> torch.Tensor:
    """The sign of each quaternion (x, y, z, w) with ``w >= 0``."""
    sign = torch.where(q[..., 3:4] < 0, -1.0, 1.0).to(q.dtype)
    return q * sign


def quaternion_from_10(a: torch.Tensor) -> torch.Tensor:
    """Unit quaternions ``(x, y, z, w)``, ``w >= 0``, from the network's 10 outputs.

    Parameters
    ----------
    a : tensor, shape (B, 10)

    Returns
    -------
    q : tensor, shape (B, 4)
    """
    _, vectors = torch.linalg.eigh(symmetric_from_10(a))
    return canonical(vectors[..., :, 0])
