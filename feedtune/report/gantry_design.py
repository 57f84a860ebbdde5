"""Design subsections for gantry (2x2 MIMO or independent PID) and loop-shaped x-axis gains files (thesis §4.4).

The analysis is the one ``feedtune analyze GAINS [--frf F] --json`` prints for these kinds
(:func:`feedtune.machines.analyze_gains`, by :mod:`feedtune.machines.gantry.gains_analysis`). The measured FRF is
the first input FRF with the four channels ``y1/u1, y1/u2, y2/u1, y2/u2`` (gantry) or with a single channel
(axis). Figures: singular values of L, S and SG against G, the MIMO Nyquist plot of det(I + L) and the CoM
tracking (Figs. 4.13-4.15); for the axis the SISO loop, Nyquist, sensitivity (Fig. 4.9), disturbance and
tracking.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from functools import partial
from pathlib import PurePath

import numpy as np

from .certificate import certificate_blocks
from .collect import FrfInput, GainsInput, Inputs
from .content import Cell, FigureBlock, Paragraph, Section, Table, text_cell
from .design import (
    CASE_TITLES,
    bandwidth_cell,
    bandwidth_note,
    bandwidth_table_entry,
    case_masks,
    controller_grid,
    design_warnings,
    model_band_top,
    sampling_warnings,
    shows,
    store_bandwidth,
    support_of,
    verdict_paragraph,
    verdict_result,
)
from .figures import (
    Curve,
    controller_figure,
    det_nyquist_figure,
    loop_figure,
    magnitude_figure,
    nyquist_figure,
    sensitivity_figure,
    singular_value_figure,
)
from .objective import objective_block
from .sections import Colors, ReportLimits, controller_label, parameter_table, quantity_value, tuning_table
from .trust import mask_note

GANTRY_CHANNELS = ("y1/u1", "y1/u2", "y2/u1", "y2/u2")


@dataclass(frozen=True)
class MachineDesign:
    """One analysed gantry or axis gains file (same attributes as the ball-screw designs for the summary)."""

    name: str
    label: str
    color: str
    kind: str
    analysis: object
    result: dict
    frf: str | None
    tuning: dict | None = None
    law: object = None
    masks: dict = field(default_factory=dict)
    support: dict = field(default_factory=dict)
    bandwidth: dict = field(default_factory=dict)
    channels: tuple = ()
    notes: tuple = ()

    @property
    def main_case(self) -> str:
        """``discrete`` when a measured FRF was given, else ``ideal_discrete``."""
        return "discrete" if self.analysis.cases.get("discrete") is not None else "ideal_discrete"


def gantry_frf(inputs: Inputs, x_m: float | None = None) -> FrfInput | None:
    """The FRF with the four gantry channels measured at table position ``x_m`` [m] (``x_m`` in its
    metadata), else the first with the four channels."""
    candidates = [f for f in inputs.frfs if all(f.frf.has(ch) for ch in GANTRY_CHANNELS)]
    if x_m is not None:
        for f in candidates:
            try:
                if abs(float(f.frf.meta.get("x_m", "nan")) - x_m) < 1e-9:
                    return f
            except ValueError:
                continue
    return candidates[0] if candidates else None


def _frf_name(name: str, frf) -> str:
    """An FRF's name with the table position it records."""
    return name if frf.position_m is None else f"{name} (x = {frf.position_m:g} m)"


def design_position(gi: GainsInput) -> float:
    """Table position [m] a gantry gains file was designed at: ``[design] x_m``, 0 when absent (as the
    gains reader)."""
    design = gi.doc.get("design")
    value, _ = quantity_value(design.get("x_m", 0.0) if isinstance(design, Mapping) else 0.0)
    return 0.0 if value is None else value


def axis_frf(inputs: Inputs) -> FrfInput | None:
    """The first single-channel FRF."""
    return next((f for f in inputs.frfs if len(f.frf.channels) == 1), None)


