"""The dense-sim preset (1,000 poses over the hemisphere, 4 scenes) and presets' scenes field, old recipes kept."""

from __future__ import annotations

import json

import numpy as np
import pytest

from handeye.core.errors import HandEyeInputError
from sim.cameras import PRESETS, CameraPreset, get_preset, place_cameras

#: The ``recipe.preset`` of a ``small`` dataset's meta.json written before presets had scenes (verbatim).
OLD_SMALL_RECIPE = json.loads(
    '{"name": "small", "robot": "ur5", "region_azimuths_deg": [[0.0, 180.0], [180.0, 360.0]], "train_per_region": '
    '[2, 2], "test_per_region": [1, 1], "configurations": 6, "calibration_views": 10, "radius_m": [1.3, 1.7], '
    '"elevation_deg": [20.0, 50.0], "look_at_m": [0.0, 0.0, 0.3], "image_size": [128, 128], '
    '"calibration_image_size": [480, 480], "fov_deg": 60.0}'
)


def test_dense_sim_is_1000_poses_in_4_scenes_as_paper_sim_records_them():
    dense, paper = get_preset("dense-sim"), get_preset("paper-sim")
    assert dense.n_cameras == 1000 and dense.scenes == 4 and dense.robot == "ur5"
    assert len(dense.region_azimuths_deg) == 10 and dense.train_per_region == (80,) * 10
    assert dense.test_per_region == (20,) * 10
    recorded = ("configurations", "calibration_views", "image_size", "calibration_image_size", "fov_deg", "look_at_m")
    assert [getattr(dense, a) for a in recorded] == [getattr(paper, a) for a in recorded]
    # the regions tile the full turn
    edges = np.array(dense.region_azimuths_deg)
    assert edges[0, 0] == 0.0 and edges[-1, 1] == 360.0 and np.all(edges[1:, 0] == edges[:-1, 1])
    assert dense.elevation_deg == (10.0, 75.0) and dense.radius_m == (1.1, 1.8)


@pytest.mark.parametrize("seed", [0, 1])
def test_dense_sim_covers_the_hemisphere(seed):
    preset = get_preset("dense-sim")
    cams = place_cameras(preset, np.random.default_rng(seed))
    # every cell of 30 deg azimuth x 13 deg elevation holds cameras
    counts, _, _ = np.histogram2d(
        cams.azimuth_deg, cams.elevation_deg, bins=[np.linspace(0, 360, 13), np.linspace(10, 75, 6)]
    )
    assert counts.min() >= 3
    # every viewing direction of the band is within 12 deg of a camera (measured: at most 9.5 deg over 5 seeds;
    # 1,000 cameras on its 5 sr are about 4 deg apart)
    a, e = np.radians(cams.azimuth_deg), np.radians(cams.elevation_deg)
    d_cam = np.column_stack([np.cos(e) * np.cos(a), np.cos(e) * np.sin(a), np.sin(e)])
    ga, ge = np.meshgrid(np.radians(np.arange(0.0, 360.0, 2.0)), np.radians(np.arange(10.0, 75.1, 2.0)))
    d_grid = np.column_stack([(np.cos(ge) * np.cos(ga)).ravel(), (np.cos(ge) * np.sin(ga)).ravel(), np.sin(ge).ravel()])
    nearest_deg = np.degrees(np.arccos(np.clip(d_grid @ d_cam.T, -1.0, 1.0)).min(axis=1))
    assert nearest_deg.max() < 12.0
    # test poses in every region and over the elevation range
    test = cams.split == "test"
    assert set(cams.region[test]) == set(range(10))
    assert np.ptp(cams.elevation_deg[test]) > 50.0 and np.ptp(cams.radius_m) > 0.6


def test_scenes_must_be_a_positive_integer():
    base = dict(name="x", robot="ur5", region_azimuths_deg=((0.0, 90.0),), train_per_region=(1,))
    base.update(test_per_region=(0,), configurations=1)
    assert CameraPreset(**base).scenes == 1
    assert type(CameraPreset(**base, scenes=np.int64(3)).scenes) is int
    for bad in (0, -1, 1.5, True, "2"):
        with pytest.raises(HandEyeInputError, match="scenes"):
            CameraPreset(**base, scenes=bad)


@pytest.mark.parametrize("name", list(PRESETS))
def test_recipe_round_trip_and_one_scene_presets_keep_their_old_recipe(name):
    preset = get_preset(name)
    doc = json.loads(json.dumps(preset.to_dict()))
    assert CameraPreset.from_dict(doc) == preset
    assert ("scenes" in doc) == (preset.scenes > 1)


def test_an_old_recipe_reads_back_as_the_same_preset_and_is_written_again_unchanged():
    assert CameraPreset.from_dict(OLD_SMALL_RECIPE) == get_preset("small")
    assert json.loads(json.dumps(get_preset("small").to_dict())) == OLD_SMALL_RECIPE


def test_dataset_meta_of_an_old_preset_keeps_its_recipe():
    pytest.importorskip("pinocchio")
    from sim.generate import NoiseModel, dataset_meta

    meta = dataset_meta(get_preset("small"), 0, NoiseModel(), ("calibration", "data"))
    assert meta["recipe"]["preset"] == OLD_SMALL_RECIPE
