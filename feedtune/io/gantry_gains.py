"""Gains documents of the gantry (``kind = "gantry"``, MIMO or PID) and of the loop-shaped x axis (``"axis"``).

Schema ``"feedtune.gains/1.1"`` like the ball-screw gains file (:mod:`feedtune.io.gains`): numbers with a
unit are ``{"value", "unit"}``, discrete filters are second-order sections ``[b0, b1, b2, a0, a1, a2]`` in
powers of ``z^-1`` at ``fs`` run as a transposed-direct-form-II cascade (``scipy.signal.sosfilt``), the
position-dependent quantities of eq. 4.33 are tables over the table position ``x`` (linear interpolation,
clamped at the ends). ``docs/gantry_gains.md`` describes every key and the execution order;
:mod:`feedtune.machines.gantry.runtime` executes exactly that, reading nothing else.

This module reads and checks those documents (used by the runtime) and builds them from designs
(:func:`gantry_gains_document`, :func:`axis_gains_document`).
"""

from __future__ import annotations

import numpy as np

from .. import __version__
from ..errors import DataError
from .document import require_schema, strip_none
from .gains import SCHEMA, q, read_sampling, value

GANTRY_KIND = "gantry"
AXIS_KIND = "axis"
GANTRY_CONTROLLERS = ("mimo", "pid")

PREFILTER_TERMS = ("vel", "acc", "jerk", "snap")
PREFILTER_UNITS = {"vel": "s", "acc": "s^2", "jerk": "s^3", "snap": "s^4"}

SCHEDULE_COLUMNS = (
    "alpha1", "alpha2", "m11", "m12", "m22",
    *(f"k_{t}_1" for t in PREFILTER_TERMS),
    *(f"k_{t}_2" for t in PREFILTER_TERMS),
)


def schedule_units(command_unit: str = "V") -> dict[str, str]:
    """Units of the schedule columns (and of ``x``)."""
    u = command_unit
    out = {"x": "m", "alpha1": "-", "alpha2": "-", "m11": f"{u}/(m/s^2)", "m12": f"{u}/(m/s^2)",
           "m22": f"{u}/(m/s^2)"}
    for side in (1, 2):
        out.update({f"k_{t}_{side}": PREFILTER_UNITS[t] for t in PREFILTER_TERMS})
    return out


def mimo_gain_units(command_unit: str = "V") -> dict[str, str]:
    """Units of the MIMO ``[gains]``: active-damping ``beta`` and actuator-level integral ``ki``."""
    return {"beta": f"{command_unit}/(m/s)", "ki": f"{command_unit}/(m*s)"}


def pid_gain_units(command_unit: str = "V") -> dict[str, str]:
    """Units of the PID ``[gains]`` (``kp1, kd1, ki1, kp2, kd2, ki2``)."""
    u = command_unit
    out = {}
    for side in (1, 2):
        out.update({f"kp{side}": f"{u}/m", f"kd{side}": f"{u}/(m/s)", f"ki{side}": f"{u}/(m*s)"})
    return out


MIMO_LAW_TEXT = (
    "every sample k, r = y_r[k+P]: d_n = prefilter_n(r) (n = vel, acc, jerk, snap); "
    "s = schedule(x[k]) (linear interpolation, clamped); ra_i = r + sum_n k_n_i d_n; "
    "acc_i = acceleration(ra_i); yr_i = position(ra_i); uff = [[m11, m12], [m12, m22]] [acc_1, acc_2]; "
    "e_i = yr_i - y_i[k]; on the first sample e_prev = e; ebar = alpha1 e_1 + alpha2 e_2; v = lead(ebar); "
    "dd = ((e_1 - e_2) - (e_1 - e_2)_prev) fs; ie_i += e_i / fs; "
    "w_1 = alpha1 (v + beta dd + ki ie_1); w_2 = alpha2 (v - beta dd + ki ie_2); "
    "u_i = filter_pack_i(w_i) + uff_i; u is applied delay_samples after y_1[k], y_2[k] were sampled"
)

PID_LAW_TEXT = (
    "every sample k, r = y_r[k+P]: d_n = prefilter_n(r); s = schedule(x[k]); ra_i = r + sum_n k_n_i d_n; "
    "acc_i = acceleration(ra_i); yr_i = position(ra_i); uff = [[m11, m12], [m12, m22]] [acc_1, acc_2]; "
    "e_i = yr_i - y_i[k]; on the first sample e_prev = e; de_i = (e_i - e_i_prev) fs; ie_i += e_i / fs; "
    "w_i = kp_i e_i + kd_i de_i + ki_i ie_i; u_i = filter_pack_i(w_i) + uff_i; "
    "u is applied delay_samples after y_1[k], y_2[k] were sampled"
)

