"""The benchmark figures plot what their labels say: each line's points are the results file's cells of that
column (read here apart, by row and column name), on the axis its title and unit name. The figure test beside
it (tests/test_make_figures.py) checks that the figures are drawn and captioned, not what they show: a swapped
column (the rotation's bound on the translation's axis) passed it."""

from __future__ import annotations

import re

import numpy as np
import pytest

pytest.importorskip("matplotlib")

from matplotlib.container import BarContainer  # noqa: E402

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


def _half_lengths(errorbar) -> np.ndarray | None:
    """Half the length of each error bar of a bar plot's ``errorbar`` (None where it has none)."""
    if errorbar is None:
        return None
    return np.array([(top - bottom) / 2 for (_, bottom), (_, top) in errorbar.lines[2][0].get_segments()])


@pytest.fixture
def drawn(monkeypatch, tmp_path):
    """``drawn(figure_function)``: its lines by (axes index, label) -> (x, y), its bars by (axes index, label) ->
    ``rects`` (x, y, width, height per bar) and ``errors`` (each bar's error bar, half its length), and the axes'
    titles and y labels."""

    def draw(function):
        seen = {}
        save = rf.common.save

        def keep(fig, path, caption, **kw):
            seen["lines"] = {
                (i, ln.get_label()): (np.asarray(ln.get_xdata(), float), np.asarray(ln.get_ydata(), float))
                for i, ax in enumerate(fig.axes)
                for ln in ax.get_lines()
            }
            seen["bars"] = {
                (i, c.get_label()): {
                    "rects": np.array([[r.get_x(), r.get_y(), r.get_width(), r.get_height()] for r in c]),
                    "errors": _half_lengths(c.errorbar),
                }
                for i, ax in enumerate(fig.axes)
                for c in ax.containers
                if isinstance(c, BarContainer)
            }
            seen["axes"] = [(ax.get_title(), ax.get_ylabel()) for ax in fig.axes]
            return save(fig, path, caption, **kw)

        monkeypatch.setattr(rf.common, "save", keep)  # every figure saves through common.save
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


def test_the_simulation_figure_plots_each_noise_rows_median_and_worst(drawn):
    """Per panel (rotation deg, translation mm) the dots are the median column and the squares the worst, one per
    noise row of the labels table, in the file's order."""
    src = RESULTS / "sim_generation_paper-sim.md"
    header = _cells(src, "noise (pixel grey levels, joint deg)")
    rows = ("none", "pixel 2", "joints 0.01 deg", "default: pixel 2, depth 1 mm at 1 m, joints 0.01 deg", "2x default")
    seen = drawn(rf.simulation_labels)
    for j, (what, unit) in enumerate((("rotation", "deg"), ("translation", "mm"))):
        assert seen["axes"][j][0] == f"{what} [{unit}]"
        for label, stat in (("median over the camera poses", "median"), ("worst camera pose", "worst")):
            column = f"{stat} {unit}"
            x, y = seen["lines"][(j, label)]
            assert list(y) == list(range(len(rows)))
            assert list(x) == [float(_cells(src, row)[header.index(column)]) for row in rows]


def test_the_cluster_figure_plots_the_throughput_and_the_time_per_run(drawn):
    """Left and middle, the Throughput table's pool and ray cells; right, per preset and configuration, the mean of
    each time column as the bar and its std as the error bar."""
    engines, training = RESULTS / "cluster_engines.md", RESULTS / "distributed_training.md"
    seen = drawn(rf.cluster_throughput)
    header = _cells(engines, "engine")
    for i, column in enumerate(("shards/min", "camera poses/min")):
        rects = seen["bars"][(i, column)]["rects"]
        assert list(rects[:, 3]) == [float(_cells(engines, e)[header.index(column)]) for e in ("pool", "ray")]
    ratios = re.search(r"generation ([0-9.]+), labelling ([0-9.]+)", engines.read_text(encoding="utf-8")).groups()
    assert [seen["axes"][i][0].split()[-1] for i in (0, 1)] == list(ratios)
    header = _cells(training, "configuration")
    for k, preset in enumerate(("tiny", "demo")):
        for config in ("1 proc x 1 thread", "1 proc x 2 threads", "2 proc x 1 thread"):
            cells = _cells(training, config, f"## Preset {preset}: time per run")
            for column in ("wall (whole command)", "protocol (training and evaluation)"):
                bars = seen["bars"][(2, f"{config}, {column}")]
                mean, std = _numbers(cells[header.index(column)])
                assert bars["rects"][k, 3] == mean
                np.testing.assert_allclose(bars["errors"][k], std)


def test_the_reliability_figure_stacks_each_commands_outcomes(drawn):
    """One bar per command row of the first table (not its all row), its outcomes stacked in the legend's order to
    the runs tried; each outcome labelled with the all row's count, and the title that row's totals."""
    src = RESULTS / "reliability.md"
    lines = src.read_text(encoding="utf-8").splitlines()
    start = next(i for i, ln in enumerate(lines) if ln.startswith("| command | tried |"))
    end = next(i for i, ln in enumerate(lines) if ln.startswith("| **all** |"))
    header, total = _cells(src, "command"), _cells(src, "**all**")
    rows = [[c.strip() for c in ln.strip("|").split("|")] for ln in lines[start + 2 : end]]
    seen = drawn(rf.reliability_outcomes)
    left = np.zeros(len(rows))
    failures = ("unclear", "silent", "destroyed/lost", "traceback", "timeout/other")
    for name in ("clear", "ok", *failures):
        rects = seen["bars"][(0, f"{name}: {total[header.index(name)]} in all")]["rects"]
        assert list(rects[:, 2]) == [int(r[header.index(name)]) for r in rows]
        assert list(rects[:, 0]) == list(left)
        left += rects[:, 2]
    assert list(left) == [int(r[header.index("tried")]) for r in rows]
    tried, clear, ok = (total[header.index(c)] for c in ("tried", "clear", "ok"))
    failed = sum(int(total[header.index(c)]) for c in failures)
    each = ", ".join(f"{total[header.index(c)]} {c}" for c in failures)
    assert seen["axes"][0][0] == f"{tried} fault runs: {clear} clear, {ok} ok, {failed} failed ({each})"