def analyze_machine_gains(gi: GainsInput, fi: FrfInput | None, limits: ReportLimits) -> tuple[object, dict, object]:
    """``(analysis, result, law)`` of a gantry or axis gains file, ``result`` as ``feedtune analyze --json``."""
    from ..machines import analyze_gains

    done = analyze_gains(gi.doc, str(gi.path), None if fi is None else fi.frf)
    return done.analysis, {**done.result, **verdict_result(done.analysis, limits, gi, fi)}, done.law


def build_machine_designs(inputs: Inputs, names: Mapping, colors: Colors, limits: ReportLimits) -> list[MachineDesign]:
    """Analyse every gantry and axis gains file."""
    from dataclasses import replace

    a_frf = axis_frf(inputs)
    out = []
    for gi in inputs.gains:
        if gi.kind not in ("gantry", "axis"):
            continue
        fi = gantry_frf(inputs, design_position(gi)) if gi.kind == "gantry" else a_frf
        frf = fi.frf if fi is not None else None
        analysis, result, law = analyze_machine_gains(gi, fi, limits)
        label = controller_label(result["controller"])
        channels = GANTRY_CHANNELS if gi.kind == "gantry" else (tuple(frf.channels) if frf is not None else ())
        band_top = model_band_top(inputs, "gantry") if gi.kind == "gantry" else None
        d = MachineDesign(names[gi.path], label, "", gi.kind, analysis, result,
                          names[fi.path] if fi is not None else None, gi.doc.get("design"), law,
                          case_masks(analysis, frf, channels, limits.coherence_trust),
                          support_of(frf, channels, limits.coherence_trust, band_top), channels=channels,
                          notes=sampling_warnings(names[fi.path] if fi is not None else None, frf, law))
        out.append(replace(d, bandwidth=bandwidth_table_entry(d)))
    labels = [d.label for d in out]
    # named by the gains file, as its runs are: a design has one colour in every figure, design and time domain
    out = [replace(d, label=f"{d.label} ({PurePath(d.name).stem})") if labels.count(d.label) > 1 else d
           for d in out]
    return [replace(d, color=colors(d.label)) for d in out]


# ------------------------------------------------------------------------------------------ tables
def _margins_table(designs: list[MachineDesign], gantry: bool, limits: ReportLimits) -> Table:
    rows = []
    for d in designs:
        for case, m in d.result["analysis"].items():
            if m is None:
                continue
            k = ["design", d.name, "analysis", case]
            row = [text_cell(d.label), text_cell(CASE_TITLES.get(case, case)), Cell(m["stable"], key=[*k, "stable"]),
                   Cell(m["crossovers_hz"], "Hz", key=[*k, "crossovers_hz"]),
                   Cell(m["phase_margin_deg"], "deg", key=[*k, "phase_margin_deg"]),
                   Cell(m["gain_margin_db"], "dB", key=[*k, "gain_margin_db"]),
                   Cell(m["ms"], "", key=[*k, "ms"]), Cell(m["ms_freq_hz"], "Hz", key=[*k, "ms_freq_hz"]),
                   Cell(m["rejection_band_hz"], "Hz", key=[*k, "rejection_band_hz"])]
            if gantry:
                row.append(Cell(m.get("damping_band_hz"), "Hz", key=[*k, "damping_band_hz"]))
            row.append(bandwidth_cell(d, case))
            rows.append(row)
    columns = ["controller", "case", "stable", "CoM crossovers" if gantry else "crossovers", "phase margin",
               "gain margin", "max sigma(S)" if gantry else "Ms", "at", "rejection band"]
    if gantry:
        columns.append("active damping band")
    columns.append("tracking bandwidth")
    note = ("Crossovers and margins of the centre-of-mass loop alpha^T L [1 1]^T; stability by the MIMO Nyquist "
            "criterion on det(I + L). " if gantry else "") + bandwidth_note(limits)
    return Table("Stability, margins and bandwidth per analysis case (feedtune analyze)", columns, rows, note)


