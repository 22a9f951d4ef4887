"""``handeye sim generate --sensor``: the depth a real camera reports, its unit's errors recorded as truth."""

from __future__ import annotations

import json

import numpy as np
import pytest

pytest.importorskip("pyrender")

from handeye.cli import main  # noqa: E402
from handeye.core.dataset import SENSOR_COLUMNS, Dataset  # noqa: E402
from handeye.core.engine_protocol import EngineOptions  # noqa: E402
from handeye.core.errors import HandEyeInputError  # noqa: E402
from handeye.robot.depth_sensors import PROFILES  # noqa: E402
from sim.cameras import CameraPreset  # noqa: E402
from sim.generate import DEFAULT_NOISE, NoiseModel, Recipe, generate  # noqa: E402
from sim.sensors import draw_systematic  # noqa: E402
from tests.tolerances import FLOAT, MM

#: One rendering process, no progress bar.
SERIAL = EngineOptions(workers=1, progress=False)
#: Two camera poses of two data frames at 64x64.
PRESET = CameraPreset("sensor", "ur5", ((0.0, 360.0),), (2,), (0,), 2, image_size=(64, 64))


@pytest.fixture(scope="module")
def pair(tmp_path_factory):
    """The same placements rendered without depth noise and as a D435 reports them."""
    root = tmp_path_factory.mktemp("sensor")
    clean = NoiseModel(pixel_sigma=2.0)
    generate(root / "clean", Recipe(PRESET, seed=3, noise=clean, recordings=("data",)), options=SERIAL)
    generate(root / "d435", Recipe(PRESET, 3, clean, ("data",), sensor="d435"), options=SERIAL)
    return Dataset.open(root / "clean"), Dataset.open(root / "d435")


def test_the_units_errors_are_recorded_as_truth(pair):
    _, ds = pair
    assert ds.meta["recipe"]["sensor"]["name"] == "d435"
    table = ds.cameras()
    for c in range(len(ds)):
        truth = draw_systematic(PROFILES["d435"], 3, c)
        assert table["depth_scale_true"][c] == pytest.approx(truth.scale, abs=FLOAT)
        assert table["depth_offset_mm_true"][c] == pytest.approx(truth.offset_m * 1e3, abs=FLOAT / MM)
        assert table["depth_extrinsic_mm_true.z"][c] == pytest.approx(truth.t_colour_depth_m[2] * 1e3, abs=FLOAT / MM)


def test_the_depth_is_the_sensors(pair):
    """Where both have depth, the sensor's differs from the clean one by its scale and offset plus noise; some
    pixels are lost."""
    clean, d435 = pair
    for c in range(len(clean)):
        a = clean.depth_m(c, clean.select(c, "data")["depth"][0])
        b = d435.depth_m(c, d435.select(c, "data")["depth"][0])
        both = (a > 0) & (b > 0)
        scale = d435.cameras()["depth_scale_true"][c]
        assert (b[a > 0] == 0).any()  # holes
        resid = b[both] - scale * a[both]
        # the median removes the flying pixels; the offset and the extrinsic's z move every pixel alike
        expected = (
            d435.cameras()["depth_offset_mm_true"][c] / 1e3 + d435.cameras()["depth_extrinsic_mm_true.z"][c] / 1e3
        )
        noise = PROFILES["d435"].sigma_m(np.median(a[both]))
        assert abs(np.median(resid) - expected) < 3 * noise


def test_rewriting_the_camera_table_keeps_the_sensor_columns(pair):
    """Labelling and markerless labels rewrite cameras.csv with camera_table_columns: the truth stays."""
    _, ds = pair
    from handeye.core.dataset import camera_table_columns

    assert set(SENSOR_COLUMNS) <= set(camera_table_columns(ds.cameras()))


def test_a_misregistered_units_registration_is_recorded_as_truth(tmp_path):
    """d435-real-cell draws a registration shift and roll per placement: cameras.csv records them (they were
    drawn into the table and then left out of the file by camera_table_columns)."""
    from handeye.core.dataset import REGISTRATION_COLUMNS, read_table

    recipe = Recipe(PRESET, 3, NoiseModel(), ("data",), sensor="d435-real-cell")
    generate(tmp_path / "cell", recipe, cameras=[], options=SERIAL)  # the camera table, no shard rendered
    table = read_table(tmp_path / "cell" / "cameras.csv", list(REGISTRATION_COLUMNS))
    for c in range(PRESET.n_cameras):
        truth = draw_systematic(PROFILES["d435-real-cell"], 3, c)
        assert abs(truth.registration_roll_deg) > 0
        assert table["depth_registration_px_true.u"][c] == pytest.approx(truth.registration_px[0], abs=FLOAT)
        assert table["depth_registration_px_true.v"][c] == pytest.approx(truth.registration_px[1], abs=FLOAT)
        assert table["depth_registration_roll_deg_true"][c] == pytest.approx(truth.registration_roll_deg, abs=FLOAT)


def test_depth_noise_given_twice_is_refused(tmp_path):
    with pytest.raises(HandEyeInputError, match="given twice"):
        generate(tmp_path / "x", Recipe(PRESET, noise=DEFAULT_NOISE, sensor="d435"), options=SERIAL)


def test_cli_sensor_by_name_or_file_and_its_errors(tmp_path, capsys):
    from handeye.commands.sim import parse_sensor

    params = dict(PROFILES["zivid"].to_dict(), name="my zivid")
    path = tmp_path / "mine.json"
    path.write_text(json.dumps(params))
    assert parse_sensor(str(path)).name == "my zivid"
    assert parse_sensor("d455") is PROFILES["d455"]
    for bad, message in (("kinect", "use one of"), (str(tmp_path / "none.json"), "no such")):
        assert main(["sim", "generate", "--out", str(tmp_path / "d"), "--sensor", bad, "--quiet"]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and message in err
