"""Identification section: measured vs model FRF, parameters with uncertainty, modes, fit quality (from the
model file's stored ``fit`` section: nothing is refitted), friction curves and the gantry mass distribution."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from functools import partial

import numpy as np

from ..structures import plant_of, resolve
from .collect import FrfInput, FrictionCurveInput, Inputs, LogInput, ModelInput
from .content import Alert, Cell, FigureBlock, Paragraph, Section, Table, text_cell
from .figures import PALETTE, Curve, frf_figure, friction_figure, gantry_mass_figure
from .sections import ReportLimits, parameter_table

BALLSCREW_CHANNELS = ("x1/u", "x2/u")
GANTRY_CHANNELS = ("y1/u1", "y1/u2", "y2/u1", "y2/u2")
FRF_UNITS = {"position": "{out}/{inp}", "velocity": "{out}/s/{inp}", "acceleration": "{out}/s^2/{inp}"}
COHERENCE_FAINT = 0.5
"""Measured FRF lines with a lower coherence [-] are drawn faint (``ReportLimits.coherence_trust``'s default)."""
MAX_SCATTER_POINTS = 6000
"""Points of a disturbance-estimate scatter drawn (evenly strided)."""


def frf_unit(frf) -> str:
    """Unit of an FRF's response, e.g. ``rad/V`` or ``rad/s^2/V``."""
    return FRF_UNITS.get(frf.quantity, "{out}/{inp}").format(out=frf.output_unit, inp=frf.input_unit)


def _number(x) -> float | None:
    return float(x) if isinstance(x, (int, float)) and not isinstance(x, bool) else None


# ------------------------------------------------------------------------------------------ FRF checks
def coherence_warnings(name: str, frf, band_hz, limits: ReportLimits) -> list[str]:
    """Warnings for FRF points with coherence below ``limits.coherence_min`` inside ``band_hz`` [Hz]."""
    out = []
    for ch in frf.channels:
        coh = frf.channel_coherence(ch)
        if coh is None:
            continue
        f = frf.freq_hz
        sel = (f >= band_hz[0]) & (f <= band_hz[1]) if band_hz is not None else np.ones(f.size, bool)
        low = sel & (coh < limits.coherence_min)
        if low.any():
            i = int(np.flatnonzero(sel)[np.argmin(coh[sel])])
            where = f"the fit band {band_hz[0]:g}-{band_hz[1]:g} Hz" if band_hz is not None else "the FRF"
            out.append(f"{name}: coherence of {ch} below {limits.coherence_min:g} at {int(low.sum())} of "
                       f"{int(sel.sum())} points in {where} (lowest {coh[i]:.3g} at {f[i]:.4g} Hz)")
    return out


def fit_alerts(name: str, doc: Mapping) -> list[Alert]:
    """The warnings a model file's identification stored (``fit.warnings``), as the identify command printed them."""
    fit = doc.get("fit") if isinstance(doc.get("fit"), Mapping) else {}
    return [Alert(f"{name}: {text}") for text in fit.get("warnings") or []]


def frf_alerts(name: str, frf) -> list[Alert]:
    """What ``feedtune analyze``/``tune`` warn about an FRF file as they read it: a sampled log's ZOH and
    computational delay left in (:func:`feedtune.frf_sampling.double_counting_warning`)."""
    from ..errors import cli_message
    from ..frf_sampling import double_counting_warning

    w = double_counting_warning(frf, name)
    return [] if w is None else [Alert(cli_message(w))]


def _fit_quality_warnings(name: str, fit: Mapping, limits: ReportLimits) -> list[str]:
    out = []
    for ch, q in (fit.get("fit") or {}).items():
        nrmse = _number(q.get("nrmse")) if isinstance(q, Mapping) else None
        if nrmse is not None and nrmse > limits.nrmse_max:
            out.append(f"{name}: poor fit of {ch} (NRMSE {nrmse:.3g} > {limits.nrmse_max:g})")
    return out


# ------------------------------------------------------------------------------------------ FRF figures
def _measured_curves(frf, quantity: str, channels) -> tuple[dict, dict]:
    q = frf.as_quantity(quantity)
    keep = q.freq_hz > 0
    measured, coherence = {}, {}
    for ch in channels:
        if q.has(ch):
            measured[ch] = (q.freq_hz[keep], q.channel(ch)[keep])
            c = q.channel_coherence(ch)
            if c is not None:
                coherence[ch] = (q.freq_hz[keep], c[keep])
    return measured, coherence


def _ballscrew_model_curves(model, freq_hz: np.ndarray, quantity: str, delay_s: float) -> dict:
    """Model responses of ``x1/u`` and ``x2/u`` with the identified equivalent delay [s] (as in the fit)."""
    m = model.frf(freq_hz, quantity)
    lag = np.exp(-2j * np.pi * freq_hz * delay_s)
    return {ch: (freq_hz, m.channel(ch) * lag) for ch in BALLSCREW_CHANNELS}


def _frf_block(name: str, frf, model=None, fit: Mapping | None = None,
               threshold: float = COHERENCE_FAINT) -> FigureBlock:
    """Measured (and model) FRF figure of one FRF file."""
    channels = [ch for ch in frf.channels]
    if model is not None:
        channels = [ch for ch in BALLSCREW_CHANNELS if frf.has(ch)] or channels
    measured, coherence = _measured_curves(frf, frf.quantity, channels)
    model_curves, band, caption = {}, None, f"Measured FRF {name} ({frf.quantity})."
    if model is not None:
        delay = _number((fit or {}).get("delay_s")) or 0.0
        f = frf.freq_hz[frf.freq_hz > 0]
        model_curves = _ballscrew_model_curves(model, f, frf.quantity, delay)
        b = (fit or {}).get("band_hz")
        band = [float(b[0]), float(b[1])] if isinstance(b, (list, tuple)) and len(b) == 2 else None
        caption = (f"Measured FRF {name} against the identified model ({frf.quantity}, model with the identified "
                   f"equivalent delay {delay * 1e3:.3g} ms; shaded: fit band) - thesis Fig. 3.4a.")
    if any(np.any(c[1] < threshold) for c in coherence.values()):
        caption += f" Faint: measured lines with coherence below {threshold:g}."
    fig = partial(frf_figure, channels, measured, model_curves, coherence, unit=frf_unit(frf),
                     title=f"FRF {name}" + (" vs model" if model is not None else ""), band_hz=band,
                     coherence_min=threshold)
    return FigureBlock(f"frf-{name}", caption, fig)


def _model_only_block(name: str, model) -> FigureBlock:
    top = max([m.freq_hz for m in model.modes()] + [100.0])
    f = np.logspace(0, np.log10(10 * top), 800)
    curves = _ballscrew_model_curves(model, f, "position", 0.0)
    fig = partial(frf_figure, BALLSCREW_CHANNELS, {}, curves, {}, unit=f"rad/{model.input_unit}", title=f"Model {name}")
    return FigureBlock(f"model-frf-{name}", f"Position FRF of the model {name} (no measured FRF given).", fig)


# ------------------------------------------------------------------------------------------ ball screw
def _modes_table(name: str, doc: Mapping, fit: Mapping) -> Table:
    rows = []
    for i, mode in enumerate(doc.get("modes") or []):
        rows.append([text_cell(f"mode {i + 1}"),
                     Cell(_number(mode.get("freq_hz")), "Hz", key=["identification", name, "modes", i, "freq_hz"]),
                     Cell(_number(mode.get("zeta")), "", key=["identification", name, "modes", i, "zeta"])])
    rp = _number(doc.get("real_pole_hz"))
    if rp is not None:
        rows.append([text_cell("real pole"), Cell(rp, "Hz", key=["identification", name, "real_pole_hz"]),
                     text_cell("-")])
    delay = _number(fit.get("delay_s"))
    if delay is not None:
        rows.append([text_cell("equivalent delay (beside the model)"),
                     Cell(delay, "ms", scale=1e3, key=["identification", name, "fit", "delay_s"]),
                     text_cell(f"std {fit.get('delay_std_s', 0) * 1e3:.2g} ms"
                               if _number(fit.get("delay_std_s")) is not None else "-")])
    return Table("Modes, real pole and delay", ["item", "frequency / value", "damping [-]"], rows)


def _fit_table(name: str, fit: Mapping) -> Table | None:
    quality = fit.get("fit")
    if not isinstance(quality, Mapping) or not quality:
        return None
    rows = []
    for ch, q in quality.items():
        base = ["identification", name, "fit", "fit", ch]
        rows.append([text_cell(ch), Cell(_number(q.get("nrmse")), "", key=[*base, "nrmse"]),
                     Cell(_number(q.get("mag_rms_db")), "dB", key=[*base, "mag_rms_db"]),
                     Cell(_number(q.get("phase_rms_deg")), "deg", key=[*base, "phase_rms_deg"]),
                     Cell(_number(q.get("n_points")), "", key=[*base, "n_points"])])
    band = fit.get("band_hz")
    note = f"Fit band {band[0]:g}-{band[1]:g} Hz." if isinstance(band, (list, tuple)) and len(band) == 2 else ""
    return Table("Fit quality per channel (stored in the model file)",
                 ["channel", "NRMSE", "magnitude RMS error", "phase RMS error", "points"], rows, note)


def _ballscrew_model_section(mi: ModelInput, name: str, frfs: list[tuple[str, FrfInput]],
                             limits: ReportLimits, warnings: list[str]) -> Section:
    doc, fit = mi.doc, (mi.doc.get("fit") if isinstance(mi.doc.get("fit"), Mapping) else {})
    blocks: list = []
    std = dict(fit.get("std") or {})
    std["__key__"] = ["identification", name, "fit", "std"]
    from ..models.ballscrew import LOWER_BOUNDS

    blocks.append(parameter_table("Identified parameters (eq. 3.1, thesis Table 3.1)", doc.get("params", {}),
                                  ["identification", name, "params"], std=std if len(std) > 1 else None,
                                  lower=LOWER_BOUNDS))
    blocks.append(_modes_table(name, doc, fit))
    fit_table = _fit_table(name, fit)
    if fit_table is not None:
        blocks.append(fit_table)
    blocks += fit_alerts(name, doc)
    quality = _fit_quality_warnings(name, fit, limits)
    warnings.extend(quality)
    blocks.extend(Alert(w) for w in quality)
    band = fit.get("band_hz")
    band = band if isinstance(band, (list, tuple)) and len(band) == 2 else None
    matching = [(n, f) for n, f in frfs if any(f.frf.has(ch) for ch in BALLSCREW_CHANNELS)]
    for fname, fi in matching:
        blocks.append(_frf_block(fname, fi.frf, mi.model, fit, limits.coherence_trust))
        blocks.extend(frf_alerts(fname, fi.frf))
        coh = coherence_warnings(fname, fi.frf, band, limits)
        warnings.extend(coh)
        blocks.extend(Alert(w) for w in coh)
    if not matching:
        blocks.append(_model_only_block(name, mi.model))
    return Section(f"model-{name}", f"Ball-screw model {name}", blocks)


# ------------------------------------------------------------------------------------------ friction
@dataclass(frozen=True)
class FrictionCurve:
    """A model's friction versus velocity: ``force(v)`` [command unit], units and a velocity scale."""

    mi: ModelInput
    force: Callable
    velocity_unit: str
    command_unit: str
    velocity_scale: float
    title: str


def friction_curves(inputs: Inputs) -> list[FrictionCurve]:
    """Stribeck models (kind ``friction``) and the viscous + Coulomb friction of rigid-body models."""
    out = []
    for mi in inputs.models:
        m = mi.model
        if m is None:
            continue
        if mi.kind == "friction" and hasattr(m, "force"):
            law = getattr(m, "law", "stribeck")
            title = ("Stribeck model (eq. 2.1)" if law == "stribeck" else f"{law} friction law") + (
                " with viscous friction" if getattr(m, "viscous_pos", 0.0) and law != "coulomb-viscous" else "")
            out.append(FrictionCurve(mi, m.force, m.velocity_unit, m.command_unit, m.characteristic_speed, title))
        elif plant_of(m) is not None and hasattr(m, "friction"):  # a plant model with its own friction (rigid)
            out.append(FrictionCurve(mi, m.friction, m.velocity_unit, m.command_unit, 0.0,
                                     "rigid-body friction (viscous + Coulomb)"))
    return out


def _scatter_of(li: LogInput) -> tuple[np.ndarray, np.ndarray, str, str] | None:
    """Velocity and disturbance estimate of a friction log (``v_hat, d_hat`` of the Kalman estimate)."""
    log = li.log
    for v, d in (("v_hat", "d_hat"), ("velocity", "disturbance")):
        if v in log and d in log:
            step = max(1, log.n // MAX_SCATTER_POINTS)
            return log[v][::step], log[d][::step], log.unit(v) or "m/s", log.unit(d) or "V"
    return None


DIRECTION_TEXT = {"pos": "v > 0", "neg": "v < 0"}


def _curve_name(ci: FrictionCurveInput, names: Mapping) -> str:
    return str(names.get(ci.path, ci.path.name))


def _flat_quantities(per_direction: Mapping) -> dict:
    """``{"pos": {"dc": q, ...}, ...}`` -> ``{"dc_pos": q, ...}``."""
    return {f"{name}_{key}": q for key, table in per_direction.items() if isinstance(table, Mapping)
            for name, q in table.items()}


def _friction_curve_blocks(ci: FrictionCurveInput, name: str, k: int, data: dict) -> tuple[list, list, list, str, str]:
    """Text, parameter table and warnings of a friction curve document, with its fitted curves and points.

    Returns
    -------
    (blocks, curves, points, velocity_unit, command_unit)
        Report blocks, the fitted curve per direction and the measured points (figure lines), and the units.
    """
    doc = ci.doc
    vel_unit, cmd_unit = str(doc["velocity_unit"]), str(doc["command_unit"])
    law, color = str(doc["law"]), PALETTE[(k + 1) % len(PALETTE)]
    directions = [d for d in ("pos", "neg") if d in doc["params"]]
    params = _flat_quantities(doc["params"])
    std = {n: q.get("value") if isinstance(q, Mapping) else q
           for n, q in _flat_quantities(doc.get("std") or {}).items()}
    for extra in ("mass", "rms_error", "relative_error_pct"):
        if extra in doc:
            params[extra] = doc[extra]
    if isinstance(doc.get("mass_std"), Mapping):
        std["mass"] = doc["mass_std"].get("value")
    data.setdefault("identification", {})[name] = {
        "kind": doc["kind"], "law": law, "method": doc.get("method"), "source": doc.get("source"),
        "directions": directions, "params": params, "std": std, "warnings": list(doc.get("warnings") or []),
        "velocity_unit": vel_unit, "command_unit": cmd_unit}
    fitted = " and ".join(DIRECTION_TEXT[d] for d in directions)
    text = (f"{name}: {law} law fitted to {fitted} of {doc.get('source', 'the log')} ({doc.get('method', '')}); "
            f"points: {doc['points'].get('what', 'measured friction')}.")
    if "mass" in doc:
        text += f" Mass fitted with the law: {quantity_text(doc['mass'])}."
    blocks: list = [Paragraph(text)]
    if len(directions) < 2:
        missing = "v < 0" if directions == ["pos"] else "v > 0"
        blocks.append(Alert(f"{name}: one direction only ({fitted}); the friction of {missing} is not identified, "
                            "so this curve is no friction model (a model file and a feedforward need both "
                            "directions)"))
    blocks.extend(Alert(f"{name}: {w}") for w in doc.get("warnings") or [])
    std_table = dict(std, __key__=["identification", name, "std"])
    blocks.append(parameter_table(f"Friction law ({law}) per direction: {name}", params,
                                  ["identification", name, "params"], std=std_table,
                                  note="dc: Coulomb level, ds: static level (hump: peak), omega: Stribeck "
                                       "velocity vs, viscous: Fv; levels signed as their direction."))
    curves, points = [], []
    for d in directions:
        c = doc["curve"].get(d)
        if isinstance(c, Mapping):
            curves.append(Curve(np.asarray(c["velocity"], float), np.asarray(c["force"], float),
                                f"{law} law {DIRECTION_TEXT[d]} [{cmd_unit}], {name}", color, "-", 2.0))
    pts = doc["points"]
    if pts.get("velocity"):
        points.append(Curve(np.asarray(pts["velocity"], float), np.asarray(pts["force"], float),
                            f"measured friction [{cmd_unit}], {name}", color, "o", 1.0))
    return blocks, curves, points, vel_unit, cmd_unit


def quantity_text(q) -> str:
    """``{value, unit}`` (or a number) as short text, e.g. ``25.2 N/(m/s^2)``."""
    if isinstance(q, Mapping):
        return f"{float(q['value']):.4g} {q.get('unit', '')}".strip()
    return f"{float(q):.4g}"


def friction_section(inputs: Inputs, names: Mapping, data: dict) -> Section | None:
    """Friction curves of friction and rigid-body model files over the disturbance estimates of friction
    logs, and the fitted curves of friction curve documents over their measured points (None when there is
    none of these)."""
    models = friction_curves(inputs)
    scatters = [(names[li.path], sc) for li in inputs.logs_of("friction") if (sc := _scatter_of(li)) is not None]
    curve_docs = list(getattr(inputs, "curves", []))
    if not models and not scatters and not curve_docs:
        return None
    blocks: list = []
    doc_curves, doc_points, doc_units = [], [], None
    for k, ci in enumerate(curve_docs):
        b, c, p, vu, cu = _friction_curve_blocks(ci, _curve_name(ci, names), len(models) + k, data)
        blocks += b
        doc_curves += c
        doc_points += p
        doc_units = doc_units or (vu, cu)
    vmax = max([float(np.max(np.abs(sc[0]))) for _, sc in scatters] + [0.0])
    vel_unit, cmd_unit = (scatters[0][1][2], scatters[0][1][3]) if scatters else ("m/s", "V")
    curves = []
    for i, fc in enumerate(models):
        name = names[fc.mi.path]
        span = vmax if vmax > 0 else (10.0 * fc.velocity_scale if fc.velocity_scale > 0 else 1.0)
        v = np.linspace(-span, span, 801)
        curves.append(Curve(v, fc.force(v), f"{fc.title}, {name}", PALETTE[(i + 1) % len(PALETTE)], "-", 2.0))
        vel_unit, cmd_unit = fc.velocity_unit, fc.command_unit
        data.setdefault("identification", {})[name] = _model_data(fc.mi)
        blocks.append(parameter_table(f"{fc.title[0].upper()}{fc.title[1:]}: {name}", fc.mi.doc.get("params", {}),
                                      ["identification", name, "params"]))
        blocks += fit_alerts(name, fc.mi.doc)
    pts = [Curve(sc[0], sc[1], f"disturbance estimate {n}", PALETTE[0]) for n, sc in scatters]
    if doc_units is not None and not curves and not pts:
        vel_unit, cmd_unit = doc_units
    if curves or pts:
        fig = partial(friction_figure, curves, pts, velocity_unit=vel_unit, command_unit=cmd_unit,
                              title="Friction versus velocity")
        caption = "Friction model" if curves else "Estimated disturbance versus velocity"
        if curves and pts:
            caption = "Friction model over the Kalman-filter disturbance estimate"
        blocks.append(FigureBlock("friction", caption + " (thesis eq. 2.1, §2.1.3).", fig))
    if doc_curves or doc_points:
        vu, cu = doc_units
        fig = partial(friction_figure, [*doc_points, *doc_curves], [], velocity_unit=vu, command_unit=cu,
                              title="Fitted friction law over the measured friction")
        blocks.append(FigureBlock("friction-curve", "Friction law fitted per direction (lines) over the measured "
                                  f"friction (points) [{cu} versus {vu}]: plateau means of a steady-state run, or "
                                  "F - m a of a joint fit binned by speed.", fig))
    return Section("friction", "Friction", blocks)


# ------------------------------------------------------------------------------------------ gantry, others
def _mass_points(inputs: Inputs) -> dict | None:
    """Per-position side masses ``{"mass_x", "m1", "m2"}`` [m, V/(m/s^2)] of gantry mass documents."""
    xs, m1, m2 = [], [], []
    for o in inputs.others:
        for p in (o.doc or {}).get("positions") or []:
            if isinstance(p, Mapping) and all(_number(p.get(k)) is not None for k in ("x", "m1", "m2")):
                xs.append(float(p["x"]))
                m1.append(float(p["m1"]))
                m2.append(float(p["m2"]))
    return {"mass_x": xs, "m1": m1, "m2": m2} if xs else None


def _gantry_frf_block(name: str, fi: FrfInput, model) -> FigureBlock:
    """Measured 2x2 FRF against the model at the FRF's table position (``x_m`` in its metadata; thesis Fig. 4.7)."""
    frf = fi.frf
    x = _number(_float_or_none(frf.meta.get("x_m")))
    channels = [ch for ch in GANTRY_CHANNELS if frf.has(ch)]
    measured, coherence = _measured_curves(frf, frf.quantity, channels)
    curves, caption = {}, f"Measured gantry FRF {name} ({frf.quantity})"
    if x is not None:
        f = frf.freq_hz[frf.freq_hz > 0]
        m = model.frf(f, x, frf.quantity)
        curves = {ch: (f, m.channel(ch)) for ch in channels if m.has(ch)}
        caption += f" against the model at x = {x:g} m (thesis Fig. 4.7)"
    fig = partial(frf_figure, channels, measured, curves, coherence, unit=frf_unit(frf), width=14.0,
                     title=f"FRF {name}" + (f" vs model at x = {x:g} m" if x is not None else ""))
    return FigureBlock(f"frf-{name}", caption + ".", fig)


def _float_or_none(v):
    try:
        return float(v)
    except (TypeError, ValueError):
        return None


def _gantry_section(mi: ModelInput, name: str, inputs: Inputs, names: Mapping, limits: ReportLimits,
                    warnings: list[str]) -> tuple[Section, set]:
    model = mi.model
    half = model.L / 2.0
    x = np.linspace(-half, half, 101)
    masses = np.array([model.side_masses(float(v)) for v in x])
    inertia = np.array([model.inertia(float(v)) for v in x])
    yaw = np.array([model.yaw_mode(float(v)).freq_hz for v in x])
    fit = mi.doc.get("fit") if isinstance(mi.doc.get("fit"), Mapping) else {}
    pts = [p for p in fit.get("yaw_modes") or [] if isinstance(p, Mapping)]
    points = {"yaw_x": [p.get("x") for p in pts], "yaw_hz": [p.get("fit_freq_hz") for p in pts]} if pts else {}
    mass_points = _mass_points(inputs)
    if mass_points:
        points.update(mass_points)
    unit = model.input_unit
    fig = partial(gantry_mass_figure, x, masses, inertia, yaw, mass_unit=f"{unit}/(m/s^2)",
                  inertia_unit=f"{unit} m s^2", points=points or None)
    blocks = [parameter_table("Gantry model parameters (eq. 4.1-4.4, 4.16)", mi.doc.get("params", {}),
                              ["identification", name, "params"]),
              FigureBlock(f"gantry-mass-{name}", "Mass distribution, yaw inertia and yaw-mode frequency versus "
                          f"table position over the span ±L/2 = ±{half:.3g} m; points: identified per position "
                          "(thesis Fig. 4.5).", fig)]
    blocks += fit_alerts(name, mi.doc)
    used = set()
    for fi in inputs.frfs:
        if all(fi.frf.has(ch) for ch in GANTRY_CHANNELS):
            blocks.append(_gantry_frf_block(names[fi.path], fi, model))
            blocks.extend(frf_alerts(names[fi.path], fi.frf))
            used.add(names[fi.path])
    return Section(f"model-{name}", f"Gantry model {name}", blocks), used


def ballscrew_model_section(mi: ModelInput, name: str, inputs: Inputs, names: Mapping, limits: ReportLimits,
                            warnings: list[str]) -> tuple[Section, set[str]]:
    """The section of a two-mass (ball-screw) model file and the names of the FRFs it draws."""
    frfs = [(names[f.path], f) for f in inputs.frfs]
    used = {n for n, f in frfs if any(f.frf.has(ch) for ch in BALLSCREW_CHANNELS)}
    return _ballscrew_model_section(mi, name, frfs, limits, warnings), used


def gantry_model_section(mi: ModelInput, name: str, inputs: Inputs, names: Mapping, limits: ReportLimits,
                         warnings: list[str]) -> tuple[Section, set[str]]:
    """The section of a gantry model file and the names of the FRFs it draws."""
    return _gantry_section(mi, name, inputs, names, limits, warnings)


def rigid_model_section(mi: ModelInput, name: str, inputs: Inputs, names: Mapping, limits: ReportLimits,
                        warnings: list[str]) -> tuple[None, set[str]]:
    """None: a rigid-body model is drawn by its friction in the friction subsection (:func:`friction_curves`)."""
    return None, set()


def _generic_model_section(mi: ModelInput, name: str) -> Section:
    blocks: list = []
    params = mi.doc.get("params")
    if isinstance(params, Mapping) and params:
        blocks.append(parameter_table(f"Parameters of {name}", params, ["identification", name, "params"]))
    if mi.note:
        blocks.append(Paragraph(f"{name}: {mi.note}; the parameters are listed as stored."))
    if not blocks:
        blocks.append(Paragraph(f"{name}: model kind {mi.kind!r} holds no parameter table to show."))
    blocks += fit_alerts(name, mi.doc)
    return Section(f"model-{name}", f"Model {name} ({mi.kind})", blocks)


def _model_data(mi: ModelInput) -> dict:
    keys = ("kind", "input_unit", "command_unit", "velocity_unit", "position_unit", "lead_m_per_rad",
            "real_pole_hz", "params", "modes", "fit")
    return {k: mi.doc[k] for k in keys if k in mi.doc}


# ------------------------------------------------------------------------------------------ section
def identification_section(inputs: Inputs, names: Mapping, limits: ReportLimits, data: dict,
                           warnings: list[str]) -> Section | None:
    """The identification section for the given models, FRFs and friction logs (None when none is given).

    Fills ``data["identification"]`` with each model file's parameters and stored fit, and appends fit and
    coherence warnings to ``warnings``.
    """
    subs: list[Section] = []
    frfs = [(names[f.path], f) for f in inputs.frfs]
    used_frfs: set[str] = set()
    ident = data.setdefault("identification", {})
    for mi in inputs.models:
        name = names[mi.path]
        plant = plant_of(mi.model) if mi.model is not None else None
        if plant is not None and plant.report is not None:  # the section its plant structure names
            section, used = resolve(plant.report)(mi, name, inputs, names, limits, warnings)
            if section is not None:
                ident[name] = _model_data(mi)
                subs.append(section)
            used_frfs |= used
        elif mi.model is not None and mi.kind == "friction":
            continue  # shown in the friction subsection
        else:
            ident[name] = _model_data(mi)
            subs.append(_generic_model_section(mi, name))
    for name, fi in frfs:
        if name in used_frfs:
            continue
        blocks: list = [_frf_block(name, fi.frf, threshold=limits.coherence_trust), *frf_alerts(name, fi.frf)]
        blocks.extend(Paragraph(w + "; no model fit band to judge it against.")
                      for w in coherence_warnings(name, fi.frf, None, limits))
        subs.append(Section(f"frf-{name}", f"Measured FRF {name}", blocks))
    fr = friction_section(inputs, names, data)
    if fr is not None:
        subs.append(fr)
    if not subs:
        return None
    return Section("identification", "Identification", [], subs)
