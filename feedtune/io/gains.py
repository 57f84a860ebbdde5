"""The gains document: everything a real-time target needs to run a ball-screw design at ``fs``.

The document is a plain dict (written as TOML with a JSON twin by :mod:`feedtune.io.document`). Numbers
that have a unit are ``{"value": v, "unit": "..."}``. Discrete filters are second-order sections
``[b0, b1, b2, a0, a1, a2]`` in powers of ``z^-1`` at ``fs``. See ``docs/gains.md`` for the execution order;
:mod:`feedtune.machines.ballscrew.runtime` and the C header exporter execute exactly that.
"""

from __future__ import annotations

import copy
import math
from collections.abc import Mapping

import numpy as np

from .. import __version__
from ..control.ballscrew_law import GAIN_NAMES, BallScrewLaw, gain_units, ppi_units
from ..control.filters import FilterPack
from ..control.friction import LEVELS, VELOCITY, FrictionFeedforward, friction_feedforward
from ..control.prefilter import GAIN_NAMES as PREFILTER_GAIN_NAMES
from ..control.prefilter import GAIN_UNITS as PREFILTER_UNITS
from ..control.prefilter import ORDERS as PREFILTER_ORDERS
from ..control.prefilter import correction_sos, gain_vector
from ..errors import DataError, UsageError
from ..models.ballscrew import PARAM_NAMES, BallScrewModel, param_units
from ..models.friction import COULOMB_VISCOUS, FrictionLaw, StribeckFriction
from .document import require_schema

SCHEMA = "feedtune.gains/1.1"
"""The gains documents' schema: major 1 (readers refuse another major), minor 1 (the ``[certificate]`` with its
digests, :mod:`feedtune.io.gains_certificate`)."""

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
        "params": {n: q(getattr(model, n), param_units(model.input_unit)[n]) for n in PARAM_NAMES},
        **({"lead_m_per_rad": q(model.lead_m_per_rad, "m/rad")} if model.lead_given else {}),
    }


