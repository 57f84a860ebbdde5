"""Short reprs, small HTML tables and attribute access to figures for the value types, for notebooks.

The value types (:class:`~feedtune.frf.Frf`, :class:`~feedtune.log.Log`, the models, the laws, the analyses, the
experiment results) hold whole arrays; their default dataclass reprs printed every sample. Their ``__repr__`` and
``_repr_html_`` call the functions here, which show the key numbers with their units: shape, frequency range,
channels, parameters, margins. Nothing here computes more than a minimum or a maximum; numpy is the only import.

Examples
--------
>>> quantity(0.0019359, "V/(rad/s^2)")
'0.001936 V/(rad/s^2)'
>>> call("Frf", ["2x1", "0.5-2000 Hz"])
'Frf(2x1, 0.5-2000 Hz)'
"""

from __future__ import annotations

import html
import math
from collections.abc import Callable, Iterable, Mapping, Sequence

import numpy as np

DIGITS = 4
"""Significant digits of the numbers in reprs and tables."""


# ------------------------------------------------------------------------------------------ numbers
def number(x, digits: int = DIGITS) -> str:
    """A number with ``digits`` significant digits (``-`` for None, ``inf``/``nan`` as such, yes/no for bools).

    Examples
    --------
    >>> number(3.130629), number(None), number(True), number(float("inf"))
    ('3.131', '-', 'yes', 'inf')
    """
    if x is None:
        return "-"
    if isinstance(x, (bool, np.bool_)):
        return "yes" if x else "no"
    if isinstance(x, (int, np.integer)):
        return str(int(x))
    try:
        v = float(x)
    except (TypeError, ValueError):
        return str(x)
    if math.isnan(v):
        return "nan"
    if math.isinf(v):
        return "inf" if v > 0 else "-inf"
    if v == round(v) and abs(v) < 1e9:  # 20000 Hz, not 2e+04 Hz
        return str(int(v))
    return plain_number(v, digits)


def plain_number(x: float, digits: int = DIGITS) -> str:
    """``x`` rounded to ``digits`` significant digits, plain from 1e-4 up to 1e6 (``0.001936``, ``65080``,
    ``13``), with a power of ten outside (``2.285e-06``, ``1.079e+07``).

    Examples
    --------
    >>> plain_number(65083.2), plain_number(0.0019357), plain_number(2.2851e-6), plain_number(13.0)
    ('65080', '0.001936', '2.285e-06', '13')
    """
    if not math.isfinite(x) or x == 0:
        return "0" if x == 0 else f"{x:g}"
    rounded = float(f"{x:.{digits}g}")
    exponent = math.floor(math.log10(abs(rounded)))
    if not -4 <= exponent < 6:
        return f"{x:.{digits}g}"
    text = f"{rounded:.{max(digits - 1 - exponent, 0)}f}"
    return text.rstrip("0").rstrip(".") if "." in text else text


AT_BOUND = 1e-9
"""A fitted parameter closer to its bound than this fraction of its standard deviation sits on the bound: a bounded
least-squares fit leaves it there up to rounding (``b1 = 8e-31`` with a std of ``7e-4`` is ``0``)."""


def at_lower_bound(value, std=None, lower=None) -> bool:
    """True when a fitted ``value`` sits on its ``lower`` bound (exactly, or within :data:`AT_BOUND` of its std)."""
    return lower is not None and value is not None and (
        value <= lower or (std is not None and math.isfinite(std) and value - lower <= AT_BOUND * std))


def param_text(value, unit: str = "", std=None, lower=None, digits: int = DIGITS) -> str:
    """A fitted parameter for summaries: ``0.01383 V/(rad/s)  (std 0.00034)``; on its lower bound ``lower``
    (:func:`at_lower_bound`) ``0 V/(rad/s)  (at its lower bound; std 0.00067)``; the std to 2 significant digits.

    Examples
    --------
    >>> param_text(8.2e-31, "V/(rad/s)", std=6.7e-4, lower=0.0)
    '0 V/(rad/s)  (at its lower bound; std 0.00067)'
    """
    at_bound = at_lower_bound(value, std, lower)
    text = quantity(lower if at_bound else value, unit, digits) if value is not None else "-"
    notes = (["at its lower bound"] if at_bound else []) + ([f"std {plain_number(std, 2)}"] if std is not None else [])
    return text + (f"  ({'; '.join(notes)})" if notes else "")


def quantity(x, unit: str = "", digits: int = DIGITS) -> str:
    """``number(x) unit`` (no unit for ``-``, ``""`` or ``"-"``)."""
    text = number(x, digits)
    return text if not unit or unit == "-" or text == "-" else f"{text} {unit}"


