"""The paper's layout: its tables numbered for its setting, its stated figures beside ours, its findings judged its way.

Built on hand-written results documents, so every printed figure and every verdict is known in advance: each
verdict rule (learned.paper_verdicts) on a result built to meet it, to break it, or to sit within the spread.
"""

from __future__ import annotations

import re

import numpy as np
import pytest

from learned.paper_tables import PAPER_TEXT, cost_rows, judge, paper_findings, paper_tables, setting
from learned.paper_verdicts import AS, FEW, LEVEL, NOT, WITHIN, against, describe

#: Each repeat's errors are the hand-built ones times (1 + this): three repeats with a small, known spread.
JITTER = (0.0, 0.01, -0.01)


def _run(strategy, network, final, trained_samples, skipped=(), steps=3, wall_s=10.0, repeat=0):
    """A run whose RMSE matrix is 10x ``final`` before the last step and ``final`` at it."""
    rows = [[10.0 * v for v in final] for _ in range(steps - 1)] + [list(final)]
    return {
        "strategy": strategy,
        "network": network,
        "repeat": repeat,
        "matrix": rows,
        "rmse_matrix": rows,
        "processed": 10 * trained_samples,
        "trained_samples": trained_samples,
        "stored": 0,
        "evaluated": 0,
        "skipped": list(skipped),
        "wall_s": wall_s,
        "pose_matrix": [],
    }


def _results(regions=3, repeats=3):
    steps = [[2 * k, 2 * k + 1] for k in range(regions)]
    runs = []
    for rep, j in zip(range(repeats), JITTER * repeats):
        for net, scale in (("translation", 1.0), ("orientation", 2.0)):
            s = scale * (1 + j)
            runs += [
                _run("batch", net, [s * 2.0] * regions, 1200, steps=regions, repeat=rep),
                _run("naive", net, [s * 40.0] + [s * 3.0] * (regions - 1), 400, steps=regions, repeat=rep),
                _run("reservoir", net, [s * 3.0] * regions, 600, steps=regions, repeat=rep),
                _run("selection", net, [s * 2.5] * regions, 300, skipped=[3], steps=regions, repeat=rep),
            ]
    return {
        "preset": {"threshold_mm": 3.0, "threshold_deg": 4.0, "protocol": "paper", "batch_every_step": True},
        "regions": list(range(regions)),
        "steps": steps,
        "strategies": ["batch", "naive", "reservoir", "selection"],
        "runs": runs,
    }


def _set_final(results, strategy, network, finals):
    """Repeat r of ``strategy`` ends at ``finals[r]`` on every subset."""
    for r in results["runs"]:
        if r["strategy"] == strategy and r["network"] == network:
            r["rmse_matrix"][-1] = [float(finals[r["repeat"]])] * len(results["regions"])


def _found(results):
    return {(f["network"], f["finding"]): f for f in judge(results)}


def test_the_setting_is_read_from_the_number_of_subsets():
    assert setting(_results(3)) == "real" and setting(_results(6)) == "sim" and setting(_results(4)) is None


def test_cost_is_counted_against_the_baseline():
    rows = {(r["strategy"], r["network"]): r for r in cost_rows(_results(repeats=1))}
    res = rows[("reservoir", "translation")]
    assert res["trained_samples_vs_baseline"] == pytest.approx(600 / 1200)
    assert res["minus_baseline"] == pytest.approx(3.0 - 2.0)
    assert rows[("selection", "orientation")]["minus_baseline"] == pytest.approx(5.0 - 4.0)
    assert rows[("selection", "translation")]["skipped"] == 1.0


def test_the_verdict_rule_bounds_by_the_papers_figure_and_the_spread():
    assert against([1.0, 1.0, 1.0], 1.5, at_most=True, decimals=1) == AS
    assert against([2.4, 2.4, 2.4], 1.5, at_most=True, decimals=1) == NOT  # 60 % beyond the paper's figure
    assert against([0.5, 1.5, 2.5], 1.5, at_most=True, decimals=1) == WITHIN  # the bound inside the spread
    assert against([1.5, 1.5], 1.5, at_most=True, decimals=1) == FEW  # two repeats: no verdict
    assert against([1.54, 1.54, 1.54], 1.5, at_most=True, decimals=1) == AS  # the paper's "1.5" is up to 1.55
    assert against([1.56, 1.56, 1.56], 1.5, at_most=True, decimals=1) == NOT
    assert against([0.645, 0.645, 0.645], 0.65, at_most=False, decimals=2) == AS  # "65 %" is down to 64.5 %
    assert against([0.60, 0.60, 0.60], 0.65, at_most=False, decimals=2) == NOT
    assert describe([1.0, 2.0, 3.0], unit="mm") == "+2.00 ± 1.00 mm (3 repeats)"