GANTRY_FRICTION_TEXT = ("v_r = (r - r_prev) fs (0 on the first sample); r_prev = r; d = friction(v_r); "
                        "uff_1 += alpha1 d; uff_2 += alpha2 d; ")
"""What a ``[friction_feedforward]`` adds to a gantry law (after the inertia feedforward)."""

GANTRY_FRICTION_VELOCITY_TEXT = (
    "v_r[k] = (y_r[k+P] - y_r[k+P-1]) * fs (backward difference of the previewed gantry reference, not pre-filtered; "
    "0 on the first sample) [m/s]; d = d(v_r), linear through 0 for |v_r| < v_band; u_1 += alpha1(x) d, "
    "u_2 += alpha2(x) d (the split of the inertia feedforward: alpha_i m = row sums of M(x))")


def gantry_law_text(controller: str, friction: bool = False) -> str:
    """The execution text of a gantry law (``"mimo"`` or ``"pid"``), with the friction feedforward's terms."""
    text = MIMO_LAW_TEXT if controller == "mimo" else PID_LAW_TEXT
    anchor = "uff = [[m11, m12], [m12, m22]] [acc_1, acc_2]; "
    return text.replace(anchor, anchor + GANTRY_FRICTION_TEXT) if friction else text


AXIS_LAW_TEXT = (
    "every sample k, r = x_r[k+P]: d_n = prefilter_n(r); ra = r + sum_n k_n d_n; xr = position(ra); "
    "uff = mass * acceleration(r); e = xr - x[k]; u = controller(e) + uff; "
    "u is applied delay_samples after x[k] was sampled"
)

AXIS_FRICTION_LAW_TEXT = (
    "every sample k, r = x_r[k+P]: d_n = prefilter_n(r); ra = r + sum_n k_n d_n; xr = position(ra); "
    "uff = mass * acceleration(r); v_r = (r - r_prev) fs (0 on the first sample); r_prev = r; uff += friction(v_r); "
    "e = xr - x[k]; u = controller(e) + uff; u is applied delay_samples after x[k] was sampled"
)
"""The axis law with a ``[friction_feedforward]`` (Stribeck eq. 2.1 of the reference velocity, m/s)."""

AXIS_FRICTION_VELOCITY_TEXT = (
    "v_r[k] = (x_r[k+P] - x_r[k+P-1]) * fs (backward difference of the previewed reference, not pre-filtered; 0 on "
    "the first sample) [m/s]; uff += d(v_r), linear through 0 for |v_r| < v_band")

SCHEDULE_TEXT = "linear interpolation in the table position x, clamped to the first/last row outside the table"


# --------------------------------------------------------------------------------------------- reading
def check_header(doc, where: str, kinds: tuple[str, ...] = (GANTRY_KIND, AXIS_KIND)) -> str:
    """Schema version 1 and a machine kind in ``kinds``; returns the kind. DataError otherwise."""
    if not isinstance(doc, dict):
        raise DataError(f"{where}: a gains document must be a table/object at the top level")
    require_schema(doc, "feedtune.gains", where, written=SCHEMA)
    kind = doc.get("kind")
    if kind not in kinds:
        raise DataError(f"{where}: gains file is for machine kind {kind!r}, expected {' or '.join(map(repr, kinds))}")
    from .gains_schema import validate_gains

    validate_gains(doc, where)
    return str(kind)


def section(doc: dict, name: str, where: str) -> dict:
    """A required table of the document."""
    sec = doc.get(name)
    if not isinstance(sec, dict):
        raise DataError(f"{where}: gains file has no [{name}] section")
    return sec


def entry(sec: dict, sec_name: str, key: str, where: str):
    """A required entry ``sec_name.key``."""
    if key not in sec:
        raise DataError(f"{where}: gains file has no {sec_name}.{key}")
    return sec[key]


def axis_friction(doc: dict, where: str):
    """The :class:`~feedtune.control.friction.FrictionFeedforward` of an axis or gantry document's
    ``[friction_feedforward]`` (velocities in m/s, levels in the command unit), or None without one."""
    if doc.get("friction_feedforward") is None:
        return None
    from ..control.friction import LINEAR_VELOCITY
    from .gains import friction_from_section

    return friction_from_section(doc["friction_feedforward"], command_unit(doc), where, LINEAR_VELOCITY)