# ------------------------------------------------------------------------------------------ figures
def _case(d: MachineDesign):
    return d.analysis.cases[d.main_case]


def _mask(d: MachineDesign):
    return d.masks.get(d.main_case)


def _note(designs: list[MachineDesign], limits: ReportLimits) -> str:
    d = designs[0]
    return mask_note(_mask(d), _case(d).freq_hz, limits.coherence_trust, ", ".join(d.channels))


def with_shows(block: FigureBlock, designs) -> FigureBlock:
    """``block`` naming the designs it compares (:attr:`FigureBlock.shows`)."""
    from dataclasses import replace

    return replace(block, shows=shows(designs))


def _gantry_figures(designs: list[MachineDesign], limits: ReportLimits) -> list[FigureBlock]:
    from ..analysis.mimo import return_difference_det, singular_values

    case_name = CASE_TITLES[designs[0].main_case]
    note = _note(designs, limits)
    sv = {d.label: {k: singular_values(getattr(_case(d), k)) for k in ("L", "S", "SG", "G_open")} for d in designs}

    def curves(key):
        return [(d.label, d.color, _case(d).freq_hz, *sv[d.label][key], _mask(d)) for d in designs]

    g_hi, g_lo = sv[designs[0].label]["G_open"]
    disturbance = [("open loop G", "0.45", _case(designs[0]).freq_hz, g_hi * 1e6, g_lo * 1e6, _mask(designs[0]))]
    disturbance += [(f"{lb}: S G", c, f, hi * 1e6, lo * 1e6, m) for lb, c, f, hi, lo, m in curves("SG")]
    peaks = {d.label: (_case(d).metrics.ms_freq_hz, _case(d).metrics.ms) for d in designs}
    det = [Curve(_case(d).freq_hz, return_difference_det(_case(d).L), d.label, d.color, mask=_mask(d))
           for d in designs]
    tracking = [Curve(_case(d).freq_hz, _case(d).tracking, f"{d.label}, feedforward and pre-filters", d.color,
                      mask=_mask(d)) for d in designs]
    tracking += [Curve(_case(d).freq_hz, _case(d).tracking_no_ff, f"{d.label}, feedback only", d.color, ":", 1.2,
                       _mask(d)) for d in designs]
    return [with_shows(b, designs) for b in [
        FigureBlock("gantry-sv-loop", f"Upper and lower singular values of the loop L = G K ({case_name}) "
                    "(thesis Fig. 4.13 left)." + note,
                    partial(singular_value_figure, curves("L"), ylabel="sigma(L) [dB]", title="Singular values of L")),
        FigureBlock("gantry-nyquist", f"MIMO Nyquist plot: det(I + L) ({case_name}); stability from its "
                    "encirclements of the origin (thesis Fig. 4.13 right)." + note, partial(det_nyquist_figure, det)),
        FigureBlock("gantry-sv-sensitivity", "Upper and lower singular values of the sensitivity S = (I + L)^-1; "
                    "Ms = max sigma(S) marked (thesis Fig. 4.14)." + note,
                    partial(singular_value_figure, curves("S"), ylabel="sigma(S) [dB]", peaks=peaks,
                                          ms_limit=limits.ms_max, title="Singular values of S")),
        FigureBlock("gantry-sv-disturbance", "Singular values of the open-loop plant G and of the closed-loop "
                    "disturbance transfer S G from actuator forces to the encoders (thesis Fig. 4.15)." + note,
                    partial(singular_value_figure, disturbance, ylabel="sigma [dB re 1 µm/V]", level_db=None,
                                          title="Disturbance transfer S G against the plant G")),
        FigureBlock("gantry-tracking", f"Centre-of-mass tracking ybar/y_r ({case_name}) with feedforward and "
                    "pre-filters and with feedback only." + note,
                    partial(magnitude_figure, tracking, ylabel="|ybar/y_r| [dB]", db=True, phase=True,
                                     title="Centre-of-mass tracking ybar/y_r")),
    ]]


