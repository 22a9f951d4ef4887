"""Evaluation metrics of the paper: translation error in mm, rotation error in degrees (eq. 2).

Numpy, so they apply to any prediction (learned, classic, truth).
"""

from __future__ import annotations

import numpy as np

__all__ = ["translation_errors_mm", "rotation_errors_deg", "summarize"]


def translation_errors_mm(t_mm: np.ndarray, t_true_mm: np.ndarray) -> np.ndarray:
    """Euclidean distance per sample, mm. Shapes (N, 3) -> (N,)."""
    return np.linalg.norm(np.asarray(t_mm, dtype=float) - np.asarray(t_true_mm, dtype=float), axis=-1)


def rotation_errors_deg(q: np.ndarray, q_true: np.ndarray) -> np.ndarray:
    """Eq. 2: ``720 / pi * asin(0.5 * min(|q - q*|, |q + q*|))``, degrees; the rotation angle between them.

    Parameters
    ----------
    q, q_true : array, shape (N, 4)
        Unit quaternions (either order, the same for both).

    Returns
    -------
    array, shape (N,)
    """
    q, q_true = np.asarray(q, dtype=float), np.asarray(q_true, dtype=float)
    d = np.minimum(np.linalg.norm(q - q_true, axis=-1), np.linalg.norm(q + q_true, axis=-1))
    return 720.0 / np.pi * np.arcsin(np.clip(0.5 * d, 0.0, 1.0))


def summarize(errors: np.ndarray) -> dict:
    """Mean, median and RMSE of per-sample errors (NaN for none)."""
    e = np.asarray(errors, dtype=float)
    if e.size == 0:
        return {"mean": float("nan"), "median": float("nan"), "rmse": float("nan"), "n": 0}
    return {
        "mean": float(e.mean()),
        "median": float(np.median(e)),
        "rmse": float(np.sqrt(np.mean(e**2))),
        "n": int(e.size),
    }
