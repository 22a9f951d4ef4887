"""The benchmark figures plot what their labels say: each line's points are the results file's cells of that
column (read here apart, by row and column name), on the axis its title and unit name. The figure test beside
it (tests/test_make_figures.py) checks that the figures are drawn and captioned, not what they show: a swapped
column (the rotation's bound on the translation's axis) passed it."""

from __future__ import annotations

import re
import sys

import numpy as np
import pytest

pytest.importorskip("matplotlib")

from tests.test_make_figures import rf  # noqa: E402

RESULTS = rf.common.RESULTS


def _cells(path, row_start: str, after: str = "") -> list[str]:
    """The cells of the first table row starting ``| row_start |`` after the line starting with ``after``."""
    lines = path.read_text(encoding="utf-8").splitlines()
    k = next(i for i, ln in enumerate(lines) if ln.startswith(after)) if after else 0
    row = next(ln for ln in lines[k:] if ln.startswith(f"| {row_start} |"))
    return [c.strip() for c in row.strip().strip("|").split("|")]


def _numbers(cell: str) -> list[float]:
    return [float(x) for x in re.findall(r"-?\d+(?:\.\d+)?", cell)]


@pytest.fixture
def drawn(monkeypatch, tmp_path):
    """``drawn(figure_function)``: its lines by (axes index, label) -> (x, y), and the axes' titles and y labels."""

    def draw(function):
        seen = {}
        save = rf.common._save

        def keep(fig, path, caption, **kw):
            seen["lines"] = {
                (i, ln.get_label()): (np.asarray(ln.get_xdata(), float), np.asarray(ln.get_ydata(), float))
                for i, ax in enumerate(fig.axes)
                for ln in ax.get_lines()
            }
            seen["axes"] = [(ax.get_title(), ax.get_ylabel()) for ax in fig.axes]
            return save(fig, path, caption, **kw)

        for module in (rf.common, sys.modules[function.__module__]):  # _legend_and_save's and its own, if any
            if hasattr(module, "_save"):
                monkeypatch.setattr(module, "_save", keep)
        function(tmp_path)
        return seen

    return draw


def test_the_classic_figure_plots_each_unit_on_its_axis(drawn):
    src = RESULTS / "classic_ml.md"
    seen = drawn(rf.classic_bound)
    for n in (10, 20, 50):
        cells = _cells(src, f"isotropic {n}")
        (bound_deg, bound_mm), (_, _), (ratio_deg, ratio_mm) = (_numbers(c) for c in cells[1:4])
        for ax, bound, ratio in ((0, bound_mm, ratio_mm), (1, bound_deg, ratio_deg)):
            x, y = seen["lines"][(ax, "isotropic: bound")]
            assert y[list(x).index(n)] == bound
            x, y = seen["lines"][(ax, "isotropic: handeye default")]
            assert y[list(x).index(n)] == bound * ratio
    assert seen["axes"][0] == ("translation: default (dots) on the bound (lines)", "RMS error of X [mm]")
    assert seen["axes"][1][1] == "RMS error of X [deg]"


def test_the_markerless_figure_plots_the_median_and_the_translation_z(drawn):
    src = RESULTS / "markerless_sensors.md"
    heading = next(ln for ln in src.read_text(encoding="utf-8").splitlines() if ln.startswith("## paper-real-native"))
    distance = float(re.search(r"cameras ([0-9.]+) m", heading)[1])
    cells = _cells(src, "d435, self-calibrated", heading)
    seen = drawn(rf.markerless_distance)
    (top_left, top_right) = [i for i, (t, _) in enumerate(seen["axes"]) if t.startswith("paper-real:")]
    x, y = seen["lines"][(top_left, "d435")]
    assert y[list(x).index(distance)] == _numbers(cells[2])[0]  # median mm
    x, y = seen["lines"][(top_right, "d435")]
    assert y[list(x).index(distance)] == _numbers(cells[4])[0]  # z RMS of the translation
    assert "translation error [mm]" in seen["axes"][top_left][1]


def test_the_learned_figure_plots_the_mean_column_and_the_papers_final_step(drawn):
    src = RESULTS / "learned_keypoints_cpu_paper-sim.md"
    real = RESULTS / "paper_protocol_paper-real_paper_tables.md"
    seen = drawn(rf.learned_steps)
    for ax, kind in ((0, "translation"), (1, "orientation")):
        x, y = seen["lines"][(ax, "naive")]
        for step in (1, 6):
            assert y[list(x).index(step)] == float(_cells(src, f"T{step}", f"## naive, {kind}")[-1])
    x, y = seen["lines"][(2, "S2: this run")]
    assert list(y) == [float(_cells(real, f"T{k}", "#### Table 13")[2]) for k in (1, 2, 3)]
    x, y = seen["lines"][(2, "S2: the paper")]
    assert list(x) == [3] and list(y) == [float(_cells(real, "paper, final step", "#### Table 13")[2])]


