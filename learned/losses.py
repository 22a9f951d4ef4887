"""Training losses: translation MSE in millimetres, chordal quaternion distance (the paper's eq. 1)."""

from __future__ import annotations

import torch

__all__ = ["translation_loss", "chordal_loss"]


def translation_loss(t_mm: torch.Tensor, t_true_mm: torch.Tensor) -> torch.Tensor:
    """Mean squared error over samples and axes, mm^2. Shapes (B, 3)."""
    return torch.mean((t_mm - t_true_mm) ** 2)


def chordal_loss(q: torch.Tensor, q_true: torch.Tensor) -> torch.Tensor:
    """Mean squared chordal distance of unit quaternions, sign-invariant: ``min(|q - q*|^2, |q + q*|^2)``.

    ``q`` and ``-q`` are the same rotation, so the loss is zero at either sign of the truth
    (eq. 1 of the paper with the double cover taken into account). Shapes (B, 4).
    """
    minus = torch.sum((q - q_true) ** 2, dim=-1)
    plus = torch.sum((q + q_true) ** 2, dim=-1)
    return torch.mean(torch.minimum(minus, plus))
