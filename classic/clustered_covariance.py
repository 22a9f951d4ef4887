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
"""

from __future__ import annotations

import numpy as np

__all__ = ["clustered_covariance", "pose_sigma"]


def clustered_covariance(
    J: np.ndarray,
    r: np.ndarray,
    w: np.ndarray,
    group: np.ndarray | None = None,
    prior_information: np.ndarray | None = None,
    cross_group: np.ndarray | None = None,
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
    cross_group : array of int, shape (M,), optional
        A second clustering of the residuals (errors shared across the groups, such as a depth bin):
        two-way clustered when given with ``group``.

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
    if cross_group is not None:
        c, n_c = _codes(cross_group)
        cross = _cluster_meat(scores, c, n_c)
        both = _cluster_meat(scores, *_codes(g * n_c + c))  # the (group, cross_group) pairs, one integer each
        if cross is not None and both is not None:
            value, vector = np.linalg.eigh(meat + cross - both)
            meat = (vector * np.maximum(value, 0.0)) @ vector.T
    sandwich = H_inv @ (meat + variance * prior) @ H_inv
    return sandwich if np.trace(sandwich) >= np.trace(plain) else plain


def _codes(group: np.ndarray) -> tuple[np.ndarray, int]:
    """Each residual's cluster as 0..k-1, and k."""
    labels, where = np.unique(np.asarray(group), return_inverse=True)
    return where.reshape(-1), len(labels)


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
