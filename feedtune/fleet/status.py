"""The state of a fleet from its history: per axis the newest certificate, the drift of every parameter, the
forecast of when the installed gains fail, a proposed re-tune, and one traffic light.

Traffic light of an axis:

* ``red``: the newest measurement's certificate fails (or could not be computed);
* ``amber``: it passes, but a parameter drifts beyond its noise (:mod:`feedtune.fleet.drift`) or the installed
  gains are forecast to fail within the horizon (:mod:`feedtune.fleet.forecast`);
* ``green``: it passes, nothing drifts, no failure forecast;
* ``grey``: no measurement of the axis in the history yet.

Only the rows of the measurements the manifest lists now are used (the history keeps rows of files since replaced
or removed: ``stale_rows``); a measurement of the manifest without a row is ``pending`` (not run yet, or its run
failed for a reason of the machine, not of the data).
"""

from __future__ import annotations

import datetime as _dt
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .drift import TRENDED_PARAMETERS, WEEK_S, DriftSettings, Trend, alarm_of, pooled_scatter, trend
from .forecast import RECENT, DriftLine, Forecast, ForecastTask, run_forecast
from .history import PROPOSALS
from .snapshot import MODEL_PARAMETERS, finite, fit_of, has_fit, snapshot

LIMIT_NAMES = {"ms": "Ms", "pm_deg": "PM", "gm_db": "GM", "disk_margin": "disk margin", "stable": "stability",
               "band_top": "the loop at the FRF's last line"}
"""Short names of the limits (``LimitItem.name``) in texts."""
HORIZON_WEEKS = 26.0
"""How far ahead a failure is forecast (and makes an axis amber) [weeks]."""
LIGHTS = ("red", "amber", "green", "grey")


@dataclass(frozen=True)
class AxisStatus:
    """One axis (module docstring).

    Attributes
    ----------
    axis_id, machine, axis : str
    light : str
        ``red``, ``amber``, ``green`` or ``grey``.
    reason : str
        Why, in a few words.
    rows : list of dict
        The axis' history rows of the manifest's measurements, oldest first.
    pending : list of str
        Dates of the manifest's measurements without a row.
    trends : dict of str to Trend
    alarms : tuple of str
        Parameters that drift beyond their noise.
    forecast : Forecast or None
    forecast_error : str or None
    proposal : dict or None
        ``file`` (relative to the history) and the re-tune's certificate summary.
    report : str or None
        Link to the axis' own report (from the manifest).
    gains_file : str
    """

    axis_id: str
    machine: str
    axis: str
    light: str
    reason: str
    rows: list
    pending: list
    trends: dict
    alarms: tuple
    forecast: Forecast | None
    forecast_error: str | None
    proposal: dict | None
    report: str | None
    gains_file: str

    @property
    def newest(self) -> dict | None:
        """The newest row, or None."""
        return self.rows[-1] if self.rows else None

    def to_dict(self, series: bool = True) -> dict:
        """JSON-ready; ``series``: with every trend's measurements."""
        newest = self.newest
        figures = None
        if newest is not None:
            figures = {k: _plain(newest.get(k)) for k in (
                "key", "verdict", "error", "cert_ok", "stable", "first_crossover_hz", "ms", "ms_freq_hz", "pm_deg",
                "gm_db", "disk_margin", "violations", "k", "mode_hz", "coulomb", "input_unit")}
            figures["date"] = _iso(newest.get("measured_at"))
            figures["active_limit"] = None if newest.get("active_limit") is None else {
                "name": newest.get("active_limit"), "value": newest.get("active_value"),
                "limit": newest.get("active_bound"), "slack": newest.get("active_slack")}
        alarms = []
        for name in self.alarms:
            tr = self.trends[name]
            dates = _dates_of(tr, self.rows)
            alarms.append({"name": name, "direction": "rise" if tr.direction > 0 else "fall",
                           "change_pct": _num(100 * tr.change), "slope_pct_per_week": _num(100 * tr.slope_relative),
                           "since": _iso(dates[tr.since]), "alarm_date": _iso(dates[tr.alarm_index])})
        return {"axis_id": self.axis_id, "machine": self.machine, "axis": self.axis, "light": self.light,
                "reason": self.reason, "measurements": len(self.rows), "pending": list(self.pending),
                "errors": sum(1 for r in self.rows if r.get("error")), "gains_file": self.gains_file,
                "report": self.report, "newest": figures, "alarms": alarms,
                "forecast": None if self.forecast is None else self.forecast.to_dict(),
                "forecast_error": self.forecast_error, "proposal": self.proposal,
                "trends": {k: t.to_dict(series) for k, t in self.trends.items()}}


