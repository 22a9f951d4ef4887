"""Principal curvatures of a surface known only as oriented samples, and the second-order point-to-plane residual.

Why it matters: a projective match pairs a model sample ``m`` anywhere in a
pixel with the observed point on that pixel's centre ray. On a curved link
the observed point lies off ``m``'s tangent plane by ``d^T S d / 2`` (``d``
the offset along the surface, ``S`` the shape operator), always on the
inside of a convex part, so the plain point-to-plane residual carries a
one-signed bias of a fraction of a millimetre, which pulls the camera along
its optical axis. With ``S`` known the residual is corrected to second order:

.. math:: r = n^T (x - m) + \\tfrac12 d^T S d, \\qquad d = (I - n n^T)(x - m)

and its gradient in ``x`` is ``n + S d``, the normal at the observed point.

``S`` is fitted from each sample's neighbours (normals against positions,
least squares in the tangent plane), so it is the curvature at the scale of
the samples, which is the scale of the pixels; neighbours across a crease
(normals more than ``max_angle_deg`` apart) are left out. Written by hand
because trimesh's discrete curvature measures give a scalar per ball, not
the principal directions, and need the mesh rather than samples.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from classic.markerless.rows import cross_rows

__all__ = ["sample_curvatures", "second_order_residual", "residual_under_noise", "MIN_RAY_COSINE", "MOVE_SIGMAS"]

#: The smallest ``|n . ray|`` (``ray`` with a unit depth) an observed point is moved along its ray onto the matched
#: surface by (:func:`residual_under_noise`); a surface seen more nearly edge-on keeps the observed point.
MIN_RAY_COSINE = 0.2
#: The farthest that move goes, in the point's depth-noise sigmas (an outlier's move is cut short).
MOVE_SIGMAS = 3.0


def _tangent_basis(n):
    """Two unit vectors perpendicular to each normal, shape (K, 2, 3)."""
    helper = np.where(np.abs(n[:, :1]) < 0.9, np.array([[1.0, 0, 0]]), np.array([[0, 1.0, 0]]))
    t1 = np.cross(n, helper)
    t1 /= np.linalg.norm(t1, axis=1, keepdims=True)
    t2 = np.cross(n, t1)
    return np.stack([t1, t2], axis=1)


def sample_curvatures(
    points: np.ndarray,
    normals: np.ndarray,
    radius_m: float,
    max_angle_deg: float = 35.0,
    max_curvature_per_m: float = 50.0,
    neighbours: int = 16,
) -> tuple[np.ndarray, np.ndarray]:
    """Principal curvatures and the first principal direction of every sample.

    Parameters
    ----------
    points, normals : array, shape (K, 3)
        Samples of one rigid surface and their outward unit normals (any one frame, metres).
    radius_m : float
        Neighbourhood radius, about twice the sample spacing.
    max_angle_deg : float
        Neighbours whose normal is farther than this are across a crease and left out.
    max_curvature_per_m : float
        Curvatures are clipped to this magnitude (a fillet tighter than 2 cm is beyond the
        second-order model at a pixel's offset).
    neighbours : int
        At most this many neighbours per sample.

    Returns
    -------
    curvatures : array, shape (K, 2)
        ``kappa_1 >= kappa_2``, 1/m, positive where the surface is convex (normals diverge). Zero
        where fewer than 4 neighbours agree.
    direction : array, shape (K, 3)
        Unit tangent along ``kappa_1``; the second direction is ``normal x direction``.
    """
    points = np.asarray(points, dtype=float)
    normals = np.asarray(normals, dtype=float)
    k_total = len(points)
    basis = _tangent_basis(normals)
    curv = np.zeros((k_total, 2))
    direction = basis[:, 0].copy()
    if k_total < 5:
        return curv, direction
    k = min(neighbours + 1, k_total)
    dist, j = cKDTree(points).query(points, k=k, distance_upper_bound=radius_m)
    j = j[:, 1:]
    valid = np.isfinite(dist[:, 1:])
    j_safe = np.where(valid, j, 0)
    dx = points[j_safe] - points[:, None]  # (K, k-1, 3)
    dn = normals[j_safe] - normals[:, None]
    valid &= np.einsum("ikc,ic->ik", normals[j_safe], normals) > np.cos(np.radians(max_angle_deg))
    d2 = np.einsum("ikc,iac->ika", dx, basis)  # tangent-plane offsets (K, k-1, 2)
    g2 = np.einsum("ikc,iac->ika", dn, basis)  # tangent-plane normal changes
    w = valid.astype(float)
    A = np.einsum("ik,ika,ikb->iab", w, d2, d2)  # sum d d^T
    B = np.einsum("ik,ika,ikb->iab", w, g2, d2)  # sum dn d^T
    ok = (valid.sum(1) >= 4) & (np.linalg.det(A) > 1e-6 * np.einsum("iaa->i", A) ** 2)
    G = np.zeros((k_total, 2, 2))
    G[ok] = B[ok] @ np.linalg.inv(A[ok])
    S = 0.5 * (G + np.swapaxes(G, 1, 2))
    vals, vecs = np.linalg.eigh(S)  # ascending
    curv[ok] = np.clip(vals[ok][:, ::-1], -max_curvature_per_m, max_curvature_per_m)
    e1 = np.einsum("ia,iac->ic", vecs[:, :, 1], basis)
    direction[ok] = e1[ok] / np.linalg.norm(e1[ok], axis=1, keepdims=True)
    return curv, direction


def second_order_residual(
    x_base: np.ndarray,
    m_base: np.ndarray,
    n_base: np.ndarray,
    curvatures: np.ndarray,
    direction_base: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """Point-to-surface residual to second order, and its gradient in the observed point.

    Parameters
    ----------
    x_base : array, shape (N, 3)
        Observed points in the base frame.
    m_base, n_base : array, shape (N, 3)
        Matched model samples and their unit normals.
    curvatures : array, shape (N, 2)
        ``kappa_1, kappa_2`` of the samples (1/m).
    direction_base : array, shape (N, 3)
        Unit tangent along ``kappa_1``.

    Returns
    -------
    r : array, shape (N,)
        ``n^T (x - m) + (kappa_1 a^2 + kappa_2 b^2) / 2`` with ``a, b`` the offsets along the two
        principal directions, metres.
    grad : array, shape (N, 3)
        ``n + S d``: the surface normal at the observed point, to first order.
    """
    delta = x_base - m_base
    e2 = cross_rows(n_base, direction_base)
    a = np.einsum("ij,ij->i", delta, direction_base)
    b = np.einsum("ij,ij->i", delta, e2)
    k1, k2 = curvatures[:, 0], curvatures[:, 1]
    r = np.einsum("ij,ij->i", n_base, delta) + 0.5 * (k1 * a**2 + k2 * b**2)
    grad = n_base + (k1 * a)[:, None] * direction_base + (k2 * b)[:, None] * e2
    return r, grad


def residual_under_noise(
    x_base: np.ndarray,
    m_base: np.ndarray,
    n_base: np.ndarray,
    curvatures: np.ndarray | None,
    direction_base: np.ndarray | None,
    ray_base: np.ndarray,
    variance: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The residual of :func:`second_order_residual` for an observed point with noise along its ray, its mean
    under that noise taken out, the gradient where the noise does not enter, and how far the point lies off the
    surface along its ray.

    The observed point is ``x = x_s + e ray``, ``x_s`` on the surface, ``e`` the depth noise (variance
    ``sigma^2``). The second-order term ``d^T S d / 2`` holds the noise's tangential part squared, whose mean
    ``sigma^2 t^T S t / 2`` (``t`` the ray's tangential part) is one-signed on a convex part: it is taken out of
    the residual. The gradient ``n + S d`` at the observed point holds the noise too, and multiplied by the
    residual, which holds it as well, it biases every unknown the gradient enters (errors in variables; on the
    robot's 4 cm links at a D435's noise the focal length about 0.2 % low and the camera a millimetre or two too
    far along its axis): it is taken at the point moved along its ray onto the matched tangent plane, which
    holds no noise to first order. The move, ``(n^T (x - m)) / (n^T ray)``, is left 0 on a surface seen within
    :data:`MIN_RAY_COSINE` of edge-on and cut at :data:`MOVE_SIGMAS` sigmas; the caller takes the Jacobian's
    columns that hold the observed point at the moved point too.

    Parameters
    ----------
    x_base, m_base, n_base : array, shape (N, 3)
        Observed points, matched model samples and their unit normals, base frame.
    curvatures : array, shape (N, 2), or None
        ``kappa_1, kappa_2`` of the samples (1/m); None: a plane at each sample (first order).
    direction_base : array, shape (N, 3), or None
        Unit tangent along ``kappa_1``; given with ``curvatures``.
    ray_base : array, shape (N, 3)
        Each point's ray in the base frame, scaled to a unit depth along the camera's axis.
    variance : array, shape (N,)
        Each point's depth-noise variance along the camera's axis, m^2.

    Returns
    -------
    r : array, shape (N,)
        The residual less the noise's mean, metres.
    grad : array, shape (N, 3)
        The residual's gradient in the observed point, taken at the moved point.
    move : array, shape (N,)
        The depth (along the camera's axis, metres) the point was moved back along its ray.
    """
    delta = x_base - m_base
    plane = np.einsum("ij,ij->i", n_base, delta)
    n_ray = np.einsum("ij,ij->i", n_base, ray_base)
    sigma = np.sqrt(np.maximum(variance, 0.0))
    seen = np.abs(n_ray) > MIN_RAY_COSINE
    move = np.clip(np.where(seen, plane / np.where(seen, n_ray, 1.0), 0.0), -MOVE_SIGMAS * sigma, MOVE_SIGMAS * sigma)
    if curvatures is None:
        return plane, n_base, move
    e2 = cross_rows(n_base, direction_base)
    k1, k2 = curvatures[:, 0], curvatures[:, 1]
    a, b = np.einsum("ij,ij->i", delta, direction_base), np.einsum("ij,ij->i", delta, e2)
    ta, tb = np.einsum("ij,ij->i", ray_base, direction_base), np.einsum("ij,ij->i", ray_base, e2)
    r = plane + 0.5 * (k1 * a**2 + k2 * b**2) - 0.5 * variance * (k1 * ta**2 + k2 * tb**2)
    a_s, b_s = a - move * ta, b - move * tb  # the tangential offsets of the moved point
    grad = n_base + (k1 * a_s)[:, None] * direction_base + (k2 * b_s)[:, None] * e2
    return r, grad, move
