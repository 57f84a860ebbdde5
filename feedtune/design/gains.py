"""The gains document: everything a real-time target needs to run a ball-screw design at ``fs``.

The document is a plain dict (written as TOML with a JSON twin by :mod:`feedtune.io.document`). Numbers
that have a unit are ``{"value": v, "unit": "..."}``. Discrete filters are second-order sections
``[b0, b1, b2, a0, a1, a2]`` in powers of ``z^-1`` at ``fs``. See ``docs/gains.md`` for the execution order;
:mod:`feedtune.sim.runtime` and the C header exporter execute exactly that.
"""

from __future__ import annotations

import numpy as np

from .. import __version__
from ..control.ballscrew_law import GAIN_NAMES, GAIN_UNITS, BallScrewLaw
from ..control.filters import FilterPack
from ..errors import DataError
from ..models.ballscrew import PARAM_NAMES, PARAM_UNITS, BallScrewModel
from .mcppc import McppcDesign, model_inversion, rotary_command_generator
from .ppi import PPI_UNITS, PpiDesign, acceleration_feedforward

SCHEMA = "feedtune.gains/1"

LAW_TEXT = (
    "every sample k: x1r = rotary(x_r[k+P]); x2r = table(x_r[k+P]); e1 = x1r - x1[k]; e2 = x2r - x2[k]; "
    "de_i = (e_i[k] - e_i[k-1]) * fs; ie2 += e2 / fs; "
    "u_fb = Kx1 e1 + Kx2 e2 + Kv1 de1 + Kv2 de2 + Ki2 ie2; "
    "u = filter_pack(u_fb) + feedforward(x_r[k+P]); "
    "u is applied delay_samples after x1[k], x2[k] were sampled"
)


def law_text(prefilter: bool = False, friction: bool = False) -> str:
    """The execution order of ``docs/gains.md`` as one line, with the optional pre-filter and friction terms."""
    if not (prefilter or friction):
        return LAW_TEXT
    xp = "xp" if prefilter else "x_r[k+P]"
    parts = ["every sample k:"]
    if prefilter:
        parts.append("xp = x_r[k+P] + prefilter(x_r[k+P]);")
    parts.append(f"x1r = rotary({xp}); x2r = table({xp}); e1 = x1r - x1[k]; e2 = x2r - x2[k];")
    parts.append("de_i = (e_i[k] - e_i[k-1]) * fs; ie2 += e2 / fs; u_fb = Kx1 e1 + Kx2 e2 + Kv1 de1 + Kv2 de2 "
                 "+ Ki2 ie2;")
    if friction:
        parts.append(f"v_r = ({xp} - previous {xp}) * fs, 0 on the first sample;")
    parts.append(f"u = filter_pack(u_fb) + feedforward({xp})" + (" + friction(v_r);" if friction else ";"))
    parts.append("u is applied delay_samples after x1[k], x2[k] were sampled")
    return " ".join(parts)


def refresh_law_text(doc: dict) -> dict:
    """Set ``[law].execution`` to match the optional sections the document has (in place; returns ``doc``)."""
    if isinstance(doc.get("law"), dict):
        doc["law"]["execution"] = law_text("prefilter" in doc, "friction_feedforward" in doc)
    return doc


def q(value: float, unit: str) -> dict:
    """A number with its unit."""
    return {"value": float(value), "unit": unit}


def value(entry, where: str, unit: str | None = None) -> float:
    """A finite number given bare or as ``{"value", "unit"}`` (parsed by :func:`feedtune.io.value_of`)."""
    from ..quantity import value_of

    if entry is None:
        raise DataError(f"{where}: missing")
    got = entry.get("unit") if isinstance(entry, dict) else None
    if unit is not None and got is not None and got != unit:
        raise DataError(f"{where}: unit is {got!r}, expected {unit!r}")
    v = value_of(entry, None, where)
    if not np.isfinite(v):
        raise DataError(f"{where}: value must be finite, got {v}")
    return v


def _sos(z) -> list:
    return [[float(c) for c in row] for row in z.to_sos()]


def model_section(model: BallScrewModel) -> dict:
    """The design model, so the gains file alone can be analysed again."""
    return {
        "kind": "ballscrew",
        "params": {n: q(getattr(model, n), PARAM_UNITS[n]) for n in PARAM_NAMES},
        "lead_m_per_rad": q(model.lead_m_per_rad, "m/rad"),
    }