def gains_document(design) -> dict:
    """Build the gains document of a ball-screw design (without a certificate: :func:`feedtune.workflows.deliver.
    deliver` certifies it on the FRFs and adds the ``[certificate]``).

    Parameters
    ----------
    design : McppcDesign or PpiDesign
        Any design with ``law()``, ``model``, ``kind``, ``gains``, ``filters`` and ``design_dict()`` (and, for a
        P-PI, ``ppi_gains``; for an MC-PPC, ``poles``).

    The optional sections are added by :func:`with_prefilter` and :func:`with_friction_feedforward`.
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
        "gains": {n: q(design.gains[n], gain_units(design.model.input_unit)[n]) for n in GAIN_NAMES},
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
    if hasattr(design, "ppi_gains"):
        doc["ppi_gains"] = {n: q(v, ppi_units(design.model.input_unit)[n]) for n, v in design.ppi_gains.items()}
    else:
        doc["design"]["closed_loop_poles_rad_s"] = [[float(p.real), float(p.imag)] for p in design.poles]
    return refresh_law_text(doc)


def _tf_dict(z) -> dict:
    num, den = z.to_tf()
    return {"num": [float(c) for c in num], "den": [float(c) for c in den], "variable": "s"}


def _tf_from_dict(sec, where: str):
    """The continuous transfer function of a ``{num, den, variable = "s"}`` table written by :func:`_tf_dict`."""
    from ..lti import Zpk

    if not isinstance(sec, dict) or "num" not in sec or "den" not in sec:
        raise DataError(f"{where}: missing (a table with num and den, descending powers of s)")
    try:
        num = [float(c) for c in sec["num"]]
        den = [float(c) for c in sec["den"]]
    except (TypeError, ValueError):
        raise DataError(f"{where}: num and den must be lists of numbers") from None
    if not den or not np.all(np.isfinite(num + den)):
        raise DataError(f"{where}: num and den must be finite, den not empty")
    return Zpk.from_tf(num, den)


def check_gains_header(doc, where: str) -> None:
    """Schema (version 1) and machine kind of a ball-screw gains document; DataError otherwise."""
    if not isinstance(doc, dict):
        raise DataError(f"{where}: a gains document must be a table/object at the top level")
    require_schema(doc, "feedtune.gains", where, written=SCHEMA)
    if doc.get("kind") != "ballscrew":
        raise DataError(f"{where}: gains file is for machine kind {doc.get('kind')!r}, expected 'ballscrew'")
    from .gains_schema import validate_gains

    validate_gains(doc, where)


def check_ballscrew_gains(doc: dict, where: str) -> None:
    """Header plus every section the analysis and the exporters need."""
    check_gains_header(doc, where)
    for key in ("sampling", "gains", "filters", "reference", "model"):
        if key not in doc:
            raise DataError(f"{where}: gains file has no [{key}] section")


def model_from_section(sec: dict, where: str, input_unit: str = "V") -> BallScrewModel:
    """The BallScrewModel stored in a gains or model document section, for a drive commanded in ``input_unit``."""
    params = sec.get("params", {})
    vals = {}
    for n in PARAM_NAMES:
        if n not in params:
            raise DataError(f"{where}: model parameter {n!r} missing")
        vals[n] = value(params[n], f"{where}: model.params.{n}")
    lead = sec.get("lead_m_per_rad")
    kw = {} if lead is None else {"lead_m_per_rad": value(lead, f"{where}: lead_m_per_rad")}
    return BallScrewModel(**vals, **kw, input_unit=input_unit, lead_given=lead is not None)


def law_from_document(doc: dict, where: str = "gains file") -> tuple[BallScrewLaw, BallScrewModel, str]:
    """Rebuild the continuous/discrete law, the design model and the controller kind from a gains document."""
    check_ballscrew_gains(doc, where)
    units = doc.get("units") if isinstance(doc.get("units"), Mapping) else {}
    model = model_from_section(doc["model"], where, str(units.get("command", "V")))
    gains = {n: value(doc["gains"].get(n), f"{where}: gains.{n}") for n in GAIN_NAMES}
    filters = FilterPack.from_dict(doc["filters"].get("continuous", {}))
    fs = value(doc["sampling"].get("fs_hz"), f"{where}: sampling.fs_hz", "Hz")
    if fs <= 0:
        raise DataError(f"{where}: sampling.fs_hz must be > 0 Hz")
    delay = int(doc["sampling"].get("delay_samples", 1))
    kind = str(doc.get("controller", ""))
    if kind not in ("mcppc", "ppi"):
        raise DataError(f"{where}: controller {kind!r} unknown; expected 'mcppc' or 'ppi'")
    rotary = _tf_from_dict(doc["reference"].get("rotary_continuous"), f"{where}: reference.rotary_continuous")
    ff = _tf_from_dict(doc["reference"].get("feedforward_continuous"), f"{where}: reference.feedforward_continuous")
    return BallScrewLaw(gains, filters.zpk(), rotary, ff, fs, delay), model, kind


def read_sampling(doc: dict, where: str) -> tuple[float, int, int]:
    """``(fs [Hz], delay_samples, preview_samples)`` from ``[sampling]``; DataError when missing or invalid."""
    sec = doc.get("sampling")
    if not isinstance(sec, dict):
        raise DataError(f"{where}: gains file has no [sampling] section")
    fs = value(sec.get("fs_hz"), f"{where}: sampling.fs_hz", "Hz")
    if fs <= 0:
        raise DataError(f"{where}: sampling.fs_hz must be > 0 Hz, got {fs:g}")
    counts = []
    for key in ("delay_samples", "preview_samples"):
        v = sec.get(key)
        if isinstance(v, bool) or not isinstance(v, (int, float)) or v != int(v) or v < 0:
            raise DataError(f"{where}: sampling.{key} must be an integer >= 0, got {v!r}")
        counts.append(int(v))
    return fs, counts[0], counts[1]


def with_friction_feedforward(doc: Mapping, friction: StribeckFriction, *, v_band: float | None = None,
                              where: str = "gains file", friction_where: str = "friction model") -> dict:
    """A copy of a ball-screw gains document with a ``[friction_feedforward]`` section (replacing any).

    The command unit comes from ``[units].command``, the lead from ``[model].lead_m_per_rad`` and the viscous
    friction the law's linear feedforward already carries from ``[reference].feedforward_continuous`` (its velocity
    gain ``U_ff'(0)``, ``b1 + b2`` for MC-PPC and P-PI): a model's viscous term is fed forward less that
    (:func:`~feedtune.control.friction.friction_feedforward`).

    Raises
    ------
    DataError
        The document lacks them, or the friction model's units do not fit (see :func:`friction_feedforward`).
    """

    check_gains_header(doc, where)
    units = doc.get("units") if isinstance(doc.get("units"), Mapping) else {}
    command_unit = str(units.get("command", "V"))
    model = doc.get("model")
    if not isinstance(model, Mapping) or "lead_m_per_rad" not in model:
        raise DataError(f"{where}: no [model] lead_m_per_rad to convert the friction velocities to rad/s")
    lead = value(model["lead_m_per_rad"], f"{where}: model.lead_m_per_rad", "m/rad")
    reference = doc.get("reference") if isinstance(doc.get("reference"), Mapping) else {}
    ff = _tf_from_dict(reference.get("feedforward_continuous"), f"{where}: reference.feedforward_continuous")
    out_ff = friction_feedforward(friction, command_unit=command_unit, lead_m_per_rad=lead, v_band=v_band,
                                  where=friction_where, linear_viscous=velocity_gain(ff))
    out = copy.deepcopy(dict(doc))
    out["friction_feedforward"] = out_ff.section()
    return refresh_law_text(out)


def velocity_gain(tf) -> float:
    """``d/ds U(s)`` at ``s = 0`` of a continuous feedforward ``U(s)`` [command unit/(rad/s)]: the viscous friction a
    feedforward ``... + b s`` carries."""
    num, den = tf.to_tf()
    num, den = np.atleast_1d(num), np.atleast_1d(den)
    d0 = float(np.polyval(den, 0.0))
    return float((np.polyval(np.polyder(num), 0.0) * d0 - np.polyval(num, 0.0) * np.polyval(np.polyder(den), 0.0))
                 / d0**2)


def friction_from_section(sec, command_unit: str, where: str = "gains file",
                          velocity_unit: str = VELOCITY) -> FrictionFeedforward:
    """Read a ``[friction_feedforward]`` section; DataError naming the key when missing or inconsistent.

    ``velocity_unit`` is the law's: rad/s for the ball screw, m/s for a linear axis (``kind = "axis"``). ``model`` is
    ``"stribeck"`` (levels, ``omega_pos``, ``omega_neg``) or ``"coulomb-viscous"`` (``dc_pos``, ``dc_neg``); both
    with the optional ``viscous_pos``, ``viscous_neg`` [command unit/(velocity unit)] (absent: 0, the files written
    before the viscous term).
    """

    if not isinstance(sec, Mapping):
        raise DataError(f"{where}: [friction_feedforward] must be a table")
    law = sec.get("model", "stribeck")
    if law not in ("stribeck", COULOMB_VISCOUS):
        raise DataError(f"{where}: friction_feedforward.model = {law!r}; known: 'stribeck', '{COULOMB_VISCOUS}'")
    levels = ("dc_pos", "dc_neg") if law == COULOMB_VISCOUS else LEVELS
    vals = {n: value(sec.get(n), f"{where}: friction_feedforward.{n}", command_unit) for n in levels}
    speeds = ("v_band",) if law == COULOMB_VISCOUS else ("omega_pos", "omega_neg", "v_band")
    for n in speeds:
        vals[n] = value(sec.get(n), f"{where}: friction_feedforward.{n}", velocity_unit)
    band = vals.pop("v_band")
    viscous = {n: value(sec[n], f"{where}: friction_feedforward.{n}", f"{command_unit}/({velocity_unit})")
               for n in ("viscous_pos", "viscous_neg") if n in sec}
    common = {"command_unit": command_unit, "velocity_unit": velocity_unit}
    try:
        if law == COULOMB_VISCOUS:
            model = FrictionLaw.coulomb_viscous(vals["dc_pos"], vals["dc_neg"], viscous.get("viscous_pos", 0.0),
                                                viscous.get("viscous_neg", 0.0), **common)
        elif viscous:
            model = FrictionLaw(**vals, **common, viscous_pos=viscous.get("viscous_pos", 0.0),
                                viscous_neg=viscous.get("viscous_neg", 0.0))
        else:
            model = StribeckFriction(**vals, **common)
        return FrictionFeedforward(model, band, sec.get("source"))
    except (DataError, UsageError) as exc:
        raise DataError(f"{where}: friction_feedforward: {exc}") from None


# ------------------------------------------------------------------------------------------ gains file
def prefilter_section(gains: Mapping[str, float], lpf_hz: float, fs: float, fit=None) -> dict:
    """The ``[prefilter]`` section of a gains file.

    Parameters
    ----------
    gains : dict
        ``K_vel .. K_snap`` [s .. s^4].
    lpf_hz, fs : float
        Pole frequency of ``G`` and the target's sample rate [Hz].
    fit : PrefilterFit, optional
        (any object with ``gains``, ``lpf_hz``, ``fs``, ``std``, ``to_dict()``... of a pre-filter fit)
        Fit statistics to record (information only).
    """
    K = dict(zip((PREFILTER_GAIN_NAMES[o] for o in PREFILTER_ORDERS), gain_vector(gains), strict=True))
    sec = {
        "form": "x_r' = x_r + K_vel s G^2 x_r + K_acc s^2 G^3 x_r + K_jerk s^3 G^4 x_r + K_snap s^4 G^5 x_r, "
                "G = w/(s + w), w = 2 pi lpf_hz (eq. 3.17-3.20)",
        "execution": "x_r'[k+P] = x_r[k+P] + prefilter(x_r[k+P]) before the rotary, table, feedforward and "
                     "friction paths",
        "discretization": "bilinear (Tustin), G and s G discretized separately and multiplied",
        "lpf_hz": {"value": float(lpf_hz), "unit": "Hz"},
        "gains": {n: {"value": v, "unit": PREFILTER_UNITS[n]} for n, v in K.items()},
        "prefilter_sos": [[float(c) for c in row] for row in correction_sos(K, lpf_hz, fs)],
    }
    if fit is not None:
        d = fit.to_dict()
        u = fit.length_unit or "u"
        sec["fit"] = {
            "orders": d["orders"],
            "std": {n: {"value": v, "unit": PREFILTER_UNITS[n]} for n, v in fit.std.items()},
            "condition_number": d["condition_number"],
            "error_rms": {"value": fit.error_rms, "unit": u},
            "fitted_rms": {"value": fit.fitted_rms, "unit": u},
            "residual_rms": {"value": fit.residual_rms, "unit": u},
            "predicted_reduction": fit.predicted_reduction,
            "n_samples": fit.n_samples,
            "fs_hz": {"value": fit.fs, "unit": "Hz"},
            "sources": {k: str(v) for k, v in fit.sources.items()},
        }
    return sec


def with_prefilter(doc: Mapping, fit=None, *, gains: Mapping[str, float] | None = None,
                   lpf_hz: float | None = None, where: str = "gains file") -> dict:
    """A copy of a ball-screw gains document with a ``[prefilter]`` section (replacing any existing one).

    Give ``fit`` (its gains and ``lpf_hz``), or ``gains`` and ``lpf_hz``. The sections are built at the
    document's sample rate; a fit from a log at another rate is refused.

    Raises
    ------
    DataError
        Not a gains document, or the fit's sample rate differs from the file's.
    """
    import copy


    check_gains_header(doc, where)
    fs = value((doc.get("sampling") or {}).get("fs_hz"), f"{where}: sampling.fs_hz", "Hz")
    if fit is not None:
        if not math.isclose(fit.fs, fs, rel_tol=1e-6):
            raise DataError(f"{where}: the gains run at fs = {fs:g} Hz but the tracking log was sampled at "
                            f"{fit.fs:g} Hz; the pre-filter must be identified at the target's rate")
        gains, lpf_hz = fit.gains, fit.lpf_hz
    if gains is None or lpf_hz is None:
        raise UsageError("with_prefilter needs a fit, or gains and lpf_hz")
    out = copy.deepcopy(dict(doc))
    out["prefilter"] = prefilter_section(gains, lpf_hz, fs, fit)
    return refresh_law_text(out)


def read_prefilter_gains(doc: Mapping, where: str = "gains file") -> tuple[dict, float] | None:
    """``(gains, lpf_hz)`` of a document's ``[prefilter]`` section, or None when it has none."""

    sec = doc.get("prefilter")
    if sec is None:
        return None
    if not isinstance(sec, Mapping) or not isinstance(sec.get("gains"), Mapping):
        raise DataError(f"{where}: [prefilter] needs a [prefilter.gains] table with {', '.join(PREFILTER_UNITS)}")
    gains = {n: value(sec["gains"].get(n, 0.0), f"{where}: prefilter.gains.{n}", u) for n, u in PREFILTER_UNITS.items()}
    lpf = value(sec.get("lpf_hz"), f"{where}: prefilter.lpf_hz", "Hz")
    return gains, lpf


def read_sos(rows, where: str) -> np.ndarray:
    """Second-order sections ``[b0, b1, b2, a0, a1, a2]`` divided by ``a0``; DataError when malformed.

    Parameters
    ----------
    rows : list of list of float
        Sections in powers of ``z^-1``.
    where : str
        Name used in error messages (file and key).

    Returns
    -------
    ndarray, shape (n_sections, 6)
        With ``a0 = 1`` in every row.
    """
    if not isinstance(rows, (list, tuple)) or len(rows) == 0:
        raise DataError(f"{where}: expected a non-empty list of second-order sections [b0, b1, b2, a0, a1, a2]")
    out = np.empty((len(rows), 6))
    for i, row in enumerate(rows):
        if not isinstance(row, (list, tuple)) or len(row) != 6:
            raise DataError(f"{where}[{i}]: a section must have 6 coefficients [b0, b1, b2, a0, a1, a2]")
        out[i] = [value(c, f"{where}[{i}]") for c in row]
        if out[i, 3] == 0:
            raise DataError(f"{where}[{i}]: a0 = 0 is not a valid section")
        out[i] /= out[i, 3]
    return out
