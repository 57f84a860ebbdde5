"""The demo reports as a reader sees them, in a real browser and in the PDF.

Headless Chromium lays out the ball-screw and the gantry demo reports, and a small script measures: every figure
decoded and inside the page width, no table wider than its box, no horizontal scrolling of the page, no table cell
whose text overflows it or whose word (a number, a unit, a word) is broken across two lines. The PDF of the same
reports is read back as a PDF reader does (poppler's ``pdftotext`` and ``pdfimages``): every table cell's region holds
its text with no number or word split and nothing outside the cell, and every figure shows each design it compares
(pixels of the design's colour inside the axes).

Dependency-free: the HTML is copied with one ``<script>`` appended, Chromium prints the resulting DOM
(``--dump-dom``) and the script's findings are read back from a ``<pre>`` element. The browser tests are skipped when
no Chromium is installed (Debian package ``chromium``), the PDF tests without poppler-utils. Set
``FEEDTUNE_SCREENSHOTS=DIR`` to also save full-page screenshots there.
"""

from __future__ import annotations

import html
import json
import os
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest
from report_checks import (
    BROWSER,
    MIN_PIXELS,
    axes_mask,
    cell_problems,
    colour_pixels,
    have_poppler,
    pdf_images,
    pdf_words,
    run_browser,
)

from feedtune.workflows import run_machine_demo
from feedtune.workflows.files import write_texts

DESKTOP, NARROW = 1280, 800
"""Viewport widths [px]: a laptop screen (every table fits without scrolling) and a narrow window (wide tables
scroll inside their own box, the page does not)."""

PROBE = r"""<script>
window.addEventListener('load', () => {
  const vw = document.documentElement.clientWidth;
  const out = {vw: vw, page_scroll_width: document.documentElement.scrollWidth,
               page_height: document.documentElement.scrollHeight, imgs: [], tables: []};
  document.querySelectorAll('figure img').forEach(i => {
    const r = i.getBoundingClientRect();
    out.imgs.push({id: i.parentElement.id, natural_width: i.naturalWidth, complete: i.complete, left: r.left,
                   right: r.right, width: r.width});
  });
  out.cells = [];
  document.querySelectorAll('td, th').forEach(c => {
    const broken = [];
    const walker = document.createTreeWalker(c, NodeFilter.SHOW_TEXT);
    for (let n = walker.nextNode(); n; n = walker.nextNode()) {
      const re = /[^\s_\/]+[_\/]?/g;  // the pieces a line may not break inside (the HTML allows breaks after _ and /)
      for (let m = re.exec(n.data); m; m = re.exec(n.data)) {
        const r = document.createRange();
        r.setStart(n, m.index); r.setEnd(n, m.index + m[0].replace(/[_\/]$/, '').length);
        const lines = new Set(Array.from(r.getClientRects()).map(x => Math.round(x.top)));
        if (lines.size > 1) broken.push(m[0]);
      }
    }
    if (broken.length || c.scrollWidth > c.clientWidth + 1)
      out.cells.push({text: c.textContent, broken: broken, scroll_width: c.scrollWidth, client_width: c.clientWidth});
  });
  document.querySelectorAll('table').forEach(t => {
    const box = t.parentElement, r = t.getBoundingClientRect();
    out.tables.push({caption: t.caption ? t.caption.textContent : '', scroll_width: t.scrollWidth,
                     client_width: t.clientWidth, box_class: box.className, box_scroll_width: box.scrollWidth,
                     box_client_width: box.clientWidth, box_overflow_x: getComputedStyle(box).overflowX,
                     right: r.right});
  });
  const pre = document.createElement('pre');
  pre.id = 'feedtune-probe';
  pre.textContent = JSON.stringify(out);
  document.body.appendChild(pre);
});
</script>"""


pytestmark = pytest.mark.slow
needs_browser = pytest.mark.skipif(BROWSER is None, reason="no Chromium on the PATH (Debian: apt-get install chromium)")
needs_poppler = pytest.mark.skipif(not have_poppler(), reason="no pdftotext/pdfimages (Debian: poppler-utils)")


def probe(report: Path, width: int, tmp: Path) -> dict:
    """Lay out ``report`` at a viewport ``width`` [px] wide and return what the probe script measured."""
    page = tmp / f"probe_{width}_{report.parent.name}.html"
    page.write_text(report.read_text(encoding="utf-8").replace("</body>", PROBE + "</body>"), encoding="utf-8")
    res = run_browser([f"--window-size={width},900", "--dump-dom", page.as_uri()], tmp / "profile")
    m = re.search(r'<pre id="feedtune-probe">(.*?)</pre>', res.stdout, re.S)
    assert m is not None, f"the probe did not run (exit {res.returncode}): {res.stderr[-2000:]}"
    return json.loads(html.unescape(m.group(1)))


