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


rf = _module("results_figures")

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
    assert rf.tables(path) == [("Cell, one", ["a", "b"], [["1 / 2", "-"], ["x", "y"]])]
    assert rf.command_of(path) == "python x.py"
    assert rf._pair("0.1223 / 1.715") == (0.1223, 1.715)


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
        assert "made by `" in fig.caption and rf.DRAWN_BY in fig.caption
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
