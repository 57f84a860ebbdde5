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
import re
from contextlib import contextmanager
from functools import partial

from .content import Alert, Cell, FigureBlock, Paragraph, Report, Section, Table, Verdict
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
div.table-wrap { max-width: 100%; overflow-x: auto; margin: 10px 0 4px; }
table { border-collapse: collapse; font-size: 0.8em; line-height: 1.35; width: auto; max-width: 100%; }
caption { text-align: left; font-weight: 600; padding: 4px 0; font-size: 1.08em; }
th, td { border: 1px solid var(--line); padding: 2px 6px; vertical-align: top; overflow-wrap: normal;
         word-break: normal; hyphens: manual; }
span.w { white-space: nowrap; }
th { background: var(--head); text-align: left; font-weight: 600; }
td.num { text-align: right; font-variant-numeric: tabular-nums; white-space: nowrap; overflow-wrap: normal; }
p.verdict { font-weight: 600; border-left: 4px solid #1a7f37; padding-left: 8px; }
p.verdict.fail { border-left-color: var(--warn); color: #4a2a00; background: var(--warn-bg); }
p.note { color: var(--muted); font-size: 0.85em; margin: 2px 0 12px; }
div.warning { background: var(--warn-bg); border-left: 4px solid var(--warn); color: #4a2a00; padding: 6px 10px;
              margin: 6px 0; font-size: 0.92em; }
figure { margin: 16px 0 20px; break-inside: avoid; }
figure img { max-width: 100%; height: auto; border: 1px solid var(--line); }
figcaption { color: var(--muted); font-size: 0.88em; margin-top: 4px; }
@media print { body { max-width: none; } h2 { break-after: avoid; } div.table-wrap { overflow: visible; } }
"""


def _esc(text: str) -> str:
    return html.escape(str(text), quote=True)


_HYPHENATED = re.compile(r"(?<![\w.])[A-Za-z0-9.]+(?:-[A-Za-z0-9.]+)+(?![\w])")


def _breakable(text: str) -> str:
    """Escaped text that may break after ``_`` (and after ``/`` in a path without spaces): long file names wrap
    inside narrow columns. A hyphenated word or range (``pre-filter``, ``MC-PPC``, ``4.17-4.18``) is kept on one
    line, as the PDF keeps it."""
    out = _esc(text).replace("_", "_<wbr>")
    out = out.replace("/", "/<wbr>") if " " not in text else out
    return _HYPHENATED.sub(lambda m: f'<span class="w">{m.group(0)}</span>', out)


def _cell(cell: Cell) -> str:
    if not cell.is_number:
        return f"<td>{_breakable(cell.text)}</td>"
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
    head = "".join(f"<th>{_breakable(c)}</th>" for c in t.columns)
    body = "\n".join("<tr>" + "".join(_cell(c) for c in row) + "</tr>" for row in t.rows)
    note = f'<p class="note">{_esc(t.note)}</p>' if t.note else ""
    return (f'<div class="table-wrap"><table><caption>{_esc(t.title)}</caption><thead><tr>{head}</tr></thead>\n'
            f"<tbody>\n{body}\n</tbody></table></div>{note}")


def png_size(png: bytes) -> tuple[int, int]:
    """``(width, height)`` [px] of a PNG image from its header."""
    return int.from_bytes(png[16:20], "big"), int.from_bytes(png[20:24], "big")


def _figure(f: FigureBlock, png: bytes) -> str:
    w, h = png_size(png)
    data = base64.b64encode(png).decode("ascii")
    return (f'<figure id="fig-{_esc(_slug(f.name))}"><img alt="{_esc(f.caption)}" width="{w}" height="{h}" '
            f'src="data:image/png;base64,{data}"><figcaption>{_esc(f.caption)}</figcaption></figure>')


def _slug(text: str) -> str:
    return "".join(ch if ch.isalnum() or ch in "-_" else "-" for ch in text)


def _block(b, pngs: dict) -> str:
    if isinstance(b, Table):
        return _table(b)
    if isinstance(b, FigureBlock):
        return _figure(b, pngs[b.name])
    if isinstance(b, Alert):
        return f'<div class="warning">{_esc(b.text)}</div>'
    if isinstance(b, Verdict):
        return f'<p class="verdict {"pass" if b.ok else "fail"}">{_esc(b.text)}</p>'
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


def _made_by(data: dict) -> str:
    """The command that made the report and its project file, one line (nothing for a report built by the
    library): the inputs' digests are in the report data's ``created_by``."""
    made = data.get("created_by")
    if not isinstance(made, dict) or not made.get("command"):
        return ""
    project = f" (project {_esc(made['project'])})" if made.get("project") else ""
    return (f'<p class="meta">Made by <code>{_esc(made["command"])}</code>{project}; the SHA-256 of every input '
            "file is in the report data (created_by).</p>")


def data_script(data: dict) -> str:
    """The ``<script type="application/json">`` element holding the report data (``<`` escaped)."""
    text = json.dumps(data, allow_nan=False, ensure_ascii=False, separators=(",", ":")).replace("<", "\\u003c")
    return f'<script type="application/json" id="{DATA_ELEMENT_ID}">{text}</script>'


PROCESSES_ENV = "FEEDTUNE_REPORT_PROCESSES"
"""Environment variable: the number of processes that draw the figures (1: this process only)."""
MIN_FIGURES_PER_PROCESS = 3
"""Fewer figures than this per extra process are drawn in this process (forking costs more than it saves)."""


def render_processes(n_figures: int) -> int:
    """How many processes draw ``n_figures`` figures: ``$FEEDTUNE_REPORT_PROCESSES`` when set, 1 when
    ``$FEEDTUNE_JOBS`` is not set or 1 (library callers: :mod:`feedtune.parallel`), else this one plus
    one per core the machine leaves idle (the cores this process may use minus the 1-minute load average, which
    counts this process; a core at least half idle counts), at most 4 in all and one per
    :data:`MIN_FIGURES_PER_PROCESS` figures; 1 where ``os.fork`` does not exist."""
    import os

    if not hasattr(os, "fork"):
        return 1
    env = os.environ.get(PROCESSES_ENV, "").strip()
    if env:
        try:
            return max(1, int(env))
        except ValueError:
            return 1
    if not os.environ.get("FEEDTUNE_JOBS", "").strip() or os.environ["FEEDTUNE_JOBS"].strip() == "1":
        return 1  # processes only where asked for (feedtune.parallel: the command line asks)
    try:
        cpus = len(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        cpus = os.cpu_count() or 1
    try:
        idle = cpus - os.getloadavg()[0]
    except (AttributeError, OSError):
        idle = cpus - 1.0
    extra = min(cpus - 1, int(idle + 0.5))
    return max(1, min(1 + extra, 4, n_figures // MIN_FIGURES_PER_PROCESS))


def _warm_up() -> None:
    """Draw a tiny figure with text (imports matplotlib, loads the fonts and the Agg backend: about 0.3 s the first
    time, a few ms after)."""
    from .figures import new_figure

    fig, axes = new_figure(1, height=0.8, width=2.0)
    axes[0, 0].set_xlabel("t [s]")
    figure_png(fig)


@contextmanager
def _gc_paused():
    """Python's cycle collector paused inside the block (restored after).

    Drawing a figure allocates tens of thousands of container objects (artists, transforms, paths); the collector
    runs every few hundred of them and its full passes walk every object of the process (the report's data
    included): a sixth of the drawing time. Paused, the figures' garbage is collected once, later."""
    import gc

    was = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if was:
            gc.enable()


def _draw(figure: FigureBlock) -> bytes:
    return figure_png(figure.figure)


def render_pngs(report: Report, processes: int | None = None) -> dict[str, bytes]:
    """Every figure of the report drawn once, as PNG bytes by figure name (the HTML and the PDF use them).

    The figures are built and drawn here (a :class:`FigureBlock` may hold a callable that draws its figure), on
    ``processes`` processes (default :func:`render_processes`): this one and forked children, each taking the next
    figure not yet taken as soon as it is free (:func:`feedtune.parallel.run_queue`), so that the work is evenly
    spread whatever each figure costs; the children send the PNG bytes back. The images do not depend on the
    process that drew them. Figure names are unique within a report (they are also the HTML ids ``fig-NAME``)."""
    from .. import progress
    from ..parallel import WorkerLostError, run_queue

    figures = report.figures()
    if len({f.name for f in figures}) != len(figures):
        raise ValueError("internal error: two report figures share a name")
    n = render_processes(len(figures)) if processes is None else max(1, int(processes))
    n = min(n, len(figures))
    label = "figures" if n <= 1 else f"figures ({n} processes)"
    with progress.task(label, total=len(figures)) as advance, _gc_paused():
        if n > 1:
            _warm_up()  # fonts and the Agg backend loaded once, before the children are forked (quick if done)
        jobs = [(f.name, partial(_draw, f)) for f in figures]
        drawn_here: list[str] = []
        try:
            pngs = run_queue(jobs, processes=n, after_each=lambda name: (drawn_here.append(name), advance()))
        except WorkerLostError:  # a child was killed (rare): every figure drawn here
            pngs = run_queue(jobs, processes=1)
        if len(figures) > len(drawn_here):
            advance(len(figures) - len(drawn_here))  # the children's
    return {f.name: pngs[f.name] for f in figures}


def render_html(report: Report, *, created: str | None = None, pngs: dict[str, bytes] | None = None) -> str:
    """The HTML text of a report.

    Parameters
    ----------
    report : Report
        Sections, title and data (``report.html`` is not used).
    created : str, optional
        Creation time shown in the header (default: now, local time, to the minute).
    pngs : dict, optional
        The figures as PNG by name (:func:`render_pngs`; drawn here when not given).
    """
    from .. import __version__

    pngs = pngs if pngs is not None else render_pngs(report)
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
        "SI units; tracking and displacement errors in µm.</p>" + _made_by(report.data) + "</header>",
        _toc(report.sections),
        body,
        data_script(report.data),
        "</body></html>",
        "",
    ])