def command_unit(doc: dict) -> str:
    """The drive's command unit from ``[units]`` (default ``"V"``)."""
    units = doc.get("units")
    return str(units.get("command", "V")) if isinstance(units, dict) else "V"


def read_gains(doc: dict, names_units: dict[str, str], where: str) -> dict[str, float]:
    """The numbers of ``[gains]`` named in ``names_units`` (checked against their units)."""
    sec = section(doc, "gains", where)
    return {n: value(entry(sec, "gains", n, where), f"{where}: gains.{n}", u) for n, u in names_units.items()}


def read_schedule(doc: dict, where: str) -> tuple[np.ndarray, np.ndarray]:
    """``(x [m], table)`` of ``[schedule]``: ``table[i]`` holds :data:`SCHEDULE_COLUMNS` at ``x[i]``.

    Raises
    ------
    DataError
        Missing column, lengths that differ, non-finite numbers, ``x`` not strictly increasing.
    """
    sec = section(doc, "schedule", where)
    cols = {}
    for name in ("x", *SCHEDULE_COLUMNS):
        raw = entry(sec, "schedule", name, where)
        if not isinstance(raw, (list, tuple)) or len(raw) == 0:
            raise DataError(f"{where}: schedule.{name} must be a non-empty list of numbers")
        try:
            arr = np.array([float(v) for v in raw])
        except (TypeError, ValueError):
            raise DataError(f"{where}: schedule.{name} must be a list of numbers") from None
        if not np.all(np.isfinite(arr)):
            raise DataError(f"{where}: schedule.{name} contains non-finite values")
        cols[name] = arr
    n = cols["x"].size
    for name, arr in cols.items():
        if arr.size != n:
            raise DataError(f"{where}: schedule.{name} has {arr.size} rows, schedule.x has {n}")
    if np.any(np.diff(cols["x"]) <= 0):
        raise DataError(f"{where}: schedule.x must be strictly increasing [m]")
    units = sec.get("units")
    if isinstance(units, dict):
        for name, unit in schedule_units(command_unit(doc)).items():
            if name in units and units[name] != unit:
                raise DataError(f"{where}: schedule.{name} has unit {units[name]!r}, expected {unit!r}")
    return cols["x"], np.column_stack([cols[c] for c in SCHEDULE_COLUMNS])


# -------------------------------------------------------------------------------------------- building
def _sos(z) -> list:
    return [[float(c) for c in row] for row in z.to_sos()]


def _law_section(text: str) -> dict:
    return {
        "execution": text,
        "schedule": SCHEDULE_TEXT,
        "filters": "second-order sections [b0, b1, b2, a0, a1, a2] in z^-1, cascade, transposed direct form II "
                   "(scipy.signal.sosfilt), states zero at start",
        "derivative": "backward difference (e[k] - e[k-1]) fs",
        "integrator": "backward Euler ie[k] = ie[k-1] + e[k] / fs",
        "discretization": "pole-zero matching",
    }


def _reference_section(prefilter_hz: float, fs: float) -> dict:
    from ..control.prefilter import reference_filters

    refs = reference_filters(prefilter_hz, fs)
    out = {f"{name}_sos": _sos(z) for name, z in refs.items()}
    out["prefilter_hz"] = q(prefilter_hz, "Hz")
    return out


def _sampling(fs: float, delay: int, preview: int) -> dict:
    return {"fs_hz": q(fs, "Hz"), "delay_samples": int(delay), "preview_samples": int(preview)}


