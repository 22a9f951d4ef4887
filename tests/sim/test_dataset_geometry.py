"""A recorded dataset agrees with geometry: the flange origin appears where the recorded camera model puts it.

Everything comes from the files, as a user (or the learned module) reads them: intrinsics from meta.json,
the truth T_base_cam from cameras.csv, T_base_ee from frames.csv, depth from the 16-bit PNG and its scale.
"""

from __future__ import annotations

import numpy as np
import pytest

from handeye.core.dataset import Dataset
from handeye.core.se3 import invert_transform
from tests.conftest import MARKER_RADIUS_M
from tests.sim._geometry import assert_sphere_rendered
from tests.tolerances import DEPTH_M, DEPTH_QUANTUM_M


def _frames(root):
    ds = Dataset.open(root)
    for c in range(len(ds)):
        t = ds.select(c, "data")
        for k in range(len(t["frame"])):
            yield ds, c, t, k


def test_marker_dataset_has_every_frame(marker_dataset):
    assert len(list(_frames(marker_dataset))) == 3 * 4


@pytest.mark.parametrize("index", range(12))
def test_flange_origin_where_the_recorded_camera_model_puts_it(marker_dataset, index):
    ds, c, t, k = list(_frames(marker_dataset))[index]
    K = np.array(ds.meta["intrinsics"]["K"])
    W, H = ds.meta["intrinsics"]["width"], ds.meta["intrinsics"]["height"]
    T_base_ee = ds.poses(t, "T_base_ee")[k]
    p_cam = (invert_transform(ds.truth()[c]) @ T_base_ee[:, 3])[:3]
    rgb = ds.rgb(c, t["rgb"][k]).astype(int)
    depth = ds.depth_m(c, t["depth"][k])
    # the marker is magenta: red and blue high, green a small fraction of them (nothing else in the lab is)
    magenta = (rgb[..., 0] > 80) & (rgb[..., 2] > 80) & (rgb[..., 1] < 0.25 * np.minimum(rgb[..., 0], rgb[..., 2]))
    u, v = assert_sphere_rendered(
        magenta, depth, p_cam, MARKER_RADIUS_M, K, min_pixels=20, min_core=5, depth_atol_m=DEPTH_M + DEPTH_QUANTUM_M
    )
    assert 5 < u < W - 5 and 5 < v < H - 5  # the generator keeps the tool in the image
