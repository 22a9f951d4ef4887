"""benchmarks/running_cell.py's scoring on a planted replay: delays, committed errors, shares, the Poisson bound."""

from __future__ import annotations

import argparse

import numpy as np
import pytest

from benchmarks.running_cell import (
    Replay,
    called,
    false_alarm_line,
    image_size,
    is_alarm,
    learnt_at,
    poisson_lower,
    poisson_upper,
    score_bumps,
    score_commits,
)
from handeye.core.se3 import make_transform, so3_exp
from handeye.watch.events import Event
from tests.tolerances import EXACT

RATE = 2.0
#: Garwood's table gives the Poisson bound to three decimals.
TABLE_DIGITS = 1e-3


def _doc():
    events = [
        {"type": "bump", "t_s": 3.0, "frame": 6, "segment": 1, "translation_mm": 2.0, "rotation_deg": 0.2},
        {"type": "dropout", "t_s": 6.0, "frame": 12, "end_frame": 14, "end_t_s": 7.0},
        {"type": "bump", "t_s": 8.0, "frame": 16, "segment": 2, "translation_mm": 5.0, "rotation_deg": 0.5},
    ]
    occlusions = [{"occlusion": 0, "shape": "box", "first_frame": 2, "end_frame": 6, "mid_frame": 3}]
    return {"rate_hz": RATE, "duration_s": 10.0, "events": events, "occlusions": occlusions}


def _truth():
    return np.stack([make_transform(np.eye(3), [1.0, 0.0, 1.0 + k * 0.01]) for k in range(3)])


class _Result:
    ok = True

    def __init__(self, T):
        self.T_base_cam = T
        self.sigma = {"translation_mm": 0.5, "rotation_deg": 0.1}


def _replay(truth):
    committed = truth[1] @ make_transform(so3_exp([0.0, 0.0, np.radians(0.05)]), [0.001, 0.0, 0.0])
    run = Replay()
    run.events = [
        (Event(1.0, "ok", "learning"), truth[0], 0),
        (Event(4.5, "moved", "ok", stale_since=4.5), truth[0], 1),
        (Event(6.0, "recalibrated", "moved"), committed, 1),
        (Event(9.0, "moved", "ok", stale_since=9.0), committed, 2),  # the second bump's alarm, never recalibrated
    ]
    run.recal = [(1.0, _Result(committed))]
    run.states = ["learning", "learning", "occluded", "ok", "occluded", "occluded"] + ["ok"] * 6
    run.states += ["dropout", "ok"] + ["ok"] * 6
    return run


def test_bumps_are_scored_by_their_first_alarm_and_the_commit_after_it():
    truth = _truth()
    rows = score_bumps(_replay(truth), _doc(), truth)
    first, second = rows
    assert first["delay_s"] == pytest.approx(1.5) and not first["learning"]
    trans_mm, rot_deg = first["error"]
    assert trans_mm == pytest.approx(1.0, abs=EXACT)  # the planted 1 mm along x, the rotation about the centre
    assert rot_deg == pytest.approx(0.05, abs=EXACT)
    assert first["ratio"] == pytest.approx((2.0, 0.5))
    assert second["delay_s"] == pytest.approx(1.0) and second["error"] is None
    assert learnt_at(_replay(truth)) == 1.0


def test_a_return_to_moved_while_collecting_is_not_another_alarm():
    """After a refusal (or a dropout) the watcher says 'moved' again, stale since the first alarm: one alarm, as
    the false-alarm count and the bumps' extra alarms take it (both counted these returns before)."""
    truth = _truth()
    run = _replay(truth)
    run.events += [
        (Event(9.5, "refused", "moved", stale_since=9.0), truth[2], 2),
        (Event(9.5, "moved", "refused", stale_since=9.0), truth[2], 2),
    ]
    assert [is_alarm(ev) for ev, _, _ in run.events] == [False, True, False, True, False, False]
    assert [row["extra_alarms"] for row in score_bumps(run, _doc(), truth)] == [0, 0]


