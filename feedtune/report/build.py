"""Build a report from the user's files and write it (HTML, optional PDF).

:func:`build_report` classifies the inputs (:mod:`feedtune.report.collect`), builds the sections from
results stored in the files or computed by the analysis functions the CLI uses (nothing is re-identified
or re-designed), and renders the HTML. :func:`write_report` writes the HTML (and PDF) atomically, all or
nothing, refusing to overwrite without ``force``.
"""

from __future__ import annotations

import math
import os
from collections.abc import Iterable, Mapping
from pathlib import Path

import numpy as np

from .collect import Inputs, collect_inputs
from .content import Alert, Report, Section
from .design import design_section
from .html import render_html, render_pngs
from .identification import identification_section
from .sections import Colors, ReportLimits, display_names
from .summary import inputs_section, summary_section
from .time_domain import time_domain_section

REPORT_SCHEMA = "feedtune.report/1"
DEFAULT_TITLE = "feedtune tuning report"


def plain(obj):
    """JSON-ready copy: numpy scalars and arrays to Python, tuples to lists, non-finite floats to None."""
    if isinstance(obj, Mapping):
        return {str(k): plain(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [plain(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return plain(obj.tolist())
    if isinstance(obj, (bool, np.bool_)):
        return bool(obj)
    if isinstance(obj, (np.integer,)):
        return int(obj)
    if isinstance(obj, (float, np.floating)):
        v = float(obj)
        return v if math.isfinite(v) else None
    if isinstance(obj, complex):
        return [obj.real, obj.imag]
    if isinstance(obj, Path):
        return str(obj)
    return obj


def section_alerts(sections) -> list[str]:
    """The text of every warning (:class:`~feedtune.report.content.Alert`) the sections show, in display order: the
    summary lists each of them (a warning shown in a section is never missing from the summary)."""
    return [b.text for top in sections if top is not None for s in top.walk() for b in s.blocks
            if isinstance(b, Alert)]


def _sections(inputs: Inputs, limits: ReportLimits, strict: bool) -> tuple[list[Section], dict, list[str]]:
    names = display_names([*(m.path for m in inputs.models), *(g.path for g in inputs.gains),
                           *(f.path for f in inputs.frfs), *(x.path for x in inputs.logs)])
    colors = Colors()
    data: dict = {}
    warnings: list[str] = [f"{s.path}: left out ({s.reason})" for s in inputs.skipped if s.warning]
    ident = identification_section(inputs, names, limits, data, warnings)
    design, designs = design_section(inputs, names, limits, data, warnings, colors)
    time = time_domain_section(inputs, names, limits, data, warnings, colors, strict)
    warnings = list(dict.fromkeys([*warnings, *section_alerts([ident, design, time])]))
    summary = summary_section(designs, data, warnings, limits, inputs)
    body = [s for s in (summary, ident, design, time, inputs_section(inputs, names)) if s is not None]
    return [s for s in body if not s.is_empty()], data, warnings


def build_report(paths: Iterable[str | os.PathLike[str]], *, title: str | None = None,
                 log_kinds: Mapping[str, str] | None = None, strict: bool = False,
                 limits: ReportLimits | None = None, render: bool = True, log_reader=None,
                 frfs: Iterable[tuple[str, object]] = ()) -> Report:
    """Build the report of the given files and folders.

    Parameters
    ----------
    paths : iterable of path-like
        Model, gains, FRF and log files, or folders holding them (see :mod:`feedtune.report.collect`).
    title : str, optional
        Title (default :data:`DEFAULT_TITLE`).
    log_kinds : mapping of str to str, optional
        ``{log file name: kind}`` overrides (``track``, ``cut``, ``ropesnap``, ``contour``, ``friction``,
        ``frf``).
    strict : bool
        Files in folders that cannot be read, classified or analysed are errors instead of warnings.
    limits : ReportLimits, optional
        Warning thresholds (Ms, margins, coherence, fit error, saturation).
    render : bool
        Render the HTML (``Report.html``); False leaves it empty (sections, figures and data only).
    log_reader : callable, optional
        ``log_reader(path)`` -> Log for the log files named in ``paths``
        (:func:`~feedtune.report.collect.collect_inputs`).
    frfs : iterable of (str, Frf)
        FRFs read already, with the name to show (e.g. one merged from a file per encoder).

    Returns
    -------
    Report
        ``sections``, machine-readable ``data``, ``warnings`` and the HTML text ``html``.

    Raises
    ------
    DataError
        A missing or unreadable named file, a file that is none of the above, nothing usable.
    UsageError
        A bad ``log_kinds`` entry.
    """
    from .. import progress
    from ..io.provenance import created_by

    limits = limits or ReportLimits()
    progress.step("report: reading the inputs")
    inputs = collect_inputs(paths, log_kinds=log_kinds, strict=strict, log_reader=log_reader, frfs=frfs)
    progress.step("report: building the sections")
    sections, data, warnings = _sections(inputs, limits, strict)
    data = plain({"schema": REPORT_SCHEMA, "created_by": created_by(), "title": title or DEFAULT_TITLE,
                  "inputs": inputs.to_dict(), **data, "warnings": warnings})
    report = Report(title or DEFAULT_TITLE, sections, data, warnings)
    if not render:
        return report
    progress.step(f"report: drawing {len(report.figures())} figures")
    pngs = render_pngs(report)
    return Report(report.title, sections, data, warnings, render_html(report, pngs=pngs), pngs)


def pdf_path_for(html_path: str | os.PathLike[str]) -> Path:
    """The PDF written beside an HTML report: same name, ``.pdf``."""
    return Path(html_path).with_suffix(".pdf")


def write_report(report: Report, out: str | os.PathLike[str], *, pdf: bool = False, force: bool = False) -> list[Path]:
    """Write ``report.html`` to ``out`` (and the PDF beside it), atomically and all or nothing.

    Raises
    ------
    UsageError
        A destination exists and ``force`` is false.
    DataError
        The folder does not exist or cannot be written.
    """
    from ..errors import UsageError
    from ..io import atomic_outputs

    if not report.html:
        raise UsageError("the report was built with render=False; build it with render=True to write it")
    paths = [Path(out)] + ([pdf_path_for(out)] if pdf else [])
    with atomic_outputs(paths, force=force) as temps:
        temps[0].write_bytes(report.html.encode("utf-8"))
        if pdf:
            from .. import progress
            from .pdf import write_pdf

            progress.step("report: writing the PDF")
            write_pdf(report, temps[1])
    return paths
