"""The paper's protocol mode: each of its choices does what the paper's text says (learned.protocol)."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("torch")

from handeye.core.errors import HandEyeInputError  # noqa: E402
from learned.experiment import run_experiment, time_steps  # noqa: E402
from learned.presets import PRESETS, Preset, get_preset  # noqa: E402
from learned.protocol import DEPARTURES, PAPER_NAIVE_BATCH, PROTOCOLS  # noqa: E402
from learned.replay import ReplayBuffer, draw  # noqa: E402
from learned.strategies import make_strategy  # noqa: E402
from tests.learned._synthetic import (  # noqa: E402
    FRAMES_PER_CAMERA,
    TRAIN_PER_REGION,
    count_setting,
    make_frames,
)

PRESET, FIRST, LATER = count_setting()


def test_the_paper_preset_runs_the_papers_protocol_and_the_others_this_projects():
    paper = get_preset("paper")
    assert paper.protocol == "paper" and paper.metric == "rmse" and paper.sampling == "normal"
    assert paper.c2 == 14 and paper.selection_replay == "all" and paper.batch_every_step and paper.pose_steps
    assert paper.naive_batch_size == PAPER_NAIVE_BATCH
    assert (paper.label_method, paper.label_repeats) == ("tsai", 5)  # the paper's labels: Tsai, 5 repeats
    assert (PRESETS["cpu"].label_method, PRESETS["cpu"].label_repeats) == ("park", 0)
    for name in ("tiny", "demo", "cpu"):
        assert PRESETS[name].protocol == "handeye"
        assert PRESETS[name].with_protocol("handeye") == PRESETS[name]  # the defaults are this project's mode
    assert PRESETS["cpu"].with_protocol("paper").with_protocol("handeye") == PRESETS["cpu"]


def test_every_field_where_the_modes_differ_is_a_named_departure():
    differing = {k for k in PROTOCOLS["paper"] if PROTOCOLS["paper"][k] != PROTOCOLS["handeye"][k]}
    named = {"metric", "sampling", "c2", "selection_replay", "batch_every_step", "naive_batch_size", "pose_steps"}
    labels = {"label_method", "label_repeats"}  # one departure: the labels ('handeye label --method --repeats')
    assert differing == named | labels
    assert len(DEPARTURES) == len(named) + 1
    assert all(len(row) == 4 and all(row) for row in DEPARTURES)


def test_an_unknown_protocol_is_refused_with_the_known_ones():
    with pytest.raises(HandEyeInputError, match="paper, handeye"):
        PRESETS["cpu"].with_protocol("icra")
    with pytest.raises(HandEyeInputError, match="sampling"):
        Preset("x", sampling="gaussian")


def test_the_naive_strategy_trains_with_a_small_batch_in_the_papers_mode():
    preset = PRESETS["cpu"].with_protocol("paper")
    for strategy in ("batch", "reservoir", "selection"):
        assert preset.train_configs(strategy)[1].batch_size == preset.batch_size
    first, later = preset.train_configs("naive")
    assert first.batch_size == later.batch_size == PAPER_NAIVE_BATCH < preset.batch_size
    assert PRESETS["cpu"].train_configs("naive")[1].batch_size == preset.batch_size


def test_uniform_draws_are_the_generators_own_choice():
    """The project's mode draws exactly as before the paper's mode existed (same generator, same call)."""
    index = np.arange(100, 150)
    a, b = np.random.default_rng(5), np.random.default_rng(5)
    assert np.array_equal(draw(index, 7, a), b.choice(index, 7, replace=False))


def test_normal_draws_follow_the_stated_weights():
    """One entry of 50 drawn 20,000 times: each position's frequency within 5 binomial sigmas of its weight."""
    n, trials = 50, 20000
    rng = np.random.default_rng(0)
    picks = np.array([draw(np.arange(n), 1, rng, "normal")[0] for _ in range(trials)])
    z = (np.arange(n) - (n - 1) / 2) / (n / 4)
    p = np.exp(-0.5 * z**2)
    p /= p.sum()
    counts = np.bincount(picks, minlength=n)
    assert np.all(np.abs(counts - trials * p) <= 5 * np.sqrt(trials * p * (1 - p)) + 1)
    assert counts[n // 2] > 4 * counts[0]  # the middle is drawn far more often than the ends


def test_a_normal_buffer_keeps_c1_per_pose_and_remembers_how_it_draws(frames):
    buf = ReplayBuffer(4, sampling="normal")
    buf.update(frames, np.flatnonzero(frames.split == "train"), np.random.default_rng(0))
    assert all(len(v) == 4 for v in buf.values())
    again = ReplayBuffer(1)
    again.load_state_dict(buf.state_dict())
    assert again.sampling == "normal" and {c: list(v) for c, v in again.items()} == {c: list(v) for c, v in buf.items()}
    with pytest.raises(ValueError, match="sampling"):
        ReplayBuffer(4, sampling="gaussian")


def test_the_papers_baseline_is_retrained_from_scratch_on_all_seen_at_every_step(frames):
    strat = make_strategy("batch", PRESET.model_config("translation"), FIRST, LATER, np.random.default_rng(1),
                          every_step=True)  # fmt: skip
    steps = time_steps(frames)
    for k, cams in enumerate(steps):
        strat.step(k, cams, frames, last=k == len(steps) - 1)
    seen = [sum((steps[j] for j in range(k + 1)), []) for k in range(len(steps))]
    assert [sorted(t) for t in strat.trained_on] == [sorted(s) for s in seen]
    per_pose = FIRST.epochs * FRAMES_PER_CAMERA
    assert strat.processed == per_pose * TRAIN_PER_REGION * (1 + 2 + 3)


@pytest.fixture(scope="module")
def paper_run():
    frames = make_frames(
        np.random.default_rng(0),
        regions=((0, 70), (180, 250)),
        train_per_region=4,
        test_per_region=1,
        frames_per_camera=10,
        size=PRESETS["tiny"].image_size,
    )
    preset = PRESETS["tiny"].with_protocol("paper")
    return run_experiment(frames, preset, progress=False, threads=2)


def test_selection_has_a_row_after_every_pose_of_the_later_steps(paper_run):
    steps = paper_run["steps"]
    for net in ("translation", "orientation"):
        run = next(r for r in paper_run["runs"] if r["strategy"] == "selection" and r["network"] == net)
        rows = run["pose_matrix"]
        assert [p["camera"] for p in rows] == [c for s in steps[1:] for c in s]
        assert sorted(p["camera"] for p in rows if not p["novel"]) == sorted(run["skipped"])
        assert all(len(p["rmse_matrix"]) == len(paper_run["regions"]) for p in rows)
        assert all(np.isfinite(p["rmse_matrix"]).all() for p in rows)
        # the last pose's row is the step matrix's last row: the same network, evaluated once more
        assert np.allclose(rows[-1]["rmse_matrix"], run["rmse_matrix"][-1])


def test_the_papers_baseline_has_an_error_after_every_step(paper_run):
    for r in paper_run["runs"]:
        if r["strategy"] == "batch":
            assert np.isfinite(np.array(r["rmse_matrix"])).all() and len(r["rmse_matrix"]) == len(paper_run["steps"])
        else:
            assert r["pose_matrix"] == [] or r["strategy"] == "selection"
    assert paper_run["preset"]["protocol"] == "paper"


def test_the_documentation_prints_the_departures_as_the_code_names_them():
    from pathlib import Path

    from handeye.core.tables import markdown_table

    page = (Path(__file__).parents[2] / "docs" / "reproduce-paper.md").read_text()
    table = "\n".join(markdown_table(["choice", "the paper", "this project (--protocol handeye)", "why"], DEPARTURES))
    assert table in page