def test_every_commit_is_scored_and_refusals_and_wrong_commits_are_counted_apart():
    """The planted commit is 2 of its sigmas off (right); a refusal, then a second commit 5 mm off at 0.5 mm
    sigma (10 sigmas: wrong), both after the second bump's alarm, where the per-bump table looks no further."""
    truth = _truth()
    run = _replay(truth)
    assert score_commits(run, truth) == {"commits": 1, "wrong": 0, "refused": 0}
    off = truth[2] @ make_transform(np.eye(3), [0.005, 0.0, 0.0])
    run.events += [(Event(9.5, "refused", "moved"), truth[1], 2), (Event(9.8, "recalibrated", "moved"), off, 2)]
    run.recal.append((1.0, _Result(off)))
    assert score_commits(run, truth) == {"commits": 2, "wrong": 1, "refused": 1}


def test_interval_shares_count_the_frames_called_so():
    run = _replay(_truth())
    ((occlusion, share),) = called(run, _doc(), "occlusion", "occluded")
    assert share == pytest.approx(3 / 4) and occlusion["t_s"] == 1.0
    ((_, share),) = called(run, _doc(), "dropout", "dropout")
    assert share == pytest.approx(1 / 2)


def test_poisson_upper_bound():
    assert poisson_upper(0) == pytest.approx(-np.log(0.05), rel=EXACT)  # 2.996
    assert poisson_upper(5) == pytest.approx(10.513, abs=TABLE_DIGITS)  # Garwood's table


def test_poisson_lower_bound():
    assert poisson_lower(0) == 0.0
    assert poisson_lower(1) == pytest.approx(-np.log(0.95), rel=EXACT)  # 0.0513
    assert poisson_lower(5) == pytest.approx(1.970, abs=TABLE_DIGITS)  # Garwood's table (one-sided 95 %)


def test_the_false_alarm_line_names_the_stated_rate_and_whether_the_count_exceeds_it():
    """The static stream's figure is printed beside the watcher's stated rate (it was printed alone, so 4.1 per
    hour read as the watcher's own figure); 13 alarms in 1628 s show a rate above 1 per hour, 2 in 1752 s do not;
    no watched time gives no rate (it divided by zero)."""
    many, few = false_alarm_line(13, 1628.0, 1.0), false_alarm_line(2, 1752.0, 1.0)
    assert "stated rate 1 per hour" in many and "stated rate 1 per hour" in few
    assert "28.7 per hour" in many and "the count shows a rate above it" in many
    assert "4.1 per hour" in few and "the count does not show a rate above it" in few
    assert "no false-alarm rate" in false_alarm_line(0, 0.0, 1.0)


def test_a_bump_while_stale_is_not_detected_by_a_return_to_moved():
    """An alarm at 7.5 s, before the second bump (8 s), its recalibration refused at 8.5 s: the 'moved' that
    follows is a return, not the bump's detection (it was scored as one, 0.5 s); the bump came stale."""
    truth = _truth()
    run = _replay(truth)
    run.events = run.events[:3] + [
        (Event(7.5, "moved", "ok", stale_since=7.5), truth[1], 1),
        (Event(8.5, "refused", "moved", stale_since=7.5), truth[1], 2),
        (Event(8.5, "moved", "refused", stale_since=7.5), truth[1], 2),
    ]
    first, second = score_bumps(run, _doc(), truth)
    assert second["delay_s"] is None and second["stale"] and second["error"] is None
    assert first["delay_s"] == pytest.approx(1.5) and not first["stale"]


@pytest.mark.parametrize("text", ["96", "96x96x3", "9_6x96", "\uff19\uff16x96", "8x96", "ninety-sixx96"])
def test_image_size_is_two_integers_in_the_number_grammar(text):
    """As ``handeye sim stream --size``: int() took '9_6' and full-width digits as 96."""
    with pytest.raises(argparse.ArgumentTypeError):
        image_size(text)
    assert image_size("256X128") == (256, 128)
