"""The learned run's result files are written whole, and only where a regular file belongs
(:mod:`handeye.core.safe_write`): a FIFO or a device at ``results.json`` or ``report.md`` is refused, not
written into."""

from __future__ import annotations

import os
from types import SimpleNamespace

import pytest

from handeye.core.errors import OutputFileError

pytest.importorskip("torch")


def _fifo_with_reader(path):
    """A FIFO at ``path`` with a reader open (a plain write would go into it and succeed); the reader's fd."""
    os.mkfifo(path)
    return os.open(path, os.O_RDONLY | os.O_NONBLOCK)


def test_results_json_is_not_written_into_a_fifo(tmp_path):
    from learned.experiment import _write_results

    reader = _fifo_with_reader(tmp_path / "results.json")
    try:
        with pytest.raises(OutputFileError, match="results.json"):
            _write_results(SimpleNamespace(writer=True, out=tmp_path), {"runs": []})
    finally:
        os.close(reader)


def test_report_md_is_not_written_into_a_fifo(tmp_path, monkeypatch):
    import learned.report as report

    run = SimpleNamespace(dir=tmp_path, results={})
    monkeypatch.setattr(report._Run, "read", staticmethod(lambda folder: run))
    sections = ("_title", "_step_matrices", "_placement_matrices", "_final_step", "_final_step_rmse", "_compute")
    sections += ("_per_camera_summary", "_per_camera_tables", "paper_tables", "_repeat_placements", "_own_checks")
    for name in sections:  # the report's sections are not what is tested: each a line
        monkeypatch.setattr(report, name, lambda _: ["x"])
    reader = _fifo_with_reader(tmp_path / "report.md")
    try:
        with pytest.raises(OutputFileError, match="report.md"):
            report.write_report(tmp_path, figures=False)
    finally:
        os.close(reader)