@dataclass(frozen=True)
class FleetStatus:
    """Every axis of a fleet and how the drift was judged."""

    name: str
    manifest: str
    history: str
    axes: tuple[AxisStatus, ...]
    settings: DriftSettings
    scatter: dict
    horizon_weeks: float
    stale_rows: int = 0
    warnings: tuple[str, ...] = field(default_factory=tuple)

    def counts(self) -> dict:
        """Axes per light."""
        return {light: sum(1 for a in self.axes if a.light == light) for light in LIGHTS}

    def to_dict(self, series: bool = True) -> dict:
        """JSON-ready (docs/json.md, ``fleet report``)."""
        return {"fleet": self.name, "manifest": self.manifest, "history": self.history, "counts": self.counts(),
                "drift": {**self.settings.to_dict(), "scatter": self.scatter}, "horizon_weeks": self.horizon_weeks,
                "stale_rows": self.stale_rows, "axes": [a.to_dict(series) for a in self.axes],
                "warnings": list(self.warnings)}


def _plain(v):
    if isinstance(v, (_dt.datetime, _dt.date)):
        return v.isoformat()
    if isinstance(v, float) and not np.isfinite(v):
        return None
    return v


def _num(v) -> float | None:
    v = float(v)
    return v if np.isfinite(v) else None


def _iso(v) -> str | None:
    if v is None:
        return None
    return v.date().isoformat() if isinstance(v, _dt.datetime) else str(v)


def _dates_of(tr: Trend, rows: list) -> list:
    """The dates of a trend's measurements (rows without the parameter are not in the trend)."""
    return [r["measured_at"] for r in rows if finite(r.get(tr.name))]


# ------------------------------------------------------------------------------------------ building it
def _weeks(rows: list) -> np.ndarray:
    t0 = rows[0]["measured_at"]
    return np.array([(r["measured_at"] - t0).total_seconds() / WEEK_S for r in rows])


