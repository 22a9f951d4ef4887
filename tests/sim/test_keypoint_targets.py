"""Keypoint targets of the equivariant model land on the rendered robot.

The marker dataset renders a sphere centred on the flange origin (the ``flange`` keypoint). The
renderer is proved against the camera model by :func:`tests.sim._geometry.assert_sphere_rendered`
(mask to MAX_MASK_MISMATCH_PX, depth to the depth quantum); the flange keypoint's target, computed
from the truth, the kinematics of the recorded joints and the intrinsics in ``meta.json``, must then
be that sphere's projected centre (to float32 rounding) and its depth the centre's depth.
"""

from __future__ import annotations

import numpy as np
import pytest

from handeye.core.dataset import Dataset
from handeye.core.se3 import invert_transform
from tests.conftest import MARKER_RADIUS_M
from tests.sim._geometry import assert_sphere_rendered
from tests.tolerances import DEPTH_M, DEPTH_QUANTUM_M, FLOAT32_POSITION_MM, MM

pytest.importorskip("torch")

#: float32 normalised coordinates of a 320-pixel image: 2^-24 relative, well under 1e-4 px.
FLOAT32_PX = 1e-4


def test_flange_keypoint_target_is_the_rendered_marker_centre(marker_dataset):
    from handeye.learned_frames import load_keypoint_frames
    from learned.keypoints import keypoint_targets

    frames = load_keypoint_frames(marker_dataset, (64, 64), labels="truth", progress=False)
    ds = Dataset.open(marker_dataset)
    K = np.array(ds.meta["intrinsics"]["K"])
    W, H = ds.meta["intrinsics"]["width"], ds.meta["intrinsics"]["height"]
    flange = -2  # keypoints: the joints' origins, points along the long links, the flange, the reference point
    targets = keypoint_targets(
        frames.keypoints_base, frames.truth_t_base_cam_mm, frames.truth_q_base_cam_xyzw, frames.intrinsics_norm
    )
    i = 0
    for c in range(len(ds)):
        t = ds.select(c, "data")
        for k in range(len(t["frame"])):
            T_base_ee = ds.poses(t, "T_base_ee")[k]
            p_cam = (invert_transform(ds.truth()[c]) @ T_base_ee[:, 3])[:3]
            rgb = ds.rgb(c, t["rgb"][k]).astype(int)
            magenta = (
                (rgb[..., 0] > 80) & (rgb[..., 2] > 80) & (rgb[..., 1] < 0.25 * np.minimum(rgb[..., 0], rgb[..., 2]))
            )
            u, v = assert_sphere_rendered(
                magenta,
                ds.depth_m(c, t["depth"][k]),
                p_cam,
                MARKER_RADIUS_M,
                K,
                min_pixels=20,
                min_core=5,
                depth_atol_m=DEPTH_M + DEPTH_QUANTUM_M,
            )
            x_n, y_n, z = targets[i, flange]
            assert x_n * W - 0.5 == pytest.approx(u, abs=FLOAT32_PX * W)
            assert y_n * H - 0.5 == pytest.approx(v, abs=FLOAT32_PX * H)
            assert z == pytest.approx(p_cam[2], abs=FLOAT32_POSITION_MM * MM)
            np.testing.assert_allclose(
                frames.keypoints_base[i, flange], T_base_ee[:3, 3], atol=FLOAT32_POSITION_MM * MM
            )
            i += 1
    assert i == len(frames)
