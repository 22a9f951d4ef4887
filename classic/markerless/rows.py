"""Row-wise vector arithmetic on (N, 3) arrays, as the registration's inner loops use it."""

from __future__ import annotations

import numpy as np

__all__ = ["cross_rows"]


def cross_rows(a: np.ndarray, b: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
    """``a x b`` over the last axis, broadcast: ``np.cross``'s products and differences, bit for bit, about twice
    as fast on (N, 3) rows (each component written in place, no stack of temporaries).

    Parameters
    ----------
    a, b : array, shape (..., 3)
    out : array, shape (the broadcast shape), optional
        Written and returned (a view, such as a Jacobian's three columns, will do).

    Returns
    -------
    array, shape (the broadcast shape of ``a`` and ``b``)
    """
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    if out is None:
        out = np.empty(np.broadcast_shapes(a.shape, b.shape), dtype=np.result_type(a, b))
    for k, (x, y, z, w) in enumerate(((a1, b2, a2, b1), (a2, b0, a0, b2), (a0, b1, a1, b0))):
        np.multiply(x, y, out=out[..., k])
        out[..., k] -= z * w
    return out
