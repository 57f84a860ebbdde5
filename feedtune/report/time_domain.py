"""Time-domain section: tracking error and control signal per run with the error spectrum (thesis Fig. 3.15),
rope-snap displacement and amplitude spectral density (Fig. 3.14, 4.17), contour error (Fig. 4.20-4.22),
before/after pre-filter, and the comparison in the form of Table 3.2.

Tracking and rope-snap numbers come from :func:`feedtune.analysis.log_analysis.analyze_tracking_log` and
:func:`~feedtune.analysis.log_analysis.analyze_ropesnap_log`, the functions behind
``feedtune analyze track|ropesnap LOG --json``, so the report's tables equal the command's output.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from functools import partial
from pathlib import Path

import numpy as np

from ..errors import DataError
from .collect import Inputs, LogInput
from .content import Alert, Cell, FigureBlock, Paragraph, Section, Table, text_cell
from .design import PREFILTER_SUFFIX
from .figures import DWARF_RATIO, Curve, TimePanel, Window, contour_figure, dwarf_split, time_figure
from .sections import Colors, ReportLimits, baseline_of, controller_label, improvement_pct

TRACKING_KINDS = ("track", "cut")
COMMAND_SIGNALS = ("u", "u1", "u2", "ux")
"""Command columns of the twin logs (ball screw ``u``; gantry sides ``u1``, ``u2`` and the x axis ``ux``)."""
PEAK_FLOOR_RATIO = 10.0
"""A spectrum peak is reported when its amplitude is at least this many times the noise floor (20 dB)."""
PEAK_MIN_LINES = 4
"""... and it lies at least this many frequency lines above 0 Hz (below, it is the run's own slow motion seen
through the window's main lobe, not a line of the spectrum)."""
PEAK_CRITERION = (f"a peak is listed when its amplitude is at least {PEAK_FLOOR_RATIO:g} times (20 dB) the noise "
                  "floor, the median amplitude within one octave either side, and it lies at least "
                  f"{PEAK_MIN_LINES} frequency lines above 0 Hz")
ACCELERATION_TOL = 0.02
"""Samples with ``|a_ref| > ACCELERATION_TOL max|a_ref|`` are accelerating (as the analysis' motion phases)."""
ZOOM_BEFORE, ZOOM_AFTER = 0.2, 0.8
"""A zoom window around an acceleration phase of duration D runs from D x ZOOM_BEFORE before it to D x ZOOM_AFTER
after it (the settling after the phase is where the error shows)."""
ZOOM_MIN_S = 0.02
"""Shortest zoom window [s]."""
TWIN_SOURCES = {"twin ": "ballscrew", "gantry twin ": "gantry"}
"""Prefixes of the ``source`` metadata of twin logs and the machine whose twin wrote them."""


@dataclass(frozen=True)
class Run:
    """One analysed log: file name, display label, colour, comparison group and metrics.

    ``options`` are the keyword arguments given to the log analysis (the ``feedtune analyze`` options, e.g.
    ``{"error": "e2", "reference": "y_ref"}`` for a gantry side); ``sides`` holds the metrics of every side
    of a gantry run (``metrics`` is then the side with the larger maximum error)."""

    name: str
    li: LogInput
    label: str
    color: str
    group: tuple
    group_title: str
    metrics: object
    base_label: str
    prefilter: bool
    options: dict = field(default_factory=dict)
    sides: dict = field(default_factory=dict)


# ------------------------------------------------------------------------------------------ log facts
def saturation(u: np.ndarray, min_samples: int) -> tuple[float, int] | None:
    """``(level, samples)`` when ``|u|`` sits at its largest value for at least ``min_samples`` consecutive
    samples (a clipped command), else None.

    Examples
    --------
    >>> u = np.r_[np.zeros(5), np.full(12, 10.0), np.zeros(5)]
    >>> saturation(u, 10)
    (10.0, 12)
    """
    a = np.abs(np.asarray(u, float))
    top = float(a.max()) if a.size else 0.0
    if top <= 0:
        return None
    at = a >= top * (1 - 1e-9)
    edges = np.diff(np.r_[0, at.astype(np.int8), 0])
    starts, stops = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)
    longest = int((stops - starts).max()) if starts.size else 0
    return (top, longest) if longest >= min_samples else None


def log_warnings(name: str, log, limits: ReportLimits) -> list[str]:
    """A tripped run (``meta["trip"]``) and saturated commands (``u``, ``u1``, ``u2``, ``ux``)."""
    out = []
    if log.meta.get("trip"):
        out.append(f"{name}: the run tripped ({log.meta['trip']})")
    for sig in ("u", "u1", "u2", "ux"):
        if sig in log:
            sat = saturation(log[sig], limits.saturation_samples)
            if sat is not None:
                unit = log.unit(sig) or "V"
                out.append(f"{name}: {sig} at its limit ±{sat[0]:.4g} {unit} for {sat[1]} consecutive samples "
                           f"({sat[1] / log.fs * 1e3:.3g} ms): saturation")
    return out


def twin_u_max(machine: str) -> float | None:
    """The command saturation [V] of a registered machine's twin with its default parameters (``u_max``; None for
    a name no machine has)."""
    from dataclasses import fields

    from ..machines.registry import get_machine, machine_names
    from ..structures import resolve

    if machine not in machine_names():
        return None
    value = next((f.default for f in fields(resolve(get_machine(machine).params)) if f.name == "u_max"), None)
    return float(value) if isinstance(value, (int, float)) else None