def span(lo, hi, unit: str = "") -> str:
    """``lo-hi unit``, e.g. ``0.5-2000 Hz``."""
    return quantity(f"{number(lo)}-{number(hi)}", unit)


def filter_pack_text(pack) -> str:
    """A filter pack in a few words: ``notches 420, 1080 Hz, low-pass 2000 Hz (order 1)``, ``no filters``.

    Examples
    --------
    >>> from feedtune.control.filters import THESIS_FILTER_PACK
    >>> filter_pack_text(THESIS_FILTER_PACK)
    'notches 420, 1080 Hz, low-pass 2000 Hz (order 1)'
    """
    parts = []
    if pack.notches:
        parts.append(f"notch{'es' if len(pack.notches) > 1 else ''} "
                     + quantity(", ".join(number(n.freq_hz) for n in pack.notches), "Hz"))
    if pack.lpf_hz:
        parts.append(f"low-pass {quantity(pack.lpf_hz, 'Hz')} (order {pack.lpf_order})")
    if pack.leads:
        parts.append(f"lead{'s' if len(pack.leads) > 1 else ''} " + ", ".join(
            f"{quantity(ld.center_hz, 'Hz')} {quantity(ld.phase_deg, 'deg')}" for ld in pack.leads))
    return ", ".join(parts) or "no filters"


def design_repr(name: str, settings: Iterable[str], gains: Mapping[str, float], units: Mapping[str, str],
                filters=None, fs: float | None = None, delay_samples: int | None = None) -> str:
    """``Name(settings..., gains with units, filters, fs, delay)`` on one line, for a design's ``repr``."""
    tail = [] if filters is None else [filter_pack_text(filters)]
    if fs is not None:
        tail.append(f"fs={quantity(fs, 'Hz')}")
    if delay_samples is not None:
        tail.append(f"delay {delay_samples} sample{'' if delay_samples == 1 else 's'}")
    return call(name, [*settings, *params(gains, units), *tail])


def call(name: str, parts: Iterable[str]) -> str:
    """``name(part, part, ...)``."""
    return f"{name}({', '.join(p for p in parts if p)})"


def params(values: Mapping[str, object], units: Mapping[str, str] | None = None) -> list[str]:
    """``["name=value unit", ...]``."""
    units = units or {}
    return [f"{k}={quantity(v, units.get(k, ''))}" for k, v in values.items()]


# ------------------------------------------------------------------------------------------ HTML
def html_table(title: str, header: Sequence[str], rows: Sequence[Sequence[object]], note: str = "") -> str:
    """A small HTML table (numbers formatted by :func:`number`) under a bold title, for ``_repr_html_``."""
    esc = html.escape
    head = "".join(f"<th style='text-align:left'>{esc(str(h))}</th>" for h in header)
    body = "".join("<tr>" + "".join(f"<td>{esc(c if isinstance(c, str) else number(c))}</td>" for c in row)
                   + "</tr>" for row in rows)
    foot = f"<div style='color:#57606a;font-size:0.9em'>{esc(note)}</div>" if note else ""
    return (f"<div><b>{esc(title)}</b><table><thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>"
            f"{foot}</div>")


def text_table(header: Sequence[str], rows: Sequence[Sequence[object]], indent: str = "  ") -> str:
    """Rows as aligned plain-text columns (numbers by :func:`number`)."""
    cells = [[str(h) for h in header]] + [[c if isinstance(c, str) else number(c) for c in row] for row in rows]
    widths = [max(len(r[j]) for r in cells) for j in range(len(header))]
    return "\n".join(indent + "  ".join(c.ljust(w) for c, w in zip(r, widths, strict=True)).rstrip()
                     for r in cells)


# ------------------------------------------------------------------------------------------ value types
def frf_unit(frf) -> str:
    """Unit of an FRF's response: ``rad/V``, ``rad/s/V`` or ``rad/s^2/V`` for position, velocity, acceleration."""
    per = {"position": "", "velocity": "/s", "acceleration": "/s^2"}.get(frf.quantity, "")
    return f"{frf.output_unit}{per}/{frf.input_unit}"


def frf_parts(frf) -> list[str]:
    """The key facts of an FRF: channels, size, band, quantity and unit, coherence, source."""
    f = frf.freq_hz
    parts = [" ".join(frf.channels), f"{len(frf.outputs)}x{len(frf.inputs)}", f"{f.size} lines",
             span(f[0], f[-1], "Hz"), frf.quantity, frf_unit(frf)]
    if frf.coherence is not None and np.isfinite(frf.coherence).any():
        parts.append("coherence")
    if frf.position_m is not None:
        parts.append(f"x={quantity(frf.position_m, 'm')}")
    if frf.source != "FRF":
        parts.append(f"source={frf.source!r}")
    return parts


