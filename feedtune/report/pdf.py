"""Write a report as a compact PDF with the same text, tables and figures as the HTML (matplotlib ``PdfPages``).

Layout: A4 portrait. A title page (title, creator, the pass/fail line of every design, the contents with page
numbers), then the sections flowing one after the other: headings, text, tables (small font, columns wrapped to
the page width, long tables continued on the next page with their header) and figures (scaled to the page width,
several per page). The figures are the PNG images the HTML embeds, drawn once (``Report.images``); the PDF embeds
them at their own resolution. The PDF is written to a given path; callers write it atomically (see
:func:`feedtune.report.build.write_report`).
"""

from __future__ import annotations

import datetime as _dt
import io
import os
import textwrap

from .content import Alert, FigureBlock, Paragraph, Report, Section, Table, Verdict

PAGE_IN = (8.27, 11.69)
"""A4 portrait [in]."""
MARGIN_IN = (0.5, 0.55, 0.5, 0.5)
"""Left, top, right, bottom margins [in]."""
BODY_PT, TABLE_PT, CAPTION_PT, H2_PT, H3_PT = 7.5, 6.3, 6.5, 12.0, 9.5
"""Font sizes [pt]."""
CHAR_EM = 0.56
"""Mean character width of DejaVu Sans [em], for wrapping."""
TABLE_CHAR_EM = 0.62
"""Character width allowed for in table columns [em] (digits and bold headers are wider than the mean)."""
MIN_FIGURE_SCALE = 0.7
"""A figure may be drawn down to this fraction of the page width to fit the rest of a page."""
LINE = 1.3
"""Line height [font sizes]."""
WARN_COLOR, MUTED = "#9a4d00", "0.35"


def _line_in(pt: float) -> float:
    return pt * LINE / 72.0


def _chars(width_in: float, pt: float) -> int:
    return max(4, int(width_in * 72.0 / (CHAR_EM * pt)))


def _wrap(text: str, width_in: float, pt: float, em: float = CHAR_EM) -> list[str]:
    out: list[str] = []
    chars = max(4, int(width_in * 72.0 / (em * pt)))
    for part in str(text).split("\n"):
        out += textwrap.wrap(part, chars, break_long_words=True, break_on_hyphens=False) or [""]
    return out


class _Flow:
    """Pages being filled from the top: the current page, the height used on it [in]."""

    def __init__(self) -> None:
        self.pages: list = []
        self.width = PAGE_IN[0] - MARGIN_IN[0] - MARGIN_IN[2]
        self.bottom = PAGE_IN[1] - MARGIN_IN[3]
        self.y = 0.0
        self.toc_y = MARGIN_IN[1]
        self.new_page()

    def new_page(self) -> None:
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure

        fig = Figure(figsize=PAGE_IN)
        FigureCanvasAgg(fig)
        self.pages.append(fig)
        self.y = MARGIN_IN[1]

    @property
    def page(self):
        return self.pages[-1]

    @property
    def free(self) -> float:
        return self.bottom - self.y

    def fresh(self) -> bool:
        return self.y <= MARGIN_IN[1] + 1e-9

    def need(self, height: float) -> None:
        """Start a new page unless ``height`` [in] fits on this one (or this one is still empty)."""
        if height > self.free and not self.fresh():
            self.new_page()

    def text(self, x_in: float, text: str, pt: float, **kw) -> None:
        self.page.text((MARGIN_IN[0] + x_in) / PAGE_IN[0], 1 - self.y / PAGE_IN[1], text, fontsize=pt, va="top",
                       ha="left", **kw)

    def rule(self, x0_in: float, x1_in: float, color="0.7", lw=0.5) -> None:
        from matplotlib.lines import Line2D

        y = 1 - self.y / PAGE_IN[1]
        self.page.add_artist(Line2D([(MARGIN_IN[0] + x0_in) / PAGE_IN[0], (MARGIN_IN[0] + x1_in) / PAGE_IN[0]],
                                    [y, y], transform=self.page.transFigure, color=color, lw=lw))

    def lines(self, lines: list[str], pt: float, x_in: float = 0.0, **kw) -> None:
        """Lines of text, continuing on new pages as needed."""
        step = _line_in(pt)
        for line in lines:
            self.need(step)
            self.text(x_in, line, pt, **kw)
            self.y += step


# ------------------------------------------------------------------------------------------ blocks
def _paragraph(flow: _Flow, text: str, color: str = "black", pt: float = BODY_PT) -> None:
    lines = _wrap(text, flow.width - 0.1, pt)
    flow.need(min(len(lines), 3) * _line_in(pt))
    flow.lines(lines, pt, color=color)
    flow.y += 0.06