def saturation_level(log, limits: ReportLimits) -> tuple[float | None, str]:
    """``(level, where it came from)``: the command saturation [command unit] for a run's margin.

    The log's ``u_max`` metadata, else ``limits.u_max``, else for a log the twin wrote (``source: twin ...``)
    the twin's default ``u_max``; ``(None, "unknown")`` otherwise."""
    for key in ("u_max", "u_max_v", "u_max_V"):
        if key in log.meta:
            try:
                return float(log.meta[key]), "log metadata"
            except (TypeError, ValueError):
                break
    if limits.u_max is not None:
        return float(limits.u_max), "report option"
    source = str(log.meta.get("origin", log.meta.get("source", "")))  # the CSV reader keeps it as "origin"
    for prefix, machine in TWIN_SOURCES.items():
        if source.startswith(prefix):
            level = twin_u_max(machine)
            if level is not None:
                return level, f"{machine} twin default"
    return None, "unknown"


def command_peaks(log, limits: ReportLimits) -> dict:
    """Per command signal (``u``, ``u1``, ``u2``, ``ux``): peak ``|u|``, when, the saturation level and the
    margin to it (``level - peak`` in the command unit and in % of the level)."""
    level, source = saturation_level(log, limits)
    out = {}
    for sig in COMMAND_SIGNALS:
        if sig not in log:
            continue
        u = np.abs(np.asarray(log[sig], float))
        if not u.size:
            continue
        i = int(np.argmax(u))
        peak = float(u[i])
        out[sig] = {"peak_abs": peak, "t_peak_s": float(log.t[i]), "unit": log.unit(sig) or "V",
                    "saturation": level, "saturation_source": source,
                    "margin": None if level is None else level - peak,
                    "margin_pct": None if not level else 100.0 * (1.0 - peak / level)}
    return out


def significant_peak(freq_hz: np.ndarray | None, amplitude: np.ndarray | None, peaks) -> dict:
    """The largest of the analysis' spectrum ``peaks`` that stands above the noise floor (:data:`PEAK_CRITERION`).

    Returns
    -------
    dict
        ``index`` (in ``peaks``, None when none qualifies), ``freq_hz``, ``level``, ``floor`` and ``ratio`` of
        that peak, and ``resolution_hz`` (the line spacing of the spectrum).
    """
    out = {"index": None, "freq_hz": None, "level": None, "floor": None, "ratio": None, "resolution_hz": None}
    if freq_hz is None or amplitude is None or len(freq_hz) < 2:
        return out
    f, a = np.asarray(freq_hz, float), np.asarray(amplitude, float)
    df = float(f[1] - f[0])
    out["resolution_hz"] = df
    for i, p in enumerate(peaks):
        if p.freq_hz < PEAK_MIN_LINES * df:
            continue
        sel = (f >= p.freq_hz / 2) & (f <= p.freq_hz * 2)
        floor = float(np.median(a[sel])) if sel.any() else 0.0
        if floor > 0 and p.level >= PEAK_FLOOR_RATIO * floor:
            return {"index": i, "freq_hz": p.freq_hz, "level": p.level, "floor": floor, "ratio": p.level / floor,
                    "resolution_hz": df}
    return out


def commanded_acceleration(log) -> np.ndarray | None:
    """The commanded acceleration [m/s^2]: ``a_ref`` (``ay_ref``), else derived from ``v_ref`` or ``x_ref``
    (``vy_ref``, ``y_ref``); None without any."""
    for a, v, x in (("a_ref", "v_ref", "x_ref"), ("ay_ref", "vy_ref", "y_ref")):
        if a in log:
            return np.asarray(log[a], float)
        if v in log:
            return np.gradient(np.asarray(log[v], float), log.t)
        if x in log:
            return np.gradient(np.gradient(np.asarray(log[x], float), log.t), log.t)
    return None


def acceleration_phases(log) -> list[tuple[float, float]]:
    """``[(start, end)]`` [s] of the runs of samples with ``|a| > ACCELERATION_TOL max|a|`` (gaps shorter than
    5 ms closed)."""
    a = commanded_acceleration(log)
    if a is None or not a.size or not np.max(np.abs(a)) > 0:
        return []
    on = np.abs(a) > ACCELERATION_TOL * np.max(np.abs(a))
    edges = np.diff(np.r_[0, on.astype(np.int8), 0])
    starts, stops = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1) - 1
    phases: list[list[float]] = []
    for i0, i1 in zip(starts, stops, strict=True):
        t0, t1 = float(log.t[i0]), float(log.t[i1])
        if phases and t0 - phases[-1][1] < 0.005:
            phases[-1][1] = t1
        else:
            phases.append([t0, t1])
    return [(p[0], p[1]) for p in phases]


def tracking_windows(log) -> list[Window]:
    """A zoom window around every acceleration phase of a run's reference (:func:`acceleration_phases`)."""
    phases = acceleration_phases(log)
    t_lo, t_hi = float(log.t[0]), float(log.t[-1])
    out = []
    for k, (s, e) in enumerate(phases, start=1):
        d = max(e - s, ZOOM_MIN_S / (1 + ZOOM_BEFORE + ZOOM_AFTER))
        t0, t1 = max(t_lo, s - ZOOM_BEFORE * d), min(t_hi, e + ZOOM_AFTER * d)
        out.append(Window(f"acceleration {k} of {len(phases)}: {s * 1e3:.0f}-{e * 1e3:.0f} ms", t0, t1))
    return out


def worst_window(windows: list[Window], curves: list[Curve]) -> list[Window]:
    """The window in which the largest ``|y|`` of the curves occurs (the event a reader wants to see), as a list
    (empty without windows)."""
    if len(windows) <= 1:
        return list(windows)

    def peak(w: Window) -> float:
        vals = [np.max(np.abs(c.y[(c.x >= w.t0) & (c.x <= w.t1)]), initial=0.0) for c in curves]
        return max(vals, default=0.0)

    return [max(windows, key=peak)]


