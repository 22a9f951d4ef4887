"""Which projective matches the fine stage keeps: the gate on the depth along the pixel's ray, and the samples at
the model's creases.

Both keep the kept rows' noise symmetric, so that the fit's noise terms
(:func:`classic.markerless.curvature.residual_under_noise`) take out a bias the gate did not put in:

- **The gate along the ray.** A projective match pairs a pixel's ray with a model sample somewhere in that pixel.
  On a steep surface that sample lies off the ray, and the depth difference ``q_z - p_z`` holds the surface's slope
  times that offset as well as the noise: a gate on it cuts the noise one-sidedly, row by row. The depth from the
  observed point to where the ray meets the sample's tangent plane, ``n . (q - p) / n . ray`` (``ray`` at a unit
  depth), holds the noise alone; the gate is on that, with the depth difference within three gates (a sample
  seen nearly edge-on, whose tangent plane the ray meets far away, is not kept).
- **The creases.** Where a link's side meets its end cap, a pixel's ray near the edge can meet the other face
  within the gate; the second-order residual, whose curvature leaves neighbours across a crease out
  (:func:`classic.markerless.curvature.sample_curvatures`), cannot fit that row. On `paper-sim` 1.6 % of the rows
  within 2 cm had a noise-free residual over 2 mm, 94 % of them with a sample within 8 mm of a crease; they put the
  noise-free focal length 0.17 px high (``benchmarks/results/markerless_noise_extrapolation.md``). Samples with a
  neighbour within :attr:`MarkerlessOptions.crease_radius_m` whose normal is over :data:`CREASE_ANGLE_DEG` apart
  are left out of every association.

Written by hand: the gate is one line of the association, the crease test a ball query of scipy's KD-tree.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

__all__ = ["within_gate", "near_a_crease", "crease_flags_from_first_frame", "CREASE_ANGLE_DEG", "DEPTH_GATES"]

#: Normals farther apart than this meet at a crease (:func:`classic.markerless.curvature.sample_curvatures`'s
#: ``max_angle_deg``).
CREASE_ANGLE_DEG = 35.0
#: The depth difference a kept match may have, in gates (a bound on how far off its ray the sample lies).
DEPTH_GATES = 3.0


def within_gate(q_cam: np.ndarray, p_cam: np.ndarray, n_cam: np.ndarray, gate_m: float) -> np.ndarray:
    """Whether each match's observed point is within ``gate_m`` of the sample's tangent plane along its ray.

    Parameters
    ----------
    q_cam : array, shape (N, 3)
        Observed points (corrected depth), camera frame, metres; NaN where the pixel has none.
    p_cam, n_cam : array, shape (N, 3)
        The matched model samples and their unit normals, camera frame.
    gate_m : float
        The gate, metres.

    Returns
    -------
    array of bool, shape (N,)
        ``|n . (q - p) / n . (q / q_z)| < gate_m`` and ``|q_z - p_z| <`` :data:`DEPTH_GATES` ``gate_m``; False where
        ``q`` is NaN or the ray lies in the tangent plane.
    """
    with np.errstate(invalid="ignore", divide="ignore"):
        along = np.einsum("ij,ij->i", n_cam, q_cam - p_cam) / np.einsum("ij,ij->i", n_cam, q_cam / q_cam[:, 2:3])
        return (np.abs(along) < gate_m) & (np.abs(q_cam[:, 2] - p_cam[:, 2]) < DEPTH_GATES * gate_m)


def near_a_crease(
    tree: cKDTree, normals: np.ndarray, which: np.ndarray, radius_m: float, max_angle_deg: float = CREASE_ANGLE_DEG
) -> np.ndarray:
    """Whether each sample ``which`` has a neighbour within ``radius_m`` whose normal is over ``max_angle_deg`` from
    its own.

    Parameters
    ----------
    tree : scipy.spatial.cKDTree
        Over every sample's position (any extra coordinates, such as a frame key, keep samples apart).
    normals : array, shape (K, 3)
        Every sample's unit normal, in the tree's order.
    which : array of int, shape (M,)
        The samples to test.
    radius_m : float
        The neighbourhood's radius, metres.
    max_angle_deg : float

    Returns
    -------
    array of bool, shape (M,)
    """
    which = np.asarray(which, dtype=np.int64)
    if len(which) == 0:
        return np.zeros(0, bool)
    lists = tree.query_ball_point(tree.data[which], r=radius_m, return_sorted=False)
    counts = np.fromiter((len(j) for j in lists), dtype=np.int64, count=len(which))  # each holds the sample itself
    neighbours = np.fromiter((i for j in lists for i in j), dtype=np.int64, count=int(counts.sum()))
    cosine = np.einsum("ij,ij->i", normals[neighbours], normals[np.repeat(which, counts)])
    return np.minimum.reduceat(cosine, np.r_[0, np.cumsum(counts)[:-1]]) < np.cos(np.radians(max_angle_deg))


def crease_flags_from_first_frame(
    points: np.ndarray, normals: np.ndarray, frame: np.ndarray, part: np.ndarray, radius_m: float
) -> np.ndarray | None:
    """:func:`near_a_crease` of every sample of a surface posed per frame, tested on the first frame's samples only
    and repeated for the others; None where the frames do not each hold the first frame's samples in its order.

    A link's own creases move with the link, and where two links meet moves little with the joints: on
    `paper-real`'s placements 0.3 % of the samples differ from a test in each frame, at a sixtieth of its time.

    Parameters
    ----------
    points, normals : array, shape (M, 3)
        Every sample's position and unit normal, the frames stacked in order.
    frame, part : array of int, shape (M,)
        Each sample's frame and rigid part.
    radius_m : float

    Returns
    -------
    array of bool, shape (M,), or None
    """
    frames, counts = np.unique(frame, return_counts=True)
    if len(frames) == 0:
        return np.zeros(0, bool)
    n = int(counts[0])
    if not (
        np.all(counts == n)
        and np.array_equal(frame, np.repeat(frames, n))
        and np.array_equal(part, np.tile(part[:n], len(frames)))
    ):
        return None
    first = near_a_crease(cKDTree(points[:n]), normals[:n], np.arange(n), radius_m)
    return np.tile(first, len(frames))
