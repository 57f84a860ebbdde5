"""Design section: pole map, loop with crossovers, Nyquist, sensitivity with Ms, disturbance and tracking
transfer of every ball-screw gains file, overlaid (the MC-PPC vs P-PI comparison of thesis Figs. 3.6,
3.10-3.13).

The analysis is the one ``feedtune analyze GAINS [--frf F] --json`` prints:
:func:`feedtune.io.gains.law_from_document` rebuilds the law stored in the file (no redesign) and
:func:`feedtune.analysis.ballscrew.analyze_ballscrew` evaluates it, with the first given FRF holding
``x1/u`` and ``x2/u`` for the measured and discrete cases.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from functools import partial

import numpy as np

from ..structures import gains_formats, resolve
from .certificate import certificate_blocks
from .collect import FrfInput, GainsInput, Inputs
from .content import Cell, FigureBlock, Paragraph, Section, Table, Verdict, text_cell
from .figures import (
    Curve,
    controller_figure,
    loop_figure,
    magnitude_figure,
    nyquist_figure,
    pole_map_figure,
    sensitivity_figure,
)
from .objective import objective_block
from .sections import Colors, ReportLimits, controller_label, parameter_table, quantity_value, tuning_table
from .trust import (
    MEASURED_CASES,
    TRACKING_RESPONSE,
    bandwidth_definition,
    bandwidth_entry,
    coherence_of,
    mask_note,
    trusted_mask,
    trusted_top_hz,
    verdict_line,
)

PREFILTER_SUFFIX = " + pre-filter"
BALLSCREW_CHANNELS = ("x1/u", "x2/u")
CONTROLLER_POINTS = 500
"""Frequencies of a controller's Bode plot (log-spaced from 0.5 Hz to the Nyquist frequency)."""
CASE_TITLES = {
    "ideal": "model, continuous controller",
    "ideal_discrete": "model (ZOH), discrete controller",
    "measured": "measured FRF, continuous controller",
    "discrete": "measured FRF, discrete controller + ZOH + delay",
}


@dataclass(frozen=True)
class BallScrewDesign:
    """One analysed gains file: display label, colour, the law and model it holds, the analysis objects
    and the ``feedtune analyze --json`` dictionary."""

    name: str
    label: str
    color: str
    law: object
    model: object
    analysis: object
    result: dict
    prefilter: tuple | None = None
    masks: dict = field(default_factory=dict)
    support: dict = field(default_factory=dict)
    bandwidth: dict = field(default_factory=dict)
    notes: tuple = ()

    @property
    def main_case(self) -> str:
        """``discrete`` when a measured FRF was given, else ``ideal_discrete``."""
        return "discrete" if self.analysis.cases.get("discrete") is not None else "ideal_discrete"


def case_masks(analysis, frf, channels, threshold: float) -> dict:
    """``{case: trusted points}`` of the cases drawn from the measured FRF (:func:`~feedtune.report.trust.
    trusted_mask`; cases without an FRF or an FRF without coherence get none)."""
    out = {}
    for case in MEASURED_CASES:
        c = analysis.cases.get(case)
        if c is not None and frf is not None:
            mask = trusted_mask(frf, channels, c.freq_hz, threshold)
            if mask is not None:
                out[case] = mask
    return out


def support_of(frf, channels, threshold: float, model_band_top: float | None) -> dict:
    """The tops of the bands [Hz] that support a figure: ``measured`` (the trusted FRF band; the FRF's last line
    without coherence data; None without an FRF) and ``model`` (the model's fit band, None when unknown)."""
    top = None
    if frf is not None:
        found = coherence_of(frf, channels)
        top = trusted_top_hz(*found, threshold) if found is not None else float(frf.freq_hz[-1])
    return {"measured": top, "model": model_band_top}


def model_band_top(inputs: Inputs, kind: str) -> float | None:
    """Top of the fit band [Hz] of the first model file of ``kind`` that stores one (``fit.band_hz``)."""
    for m in inputs.models:
        band = (m.doc.get("fit") or {}).get("band_hz") if m.kind == kind and isinstance(m.doc.get("fit"), Mapping) \
            else None
        if isinstance(band, (list, tuple)) and len(band) == 2:
            return float(band[1])
    return None


