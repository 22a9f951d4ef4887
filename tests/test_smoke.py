"""Smoke runs (``HANDEYE_SMOKE_TEST=1``, :mod:`handeye.core.smoke`): every preset cut, the rest unchanged, and
every run saying so."""

from __future__ import annotations

import argparse

import pytest

from handeye.core.smoke import ENV, NOTICE, smoke_test


@pytest.mark.parametrize("value,on", [("1", True), ("yes", True), ("0", False), ("", False), (" ", False)])
def test_the_variable_turns_smoke_runs_on(monkeypatch, value, on):
    monkeypatch.setenv(ENV, value)
    assert smoke_test() is on


def test_unset_is_off(monkeypatch):
    monkeypatch.delenv(ENV, raising=False)
    assert not smoke_test()


def test_camera_presets_are_cut_and_keep_their_geometry(monkeypatch):
    from sim.cameras import PRESETS, get_preset

    monkeypatch.delenv(ENV, raising=False)
    assert get_preset("paper-sim") is PRESETS["paper-sim"]
    monkeypatch.setenv(ENV, "1")
    for name, full in PRESETS.items():
        cut = get_preset(name)
        assert cut.train_per_region == tuple(min(n, 2) for n in full.train_per_region), name
        assert cut.test_per_region == tuple(min(n, 1) for n in full.test_per_region), name
        assert cut.configurations == min(full.configurations, 6) and cut.calibration_views == min(
            full.calibration_views, 6
        )
        # what the commands and the recipe name stay the preset's
        for field in ("name", "robot", "region_azimuths_deg", "radius_m", "elevation_deg", "image_size", "scenes"):
            assert getattr(cut, field) == getattr(full, field), (name, field)
    # paper-sim keeps a camera 17 (the simulation guide shows it) and its six regions
    assert get_preset("paper-sim").n_cameras == 18


def test_learned_presets_are_cut_and_keep_their_protocol(monkeypatch):
    from learned.presets import PRESETS, get_preset

    monkeypatch.setenv(ENV, "1")
    for name, full in PRESETS.items():
        cut = get_preset(name)
        assert cut.image_size == (32, 32) and cut.repeats == 1 and cut.first_epochs <= 2, name
        assert (cut.name, cut.protocol, cut.metric, cut.threshold_mm, cut.c1) == (
            full.name,
            full.protocol,
            full.metric,
            full.threshold_mm,
            full.c1,
        )
        assert (cut.keypoint_epochs is None) == (full.keypoint_epochs is None), name
        cut.model_config("keypoints", n_keypoints=5)  # a keypoint model the cut frames can feed


def test_the_command_line_says_it_is_a_smoke_run(monkeypatch, capsys, tmp_path):
    from handeye.cli import main

    monkeypatch.setenv(ENV, "1")
    assert main(["board", "--squares", "5x4", "-o", str(tmp_path / "b.png")]) == 0
    assert NOTICE in capsys.readouterr().err
    monkeypatch.setenv(ENV, "0")
    assert main(["board", "--squares", "5x4", "-o", str(tmp_path / "b.png")]) == 0
    assert NOTICE not in capsys.readouterr().err


def test_a_benchmark_cuts_its_sizes_and_says_so(monkeypatch, capsys):
    from benchmarks._report import Report

    args = argparse.Namespace(placements=4, frames=None, seed=3)
    monkeypatch.delenv(ENV, raising=False)
    Report.cut(args, placements=1, frames=10)
    assert (args.placements, args.frames) == (4, None)
    monkeypatch.setenv(ENV, "1")
    Report.cut(args, placements=1, frames=10)
    assert (args.placements, args.frames, args.seed) == (1, 10, 3)
    rep = Report("t", "benchmarks/x.py", [], "numpy")
    assert any(NOTICE in line for line in rep.lines)


def test_the_sensor_benchmark_keeps_one_profile_per_principle(monkeypatch):
    """markerless_sensors' smoke run: every principle and fixed pattern on the first dataset (every branch of
    sim.sensors.apply_sensor), one profile on the others; outside a smoke run every profile asked for."""
    from benchmarks.markerless_sensors import smoke_profiles
    from handeye.robot.depth_sensors import PROFILES

    names = list(PROFILES)
    monkeypatch.delenv(ENV, raising=False)
    assert smoke_profiles(names, first=True) == smoke_profiles(names, first=False) == names
    monkeypatch.setenv(ENV, "1")
    kept = smoke_profiles(names, first=True)
    kinds = lambda ns: {(PROFILES[n].principle, PROFILES[n].fixed_pattern_sigma_m_at_1m > 0) for n in ns}  # noqa: E731
    assert kinds(kept) == kinds(names) and len(kept) == len(kinds(names)) < len(names)
    assert smoke_profiles(names, first=False) == kept[:1]


def test_the_sensor_benchmark_renders_every_band_for_its_first_preset(monkeypatch):
    """markerless_sensors' smoke run: every band asked for on the first preset (each branch of render_band), the
    first band on the others; outside a smoke run every band for every preset."""
    from benchmarks.markerless_sensors import smoke_bands

    names = ["native", "0.7", "1.8"]
    monkeypatch.delenv(ENV, raising=False)
    assert smoke_bands(names, first=True) == smoke_bands(names, first=False) == names
    monkeypatch.setenv(ENV, "1")
    assert smoke_bands(names, first=True) == names and smoke_bands(names, first=False) == ["native"]


def test_the_bag_benchmark_keeps_a_band_with_a_board_and_one_without(monkeypatch):
    """imported_bag's smoke run: the first band without a board and the first with one (each branch of run_band),
    in the order asked; outside a smoke run every band."""
    from benchmarks.imported_bag import BANDS, WITH_BOARD, smoke_bands

    names = list(BANDS)
    monkeypatch.delenv(ENV, raising=False)
    assert smoke_bands(names) == names
    monkeypatch.setenv(ENV, "1")
    kept = smoke_bands(names)
    assert {WITH_BOARD[b] for b in kept} == {True, False} and len(kept) == 2 < len(names)
    assert kept == [b for b in names if b in kept]
    assert smoke_bands(names[::-1]) == [names[-1], names[0]]  # 1.8 m (a board), then 0.7 m (none)


def test_the_ablation_sweeps_two_settings_in_a_smoke_run(monkeypatch, tmp_path):
    """handeye learned ablation's smoke run: the grid's first and last settings; all of them otherwise."""
    import learned.ablation as ablation

    swept = []
    monkeypatch.setattr(
        ablation, "_sweep", lambda frames, preset, settings, out, strategies, **run: swept.append(settings)
    )
    monkeypatch.delenv(ENV, raising=False)
    ablation.run_ablation(None, None, tmp_path)
    monkeypatch.setenv(ENV, "1")
    ablation.run_ablation(None, None, tmp_path)
    full, cut = ([s[2] for s in settings] for settings in swept)
    assert len(full) == len(ablation.DEFAULT_GRID) > 2 and cut == [full[0], full[-1]]