def ropesnap_window(group: list) -> Window:
    """Zoom window [s after the release] over the response: up to 1.5 x the slowest 5 % settling time of the
    group (10 x the peak time when a run does not settle), at least :data:`ZOOM_MIN_S`, within the runs."""
    ends, spans = [], []
    for r in group:
        m = r.metrics
        ends.append(1.5 * m.settling_time if m.settled and m.settling_time else 10.0 * max(m.peak_time, 1e-3))
        spans.append(float(r.li.log.t[-1]) - m.t_release)
    w = min(max(max(ends), ZOOM_MIN_S), max(spans))
    return Window(f"after the release: 0-{w * 1e3:.0f} ms", -0.1 * w, w)


def speed_of(log) -> float | None:
    """Largest commanded speed [m/s]: from ``v_ref`` (``vy_ref``), else the derivative of ``x_ref``
    (``y_ref``); None without any."""
    for name in ("v_ref", "vy_ref"):
        if name in log:
            return float(np.max(np.abs(log[name])))
    for name in ("x_ref", "y_ref"):
        if name in log:
            return float(np.max(np.abs(np.gradient(log[name], log.t))))
    return None


def is_gantry_run(log) -> bool:
    """A gantry (two-sided y axis) run: reference ``y_ref`` and side errors ``e1``, ``e2``."""
    return {"y_ref", "e1", "e2"} <= set(log.signals) and "x_ref" not in log


def tracking_error_series(log, options: Mapping | None = None) -> np.ndarray:
    """The error signal ``analyze_tracking_log(log, **options)`` evaluates [m]: the ``error`` option, else
    ``e2``, else the reference minus the position it picks."""
    from ..analysis import log_analysis

    options = options or {}
    if options.get("error"):
        return log[options["error"]]
    if "e2" in log:
        return log["e2"]
    reference = options.get("reference") or "x_ref"
    position = log_analysis.pick_position(log, options.get("position"), {reference})
    return log[reference] - log[position]


def ropesnap_options(log) -> dict:
    """``analyze_ropesnap_log`` options: the table displacement ``y_table`` of a gantry run when the log has
    no ``x2_table`` (the default picks ``x2_table`` or the only signal in m)."""
    return {"position": "y_table"} if "y_table" in log and "x2_table" not in log else {}


def ropesnap_position(log, options: Mapping | None = None) -> np.ndarray:
    """The displacement ``analyze_ropesnap_log(log, **options)`` evaluates [m]."""
    from ..analysis import log_analysis

    return log[log_analysis.pick_position(log, (options or {}).get("position"), set())]


def _gains_doc_of(li: LogInput, gains_docs: Mapping[str, dict]) -> dict | None:
    """The gains document a twin log names in ``meta["gains"]``: among the inputs, else beside the log."""
    ref = li.log.meta.get("gains")
    if not ref:
        return None
    ref_name = Path(str(ref)).name
    if ref_name in gains_docs:
        return gains_docs[ref_name]
    candidate = li.path.parent / ref_name
    if candidate.is_file():
        from ..io import read_document

        try:
            return read_document(candidate)
        except DataError:
            return None
    return None


# ------------------------------------------------------------------------------------------ runs
def _label(li: LogInput, gains_docs: Mapping[str, dict]) -> tuple[str, bool]:
    ctrl = li.log.meta.get("controller")
    base = controller_label(str(ctrl)) if ctrl else li.path.stem
    doc = _gains_doc_of(li, gains_docs)
    return base, bool(doc and "prefilter" in doc)


def _group(li: LogInput) -> tuple[tuple, str]:
    v = speed_of(li.log)
    if li.kind == "cut":
        return ("cut", round(v * 1e3) if v else 0), (f"cut, peak speed {v * 1e3:.4g} mm/s" if v
                                                      else f"cut {li.path.stem}")
    if v:
        return ("track", round(v * 1e3)), f"tracking, peak speed {v * 1e3:.4g} mm/s"
    return ("track", li.path.stem), f"tracking {li.path.stem}"


def _analyze(li: LogInput, kind: str, strict: bool, warnings: list[str], names: Mapping):
    """``(metrics, options, sides)`` of a log (None when a folder member cannot be analysed)."""
    from ..analysis.log_analysis import analyze_ropesnap_log, analyze_tracking_log

    try:
        if kind == "ropesnap":
            options = ropesnap_options(li.log)
            return analyze_ropesnap_log(li.log, **options), options, {}
        if is_gantry_run(li.log):
            sides = {e: analyze_tracking_log(li.log, error=e, reference="y_ref") for e in ("e1", "e2")}
            worst = max(sides, key=lambda e: sides[e].overall.max_abs)
            return sides[worst], {"error": worst, "reference": "y_ref"}, sides
        return analyze_tracking_log(li.log), {}, {}
    except DataError as exc:
        if li.named or strict:
            raise
        warnings.append(f"{names[li.path]}: left out of the time-domain section ({exc})")
        return None


def _run_tag(li: LogInput) -> str:
    """What tells runs of one controller kind apart: the gains file the run names (the same in every test), else
    the log's file name."""
    gains = li.log.meta.get("gains")
    return Path(str(gains)).stem if gains else li.path.stem