def gantry_gains_document(design) -> dict:
    """The gains document of a :class:`GantryMimoDesign` or :class:`GantryPidDesign`.

    With the design's friction feedforward (``design.friction``, command unit and m/s of the gantry's travel) the
    document has a ``[friction_feedforward]`` section (the axis' format) and the law's execution text includes it:
    ``d(v_r)`` split ``alpha1 d, alpha2 d`` between the drives.

    Parameters
    ----------
    design : GantryMimoDesign or GantryPidDesign

    Without a certificate: :func:`feedtune.workflows.deliver.deliver` certifies it and adds the ``[certificate]``.
    """
    from .gantry_model import gantry_model_to_doc

    law = design.law
    unit = design.model.input_unit
    sched = design.schedule
    columns = dict(zip(SCHEDULE_COLUMNS, sched.table().T, strict=True))
    filters: dict = {"continuous": law.filters.to_dict(), "filter_pack_sos": _sos(law.filter_pack_discrete())}
    if law.controller == "mimo":
        gains = {"beta": q(law.beta, mimo_gain_units(unit)["beta"]), "ki": q(law.ki, mimo_gain_units(unit)["ki"])}
        filters["lead_sos"] = _sos(law.lead_discrete())
        filters["lead"] = {"gain": q(law.lead_gain, f"{unit}/m"),
                           "stages": [{"center_hz": s.center_hz, "phase_deg": s.phase_deg} for s in law.lead_stages]}
    else:
        units = pid_gain_units(unit)
        gains = {}
        for i, side in enumerate((1, 2)):
            gains.update({f"kp{side}": q(law.kp[i], units[f"kp{side}"]), f"kd{side}": q(law.kd[i], units[f"kd{side}"]),
                          f"ki{side}": q(law.ki[i], units[f"ki{side}"])})
    friction = getattr(design, "friction", None)
    text = gantry_law_text(law.controller, friction is not None)
    doc = {
        "schema": SCHEMA,
        "kind": GANTRY_KIND,
        "controller": law.controller,
        "created_by": f"feedtune {__version__}",
        "sampling": _sampling(law.fs, law.delay_samples, design.preview_samples),
        "units": {"position": "m", "command": unit, "time": "s"},
        "law": _law_section(text),
        "gains": gains,
        "filters": filters,
        "reference": _reference_section(design.prefilter_hz, law.fs),
        "schedule": {"x": [float(v) for v in sched.x], **{k: [float(v) for v in col] for k, col in columns.items()},
                     "units": schedule_units(unit)},
        "model": gantry_model_to_doc(design.model),
        "design": strip_none(design.design_dict()),
    }
    if friction is not None:
        doc["friction_feedforward"] = friction.section(GANTRY_FRICTION_VELOCITY_TEXT)
    return doc


def axis_gains_document(design) -> dict:
    """The gains document of a loop-shaped axis (:class:`~feedtune.design.loopshape.LoopShapeDesign`), in the
    command unit of its plant.

    With the design's friction feedforward (``design.friction``) the document has a ``[friction_feedforward]``
    section (the ball screw's format, velocities in m/s) and the law's execution text includes it.

    Parameters
    ----------
    design : LoopShapeDesign

    Without a certificate: :func:`feedtune.workflows.deliver.deliver` certifies it and adds the ``[certificate]``.
    """
    unit = design.plant.command_unit
    pre = design.prefilter
    friction = getattr(design, "friction", None)
    return strip_none({
        "schema": SCHEMA,
        "kind": AXIS_KIND,
        "controller": "loopshape",
        "created_by": f"feedtune {__version__}",
        "sampling": _sampling(design.fs, design.delay_samples, design.preview_samples),
        "units": {"position": "m", "command": unit, "time": "s"},
        "law": _law_section(AXIS_LAW_TEXT if friction is None else AXIS_FRICTION_LAW_TEXT),
        "gains": {"K": q(design.gain, f"{unit}/(m*s)"), "Ti": q(design.ti_s, "s")},
        "filters": {
            "continuous": design.filters.to_dict(),
            "lead_stages": [{"center_hz": s.center_hz, "phase_deg": s.phase_deg} for s in design.lead_stages],
            "controller_sos": _sos(design.controller_discrete()),
        },
        "reference": _reference_section(design.prefilter_hz, design.fs),
        "feedforward": {"mass": q(design.plant.mass, f"{unit}/(m/s^2)")},
        "prefilter": {f"k_{t}": q(v, PREFILTER_UNITS[t]) for t, v in zip(PREFILTER_TERMS, pre.values(), strict=True)},
        "friction_feedforward": None if friction is None else friction.section(AXIS_FRICTION_VELOCITY_TEXT),
        "model": {"kind": AXIS_KIND, "mass": q(design.plant.mass, f"{unit}/(m/s^2)"), "source": design.plant.source,
                  "mass_method": design.plant.mass_method},
        "design": design.design_dict(),
    })


# -------------------------------------------------------------------------------- rebuilding designs
def _sampling_values(doc: dict, where: str) -> tuple[float, int]:

    fs, delay, _ = read_sampling(doc, where)
    return fs, delay


def design_position(doc: dict, where: str) -> float:
    """The design table position ``design.x_m`` [m] of a gantry gains document (0 when absent)."""
    design = doc.get("design")
    if not isinstance(design, dict) or "x_m" not in design:
        return 0.0
    return value(design["x_m"], f"{where}: design.x_m", "m")


def _stages(raw, where: str):
    from ..control.filters import LeadStage

    if not isinstance(raw, list):
        raise DataError(f"{where}: expected a list of lead stages {{center_hz, phase_deg}}")
    try:
        return tuple(LeadStage(float(s["center_hz"]), float(s["phase_deg"])) for s in raw)
    except (KeyError, TypeError, ValueError) as exc:
        raise DataError(f"{where}: invalid lead stage ({exc})") from None