def bandwidth_table_entry(d) -> dict:
    """``{case: bandwidth_entry}`` of a design's analysis cases."""
    return {case: bandwidth_entry(m["tracking_bandwidth_hz"], case, d.support)
            for case, m in d.result["analysis"].items() if m is not None}


def bandwidth_cell(d, case: str) -> Cell:
    """The tracking bandwidth of a case as shown: the value when the data supports it, else ``-``."""
    e = d.bandwidth.get(case) or {}
    if not e.get("shown"):
        return text_cell("-")
    return Cell(e["value_hz"], "Hz", key=["design", d.name, "tracking_bandwidth", "cases", case, "value_hz"])


def bandwidth_note(limits: ReportLimits) -> str:
    """Table note defining the tracking bandwidth."""
    return "Tracking bandwidth: the " + bandwidth_definition(limits.coherence_trust) + "; '-' otherwise."


def store_bandwidth(store: dict, d, limits: ReportLimits, response: str = TRACKING_RESPONSE) -> None:
    """``store[name]["tracking_bandwidth"]``: the definition (the bandwidth of ``response``) and each case's entry."""
    store[d.name]["tracking_bandwidth"] = {"definition": bandwidth_definition(limits.coherence_trust, response),
                                           "cases": d.bandwidth}


def verdict_paragraph(d, limits: ReportLimits, assumes: bool = True) -> Verdict:
    """The pass/fail line of a design; with ``assumes``, what its checked case assumes above the measured band
    (``assumes`` of ``feedtune analyze --json``: the design section says it, the summary points there). The cases are
    named by the design's ``case_titles`` when it has them (a cascade's position loop), else :data:`CASE_TITLES`."""
    text = verdict_line(d.label, d.name, d.result["check"], getattr(d, "case_titles", CASE_TITLES),
                        limits.policy.describe(),
                        (d.result.get("verdict") or {}).get("basis_text"))
    assumes = (d.result["analysis"].get(d.main_case) or {}).get("assumes") or [] if assumes else []
    if assumes:
        text += " Above the measured band the figures are " + "; ".join(assumes) + "."
    return Verdict(text, bool(d.result["check"].get("ok")))


def analysis_frf(inputs: Inputs) -> FrfInput | None:
    """The FRF used for the measured and discrete cases: the first one with both ``x1/u`` and ``x2/u``."""
    for fi in inputs.frfs:
        if fi.frf.has("x1/u") and fi.frf.has("x2/u"):
            return fi
    return None


def analyze_gains(gi: GainsInput, fi: FrfInput | None, limits: ReportLimits) -> tuple[object, object, object, dict]:
    """``(law, model, analysis, result)`` exactly as ``feedtune analyze`` computes them (result = its JSON)."""
    from ..machines import analyze_gains as analyze_document

    done = analyze_document(gi.doc, str(gi.path), None if fi is None else fi.frf)
    return done.law, done.model, done.analysis, {**done.result, **verdict_result(done.analysis, limits, gi, fi)}


def design_label(gi: GainsInput, prefilter) -> str:
    """``MC-PPC``, ``P-PI``...; with `` + pre-filter`` when the gains file has one (as its tracking runs)."""
    return controller_label(gi.controller) + (PREFILTER_SUFFIX if prefilter is not None else "")


def prefilter_of(gi: GainsInput) -> tuple[dict, float] | None:
    """``(gains, lpf_hz)`` of the gains file's trajectory pre-filter (eq. 3.17-3.20), or None without one."""
    if "prefilter" not in gi.doc:
        return None
    from ..io.gains import read_prefilter_gains

    return read_prefilter_gains(gi.doc, str(gi.path))


# ------------------------------------------------------------------------------------------ tables
def _gain_units(doc: Mapping) -> dict:
    units = {}
    for sec in ("gains", "ppi_gains"):
        for k, v in (doc.get(sec) or {}).items():
            units[k] = quantity_value(v)[1]
    return units