def _unique_labels(runs: list[Run], colors: Colors) -> list[Run]:
    """Give runs that share a group and a label the name of their gains file (else of their log) as well."""
    from dataclasses import replace

    seen: dict[tuple, int] = {}
    for r in runs:
        seen[(r.group, r.label)] = seen.get((r.group, r.label), 0) + 1
    out = [replace(r, label=f"{r.label} ({_run_tag(r.li)})", base_label=f"{r.base_label} ({_run_tag(r.li)})")
           if seen[(r.group, r.label)] > 1 else r for r in runs]
    return [replace(r, color=colors(r.label)) for r in out]  # a design's runs in the design's colour


def tracking_runs(inputs: Inputs, names: Mapping, colors: Colors, strict: bool, warnings: list[str],
                  gains_docs: Mapping[str, dict]) -> list[Run]:
    """Analysed tracking and cutting runs, sorted by group (tracking by speed, then cuts)."""
    runs = []
    for li in inputs.logs_of(*TRACKING_KINDS):
        found = _analyze(li, "track", strict, warnings, names)
        if found is None:
            continue
        metrics, options, sides = found
        base, pre = _label(li, gains_docs)
        label = base + (PREFILTER_SUFFIX if pre else "")
        group, title = _group(li)
        runs.append(Run(names[li.path], li, label, "", group, title, metrics, base, pre, options, sides))
    runs = _unique_labels(runs, colors)
    return sorted(runs, key=lambda r: (r.group[0] == "cut", str(type(r.group[1])), r.group[1]))


def ropesnap_runs(inputs: Inputs, names: Mapping, colors: Colors, strict: bool, warnings: list[str],
                  gains_docs: Mapping[str, dict]) -> list[Run]:
    """Analysed rope-snap runs, grouped by the rope force of the metadata when given."""
    runs = []
    for li in inputs.logs_of("ropesnap"):
        found = _analyze(li, "ropesnap", strict, warnings, names)
        if found is None:
            continue
        metrics, options, _ = found
        base, pre = _label(li, gains_docs)
        force = rope_force(li.log)
        group = ("ropesnap", force)
        title = f"rope snap {force}" if force else "rope snap"
        runs.append(Run(names[li.path], li, base, "", group, title, metrics, base, pre, options))
    return _unique_labels(runs, colors)


def rope_force(log) -> str:
    """The rope force a rope-snap log records, as the demos name it: ``57 N`` (``force_N``, the force on the table),
    else ``0.5 V`` (``force_V``, the force as a command-equivalent), else ``""``."""
    from ..display import quantity

    for key, unit in (("force_n", "N"), ("force_v", "V")):
        value = next((v for k, v in log.meta.items() if k.lower() == key), None)
        if value is not None:
            try:
                return quantity(float(value), unit)
            except (TypeError, ValueError):
                return f"{value} {unit}"
    return ""


def _groups(runs: list[Run]) -> list[list[Run]]:
    out: dict[tuple, list[Run]] = {}
    for r in runs:
        out.setdefault(r.group, []).append(r)
    return list(out.values())


# ------------------------------------------------------------------------------------------ tracking
def _tracking_figure(group: list[Run]) -> FigureBlock:
    err, cmd, spec = [], [], []
    for r in group:
        log = r.li.log
        if r.sides:
            for side in r.sides:
                style = "-" if side == "e1" else "--"
                err.append(Curve(log.t, log[side] * 1e6, f"{r.label} {side}", r.color, style))
        else:
            err.append(Curve(log.t, tracking_error_series(log, r.options) * 1e6, r.label, r.color))
        for u in ("u", "u1", "u2"):
            if u in log:
                cmd.append(Curve(log.t, log[u], r.label if u == "u" else f"{r.label} {u}", r.color,
                                 "--" if u == "u2" else "-"))
        if r.metrics.freq_hz is not None:
            spec.append(Curve(r.metrics.freq_hz, r.metrics.amplitude * 1e6, r.label, r.color))
    unit = next((group[0].li.log.unit(u) for u in ("u", "u1") if u in group[0].li.log), "") or "V"
    windows = worst_window(tracking_windows(group[0].li.log), err)
    panels = [TimePanel("tracking error [µm]", err, own_scale=True), TimePanel(f"control signal [{unit}]", cmd)]
    fig = partial(time_figure, panels, windows, spec, time_label="time [s]", spectrum_label="error amplitude [µm]",
                  title=group[0].group_title)
    what = "cutting" if group[0].group[0] == "cut" else "tracking"
    df = group[0].metrics.freq_hz[1] - group[0].metrics.freq_hz[0] if group[0].metrics.freq_hz is not None else None
    zoom = (" Right: zoomed on the acceleration phase of the reference (|a_ref| above "
            f"{100 * ACCELERATION_TOL:g} % of its peak) with the largest error, shaded on the whole run." if windows
            else "")
    res = f" Spectrum: Hann window over the whole run, line spacing {df:.3g} Hz." if df else ""
    return FigureBlock(f"time-{group[0].group[0]}-{group[0].group[1]}",
                       f"{group[0].group_title[0].upper()}{group[0].group_title[1:]}: {what} error, control signal "
                       "and error amplitude spectrum (thesis Fig. 3.15)." + zoom + _dwarf_note(err) + res, fig,
                       _shows(group))


def _shows(group: list[Run]) -> tuple:
    """``((label, colour), ...)`` of the runs a figure compares (:attr:`FigureBlock.shows`)."""
    return tuple(dict.fromkeys((r.label, r.color) for r in group))


def _dwarf_note(curves: list[Curve]) -> str:
    """Caption text naming the runs drawn again at their own scale (:func:`feedtune.report.figures.dwarf_split`)."""
    small = dwarf_split(curves)[1]
    if not small:
        return ""
    names = ", ".join(dict.fromkeys(c.label for c in small))
    return (f" The second row draws {names} again at their own scale: their peak is below 1/{DWARF_RATIO:g} of the "
            "largest.")


