"""Value types of a report: sections made of paragraphs, warnings, tables and figures.

A :class:`Report` is built once (:func:`feedtune.report.build.build_report`) and rendered to HTML
(:mod:`feedtune.report.html`) and PDF (:mod:`feedtune.report.pdf`) from the same objects, so both show the
same numbers. Every number in a table is a :class:`Cell` that keeps the SI value, the key under which the
same value sits in the report's machine-readable data (``Report.data``), the display scale and unit.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

from ..display import DIGITS as DISPLAY_DIGITS


def format_number(value: float | None, digits: int = DISPLAY_DIGITS) -> str:
    """A number for display with ``digits`` significant digits, as the command line prints it
    (:func:`feedtune.display.number`: plain from 1e-4 to 1e6, whole numbers without a fraction); ``"-"`` for None or
    non-finite values.

    Examples
    --------
    >>> format_number(0.000123456), format_number(1234567.0), format_number(98127.4), format_number(None)
    ('0.0001235', '1.235e+06', '98130', '-')
    """
    from ..display import plain_number

    if value is None or not math.isfinite(float(value)):
        return "-"
    return plain_number(float(value), digits)


@dataclass(frozen=True)
class Cell:
    """One table cell: a number with its unit, or a text.

    Attributes
    ----------
    value : float, list of float, str or None
        The SI value or values (or a text, or None for "not available").
    unit : str
        Unit shown after the number (after ``scale``), e.g. ``"µm"``; ``""`` for dimensionless numbers.
    scale : float
        Display factor applied to ``value`` (``1e6`` shows metres in µm).
    key : str or None
        Dotted path of the same SI value in the report data (``Report.data``), for machine reading.
    digits : int
        Significant digits shown.
    """

    value: float | str | None
    unit: str = ""
    scale: float = 1.0
    key: str | None = None
    digits: int = DISPLAY_DIGITS

    @property
    def is_number(self) -> bool:
        """True when the cell holds a number or a list of numbers (not a text)."""
        if isinstance(self.value, (list, tuple)):
            return all(_is_real(v) for v in self.value)
        return _is_real(self.value)

    @property
    def text(self) -> str:
        """The cell as shown: the scaled number with its unit, or the text."""
        if self.value is None:
            return "-"
        if isinstance(self.value, bool):
            return "yes" if self.value else "no"
        if not self.is_number:
            return str(self.value)
        values = self.value if isinstance(self.value, (list, tuple)) else [self.value]
        if not values:
            return "none"
        shown = ", ".join(format_number(float(v) * self.scale, self.digits) for v in values)
        return f"{shown} {self.unit}".strip() if shown != "-" else shown


def _is_real(v) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool)


def text_cell(text: str) -> Cell:
    """A cell holding text only."""
    return Cell(str(text))


@dataclass(frozen=True)
class Table:
    """A table with a header row; each row is a list of cells (text cells for labels).

    Attributes
    ----------
    title : str
        Caption.
    columns : list of str
        Column titles.
    rows : list of list of Cell
    note : str
        Text under the table.
    """

    title: str
    columns: list
    rows: list
    note: str = ""

    def numbers(self) -> list[Cell]:
        """Every numeric cell."""
        return [c for row in self.rows for c in row if c.is_number]


@dataclass(frozen=True, eq=False)
class FigureBlock:
    """A matplotlib figure (``matplotlib.figure.Figure``, Agg canvas) with its caption.

    ``source`` is the figure, or a callable without arguments that draws it: the figure is then built on first use
    of :attr:`figure` (the report draws its figures where it renders them, possibly in several processes).
    ``shows`` names the designs (or runs) the figure compares, ``((label, colour), ...)``: each must be visible in it
    (a test counts each colour's pixels in the axes).
    """

    name: str
    caption: str
    source: Any
    shows: tuple = ()

    @property
    def figure(self):
        """The matplotlib Figure (built once from ``source`` when that is a callable)."""
        built = self.__dict__.get("_figure")
        if built is None:
            built = self.source() if callable(self.source) and not hasattr(self.source, "savefig") else self.source
            object.__setattr__(self, "_figure", built)
        return built


@dataclass(frozen=True)
class Paragraph:
    """Plain text."""

    text: str


@dataclass(frozen=True)
class Verdict(Paragraph):
    """A design's pass/fail line, shown emphasised (highlighted when it fails). Not a warning: the violations of a
    failing design are listed among the warnings on their own."""

    ok: bool = True


@dataclass(frozen=True)
class Alert:
    """A warning shown highlighted. Every alert a section shows is also listed in the summary's warnings
    (:func:`feedtune.report.build.build_report` gathers them)."""

    text: str


@dataclass(frozen=True)
class Section:
    """A titled part of the report.

    Attributes
    ----------
    key : str
        Identifier (HTML id), e.g. ``"identification"``.
    title : str
    blocks : list
        Paragraph, Alert, Table and FigureBlock objects in display order.
    subsections : list of Section
    """

    key: str
    title: str
    blocks: list = field(default_factory=list)
    subsections: list = field(default_factory=list)

    def is_empty(self) -> bool:
        """True when neither the section nor a subsection has a block."""
        return not self.blocks and all(s.is_empty() for s in self.subsections)

    def walk(self):
        """This section and every subsection, depth first."""
        yield self
        for s in self.subsections:
            yield from s.walk()

    def figures(self) -> list[FigureBlock]:
        """Every figure of the section and its subsections."""
        return [b for s in self.walk() for b in s.blocks if isinstance(b, FigureBlock)]

    def tables(self) -> list[Table]:
        """Every table of the section and its subsections."""
        return [b for s in self.walk() for b in s.blocks if isinstance(b, Table)]


@dataclass(frozen=True)
class Report:
    """A built report.

    Attributes
    ----------
    title : str
    sections : list of Section
        Non-empty sections in display order.
    data : dict
        Machine-readable results (JSON-ready, SI units named in the keys or in ``units`` entries); the
        HTML embeds it in ``<script type="application/json" id="feedtune-report-data">``.
    warnings : list of str
        The warnings listed in the summary.
    html : str
        The self-contained HTML document.
    images : dict
        Each figure drawn once as PNG bytes, by figure name (shared by the HTML and the PDF).
    """

    title: str
    sections: list
    data: dict
    warnings: list
    html: str = field(repr=False, default="")
    images: dict = field(repr=False, default_factory=dict)

    def section(self, key: str) -> Section | None:
        """The section (or subsection) with this key, or None."""
        for top in self.sections:
            for s in top.walk():
                if s.key == key:
                    return s
        return None

    def figures(self) -> list[FigureBlock]:
        """Every figure in display order."""
        return [f for s in self.sections for f in s.figures()]

    def tables(self) -> list[Table]:
        """Every table in display order."""
        return [t for s in self.sections for t in s.tables()]