def test_the_findings_are_judged_with_the_papers_figures_as_the_bound():
    found = _found(_results())
    res = found[("translation", "reservoir's error against the baseline")]
    # +1.00 mm in every repeat (1 % jitter) against the paper's +1.4 mm at most
    assert res["ours"] == "+1.00 ± 0.01 mm (3 repeats)" and res["paper"] == "+1.4 mm at most"
    assert res["verdict"] == AS and res["table"] == "21"
    data = found[("translation", "reservoir's data against the baseline")]
    assert data["ours"] == "50 ± 0 % less data (3 repeats)" and data["paper"] == "48 % less data at least"
    assert data["verdict"] == AS
    assert found[("orientation", "reservoir's error against the baseline")]["verdict"] == AS  # +2 deg, paper +4.5
    sel = found[("translation", "selection's error against the baseline")]
    assert sel["ours"].startswith("+0.50 ± 0.00 mm") and sel["verdict"] == AS  # paper +1.0 mm
    assert found[("translation", "selection's data against the baseline")]["verdict"] == AS  # 75 % against 66 %
    worst = found[("translation", "naive the worst at the last step")]
    assert worst["verdict"] == AS and worst["table"] == "13"
    s1 = found[("translation", "naive's S1 at the last step against the baseline's")]
    assert s1["ours"] == "20.0 ± 0.0 x the baseline (3 repeats)" and s1["verdict"] == AS  # paper: 14x at least
    assert found[("orientation", "naive's S1 at the last step against the baseline's")]["verdict"] == NOT  # 20 < 31
    real = PAPER_TEXT["real"]
    assert s1["paper"] == f"{real['naive_s1_over_baseline'][0]:.0f}x the baseline (at least)"
    elim = found[("translation", "camera poses eliminated")]
    # the baseline's 2 mm is below the 3 mm threshold: the count is judged, 1 against the paper's 6
    assert elim["ours"] == "1.0 ± 0.0 of 4 at 3 mm (3 repeats)" and elim["paper"] == "6 of 13 at 3 mm (at least)"
    assert elim["verdict"] == NOT
    assert found[("orientation", "camera poses eliminated")]["paper"] == "not given in the text"
    assert found[("translation", "the baseline's level")]["ours"].startswith("2.00 ± 0.02 mm")
    lines = paper_findings(_results())
    assert (
        "translation: reservoir's error against the baseline: +1.00 ± 0.01 mm (3 repeats) "
        "(paper: +1.4 mm at most): as the paper" in lines
    )


def test_a_strategy_60_percent_beyond_what_the_paper_allows_fails():
    results = _results()
    _set_final(results, "reservoir", "translation", [2.0 * (1 + j) + 1.6 * 1.4 for j in JITTER])
    f = _found(results)[("translation", "reservoir's error against the baseline")]
    assert f["ours"].startswith("+2.24") and f["verdict"] == NOT
    # 60 % worse than its own baseline at a hundred times the paper's level: the old rule (a share of the
    # baseline, up to the paper's +100 %) passed it; +108 mm against the paper's +1.4 mm does not
    results = _results()
    _set_final(results, "batch", "translation", [180.0 * (1 + j) for j in JITTER])
    _set_final(results, "reservoir", "translation", [288.0 * (1 + j) for j in JITTER])
    assert _found(results)[("translation", "reservoir's error against the baseline")]["verdict"] == NOT


def test_less_data_than_the_baseline_but_less_of_a_saving_than_the_papers_fails():
    results = _results()
    for r in results["runs"]:
        if r["strategy"] == "reservoir":
            r["trained_samples"] = 720  # 40 % less than the baseline's 1200, the paper's 48 % on its rig
    f = _found(results)[("translation", "reservoir's data against the baseline")]
    assert f["ours"] == "40 ± 0 % less data (3 repeats)" and f["verdict"] == NOT
    for r in results["runs"]:
        if r["strategy"] == "reservoir":
            r["trained_samples"] = 1500  # more than the baseline's
    f = _found(results)[("translation", "reservoir's data against the baseline")]
    assert f["ours"] == "25 ± 0 % more data (3 repeats)" and f["verdict"] == NOT