def test_the_basin_figure_plots_each_outcomes_share(drawn):
    src = RESULTS / "markerless_paper-sim.md"
    after = next(ln for ln in src.read_text(encoding="utf-8").splitlines() if "the given start alone" in ln)
    seen = drawn(rf.markerless_basin)
    for label, column in (("success", 1), ("wrong", 2), ("refused", 4)):
        x, y = seen["lines"][(0, f"given start alone: {label}")]
        for off in (50, 300):
            cells = _cells(src, f"{off} mm, {off // 10} deg", after)
            total = _numbers(cells[1])[1]
            assert y[list(x).index(off)] == 100 * int(_numbers(cells[column])[0]) / int(total)


def test_the_real_recordings_figure_reads_each_methods_hold_out_halves_and_refusals():
    """The figure's points are the file's cells of the method's row: the hold-out median (deg, mm), the halves'
    ratios (none for a bare closed form), the refusals; each row of the four recordings in a group."""
    sources = [RESULTS / "real_recordings.md", RESULTS / "real_recordings_rwhe.md"]
    recordings = rf.real.real_recordings(sources)
    assert [r["name"] for r in recordings] == ["camodocal_artag", "ethz_robot_arm", "kuka_1", "kuka_2"]
    assert [(r["poses"], r["refusals"], len(r["methods"])) for r in recordings] == [
        (42, 0, 23),
        (98, 0, 23),
        (30, 0, 24),
        (28, 0, 24),
    ]
    for rec, src, method in (
        (recordings[0], sources[0], "handeye default (auto+lm)"),
        (recordings[0], sources[0], "handeye li (closed form)"),
        (recordings[3], sources[1], "handeye image path (auto, reprojection)"),
    ):
        cells = _cells(src, method, f"## {rec['name']}:")
        m = next(m for m in rec["methods"] if m["method"] == method)
        assert m["holdout"] == tuple(_numbers(cells[5]))
        halves = _numbers(cells[6]) or [float("nan")] * 2
        np.testing.assert_array_equal(m["halves"], halves)
        assert (m["refused"], m["holdout_refused"]) == (False, 0)
    groups = {m["group"] for r in recordings for m in r["methods"]}
    assert groups == {g for g, _, _ in rf.real.REAL_GROUPS}
    with pytest.raises(ValueError, match="no group"):
        rf.real.real_group("someone else's method")


def test_the_vision_figure_plots_the_translation_column_and_the_robot_rows(drawn):
    repro, robot = RESULTS / "vision_reprojection.md", RESULTS / "vision_robot_noise.md"
    seen = drawn(rf.vision_errors)
    x, y = seen["lines"][(0, "handeye reprojection refinement")]  # the 30-view rows
    assert list(x) == [0.1, 0.3, 1.0]
    lines = repro.read_text(encoding="utf-8").splitlines()
    rows = [next(ln for ln in lines if ln.startswith(f"| {n} | 30 (")).split("|") for n in ("0.1", "0.3", "1.0")]
    assert list(y) == [_numbers(r[-3])[1] for r in rows]  # the last cell 'most accurate', before it the refinement
    assert seen["axes"][0][1] == "median translation error of X [mm]"
    # the middle panel: one line per model, setup and component; the robot's error sorted, exact robot first
    middle = [y for (i, _), (x, y) in seen["lines"].items() if i == 1 and len(x) == 3]
    assert len(middle) == 16
    levels = ("0.0 deg, 0.0 mm", "0.05 deg, 0.5 mm", "0.2 deg, 2.0 mm")
    none_x_rot = [_numbers(_cells(robot, f"eye-to-hand | {lv} | none")[4])[0] for lv in levels]
    assert any(list(y) == none_x_rot for y in middle)


def test_the_planning_figure_plots_each_column_of_the_table(drawn):
    """Each panel's lines are the table's cells of that column and component (rotation, translation, workspace, in
    that order), and the dashed lines the random columns' 15-pose cells."""
    src = RESULTS / "plan_poses.md"
    header = _cells(src, "poses")
    seen = drawn(rf.plan_poses)
    for j, unit in enumerate(("deg", "mm", "mm")):
        assert seen["axes"][j][1] == f"RMS error of X over the cells [{unit}]"
        for column in ("planned predicted", "random predicted", "planned actual", "random actual"):
            x, y = seen["lines"][(j, column)]
            assert list(x) == [6, 8, 10, 15]
            k = header.index(column)
            assert list(y) == [_numbers(_cells(src, str(n))[k])[j] for n in (6, 8, 10, 15)]
            if column.startswith("random"):
                _, y = seen["lines"][(j, f"{column}, 15 poses")]
                assert set(y) == {_numbers(_cells(src, "15")[k])[j]}
    assert [t for t, _ in seen["axes"]] == ["rotation [deg]", "translation [mm]", "workspace error [mm]"]
