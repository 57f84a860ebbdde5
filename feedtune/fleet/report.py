"""The fleet's page: one self-contained HTML file with a row per axis.

Per axis: a traffic light (:mod:`feedtune.fleet.status`), the newest certificate (verdict, the binding limit and
its slack, Ms, phase, gain and disk margins), the drifting parameters with their change and slope, an inline SVG
sparkline of each (the measurements, the fitted line since the change began, the alarm marked; the stiffness when
nothing drifts), the forecast with its interval, the proposed re-tune and a link to the axis' own report. Worst
first: red, amber, green, grey; within a light, the earliest forecast and the smallest slack first.

Everything that comes from files (names, paths, messages, units) is escaped; links are relative paths or http(s)
addresses (anything else is shown as text). No scripts, styles or images from elsewhere: the page opens offline.
"""

from __future__ import annotations

import html
import math
import os
from pathlib import Path
from urllib.parse import quote, urlsplit

import numpy as np

from .history import unit_of
from .status import LIGHTS, LIMIT_NAMES, AxisStatus, FleetStatus

LIGHT_COLOURS = {"red": "#cf222e", "amber": "#bf8700", "green": "#1a7f37", "grey": "#8c959f"}
NAMES = {**LIMIT_NAMES, "k": "stiffness k", "m1": "m1", "m2": "m2", "c": "nut damping c",
         "coulomb": "Coulomb friction", "viscous": "viscous friction", "mode_hz": "axial mode"}
LIMIT_UNITS = {"ms": "", "pm_deg": " deg", "gm_db": " dB", "disk_margin": "", "band_top": ""}

CSS_EXTRA = """
td.light { width: 1.6em; text-align: center; }
span.dot { display: inline-block; width: 0.95em; height: 0.95em; border-radius: 50%; vertical-align: -0.1em; }
svg.spark { vertical-align: middle; margin: 1px 4px 1px 0; }
.muted { color: var(--muted); }
ul.counts { list-style: none; padding: 0; display: flex; gap: 18px; margin: 8px 0; }
td.reason { max-width: 22em; }
"""


def _esc(text) -> str:
    return html.escape("" if text is None else str(text), quote=True)


def _fmt(v, digits: int = 3, unit: str = "") -> str:
    if v is None or (isinstance(v, float) and not math.isfinite(v)):
        return "-"
    return f"{float(v):.{digits}g}{unit}"


def _href(target: str | None, page_dir: Path, base: Path) -> str | None:
    """A safe link from the page to ``target`` (a path relative to ``base`` or an http(s) address); None when the
    target is another kind of address (``javascript:``, ``data:``)."""
    if not target:
        return None
    parts = urlsplit(target)
    if parts.scheme in ("http", "https"):
        return target
    if parts.scheme and len(parts.scheme) > 1:  # not a Windows drive letter
        return None
    path = Path(target)
    path = path if path.is_absolute() else base / path
    rel = os.path.relpath(path, page_dir)
    return quote(Path(rel).as_posix())


def sparkline(trend, *, width: int = 116, height: int = 26, alarm: bool = True, label: str = "") -> str:
    """An inline SVG of a trend: the measurements, the fitted line since the change began and the alarm (a red
    dot); ``label`` becomes its tooltip."""
    t, y = np.asarray(trend.weeks, float), np.asarray(trend.values, float)
    if y.size == 0:
        return ""
    line_t = np.array([t[trend.since], t[-1]])
    line_y = trend.level + trend.slope * (line_t - t[-1])
    lo, hi = float(min(y.min(), line_y.min())), float(max(y.max(), line_y.max()))
    span = hi - lo or abs(hi) or 1.0
    t0, t1 = float(t.min()), float(t.max()) if t.max() > t.min() else float(t.min()) + 1.0
    pad = 3.0

    def xy(tt, yy):
        x = pad + (tt - t0) / (t1 - t0) * (width - 2 * pad)
        return x, height - pad - (yy - lo) / span * (height - 2 * pad)

    pts = " ".join(f"{x:.1f},{yv:.1f}" for x, yv in (xy(a, b) for a, b in zip(t, y, strict=True)))
    colour = LIGHT_COLOURS["amber"] if alarm and trend.alarm else LIGHT_COLOURS["grey"]
    (x0, y0), (x1, y1) = xy(line_t[0], line_y[0]), xy(line_t[1], line_y[1])
    parts = [f'<svg class="spark" width="{width}" height="{height}" viewBox="0 0 {width} {height}" '
             f'xmlns="http://www.w3.org/2000/svg" role="img"><title>{_esc(label)}</title>',
             f'<polyline fill="none" stroke="#57606a" stroke-width="1" points="{pts}"/>',
             f'<line x1="{x0:.1f}" y1="{y0:.1f}" x2="{x1:.1f}" y2="{y1:.1f}" stroke="{colour}" stroke-width="1.6"/>']
    if trend.alarm_index is not None:
        ax, ay = xy(t[trend.alarm_index], y[trend.alarm_index])
        parts.append(f'<circle cx="{ax:.1f}" cy="{ay:.1f}" r="2.4" fill="{LIGHT_COLOURS["red"]}"/>')
    parts.append("</svg>")
    return "".join(parts)


