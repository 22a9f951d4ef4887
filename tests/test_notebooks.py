"""The notebooks run: every code cell executed in order, in one namespace, as a kernel would."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

NOTEBOOKS = Path(__file__).resolve().parent.parent / "notebooks"


def run_notebook(path: Path) -> dict:
    """Execute a notebook's code cells; an exception names the cell."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    namespace: dict = {"__name__": "__notebook__"}
    cells = [c for c in json.loads(path.read_text())["cells"] if c["cell_type"] == "code"]
    for k, cell in enumerate(cells):
        source = "".join(cell["source"])
        try:
            exec(compile(source, f"{path.name}[cell {k + 1}]", "exec"), namespace)
        finally:
            plt.close("all")
    return namespace


def _with_the_small_render(small_dataset, folder: Path) -> None:
    """The notebooks render ``Recipe("small", seed=0)`` on 2 workers and label it, as conftest's ``small_dataset``
    does: that render, copied where the notebook renders, is kept by its ``generate`` (a resumed render keeps the
    complete placements of the same recipe), so a run renders the small preset once, not once per notebook."""
    shutil.copytree(small_dataset[0], folder / "small")


@pytest.mark.slow  # 13 s on a quiet 2-core machine: a whole walkthrough, the slow tier (CI)
def test_simulator_walkthrough(tmp_path, monkeypatch, small_dataset):
    pytest.importorskip("pinocchio")
    pytest.importorskip("pyrender")
    _with_the_small_render(small_dataset, tmp_path)
    monkeypatch.setenv("HANDEYE_NOTEBOOK_DATA", str(tmp_path))
    ns = run_notebook(NOTEBOOKS / "01_simulator.ipynb")
    assert (tmp_path / "small" / "cam2.png").is_file()
    assert all(s == "ok" for s in ns["cams"]["label_status"])


@pytest.mark.slow  # 16 s: renders, labels and trains, the slow tier (CI)
def test_continual_learning_walkthrough(tmp_path, monkeypatch, small_dataset):
    pytest.importorskip("pinocchio")
    pytest.importorskip("torch")
    _with_the_small_render(small_dataset, tmp_path)
    monkeypatch.setenv("HANDEYE_NOTEBOOK_DATA", str(tmp_path))
    ns = run_notebook(NOTEBOOKS / "02_continual_learning.ipynb")
    assert (tmp_path / "cell.pt").is_file() and (tmp_path / "run" / "report.md").is_file()
    assert ns["T"].shape == (4, 4)