def _column_widths(t: Table, width: float) -> list[float]:
    """Column widths [in]: each column's natural width (longest cell, header words), shrunk to the page width
    by narrowing the widest columns first."""
    char = TABLE_CHAR_EM * TABLE_PT / 72.0
    natural = []
    for j, name in enumerate(t.columns):
        cells = [len(row[j].text) for row in t.rows] or [1]
        head = max((len(w) for w in str(name).split()), default=1)
        natural.append(max(min(max(cells), 48), head, 3) * char + 0.1)
    total = sum(natural)
    if total <= width:
        return natural
    widths = sorted(natural)
    # the cap c with sum(min(w, c)) == width: columns wider than c are wrapped to c
    for k, w in enumerate(widths):
        rest = len(widths) - k
        cap = (width - sum(widths[:k])) / rest
        if cap <= w:
            break
    return [min(w, max(cap, 4 * char + 0.08)) for w in natural]


def _table(flow: _Flow, t: Table) -> None:
    widths = _column_widths(t, flow.width)
    xs = [sum(widths[:j]) for j in range(len(widths))]
    step = _line_in(TABLE_PT)

    def cells(texts):
        return [_wrap(x, w - 0.1, TABLE_PT, TABLE_CHAR_EM) for x, w in zip(texts, widths, strict=True)]

    head = cells([str(c) for c in t.columns])
    head_h = max(len(c) for c in head) * step + 0.04
    rows = [cells([c.text for c in row]) for row in t.rows]
    title = _wrap(t.title, flow.width, TABLE_PT + 1)
    first_row = (max(len(c) for c in rows[0]) * step + 0.03) if rows else 0.0
    flow.need(len(title) * _line_in(TABLE_PT + 1) + head_h + first_row + 0.1)

    def header(continued: bool):
        for line in (title if not continued else [title[0] + " (continued)"]):
            flow.text(0, line, TABLE_PT + 1, weight="bold")
            flow.y += _line_in(TABLE_PT + 1)
        flow.y += 0.02
        flow.rule(0, sum(widths), "0.4", 0.6)
        flow.y += 0.02
        for x, c in zip(xs, head, strict=True):
            for k, line in enumerate(c):
                flow.page.text((MARGIN_IN[0] + x + 0.04) / PAGE_IN[0], 1 - (flow.y + k * step) / PAGE_IN[1], line,
                               fontsize=TABLE_PT, weight="bold", va="top")
        flow.y += head_h
        flow.rule(0, sum(widths), "0.4", 0.6)
        flow.y += 0.02

    header(False)
    numeric = [all(row[j].is_number or row[j].text == "-" for row in t.rows) for j in range(len(t.columns))]
    for r, row_cells in enumerate(rows):
        h = max(len(c) for c in row_cells) * step + 0.03
        if h > flow.free:
            flow.new_page()
            header(True)
        for j, (x, c) in enumerate(zip(xs, row_cells, strict=True)):
            right = numeric[j]
            for k, line in enumerate(c):
                xx = x + widths[j] - 0.04 if right else x + 0.04
                flow.page.text((MARGIN_IN[0] + xx) / PAGE_IN[0], 1 - (flow.y + k * step) / PAGE_IN[1], line,
                               fontsize=TABLE_PT, va="top", ha="right" if right else "left")
        flow.y += h
        if r < len(rows) - 1:
            flow.rule(0, sum(widths), "0.85", 0.4)
            flow.y += 0.01
    flow.rule(0, sum(widths), "0.4", 0.6)
    flow.y += 0.05
    if t.note:
        _paragraph(flow, t.note, MUTED, CAPTION_PT)
    flow.y += 0.06


def _image(png: bytes):
    import matplotlib.image as mpimg

    return mpimg.imread(io.BytesIO(png), format="png")


def _figure(flow: _Flow, b: FigureBlock, png: bytes) -> None:
    img = _image(png)
    h_px, w_px = img.shape[:2]
    caption = _wrap(b.caption, flow.width, CAPTION_PT)
    cap_h = len(caption) * _line_in(CAPTION_PT) + 0.08
    width = flow.width
    height = width * h_px / w_px
    page_room = flow.bottom - MARGIN_IN[1] - cap_h
    if height > page_room:  # taller than a page: scale down to fit
        width, height = width * page_room / height, page_room
    if height + cap_h > flow.free and flow.free - cap_h >= MIN_FIGURE_SCALE * height:  # shrink into this page
        width, height = width * (flow.free - cap_h) / height, flow.free - cap_h
    flow.need(height + cap_h)
    if height + cap_h > flow.free:  # a fresh page and still too tall (should not happen): shrink into it
        height = max(flow.free - cap_h, 1.0)
        width = height * w_px / h_px
    x = MARGIN_IN[0] + (flow.width - width) / 2
    ax = flow.page.add_axes((x / PAGE_IN[0], 1 - (flow.y + height) / PAGE_IN[1], width / PAGE_IN[0],
                             height / PAGE_IN[1]))
    ax.imshow(img, interpolation="none", aspect="auto")
    ax.set_axis_off()
    flow.y += height + 0.04
    flow.lines(caption, CAPTION_PT, color=MUTED)
    flow.y += 0.1


