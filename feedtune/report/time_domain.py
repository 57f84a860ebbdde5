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
from pathlib import Path

import numpy as np

from ..errors import DataError
from .collect import Inputs, LogInput
from .content import Alert, Cell, FigureBlock, Paragraph, Section, Table, text_cell
from .design import PREFILTER_SUFFIX
from .figures import Curve, contour_figure, runs_figure
from .sections import Colors, ReportLimits, baseline_of, controller_label, improvement_pct

TRACKING_KINDS = ("track", "cut")


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
    reference = options.get("reference", "x_ref")
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
    return [replace(r, label=f"{r.label} ({_run_tag(r.li)})", base_label=f"{r.base_label} ({_run_tag(r.li)})",
                    color=colors(f"{r.label} ({_run_tag(r.li)})")) if seen[(r.group, r.label)] > 1 else r
            for r in runs]


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
        runs.append(Run(names[li.path], li, label, colors(label), group, title, metrics, base, pre, options, sides))
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
        force = li.log.meta.get("force_v")
        group = ("ropesnap", str(force) if force is not None else "")
        title = f"rope snap, {force} V" if force is not None else "rope snap"
        runs.append(Run(names[li.path], li, base, colors(base), group, title, metrics, base, pre, options))
    return _unique_labels(runs, colors)


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
    fig = runs_figure(err, cmd, spec, error_label="tracking error [µm]", command_label=f"control signal [{unit}]",
                      spectrum_label="error amplitude [µm]", title=group[0].group_title)
    what = "cutting" if group[0].group[0] == "cut" else "tracking"
    return FigureBlock(f"time-{group[0].group[0]}-{group[0].group[1]}",
                       f"{group[0].group_title[0].upper()}{group[0].group_title[1:]}: {what} error, control signal "
                       "and error amplitude spectrum (thesis Fig. 3.15).", fig)


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


def _runs_table(runs: list[Run]) -> Table:
    rows = []
    for r in runs:
        entries = [(side, m, ["tracking", r.name, "sides", side]) for side, m in r.sides.items()] or \
            [(None, r.metrics, ["tracking", r.name, "metrics"])]
        for side, m, key in entries:
            peak = m.peaks[0] if m.peaks else None
            pk = [*key, "peaks", 0]
            rows.append([text_cell(r.name), text_cell(r.label), text_cell(r.group_title),
                         text_cell(_error_name(r, side)),
                         *_stats_cells(m, "overall", key), *_stats_cells(m, "constant_velocity", key),
                         *_stats_cells(m, "acceleration", key),
                         Cell(peak.freq_hz if peak else None, "Hz", key=[*pk, "freq_hz"] if peak else None),
                         Cell(peak.level if peak else None, "µm", 1e6, key=[*pk, "amplitude_m"] if peak else None)])
    note = ("Gantry runs: each side's error (feedtune analyze track LOG --error e1|e2 --reference y_ref); the "
            "comparison uses the side with the larger maximum error." if any(r.sides for r in runs) else "")
    return Table("Tracking error per run (feedtune analyze track)",
                 ["log", "controller", "run", "error", "max", "RMS", "max at constant velocity",
                  "RMS at constant velocity", "max while accelerating", "RMS while accelerating",
                  "largest spectrum peak", "peak amplitude"], rows, note)


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
    base = baseline_of(labels)
    others = [lb for lb in labels if lb != base] if base else []
    columns = ["run"] + [f"{lb} {w}" for lb in labels for w in ("max", "RMS")]
    columns += [f"{lb} vs {base}: {w} reduction" for lb in others for w in ("max", "RMS")]
    by_name = {r.name: r for r in runs}
    table_rows = []
    for row in rows:
        cells = [text_cell(row["run"] + ("*" if row["cut"] else ""))]
        for lb in labels:
            run = row["runs"].get(lb)
            if run is None:
                cells += [Cell(None), Cell(None)]
                continue
            k = ["tracking", by_name[run["log"]].name, "metrics", "overall"]
            cells += [Cell(run["max_m"], "µm", 1e6, key=[*k, "max_m"]),
                      Cell(run["rms_m"], "µm", 1e6, key=[*k, "rms_m"])]
        for lb in others:
            red = row["reduction_pct"].get(lb, {})
            cells += [Cell(red.get("max"), "%", digits=3), Cell(red.get("rms"), "%", digits=3)]
        table_rows.append(cells)
    note = "Reduction = 100 (1 - error / baseline error)."
    if any(r["cut"] for r in rows):
        note = "* machining (cutting) run. " + note
    return Table("Maximum and RMS tracking error per run and controller (form of thesis Table 3.2)", columns,
                 table_rows, note)


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
    fig = runs_figure(disp, cmd, asd, error_label="table displacement [µm]", command_label=f"control signal [{unit}]",
                      spectrum_label="ASD [µm/√Hz]", title=group[0].group_title, spectrum_loglog=True)
    for ax in fig.axes[:2]:
        ax.set_xlabel("time after the release [s]")
    title = group[0].group_title
    return FigureBlock(f"time-ropesnap-{group[0].group[1]}", f"{title[0].upper()}{title[1:]}: table "
                       "displacement from its pre-release level, control signal and amplitude spectral density "
                       "of the displacement after the release (thesis Fig. 3.14, 4.17).", fig)


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
        out.append((Run(names[li.path], li, label, colors(label), group, title, metrics, label, False), d))
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
        blocks.append(FigureBlock(f"contour-{group[0].group[1]}", f"{title[0].upper()}{title[1:]}: path against "
                                  "the reference and the contour error (thesis Fig. 4.20-4.22).",
                                  contour_figure(paths, errors, title=title)))
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
        blocks: list = [_comparison_table(track, labels, rows), _runs_table(track)]
        pre = _prefilter_table(track)
        if pre is not None:
            blocks.append(pre)
        blocks.extend(_tracking_figure(g) for g in _groups(track))
        subs.append(Section("time-tracking", "Tracking and cutting", blocks))
    snaps = ropesnap_runs(inputs, names, colors, strict, warnings, gains_docs)
    if snaps:
        for r in snaps:
            data.setdefault("ropesnap", {})[r.name] = {"log": r.name, "kind": "ropesnap", "controller": r.label,
                                                       "options": dict(r.options), "metrics": r.metrics.to_dict()}
        table, reductions = _ropesnap_table(snaps)
        comparison["ropesnap"] = reductions
        blocks = [table]
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