def frf_html(frf) -> str:
    """Per channel: band, peak magnitude and where, median coherence."""
    rows = []
    for ch in frf.channels:
        h = np.abs(frf.channel(ch))
        k = int(np.argmax(h))
        coh = frf.channel_coherence(ch)
        med = None if coh is None or not np.isfinite(coh).any() else float(np.nanmedian(coh))
        rows.append([ch, h[k], frf.freq_hz[k], med])
    return html_table(call("Frf", frf_parts(frf)), ["channel", f"max |H| [{frf_unit(frf)}]", "at [Hz]",
                                                     "median coherence [-]"], rows)


def log_parts(log) -> list[str]:
    """Samples, duration, sample rate, signals with units, source."""
    names = [f"{n} [{log.units.get(n) or '-'}]" for n in list(log.signals)[:8]]
    more = len(log.signals) - len(names)
    parts = [f"{log.n} samples", span(log.t[0], log.t[-1], "s"), f"fs={quantity(log.fs, 'Hz')}",
             " ".join(names) + (f" +{more} more" if more > 0 else "")]
    if log.source != "log":
        parts.append(f"source={log.source!r}")
    return parts


def log_html(log) -> str:
    """Per signal: unit, minimum, maximum, RMS."""
    rows = [[n, log.units.get(n) or "-", float(np.min(x)), float(np.max(x)), float(np.sqrt(np.mean(x * x)))]
            for n, x in log.signals.items()]
    return html_table(call("Log", log_parts(log)), ["signal", "unit", "min", "max", "RMS"], rows)


# ------------------------------------------------------------------------------------------ analyses
FIGURES = (("stable", "stable", ""), ("crossovers_hz", "crossovers", "Hz"), ("phase_margin_deg", "PM", "deg"),
           ("gain_margin_db", "GM", "dB"), ("ms", "Ms", "-"), ("disk_margin", "DM", "-"))
"""The figures of a case in reprs and tables: attribute, column title, unit."""


def _figure(metrics, attr):
    v = getattr(metrics, attr, None)
    if attr == "crossovers_hz":
        return ", ".join(number(x) for x in (v or [])) or "-"
    return v


def case_row(name: str, case) -> list:
    """One table row of an analysis case (None case: the FRF it needs is missing)."""
    if case is None:
        return [name, "(needs an FRF)"] + [""] * (len(FIGURES) - 1)
    return [name] + [_figure(case.metrics, a) for a, _, _ in FIGURES]


def analysis_rows(analysis) -> tuple[list[str], list[list]]:
    """Header and rows of an analysis' cases."""
    header = ["case"] + [f"{t} [{u}]" if u else t for _, t, u in FIGURES]
    return header, [case_row(n, c) for n, c in analysis.cases.items()]


def analysis_repr(analysis) -> str:
    """Class name, cases and their figures as a small text table."""
    header, rows = analysis_rows(analysis)
    n = sum(c is not None for c in analysis.cases.values())
    return f"{type(analysis).__name__}({n} of {len(analysis.cases)} cases)\n" + text_table(header, rows)


def analysis_html(analysis) -> str:
    """The cases and their figures as an HTML table."""
    header, rows = analysis_rows(analysis)
    return html_table(type(analysis).__name__, header, rows,
                      "Every figure of a case: analysis.CASE.NAME or analysis.cases['CASE'].NAME; to_dict(), "
                      "to_dataframe().")


def case_repr(case) -> str:
    """One case with its grid and figures."""
    f = case.freq_hz
    parts = [repr(case.name), f"{f.size} points", span(f[0], f[-1], "Hz")]
    parts += [f"{t}={quantity(_figure(case.metrics, a), u)}" for a, t, u in FIGURES]
    return call(type(case).__name__, parts)


def case_attribute(case, name: str):
    """A figure of a case by attribute: its metrics' attribute, else a key of its ``to_dict()``."""
    if name.startswith("_"):
        raise AttributeError(name)
    metrics = case.__dict__.get("metrics")
    if metrics is not None and hasattr(metrics, name):
        return getattr(metrics, name)
    d = case.to_dict() if metrics is not None else {}
    if name in d:
        return d[name]
    raise AttributeError(f"{type(case).__name__!r} has no attribute or figure {name!r}; figures: {', '.join(d)}")


def case_dir(case) -> list[str]:
    """Attributes of a case and the names of its figures (tab completion)."""
    return sorted(set(object.__dir__(case)) | set(case.to_dict()))


def analysis_case(analysis, name: str):
    """A case of an analysis by attribute (``analysis.discrete``); None when it needs a missing FRF."""
    cases = analysis.__dict__.get("cases")
    if name.startswith("_") or cases is None or name not in cases:
        raise AttributeError(f"{type(analysis).__name__!r} has no attribute or case {name!r}"
                             + (f"; cases: {', '.join(cases)}" if cases else ""))
    return cases[name]


