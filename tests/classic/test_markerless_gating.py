"""The fine stage's gate on the depth along the pixel's ray and the crease samples it leaves out
(:mod:`classic.markerless.gating`), on geometry whose answer is known."""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from classic.markerless import MarkerlessOptions
from classic.markerless.gating import DEPTH_GATES, crease_flags_from_first_frame, near_a_crease, within_gate
from handeye.core.errors import HandEyeInputError

GATE_M = 0.01


def _steep_plane(offset_m: float):
    """Rays over a plane at 1 m turned 70 deg from the camera's axis; each ray's sample ``offset_m`` along the plane
    off where the ray meets it (a projective match's sample anywhere in its pixel). Returns the ray's point on the
    plane, the sample and the plane's normal, camera frame."""
    n = np.array([np.sin(np.radians(70.0)), 0.0, -np.cos(np.radians(70.0))])
    along = np.cross(n, [0.0, 1.0, 0.0])
    rays = np.c_[np.linspace(-0.1, 0.1, 21), np.zeros(21), np.ones(21)]
    point = rays * ((n @ [0.0, 0.0, 1.0]) / (rays @ n))[:, None]  # the plane through (0, 0, 1)
    return point, point + offset_m * along, np.tile(n, (len(rays), 1))


def test_an_observed_point_on_the_samples_tangent_plane_is_kept_however_far_off_its_ray_the_sample_is():
    """A noise-free point on a steep plane whose sample lies 2 cm along the plane: the depth difference is about
    1.9 cm (the offset times the sine of the 70 deg tilt), beyond the 1 cm gate, which the depth difference alone
    would cut; along the ray it is 0, and the row is kept."""
    q, p, n = _steep_plane(0.02)
    assert np.all(np.abs(q[:, 2] - p[:, 2]) > GATE_M)  # the old gate on the depth difference drops every row
    assert np.all(within_gate(q, p, n, GATE_M))


def test_a_point_off_the_tangent_plane_along_its_ray_by_more_than_the_gate_is_dropped():
    """The same rows with the observed point moved along its ray by 1.5 gates (dropped) and by 0.5 (kept); with the
    sample so far off the ray that the depths differ by more than DEPTH_GATES gates, dropped too."""
    q, p, n = _steep_plane(0.0)
    ray = q / q[:, 2:3]
    assert not np.any(within_gate(q + 1.5 * GATE_M * ray, p, n, GATE_M))
    assert np.all(within_gate(q - 0.5 * GATE_M * ray, p, n, GATE_M))
    far_q, far_p, far_n = _steep_plane(1.2 * DEPTH_GATES * GATE_M / np.sin(np.radians(70.0)))
    assert not np.any(within_gate(far_q, far_p, far_n, GATE_M))


def test_no_depth_or_a_ray_in_the_tangent_plane_is_not_kept():
    q, p, n = _steep_plane(0.0)
    q[0] = np.nan
    n[1] = np.cross(q[1], [0.0, 1.0, 0.0]) / np.linalg.norm(q[1])  # the ray lies in the tangent plane
    kept = within_gate(q, p, n, GATE_M)
    assert not kept[0] and not kept[1] and np.all(kept[2:])


def _cube(side_m: float = 0.06, spacing_m: float = 0.002):
    """Samples of a cube's six faces on a grid (cell centres), outward normals, and each sample's distance to the
    nearest edge of its face."""
    g = (np.arange(int(round(side_m / spacing_m))) + 0.5) * spacing_m - side_m / 2
    a, b = (x.ravel() for x in np.meshgrid(g, g))
    points, normals, edge = [], [], []
    for axis in range(3):
        for sign in (-1.0, 1.0):
            p = np.zeros((len(a), 3))
            p[:, axis] = sign * side_m / 2
            p[:, (axis + 1) % 3], p[:, (axis + 2) % 3] = a, b
            n = np.zeros((len(a), 3))
            n[:, axis] = sign
            points.append(p)
            normals.append(n)
            edge.append(side_m / 2 - np.maximum(np.abs(a), np.abs(b)))
    return np.vstack(points), np.vstack(normals), np.concatenate(edge)