def _stats_cells(metrics, part: str, key: list) -> list[Cell]:
    stats = getattr(metrics, part)
    k = [*key, part]
    if stats is None:
        return [Cell(None), Cell(None)]
    return [Cell(stats.max_abs, "µm", 1e6, key=[*k, "max_m"]), Cell(stats.rms, "µm", 1e6, key=[*k, "rms_m"])]


def _error_name(r: Run, side: str | None) -> str:
    if side is not None:
        return side
    return r.options.get("error") or ("e2" if "e2" in r.li.log else "x_ref - position")


def _entries(r: Run):
    """``(side, metrics, data key)`` per analysed error of a run (each side of a gantry run)."""
    return [(side, m, ["tracking", r.name, "sides", side]) for side, m in r.sides.items()] or \
        [(None, r.metrics, ["tracking", r.name, "metrics"])]


def short_title(title: str) -> str:
    """A group title for a table cell: ``tracking, peak speed 200 mm/s`` -> ``200 mm/s``, ``cut, peak speed
    200 mm/s`` -> ``cut 200 mm/s`` (the tables say the speed is the peak commanded speed)."""
    for prefix, shown in (("tracking, peak speed ", ""), ("cut, peak speed ", "cut ")):
        if title.startswith(prefix):
            return shown + title[len(prefix):]
    return title


def _short_run(r: Run) -> str:
    return short_title(r.group_title)


def _runs_table(runs: list[Run]) -> Table:
    rows = []
    for r in runs:
        for side, m, key in _entries(r):
            rows.append([text_cell(_short_run(r)), text_cell(r.label), text_cell(r.name),
                         text_cell(_error_name(r, side)),
                         *_stats_cells(m, "overall", key), *_stats_cells(m, "constant_velocity", key),
                         *_stats_cells(m, "acceleration", key)])
    note = ("Gantry runs: each side's error (feedtune analyze track LOG --error e1|e2 --reference y_ref); the "
            "comparison uses the side with the larger maximum error. " if any(r.sides for r in runs) else "")
    note += (f"Accelerating: |a_ref| above {100 * ACCELERATION_TOL:g} % of its peak; constant velocity: speed within "
             "2 % of its peak and not accelerating.")
    return Table("Tracking error per run (feedtune analyze track)",
                 ["run", "controller", "log", "error", "max", "RMS", "max, constant velocity",
                  "RMS, constant velocity", "max, accelerating", "RMS, accelerating"], rows, note)


def _spectrum_table(runs: list[Run], data: dict) -> Table:
    """The largest error-spectrum peak above the noise floor per run, with the frequency resolution."""
    rows = []
    for r in runs:
        store = data["tracking"][r.name].setdefault("spectrum_peak", {})
        for side, m, key in _entries(r):
            sp = significant_peak(m.freq_hz, m.amplitude, m.peaks)
            store[side or "error"] = {k: sp[k] for k in ("freq_hz", "level", "floor", "ratio", "resolution_hz")} | {
                "index": sp["index"], "criterion": PEAK_CRITERION}
            skey = ["tracking", r.name, "spectrum_peak", side or "error"]
            if sp["index"] is None:
                peak_cells = [text_cell("none above the noise floor"), Cell(None), Cell(None)]
            else:
                pk = [*key, "peaks", sp["index"]]
                peak_cells = [Cell(sp["freq_hz"], "Hz", key=[*pk, "freq_hz"]),
                              Cell(sp["level"], "µm", 1e6, key=[*pk, "amplitude_m"]),
                              Cell(sp["ratio"], "", key=[*skey, "ratio"])]
            rows.append([text_cell(_short_run(r)), text_cell(r.label), text_cell(_error_name(r, side)), *peak_cells,
                         Cell(sp["resolution_hz"], "Hz", key=[*skey, "resolution_hz"])])
    return Table("Error spectrum: the largest peak above the noise floor per run",
                 ["run", "controller", "error", "peak at", "amplitude", "peak / noise floor", "frequency resolution"],
                 rows, "Amplitude spectrum of the whole run's error (Hann window, amplitude-correct); "
                 f"{PEAK_CRITERION}. Frequency resolution: the line spacing 1/T of the run of duration T.")


def command_table(runs: list[Run], section: str, data: dict, limits: ReportLimits) -> Table | None:
    """Peak |u| per run and command signal with the margin to the saturation level (``data[section][log]
    ["command"]``)."""
    rows = []
    sources = set()
    for r in runs:
        peaks = command_peaks(r.li.log, limits)
        data[section][r.name]["command"] = peaks
        for sig, p in peaks.items():
            k = [section, r.name, "command", sig]
            sources.add(p["saturation_source"])
            unit = p["unit"]
            rows.append([text_cell(_short_run(r)), text_cell(r.label), text_cell(sig),
                         Cell(p["peak_abs"], unit, key=[*k, "peak_abs"]),
                         Cell(p["t_peak_s"], "s", key=[*k, "t_peak_s"]),
                         Cell(p["saturation"], unit, key=[*k, "saturation"]) if p["saturation"] is not None
                         else text_cell("unknown"),
                         Cell(p["margin"], unit, key=[*k, "margin"]) if p["margin"] is not None else text_cell("-"),
                         Cell(p["margin_pct"], "%", key=[*k, "margin_pct"])
                         if p["margin_pct"] is not None else text_cell("-")])
    if not rows:
        return None
    note = ("Margin = saturation level - peak |u| (negative: the command reached the level). Saturation level from: "
            + ", ".join(sorted(sources)) + ".")
    if "unknown" in sources:
        note += " Unknown levels: give the log a '# u_max:' metadata line or ReportLimits(u_max=...)."
    return Table("Control effort: peak command and margin to saturation per run",
                 ["run", "controller", "command", "peak |u|", "at", "saturation level", "margin", "margin [%]"],
                 rows, note)