def screenshot(report: Path, height: int, out: Path, tmp: Path) -> None:
    """A full-page screenshot of ``report`` at :data:`DESKTOP` width."""
    run_browser([f"--window-size={DESKTOP},{height + 20}", f"--screenshot={out}", report.as_uri()],
                 tmp / "profile")


@dataclass(frozen=True)
class DemoReport:
    """A demo's report: the built report, its HTML and its PDF, and the PDF's table cells as laid out."""

    report: object
    html: Path
    pdf: Path
    cells: list


@pytest.fixture(scope="module", params=["ballscrew", "gantry"])
def demo(request, tmp_path_factory) -> DemoReport:
    """The report the demo writes (``feedtune demo MACHINE --out DIR``), built from the demo's own files, with its
    PDF (``feedtune report --pdf``: :func:`feedtune.report.pdf.write_pdf` is these two calls)."""
    from feedtune.cli.demo_cmd import write_demo_report
    from feedtune.report.build import build_report
    from feedtune.report.pdf import layout_pages, save_pages

    machine = request.param
    out = tmp_path_factory.mktemp(f"demo_{machine}") / "demo_out"
    write_texts(run_machine_demo(machine, seed=0).texts, out_dir=out)
    html_path = write_demo_report(out, True, machine)
    here = Path.cwd()
    os.chdir(out)
    try:
        report = build_report(["."], title=f"feedtune demo on the digital twin ({machine})")
    finally:
        os.chdir(here)
    cells: list = []
    pdf = out / "report.pdf"
    save_pages(layout_pages(report, cells=cells), pdf, report.title)
    return DemoReport(report, html_path, pdf, cells)


@pytest.fixture(scope="module")
def demo_report(demo) -> Path:
    return demo.html


@needs_browser
def test_every_figure_is_shown_inside_the_page_and_no_table_overflows(demo_report, tmp_path):
    n_figures = len(re.findall(r'<figure id="fig-', demo_report.read_text(encoding="utf-8")))
    desk = probe(demo_report, DESKTOP, tmp_path)
    assert len(desk["imgs"]) == n_figures > 10
    for img in desk["imgs"]:
        assert img["complete"] and img["natural_width"] > 0, img
        assert img["left"] >= 0 and img["right"] <= desk["vw"] + 0.5, img
    assert desk["page_scroll_width"] <= desk["vw"]
    assert desk["cells"] == []  # no cell overflows, no number or word broken across lines
    assert len(desk["tables"]) > 10
    for t in desk["tables"]:
        assert t["box_class"] == "table-wrap" and t["box_overflow_x"] == "auto", t  # the scroll box by design
        assert t["scroll_width"] <= t["client_width"] + 1, t  # nothing cut off inside the table
        assert t["box_scroll_width"] <= t["box_client_width"] + 1, t  # fits the page: no scrolling at 1280 px
        assert t["right"] <= desk["vw"] + 0.5, t

    narrow = probe(demo_report, NARROW, tmp_path)
    assert narrow["page_scroll_width"] <= narrow["vw"]  # the page never scrolls sideways
    assert narrow["cells"] == []
    for img in narrow["imgs"]:
        assert img["natural_width"] > 0 and img["right"] <= narrow["vw"] + 0.5, img  # figures scale down
    for t in narrow["tables"]:
        assert t["scroll_width"] <= t["client_width"] + 1, t
        assert t["box_scroll_width"] <= t["box_client_width"] + 1 or t["box_overflow_x"] == "auto", t

    shots = os.environ.get("FEEDTUNE_SCREENSHOTS")
    if shots:
        Path(shots).mkdir(parents=True, exist_ok=True)
        screenshot(demo_report, desk["page_height"], Path(shots) / f"{demo_report.parent.parent.name}.png", tmp_path)


@needs_poppler
def test_pdf_tables_never_split_a_number_or_a_word(demo):
    pages = pdf_words(demo.pdf)
    assert len(demo.cells) > 500
    assert "verdict" in {c["text"] for c in demo.cells}
    assert cell_problems(demo.cells, pages) == []


@needs_poppler
def test_every_pdf_figure_shows_each_design(demo, tmp_path):
    from PIL import Image

    figures = demo.report.figures()
    images = pdf_images(demo.pdf, tmp_path / "images")
    assert len(images) == len(figures)
    checked = 0
    for path, block in zip(images, figures, strict=True):
        rgb = np.asarray(Image.open(path).convert("RGB"))
        fig = block.figure
        assert rgb.shape[1::-1] == (round(fig.get_figwidth() * fig.dpi), round(fig.get_figheight() * fig.dpi))
        mask = axes_mask(fig, rgb.shape[:2])
        for label, color in block.shows:
            assert colour_pixels(rgb, mask, color) >= MIN_PIXELS, (block.name, label, color)
            checked += 1
    assert checked > 20
