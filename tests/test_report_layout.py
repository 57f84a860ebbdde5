"""The report's layout rules on small inputs: tables that never split a number or a word (the PDF's column widths and
wrapping, measured in its font), colours that stay apart for colour-blind readers, runs dwarfed by another drawn at
their own scale.

The demo reports themselves are checked page by page in tests/test_report_browser.py (Chromium, the PDF's text and
images); here the rules are checked against things that are not the layout code: the colour-vision simulation of
Machado et al. (2009), the widths the PDF backend's own font gives, and text reconstructed from the laid-out lines.
"""

from __future__ import annotations

import itertools
import re

import numpy as np
import pytest
from report_checks import MIN_PIXELS, axes_mask, colour_pixels, split_in

from feedtune.report.content import Cell, Table, text_cell
from feedtune.report.figures import PALETTE, Curve, dwarf_split
from feedtune.report.pdf import MIN_TABLE_PT, TABLE_PT, table_layout
from feedtune.report.textfit import text_width, wrap

WORD = re.compile(r"[A-Za-z0-9.+\-]+")

# Machado, Oliveira and Fernandes (2009), "A physiologically-based model for simulation of color vision deficiency",
# severity 1.0, applied to linear RGB
CVD = {
    "protanopia": [[0.152286, 1.052583, -0.204868], [0.114503, 0.786281, 0.099216], [-0.003882, -0.048116, 1.051998]],
    "deuteranopia": [[0.367322, 0.860646, -0.227968], [0.280085, 0.672501, 0.047413], [-0.011820, 0.042940, 0.968881]],
    "tritanopia": [[1.255528, -0.076749, -0.178779], [-0.078411, 0.930809, 0.147602], [0.004733, 0.691367, 0.303900]],
}


def _lab(rgb: np.ndarray) -> np.ndarray:
    """CIELAB (D65) of linear RGB."""
    xyz = np.array([[0.4124, 0.3576, 0.1805], [0.2126, 0.7152, 0.0722], [0.0193, 0.1192, 0.9505]]) @ rgb
    xyz = xyz / np.array([0.95047, 1.0, 1.08883])
    f = np.where(xyz > 0.008856, np.cbrt(xyz), 7.787 * xyz + 16 / 116)
    return np.array([116 * f[1] - 16, 500 * (f[0] - f[1]), 200 * (f[1] - f[2])])


def _linear(hex_color: str) -> np.ndarray:
    c = np.array([int(hex_color[i:i + 2], 16) for i in (1, 3, 5)]) / 255.0
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)


def _min_distance(colors, matrix) -> float:
    lab = [_lab(np.clip(np.asarray(matrix) @ _linear(c), 0, 1)) for c in colors]
    return min(float(np.linalg.norm(a - b)) for a, b in itertools.combinations(lab, 2))


def test_design_colours_stay_apart_for_colour_blind_readers():
    # CIE76 distance of every pair of design colours as a reader with each dichromacy sees them: at least 15 (clearly
    # different); the matplotlib colours the report used before fail it (red/green 4.6 for protanopia)
    for name, matrix in CVD.items():
        assert _min_distance(PALETTE, matrix) > 15, name
    assert _min_distance(PALETTE, np.eye(3)) > 20
    old = ("#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e", "#8c564b", "#e377c2", "#17becf")
    assert _min_distance(old, CVD["protanopia"]) < 10


def _rebuilt(lines: list[str], text: str) -> bool:
    """True when ``lines`` are ``text`` broken only at spaces, after ``_`` or ``/`` (or after ``", "``)."""
    return split_in([w for line in lines for w in line.split()], text) is None


def test_wide_tables_shrink_or_turn_and_never_split_a_token():
    numbers = [0.02688, 98127.4, 1.2345e-33, 116.1, 0.0003779, 2.282]
    wide = Table("wide", [f"column with a long header {k}" for k in range(14)],
                 [[text_cell("track_1000mm_s_mcppc_prefilter.csv")]
                  + [Cell(v * (j + 1), "V/(rad s)") for j, v in enumerate(numbers * 2)]
                  + [Cell([116.1, 130.8, 135.7], "Hz")]] * 3)
    portrait, landscape = 7.27, 10.69
    lay = table_layout(wide, portrait, landscape)
    assert lay.landscape and MIN_TABLE_PT * 0.5 < lay.pt <= TABLE_PT
    assert sum(lay.widths) <= landscape + 1e-6
    for row in [[text_cell(c) for c in wide.columns], *wide.rows]:
        for j, cell in enumerate(row):
            inner = (lay.widths[j] - 0.08) * 72
            lines = wrap(cell.text, inner, lay.pt, numeric=lay.numeric[j] and cell.is_number)
            assert _rebuilt(lines, cell.text), (cell.text, lines)
            assert all(text_width(line, lay.pt) <= inner + 0.01 for line in lines), (cell.text, lines)
    narrow = Table("narrow", ["a", "b"], [[text_cell("x"), Cell(0.02688, "")]])
    lay = table_layout(narrow, portrait, landscape)
    assert not lay.landscape and lay.pt == TABLE_PT


