"""The covariance of a 6-parameter pose fit whose residuals come in correlated groups (frames).

Residuals of one frame share errors (the model's discretisation, the sensor's systematic error, a
detector's bias for that view); counted as independent they give a sigma several times too small.
The sandwich (cluster-robust) estimate with one cluster per group counts each group once:

.. math:: C = H^{-1} \\Big(\\tfrac{k}{k-1} \\sum_g s_g s_g^T\\Big) H^{-1}, \\quad
          H = \\sum_i w_i J_i^T J_i, \\quad s_g = \\sum_{i \\in g} w_i J_i^T r_i

The plain ``s^2 H^{-1}`` (the residuals' own scatter) is kept as a floor: the larger of the two, by
trace, is returned. Used by the markerless registration and the cross-frame keypoint solve.

An error can also be shared along a second dimension across the groups: a depth sensor's bias that depends
on the depth (a stereo matcher's pull toward whole disparities, a time-of-flight camera's wiggling) is the
same in every frame at that depth, so frames agree with each other while all being off together. With
``cross_group`` (the depth bin of each residual) the estimate is two-way clustered (Cameron, Gelbach & Miller,
"Robust inference with multiway clustering", J. Business & Economic Statistics 29(2), 2011):
``C = C_group + C_cross - C_both``, its negative eigenvalues set to zero.

Several cross clusterings (the depth bin and the image tile of each residual: a sensor's fixed pattern is the
same in every frame at one image position) make it multiway: the inclusion-exclusion sum over the non-empty
subsets ``S`` of the clusterings, ``sum_S (-1)^(|S|+1) C_S``, ``C_S`` clustered by the intersection of the
clusterings in ``S`` (Cameron, Gelbach & Miller 2011, section 2.3); with two clusterings it is the two-way sum.
"""

from __future__ import annotations

from itertools import combinations
from typing import Sequence

import numpy as np

__all__ = ["clustered_covariance", "pose_sigma"]


def clustered_covariance(
    J: np.ndarray,
    r: np.ndarray,
    w: np.ndarray,
    group: np.ndarray | None = None,
    prior_information: np.ndarray | None = None,
    cross_group: np.ndarray | Sequence[np.ndarray | None] | None = None,
) -> np.ndarray:
    """Covariance of the parameters of a weighted least-squares fit, clustered by group.

    Parameters
    ----------
    J : array, shape (M, 6)
        Jacobian rows of the residuals at the solution.
    r : array, shape (M,)
        Residuals.
    w : array, shape (M,)
        Their (robust) weights.
    group : array of int, shape (M,), optional
        Cluster of each residual; the plain estimate when omitted or with a single cluster.
    prior_information : array, shape (P, P), optional
        A Gaussian prior on the parameters as an extra, independent observation, in the units of ``J^T J``
        (its inverse times the residual variance is the prior's covariance): added to the information, and
        to the scores' variance times the residuals' variance.
    cross_group : array of int, shape (M,), or a sequence of them (None entries skipped), optional
        Further clusterings of the residuals (errors shared across the groups, such as a depth bin or an
        image tile): multiway clustered with ``group``. A clustering with a single cluster is left out.

    Returns
    -------
    array, shape (6, 6)
    """
    Jw = J * w[:, None]
    prior = np.zeros((J.shape[1], J.shape[1])) if prior_information is None else np.asarray(prior_information)
    H_inv = np.linalg.pinv(Jw.T @ J + prior)
    dof = max(float(w.sum()) - J.shape[1], 1.0)
    variance = float((w * r**2).sum() / dof)
    plain = H_inv * variance
    if group is None:
        return plain
    scores = Jw * r[:, None]
    g, n_g = _codes(group)
    meat = _cluster_meat(scores, g, n_g)
    if meat is None:
        return plain
    crosses = []
    if cross_group is not None:
        is_one = np.isscalar(cross_group[0]) if len(cross_group) else True  # one clustering, not several
        for clustering in [cross_group] if is_one else cross_group:
            if clustering is not None and _codes(clustering)[1] >= 2:
                crosses.append(_codes(clustering))
    if crosses:
        clusterings = [(g, n_g), *crosses]
        total = None
        for size in range(1, len(clusterings) + 1):
            sign = 1.0 if size % 2 else -1.0
            for subset in combinations(clusterings, size):
                part = _cluster_meat(scores, *_intersection(subset))
                if part is None:
                    continue
                total = sign * part if total is None else total + sign * part
        value, vector = np.linalg.eigh(total)
        meat = (vector * np.maximum(value, 0.0)) @ vector.T
    sandwich = H_inv @ (meat + variance * prior) @ H_inv
    return sandwich if np.trace(sandwich) >= np.trace(plain) else plain


def _codes(group: np.ndarray) -> tuple[np.ndarray, int]:
    """Each residual's cluster as 0..k-1, and k."""
    labels, where = np.unique(np.asarray(group), return_inverse=True)
    return where.reshape(-1), len(labels)


def _intersection(clusterings) -> tuple[np.ndarray, int]:
    """The clusters of the intersection of several clusterings (each ``(codes, k)``), as :func:`_codes`."""
    codes, k = clusterings[0]
    for other, n_other in clusterings[1:]:
        codes, k = _codes(codes * n_other + other)  # the pairs, one integer each
    return codes, k


def _cluster_meat(scores_per_residual: np.ndarray, codes: np.ndarray, k: int) -> np.ndarray | None:
    """``k / (k - 1) sum_g s_g s_g^T`` over the k clusters (``codes`` from :func:`_codes`), None with fewer
    than two."""
    if k < 2:
        return None
    scores = np.stack([np.bincount(codes, column, minlength=k) for column in scores_per_residual.T], axis=1)
    return scores.T @ scores * k / (k - 1)


def pose_sigma(covariance: np.ndarray, R_base_cam: np.ndarray) -> dict:
    """RMS error norms of a camera pose from the covariance of its right perturbation ``(omega, v)``.

    Parameters
    ----------
    covariance : array, shape (6, 6)
        Of ``(omega, v)`` in the camera frame (rad, m).
    R_base_cam : array, shape (3, 3)
        The camera's rotation: its position error in the base frame is ``R v``.

    Returns
    -------
    dict
        ``rotation_deg``, ``translation_mm``.
    """
    return {
        "rotation_deg": float(np.degrees(np.sqrt(np.trace(covariance[:3, :3])))),
        "translation_mm": float(np.sqrt(np.trace(R_base_cam @ covariance[3:, 3:] @ R_base_cam.T)) * 1e3),
    }