def _axis_figures(designs: list[MachineDesign], limits: ReportLimits) -> list[FigureBlock]:
    case_name = CASE_TITLES[designs[0].main_case]
    note = _note(designs, limits)
    loop = [Curve(_case(d).freq_hz, _case(d).L, d.label, d.color, mask=_mask(d)) for d in designs]
    sens = [Curve(_case(d).freq_hz, _case(d).S, d.label, d.color, mask=_mask(d)) for d in designs]
    cross = {d.label: _case(d).metrics.crossovers_hz for d in designs}
    ms = {d.label: _case(d).metrics.ms for d in designs}
    peaks = {d.label: (_case(d).metrics.ms_freq_hz, _case(d).metrics.ms) for d in designs}
    dist = [Curve(_case(d).freq_hz, _case(d).disturbance * 1e6, d.label, d.color, mask=_mask(d)) for d in designs]
    track = [Curve(_case(d).freq_hz, _case(d).tracking, f"{d.label}, feedforward and pre-filter", d.color,
                   mask=_mask(d)) for d in designs]
    track += [Curve(_case(d).freq_hz, _case(d).tracking_no_ff, f"{d.label}, feedback only", d.color, ":", 1.2,
                    _mask(d)) for d in designs]
    return [with_shows(b, designs) for b in [
        FigureBlock("axis-loop", f"x-axis loop gain ({case_name}), crossovers marked (thesis Fig. 4.9 left)." + note,
                    partial(loop_figure, loop, cross, title="x-axis loop transfer L")),
        FigureBlock("axis-nyquist", f"x-axis Nyquist plot ({case_name}) (thesis Fig. 4.9 right)." + note,
                    partial(nyquist_figure, loop, ms, title="x-axis Nyquist plot")),
        FigureBlock("axis-sensitivity", f"x-axis sensitivity ({case_name}) (thesis Fig. 4.9 centre)." + note,
                    partial(sensitivity_figure, sens, peaks, limits.ms_max, title="x-axis sensitivity |S|")),
        FigureBlock("axis-disturbance", f"x-axis disturbance transfer x/d = G S ({case_name})." + note,
                    partial(magnitude_figure, dist, ylabel="|x/d| [µm/V]", title="x-axis disturbance transfer x/d")),
        FigureBlock("axis-tracking", f"x-axis tracking x/x_r ({case_name})." + note,
                    partial(magnitude_figure, track, ylabel="|x/x_r| [dB]", db=True, phase=True,
                            title="x-axis tracking")),
    ]]


def _controller_block(d: MachineDesign) -> FigureBlock | None:
    """Bode plot of the discrete controller entries and of the filter pack of a gantry or axis law."""
    from ..control.discretize import matched

    law = d.law
    fs = getattr(law, "fs", None)
    if law is None or not fs:
        return None
    f = controller_grid(fs)
    unit = "V/m"
    if hasattr(law, "response_discrete"):  # gantry MIMO or PID: K is 2x2
        K = law.response_discrete(f)
        entries = ((0, 0, "K11 (side 1 from side 1)", "-"), (1, 1, "K22 (side 2 from side 2)", "--"),
                   (0, 1, "K12 (side 1 from side 2)", ":"), (1, 0, "K21 (side 2 from side 1)", "-."))
        paths = [Curve(f, K[i, j], label, d.color, style, 1.3) for i, j, label, style in entries
                 if np.any(np.abs(K[i, j]) > 0)]
        pack = law.filter_pack_discrete().freqresp(f)
        what = "the 2x2 controller K(z) entries (backward differences, backward-Euler integral)"
    else:  # x axis: C(z)
        unit = f"{d.result.get('command_unit') or 'V'}/m"
        paths = [Curve(f, law.controller_discrete().freqresp(f), "C(z)", d.color, "-", 1.4)]
        pack = matched(law.filters.zpk(), fs).tf.freqresp(f)
        what = "C(z), the matched PI, lead stages and filter pack"
    filters = [Curve(f, pack, "filter pack h(z)", "0.25", "-", 1.3)]
    fig = partial(controller_figure, paths, filters, unit=unit, fs_hz=fs,
                  title=f"Controller and filter pack of {d.label}")
    return FigureBlock(f"design-controller-{d.name}", f"Controller of {d.label} ({d.name}) as the target executes "
                       f"it at {fs:g} Hz: {what} (left, dB re 1 {unit}), and the filter pack alone (right).", fig)


