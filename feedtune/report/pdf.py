"""Write a report as a PDF with the same figures and tables as the HTML (matplotlib ``PdfPages``).

Pages are A4 landscape for text and tables (long tables continue on further pages); figures keep their
own size. The PDF is written to a given path; callers write it atomically (see
:func:`feedtune.report.build.write_report`).
"""

from __future__ import annotations

import os
import textwrap

from .content import Alert, FigureBlock, Paragraph, Report, Section, Table
from .figures import finish_figure

PAGE_IN = (11.69, 8.27)
"""A4 landscape [in]."""
ROWS_PER_PAGE = 28
"""Table rows per page."""
WRAP_CHARS = 150
"""Characters per line of text pages."""


def _page():
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=PAGE_IN)
    FigureCanvasAgg(fig)
    return fig


def _text_page(title: str, lines: list[tuple[str, str]]):
    """A page with a title and ``(text, colour)`` lines, wrapped."""
    fig = _page()
    fig.text(0.04, 0.95, title, fontsize=15, weight="bold", va="top")
    y = 0.89
    for text, color in lines:
        for line in textwrap.wrap(text, WRAP_CHARS) or [""]:
            if y < 0.05:
                break
            fig.text(0.04, y, line, fontsize=9, color=color, va="top")
            y -= 0.027
        y -= 0.01
    return fig


def _table_pages(t: Table):
    """One or more pages showing the table (header repeated)."""
    pages = []
    for start in range(0, max(len(t.rows), 1), ROWS_PER_PAGE):
        rows = t.rows[start:start + ROWS_PER_PAGE]
        fig = _page()
        suffix = " (continued)" if start else ""
        fig.text(0.04, 0.95, t.title + suffix, fontsize=12, weight="bold", va="top")
        ax = fig.add_axes((0.03, 0.08, 0.94, 0.82))
        ax.axis("off")
        cells = [[c.text for c in row] for row in rows] or [["-"] * len(t.columns)]
        wrapped_cols = ["\n".join(textwrap.wrap(c, 18)) for c in t.columns]
        tab = ax.table(cellText=cells, colLabels=wrapped_cols, loc="upper center", cellLoc="left")
        tab.auto_set_font_size(False)
        tab.set_fontsize(7.5 if len(t.columns) < 8 else 6.5)
        tab.auto_set_column_width(list(range(len(t.columns))))
        tab.scale(1.0, 1.35)
        for (r, _), cell in tab.get_celld().items():
            if r == 0:
                cell.set_facecolor("#f3f5f7")
                cell.set_height(cell.get_height() * 2.2)
        if t.note:
            fig.text(0.04, 0.04, t.note, fontsize=8, color="0.35")
        pages.append(fig)
    return pages


def _section_pages(s: Section, prefix: str):
    title = f"{prefix}{s.title}"
    lines = [(b.text, "#9a4d00" if isinstance(b, Alert) else "black") for b in s.blocks
             if isinstance(b, (Paragraph, Alert))]
    pages = [_text_page(title, lines)] if lines else []
    for b in s.blocks:
        if isinstance(b, Table):
            pages += _table_pages(b)
        elif isinstance(b, FigureBlock):
            finish_figure(b.figure)
            pages.append(b.figure)
    for sub in s.subsections:
        if not sub.is_empty():
            pages += _section_pages(sub, f"{s.title}: ")
    return pages


def write_pdf(report: Report, path: str | os.PathLike[str]) -> None:
    """Write the report's sections (text, tables, figures) to ``path`` as PDF."""
    from matplotlib.backends.backend_pdf import PdfPages

    with PdfPages(path, metadata={"Title": report.title, "Creator": "feedtune"}) as pdf:
        for s in report.sections:
            if s.is_empty():
                continue
            for page in _section_pages(s, ""):
                pdf.savefig(page)