def _sort_key(a: AxisStatus):
    weeks = a.forecast.weeks if a.forecast is not None and a.forecast.weeks is not None else math.inf
    slack = a.newest.get("active_slack") if a.newest else None
    return (LIGHTS.index(a.light), weeks, slack if slack is not None else math.inf, a.axis_id)


def _binding(row: dict | None) -> str:
    if not row or row.get("active_limit") is None:
        return "-"
    name = row["active_limit"]
    unit = LIMIT_UNITS.get(name, "")
    slack = row.get("active_slack")
    text = f"{NAMES.get(name, name)} {_fmt(row.get('active_value'))}{unit} (limit {_fmt(row.get('active_bound'))}{unit}"
    text += f", slack {100 * slack:.0f} %)" if slack is not None else ")"
    return _esc(text)


def _drift_cell(a: AxisStatus) -> str:
    row = a.newest or {}
    if not a.alarms:
        tr = a.trends.get("k")
        if tr is None:
            return '<span class="muted">-</span>'
        unit = unit_of("k", row)
        label = f"stiffness k [{unit}]: no drift beyond the noise; slope {100 * tr.slope_relative:+.2f} %/week"
        return sparkline(tr, alarm=False, label=label) + '<span class="muted">none</span>'
    out = []
    for name in a.alarms:
        tr = a.trends[name]
        unit = unit_of(name, row)
        label = (f"{NAMES.get(name, name)} [{unit}]: {', '.join(_fmt(v, 4) for v in tr.values)}; "
                 f"{100 * tr.change:+.1f} % since the change began, {100 * tr.slope_relative:+.2f} %/week")
        out.append(f"{sparkline(tr, label=label)}{_esc(NAMES.get(name, name))} {100 * tr.change:+.1f} % "
                   f"({100 * tr.slope_relative:+.2f} %/week)")
    return "<br>".join(out)


def _forecast_cell(a: AxisStatus) -> str:
    fc = a.forecast
    if a.forecast_error:
        return _esc(a.forecast_error)
    if fc is None:
        return '<span class="muted">no drift of the model</span>' if a.rows else "-"
    early, late = fc.early, fc.late
    interval = f"{_fmt(early, 2)}-{_fmt(late, 2) if late is not None else f'>{fc.horizon_weeks:g}'} weeks"
    if fc.weeks is None:
        return _esc(f"no failure within {fc.horizon_weeks:g} weeks (90 % interval from {_fmt(early, 2)} weeks)"
                    if early is not None else f"no failure within {fc.horizon_weeks:g} weeks")
    what = NAMES.get(fc.limit or "", fc.limit or "a limit")
    return _esc(f"{what} fails {fc.date(fc.weeks)} (in {fc.weeks:.1f} weeks; 90 %: {interval})")


def _proposal_cell(a: AxisStatus, page_dir: Path, history: Path) -> str:
    p = a.proposal
    if not p:
        return "-"
    href = _href(p["file"], page_dir, history)
    text = (f"{p.get('controller') or ''}: crossover {_fmt(p.get('first_crossover_hz'))} Hz, "
            f"Ms {_fmt(p.get('ms'))}, certified")
    return f'<a href="{_esc(href)}">{_esc(text)}</a>' if href else _esc(text)