def test_the_samples_near_a_cubes_edges_are_found_and_the_faces_middles_not():
    """With an 8 mm radius on 2 mm cells: every sample nearer an edge than the radius less a cell is flagged, none
    farther than the radius; on one flat face alone none is."""
    points, normals, edge = _cube()
    radius = 0.008
    flagged = near_a_crease(cKDTree(points), normals, np.arange(len(points)), radius)
    assert np.all(flagged[edge < radius - 0.002]) and not np.any(flagged[edge > radius])
    face = slice(0, len(points) // 6)
    flat = near_a_crease(cKDTree(points[face]), normals[face], np.arange(len(points) // 6), radius)
    assert not np.any(flat)
    assert near_a_crease(cKDTree(points), normals, np.zeros(0, int), radius).shape == (0,)


def test_a_gentle_bend_is_no_crease():
    """Two planes meeting at 20 deg (below the 35 deg of a crease): nothing flagged."""
    g = (np.arange(20) + 0.5) * 0.002
    a, b = (x.ravel() for x in np.meshgrid(g, g))
    t = np.radians(20.0)
    left = np.c_[-a, b, np.zeros_like(a)]
    right = np.c_[a * np.cos(t), b, a * np.sin(t)]
    normals = np.vstack([np.tile([0.0, 0.0, -1.0], (len(a), 1)), np.tile([np.sin(t), 0.0, -np.cos(t)], (len(a), 1))])
    points = np.vstack([left, right])
    assert not np.any(near_a_crease(cKDTree(points), normals, np.arange(len(points)), 0.008))


def test_the_crease_radius_is_checked():
    assert MarkerlessOptions(crease_radius_m=None).crease_radius_m is None
    for bad in (0.0, -0.01, float("nan")):
        try:
            MarkerlessOptions(crease_radius_m=bad)
        except HandEyeInputError as e:
            assert "crease_radius_m" in str(e)
        else:
            raise AssertionError(f"crease_radius_m={bad} accepted")


def test_the_first_frames_creases_are_every_frames_where_the_frames_hold_the_same_samples():
    """A cube and a plate beside it, moved rigidly from frame to frame: the flags found on the first frame and
    repeated are those of a test in each frame; a surface whose frames hold other samples is left to that test."""
    from scipy.spatial.transform import Rotation

    cube, cube_n, _ = _cube()
    g = (np.arange(10) + 0.5) * 0.002
    plate = np.c_[[x.ravel() for x in np.meshgrid(g, g)]].T
    plate = np.c_[plate + 0.04, np.zeros(len(plate))]  # 1 cm beyond the cube's face at x = 0.03
    points0 = np.vstack([cube, plate])
    normals0 = np.vstack([cube_n, np.tile([0.0, 0.0, 1.0], (len(plate), 1))])
    part0 = np.r_[np.zeros(len(cube), int), np.ones(len(plate), int)]
    rng = np.random.default_rng(2)
    points, normals, frame = [], [], []
    for f in range(3):
        R = Rotation.random(random_state=rng).as_matrix()
        points.append(points0 @ R.T + rng.normal(size=3))
        normals.append(normals0 @ R.T)
        frame.append(np.full(len(points0), f))
    points, normals, frame = np.vstack(points), np.vstack(normals), np.concatenate(frame)
    part = np.tile(part0, 3)
    radius = 0.008
    flags = crease_flags_from_first_frame(points, normals, frame, part, radius)
    keyed = cKDTree(np.c_[points, frame * 1000.0])  # each sample among its own frame's
    assert np.array_equal(flags, near_a_crease(keyed, normals, np.arange(len(points)), radius))
    assert flags.any() and not flags.all()
    assert crease_flags_from_first_frame(points[1:], normals[1:], frame[1:], part[1:], radius) is None
