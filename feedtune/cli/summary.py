"""The human-readable summary of a design or its analysis, the same for every machine.

``design ppc|ppi|gantry|pid|loopshape`` and ``analyze GAINS`` print it from their ``--json`` result: the gains with
their units, then one line per analysis case with every crossover, the worst phase and gain margins and where they
occur, the peak sensitivity and where, the disk margin, every ``|S| < 1`` band and the Nyquist verdict.
"""

from __future__ import annotations

import typer

from ..control.names import CONTROLLER_NAMES, controller_name
from ..structures import gains_formats
from .common import fmt

__all__ = ["CONTROLLER_NAMES", "print_design_summary"]
MAX_LISTED = 4
"""Crossovers and bands listed per case before ``+N more``."""


def _listed(items: list[str]) -> str:
    if not items:
        return "-"
    more = f" +{len(items) - MAX_LISTED}" if len(items) > MAX_LISTED else ""
    return ", ".join(items[:MAX_LISTED]) + more


def hz(x: float) -> str:
    """A frequency [Hz] to the resolution that means something: 1234, 123.4, 12.34, 1.234."""
    if x >= 1000:
        return f"{x:.0f}"
    return f"{x:.4g}" if x >= 1 else f"{x:.3g}"


def _at(value, freq, digits: int = 3) -> str:
    if value is None:
        return "-"
    return f"{value:.{digits}g} @{hz(freq)}" if freq is not None else f"{value:.{digits}g}"


def _worst_freq(entries: list[dict], key: str, value) -> float | None:
    return next((e["freq_hz"] for e in entries if e[key] == value), None)


def print_design_summary(result: dict) -> None:
    """Print the gains and the per-case table of a design or analysis result (``--json`` layout: ``gains`` as
    ``{"value", "unit", "std"}`` entries, or plain numbers in ``gain_units``)."""
    controller = result.get("controller", result.get("gains_kind"))
    name = controller_name(controller)
    units = result.get("gain_units", {})
    typer.echo(f"{name} gains:")
    for k, v in result["gains"].items():
        value, unit = (v["value"], v["unit"]) if isinstance(v, dict) else (v, units.get(k, ""))
        typer.echo(f"  {k:9s} = {fmt(value, unit, 6)}")
    for stage in result.get("lead_stages", []):
        typer.echo(f"  lead stage {stage['phase_deg']:.1f} deg at {stage['center_hz']:.4g} Hz "
                   f"(zero {stage['zero_hz']:.4g} Hz, pole {stage['pole_hz']:.4g} Hz, gamma {stage['gamma']:.3g})")
    kind = result.get("gains_kind", result.get("kind"))
    fmt_ = next((g for g in gains_formats() if g.kind == kind), None)
    head = f"{fmt_.loop if fmt_ else ''} crossovers [Hz]".strip()
    typer.echo(f"{'case':15s} {head:30s} {'PM [deg] @Hz':>15s} {'GM [dB] @Hz':>15s} "
               f"{'Ms @Hz':>14s} {'disk':>5s}  {'|S|<1 bands [Hz]':28s} stable")
    for case, a in result["analysis"].items():
        if a is None:
            typer.echo(f"{case:15s} (needs --frf)")
            continue
        xo = _listed([hz(x) for x in a["crossovers_hz"]])
        pm = _at(a["phase_margin_deg"], _worst_freq(a["phase_margins"], "pm_deg", a["phase_margin_deg"]))
        gm = _at(a["gain_margin_db"], _worst_freq(a["gain_margins"], "gm_db", a["gain_margin_db"]))
        ms = _at(a["ms"], a["ms_freq_hz"])
        dm = fmt(a.get("disk_margin"), "", 2)
        bands = _listed([f"{hz(lo) if lo > 0 else '0'}-{hz(hi)}" for lo, hi in a["rejection_bands_hz"]])
        typer.echo(f"{case:15s} {xo:30s} {pm:>15s} {gm:>15s} {ms:>14s} {dm:>5s}  {bands:28s} "
                   f"{'yes' if a['stable'] else 'NO'}")
    typer.echo(fmt_.legend if fmt_ and fmt_.legend else
               "PM, GM: the worst over every crossover; disk = balanced disk margin alpha")
    print_case_legend(result["analysis"])
    ideal = result["analysis"].get("ideal") or {}
    if ideal.get("disturbance_min_real_rad_per_V") is not None:
        unit = result.get("command_unit", "V")
        typer.echo(f"d2->x2 most negative real part: {ideal['disturbance_min_real_rad_per_V']:.4g} rad/{unit} at "
                   f"{ideal['disturbance_min_real_freq_hz']:.1f} Hz (ideal)")


def print_case_legend(cases) -> None:
    """Two lines naming the analysis cases of ``cases`` by their long titles (the report's)."""
    from ..analysis.cases import CASE_TITLES

    named = [f"{c} = {CASE_TITLES[c]}" for c in cases if c in CASE_TITLES]
    for i in range(0, len(named), 2):
        typer.echo(("cases: " if i == 0 else "       ") + "; ".join(named[i:i + 2]))
