"""Helpers shared by the report's section builders: names, labels, colours, limits and small tables."""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path

from ..analysis.limits import DEFAULT_LIMITS, Limits
from ..structures import controller_title, controllers
from .content import Cell, Table, text_cell
from .figures import PALETTE

BASELINE_CONTROLLERS = tuple(c.title for c in controllers() if c.baseline)
"""Labels taken as the baseline of improvement percentages (the industry controllers: P-PI, PID), in this order."""


@dataclass(frozen=True)
class ReportLimits:
    """What the report holds designs and data to.

    Attributes
    ----------
    policy : Limits
        The stability and robustness limits (:mod:`feedtune.analysis.limits`), the same as ``design`` and
        ``analyze`` use; default: the ``textbook`` profile.
    coherence_min : float
        Coherence [-] below which FRF points inside the fit band are flagged.
    coherence_trust : float
        Coherence [-] below which the lines of a measured FRF are left out of the curves drawn from it (loop,
        sensitivity, Nyquist, tracking) and end the band that supports a tracking bandwidth.
    nrmse_max : float
        Normalised RMS fit error [-] above which a model fit is called poor.
    saturation_samples : int
        Consecutive samples at the command's largest magnitude that count as saturation.
    u_max : float or None
        Command saturation level [command unit] for the margin of every run; None: the log's ``u_max`` metadata,
        else the twin's default for twin logs, else unknown (no margin shown).
    """

    policy: Limits = DEFAULT_LIMITS
    coherence_min: float = 0.8
    nrmse_max: float = 0.2
    saturation_samples: int = 10
    coherence_trust: float = 0.5
    u_max: float | None = None

    @property
    def ms_max(self) -> float | None:
        """The policy's peak-sensitivity limit [-] (drawn in the sensitivity figures)."""
        return self.policy.ms_max

    def to_dict(self) -> dict:
        """JSON-ready thresholds with units in the keys."""
        return {**self.policy.to_dict(), "coherence_min": self.coherence_min, "nrmse_max": self.nrmse_max,
                "saturation_samples": self.saturation_samples, "coherence_trust": self.coherence_trust,
                "u_max": self.u_max}


def controller_label(name: str | None) -> str:
    """``"mcppc"`` -> ``"MC-PPC"`` (:func:`feedtune.structures.controller_title`); other names unchanged; empty ->
    ``"controller"``."""
    return controller_title(name)


def display_names(paths: Iterable[Path]) -> dict[Path, str]:
    """A unique short name per file: the file name, or the path where two files share a name."""
    paths = list(paths)
    counts: dict[str, int] = {}
    for p in paths:
        counts[p.name] = counts.get(p.name, 0) + 1
    return {p: (p.name if counts[p.name] == 1 else str(p)) for p in paths}


@dataclass
class Colors:
    """Colours handed out to labels in order of first use (the same label keeps its colour everywhere)."""

    assigned: dict = field(default_factory=dict)

    def __call__(self, label: str) -> str:
        if label not in self.assigned:
            self.assigned[label] = PALETTE[len(self.assigned) % len(PALETTE)]
        return self.assigned[label]


def baseline_of(labels: list[str]) -> str | None:
    """The label improvements are measured against: P-PI (or PID) when present, else the last one."""
    if len(labels) < 2:
        return None
    for base in BASELINE_CONTROLLERS:
        for label in labels:
            if label == base or label.startswith(base + " "):
                return label
    return labels[-1]


def improvement_pct(value: float | None, baseline: float | None) -> float | None:
    """``100 (1 - value / baseline)`` [%]: the reduction of an error relative to the baseline."""
    if value is None or baseline is None or not baseline or not math.isfinite(value) or not math.isfinite(baseline):
        return None
    return 100.0 * (1.0 - value / baseline)