def _margins_table(designs: list[BallScrewDesign], limits: ReportLimits) -> Table:
    rows = []
    for d in designs:
        for case, figures in d.result["analysis"].items():
            if figures is None:
                continue
            k = ["design", d.name, "analysis", case]
            rows.append([
                text_cell(d.label), text_cell(CASE_TITLES.get(case, case)),
                Cell(figures["stable"], key=[*k, "stable"]),
                Cell(figures["crossovers_hz"], "Hz", key=[*k, "crossovers_hz"]),
                Cell(figures["phase_margin_deg"], "deg", key=[*k, "phase_margin_deg"]),
                Cell(figures["gain_margin_db"], "dB", key=[*k, "gain_margin_db"]),
                Cell(figures["ms"], "", key=[*k, "ms"]),
                Cell(figures["ms_freq_hz"], "Hz", key=[*k, "ms_freq_hz"]),
                Cell(figures["rejection_band_hz"], "Hz", key=[*k, "rejection_band_hz"]),
                bandwidth_cell(d, case),
            ])
    return Table("Stability, margins and bandwidth per analysis case (feedtune analyze)",
                 ["controller", "case", "stable", "crossovers", "phase margin", "gain margin", "Ms", "Ms at",
                  "|S| < 1 band", "tracking bandwidth"], rows,
                 "Phase margin: the crossover whose margin is closest to 0; gain margin: the phase crossover "
                 "closest to 0 dB (negative: the gain may only be reduced). " + bandwidth_note(limits))


def _poles_table(d: BallScrewDesign) -> Table:
    rows = []
    poles = d.result["closed_loop_poles"]
    order = sorted(range(len(poles)), key=lambda i: abs(complex(*poles[i])))
    for i in order:
        re, im = poles[i]
        if im < 0:
            continue
        p = complex(re, im)
        wn = abs(p)
        rows.append([Cell(re, "rad/s", key=["design", d.name, "closed_loop_poles", i, 0]),
                     Cell(im, "rad/s", key=["design", d.name, "closed_loop_poles", i, 1]),
                     Cell(wn / (2 * np.pi), "Hz"), Cell(-re / wn if wn else None, "")])
    return Table(f"Closed-loop poles of {d.label} ({d.name}), model with filter pack (conjugates listed once)",
                 ["real part", "imaginary part", "natural frequency", "damping [-]"], rows)


def _filters_paragraph(d: BallScrewDesign, doc: Mapping) -> Paragraph | None:
    cont = (doc.get("filters") or {}).get("continuous") or {}
    parts = [f"notch {n.get('freq_hz', 0):g} Hz (zeta_z {n.get('zeta_z', 0):g}, zeta_p {n.get('zeta_p', 0):g})"
             for n in cont.get("notches") or []]
    if cont.get("lpf_hz"):
        parts.append(f"low-pass {cont['lpf_hz']:g} Hz")
    if not parts:
        return None
    fs = quantity_value((doc.get("sampling") or {}).get("fs_hz"))[0]
    rate = f" at {fs:g} Hz sampling" if fs else ""
    return Paragraph(f"{d.label} ({d.name}): filter pack " + ", ".join(parts) + rate + ".")


# ------------------------------------------------------------------------------------------ figures
def _curves(designs, case_of, attr: str, *, ideal_dashed: bool = False, label_suffix: str = "") -> list[Curve]:
    """One curve per design of ``attr`` in the case ``case_of(d)``, with the trusted points of a measured case."""
    out = []
    for d in designs:
        name = case_of(d)
        case = d.analysis.cases.get(name)
        if case is None or getattr(case, attr) is None:
            continue
        out.append(Curve(case.freq_hz, getattr(case, attr), d.label + label_suffix, d.color,
                         "--" if ideal_dashed else "-", 1.0 if ideal_dashed else 1.5, d.masks.get(name)))
    return out


def _masked_note(designs, limits: ReportLimits) -> str:
    """Caption text on the measured lines left out of the main case's curves."""
    d = designs[0]
    case = d.analysis.cases.get(d.main_case)
    return mask_note(d.masks.get(d.main_case), case.freq_hz, limits.coherence_trust, " and ".join(BALLSCREW_CHANNELS)) \
        if case is not None else ""