def comparison_rows(runs: list[Run]) -> tuple[list[str], list[dict]]:
    """Table 3.2 data: controller labels in order and one row per group with max/RMS per label [m] and the
    reduction against the baseline controller [%]."""
    labels: list[str] = []
    for r in runs:
        if r.label not in labels:
            labels.append(r.label)
    base = baseline_of(labels)
    rows = []
    for group in _groups(runs):
        by = {r.label: r for r in group}
        entry = {"run": group[0].group_title, "cut": group[0].group[0] == "cut",
                 "runs": {lb: {"log": r.name, "max_m": r.metrics.overall.max_abs, "rms_m": r.metrics.overall.rms}
                          for lb, r in by.items()},
                 "baseline": base if base in by else None, "reduction_pct": {}}
        if base in by:
            b = by[base].metrics.overall
            for lb, r in by.items():
                if lb != base:
                    entry["reduction_pct"][lb] = {"max": improvement_pct(r.metrics.overall.max_abs, b.max_abs),
                                                  "rms": improvement_pct(r.metrics.overall.rms, b.rms)}
        rows.append(entry)
    return labels, rows


def _comparison_table(runs: list[Run], labels: list[str], rows: list[dict]) -> Table:
    """Table 3.2 in long form (one row per run and controller, so any number of controllers fits the page)."""
    base = baseline_of(labels)
    by_name = {r.name: r for r in runs}
    table_rows = []
    for row in rows:
        run_text = short_title(row["run"]) + ("*" if row["cut"] else "")
        for lb in labels:
            run = row["runs"].get(lb)
            if run is None:
                continue
            k = ["tracking", by_name[run["log"]].name, "metrics", "overall"]
            red = row["reduction_pct"].get(lb)
            reds = ([Cell(red.get("max"), "%", digits=3), Cell(red.get("rms"), "%", digits=3)] if red else
                    [text_cell("baseline" if lb == base else "-"), text_cell("baseline" if lb == base else "-")])
            table_rows.append([text_cell(run_text), text_cell(lb), Cell(run["max_m"], "µm", 1e6, key=[*k, "max_m"]),
                               Cell(run["rms_m"], "µm", 1e6, key=[*k, "rms_m"]), *reds])
    note = f"Run: peak commanded speed. Reduction against {base or 'the baseline'} = 100 (1 - error / baseline error)."
    if any(r["cut"] for r in rows):
        note = "* machining (cutting) run. " + note
    return Table("Maximum and RMS tracking error per run and controller (form of thesis Table 3.2)",
                 ["run", "controller", "max", "RMS", "max reduction", "RMS reduction"], table_rows, note)


def _prefilter_table(runs: list[Run]) -> Table | None:
    """Before/after pre-filter per controller and run, when both variants were logged."""
    rows = []
    for group in _groups(runs):
        for base in dict.fromkeys(r.base_label for r in group):
            before = [r for r in group if r.base_label == base and not r.prefilter]
            after = [r for r in group if r.base_label == base and r.prefilter]
            if not (before and after):
                continue
            b, a = before[0], after[0]
            kb, ka = ["tracking", b.name, "metrics", "overall"], ["tracking", a.name, "metrics", "overall"]
            rows.append([text_cell(group[0].group_title), text_cell(base),
                         Cell(b.metrics.overall.max_abs, "µm", 1e6, key=[*kb, "max_m"]),
                         Cell(a.metrics.overall.max_abs, "µm", 1e6, key=[*ka, "max_m"]),
                         Cell(improvement_pct(a.metrics.overall.max_abs, b.metrics.overall.max_abs), "%", digits=3),
                         Cell(b.metrics.overall.rms, "µm", 1e6, key=[*kb, "rms_m"]),
                         Cell(a.metrics.overall.rms, "µm", 1e6, key=[*ka, "rms_m"]),
                         Cell(improvement_pct(a.metrics.overall.rms, b.metrics.overall.rms), "%", digits=3)])
    if not rows:
        return None
    return Table("Before/after the trajectory pre-filter (eq. 3.14-3.23)",
                 ["run", "controller", "max without", "max with", "max reduction", "RMS without", "RMS with",
                  "RMS reduction"], rows)


# ------------------------------------------------------------------------------------------ rope snap
def _ropesnap_figure(group: list[Run]) -> FigureBlock:
    disp, cmd, asd = [], [], []
    for r in group:
        log, m = r.li.log, r.metrics
        t = log.t - m.t_release
        disp.append(Curve(t, (ropesnap_position(log, r.options) - m.baseline) * 1e6, r.label, r.color))
        for u in ("u", "u1", "u2"):
            if u in log:
                cmd.append(Curve(t, log[u], r.label if u == "u" else f"{r.label} {u}", r.color,
                                 "--" if u == "u2" else "-"))
        asd.append(Curve(m.asd_freq_hz, m.asd * 1e6, r.label, r.color))
    unit = next((group[0].li.log.unit(u) for u in ("u", "u1") if u in group[0].li.log), "") or "V"
    window = ropesnap_window(group)
    fig = partial(time_figure, [TimePanel("table displacement [µm]", disp, own_scale=True),
                                TimePanel(f"control signal [{unit}]", cmd)],
                      [window], asd, time_label="time after the release [s]", spectrum_label="ASD [µm/√Hz]",
                      title=group[0].group_title, spectrum_loglog=True)
    title = group[0].group_title
    m = group[0].metrics
    df = float(m.asd_freq_hz[1] - m.asd_freq_hz[0]) if m.asd_freq_hz.size > 1 else None
    res = f" ASD: Welch, Hann, line spacing {df:.3g} Hz." if df else ""
    return FigureBlock(f"time-ropesnap-{group[0].group[1]}", f"{title[0].upper()}{title[1:]}: table "
                       "displacement from its pre-release level, control signal and amplitude spectral density "
                       "of the displacement after the release (thesis Fig. 3.14, 4.17); right: zoomed on the "
                       "response after the release." + _dwarf_note(disp) + res, fig, _shows(group))


