"""The c1/c2/c3 ablation and the threshold pairs: one run per setting, resumable, reported in the paper's layout."""

from __future__ import annotations

import json

import numpy as np
import pytest

pytest.importorskip("torch")

from handeye.core.errors import HandEyeInputError  # noqa: E402
from learned.ablation import (  # noqa: E402
    ablation_report,
    parse_grid,
    parse_thresholds,
    run_ablation,
    run_thresholds,
    threshold_report,
)
from learned.presets import PRESETS  # noqa: E402
from tests.learned._synthetic import make_frames  # noqa: E402


@pytest.fixture(scope="module")
def frames():
    return make_frames(
        np.random.default_rng(0),
        regions=((0, 70), (180, 250)),
        train_per_region=3,
        test_per_region=1,
        frames_per_camera=8,
        size=PRESETS["tiny"].image_size,
    )


def test_settings_are_parsed_and_bad_ones_named():
    assert parse_grid("4,14,1.0 2,all,0.5") == [(4, 14, 1.0), (2, None, 0.5)]
    assert parse_thresholds("3,4 6,8") == [(3.0, 4.0), (6.0, 8.0)]
    for bad in ("4,14", "4,x,1", "0,14,1", "4,14,1.5", ""):
        with pytest.raises(HandEyeInputError):
            parse_grid(bad)
    for bad in ("3", "3,0", "a,b", ""):
        with pytest.raises(HandEyeInputError):
            parse_thresholds(bad)


def test_the_ablation_runs_each_setting_and_reports_its_average_error(frames, tmp_path):
    grid = [(4, None, 1.0), (2, 1, 0.5)]
    run_ablation(frames, PRESETS["tiny"], tmp_path, grid, progress=False, threads=2)
    text = ablation_report(tmp_path)
    for (c1, c2, c3), label in zip(grid, ("c1=4, c2=all, c3=100%", "c1=2, c2=1, c3=50%")):
        folder = tmp_path / f"c1_{c1}_c2_{'all' if c2 is None else c2}_c3_{c3:g}"
        res = json.loads((folder / "results.json").read_text())
        assert (res["preset"]["c1"], res["preset"]["c2"], res["preset"]["c3"]) == (c1, c2, c3)
        assert res["strategies"] == ["reservoir"]
        run = next(r for r in res["runs"] if r["network"] == "translation")
        last = float(np.nanmean(run["rmse_matrix"][-1]))
        assert f"| {label} |" in text and f"{last:.2f} |" in text
    assert (tmp_path / "ablation.png").stat().st_size > 0
    # finished settings are read back, not trained again
    before = {p: p.stat().st_mtime_ns for p in tmp_path.glob("*/results.json")}
    run_ablation(frames, PRESETS["tiny"], tmp_path, grid, progress=False, threads=2)
    assert {p: p.stat().st_mtime_ns for p in tmp_path.glob("*/results.json")} == before


def test_a_threshold_above_every_error_eliminates_every_pose_and_one_below_none(frames, tmp_path):
    run_thresholds(frames, PRESETS["tiny"], tmp_path, [(1e-6, 1e-6), (1e9, 1e9)], progress=False, threads=2)
    later = 3  # the second region's training poses
    for name, skipped in (("threshold_1e-06mm_1e-06deg", 0), ("threshold_1e+09mm_1e+09deg", later)):
        res = json.loads((tmp_path / name / "results.json").read_text())
        assert all(len(r["skipped"]) == skipped for r in res["runs"])
    text = threshold_report(tmp_path)
    assert text.count(f"| {later:.1f} | - |") == 2 and text.count("| 0.0 | - |") == 2  # per network
