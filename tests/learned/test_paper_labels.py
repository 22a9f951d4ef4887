"""The paper's protocol trains on the paper's labels (Tsai's closed form, 5 repeats averaged), ours on its own.

The kind is read from the dataset's label columns (learned.label_kind): the paper's kind carries no sigma.
"""

from __future__ import annotations

import pytest

from learned.label_kind import HANDEYE, PAPER, label_kind

pytest.importorskip("torch")


def test_the_kind_of_label_is_read_from_the_dataset(small_dataset, paper_labelled):
    assert label_kind(small_dataset[0]) == HANDEYE
    assert label_kind(paper_labelled) == PAPER


def test_a_paper_mode_run_on_this_projects_labels_is_refused_with_the_command_that_writes_the_papers(
    small_dataset, tmp_path, capsys
):
    from handeye.cli import main

    root = small_dataset[0]
    out = tmp_path / "refused"
    args = ["learned", "run", "--data", str(root), "--preset", "tiny", "--quiet", "--out", str(out)]
    assert main([*args, "--protocol", "paper"]) == 2
    err = capsys.readouterr().err
    assert f"handeye label {root} --method tsai --repeats 5" in err and "this project's" in err
    assert not out.exists()


def test_this_projects_mode_on_the_papers_labels_is_refused(paper_labelled, tmp_path, capsys):
    from handeye.cli import main

    out = tmp_path / "refused"
    args = ["learned", "thresholds", "--data", str(paper_labelled), "--preset", "tiny", "--quiet", "--out", str(out)]
    assert main(args) == 2
    err = capsys.readouterr().err
    assert f"'handeye label {paper_labelled}'" in err and "the paper's" in err
    assert not out.exists()


def test_a_label_of_this_project_whose_sigma_is_nan_is_still_this_projects(monkeypatch):
    import numpy as np

    import learned.label_kind as lk

    nan = float("nan")
    table = {
        "label_status": np.array(["ok", "ok", "failed: no views"]),
        "label_rms_px": np.array([0.31, 0.28, nan]),
        "label_sigma_trans_mm": np.array([0.4, nan, nan]),  # a singular covariance: no sigma, the RMS written
        "label_sigma_rot_deg": np.array([0.02, nan, nan]),
    }
    monkeypatch.setattr(lk.Dataset, "open", staticmethod(lambda root: type("D", (), {"cameras": lambda self: table})()))
    assert label_kind("any") == HANDEYE
    table["label_rms_px"][1] = nan  # a pose with none of them: the paper's kind beside ours
    assert label_kind("any") == "mixed"


def test_the_paper_protocol_benchmark_names_the_labels_both_modes_train_on(small_dataset, paper_labelled):
    from benchmarks.paper_protocol import labels_line

    ours = labels_line(small_dataset[0])
    assert HANDEYE in ours and "the paper's protocol on other labels" in ours
    papers = labels_line(paper_labelled)
    assert PAPER in papers and "other labels" not in papers