def _heading(flow: _Flow, text: str, level: int, toc: list, page_of) -> None:
    pt = H2_PT if level == 2 else H3_PT
    flow.need(_line_in(pt) + 1.2)  # keep a heading with the start of its content
    if level == 2 and not flow.fresh():
        flow.y += 0.12
    toc.append((level, text, page_of()))
    flow.text(0, text, pt, weight="bold")
    flow.y += _line_in(pt) + 0.02
    if level == 2:
        flow.rule(0, flow.width, "0.3", 0.7)
        flow.y += 0.06


def _section(flow: _Flow, s: Section, level: int, images: dict, toc: list, page_of) -> None:
    _heading(flow, s.title, level, toc, page_of)
    for b in s.blocks:
        if isinstance(b, Table):
            _table(flow, b)
        elif isinstance(b, FigureBlock):
            _figure(flow, b, images[b.name])
        elif isinstance(b, Alert):
            _paragraph(flow, b.text, WARN_COLOR)
        elif isinstance(b, Verdict):
            _paragraph(flow, b.text, "black" if b.ok else WARN_COLOR)
        elif isinstance(b, Paragraph):
            _paragraph(flow, b.text)
    for sub in s.subsections:
        if not sub.is_empty():
            _section(flow, sub, min(level + 1, 4), images, toc, page_of)


def _title_page(flow: _Flow, report: Report, created: str) -> None:
    from .. import __version__

    flow.y = 1.6
    for line in _wrap(report.title, flow.width, 20):
        flow.text(0, line, 20, weight="bold")
        flow.y += _line_in(20)
    flow.y += 0.1
    n_files = sum(len(v) for k, v in report.data.get("inputs", {}).items() if k != "skipped")
    flow.text(0, f"feedtune {__version__} report, {created}, built from {n_files} input files. SI units; tracking "
                 "and displacement errors in µm.", BODY_PT + 1, color=MUTED)
    flow.y += 0.4
    verdicts = [b for s in report.sections if s.key == "summary" for b in s.blocks if isinstance(b, Verdict)]
    if verdicts:
        flow.text(0, "Verdict per design", H3_PT, weight="bold")
        flow.y += _line_in(H3_PT) + 0.04
        for b in verdicts:
            _paragraph(flow, b.text, "black" if b.ok else WARN_COLOR)
        flow.y += 0.2
    if report.warnings:
        flow.text(0, f"{len(report.warnings)} warnings: see the Summary.", BODY_PT + 0.5, color=WARN_COLOR)
        flow.y += 0.3
    flow.text(0, "Contents", H3_PT, weight="bold")
    flow.y += _line_in(H3_PT) + 0.04
    flow.toc_y = flow.y


def _draw_toc(page, top_in: float, toc: list) -> None:
    y = top_in
    for level, text, page_no in toc:
        if level > 3:
            continue
        pt = BODY_PT + (1 if level == 2 else 0)
        x = MARGIN_IN[0] + (0.0 if level == 2 else 0.25)
        page.text(x / PAGE_IN[0], 1 - y / PAGE_IN[1], text, fontsize=pt, va="top",
                  weight="bold" if level == 2 else "normal")
        page.text((PAGE_IN[0] - MARGIN_IN[2]) / PAGE_IN[0], 1 - y / PAGE_IN[1], str(page_no), fontsize=pt, va="top",
                  ha="right")
        y += _line_in(pt) + 0.02
        if y > PAGE_IN[1] - MARGIN_IN[3]:
            break


def layout_pages(report: Report, *, created: str | None = None) -> list:
    """The PDF pages of a report as matplotlib Figures (title page first)."""
    from .html import render_pngs

    images = report.images or render_pngs(report)
    flow = _Flow()
    when = created or _dt.datetime.now().strftime("%Y-%m-%d %H:%M")
    _title_page(flow, report, when)
    flow.new_page()
    toc: list = []
    for s in report.sections:
        if not s.is_empty():
            _section(flow, s, 2, images, toc, lambda: len(flow.pages))
    _draw_toc(flow.pages[0], flow.toc_y, toc)
    n = len(flow.pages)
    for k, page in enumerate(flow.pages, start=1):
        page.text(MARGIN_IN[0] / PAGE_IN[0], 0.25 / PAGE_IN[1], report.title, fontsize=6.5, color=MUTED)
        page.text(1 - MARGIN_IN[2] / PAGE_IN[0], 0.25 / PAGE_IN[1], f"page {k} of {n}", fontsize=6.5, color=MUTED,
                  ha="right")
    return flow.pages


def write_pdf(report: Report, path: str | os.PathLike[str]) -> None:
    """Write the report's sections (text, tables, figures) to ``path`` as a compact A4 PDF."""
    from matplotlib.backends.backend_pdf import PdfPages

    pages = layout_pages(report)
    with PdfPages(path, metadata={"Title": report.title, "Creator": "feedtune"}) as pdf:
        for page in pages:
            pdf.savefig(page)