def _ropesnap_table(runs: list[Run]) -> tuple[Table, dict]:
    rows, reductions = [], {}
    for group in _groups(runs):
        labels = [r.label for r in group]
        base = baseline_of(labels)
        by = {r.label: r for r in group}
        for r in group:
            k = ["ropesnap", r.name, "metrics"]
            m = r.metrics
            red_peak = red_settle = None
            if base is not None and r.label != base:
                b = by[base].metrics
                red_peak = improvement_pct(m.peak_abs, b.peak_abs)
                red_settle = improvement_pct(m.settling_time, b.settling_time)
                reductions.setdefault(group[0].group_title, {})[r.label] = {
                    "baseline": base, "peak": red_peak, "settling_time": red_settle}
            rows.append([text_cell(group[0].group_title), text_cell(r.label), text_cell(r.name),
                         Cell(m.peak_abs, "µm", 1e6, key=[*k, "peak_abs_m"]),
                         Cell(m.peak_time, "s", key=[*k, "peak_time_s"]),
                         Cell(m.settling_time, "s", key=[*k, "settling_time_s"]) if m.settled
                         else text_cell("not settled"),
                         Cell(m.t_release, "s", key=[*k, "t_release_s"]),
                         Cell(red_peak, "%", digits=3), Cell(red_settle, "%", digits=3)])
    table = Table("Rope snap: peak displacement and 5 % settling time (feedtune analyze ropesnap)",
                  ["test", "controller", "log", "peak displacement", "peak after release", "5 % settling time",
                   "release at", "peak reduction", "settling-time reduction"], rows,
                  "Reductions are against P-PI (or PID) when present, else the last controller of the test.")
    return table, reductions


# ------------------------------------------------------------------------------------------ contour
MAX_CONTOUR_PAIRS = 50_000_000
"""Largest point x segment count for which the contour error is computed (the nearest-segment search of
:func:`feedtune.analysis.metrics.contour_error` is O(points x segments)); longer logs need a logged
``contour_error`` column."""
PATH_POINTS = 4000
"""Points of an x-y path drawn (evenly strided; the paths are smooth)."""


def contour_distance(log) -> tuple[np.ndarray, str]:
    """The contour error of a contour log [m] and where it came from: the log's ``contour_error`` column when
    it has one (``"logged"``), else :func:`feedtune.analysis.metrics.contour_error` of ``x, y`` against
    ``x_ref, y_ref`` (``"computed"``)."""
    from ..analysis.metrics import contour_error

    if "contour_error" in log:
        return log["contour_error"], "logged"
    if log.n * (log.n - 1) > MAX_CONTOUR_PAIRS:
        raise DataError(f"{log.source}: {log.n} samples are too many for the point-to-path search "
                        f"(at most {int(np.sqrt(MAX_CONTOUR_PAIRS))}); log a contour_error column [m] or "
                        "decimate the log")
    return contour_error(log["x_ref"], log["y_ref"], log["x"], log["y"]).distance, "computed"


def _contour_metrics(d: np.ndarray, source: str) -> dict:
    """Max and RMS contour error [m] (as :class:`~feedtune.analysis.metrics.ContourError`) and the source."""
    return {"max_m": float(np.max(np.abs(d))), "rms_m": float(np.sqrt(np.mean(d**2))), "n_points": int(d.size),
            "source": source}


def _contour_group(li: LogInput) -> tuple[tuple, str]:
    shape, size = li.log.meta.get("shape"), li.log.meta.get("size_m")
    if shape:
        title = f"{shape}" + (f", {float(size) * 1e3:g} mm" if size is not None else "")
        return ("contour", title), f"contour: {title}"
    return ("contour", li.path.stem), f"contour {li.path.stem}"


def _contour_runs(inputs: Inputs, names: Mapping, colors: Colors, data: dict, strict: bool,
                  warnings: list[str]) -> list[tuple[Run, np.ndarray]]:
    out = []
    for li in inputs.logs_of("contour"):
        log = li.log
        missing = [s for s in ("x_ref", "y_ref", "x", "y") if s not in log]
        try:
            if missing:
                raise DataError(f"{names[li.path]}: contour log without {', '.join(missing)}; expected x_ref, "
                                "y_ref, x, y [m]")
            d, source = contour_distance(log)
        except DataError as exc:
            if li.named or strict:
                raise
            warnings.append(f"{names[li.path]}: left out of the time-domain section ({exc})")
            continue
        ctrl = log.meta.get("controller")
        label = controller_label(str(ctrl)) if ctrl else li.path.stem
        group, title = _contour_group(li)
        metrics = _contour_metrics(d, source)
        data.setdefault("contour", {})[names[li.path]] = {"log": names[li.path], "controller": label, "run": title,
                                                          "metrics": metrics}
        out.append((Run(names[li.path], li, label, "", group, title, metrics, label, False), d))
    unique = _unique_labels([r for r, _ in out], colors)
    for (r, _), u in zip(out, unique, strict=True):
        data["contour"][r.name]["controller"] = u.label
    return [(u, d) for u, (_, d) in zip(unique, out, strict=True)]


