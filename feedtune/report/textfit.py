"""Text measured in the PDF's font and wrapped without ever splitting a number or a word.

The PDF (:mod:`feedtune.report.pdf`) is drawn by matplotlib in DejaVu Sans, whose text is laid out with the fonts'
linear advance widths (no hinting in a PDF): :func:`text_width` sums them per character (cached), so a column is
exactly as wide as its longest unbreakable piece. Text breaks only where a reader expects it (:func:`pieces`): after a
space; in a file name or a path, after ``_`` and ``/``; in a list of numbers, after ``", "``. A number with its unit
(``116.1 Hz``), a word and a unit such as ``V/(rad s)`` stay whole.

Examples
--------
>>> pieces("track_200mm_s_mcppc.csv")
['track_', '200mm_', 's_', 'mcppc.csv']
>>> pieces("116.1, 130.8, 135.7 Hz", numeric=True)
['116.1, ', '130.8, ', '135.7 Hz']
>>> wrap("measured FRF, discrete controller", text_width("measured FRF, disc", 6.3), 6.3)
['measured FRF,', 'discrete controller']
"""

from __future__ import annotations

import re
from functools import lru_cache

REFERENCE_PT = 100.0
"""Font size at which the advance widths are read [pt]; widths scale linearly with the size."""
_SPACE_BREAK = re.compile(r"(?<= )(?=\S)")
_NAME_BREAK = re.compile(r"(?<=[_/])(?=[^_/\s])")
_LIST_BREAK = re.compile(r"(?<=, )")


@lru_cache(maxsize=2)
def _font(bold: bool):
    """A private FT2Font of DejaVu Sans at :data:`REFERENCE_PT`: not matplotlib's shared ``get_font`` object, whose
    size every text drawn since sets anew (measured on it, widths depended on what had been drawn before)."""
    from matplotlib.font_manager import FontProperties, findfont
    from matplotlib.ft2font import FT2Font

    font = FT2Font(findfont(FontProperties(family=["DejaVu Sans"], weight="bold" if bold else "normal")))
    font.set_size(REFERENCE_PT, 72)
    return font


@lru_cache(maxsize=4096)
def _advance(char: str, bold: bool) -> float:
    """Advance width of one character at :data:`REFERENCE_PT` [pt]."""
    from matplotlib.ft2font import LoadFlags

    glyph = _font(bold).load_char(ord(char), flags=LoadFlags.NO_HINTING)
    return glyph.linearHoriAdvance / 65536.0


def text_width(text: str, pt: float, bold: bool = False) -> float:
    """Width of ``text`` set in DejaVu Sans at ``pt`` points [pt] (linear advances, as a PDF lays it out)."""
    return sum(_advance(c, bold) for c in str(text)) * pt / REFERENCE_PT


def pieces(text: str, numeric: bool = False) -> list[str]:
    """``text`` cut where a line may end (each piece keeps its trailing space or separator).

    A numeric cell (numbers and a unit) breaks only after ``", "``: its numbers and its unit stay together. Other
    text breaks after spaces, and a word holding ``_`` or ``/`` but no ``(`` (a file name, a path; not a unit such as
    ``V/(rad s)``) also after those.
    """
    text = str(text)
    if numeric:
        return [p for p in _LIST_BREAK.split(text) if p]
    out = []
    for word in _SPACE_BREAK.split(text):
        name_like = ("_" in word or "/" in word) and "(" not in word and "^" not in word
        out += [p for p in _NAME_BREAK.split(word) if p] if name_like and len(word.strip()) > 1 else [word]
    return out


def min_width(text: str, pt: float, bold: bool = False, numeric: bool = False) -> float:
    """The width of the widest unbreakable piece [pt]: the narrowest a column can hold ``text`` in."""
    return max((text_width(p.rstrip(), pt, bold) for p in pieces(text, numeric)), default=0.0)


def wrap(text: str, width_pt: float, pt: float, bold: bool = False, numeric: bool = False) -> list[str]:
    """``text`` in lines at most ``width_pt`` wide, broken only between :func:`pieces` (``\\n`` starts a line).

    A piece wider than ``width_pt`` gets a line of its own (it overflows rather than splits: callers size their
    columns to :func:`min_width`).
    """
    lines: list[str] = []
    for part in str(text).split("\n"):
        line = ""
        for piece in pieces(part, numeric):
            trial = line + piece
            if line and text_width(trial.rstrip(), pt, bold) > width_pt:
                lines.append(line.rstrip())
                line = piece
            else:
                line = trial
        lines.append(line.rstrip())
    return lines