def feedback_groups(designs: list[BallScrewDesign]) -> list[BallScrewDesign]:
    """One design per distinct feedback (same gains and analysis, e.g. a design and its copy with a
    pre-filter), labelled with every member's label, for the figures of feedback quantities."""
    import json
    from dataclasses import replace

    groups: dict[str, list[BallScrewDesign]] = {}
    for d in designs:
        key = json.dumps([d.result["gains"], d.result["analysis"]], sort_keys=True, default=str)
        groups.setdefault(key, []).append(d)
    return [replace(g[0], label=" = ".join(d.label for d in g)) if len(g) > 1 else g[0] for g in groups.values()]


def _case_name(designs) -> str:
    return CASE_TITLES[designs[0].main_case]


def shows(designs) -> tuple:
    """``((label, colour), ...)`` of the designs a figure compares (:attr:`FigureBlock.shows`)."""
    return tuple(dict.fromkeys((d.label, d.color) for d in designs))


def _pole_map(designs: list[BallScrewDesign]) -> FigureBlock:
    open_loop = designs[0].model.poles()
    closed = [(d.label, d.color, np.array([complex(*p) for p in d.result["closed_loop_poles"]])) for d in designs]
    top = max(m.freq_hz for d in designs for m in d.model.modes()) if designs[0].model.modes() else 100.0
    fig = partial(pole_map_figure, open_loop, closed, zoom_rad_s=2 * np.pi * 3 * top)
    return FigureBlock("design-poles", "Open-loop poles of the design model and closed-loop poles of each "
                       "controller including its filter pack (thesis Fig. 3.6).", fig, shows(designs))


def _loop(designs, limits: ReportLimits) -> FigureBlock:
    main = _curves(designs, lambda d: d.main_case, "L")
    ideal = _curves(designs, lambda d: "ideal", "L", ideal_dashed=True, label_suffix=" (model, continuous)")
    cross = {d.label: d.analysis.cases[d.main_case].metrics.crossovers_hz for d in designs}
    fig = partial(loop_figure, main + ideal, cross, title="Loop transfer L")
    return FigureBlock("design-loop", f"Loop transfer L = K1 G11 + K2 G21 (eq. 3.24/3.25), solid: "
                       f"{_case_name(designs)}, dashed: model with the continuous controller; circles: "
                       "crossovers (thesis Fig. 3.10a-b)." + _masked_note(designs, limits), fig, shows(designs))


def _nyquist(designs, limits: ReportLimits) -> FigureBlock:
    main = _curves(designs, lambda d: d.main_case, "L")
    ms = {d.label: d.analysis.cases[d.main_case].metrics.ms for d in designs}
    return FigureBlock("design-nyquist", f"Nyquist plot of L ({_case_name(designs)}), dotted circles: distance "
                       "1/Ms from -1 (thesis Fig. 3.10c-d)." + _masked_note(designs, limits),
                       partial(nyquist_figure, main, ms), shows(designs))


def _sensitivity(designs, limits: ReportLimits) -> FigureBlock:
    main = _curves(designs, lambda d: d.main_case, "S")
    ideal = _curves(designs, lambda d: "ideal", "S", ideal_dashed=True, label_suffix=" (model, continuous)")
    peaks = {d.label: (d.analysis.cases[d.main_case].metrics.ms_freq_hz, d.analysis.cases[d.main_case].metrics.ms)
             for d in designs}
    return FigureBlock("design-sensitivity", f"Sensitivity S = 1/(1 + L), solid: {_case_name(designs)}; "
                       "|S| < 1 (below 0 dB) where disturbances are rejected (thesis Fig. 3.11). Ms is the "
                       "analysis' peak over every line." + _masked_note(designs, limits),
                       partial(sensitivity_figure, main + ideal, peaks, limits.ms_max), shows(designs))


