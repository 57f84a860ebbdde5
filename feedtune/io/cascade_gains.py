"""Gains documents of the drive cascade (``kind = "cascade"``, docs/cascade.md): speed PI, current-setpoint filters,
position gain and feedforward of a one-encoder axis, each loop at its own rate.

Schema ``"feedtune.gains/1.1"`` like every gains file (numbers with a unit are ``{"value", "unit"}``). The document
holds the filters twice: as the drive's parameters (``filters.current_setpoint``: PT1, PT2 and general second-order
filters, :mod:`feedtune.control.drive_tuning`) and as the second-order sections a target runs at the speed-loop rate
(``filters.current_setpoint_sos``); the reader refuses a file whose sections are not the discretization of its
parameters (an edit of one without the other). :mod:`feedtune.machines.cascade.runtime` executes exactly what
``[law].execution`` says, reading nothing else; the analysis (``feedtune analyze``) rebuilds the law and the plant
model (``[model]``: the mechanics and the current loop assumed) from the same document.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np

from .. import __version__
from ..control.cascade import CascadeLaw
from ..control.drive_tuning import Pt1Filter, Pt2Filter, SecondOrderFilter
from ..errors import DataError, UsageError
from ..models.ballscrew import BallScrewModel
from ..models.cascade_plant import CascadePlant
from .document import strip_none
from .gains import SCHEMA, q, read_sampling, read_sos, value

CASCADE_KIND = "cascade"
IDENTITY_SECTION = [1.0, 0.0, 0.0, 1.0, 0.0, 0.0]
"""The section a document without filters holds (a cascade of sections has at least one)."""
SOS_TOLERANCE = 1e-9
"""Largest difference between a document's sections and the discretization of its filters [-, relative to the
largest coefficient]."""

LAW_TEXT = (
    "every speed sample k at fs, positions in the axis' unit: on the first sample x1_prev = x1[k], r_prev = r[k], "
    "vr_prev = 0; if k mod N = 0 (the position loop at fp = fs / N): vr = (r[k] - r_prev) fp; "
    "ar = (vr - vr_prev) fp; r_prev = r[k]; vr_prev = vr; xp = x2[k] if the position loop is on the load encoder "
    "else x1[k]; w = Kv (r[k] - xp) + kv_ff vr; iff = J_ff ar (w and iff held until the next position sample); "
    "every sample: v = (x1[k] - x1_prev) fs; x1_prev = x1[k]; e = w - v; I += Kp / (fs Tn) e; "
    "u = current_setpoint_filters(Kp e + I + iff); u is applied delay_samples after x1[k] was sampled"
)


def _filter_from(d, where: str):
    if not isinstance(d, Mapping):
        raise DataError(f"{where}: expected a table with kind and the filter's parameters")
    kind, enabled = d.get("kind"), d.get("enabled", True)
    if not isinstance(enabled, bool):
        raise DataError(f"{where}: enabled must be true or false, got {enabled!r}")
    names = {"PT1": ("time_constant_s",), "PT2": ("freq_hz", "damping"),
             "second_order": ("num_freq_hz", "num_damping", "den_freq_hz", "den_damping")}
    if kind not in names:
        raise DataError(f"{where}: kind must be PT1, PT2 or second_order, got {kind!r}")
    vals = []
    for n in names[kind]:
        if n not in d:
            raise DataError(f"{where}: a {kind} filter needs {n}")
        vals.append(value(d[n], f"{where}.{n}"))
    cls = {"PT1": Pt1Filter, "PT2": Pt2Filter, "second_order": SecondOrderFilter}[kind]
    try:
        return cls(*vals, enabled)
    except DataError as exc:
        raise DataError(f"{where}: {exc}") from None


def _mechanics_doc(plant: CascadePlant) -> dict:
    m = plant.mechanics
    if isinstance(m, BallScrewModel):
        from .gains import model_section

        return model_section(m)
    from .rigid_model import rigid_to_doc

    return {"kind": "rigid", **rigid_to_doc(m)}


def _mechanics_from(sec, where: str, command_unit: str):
    if not isinstance(sec, Mapping):
        raise DataError(f"{where}: expected the mechanics' table (kind = \"rigid\" or \"ballscrew\")")
    kind = sec.get("kind")
    if kind == "rigid":
        from .rigid_model import rigid_from_doc

        return rigid_from_doc(sec, where)
    if kind == "ballscrew":
        from .gains import model_from_section

        return model_from_section(dict(sec), where, command_unit)
    raise DataError(f"{where}: kind must be 'rigid' or 'ballscrew', got {kind!r}")


def cascade_gains_document(design) -> dict:
    """The gains document of a :class:`~feedtune.design.cascade.CascadeDesign` (its law, plant model and design
    record). Without a certificate: :func:`feedtune.workflows.deliver.deliver` certifies it and adds the
    ``[certificate]``."""
    return cascade_document(design.law, design.plant, design.design_dict())


def cascade_document(law: CascadeLaw, plant: CascadePlant | None, design: Mapping | None = None) -> dict:
    """The gains document of a cascade law, its plant model (None: no ``[model]``) and a design record (``[design]``:
    where the law comes from, e.g. a drive's parameter file read back)."""
    units = law.gain_units()
    gains = {"Kp": q(law.kp, units["Kp"]), "Kv": q(law.kv, units["Kv"]), "kv_ff": q(law.kv_ff, "-"),
             "J_ff": q(law.inertia_ff, units["J_ff"])}
    if not math.isinf(law.tn_s):
        gains["Tn"] = q(law.tn_s, "s")
    sos = law.filter_sos()
    return strip_none({
        "schema": SCHEMA,
        "kind": CASCADE_KIND,
        "controller": CASCADE_KIND,
        "created_by": f"feedtune {__version__}",
        "sampling": {"fs_hz": q(law.fs, "Hz"), "delay_samples": law.delay_samples, "preview_samples": 0},
        "units": {"position": law.position_unit, "command": law.command_unit, "time": "s"},
        "law": {"execution": LAW_TEXT,
                "filters": "second-order sections [b0, b1, b2, a0, a1, a2] in z^-1 at fs, cascade, transposed "
                           "direct form II (scipy.signal.sosfilt), states zero at start",
                "discretization": "PT1, PT2 and general second-order filters: bilinear transform with the numerator "
                                  "and the denominator each prewarped at its own frequency",
                "integrator": "backward Euler I[k] = I[k-1] + Kp / (fs Tn) e[k] (no Tn: no integral action)",
                "speed": "backward difference (x1[k] - x1[k-1]) fs",
                "position_loop": "every N speed samples; its output held between them"},
        "gains": gains,
        "position_loop": {"ratio": law.position_ratio, "fs_hz": q(law.fp, "Hz"), "encoder": law.position_encoder},
        "filters": {"current_setpoint": [f.to_dict() for f in law.filters],
                    "current_setpoint_sos": [[float(c) for c in r] for r in sos] if sos.size else [IDENTITY_SECTION]},
        "model": None if plant is None else {"mechanics": _mechanics_doc(plant),
                                             "current_loop_hz": None if plant.current_loop_hz is None
                                             else q(plant.current_loop_hz, "Hz")},
        "design": None if design is None else dict(design),
    })


def _ratio(sec: Mapping, where: str) -> int:
    n = sec.get("ratio")
    if isinstance(n, bool) or not isinstance(n, (int, float)) or n != int(n) or n < 1:
        raise DataError(f"{where}: position_loop.ratio must be an integer >= 1 (speed samples per position sample), "
                        f"got {n!r}")
    return int(n)


def cascade_from_document(doc: Mapping, where: str = "gains file") -> tuple[CascadeLaw, CascadePlant | None,
                                                                              np.ndarray]:
    """``(law, plant model or None, sections)`` of a cascade gains document (DataError naming the key).

    The sections are the document's ``filters.current_setpoint_sos`` (what a target runs), checked against the
    discretization of ``filters.current_setpoint`` to :data:`SOS_TOLERANCE`.
    """
    from .gantry_gains import check_header, command_unit, entry, section

    check_header(doc, where, (CASCADE_KIND,))
    fs, delay, _ = read_sampling(dict(doc), where)
    units = doc.get("units") if isinstance(doc.get("units"), Mapping) else {}
    cu = command_unit(dict(doc))
    pu = str(units.get("position", "rad"))
    g = section(dict(doc), "gains", where)
    gu = {"Kp": f"{cu}/({pu}/s)", "Tn": "s", "Kv": "1/s", "kv_ff": "-", "J_ff": f"{cu}/({pu}/s^2)"}
    kp = value(entry(g, "gains", "Kp", where), f"{where}: gains.Kp", gu["Kp"])
    tn = value(g["Tn"], f"{where}: gains.Tn", "s") if "Tn" in g else math.inf
    kv = value(g.get("Kv", 0.0), f"{where}: gains.Kv", gu["Kv"])
    kv_ff = value(g.get("kv_ff", 1.0), f"{where}: gains.kv_ff", "-")
    jff = value(g.get("J_ff", 0.0), f"{where}: gains.J_ff", gu["J_ff"])
    pl = section(dict(doc), "position_loop", where)
    ratio = _ratio(pl, where)
    encoder = pl.get("encoder", "motor")
    fsec = section(dict(doc), "filters", where)
    raw = entry(fsec, "filters", "current_setpoint", where)
    if not isinstance(raw, list):
        raise DataError(f"{where}: filters.current_setpoint must be a list of filters")
    filters = tuple(_filter_from(d, f"{where}: filters.current_setpoint[{i}]") for i, d in enumerate(raw))
    try:
        law = CascadeLaw(kp, tn, filters, kv, fs, ratio, delay, kv_ff, jff, encoder, cu, pu)
    except UsageError as exc:
        raise DataError(f"{where}: {exc}") from None
    sos = read_sos(entry(fsec, "filters", "current_setpoint_sos", where), f"{where}: filters.current_setpoint_sos")
    sos = sos / sos[:, 3:4]
    sos = sos[~np.all(np.isclose(sos, IDENTITY_SECTION, rtol=0, atol=0), axis=1)]
    mine = law.filter_sos()
    scale = max(1.0, float(np.max(np.abs(mine)))) if mine.size else 1.0
    if sos.shape != mine.shape or (mine.size and np.max(np.abs(sos - mine)) > SOS_TOLERANCE * scale):
        raise DataError(f"{where}: filters.current_setpoint_sos are not the discretization of "
                        "filters.current_setpoint at sampling.fs_hz (was one edited without the other?)")
    plant = None
    if isinstance(doc.get("model"), Mapping):
        msec = doc["model"]
        mech = _mechanics_from(msec.get("mechanics"), f"{where}: model.mechanics", cu)
        cl = msec.get("current_loop_hz")
        try:
            plant = CascadePlant(mech, None if cl is None else value(cl, f"{where}: model.current_loop_hz", "Hz"))
        except UsageError as exc:
            raise DataError(f"{where}: model: {exc}") from None
        if plant.command_unit != cu or plant.position_unit != pu:
            raise DataError(f"{where}: the model is in {plant.position_unit} per {plant.command_unit}, the gains in "
                            f"{pu} per {cu}")
    return law, plant, mine


__all__ = ["CASCADE_KIND", "LAW_TEXT", "cascade_document", "cascade_from_document", "cascade_gains_document"]
