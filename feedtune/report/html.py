"""Render a report as one self-contained HTML document.

Inline CSS, figures as base64 PNG ``data:`` images, no scripts other than the machine-readable data block
``<script type="application/json" id="feedtune-report-data">`` (not executed by browsers), no external
fonts, style sheets, images or links: the file opens without network access. Every numeric table cell
carries ``data-key`` (the JSON path of its SI value in the data block) and ``data-value`` (that value).
"""

from __future__ import annotations

import base64
import datetime as _dt
import html
import json

from .content import Alert, Cell, FigureBlock, Paragraph, Report, Section, Table
from .figures import figure_png

DATA_ELEMENT_ID = "feedtune-report-data"

CSS = """
:root { --fg: #1b1f24; --muted: #57606a; --line: #d0d7de; --warn-bg: #fff4e5; --warn: #9a4d00; --head: #f3f5f7; }
* { box-sizing: border-box; }
body { margin: 0 auto; max-width: 1040px; padding: 0 24px 48px; color: var(--fg);
       font: 15px/1.5 system-ui, -apple-system, "Segoe UI", Roboto, "Helvetica Neue", Arial, sans-serif; }
header { border-bottom: 2px solid var(--fg); margin: 24px 0 8px; }
h1 { font-size: 1.7em; margin: 0 0 4px; }
h2 { font-size: 1.35em; margin: 36px 0 8px; border-bottom: 1px solid var(--line); padding-bottom: 4px; }
h3 { font-size: 1.12em; margin: 24px 0 6px; }
.meta { color: var(--muted); font-size: 0.9em; margin: 0 0 12px; }
nav ol { columns: 2; font-size: 0.92em; margin: 8px 0 0; }
nav a, a { color: #0b5cad; text-decoration: none; }
table { border-collapse: collapse; margin: 10px 0 4px; font-size: 0.86em; width: auto; max-width: 100%;
        display: block; overflow-x: auto; }
caption { text-align: left; font-weight: 600; padding: 4px 0; }
th, td { border: 1px solid var(--line); padding: 3px 8px; vertical-align: top; }
th { background: var(--head); text-align: left; font-weight: 600; }
td.num { text-align: right; font-variant-numeric: tabular-nums; white-space: nowrap; }
p.note { color: var(--muted); font-size: 0.85em; margin: 2px 0 12px; }
div.warning { background: var(--warn-bg); border-left: 4px solid var(--warn); color: #4a2a00; padding: 6px 10px;
              margin: 6px 0; font-size: 0.92em; }
figure { margin: 16px 0 20px; break-inside: avoid; }
figure img { max-width: 100%; height: auto; border: 1px solid var(--line); }
figcaption { color: var(--muted); font-size: 0.88em; margin-top: 4px; }
@media print { body { max-width: none; } h2 { break-after: avoid; } table { display: table; } }
"""


def _esc(text: str) -> str:
    return html.escape(str(text), quote=True)


def _cell(cell: Cell) -> str:
    if not cell.is_number:
        return f"<td>{_esc(cell.text)}</td>"
    attrs = ' class="num"'
    if cell.key is not None:
        attrs += f" data-key='{_esc(json.dumps(cell.key))}'"
    attrs += f" data-value='{_esc(json.dumps(_plain_value(cell.value)))}'"
    return f"<td{attrs}>{_esc(cell.text)}</td>"


def _plain_value(v):
    import math

    if isinstance(v, (list, tuple)):
        return [_plain_value(x) for x in v]
    if isinstance(v, float) and not math.isfinite(v):
        return None
    return v


def _table(t: Table) -> str:
    head = "".join(f"<th>{_esc(c)}</th>" for c in t.columns)
    body = "\n".join("<tr>" + "".join(_cell(c) for c in row) + "</tr>" for row in t.rows)
    note = f'<p class="note">{_esc(t.note)}</p>' if t.note else ""
    return (f"<table><caption>{_esc(t.title)}</caption><thead><tr>{head}</tr></thead>\n<tbody>\n{body}\n"
            f"</tbody></table>{note}")