def _series(rows: list, name: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    use = [r for r in rows if finite(r.get(name))]
    if not use:
        return np.zeros(0), np.zeros(0), np.zeros(0)
    t = _weeks(rows)[[i for i, r in enumerate(rows) if finite(r.get(name))]]
    y = np.array([float(r[name]) for r in use])
    s = np.array([float(r[f"{name}_std"]) if finite(r.get(f"{name}_std")) else 0.0 for r in use])
    return t, y, s


def axis_rows(table, manifest, keys: Mapping[str, str]) -> tuple[dict[str, list], int]:
    """``{axis_id: rows oldest first}`` of the measurements the manifest lists (``keys``: key -> axis_id), and how
    many history rows are not among them."""
    rows = table.to_pylist()
    out: dict[str, list] = {a.id: [] for a in manifest.axes}
    stale = 0
    for r in rows:
        if keys.get(r["key"]) == r["axis_id"] and r["axis_id"] in out:
            out[r["axis_id"]].append(r)
        else:
            stale += 1
    for v in out.values():
        v.sort(key=lambda r: (r["measured_at"], r["key"]))
    return out, stale


def fleet_status(manifest, history, plan, engine=None, *, settings: DriftSettings | None = None,
                 horizon_weeks: float = HORIZON_WEEKS, until: _dt.datetime | None = None) -> FleetStatus:
    """The status of every axis of ``manifest`` from the rows in ``history`` (module docstring).

    Parameters
    ----------
    manifest : Manifest
    history : path-like
        The history folder.
    plan : Plan
        The manifest's measurements and their keys (:func:`feedtune.fleet.run.plan_fleet`).
    engine : Engine, optional
        Runs the forecasts (default: this process).
    settings : DriftSettings, optional
    horizon_weeks : float
        How far ahead failures are forecast [weeks].
    until : datetime.datetime, optional
        The fleet as it was then: the measurements taken later are left out (audits; the forecasts a fleet run
        would have made on that day).
    """
    from .. import progress
    from .engine import Engine, TaskFailed
    from .history import read_history

    settings = settings or DriftSettings()
    if not (np.isfinite(horizon_weeks) and horizon_weeks > 0):
        from ..errors import UsageError

        raise UsageError(f"horizon_weeks must be > 0, got {horizon_weeks!r}", parameter="horizon_weeks")
    table = read_history(history)
    by_axis, stale = axis_rows(table, manifest, plan.keys)
    ok_rows = {a: [r for r in rows if until is None or r["measured_at"] <= until] for a, rows in by_axis.items()}
    scatter = {}
    warnings = []
    for name in TRENDED_PARAMETERS:
        tau, n = pooled_scatter([_series(rows, name) for rows in ok_rows.values() if rows])
        scatter[name] = {"relative": tau, "residuals": n}
        if 0 < n < 10 and name in ("k", "coulomb"):
            warnings.append(f"the scatter of {name} between measurements rests on {n} residuals only: alarms may "
                            "come early; the estimate firms up with more measurements and axes")
    trends = {axis_id: axis_trends(rows, scatter, settings) for axis_id, rows in ok_rows.items()}
    tasks = []
    for entry in manifest.axes:
        task = forecast_task(entry, manifest, ok_rows[entry.id], trends[entry.id], plan, horizon_weeks)
        if task is not None:
            tasks.append(task)
    forecasts: dict[str, object] = {}
    if tasks:
        engine = engine or Engine(jobs=1)
        with progress.task("forecasts", total=len(tasks)) as advance:
            for task, result in engine.map_unordered(run_forecast, tasks):
                forecasts[task.axis_id] = result.message if isinstance(result, TaskFailed) else result
                advance()
    axes = []
    for entry in manifest.axes:
        rows = ok_rows[entry.id]
        done = {r["key"] for r in rows}
        pending = [m.date.date().isoformat() for m, key in plan.measurements(entry.id)
                   if key not in done and (until is None or m.date <= until)]
        fc = forecasts.get(entry.id)
        forecast = fc if isinstance(fc, Forecast) else None
        fc_error = fc if isinstance(fc, str) else None
        alarms = tuple(n for n, tr in trends[entry.id].items() if alarm_of(tr))
        light, reason = _light(rows, alarms, forecast, horizon_weeks)
        axes.append(AxisStatus(entry.id, entry.machine, entry.axis, light, reason, rows, pending, trends[entry.id],
                               alarms, forecast, fc_error, _proposal(history, entry, rows), entry.report,
                               manifest.relative(entry.gains)))
    return FleetStatus(manifest.name, str(manifest.path), str(history), tuple(axes), settings, scatter,
                       float(horizon_weeks), stale, tuple(warnings))


def axis_trends(rows: list, scatter: Mapping, settings: DriftSettings) -> dict[str, Trend]:
    """The trend of every parameter of :data:`feedtune.fleet.drift.TRENDED_PARAMETERS` one axis' rows have
    (``scatter``: ``{name: {"relative": tau}}``, :func:`feedtune.fleet.drift.pooled_scatter`)."""
    out = {}
    for name in TRENDED_PARAMETERS:
        t, y, s = _series(rows, name)
        if y.size:
            out[name] = trend(name, t, y, s, scatter[name]["relative"], settings)
    return out


def forecast_task(entry, manifest, rows, trends, plan, horizon) -> ForecastTask | None:
    """The forecast task of an axis with a drifting model parameter and a fitted newest measurement (None
    otherwise)."""
    drifting = [trends[n] for n in MODEL_PARAMETERS if n in trends and alarm_of(trends[n])]
    if not drifting or not rows:
        return None
    newest = rows[-1]
    if not has_fit(newest):
        return None
    meas = plan.measurement(newest["key"])
    if meas is None:
        return None
    lines = tuple(DriftLine(t.name, t.level, t.slope, t.level_std, t.slope_std, t.cov) for t in drifting)
    recent = []
    for r in [r for r in rows[:-1] if has_fit(r)][-(RECENT - 1):]:
        m = plan.measurement(r["key"])
        if m is not None:
            recent.append((tuple(str(p) for p in m.frfs), fit_of(r)))
    held = {n: trends[n].mean for n in MODEL_PARAMETERS if n in trends and not alarm_of(trends[n])}
    return ForecastTask(snapshot(entry, manifest, newest, meas), lines, float(horizon), tuple(recent), held)


def _light(rows, alarms, forecast, horizon) -> tuple[str, str]:
    if not rows:
        return "grey", "no measurement in the history yet"
    newest = rows[-1]
    if newest.get("verdict") != "ok":
        if newest.get("verdict") == "fails":
            return "red", "the installed gains fail the limits on the newest measurement"
        return "red", f"no certificate on the newest measurement: {newest.get('error')}"
    if forecast is not None and forecast.weeks is not None and forecast.weeks <= horizon:
        limit = LIMIT_NAMES.get(forecast.limit or "", forecast.limit or "a limit")
        return "amber", (f"{limit} forecast to fail in {forecast.weeks:.1f} weeks "
                         f"({', '.join(forecast.parameters)} drifting)")
    if alarms:
        return "amber", f"{', '.join(alarms)} drifting beyond the noise"
    return "green", "the installed gains pass; nothing drifts"


def _proposal(history, entry, rows) -> dict | None:
    """The proposal written for the newest measurement (:mod:`feedtune.fleet.retune`), if any."""
    if not rows:
        return None
    path = Path(history) / PROPOSALS / proposal_name(entry.slug, rows[-1]["key"])
    if not path.is_file():
        return None
    from ..io import read_document

    try:
        doc = read_document(path)
    except ValueError:
        return None
    worst = (doc.get("certificate") or {}).get("worst") or {}
    return {"file": f"{PROPOSALS}/{path.name}", "controller": doc.get("controller"),
            "first_crossover_hz": worst.get("first_crossover_hz"), "ms": worst.get("ms"),
            "pm_deg": worst.get("pm_deg"), "gm_db": worst.get("gm_db"), "disk_margin": worst.get("disk_margin"),
            "ok": worst.get("ok")}


def proposal_name(slug: str, key: str) -> str:
    """File name of the proposal for a measurement: ``<machine>_<axis>-<key[:12]>.toml``."""
    return f"{slug}-{key[:12]}.toml"