def test_text_widths_do_not_depend_on_what_was_drawn_before():
    """Widths come from a font object of their own: matplotlib's shared one takes the size of the last text drawn,
    and measured on it a column's width depended on the figures drawn before (once: 'bandwidth' set outside the cell
    of 'tracking bandwidth' inside the whole slow set only). DejaVu Sans' 'c' advances 1126 of its 2048 units."""
    from matplotlib.font_manager import FontProperties, findfont, get_font

    from feedtune.report import textfit

    before = text_width("tracking bandwidth", 6.3)
    get_font(findfont(FontProperties(family=["DejaVu Sans"]))).set_size(8, 100)  # what drawing a figure does
    textfit._advance.cache_clear()
    assert text_width("tracking bandwidth", 6.3) == before
    assert text_width("c", 100.0) == pytest.approx(1126 / 2048 * 100, rel=1e-6)


def test_the_rebuild_rule_catches_a_split_number():
    assert not _rebuilt(["0.0268", "8"], "0.02688")
    assert not _rebuilt(["dampin", "g [-]"], "damping [-]")
    assert _rebuilt(["track_", "200mm_s.csv"], "track_200mm_s.csv")


def _two_designs_figure(colors: tuple[str, str]):
    """The loop figure of two designs whose loops coincide (the case of the gantry's MIMO and PID at high
    frequency)."""
    from feedtune.report.figures import figure_png, loop_figure

    f = np.logspace(0, 3, 400)
    L = 100.0 / (1j * f) ** 2
    curves = [Curve(f, L, "MIMO", colors[0], "-", 1.5), Curve(f, L * 1.001, "PID", colors[1], "-", 1.5)]
    fig = loop_figure(curves, {})
    png = figure_png(fig)
    from io import BytesIO

    from PIL import Image

    rgb = np.asarray(Image.open(BytesIO(png)).convert("RGB"))
    mask = axes_mask(fig, rgb.shape[:2])
    return [colour_pixels(rgb, mask, c) for c in colors]


def test_coinciding_curves_stay_visible_and_the_pixel_check_sees_when_they_do_not():
    mimo, pid = _two_designs_figure(PALETTE[:2])
    assert min(mimo, pid) > 3 * MIN_PIXELS  # nested widths and markers: both seen
    hidden, top = _two_designs_figure(("#d62728", "#8c564b"))  # colours outside the palette: plain equal lines
    assert hidden < MIN_PIXELS <= top  # the first drawn is covered: the check the demo reports pass would fail


def test_a_run_dwarfed_by_another_is_drawn_again_at_its_scale():
    from feedtune.report.figures import TimePanel, Window, time_figure

    t = np.linspace(0, 1, 2000)
    pid = Curve(t, 385 * np.sin(8 * t), "PID", PALETTE[1])
    mimo = Curve(t, 6 * np.sin(8 * t), "MIMO", PALETTE[0])
    assert [c.label for c in dwarf_split([pid, mimo])[1]] == ["MIMO"]
    assert dwarf_split([pid, Curve(t, 200 * np.sin(8 * t), "P-PI")])[1] == []
    fig = time_figure([TimePanel("table displacement [µm]", [pid, mimo], own_scale=True)], [Window("w", 0.1, 0.3)],
                      [], time_label="t [s]", spectrum_label="", title="rope snap")
    whole = [ax for ax in fig.axes if ax.get_ylabel().endswith("[µm]") and ax.get_ylabel() != "[µm]"]
    assert [ax.get_ylabel() for ax in whole] == ["table displacement [µm]", "the smaller [µm]"]
    small = whole[1]
    assert [line.get_label() for line in small.get_lines() if not line.get_label().startswith("_")] == ["MIMO"]
    lo, hi = small.get_ylim()
    assert hi - lo < 20  # the MIMO's scale, not the PID's 770 um


@pytest.mark.parametrize("text", ["0.02688", "V/(rad/s^2)", "116.1, 130.8, 135.7 Hz", "damping [-]"])
def test_wrap_keeps_numbers_units_and_words_whole_in_any_width(text):
    for width in (5.0, 20.0, 60.0, 400.0):
        lines = wrap(text, width, 6.3, numeric=text[0].isdigit())
        assert _rebuilt(lines, text), (width, lines)
        for token in WORD.findall(text):
            assert any(token in line for line in lines), (token, lines)