def test_a_difference_within_the_spread_of_the_repeats_gets_no_verdict():
    results = _results()
    _set_final(results, "batch", "translation", [180.0, 200.0, 160.0])
    _set_final(results, "reservoir", "translation", [170.0, 215.0, 140.0])  # -10, +15, -20 mm: spread 18
    f = _found(results)[("translation", "reservoir's error against the baseline")]
    assert f["ours"] == "-5.00 ± 18.03 mm (3 repeats)" and f["verdict"] == WITHIN
    one = _found(_results(repeats=1))
    assert {f["verdict"] for f in one.values()} <= {FEW, "-"}  # one repeat: no spread, no verdict
    assert one[("translation", "reservoir's error against the baseline")]["ours"] == "+1.00 mm (1 repeat)"


def test_eliminations_at_thresholds_the_errors_never_reach_are_not_judgeable():
    results = _results()
    for r in results["runs"]:
        if r["strategy"] == "selection":
            r["skipped"] = []
    # the baseline at 180 mm, sixty times the 3 mm threshold: 0 of 4 eliminated says nothing of the paper's 6
    _set_final(results, "batch", "translation", [180.0 * (1 + j) for j in JITTER])
    found = _found(results)
    elim = found[("translation", "camera poses eliminated")]
    assert (
        elim["verdict"] == LEVEL and "0.0 ± 0.0 of 4 at 3 mm" in elim["ours"] and "above the threshold" in elim["ours"]
    )
    assert found[("translation", "selection's data against the baseline")]["verdict"] == LEVEL
    assert found[("translation", "reservoir's data against the baseline")]["verdict"] == AS  # no threshold in it
    # with the baseline below the threshold, none eliminated is a finding: not as the paper
    results = _results()
    for r in results["runs"]:
        r["skipped"] = []
    assert _found(results)[("translation", "camera poses eliminated")]["verdict"] == NOT


def _sim_with_naive_diagonal(times_baseline):
    """Six subsets; naive's error on each subset right after its own step ``times_baseline`` x the baseline's."""
    results = _results(6)
    for r in results["runs"]:
        if r["strategy"] == "naive":
            base = 2.0 * (1.0 if r["network"] == "translation" else 2.0) * (1 + JITTER[r["repeat"]])
            m = np.array(r["rmse_matrix"])
            np.fill_diagonal(m, times_baseline * base)
            r["rmse_matrix"] = m.tolist()
    return results


def test_naives_diagonal_is_held_to_the_papers_1_5x():
    found = _found(_sim_with_naive_diagonal(1.2))
    diag = found[("translation", "naive's diagonal against the baseline")]
    assert diag["paper"] == "at most 1.5x the baseline" and diag["table"] == "3"
    assert diag["ours"] == "1.20 ± 0.00 x the baseline (3 repeats)" and diag["verdict"] == AS
    assert (
        _found(_sim_with_naive_diagonal(2.0))[("orientation", "naive's diagonal against the baseline")]["verdict"]
        == NOT
    )
    assert found[("translation", "naive the worst at the last step")]["verdict"] == AS


def test_the_tables_carry_the_papers_numbers_and_only_those_its_text_gives():
    text = "\n".join(paper_tables(_results()))
    for n in (13, 14, 15, 16, 19, 20, 21):
        assert f"Table {n}:" in text
    assert "| paper, final step | 31.51 | 4.14 | 3.49 |" in text  # Table 13's final row, stated in the text
    assert text.count("not given in the text") >= 3
    sim = "\n".join(paper_tables(_results(6)))
    assert "Table 3:" in sim and "Table 11:" in sim and "paper, final step" not in sim
    other = "\n".join(paper_tables(_results(4)))
    assert re.search(r"Table \d+:", other) is None and "no figures of its" in other


def test_a_run_without_a_baseline_says_it_cannot_be_judged_the_papers_way():
    results = _results()
    results["strategies"] = ["naive", "reservoir"]
    results["runs"] = [r for r in results["runs"] if r["strategy"] in results["strategies"]]
    assert paper_findings(results) == ["the paper judges every strategy against the batch baseline: this run has none"]
    assert np.isfinite(cost_rows(results)[0]["trained_samples"])