def _disturbance(designs) -> FigureBlock:
    curves = []
    linear = all(d.model.lead_given for d in designs)  # a rotary bench without a lead: in rad, its own unit
    for d in designs:
        scale = d.model.lead_m_per_rad * 1e6 if linear else 1.0
        for case, style in (("ideal", "-"), ("ideal_discrete", "--")):
            c = d.analysis.cases.get(case)
            if c is not None and c.disturbance is not None:
                suffix = "" if case == "ideal" else " (discrete)"
                curves.append(Curve(c.freq_hz, c.disturbance * scale, d.label + suffix, d.color, style,
                                    1.5 if case == "ideal" else 1.0))
    unit = designs[0].model.input_unit
    fig = partial(magnitude_figure, curves, ylabel=f"|x2/d2| [{'µm' if linear else 'rad'}/{unit}]",
                           title="Disturbance transfer x2/d2")
    return FigureBlock("design-disturbance", "Disturbance transfer from a force d2 on the table to the table "
                       "position x2 (eq. 3.26/3.27), on the model; solid: continuous, dashed: discrete "
                       "controller (thesis Fig. 3.12).", fig, shows(designs))


def _prefiltered(designs) -> list[Curve]:
    from ..control.prefilter import prefilter_response

    out = []
    for d in designs:
        case = d.analysis.cases.get(d.main_case)
        if d.prefilter is None or case is None:
            continue
        gains, lpf_hz = d.prefilter
        F = prefilter_response(gains, lpf_hz, case.freq_hz, d.law.fs, method="tustin")
        out.append(Curve(case.freq_hz, case.tracking * F, f"{d.label}, feedforward and pre-filter", d.color,
                         "-.", 1.6, d.masks.get(d.main_case)))
    return out


def _tracking(designs, limits: ReportLimits) -> FigureBlock:
    leaders = feedback_groups(designs)
    with_ff = _curves(leaders, lambda d: d.main_case, "tracking", label_suffix=", feedforward")
    without = _curves(leaders, lambda d: d.main_case, "tracking_no_ff", label_suffix=", feedback only")
    without = [Curve(c.x, c.y, c.label, c.color, ":", 1.2, c.mask) for c in without]
    pre = _prefiltered(designs)
    fig = partial(magnitude_figure, with_ff + without + pre, ylabel="|x2/x_r| [dB]", db=True, phase=True,
                           title="Command tracking x2/x_r")
    extra = " and with the trajectory pre-filter of the gains file (dash-dot)" if pre else ""
    return FigureBlock("design-tracking", f"Command tracking x2/x_r ({_case_name(designs)}) with the rotary "
                       "command generator and feedforward (solid), with feedback only (dotted)" + extra +
                       " (thesis Fig. 3.13)." + _masked_note(designs, limits), fig, shows(leaders))


def controller_grid(fs: float) -> np.ndarray:
    """Frequencies [Hz] of a controller's Bode plot: 0.5 Hz to just below the Nyquist frequency."""
    return np.logspace(np.log10(0.5), np.log10(fs / 2 * 0.999), CONTROLLER_POINTS)


def _controller(d: BallScrewDesign) -> FigureBlock:
    """Bode plot of the discrete K1, K2 (eq. 3.5 with the filter pack) and of the filter pack alone."""
    law = d.law
    f = controller_grid(law.fs)
    unit = f"{d.model.input_unit}/rad"
    paths = [Curve(f, law.K1d().freqresp(f), "K1 on the rotary error (x1)", d.color, "-", 1.4),
             Curve(f, law.K2d().freqresp(f), "K2 on the table error (x2)", d.color, "--", 1.4)]
    filters = [Curve(f, law.filter_pack_discrete().freqresp(f), "filter pack G_fp", "0.25", "-", 1.3)]
    fig = partial(controller_figure, paths, filters, unit=unit, fs_hz=law.fs,
                  title=f"Controller and filter pack of {d.label}")
    return FigureBlock(f"design-controller-{d.name}", f"Controller of {d.label} ({d.name}) as the target executes it "
                       f"at {law.fs:g} Hz: K1 and K2 of eq. 3.5 (backward differences, backward-Euler integral) "
                       "with the matched filter pack (left, dB re 1 " + unit + "), and the filter pack alone "
                       "(right).", fig)


# ------------------------------------------------------------------------------------------ warnings
def design_warnings(d, limits: ReportLimits) -> list[str]:
    """The design's check under the policy (stability in every case, the limits in its main case), one line per
    violation, as ``feedtune analyze --check`` reports them, what the verdict's notes say (an edited
    certificate ignored) and the FRF's sampling warnings (:func:`sampling_warnings`)."""
    cert = d.result.get("verdict") or {}
    ignored = [n for n in cert.get("notes", []) if cert.get("stored_status") in ("edited", "undigested")][:1]
    return [f"{d.label} ({d.name}): {v}" for v in d.result["check"]["violations"]] + ignored + list(d.notes)