def gains_document(design: McppcDesign | PpiDesign, analysis: dict | None = None, *, prefilter=None,
                   friction=None, friction_band: float | None = None) -> dict:
    """Build the gains document of a ball-screw design.

    Parameters
    ----------
    design : McppcDesign or PpiDesign
    analysis : dict, optional
        Analysis figures to store for information (``BallScrewAnalysis.to_dict()``).
    prefilter : PrefilterFit, optional
        Trajectory pre-filter to add as ``[prefilter]`` (:func:`feedtune.design.prefilter.with_prefilter`).
    friction : StribeckFriction, optional
        Friction model to feed forward as ``[friction_feedforward]``
        (:func:`feedtune.design.friction_ff.with_friction_feedforward`).
    friction_band : float, optional
        Half-width of the friction feedforward's linear band around zero velocity, in the friction model's
        velocity unit (m/s or rad/s); default a tenth of its smaller Stribeck velocity.
    """
    law = design.law()
    paths = law.reference_paths()
    fp_d = law.filter_pack_discrete()
    doc: dict = {
        "schema": SCHEMA,
        "kind": "ballscrew",
        "controller": design.kind,
        "created_by": f"feedtune {__version__}",
        "sampling": {
            "fs_hz": q(law.fs, "Hz"),
            "delay_samples": int(law.delay_samples),
            "preview_samples": int(law.preview_samples),
        },
        "units": {"position": "rad", "command": design.model.input_unit, "time": "s"},
        "law": {
            "execution": LAW_TEXT,
            "velocity_estimator": "backward difference (eq. 3.5)",
            "integrator": "backward Euler",
            "discretization": "pole-zero matching",
        },
        "gains": {n: q(design.gains[n], GAIN_UNITS[n]) for n in GAIN_NAMES},
        "filters": {
            "continuous": design.filters.to_dict(),
            "filter_pack_sos": _sos(fp_d),
        },
        "reference": {
            "rotary_sos": _sos(paths["rotary"].discrete),
            "table_sos": _sos(paths["table"].discrete),
            "feedforward_sos": _sos(paths["feedforward"].discrete),
            "rotary_continuous": _tf_dict(law.rotary_reference),
            "feedforward_continuous": _tf_dict(law.feedforward),
        },
        "model": model_section(design.model),
        "design": design.design_dict(),
    }
    if isinstance(design, PpiDesign):
        doc["ppi_gains"] = {n: q(v, PPI_UNITS[n]) for n, v in design.ppi_gains.items()}
    else:
        doc["design"]["closed_loop_poles_rad_s"] = [[float(p.real), float(p.imag)] for p in design.poles]
    if analysis is not None:
        doc["analysis"] = _strip_none(analysis)
    if prefilter is not None:
        from .prefilter import with_prefilter

        doc = with_prefilter(doc, prefilter)
    if friction is not None:
        from .friction_ff import with_friction_feedforward

        doc = with_friction_feedforward(doc, friction, v_band=friction_band)
    return refresh_law_text(doc)


def _tf_dict(z) -> dict:
    num, den = z.to_tf()
    return {"num": [float(c) for c in num], "den": [float(c) for c in den], "variable": "s"}


def _strip_none(d):
    if isinstance(d, dict):
        return {k: _strip_none(v) for k, v in d.items() if v is not None}
    if isinstance(d, list):
        return [_strip_none(v) for v in d if v is not None]
    return d


def check_gains_header(doc, where: str) -> None:
    """Schema (version 1) and machine kind of a ball-screw gains document; DataError otherwise."""
    if not isinstance(doc, dict):
        raise DataError(f"{where}: a gains document must be a table/object at the top level")
    schema = str(doc.get("schema", ""))
    if not schema.startswith("feedtune.gains/"):
        raise DataError(f"{where}: not a feedtune gains file (schema {schema!r}, expected {SCHEMA!r})")
    if schema.split("/", 1)[1].split(".")[0] != "1":
        raise DataError(f"{where}: gains schema {schema!r} is not supported; this feedtune reads version 1")
    if doc.get("kind") != "ballscrew":
        raise DataError(f"{where}: gains file is for machine kind {doc.get('kind')!r}, expected 'ballscrew'")


def check_ballscrew_gains(doc: dict, where: str) -> None:
    """Header plus every section the analysis and the exporters need."""
    check_gains_header(doc, where)
    for key in ("sampling", "gains", "filters", "reference", "model"):
        if key not in doc:
            raise DataError(f"{where}: gains file has no [{key}] section")


def model_from_section(sec: dict, where: str) -> BallScrewModel:
    """The BallScrewModel stored in a gains or model document section."""
    params = sec.get("params", {})
    vals = {}
    for n in PARAM_NAMES:
        if n not in params:
            raise DataError(f"{where}: model parameter {n!r} missing")
        vals[n] = value(params[n], f"{where}: model.params.{n}")
    lead = sec.get("lead_m_per_rad")
    kw = {} if lead is None else {"lead_m_per_rad": value(lead, f"{where}: lead_m_per_rad")}
    return BallScrewModel(**vals, **kw)


def law_from_document(doc: dict, where: str = "gains file") -> tuple[BallScrewLaw, BallScrewModel, str]:
    """Rebuild the continuous/discrete law, the design model and the controller kind from a gains document."""
    check_ballscrew_gains(doc, where)
    model = model_from_section(doc["model"], where)
    gains = {n: value(doc["gains"].get(n), f"{where}: gains.{n}") for n in GAIN_NAMES}
    filters = FilterPack.from_dict(doc["filters"].get("continuous", {}))
    fs = value(doc["sampling"].get("fs_hz"), f"{where}: sampling.fs_hz", "Hz")
    if fs <= 0:
        raise DataError(f"{where}: sampling.fs_hz must be > 0 Hz")
    delay = int(doc["sampling"].get("delay_samples", 1))
    kind = str(doc.get("controller", ""))
    if kind == "mcppc":
        rotary, ff = rotary_command_generator(model), model_inversion(model)
    elif kind == "ppi":
        from ..lti import Zpk

        rotary, ff = Zpk.constant(1.0), acceleration_feedforward(model)
    else:
        raise DataError(f"{where}: controller {kind!r} unknown; expected 'mcppc' or 'ppi'")
    return BallScrewLaw(gains, filters.zpk(), rotary, ff, fs, delay), model, kind
