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
from dataclasses import dataclass

from .content import Alert, FigureBlock, Paragraph, Report, Section, Table, Verdict
from .textfit import min_width, text_width, wrap

PAGE_IN = (8.27, 11.69)
"""A4 portrait [in]."""
MARGIN_IN = (0.5, 0.55, 0.5, 0.5)
"""Left, top, right, bottom margins [in]."""
BODY_PT, TABLE_PT, CAPTION_PT, H2_PT, H3_PT = 7.5, 6.3, 6.5, 12.0, 9.5
"""Font sizes [pt]."""
MIN_TABLE_PT = 5.0
"""A table too wide for a portrait page at :data:`TABLE_PT` is set in a smaller font down to this size [pt]; wider
still, it gets a landscape page (and shrinks further only if even that is too narrow)."""
CELL_PAD_IN = 0.04
"""Space between a column's text and its edges [in]."""
MIN_FIGURE_SCALE = 0.7
"""A figure may be drawn down to this fraction of the page width to fit the rest of a page."""
LINE = 1.3
"""Line height [font sizes]."""
WARN_COLOR, MUTED = "#9a4d00", "0.35"


def _line_in(pt: float) -> float:
    return pt * LINE / 72.0


def _wrap(text: str, width_in: float, pt: float, bold: bool = False) -> list[str]:
    """Lines of running text at most ``width_in`` wide (measured in the font; never a word split,
    :func:`feedtune.report.textfit.wrap`)."""
    return wrap(text, width_in * 72.0, pt, bold)