def sampling_warnings(frf_name: str | None, frf, law) -> tuple[str, ...]:
    """What ``feedtune analyze GAINS --frf F`` warns about the FRF against the gains' sample rate: an FRF ending far
    below the Nyquist frequency (the loop above it rests on the model; :func:`feedtune.frf_sampling.band_warning`)."""
    from ..errors import cli_message
    from ..frf_sampling import band_warning

    fs = getattr(law, "fs", None)
    if frf is None or not fs:
        return ()
    w = band_warning(frf, float(fs), frf_name)
    return () if w is None else (cli_message(w),)


def verdict_result(analysis, limits: ReportLimits, gi: GainsInput, fi: FrfInput | None = None) -> dict:
    """The ``check`` and ``certificate`` entries of ``feedtune analyze --json`` for a gains file under the report's
    policy: its verdict (:func:`feedtune.machines.certificate.gains_verdict`), certified on the FRF ``fi`` the
    analysis is on, else the file's own certificate while it holds for its gains, else the design model."""
    from ..machines.certificate import FrfSource, gains_verdict

    sources = [] if fi is None else [FrfSource.from_file(fi.path, fi.frf, fi.path.name)]
    verdict = gains_verdict(gi.doc, str(gi.path), sources, limits.policy,
                            known=[(None if fi is None else fi.frf, analysis)])
    return {"check": verdict.certificate.check_dict(), "verdict": verdict.to_dict()}


# ------------------------------------------------------------------------------------------ section
def _unanalysed_section(gains: list[GainsInput], names: Mapping) -> Section | None:
    """Gains files of machine kinds this feedtune does not analyse, listed."""
    if not gains:
        return None
    rows = [[text_cell(names[g.path]), text_cell(g.kind), text_cell(controller_label(g.controller))] for g in gains]
    return Section("design-other", "Gains for other machines",
                   [Table("Gains files not analysed", ["file", "machine", "controller"], rows),
                    Paragraph("These gains kinds have no report module in this feedtune; their files are listed "
                              "only.")])


def build_designs(inputs: Inputs, names: Mapping, colors: Colors,
                  limits: ReportLimits) -> tuple[list[BallScrewDesign], str | None]:
    """Analyse every ball-screw gains file; also return the name of the FRF used (or None)."""
    from dataclasses import replace

    fi = analysis_frf(inputs)
    frf = fi.frf if fi is not None else None
    ballscrew = [g for g in inputs.gains if g.kind == "ballscrew"]
    prefilters = [prefilter_of(g) for g in ballscrew]
    labels = [design_label(g, p) for g, p in zip(ballscrew, prefilters, strict=True)]
    support = support_of(frf, BALLSCREW_CHANNELS, limits.coherence_trust, model_band_top(inputs, "ballscrew"))
    designs = []
    for g, pre, label in zip(ballscrew, prefilters, labels, strict=True):
        if labels.count(label) > 1:  # named by the gains file, as its runs are (the same colour in every figure)
            label = f"{label} ({g.path.stem})"
        law, model, analysis, result = analyze_gains(g, fi, limits)
        d = BallScrewDesign(names[g.path], label, colors(label), law, model, analysis, result, pre,
                            case_masks(analysis, frf, BALLSCREW_CHANNELS, limits.coherence_trust), support,
                            notes=sampling_warnings(names[fi.path] if fi is not None else None, frf, law))
        designs.append(replace(d, bandwidth=bandwidth_table_entry(d)))
    return designs, (names[fi.path] if fi is not None else None)


