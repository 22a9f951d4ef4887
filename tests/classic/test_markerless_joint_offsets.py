"""The robot's joint zero offsets estimated with the pose (issue 41 item 3), on an analytic arm of spheres.

A chain of six revolute joints carries one sphere per link over a static base sphere (product of exponentials,
numpy only). The depth is ray-cast at the true joints ``q + delta``; the method is told ``q`` and the parts'
twists at ``q``. Joint 1 turns about the base's fixed vertical axis: with only the moving spheres fitted its
offset is a rotation of the camera, so the truth is the camera in the kinematic base frame,
``T_kin = exp(-delta_1 xi_1) T_phys``. Joint 6 turns the last sphere about its own centre: no residual moves
with it, and it keeps its prior.
"""

from __future__ import annotations

import numpy as np
import pytest

from classic.markerless import MarkerlessOptions, RobotSurfaceFrames, register_robot
from classic.markerless.kinematics import (
    JOINT_OFFSET_PRIORS_DEG,
    joint_offset_prior_deg,
    joint_status,
    moved_surface,
    offset_columns,
    turned_directions,
)
from handeye.core.errors import HandEyeInputError, ShapeError
from handeye.core.se3 import make_transform, so3_exp
from tests.classic.test_markerless import SIGMA_1M, K, _look_at, render_depth, sphere_model, within_sigma
from tests.tolerances import ABSOLUTE_ONLY, FLOAT, JACOBIAN_RTOL, SIGMA_BOUND

#: Joint axes and a point on each, zero configuration (base frame, metres).
AXES = np.array([[0, 0, 1], [0, 1, 0], [0, 1, 0], [0, 1, 0], [0, 0, 1], [1, 0, 0]], dtype=float)
POINTS = np.array([[0, 0, 0], [0, 0, 0.3], [0, 0, 0.6], [0.3, 0, 0.6], [0.3, 0.12, 0.45], [0.45, 0.12, 0.45]])
#: Sphere centres, zero configuration: the static base, then one per link (the last on joint 6's axis).
CENTRES = np.array(
    [
        [0, 0, 0.09],
        [0.1, 0, 0.3],
        [0.08, 0, 0.5],
        [0.3, 0, 0.6],
        [0.3, 0.12, 0.45],
        [0.45, 0.12, 0.45],
        [0.58, 0.12, 0.45],
    ]
)
RADII = np.array([0.09, 0.07, 0.06, 0.05, 0.05, 0.045, 0.04])
#: The offsets (degrees): a few tenths on every joint, as issue 41's real arm.
OFFSETS_DEG = np.array([0.2, -0.3, 0.25, -0.2, 0.3, -0.2])
N_FRAMES = 16


def _rotation_about(axis, point, angle):
    R = so3_exp(axis * angle)
    return make_transform(R, point - R @ point)


def chain(q):
    """Sphere centres (n_parts, 3) and twists (n_parts, 6 joints, 6) at the joints ``q`` (6,)."""
    G = np.eye(4)
    twists = np.zeros((len(CENTRES), len(AXES), 6))
    centres = CENTRES.copy()
    for j, (w, c) in enumerate(zip(AXES, POINTS)):
        w_now, c_now = G[:3, :3] @ w, G[:3, :3] @ c + G[:3, 3]
        twists[j + 1 :, j] = np.r_[w_now, -np.cross(w_now, c_now)]
        G = G @ _rotation_about(w, c, q[j])
        centres[j + 1] = G[:3, :3] @ CENTRES[j + 1] + G[:3, 3]
    return centres, twists


def arm_scene(rng, offsets_deg=OFFSETS_DEG):
    """Depth at ``q + delta``; the surface posed at ``q`` with its twists; the camera physical and kinematic."""
    q = rng.uniform([-0.6, -0.5, -0.6, -0.6, -0.8, -1.0], [0.6, 0.3, 0.6, 0.6, 0.8, 1.0], size=(N_FRAMES, 6))
    delta = np.radians(offsets_deg)
    T_phys = _look_at(np.array([1.0, -0.7, 1.0]), np.array([0.15, 0.0, 0.4]))
    true = np.stack([chain(qi + delta)[0] for qi in q])
    told = [chain(qi) for qi in q]
    depth = render_depth(true, T_phys, rng, radii=RADII)
    surface = sphere_model(np.stack([c for c, _ in told]), radii=RADII)
    surface.joint_twists_base = np.stack([t for _, t in told])
    surface.__post_init__()
    T_kin = _rotation_about(AXES[0], POINTS[0], -delta[0]) @ T_phys  # joint 1's axis is fixed in the base
    return depth, surface, T_phys, T_kin, delta


