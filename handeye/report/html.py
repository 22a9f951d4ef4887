"""HTML building blocks of the report: one self-contained page, inline CSS, images as data URIs, no script."""

from __future__ import annotations

import base64
from html import escape
from pathlib import Path

from handeye.report.style import COLORS

__all__ = ["CSS", "table", "key_values", "figure", "cards", "section", "page", "data_uri"]

CSS = (
    """
:root { --ink: %(ink)s; --muted: %(muted)s; --grid: %(grid)s; --inlier: %(inlier)s; --outlier: %(outlier)s;
        --accent: %(accent)s; --ok: %(ok)s; }
* { box-sizing: border-box; }
body { margin: 0; background: #f3f5f7; color: var(--ink); line-height: 1.5;
       font: 15px/1.5 system-ui, -apple-system, "Segoe UI", Roboto, "Helvetica Neue", Arial, sans-serif; }
header { background: var(--ink); color: #fff; padding: 28px 0 22px; }
header h1 { margin: 0 0 4px; font-size: 26px; font-weight: 650; letter-spacing: .2px; }
header .sub { color: #c9d2db; font-size: 14px; }
header code { background: rgba(255,255,255,.1); color: #fff; }
.wrap { max-width: 1180px; margin: 0 auto; padding: 0 24px; }
nav { background: #fff; border-bottom: 1px solid var(--grid); position: sticky; top: 0; z-index: 1; }
nav a { display: inline-block; padding: 10px 12px; color: var(--ink); text-decoration: none; font-size: 14px; }
nav a:hover { color: var(--inlier); }
section { background: #fff; border-radius: 10px; margin: 22px 0; padding: 20px 26px 22px;
          box-shadow: 0 1px 2px rgba(16,24,40,.06), 0 1px 3px rgba(16,24,40,.08); }
h2 { margin: 0 0 12px; font-size: 19px; border-left: 4px solid var(--inlier); padding-left: 10px; }
p { margin: 6px 0 12px; }
code, .mono { font-family: ui-monospace, SFMono-Regular, Menlo, Consolas, "DejaVu Sans Mono", monospace;
              font-size: 13px; }
code { background: #eef1f4; padding: 1px 5px; border-radius: 4px; word-break: break-word; }
table { border-collapse: collapse; width: 100%%; margin: 8px 0 14px; font-size: 14px; }
th, td { padding: 6px 10px; text-align: left; border-bottom: 1px solid var(--grid); vertical-align: top; }
table.kv th { width: 210px; }
th { background: #f7f9fa; font-weight: 600; color: #3e4c59; }
.scroll { overflow-x: auto; }
td.num { font-variant-numeric: tabular-nums; white-space: nowrap;
         font-family: ui-monospace, SFMono-Regular, Menlo, Consolas, "DejaVu Sans Mono", monospace; font-size: 13px; }
tbody tr:nth-child(even) td { background: #fbfcfd; }
figure { margin: 14px 0 6px; }
figure img { display: block; max-width: 100%%; height: auto; margin: 0 auto; border-radius: 6px; }
figcaption { color: var(--muted); font-size: 13.5px; margin-top: 8px; }
figcaption .cmd { display: block; margin-top: 4px; }
.cards { display: flex; flex-wrap: wrap; gap: 12px; margin: 4px 0 10px; }
.card { flex: 1 1 160px; border: 1px solid var(--grid); border-radius: 8px; padding: 10px 14px;
        border-top: 4px solid var(--inlier); }
.card.ok { border-top-color: var(--ok); } .card.warn { border-top-color: var(--accent); }
.card.bad { border-top-color: var(--outlier); }
.card .label { color: var(--muted); font-size: 12.5px; text-transform: uppercase; letter-spacing: .4px; }
.card .value { font-size: 20px; font-weight: 650; font-variant-numeric: tabular-nums; }
.card .note { color: var(--muted); font-size: 12.5px; }
.badge { display: inline-block; padding: 1px 8px; border-radius: 10px; font-size: 12.5px; font-weight: 600;
         color: #fff; background: var(--ok); }
.badge.warn { background: var(--accent); color: var(--ink); } .badge.bad { background: var(--outlier); }
ul.warnings li { color: #8a5a00; }
.note code { white-space: nowrap; }
footer { color: var(--muted); font-size: 13px; padding: 8px 0 34px; }
"""
    % COLORS
)


