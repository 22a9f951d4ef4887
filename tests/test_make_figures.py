"""``docs/make_figures.py --results`` redraws the benchmark pages' figures from the shipped results files, each
page shows them with their captions, and every image a documentation page links is a file."""

from __future__ import annotations

import importlib.util
import re
import sys
from pathlib import Path

import pytest

pytest.importorskip("matplotlib")

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"


def _module(name: str):
    spec = importlib.util.spec_from_file_location(name, DOCS / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module  # a dataclass looks its module up there
    sys.path.insert(0, str(DOCS))
    try:
        spec.loader.exec_module(module)
    finally:
        sys.path.remove(str(DOCS))
    return module


def _package(name: str):
    """The package ``docs/<name>/`` imported (its modules import one another relatively)."""
    sys.path.insert(0, str(DOCS))
    try:
        return importlib.import_module(name)
    finally:
        sys.path.remove(str(DOCS))


rf = _package("figures")

#: A Markdown image ``![alt](path)`` or an HTML ``<img src="path">`` of a page.
IMAGE = re.compile(r"!\[[^\]]*\]\(([^)\s]+)\)|<img [^>]*src=\"([^\"]+)\"")


def missing_images(page: Path, text: str) -> list[str]:
    """The images ``text`` (the page's Markdown) links that are not files, relative to the page."""
    links = [a or b for a, b in IMAGE.findall(text)]
    return [link for link in links if "://" not in link and not (page.parent / link).is_file()]


def test_tables_reads_a_known_table(tmp_path):
    path = tmp_path / "r.md"
    path.write_text(
        "command: python x.py\n\n## Cell, one\n\nnote\n\n| a | b |\n|---|---|\n| 1 / 2 | - |\n| x | y |\n\n"
    )
    assert rf.common.tables(path) == [("Cell, one", ["a", "b"], [["1 / 2", "-"], ["x", "y"]])]
    assert rf.common.command_of(path) == "python x.py"
    assert rf.common.pair("0.1223 / 1.715") == (0.1223, 1.715)


def test_make_figures_redraws_every_figure_from_the_shipped_results(tmp_path):
    """The quick path (no simulator): every figure drawn, of the size the shipped one has, its caption naming
    results files that exist, and the caption shown on a benchmark page under the shipped image."""
    from PIL import Image

    make = _module("make_figures")
    make.main(["--results", "--out", str(tmp_path)])
    pages = {p: p.read_text(encoding="utf-8") for p in (DOCS / "benchmarks").glob("*.md")}
    for fig in rf.draw_all(tmp_path):
        assert fig.path.stat().st_size > 0
        shipped = DOCS / "img" / fig.path.name
        assert Image.open(shipped).size == Image.open(fig.path).size, f"{shipped}: not this script's (rerun it)"
        for name in re.findall(r"`(benchmarks/results/[^`]+\.md)`", fig.caption):
            assert (ROOT / name).is_file(), name
        assert "made by `" in fig.caption and rf.common.DRAWN_BY in fig.caption
        shown = [p for p, text in pages.items() if f"](../img/{fig.path.name})\n\n*{fig.caption}*" in text]
        assert shown, f"{fig.path.name}: no benchmark page shows it with its caption"


def test_every_image_a_page_links_exists():
    missing = {}
    for page in DOCS.rglob("*.md"):
        if bad := missing_images(page, page.read_text(encoding="utf-8")):
            missing[str(page.relative_to(ROOT))] = bad
    assert not missing


def test_the_image_check_finds_a_missing_image():
    page = DOCS / "benchmarks" / "classic.md"
    text = '![x](../img/classic_bound.png) ![y](../img/no-such.png) <img src="../img/nor-this.png">'
    assert missing_images(page, text) == ["../img/no-such.png", "../img/nor-this.png"]


def test_a_figure_is_written_whole_and_never_into_a_fifo(tmp_path):
    """A FIFO where a figure goes is refused, naming it (a plain ``savefig`` opened it and blocked, or wrote a
    half image into whatever read it); the figure beside it is a whole PNG, no temporary file left."""
    import os
    import signal

    from handeye.core.errors import OutputFileError

    os.mkfifo(tmp_path / "classic_bound.png")

    def _blocked(*_):
        raise TimeoutError("the figure was written into the FIFO (open blocked)")

    old = signal.signal(signal.SIGALRM, _blocked)
    signal.alarm(20)
    try:
        with pytest.raises(OutputFileError, match="FIFO"):
            rf.classic_bound(tmp_path)
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, old)
    fig = rf.markerless_basin(tmp_path)
    assert fig.path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["classic_bound.png", "markerless_basin.png"]