@pytest.fixture(scope="module")
def scene():
    return arm_scene(np.random.default_rng(3))


def test_twists_are_the_motion_of_the_posed_chain():
    q = np.random.default_rng(0).uniform(-1, 1, 6)
    centres, twists = chain(q)
    h = 1e-6
    for j in range(6):
        e = np.eye(6)[j] * h
        num = (chain(q + e)[0] - chain(q - e)[0]) / (2 * h)
        pred = np.cross(twists[:, j, :3], centres) + twists[:, j, 3:]
        assert np.allclose(num, pred, rtol=ABSOLUTE_ONLY, atol=JACOBIAN_RTOL * np.abs(centres).max())


def test_sim_surface_twists_are_finite_differences_of_the_posed_surface():
    """handeye.robot.surface: each part's twist moves its posed points as a small change of each joint does."""
    pytest.importorskip("pinocchio")
    pytest.importorskip("trimesh")
    from handeye.robot.model import load_robot
    from handeye.robot.surface import RobotSurface

    robot = load_robot("ur5")
    surface = RobotSurface(robot, spacing_m=0.03)
    q = np.random.default_rng(1).uniform(-np.pi, np.pi, size=(2, robot.nq))
    posed = surface.posed(q)
    assert posed.joint_twists_base.shape == (2, len(surface.parts), robot.nq, 6)
    tw = posed.joint_twists_base[posed.frame, posed.part]  # (M, nq, 6)
    h = 1e-5
    for j in range(robot.nq):
        e = np.zeros(robot.nq)
        e[j] = h
        num = (surface.posed(q + e, twists=False).points_base - surface.posed(q - e, twists=False).points_base) / (
            2 * h
        )
        pred = np.cross(tw[:, j, :3], posed.points_base) + tw[:, j, 3:]
        # central differences: truncation ~ h^2 |p| (metres per radian), far below JACOBIAN_RTOL x |p|
        assert np.allclose(num, pred, rtol=ABSOLUTE_ONLY, atol=JACOBIAN_RTOL * np.abs(posed.points_base).max()), j
    # the base rotation turns every part about the same fixed axis: one twist for all
    moving = posed.part > 0
    assert np.allclose(tw[moving, 0], tw[moving, 0][0], rtol=ABSOLUTE_ONLY, atol=FLOAT)


def test_moved_surface_and_columns_are_first_order_of_the_chain():
    q = np.random.default_rng(2).uniform(-1, 1, 6)
    centres, twists = chain(q)
    delta = np.radians([0.0, 0.1, -0.2, 0.3, 0.1, 0.0])
    n = len(centres)
    moved, _ = moved_surface(centres, np.tile([0, 0, 1.0], (n, 1)), np.zeros(n, int), np.arange(n), twists[None], delta)
    # second order: |delta|^2 times the lever (< 1 m)
    assert np.allclose(moved, chain(q + delta)[0], atol=np.sum(delta) ** 2 + np.sum(delta**2))
    normals = np.tile([1.0, 0, 0], (n, 1))
    cols = offset_columns(normals, centres, twists)
    assert np.allclose(cols[:, 2], -(np.cross(twists[:, 2, :3], centres) + twists[:, 2, 3:])[:, 0])


def test_tangent_directions_turn_with_the_normals():
    """The curvature residual's principal direction turns with the link, as the normal does: a tangent left at
    the recorded joints drifts off the turned normal by the offsets' angle (the second tangent n x d no longer
    a unit vector)."""
    rng = np.random.default_rng(5)
    q = rng.uniform(-1, 1, 6)
    centres, twists = chain(q)
    delta = np.radians([0.2, -0.3, 0.15, -0.1, 0.25, -0.2])
    n = len(centres)
    normals = rng.normal(size=(n, 3))
    normals /= np.linalg.norm(normals, axis=1)[:, None]
    tangents = np.cross(normals, rng.normal(size=(n, 3)))
    tangents /= np.linalg.norm(tangents, axis=1)[:, None]
    _, turned_n = moved_surface(centres, normals, np.zeros(n, int), np.arange(n), twists[None], delta)
    turned_d = turned_directions(tangents, twists, delta)
    omega = np.einsum("njk,j->nk", twists[:, :, :3], delta)
    exact = np.einsum("nij,nj->ni", np.array([so3_exp(w) for w in omega]), tangents)
    angle = np.linalg.norm(omega, axis=1)
    # first order: off the exact rotation and off orthogonality by the angle squared at most
    assert np.all(np.linalg.norm(turned_d - exact, axis=1) <= angle**2)
    assert np.all(np.abs(np.einsum("ij,ij->i", turned_n, turned_d)) <= angle**2)
    # left unturned, the tangent is off the turned normal by the angle itself
    assert np.max(np.abs(np.einsum("ij,ij->i", turned_n, tangents))) > np.max(angle**2)
    assert turned_directions(tangents, twists, np.zeros(6)) is tangents