def ballscrew_subsections(inputs: Inputs, names: Mapping, limits: ReportLimits, data: dict, warnings: list[str],
                          colors: Colors) -> tuple[list[Section], list[BallScrewDesign]]:
    """The ball-screw design subsection (none without ball-screw gains files) and the analysed designs (the report
    hook of the ``ballscrew`` gains format, :attr:`feedtune.structures.GainsFormat.report`).

    Fills ``data["design"][file] = {kind, gains, closed_loop_poles, analysis, frf}`` (the first four equal
    ``feedtune analyze FILE [--frf F] --json``) and appends stability/margin warnings.
    """
    designs, frf_name = build_designs(inputs, names, colors, limits)
    if not designs:
        return [], []
    store = data.setdefault("design", {})
    blocks: list = []
    where = f"the measured FRF {frf_name}" if frf_name else "the design model only (no measured FRF given)"
    blocks.append(Paragraph(f"Each gains file is analysed as stored (no redesign) against {where}; the "
                            "numbers equal feedtune analyze GAINS" + (f" --frf {frf_name}" if frf_name else "")
                            + " --json."))
    for d in designs:
        store[d.name] = {**d.result, "frf": frf_name}
        store_bandwidth(store, d, limits)
        doc = next(g.doc for g in inputs.gains if names[g.path] == d.name)
        blocks.append(parameter_table(f"Gains of {d.label} ({d.name})", d.result["gains"],
                                      ["design", d.name, "gains"], units=_gain_units(doc)))
        para = _filters_paragraph(d, doc)
        if para is not None:
            blocks.append(para)
        if d.prefilter is not None:
            store[d.name]["prefilter"] = {"gains": d.prefilter[0], "lpf_hz": d.prefilter[1]}
            blocks.append(parameter_table(
                f"Trajectory pre-filter of {d.label} (eq. 3.17-3.20, G = low-pass at {d.prefilter[1]:g} Hz)",
                d.prefilter[0], ["design", d.name, "prefilter", "gains"],
                units={"K_vel": "s", "K_acc": "s^2", "K_jerk": "s^3", "K_snap": "s^4"}))
        warnings.extend(design_warnings(d, limits))
        blocks.append(verdict_paragraph(d, limits))
    blocks.append(tuning_table([(d.label, next(g.doc for g in inputs.gains if names[g.path] == d.name)
                                  .get("design")) for d in designs]))
    blocks += [b for b in (objective_block(d.name, d.label, next(g.doc for g in inputs.gains
                                                                  if names[g.path] == d.name).get("design"))
                           for d in designs) if b is not None]
    blocks.append(_margins_table(designs, limits))
    blocks.extend(_poles_table(d) for d in designs)
    leaders = feedback_groups(designs)
    blocks += [_pole_map(leaders), _loop(leaders, limits), _nyquist(leaders, limits),
               _sensitivity(leaders, limits), _disturbance(leaders), _tracking(designs, limits)]
    blocks += [_controller(d) for d in leaders]
    frfs = [(names[fi.path], fi.frf) for fi in inputs.frfs if fi.frf.has("x1/u") and fi.frf.has("x2/u")]
    blocks += certificate_blocks(designs, frfs, {names[g.path]: g.doc for g in inputs.gains}, limits, store)
    return [Section("design-ballscrew", "Ball-screw controllers", blocks)], designs


def design_section(inputs: Inputs, names: Mapping, limits: ReportLimits, data: dict, warnings: list[str],
                   colors: Colors) -> tuple[Section | None, list]:
    """The design section (None without gains files) and the analysed designs of every gains format.

    Each gains format's report hook (:attr:`feedtune.structures.GainsFormat.report`, ``hook(inputs, names, limits,
    data, warnings, colors) -> (subsections, designs)``) draws the files of its kind, in the registry's order, and
    fills ``data["design"][file]`` (``feedtune analyze FILE --json`` and what the report adds); gains files of a
    format without one are listed.
    """
    subs: list[Section] = []
    designs: list = []
    for ref in dict.fromkeys(f.report for f in gains_formats() if f.report):
        found, analysed = resolve(ref)(inputs, names, limits, data, warnings, colors)
        subs += found
        designs += analysed
    drawn = {f.kind for f in gains_formats() if f.report}  # the formats whose report module draws them
    other = _unanalysed_section([g for g in inputs.gains if g.kind not in drawn], names)
    if not subs and other is None:
        return None, []
    data.setdefault("design", {})
    if other is not None:
        subs.append(other)
    return Section("design", "Design", [], subs), designs