def test_sections_split_a_file_into_its_reports(tmp_path):
    path = tmp_path / "r.md"
    path.write_text(
        "# A reading by hand\n\n| a |\n|---|\n| 1 |\n\n---\n\n# Run\ncommand: python b.py --cases 2\n\n## c\n\n"
        "| b |\n|---|\n| 2 |\n"
    )
    assert rf.common.sections(path) == [
        ("", [("A reading by hand", ["a"], [["1"]])]),
        ("python b.py --cases 2", [("c", ["b"], [["2"]])]),
    ]
    assert rf.common.command_of_section(path, "c") == "python b.py --cases 2"


def test_the_real_cell_figure_reads_the_rows_the_page_quotes():
    """The figure's rows are the page's table (docs/benchmarks/markerless.md, 'A real cell's errors'): the run at
    the front's defaults, not the later runs with options put together in the same file; its sigmas are the
    resolution file's after-column medians, quoted in its text (2.28, 4.46 and 3.75 mm)."""
    page = DOCS / "benchmarks" / "markerless.md"
    (_, header, quoted), *_ = [t for t in rf.common.tables(page) if t[0] == "A real cell's errors"]
    assert header[1] == "`paper-real`: accepted" and header[6] == "`paper-sim`: accepted"
    for preset, first in (("paper-real", 1), ("paper-sim", 6)):
        rows = rf.real_cell._error_rows(rf.common.RESULTS / "markerless_errors.md", preset)
        assert len(rows) == 10
        for r, q in zip(rows, quoted):
            assert f"{r['accepted']}/{r['placements']}" == q[first]
            assert (r["median"], r["worst"], r["beyond"]) == (
                float(q[first + 1].split()[0]),
                float(q[first + 2]),
                int(q[first + 3]),
            )
    sigma = rf.real_cell._sigma_rows(rf.common.RESULTS / "markerless_resolution.md")
    assert [
        round(sigma[k]["sigma"], 2)
        for k in ("256x256, none (d435 as is)", "256x256, fixed pattern 3.6 mm", "256x256, all together")
    ] == [2.28, 4.46, 3.75]
    assert sigma["848x480, all together"]["beyond"] == 0 and sigma["848x480, all together"]["worst"] == 12.03


def test_the_real_cell_figure_refuses_two_runs_at_the_defaults(tmp_path):
    src = (rf.common.RESULTS / "markerless_errors.md").read_text(encoding="utf-8")
    first = src.split("\n---\n")[1]
    path = tmp_path / "markerless_errors.md"
    path.write_text(src + "\n---\n" + first, encoding="utf-8")
    with pytest.raises(ValueError, match="2 runs of paper-real"):
        rf.real_cell._error_rows(path, "paper-real")


def test_the_sensor_figure_reads_the_charuco_lines():
    text = (rf.common.RESULTS / "markerless_sensors.md").read_text(encoding="utf-8")
    assert rf.markerless.charuco_medians(text) == {
        "paper-real-native": 0.19,
        "paper-real-0.7": None,
        "paper-real-1.8": 0.81,
        "paper-sim-native": 0.36,
        "paper-sim-0.7": None,
        "paper-sim-1.8": 0.45,
    }


def test_the_basin_map_reads_every_cell_of_both_starts():
    """The map's file holds a full grid per start (the given start alone and with the centroid start beside), every
    cell's trials counted once: the accepted ones within 1 mm or wrong, plus the refused, make its trials; the
    wrong answers beyond 3 sigma are among the wrong ones."""
    starts = rf.basin.basin_map_cells(rf.common.RESULTS / "markerless_basin_map_small.md")
    assert sorted(starts) == ["centroid start beside", "given start alone"]
    for cells in starts.values():
        mms, degs = {mm for mm, _ in cells}, {deg for _, deg in cells}
        assert len(mms) > 1 and len(degs) > 1 and len(cells) == len(mms) * len(degs)
        assert 2.5 in degs
        for c in cells.values():
            assert c["good"] + c["wrong"] + c["refused"] == c["n"]
            assert 0 <= c["far"] <= c["wrong"]


def test_the_basin_map_parses_a_fractional_degree(tmp_path):
    path = tmp_path / "r.md"
    path.write_text(
        "command: python x.py\n\n## Basin: d, 6 trials per cell; the given start alone\n\n"
        "| start off by | success | wrong answer | of which beyond 3 sigma | refused |\n|---|---|---|---|---|\n"
        "| 25 mm, 2.5 deg | 3/6 (50 %) | 2 | 1 | 1 |\n"
    )
    assert rf.basin.basin_map_cells(path) == {
        "given start alone": {(25, 2.5): {"n": 6, "good": 3, "wrong": 2, "far": 1, "refused": 1}}
    }