def analysis_frame(analysis):
    """One row per case (index ``case``), one column per scalar figure of ``to_dict()`` (lists and dicts left out);
    cases without a result are rows of missing values."""
    import pandas as pd

    rows = {}
    for name, d in analysis.to_dict().items():
        d = d or {}
        rows[name] = {k: v for k, v in d.items() if v is None or isinstance(v, (bool, int, float, str, np.number))}
    frame = pd.DataFrame.from_dict(rows, orient="index")
    frame.index.name = "case"
    return frame


def run_parts(result) -> list[str]:
    """An experiment result: kind, log size and band, the first scalar figures of its summary, trip."""
    log = result.log
    parts = [repr(result.kind), f"{log.n} samples", span(log.t[0], log.t[-1], "s"), f"fs={quantity(log.fs, 'Hz')}"]
    shown = 0
    for k, v in (result.summary or {}).items():
        if shown < 4 and isinstance(v, (int, float, np.number)) and not isinstance(v, bool):
            parts.append(f"{k}={number(v)}")
            shown += 1
    if getattr(result.run, "tripped", False):
        parts.append("TRIPPED")
    return parts


# ------------------------------------------------------------------------------------------ facades
_FACADES: dict[str, Callable] = {}
"""``{name: function}`` registered by the facades above every package (:mod:`feedtune.plotting`,
:mod:`feedtune.interop_control`)."""


def register_facade(name: str, fn: Callable) -> Callable:
    """Register ``fn`` under ``name`` for the value types' ``.plot()``, ``.to_control()`` and ``.from_control()``.

    The facades call this at import time and the package root imports them (on the first :func:`facade` call), so
    the value types at the bottom reach them through :func:`facade` without importing them (no import cycle, eager or
    lazy). Returns ``fn``.
    """
    _FACADES[name] = fn
    return fn


def facade(name: str) -> Callable:
    """The function a facade registered under ``name`` (see :func:`register_facade`).

    Examples
    --------
    >>> facade("plot_frf").__module__
    'feedtune.plotting'
    """
    if name not in _FACADES:
        from . import _load_facades

        _load_facades()
    try:
        return _FACADES[name]
    except KeyError:
        raise RuntimeError(f"no facade function {name!r} is registered; feedtune.plotting and "
                           "feedtune.interop_control register theirs") from None


# ------------------------------------------------------------------------------------------ mixins
class CaseDisplay:
    """Notebook access shared by the analysis cases (ball screw, gantry, axis): figures as attributes
    (``case.ms``), a short repr and ``plot()``. The dataclass using it is declared with ``repr=False``."""

    def __getattr__(self, name: str):
        """A figure by name: ``case.ms``, ``case.gain_margin_db`` (the metrics', then ``to_dict()``'s)."""
        return case_attribute(self, name)

    def __dir__(self) -> list[str]:
        return case_dir(self)

    def __repr__(self) -> str:
        return case_repr(self)

    def plot(self, kind: str = "loop"):
        """This case: ``loop``, ``nyquist``, ``sensitivity``, ``tracking`` or ``disturbance``
        (:func:`feedtune.plotting.plot_analysis`); returns the matplotlib Figure."""
        return facade("plot_analysis")(self, kind)


class AnalysisDisplay:
    """What the analyses of every machine share (``cases``: ``{name: case or None}``): ``to_dict()``, a case by
    attribute (``analysis.discrete``), a short repr and HTML table, ``to_dataframe()`` and ``plot()``. The dataclass
    using it is declared with ``repr=False``."""

    cases: dict

    def to_dict(self) -> dict:
        """``{case: figures or None}``."""
        return {name: (c.to_dict() if c is not None else None) for name, c in self.cases.items()}

    def __getattr__(self, name: str):
        """A case by name: ``analysis.discrete`` is ``analysis.cases["discrete"]``."""
        return analysis_case(self, name)

    def __dir__(self) -> list[str]:
        return sorted(set(object.__dir__(self)) | set(self.__dict__.get("cases", {})))

    def __repr__(self) -> str:
        return analysis_repr(self)

    def _repr_html_(self) -> str:
        return analysis_html(self)

    def to_dataframe(self):
        """The scalar figures of ``to_dict()`` as a pandas DataFrame, one row per case."""
        return analysis_frame(self)

    def plot(self, kind: str = "loop", *, cases=None):
        """Every case (or ``cases``) in one figure: ``loop``, ``nyquist``, ``sensitivity``, ``tracking`` or
        ``disturbance`` (:func:`feedtune.plotting.plot_analysis`); returns the matplotlib Figure."""
        return facade("plot_analysis")(self, kind, cases=cases)