def _axis_cell(a: AxisStatus, page_dir: Path, base: Path) -> str:
    name = _esc(a.axis_id)
    href = _href(a.report, page_dir, base)
    return f'<a href="{_esc(href)}">{name}</a>' if href else name


def fleet_html(status: FleetStatus, page: Path) -> str:
    """The page's HTML text (module docstring); links relative to the folder of ``page``."""
    from .. import __version__
    from ..report.html import CSS

    page_dir = Path(page).resolve().parent
    base = Path(status.manifest).parent
    history = Path(status.history).resolve()
    counts = status.counts()
    rows = []
    for a in sorted(status.axes, key=_sort_key):
        n = a.newest or {}
        date = n.get("measured_at")
        rows.append(
            "<tr>"
            f'<td class="light"><span class="dot" title="{_esc(a.light)}" '
            f'style="background:{LIGHT_COLOURS[a.light]}"></span></td>'
            f"<td>{_axis_cell(a, page_dir, base)}</td>"
            f"<td>{_esc(date.date().isoformat() if date else '-')}<br><span class=\"muted\">{len(a.rows)} "
            f"measured{', ' + str(len(a.pending)) + ' pending' if a.pending else ''}</span></td>"
            f"<td class=\"reason\">{_esc(a.reason)}</td>"
            f"<td>{_binding(n)}</td>"
            f'<td class="num">{_fmt(n.get("ms"))}</td><td class="num">{_fmt(n.get("pm_deg"))}</td>'
            f'<td class="num">{_fmt(n.get("gm_db"))}</td><td class="num">{_fmt(n.get("disk_margin"))}</td>'
            f"<td>{_drift_cell(a)}</td><td>{_forecast_cell(a)}</td>"
            f"<td>{_proposal_cell(a, page_dir, history)}</td>"
            "</tr>")
    warnings = "".join(f'<div class="warning">{_esc(w)}</div>' for w in status.warnings)
    newest = max((a.newest["measured_at"] for a in status.axes if a.newest), default=None)
    settings = status.settings
    lights = "".join(f'<li><span class="dot" style="background:{LIGHT_COLOURS[k]}"></span> {_esc(k)}: {v}</li>'
                     for k, v in counts.items())
    return f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><meta name="viewport" content="width=device-width, initial-scale=1">
<title>{_esc(status.name)}: fleet report</title><style>{CSS}{CSS_EXTRA}</style></head><body>
<header><h1>{_esc(status.name)}</h1>
<p class="meta">{len(status.axes)} axes; newest measurement {_esc(newest.date().isoformat() if newest else '-')};
manifest {_esc(status.manifest)}; history {_esc(status.history)}; feedtune {_esc(__version__)}</p></header>
<ul class="counts">{lights}</ul>
{warnings}
<p class="note">Red: the installed gains fail the limits on the newest measurement. Amber: they pass, but a parameter
drifts beyond its noise (self-starting CUSUM, false alarms {100 * settings.false_alarm:.2g} % per parameter in
{settings.horizon} measurements) or a failure is forecast within {status.horizon_weeks:g} weeks (the installed gains
certified on the newest FRFs carried forward by the drift; 90 % interval from the trend's uncertainty). Green:
nothing of that. Sparklines: the measurements, the fitted line since the change began, the alarm (red dot).
docs/fleet.md says how each number is computed.</p>
<div class="table-wrap"><table>
<thead><tr><th></th><th>axis</th><th>newest</th><th>status</th><th>binding limit</th><th>Ms</th><th>PM [deg]</th>
<th>GM [dB]</th><th>disk margin</th><th>drift</th><th>forecast</th><th>proposed re-tune</th></tr></thead>
<tbody>
{chr(10).join(rows)}
</tbody></table></div>
</body></html>
"""


def write_fleet_report(status: FleetStatus, path, *, force: bool = False) -> dict:
    """Write the page atomically; ``{"file", "size_bytes", "axes", "counts"}``."""
    from ..io.atomic import atomic_write_text, ensure_writable

    p = ensure_writable(path, force)
    text = fleet_html(status, p)
    atomic_write_text(p, text, force=force)
    return {"file": str(p), "size_bytes": len(text.encode("utf-8")), "axes": len(status.axes),
            "counts": status.counts()}
