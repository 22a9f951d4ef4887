"""The documentation site as mkdocs builds it: no raw Sphinx role, the roles linked, every image present.

The docstrings' roles (``:func:`x```) are rewritten into links at build time by the griffe extension
``docs/hooks/sphinx_roles.py``; these tests build the site (``mkdocs build --strict``, about 5 s) and read the
HTML, then open the pages in headless Chromium where one is installed.
"""

from __future__ import annotations

import importlib.util
import re
import subprocess
import sys
from html.parser import HTMLParser
from pathlib import Path
from urllib.parse import unquote, urlsplit

import pytest

from tests.test_docs import ROOT, _browser

#: A Sphinx role as mkdocs prints one it did not understand: ``:func:`` then the name in code (or a backtick).
RAW_ROLE = re.compile(r":(?:py:)?(?:func|class|data|meth|attr|mod|exc|obj|const|math):(?:<code>|`)")


def _extension():
    spec = importlib.util.spec_from_file_location("sphinx_roles", ROOT / "docs" / "hooks" / "sphinx_roles.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def build_site(out: Path) -> Path:
    """The site as ``mkdocs build --strict`` writes it into ``out`` (asserting the build succeeds).

    Not ``-q``: under it mkdocs drops the API pages' docstring warnings (griffe's) before ``--strict`` counts them,
    and a docstring griffe misreads built as if clean.
    """
    build = subprocess.run(
        [sys.executable, "-m", "mkdocs", "build", "--strict", "-d", str(out)],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert build.returncode == 0, build.stderr[-3000:]
    return out


@pytest.fixture(scope="module")
def site(tmp_path_factory) -> Path:
    return build_site(tmp_path_factory.mktemp("site"))


def pages(site: Path) -> list[Path]:
    """The site's pages (the theme's own 404 page aside)."""
    return sorted(p for p in site.rglob("index.html") if "assets" not in p.parts)


def raw_roles(page: Path) -> list[str]:
    """Each raw role in a built page, with the text around it."""
    text = page.read_text()
    return [text[max(m.start() - 60, 0) : m.end() + 40] for m in RAW_ROLE.finditer(text)]


class _Images(HTMLParser):
    def __init__(self):
        super().__init__()
        self.sources: list[str] = []

    def handle_starttag(self, tag, attrs):
        if tag == "img":
            self.sources.append(dict(attrs).get("src") or "")


def missing_images(page: Path, html: str | None = None) -> list[str]:
    """The ``<img>`` sources of a page (its HTML, or the file's) that are not files of the site."""
    parser = _Images()
    parser.feed(page.read_text() if html is None else html)
    missing = []
    for src in parser.sources:
        url = urlsplit(src)
        if url.scheme in ("http", "https", "data"):
            missing.append(f"{src} (not a file of the site)")
        elif not (page.parent / unquote(url.path)).is_file():
            missing.append(src)
    return missing


def test_no_raw_role_reaches_the_site(site):
    """No page of the built site prints a Sphinx role as text."""
    found = {p.relative_to(site).as_posix(): raw_roles(p) for p in pages(site)}
    found = {k: v for k, v in found.items() if v}
    assert not found, f"raw roles in the built HTML: { {k: (len(v), v[0]) for k, v in found.items()} }"


def test_the_check_finds_a_planted_raw_role(site, tmp_path):
    """The check above fails on a page holding one raw role (as mkdocs prints one): it can fail."""
    page = tmp_path / "index.html"
    text = (site / "reference" / "classic" / "index.html").read_text()
    page.write_text(text.replace("<p>", "<p>see :func:<code>calibrate</code> ", 1))
    assert len(raw_roles(page)) == 1


def test_roles_become_links_to_the_objects(site):
    """Roles in the classic page's docstrings link to the objects' sections: a full path (``:mod:``), a short
    name found in the docstring's module, and an imported name followed to where it is defined."""
    html = (site / "reference" / "classic" / "index.html").read_text()
    assert re.search(r'<a class="autorefs autorefs-internal"[^>]*href="#classic\.registry"><code>', html)
    # classic.calibrate's docstrings (solve's, the module's) name calibrate by its short name
    assert re.search(r'href="#classic\.calibrate\.calibrate"><code>calibrate</code>', html)


def test_calibrate_comes_first_on_its_page(site):
    """The classic page opens with the module ``classic.calibrate`` and, in it, the function ``calibrate``."""
    html = (site / "reference" / "classic" / "index.html").read_text()
    ids = re.findall(r'<h[2-6] id="([\w.]+)" class="doc doc-heading"', html)
    assert ids[:2] == ["classic.calibrate", "classic.calibrate.calibrate"], ids[:4]


def test_the_resolver_against_known_paths():
    """Short names found in the scopes around the docstring (the object, its class, its module), imported
    names followed to their definition, full paths kept, names outside the project left as code."""
    import griffe

    ext = _extension()
    classic = griffe.load("classic", search_paths=[str(ROOT)])
    calibrate = classic["calibrate.calibrate"]
    assert ext.resolve("solve", calibrate) == "classic.calibrate.solve"
    assert ext.resolve("classic.registry", calibrate) == "classic.registry"
    assert ext.resolve("numpy.linalg.svd", calibrate) is None
    assert ext.resolve("no_such_name", calibrate) is None
    imported = next(n for n, m in classic["calibrate"].members.items() if m.is_alias and "classic." in m.target_path)
    assert ext.resolve(imported, calibrate) == classic["calibrate"].members[imported].target_path
    text = ext.rewrite("see :func:`~classic.calibrate.solve` and :class:`numpy.ndarray`, :math:`x^2`", calibrate)
    assert text == (
        'see <autoref identifier="classic.calibrate.solve" optional><code>solve</code></autoref> and '
        "`numpy.ndarray`, `x^2`"
    )
    wrapped = ext.rewrite(":func:`classic.calibrate.\n    solve`", calibrate)  # a target wrapped across lines
    assert (
        wrapped
        == '<autoref identifier="classic.calibrate.solve" optional><code>classic.calibrate.solve</code></autoref>'
    )


def test_every_image_is_a_file_of_the_site(site):
    """Every ``<img>`` of every page points at a file the build wrote (the figures are present)."""
    missing = {p.relative_to(site).as_posix(): missing_images(p) for p in pages(site)}
    missing = {k: v for k, v in missing.items() if v}
    assert not missing, f"images missing from the site: {missing}"
    assert sum(len(_parsed(p)) for p in pages(site)) >= 3  # the site has figures to check


def _parsed(page: Path) -> list[str]:
    parser = _Images()
    parser.feed(page.read_text())
    return parser.sources


def undecodable_images(page: Path) -> list[str]:
    """The ``<img>`` files of a built page that are no image: Pillow cannot read them, or they have no pixels."""
    from PIL import Image

    bad = []
    for src in _parsed(page):
        path = page.parent / unquote(urlsplit(src).path)
        if not path.is_file():
            continue  # missing_images says so
        try:
            with Image.open(path) as image:
                image.load()
                if image.width == 0 or image.height == 0:
                    bad.append(f"{src} (no pixels)")
        except Exception as err:  # any decoder error: the page shows a broken picture
            bad.append(f"{src} ({type(err).__name__})")
    return bad


def markdown_images(page: Path) -> int:
    """How many images (``![...](...)``) a documentation page's Markdown shows."""
    return len(re.findall(r"!\[[^\]]*\]\([^)]+\)", page.read_text(encoding="utf-8")))


def test_every_figure_decodes_and_every_page_shows_its_figures(site):
    """Each page's figures are pictures (Pillow reads every ``<img>`` file, with pixels), and each page shows as
    many of them as its Markdown names (a figure Markdown left as text, or dropped, is missed here)."""
    bad = {p.relative_to(site).as_posix(): undecodable_images(p) for p in pages(site)}
    assert not {k: v for k, v in bad.items() if v}
    docs = ROOT / "docs"
    shown = {}
    for md in docs.rglob("*.md"):
        rel = md.relative_to(docs).with_suffix("")
        built = site / (rel.parent if rel.name == "index" else rel) / "index.html"
        if built.is_file() and markdown_images(md):
            shown[rel.as_posix()] = (markdown_images(md), len(_parsed(built)))
    assert shown, "no page with figures found"
    assert not {k: v for k, v in shown.items() if v[1] < v[0]}, "pages showing fewer figures than they name"


def test_the_decode_check_finds_a_broken_figure(site, tmp_path):
    """A page whose figure is not a picture (a text file named .png) is found: the check can fail."""
    (tmp_path / "broken.png").write_text("not a picture")
    page = tmp_path / "index.html"
    page.write_text('<img src="broken.png">')
    assert undecodable_images(page) == ["broken.png (UnidentifiedImageError)"]


def test_the_image_check_finds_a_missing_figure(site, tmp_path):
    page = site / "index.html"
    assert missing_images(page, page.read_text() + '<img src="img/no-such-figure.png">') == ["img/no-such-figure.png"]


def _rendered(page: Path, site: Path) -> str:
    """The page's DOM as headless Chromium leaves it after its scripts ran, asserting it rendered with no
    script error."""
    run = subprocess.run(
        [_browser(), "--headless", "--no-sandbox", "--disable-gpu", "--enable-logging=stderr",
         "--virtual-time-budget=3000", "--dump-dom", page.as_uri()],
        capture_output=True,
        text=True,
        timeout=120,
    )  # fmt: skip
    name = page.relative_to(site).as_posix()
    assert run.returncode == 0 and "md-content" in run.stdout, f"{name}: {run.stderr[-1000:]}"
    assert "Uncaught" not in run.stderr, f"{name}: a script error: {run.stderr[-1000:]}"
    return run.stdout


@pytest.mark.skipif(_browser() is None, reason="no headless browser (chromium; .ci/run installs it)")
def test_the_index_in_a_browser(site):
    """The home page renders with the navigation and its text, its figure a file of the site."""
    dom = _rendered(site / "index.html", site)
    assert "Getting started" in dom and "Markerless" in dom  # the navigation
    assert "robot hand" in dom.lower()  # the index text
    assert not missing_images(site / "index.html", dom)


@pytest.mark.slow  # a browser per page: about 50 s for the 13 pages on 2 shared cores
@pytest.mark.skipif(_browser() is None, reason="no headless browser (chromium; .ci/run installs it)")
def test_the_pages_in_a_browser(site):
    """Each API page and each other page with a figure, as headless Chromium renders it: no raw role in the
    text, every ``<img>`` a file of the site, no script error."""
    chosen = [p for p in pages(site) if p != site / "index.html" and ("reference" in p.parts or _parsed(p))]
    assert chosen
    for page in chosen:
        dom = _rendered(page, site)
        name = page.relative_to(site).as_posix()
        assert not RAW_ROLE.search(dom), f"{name}: a raw role in the rendered page"
        assert not missing_images(page, dom), f"{name}: {missing_images(page, dom)}"


#: A markdown table mkdocs left as text: its delimiter row in a paragraph (a table with no blank line above it).
RAW_TABLE = re.compile(r"<p>[^<]*\|\s*-{3,}\s*\|")


def folded_tables(html: str) -> list[tuple[bool, int]]:
    """Each ``<details>`` block of a page: whether it opens folded, and how many table rows it holds."""
    blocks = re.findall(r"<details([^>]*)>(.*?)</details>", html, flags=re.S)
    return [("open" not in attrs, body.count("<tr>")) for attrs, body in blocks]


def test_folded_tables_render_as_tables(site):
    """The markerless benchmark's six per-band tables (``??? note``, ``pymdownx.details``) are folded, each a
    table of its 14 rows and header inside its block (the page's other folded blocks, provenance and diagnoses,
    hold no table), their headings' anchors kept; no page of the site holds a table left as text."""
    html = (site / "benchmarks" / "markerless" / "index.html").read_text()
    folded = folded_tables(html)
    assert all(closed for closed, _ in folded)
    assert [rows for _, rows in folded if rows] == [15] * 6
    for anchor in ("paper-real-at-099-m", "paper-real-at-068-m", "paper-real-at-178-m", "paper-sim-at-152-m"):
        assert f'id="{anchor}"' in html
    raw = [p.relative_to(site).as_posix() for p in pages(site) if RAW_TABLE.search(p.read_text())]
    assert not raw, f"markdown tables left as text: {raw}"


def test_the_table_checks_fail_on_broken_markdown():
    """A folded table not indented by four spaces renders after an empty block; a table with no blank line
    above it stays a paragraph of pipes: the checks above see both."""
    import markdown

    extensions = ["admonition", "pymdownx.details", "tables"]
    body = "| a | b |\n|---|---|\n| 1 | 2 |\n"
    indented = "".join("    " + ln + "\n" for ln in body.splitlines())
    good = markdown.markdown('??? note "t"\n\n' + indented, extensions=extensions)
    assert folded_tables(good) == [(True, 2)] and not RAW_TABLE.search(good)
    for indent in ("", "  "):
        flat = "".join(indent + ln + "\n" for ln in body.splitlines())
        assert folded_tables(markdown.markdown('??? note "t"\n\n' + flat, extensions=extensions)) == [(True, 0)]
    assert RAW_TABLE.search(markdown.markdown("Text:\n" + body, extensions=extensions))