def _contour_subsection(inputs: Inputs, names: Mapping, colors: Colors, data: dict, strict: bool,
                        warnings: list[str]) -> Section | None:
    runs = _contour_runs(inputs, names, colors, data, strict, warnings)
    if not runs:
        return None
    rows, blocks, reductions = [], [], {}
    for group in _groups([r for r, _ in runs]):
        base = baseline_of([r.label for r in group])
        by = {r.label: r for r in group}
        for r in group:
            k = ["contour", r.name, "metrics"]
            red = None
            if base is not None and r.label != base:
                red = improvement_pct(r.metrics["max_m"], by[base].metrics["max_m"])
                reductions.setdefault(r.group_title, {})[r.label] = {"baseline": base, "max": red}
            rows.append([text_cell(r.group_title), text_cell(r.label), text_cell(r.name),
                         Cell(r.metrics["max_m"], "µm", 1e6, key=[*k, "max_m"]),
                         Cell(r.metrics["rms_m"], "µm", 1e6, key=[*k, "rms_m"]), text_cell(r.metrics["source"]),
                         Cell(red, "%", digits=3)])
    data.setdefault("comparison", {})["contour"] = reductions
    blocks.append(Table("Contour error (normal distance from the reference path)",
                        ["test", "controller", "log", "max", "RMS", "source", "max reduction"], rows,
                        "source: logged = the run's contour_error column; computed = nearest point of the "
                        "reference polyline."))
    distance = {r.name: d for r, d in runs}
    for group in _groups([r for r, _ in runs]):
        paths, errors = [], []
        for r in group:
            log = r.li.log
            step = max(1, log.n // PATH_POINTS)
            paths.append((r.label, r.color, log["x_ref"][::step], log["y_ref"][::step], log["x"][::step],
                          log["y"][::step]))
            errors.append(Curve(log.t, distance[r.name] * 1e6, r.label, r.color))
        title = group[0].group_title
        scale = (f" The errors differ by more than a factor of {DWARF_RATIO:g}: their magnitudes are drawn on a "
                 "logarithmic axis." if dwarf_split(errors)[1] else "")
        blocks.append(FigureBlock(f"contour-{group[0].group[1]}", f"{title[0].upper()}{title[1:]}: path against "
                                  "the reference and the contour error (thesis Fig. 4.20-4.22)." + scale,
                                  partial(contour_figure, paths, errors, title=title), _shows(group)))
    return Section("time-contour", "Contouring", blocks)


# ------------------------------------------------------------------------------------------ section
def time_domain_section(inputs: Inputs, names: Mapping, limits: ReportLimits, data: dict, warnings: list[str],
                        colors: Colors, strict: bool = False) -> Section | None:
    """The time-domain section (None without tracking, cutting, rope-snap or contour logs).

    Fills ``data["tracking"]``, ``data["ropesnap"]`` (``{"log", "kind", "metrics"}`` as
    ``feedtune analyze track|ropesnap LOG --json``), ``data["contour"]`` and ``data["comparison"]``.
    """
    for li in inputs.logs:
        warnings.extend(log_warnings(names[li.path], li.log, limits))
    gains_docs = {g.path.name: g.doc for g in inputs.gains}
    subs: list[Section] = []
    track = tracking_runs(inputs, names, colors, strict, warnings, gains_docs)
    comparison = data.setdefault("comparison", {})
    if track:
        for r in track:
            entry = {"log": r.name, "kind": "track", "controller": r.label, "run": r.group_title,
                     "options": dict(r.options), "metrics": r.metrics.to_dict()}
            if r.sides:
                entry["sides"] = {side: m.to_dict() for side, m in r.sides.items()}
            data.setdefault("tracking", {})[r.name] = entry
        labels, rows = comparison_rows(track)
        comparison["tracking"] = {"controllers": labels, "baseline": baseline_of(labels), "rows": rows}
        blocks: list = [_comparison_table(track, labels, rows), _runs_table(track), _spectrum_table(track, data)]
        effort = command_table(track, "tracking", data, limits)
        if effort is not None:
            blocks.append(effort)
        pre = _prefilter_table(track)
        if pre is not None:
            blocks.append(pre)
        blocks.extend(_tracking_figure(g) for g in _groups(track))
        subs.append(Section("time-tracking", "Tracking and cutting", blocks))
    snaps = ropesnap_runs(inputs, names, colors, strict, warnings, gains_docs)
    if snaps:
        for r in snaps:
            data.setdefault("ropesnap", {})[r.name] = {"log": r.name, "kind": "ropesnap", "controller": r.label,
                                                       "run": r.group_title, "options": dict(r.options),
                                                       "metrics": r.metrics.to_dict()}
        table, reductions = _ropesnap_table(snaps)
        comparison["ropesnap"] = reductions
        blocks = [table]
        effort = command_table(snaps, "ropesnap", data, limits)
        if effort is not None:
            blocks.append(effort)
        blocks.extend(_ropesnap_figure(g) for g in _groups(snaps))
        subs.append(Section("time-ropesnap", "Rope snap (step disturbance)", blocks))
    contour = _contour_subsection(inputs, names, colors, data, strict, warnings)
    if contour is not None:
        subs.append(contour)
    if not subs:
        return None
    frf_logs = inputs.logs_of("frf")
    intro = [Paragraph("FRF-measurement logs (" + ", ".join(names[li.path] for li in frf_logs) + ") are listed "
                       "under Inputs; estimate their FRF with feedtune frf.")] if frf_logs else []
    trips = [Alert(w) for w in warnings if "tripped" in w or "saturation" in w]
    return Section("time", "Time domain", intro + trips, subs)