def quantity_value(entry) -> tuple[float | None, str]:
    """``(value, unit)`` of a document entry ``{value, unit}`` or a bare number (``(None, "")`` otherwise)."""
    if isinstance(entry, Mapping) and "value" in entry:
        v = entry.get("value")
        return (float(v) if isinstance(v, (int, float)) and not isinstance(v, bool) else None), str(
            entry.get("unit", ""))
    if isinstance(entry, (int, float)) and not isinstance(entry, bool):
        return float(entry), ""
    return None, ""


def parameter_table(title: str, params: Mapping, key: list, *, std: Mapping | None = None,
                    units: Mapping | None = None, note: str = "", lower: Mapping | None = None) -> Table:
    """Parameters ``{name: {value, unit} or number}`` with their standard deviations when given.

    ``key`` is the data path of ``params``; values are looked up as ``key + [name, "value"]`` for quantities
    and ``key + [name]`` for bare numbers. ``std`` values sit at ``std_key`` (``std["__key__"]``). A value on its
    ``lower`` bound (``{name: bound}``, :func:`feedtune.display.at_lower_bound`: a bounded fit leaves it there up to
    rounding, ``b1 = 3e-33`` with a std of ``1e-3``) reads ``0 V/(rad/s) (at its lower bound)``, as the identify
    command prints it.
    """
    from ..display import at_lower_bound, quantity

    std = dict(std or {})
    std_key = std.pop("__key__", None)
    rows = []
    for name, entry in params.items():
        value, unit = quantity_value(entry)
        if value is None:
            continue
        unit = unit or str((units or {}).get(name, ""))
        unit = "" if unit == "-" else unit
        vkey = [*key, name, "value"] if isinstance(entry, Mapping) else [*key, name]
        s = std.get(name)
        sv = float(s) if isinstance(s, (int, float)) and not isinstance(s, bool) else None
        bound = (lower or {}).get(name)
        on_bound = at_lower_bound(value, sv, bound)
        row = [text_cell(name), text_cell(f"{quantity(bound, unit)} (at its lower bound)") if on_bound
               else Cell(value, unit, key=vkey)]
        if std:
            row.append(Cell(sv, unit, key=None if sv is None or std_key is None else [*std_key, name]))
            rel = None if sv is None or not value or on_bound else 100.0 * sv / abs(value)
            row.append(text_cell("> 1000 %") if rel is not None and rel > 1000 else Cell(rel, "%"))
        rows.append(row)
    columns = ["parameter", "value", "standard deviation", "relative std"] if std else ["parameter", "value"]
    return Table(title, columns, rows, note)


def tuning_table(entries: list[tuple[str, Mapping | None]]) -> Table:
    """How each design was chosen: ``[(label, the gains file's [design] table)]`` -> rule, limits, checked case,
    the limit that stopped the search and the first crossover it reached (the rule every comparison states)."""
    rows = []
    for label, design in entries:
        design = design if isinstance(design, Mapping) else {}
        rule = design.get("rule") or design.get("method") or "given in the gains file"
        limits = design.get("limits") if isinstance(design.get("limits"), Mapping) else {}
        active = design.get("active_limit")
        active = active.get("name") if isinstance(active, Mapping) else active
        first, _ = quantity_value(design.get("first_crossover_hz"))
        gain = design.get("integral_gain") if isinstance(design.get("integral_gain"), Mapping) else {}
        rows.append([text_cell(label), text_cell(str(rule)), text_cell(str(design.get("objective", "-"))),
                     text_cell(limits.get("profile", "-")),
                     text_cell(str(design.get("checked_case", "-"))), text_cell(str(active or "-")),
                     Cell(first, "Hz"),
                     text_cell(f"{gain['name']} {gain['value']:.4g} {gain['unit']}" if gain else "-")])
    return Table("How each design was chosen (the tuning rule in the gains file)",
                 ["controller", "rule", "objective", "limits", "checked case", "limit reached", "first crossover",
                  "integral gain"], rows,
                 "A comparison is fair when every structure was tuned by the same rule under the same limits "
                 "(docs/verdicts.md).")