def gantry_law_from_document(doc: dict, where: str = "gains file", x: float | None = None):
    """Rebuild ``(law, model, x, reference)`` of a gantry gains document for analysis.

    The law is the continuous/discrete description (filters, lead, gains) at the table position ``x`` [m]
    (default: the design position ``design.x_m``) with ``alpha`` taken from the schedule there, as the target
    runs it; ``reference`` holds the feedforward and pre-filters there.
    """
    from ..control.filters import FilterPack
    from ..control.gantry import GantryReference, MimoLaw, PidLaw
    from ..control.prefilter import PrefilterGains
    from .gantry_model import gantry_model_from_doc

    check_header(doc, where, (GANTRY_KIND,))
    controller = doc.get("controller")
    if controller not in GANTRY_CONTROLLERS:
        raise DataError(f"{where}: controller {controller!r} unknown; expected 'mimo' or 'pid'")
    fs, delay = _sampling_values(doc, where)
    unit = command_unit(doc)
    model = gantry_model_from_doc(section(doc, "model", where), f"{where}: [model]")
    fsec = section(doc, "filters", where)
    pack = FilterPack.from_dict(entry(fsec, "filters", "continuous", where), f"{where}: filters.continuous")
    x = design_position(doc, where) if x is None else float(x)
    xs, table = read_schedule(doc, where)
    row = np.array([np.interp(x, xs, col) for col in table.T])
    if controller == "mimo":
        g = read_gains(doc, mimo_gain_units(unit), where)
        lead = entry(fsec, "filters", "lead", where)
        if not isinstance(lead, dict):
            raise DataError(f"{where}: filters.lead must be a table with gain and stages")
        gain = value(entry(lead, "filters.lead", "gain", where), f"{where}: filters.lead.gain", f"{unit}/m")
        stages = _stages(entry(lead, "filters.lead", "stages", where), f"{where}: filters.lead.stages")
        law = MimoLaw((float(row[0]), float(row[1])), gain, stages, g["beta"], g["ki"], pack, fs, delay)
    else:
        g = read_gains(doc, pid_gain_units(unit), where)
        law = PidLaw((g["kp1"], g["kp2"]), (g["kd1"], g["kd2"]), (g["ki1"], g["ki2"]), pack, fs, delay)
    ref_sec = section(doc, "reference", where)
    pre_hz = value(entry(ref_sec, "reference", "prefilter_hz", where), f"{where}: reference.prefilter_hz", "Hz")
    reference = GantryReference(np.array([[row[2], row[3]], [row[3], row[4]]]), PrefilterGains(*row[5:9]),
                                PrefilterGains(*row[9:13]), pre_hz)
    return law, model, x, reference


def axis_law_from_document(doc: dict, where: str = "gains file"):
    """Rebuild the :class:`~feedtune.control.axis.AxisLaw` of an axis gains document (DataError naming the key)."""
    from ..control.axis import AxisLaw
    from ..control.filters import FilterPack
    from ..control.prefilter import PrefilterGains

    check_header(doc, where, (AXIS_KIND,))
    fs, delay = _sampling_values(doc, where)
    unit = command_unit(doc)
    g = read_gains(doc, {"K": f"{unit}/(m*s)", "Ti": "s"}, where)
    if g["Ti"] <= 0:
        raise DataError(f"{where}: gains.Ti must be > 0 s")
    fsec = section(doc, "filters", where)
    pack = FilterPack.from_dict(entry(fsec, "filters", "continuous", where), f"{where}: filters.continuous")
    stages = _stages(entry(fsec, "filters", "lead_stages", where), f"{where}: filters.lead_stages")
    ff = section(doc, "feedforward", where)
    mass = value(entry(ff, "feedforward", "mass", where), f"{where}: feedforward.mass", f"{unit}/(m/s^2)")
    if mass <= 0:
        raise DataError(f"{where}: feedforward.mass must be > 0")
    pre = section(doc, "prefilter", where)
    gains = [value(entry(pre, "prefilter", f"k_{t}", where), f"{where}: prefilter.k_{t}", PREFILTER_UNITS[t])
             for t in PREFILTER_TERMS]
    ref_sec = section(doc, "reference", where)
    pre_hz = value(entry(ref_sec, "reference", "prefilter_hz", where), f"{where}: reference.prefilter_hz", "Hz")
    return AxisLaw(mass, g["K"], g["Ti"], tuple(stages), pack, fs, delay, PrefilterGains(*gains), pre_hz)
