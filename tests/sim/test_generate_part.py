"""Rendering a part of a preset (``--cameras``): the rest is left to do, and a later run completes it."""

from __future__ import annotations

import pytest

pytest.importorskip("pyrender")

from handeye.cli import main  # noqa: E402
from handeye.core.engine_protocol import EngineOptions  # noqa: E402
from handeye.core.errors import HandEyeInputError  # noqa: E402
from sim.cameras import CameraPreset  # noqa: E402
from sim.generate import Recipe, generate  # noqa: E402

#: One rendering process, no progress bar.
SERIAL = EngineOptions(workers=1, progress=False)
#: Four camera poses of one data frame at 32x32: the shard protocol without the rendering time.
PRESET = CameraPreset("part", "ur5", ((0.0, 360.0),), (4,), (0,), 1, image_size=(32, 32))


def test_a_part_then_the_rest(tmp_path):
    root = tmp_path / "ds"
    part = generate(root, Recipe(PRESET, recordings=("data",)), [2, 0], options=SERIAL)
    assert part.rendered == [0, 2] and part.left == 2
    assert "2 camera poses still to render" in part.summary()
    rest = generate(root, Recipe(PRESET, recordings=("data",)), options=SERIAL)
    assert rest.skipped == [0, 2] and rest.rendered == [1, 3] and rest.left == 0


def test_cameras_outside_the_preset_are_refused(tmp_path):
    with pytest.raises(HandEyeInputError, match=r"0\.\.3"):
        generate(tmp_path / "ds", Recipe(PRESET), [1, 4], options=SERIAL)
    assert not (tmp_path / "ds").exists()


@pytest.mark.parametrize("text", ["3", "5:2", "a:b", "-1:3"])
def test_a_bad_cameras_option_is_one_line(tmp_path, capsys, text):
    assert main(["sim", "generate", "--out", str(tmp_path / "d"), f"--cameras={text}", "--quiet"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--cameras" in err
