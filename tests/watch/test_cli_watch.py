"""``handeye watch``: rollback, the stream's times, and (slow) a simulated stream replayed end to end."""

from __future__ import annotations

import json

import numpy as np
import pytest

from handeye.cli import main
from handeye.core.errors import HandEyeInputError
from handeye.core.se3 import make_transform, so3_exp
from handeye.watch import History
from handeye.watch.source import stream_rate, stream_times
from tests.tolerances import SIGMA_BOUND


def test_rollback_appends_a_version_from_the_command_line(tmp_path, capsys):
    h = History(tmp_path / "h.jsonl")
    for n in range(1, 4):
        h.append(make_transform(so3_exp([0.0, 0.0, 0.1 * n]), [n, 0, 0]), "test")
    assert (
        main(["watch", "rollback", "--history", str(tmp_path / "h.jsonl"), "--current", str(tmp_path / "c.json"), "2"])
        == 0
    )
    assert "version 4: rollback to version 2 (replaces 3)" in capsys.readouterr().out
    np.testing.assert_array_equal(History(tmp_path / "h.jsonl").latest().T_base_cam, h.get(2).T_base_cam)
    assert json.loads((tmp_path / "c.json").read_text())["version"] == 4


def test_rollback_without_its_arguments_is_refused_with_the_reason(tmp_path, capsys):
    assert main(["watch", "rollback", "2"]) == 2
    assert "--history PATH VERSION" in capsys.readouterr().err
    assert main(["watch", "rollback", "--history", str(tmp_path / "none.jsonl"), "2"]) == 2
    assert "no such history" in capsys.readouterr().err


def test_current_without_history_is_refused_not_ignored(tmp_path, capsys):
    """--current alone would never be written (it is published from the history): refused with the reason."""
    current = tmp_path / "c.json"
    assert main(["watch", str(tmp_path / "none"), "--truth-start", "--current", str(current)]) == 2
    assert "give --history too" in capsys.readouterr().err
    assert not current.exists()


def test_stream_times_from_stream_json_else_the_rate(tmp_path):
    counts = {0: 3, 1: 2}
    np.testing.assert_allclose(np.concatenate(list(stream_times(tmp_path, counts, 10.0).values())), np.arange(5) / 10)
    with pytest.raises(HandEyeInputError, match="no frame rate"):
        stream_rate(tmp_path)
    doc = {"rate_hz": 2.0, "segments": [{"camera": 0, "start_s": 0.0}, {"camera": 1, "start_s": 7.0}]}
    (tmp_path / "stream.json").write_text(json.dumps(doc))
    times = stream_times(tmp_path, counts, None)
    np.testing.assert_allclose(times[0], [0.0, 0.5, 1.0])
    np.testing.assert_allclose(times[1], [7.0, 7.5])
    assert stream_rate(tmp_path, 5.0) == 5.0  # the command line's rate wins


@pytest.mark.slow
def test_a_simulated_stream_bump_is_detected_and_recalibrated_within_its_sigma(tmp_path, capsys):
    """The simulator's smoke stream (2 Hz, 96 x 96, d435): its 20 mm / 2 deg bump at 7 s is "moved" within 3
    frames (the first is screened as occluded: the shifted arm is in front of the model) and the committed
    version lies within SIGMA_BOUND of its sigma from the bumped segment's truth. The null is learnt from the
    first 3 s (6 frames, the fewest the watcher takes) and its bias over the next 6 frames, so the change test
    watches from 6 s on: with 5 s the bump fell in the blind frames of that second learning."""
    pytest.importorskip("pyrender")
    from handeye.core.dataset import Dataset
    from handeye.core.metrics import pose_error
    from sim.stream import generate_stream

    root = tmp_path / "stream"
    generate_stream(root, "smoke", seed=0, progress=False)
    history = tmp_path / "h.jsonl"
    args = ["watch", str(root), "--truth-start", "--history", str(history), "--null-seconds", "3"]
    assert main([*args, "--recal-frames", "6"]) == 0
    lines = capsys.readouterr().out.splitlines()
    moved = [ln for ln in lines if " moved (was " in ln]
    t_moved = float(moved[0].split("s ")[0][2:])
    assert 7.0 <= t_moved <= 7.0 + 3 / 2.0, lines
    bumped = History(history).versions()[1]
    assert bumped.reason.startswith("moved at t=")
    rot_deg, trans_mm = pose_error(bumped.T_base_cam, Dataset.open(root).truth()[1])
    s = bumped.extra["sigma_summary"]
    assert trans_mm <= SIGMA_BOUND * s["translation_mm"] and rot_deg <= SIGMA_BOUND * s["rotation_deg"]