def data_uri(png: str | Path) -> str:
    """The PNG as a ``data:image/png;base64`` URI."""
    return "data:image/png;base64," + base64.b64encode(Path(png).read_bytes()).decode("ascii")


def table(headers: list[str], rows: list[list[str]], numeric: tuple[int, ...] = ()) -> str:
    """An HTML table; the text is escaped, columns in ``numeric`` set in tabular figures."""
    head = "".join(f"<th>{escape(h)}</th>" for h in headers)
    body = "".join(
        "<tr>"
        + "".join(
            f'<td class="num">{escape(str(c))}</td>' if k in numeric else f"<td>{escape(str(c))}</td>"
            for k, c in enumerate(row)
        )
        + "</tr>"
        for row in rows
    )
    return f'<div class="scroll"><table><thead><tr>{head}</tr></thead><tbody>{body}</tbody></table></div>'


def key_values(rows: list[tuple[str, str]]) -> str:
    """A two-column table of named values, names as row headers."""
    body = "".join(f'<tr><th scope="row">{escape(k)}</th><td>{escape(str(v))}</td></tr>' for k, v in rows)
    return f'<table class="kv"><tbody>{body}</tbody></table>'


def figure(png: str | Path, caption: str, command: str, alt: str) -> str:
    """A figure with the PNG embedded, its caption and the command that made it.

    Parameters
    ----------
    png : str or Path
        The PNG (also written beside the page; its file name is kept in ``data-file``).
    caption : str
        What the figure shows (plain text, escaped).
    command : str
        The command that made it.
    alt : str
    """
    return (
        f'<figure><img src="{data_uri(png)}" alt="{escape(alt)}" data-file="{escape(Path(png).name)}">'
        f'<figcaption>{escape(caption)}<span class="cmd">made by <code>{escape(command)}</code> '
        f"({escape(Path(png).name)})</span></figcaption></figure>"
    )


def cards(items: list[tuple[str, str, str, str]]) -> str:
    """Headline numbers: ``(label, value, note, level)`` with level ``ok``, ``warn``, ``bad`` or ``""``."""
    out = "".join(
        f'<div class="card {escape(level)}"><div class="label">{escape(label)}</div>'
        f'<div class="value">{escape(value)}</div><div class="note">{escape(note)}</div></div>'
        for label, value, note, level in items
    )
    return f'<div class="cards">{out}</div>'


def section(anchor: str, title: str, body: str) -> str:
    """A titled section with an anchor id (``body`` is HTML)."""
    return f'<section id="{escape(anchor)}"><h2>{escape(title)}</h2>{body}</section>'


def page(title: str, subtitle_html: str, sections: list[tuple[str, str, str]], footer_html: str) -> str:
    """The whole page: header, a navigation bar of the sections, the sections, a footer.

    Parameters
    ----------
    title : str
    subtitle_html : str
        HTML under the title.
    sections : list of (anchor, title, body HTML)
    footer_html : str
    """
    nav = "".join(f'<a href="#{escape(a)}">{escape(t)}</a>' for a, t, _ in sections)
    body = "".join(section(a, t, b) for a, t, b in sections)
    return (
        '<!DOCTYPE html>\n<html lang="en"><head><meta charset="utf-8">'
        '<meta name="viewport" content="width=device-width, initial-scale=1">'
        f'<title>{escape(title)}</title><link rel="icon" href="data:,"><style>{CSS}</style></head><body>'
        f'<header><div class="wrap"><h1>{escape(title)}</h1><div class="sub">{subtitle_html}</div></div>'
        "</header>"
        f'<nav><div class="wrap">{nav}</div></nav><main class="wrap">{body}</main>'
        f'<footer class="wrap">{footer_html}</footer></body></html>\n'
    )