def _figure(f: FigureBlock, png: bytes) -> str:
    w, h = (round(x * f.figure.dpi) for x in f.figure.get_size_inches())
    data = base64.b64encode(png).decode("ascii")
    return (f'<figure id="fig-{_esc(_slug(f.name))}"><img alt="{_esc(f.caption)}" width="{w}" height="{h}" '
            f'src="data:image/png;base64,{data}"><figcaption>{_esc(f.caption)}</figcaption></figure>')


def _slug(text: str) -> str:
    return "".join(ch if ch.isalnum() or ch in "-_" else "-" for ch in text)


def _block(b, pngs: dict) -> str:
    if isinstance(b, Table):
        return _table(b)
    if isinstance(b, FigureBlock):
        return _figure(b, pngs[id(b)])
    if isinstance(b, Alert):
        return f'<div class="warning">{_esc(b.text)}</div>'
    if isinstance(b, Paragraph):
        return f"<p>{_esc(b.text)}</p>"
    raise TypeError(f"unknown report block {type(b).__name__}")


def _section(s: Section, level: int, pngs: dict) -> str:
    parts = [f'<section id="{_esc(_slug(s.key))}"><h{level}>{_esc(s.title)}</h{level}>']
    parts += [_block(b, pngs) for b in s.blocks]
    parts += [_section(sub, min(level + 1, 4), pngs) for sub in s.subsections if not sub.is_empty()]
    parts.append("</section>")
    return "\n".join(parts)


def _toc(sections: list[Section]) -> str:
    items = []
    for s in sections:
        subs = "".join(f'<li><a href="#{_esc(_slug(x.key))}">{_esc(x.title)}</a></li>' for x in s.subsections
                       if not x.is_empty())
        inner = f"<ol>{subs}</ol>" if subs else ""
        items.append(f'<li><a href="#{_esc(_slug(s.key))}">{_esc(s.title)}</a>{inner}</li>')
    return f"<nav><ol>{''.join(items)}</ol></nav>"


def data_script(data: dict) -> str:
    """The ``<script type="application/json">`` element holding the report data (``<`` escaped)."""
    text = json.dumps(data, allow_nan=False, ensure_ascii=False, separators=(",", ":")).replace("<", "\\u003c")
    return f'<script type="application/json" id="{DATA_ELEMENT_ID}">{text}</script>'


def render_html(report: Report, *, created: str | None = None) -> str:
    """The HTML text of a report (figures rendered to PNG here).

    Parameters
    ----------
    report : Report
        Sections, title and data (``report.html`` is not used).
    created : str, optional
        Creation time shown in the header (default: now, local time, to the minute).
    """
    from .. import __version__

    pngs = {id(f): figure_png(f.figure) for f in report.figures()}
    when = created or _dt.datetime.now().strftime("%Y-%m-%d %H:%M")
    n_files = sum(len(v) for k, v in report.data.get("inputs", {}).items() if k != "skipped")
    body = "\n".join(_section(s, 2, pngs) for s in report.sections if not s.is_empty())
    return "\n".join([
        "<!DOCTYPE html>",
        '<html lang="en"><head><meta charset="utf-8">',
        '<meta name="viewport" content="width=device-width, initial-scale=1">',
        f'<meta name="generator" content="feedtune {_esc(__version__)}">',
        f"<title>{_esc(report.title)}</title>",
        f"<style>{CSS}</style></head><body>",
        f"<header><h1>{_esc(report.title)}</h1>",
        f'<p class="meta">feedtune {_esc(__version__)} report, {_esc(when)}, built from {n_files} input files. '
        "SI units; tracking and displacement errors in µm.</p></header>",
        _toc(report.sections),
        body,
        data_script(report.data),
        "</body></html>",
        "",
    ])