def test_joint_status_finds_the_absorbed_and_the_unseen():
    _, twists = chain(np.zeros(6))
    tw = np.stack([chain(q)[1] for q in np.random.default_rng(4).uniform(-1, 1, (5, 6))])
    frames, parts = np.repeat(np.arange(5), 6), np.tile(np.arange(1, 7), 5)
    status = joint_status(tw, frames, parts)
    assert status[0] == "absorbed" and status[1:] == ["estimated"] * 5
    with_base = joint_status(tw, np.r_[frames, 0], np.r_[parts, 0])  # the static base fitted too
    assert with_base[0] == "estimated"
    assert joint_status(tw, frames, np.full(30, 1))[1:] == ["not seen"] * 5  # the first link alone


def test_offsets_are_estimated_within_their_sigma_and_the_pose_is_the_kinematic_one(scene):
    depth, surface, T_phys, T_kin, delta = scene
    res = register_robot(depth, K, surface, options=MarkerlessOptions(depth_sigma_m_at_1m=SIGMA_1M))
    assert res.ok, res.refused
    assert within_sigma(res, T_kin, depth, RADII)
    joints = res.joint_offsets["joints"]
    assert res.joint_offsets["model"] == "estimated" and "note" in res.joint_offsets
    assert joints[0]["status"] == "absorbed" and joints[0]["estimate_deg"] == 0.0
    for j in range(1, 5):  # joints 2-5: recovered within their predicted sigma
        row = joints[j]
        assert row["status"] == "estimated" and row["determined"], row
        assert abs(row["estimate_deg"] - np.degrees(delta[j])) <= SIGMA_BOUND * row["sigma_deg"], row
    # joint 6 turns its sphere about the sphere's centre: the data say nothing, the prior stays
    assert joints[5]["status"] == "estimated" and not joints[5]["determined"]
    assert joints[5]["ratio"] > 0.9 and abs(joints[5]["estimate_deg"]) < 0.1 * joints[5]["prior_sigma_deg"]


def test_offsets_taken_as_exact_give_the_old_answer(scene):
    depth, surface, _, _, _ = scene
    opts = MarkerlessOptions(depth_sigma_m_at_1m=SIGMA_1M, joint_offsets_model="fixed")
    fixed = register_robot(depth, K, surface, options=opts)
    plain = RobotSurfaceFrames(surface.points_base, surface.normals_base, surface.frame, surface.part)
    old = register_robot(depth, K, plain, options=MarkerlessOptions(depth_sigma_m_at_1m=SIGMA_1M))
    assert fixed.ok and old.ok
    np.testing.assert_array_equal(fixed.T_base_cam, old.T_base_cam)
    assert fixed.sigma == old.sigma
    assert fixed.joint_offsets["model"] == "fixed" and old.joint_offsets["model"] == "fixed"


def test_bad_joint_offset_options_and_twists_raise(scene):
    with pytest.raises(HandEyeInputError, match="joint_offsets_model"):
        MarkerlessOptions(joint_offsets_model="free")
    with pytest.raises(HandEyeInputError, match="prior sigmas"):
        MarkerlessOptions(joint_offset_prior_deg=(0.2, 0.0))
    MarkerlessOptions(joint_offsets_model="fixed", joint_offset_prior_deg=0.0)  # not used: no error
    depth, surface, *_ = scene
    with pytest.raises(HandEyeInputError, match="joint_offset_prior_deg"):
        register_robot(depth, K, surface, options=MarkerlessOptions(joint_offset_prior_deg=(0.1, 0.2)))
    with pytest.raises(ShapeError, match="joint_twists_base"):
        RobotSurfaceFrames(
            surface.points_base,
            surface.normals_base,
            surface.frame,
            surface.part,
            joint_twists_base=np.zeros((1, 6, 6, 6)),
        )