# ------------------------------------------------------------------------------------------ section
def _subsection(kind: str, designs: list[MachineDesign], store: dict, limits: ReportLimits,
                warnings: list[str], inputs: Inputs, names: Mapping) -> Section:
    gantry = kind == "gantry"
    frf = designs[0].frf
    where = f"the measured FRF {frf}" if frf else "the design model only (no measured FRF given)"
    blocks: list = [Paragraph(f"Each gains file is analysed as stored against {where}; the numbers equal "
                              "feedtune analyze GAINS" + (f" --frf {frf}" if frf else "") + " --json.")]
    for d in designs:
        store[d.name] = {**d.result, "frf": d.frf}
        store_bandwidth(store, d, limits)
        blocks.append(parameter_table(f"Gains of {d.label} ({d.name})", d.result["gains"],
                                      ["design", d.name, "gains"], units=d.result.get("gain_units")))
        if gantry:
            blocks.append(Paragraph(f"{d.label} ({d.name}) analysed at the table position x = "
                                    f"{d.result['x_m']:.4g} m of its design."))
        warnings.extend(design_warnings(d, limits))
        blocks.append(verdict_paragraph(d, limits))
    blocks.append(tuning_table([(d.label, d.tuning) for d in designs]))
    blocks += [b for b in (objective_block(d.name, d.label, d.tuning) for d in designs) if b is not None]
    blocks.append(_margins_table(designs, gantry, limits))
    blocks += _gantry_figures(designs, limits) if gantry else _axis_figures(designs, limits)
    blocks += [b for b in (_controller_block(d) for d in designs) if b is not None]
    if gantry:
        frfs = [(_frf_name(names[fi.path], fi.frf), fi.frf) for fi in inputs.frfs
                if all(fi.frf.has(ch) for ch in GANTRY_CHANNELS)]
    else:
        frfs = [(names[fi.path], fi.frf) for fi in inputs.frfs if len(fi.frf.channels) == 1]
    frf_of = {names[fi.path]: fi.frf for fi in inputs.frfs}
    blocks += certificate_blocks(designs, frfs, {names[g.path]: g.doc for g in inputs.gains}, limits, store,
                                 analysed_on={d.name: frf_of[d.frf] for d in designs if d.frf in frf_of})
    title = "Gantry controllers (y axis, two drives)" if gantry else "x-axis controller"
    return Section(f"design-{kind}", title, blocks)


def machine_subsections(inputs: Inputs, names: Mapping, limits: ReportLimits, data: dict, warnings: list[str],
                        colors: Colors) -> tuple[list[Section], list[MachineDesign]]:
    """Gantry and axis design subsections (empty list without such gains files) and the analysed designs."""
    designs = build_machine_designs(inputs, names, colors, limits)
    store = data.setdefault("design", {}) if designs else {}
    subs = []
    for kind in ("gantry", "axis"):
        group = [d for d in designs if d.kind == kind]
        if group:
            subs.append(_subsection(kind, group, store, limits, warnings, inputs, names))
    return subs, designs


__all__ = ["MachineDesign", "analyze_machine_gains", "machine_subsections"]