class _Flow:
    """Pages being filled from the top: the current page, the height used on it [in]."""

    def __init__(self) -> None:
        self.pages: list = []
        self.size = PAGE_IN
        self.y = 0.0
        self.toc_y = MARGIN_IN[1]
        self.cells: list = []
        self.new_page()

    @property
    def width(self) -> float:
        """Text width of the current page [in]."""
        return self.size[0] - MARGIN_IN[0] - MARGIN_IN[2]

    @property
    def bottom(self) -> float:
        """Lowest text line of the current page [in from its top]."""
        return self.size[1] - MARGIN_IN[3]

    @property
    def landscape(self) -> bool:
        return self.size[0] > self.size[1]

    def new_page(self, landscape: bool = False) -> None:
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure

        self.size = PAGE_IN[::-1] if landscape else PAGE_IN
        fig = Figure(figsize=self.size)
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

    def portrait(self) -> None:
        """Back to portrait pages after a landscape table."""
        if self.landscape:
            self.new_page()

    def need(self, height: float) -> None:
        """Start a new page unless ``height`` [in] fits on this one (or this one is still empty)."""
        if height > self.free and not self.fresh():
            self.new_page()

    def text(self, x_in: float, text: str, pt: float, y_in: float | None = None, **kw) -> None:
        """Text whose top left (``ha="right"``: top right) is ``x_in`` from the left margin, ``y_in`` (default: the
        current height) from the page's top [in]."""
        kw.setdefault("ha", "left")
        y = self.y if y_in is None else y_in
        self.page.text((MARGIN_IN[0] + x_in) / self.size[0], 1 - y / self.size[1], text, fontsize=pt, va="top", **kw)

    def rule(self, x0_in: float, x1_in: float, color="0.7", lw=0.5) -> None:
        from matplotlib.lines import Line2D

        y = 1 - self.y / self.size[1]
        self.page.add_artist(Line2D([(MARGIN_IN[0] + x0_in) / self.size[0], (MARGIN_IN[0] + x1_in) / self.size[0]],
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


@dataclass(frozen=True)
class TableLayout:
    """How a table is set: font size [pt], column widths [in], which columns hold numbers (right-aligned, broken
    only between the numbers of a list) and whether it needs a landscape page."""

    pt: float
    widths: list
    numeric: list
    landscape: bool


def _numeric_columns(t: Table) -> list[bool]:
    return [all(row[j].is_number or row[j].text == "-" for row in t.rows) for j in range(len(t.columns))]


def table_layout(t: Table, page_width_in: float, landscape_width_in: float) -> TableLayout:
    """Column widths as a browser sets an automatic table: each column at least as wide as its widest unbreakable
    piece (a number with its unit, a word, a header word: :func:`feedtune.report.textfit.min_width`) and at most as
    wide as its longest text; the room left shared in proportion to what each column would still use. A table whose
    narrowest layout does not fit the portrait width is set in a smaller font (down to :data:`MIN_TABLE_PT`), then on
    a landscape page; no number or word is ever split."""
    numeric = _numeric_columns(t)
    pad = 2 * CELL_PAD_IN * 72.0

    def widths_at(pt: float) -> tuple[list[float], list[float]]:
        lo, hi = [], []
        for j, name in enumerate(t.columns):
            cells = [row[j].text for row in t.rows]
            lo.append(max([min_width(c, pt, numeric=numeric[j]) for c in cells]
                          + [min_width(str(name), pt, bold=True)]) + pad)
            hi.append(max([text_width(c, pt) for c in cells] + [min_width(str(name), pt, bold=True)]) + pad)
        return lo, [max(a, b) for a, b in zip(lo, hi, strict=True)]

    lo, hi = widths_at(TABLE_PT)
    landscape = False
    pt = TABLE_PT
    room = page_width_in * 72.0
    if sum(lo) > room:
        pt = max(MIN_TABLE_PT, TABLE_PT * room / sum(lo))
        if sum(lo) * pt / TABLE_PT > room:
            landscape, room = True, landscape_width_in * 72.0
            pt = min(TABLE_PT, TABLE_PT * room / sum(lo))
        lo, hi = widths_at(pt)
        if sum(lo) > room:  # the font's widths are not exactly linear in its size (rounding): shrink to fit
            pt *= room / sum(lo) * 0.999
            lo, hi = widths_at(pt)
    if sum(hi) <= room:
        widths = hi
    else:
        share = (room - sum(lo)) / max(sum(hi) - sum(lo), 1e-9)
        widths = [a + (b - a) * share for a, b in zip(lo, hi, strict=True)]
    return TableLayout(pt, [w / 72.0 for w in widths], numeric, landscape)


def _table(flow: _Flow, t: Table) -> None:
    portrait = PAGE_IN[0] - MARGIN_IN[0] - MARGIN_IN[2]
    lay = table_layout(t, portrait, PAGE_IN[1] - MARGIN_IN[0] - MARGIN_IN[2])
    if lay.landscape != flow.landscape:
        flow.new_page(landscape=lay.landscape)
    pt, widths = lay.pt, lay.widths
    xs = [sum(widths[:j]) for j in range(len(widths))]
    step = _line_in(pt)
    inner = [(w - 2 * CELL_PAD_IN) * 72.0 for w in widths]

    head = [wrap(str(c), w, pt, bold=True) for c, w in zip(t.columns, inner, strict=True)]
    head_h = max(len(c) for c in head) * step + 0.04
    rows = [[wrap(c.text, w, pt, numeric=lay.numeric[j] and c.is_number) for j, (c, w) in
             enumerate(zip(row, inner, strict=True))] for row in t.rows]
    title = _wrap(t.title, flow.width, pt + 1, bold=True)
    first_row = (max(len(c) for c in rows[0]) * step + 0.03) if rows else 0.0
    flow.need(len(title) * _line_in(pt + 1) + head_h + first_row + 0.1)

    def put(j: int, k: int, line: str, text: str, bold: bool = False) -> None:
        right = lay.numeric[j] and not bold
        x = xs[j] + widths[j] - CELL_PAD_IN if right else xs[j] + CELL_PAD_IN
        flow.text(x, line, pt, y_in=flow.y + k * step, ha="right" if right else "left",
                  weight="bold" if bold else "normal")

    def record(j: int, lines: list, text: str) -> None:
        """The cell's box on its page [in from the page's top left] and its text, for checks of the layout."""
        flow.cells.append({"page": len(flow.pages) - 1, "text": text,
                           "box_in": (MARGIN_IN[0] + xs[j], flow.y, MARGIN_IN[0] + xs[j] + widths[j],
                                      flow.y + max(len(lines), 1) * step)})

    def header(continued: bool):
        for line in (title if not continued else [title[0] + " (continued)"]):
            flow.text(0, line, pt + 1, weight="bold")
            flow.y += _line_in(pt + 1)
        flow.y += 0.02
        flow.rule(0, sum(widths), "0.4", 0.6)
        flow.y += 0.02
        for j, c in enumerate(head):
            for k, line in enumerate(c):
                put(j, k, line, str(t.columns[j]), bold=True)
            record(j, c, str(t.columns[j]))
        flow.y += head_h
        flow.rule(0, sum(widths), "0.4", 0.6)
        flow.y += 0.02

    header(False)
    for r, (row, row_cells) in enumerate(zip(t.rows, rows, strict=True)):
        h = max(len(c) for c in row_cells) * step + 0.03
        if h > flow.free:
            flow.new_page(landscape=lay.landscape)
            header(True)
        for j, c in enumerate(row_cells):
            for k, line in enumerate(c):
                put(j, k, line, row[j].text)
            record(j, c, row[j].text)
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
    w_in, h_in = flow.size
    ax = flow.page.add_axes((x / w_in, 1 - (flow.y + height) / h_in, width / w_in, height / h_in))
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
    flow.portrait()
    _heading(flow, s.title, level, toc, page_of)
    for b in s.blocks:
        if not isinstance(b, Table):
            flow.portrait()
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


def layout_pages(report: Report, *, created: str | None = None, cells: list | None = None) -> list:
    """The PDF pages of a report as matplotlib Figures (title page first).

    ``cells``, when given, receives every table cell as laid out: ``{"page": index, "text": the cell's text,
    "box_in": (left, top, right, bottom)}`` [in from the page's top left] (what a test of the layout compares with the
    text a PDF reader extracts there)."""
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
        w_in, h_in = page.get_size_inches()
        page.text(MARGIN_IN[0] / w_in, 0.25 / h_in, report.title, fontsize=6.5, color=MUTED)
        page.text(1 - MARGIN_IN[2] / w_in, 0.25 / h_in, f"page {k} of {n}", fontsize=6.5, color=MUTED,
                  ha="right")
    if cells is not None:
        cells.extend(flow.cells)
    return flow.pages


def save_pages(pages: list, path: str | os.PathLike[str], title: str) -> None:
    """Write laid-out pages (:func:`layout_pages`) to ``path`` as a PDF, each at its own size.

    The fonts are embedded as TrueType (``pdf.fonttype`` 42): a reader's search and copy then find the words as
    written (matplotlib's default Type 3 glyphs come out of text extraction as ``certi fi ed``)."""
    import matplotlib
    from matplotlib.backends.backend_pdf import PdfPages

    with matplotlib.rc_context({"pdf.fonttype": 42}), \
            PdfPages(path, metadata={"Title": title, "Creator": "feedtune"}) as pdf:
        for page in pages:
            pdf.savefig(page)


def write_pdf(report: Report, path: str | os.PathLike[str]) -> None:
    """Write the report's sections (text, tables, figures) to ``path`` as a compact A4 PDF."""
    save_pages(layout_pages(report), path, report.title)