def test_the_command_reads_the_joint_offset_options_and_the_table_shows_them(scene):
    from argparse import Namespace

    from handeye.commands.markerless import _joint_offset_options
    from handeye.markerless import _joint_offsets_cell

    assert _joint_offset_options(Namespace(joint_offsets="fixed", joint_offset_sigma=None)) == {
        "joint_offsets_model": "fixed"
    }
    assert _joint_offset_options(Namespace(joint_offsets="estimate", joint_offset_sigma=0.1)) == {
        "joint_offsets_model": "estimate",
        "joint_offset_prior_deg": 0.1,
    }
    assert _joint_offset_options(Namespace(joint_offsets="estimate", joint_offset_sigma=None)) == {
        "joint_offsets_model": "estimate",
        "joint_offset_prior_deg": JOINT_OFFSET_PRIORS_DEG["default"],
    }
    assert joint_offset_prior_deg("ur5e") == JOINT_OFFSET_PRIORS_DEG["ur"]
    assert joint_offset_prior_deg({"urdf": "x"}) == JOINT_OFFSET_PRIORS_DEG["default"]
    for bad in (0.0, -0.1, float("inf")):
        for model in ("estimate", "fixed"):  # refused also where it would not be used: a typo is not ignored
            with pytest.raises(HandEyeInputError, match="joint-offset-sigma"):
                _joint_offset_options(Namespace(joint_offsets=model, joint_offset_sigma=bad))
    assert _joint_offsets_cell({"model": "fixed"}) == "-"
    rows = [
        {"joint": 1, "status": "absorbed"},
        {"joint": 2, "status": "estimated", "estimate_deg": -0.31, "sigma_deg": 0.02, "determined": True},
        {"joint": 3, "status": "not seen"},
    ]
    assert _joint_offsets_cell({"model": "estimated", "joints": rows}) == "J1 abs J2 -0.310±0.020* J3 -"


def test_with_static_parts_fitted_a_round_base_leaves_the_base_rotation_absorbed(scene):
    """The static base sphere sits on joint 1's axis: fitting it cannot tell joint 1's offset from the camera's
    rotation, so it is held and the answer is the kinematic one, with the other joints still recovered."""
    depth, surface, _, T_kin, delta = scene
    opts = MarkerlessOptions(depth_sigma_m_at_1m=SIGMA_1M, static_parts=True)
    res = register_robot(depth, K, surface, options=opts)
    assert res.ok, res.refused
    assert res.diagnostics["fitted_parts"] == "all"
    joints = res.joint_offsets["joints"]
    assert joints[0]["status"] == "absorbed"
    assert within_sigma(res, T_kin, depth, RADII)
    for j in range(1, 5):
        assert abs(joints[j]["estimate_deg"] - np.degrees(delta[j])) <= SIGMA_BOUND * joints[j]["sigma_deg"]


def test_the_result_is_the_best_starts_when_a_worse_start_runs_after_it(scene):
    """A start tried after the best one (no clear success stops the search) leaves its own depth, intrinsics and
    joint offsets in the problem; the result, the split check and the reported offsets are the best start's."""
    depth, surface, _, T_kin, _ = scene
    opts = MarkerlessOptions(depth_sigma_m_at_1m=SIGMA_1M)
    alone = register_robot(depth, K, surface, starts={"good": T_kin}, options=opts, centroid_start=False)
    assert alone.ok, alone.refused
    # the good start no longer a clear success (matched >= minimum + 0.15), so the far one runs after it
    opts = MarkerlessOptions(depth_sigma_m_at_1m=SIGMA_1M, min_matched_fraction=alone.matched_fraction - 0.1)
    far = T_kin.copy()
    far[:3, 3] += [0.0, 0.0, 3.0]
    both = register_robot(depth, K, surface, starts={"good": T_kin, "far": far}, options=opts, centroid_start=False)
    assert both.ok and both.start == "good" and "far" in both.diagnostics["starts"]
    assert np.allclose(both.T_base_cam, alone.T_base_cam)
    for a, b in zip(alone.joint_offsets["joints"], both.joint_offsets["joints"]):
        assert a["status"] == b["status"] and a.get("estimate_deg") == pytest.approx(b.get("estimate_deg"))
    assert both.intrinsics["cx"]["estimate"] == pytest.approx(alone.intrinsics["cx"]["estimate"])
    assert both.sigma == pytest.approx(alone.sigma)
