"""Design subsection of drive-cascade gains files (``kind = "cascade"``, docs/cascade.md): the speed loop ``L_v`` and
the position loop ``L_p`` of every cascade design, on every measured FRF given to the report and on the design's model.

Each design is analysed exactly as ``feedtune analyze GAINS [--frf F] --json`` analyses it
(:func:`feedtune.machines.analyze_gains`): on every FRF among the inputs that fits it (one channel, or the motor and
load encoders, in the design's position and command units; the others are named with the reason) and on the model its
file holds. Its verdict is that of ``feedtune analyze GAINS --frf F1 --frf F2 ... --json``
(:func:`feedtune.machines.certificate.gains_verdict`: certified now on every fitting FRF; without one, the file's own
certificate while it holds, else the model).

Figures, per loop: the Bode plot with the crossovers, the Nyquist plot with the ``1/Ms`` circles and ``|S|`` with Ms,
in the checked case on each FRF (``discrete``, ``position_discrete``) and on the model (``ideal_discrete``,
``position_ideal_discrete``); one colour per design (:class:`~feedtune.report.sections.Colors`), one line style per
FRF (:data:`FRF_STYLES`), dashed on the model. Per design the speed controller as the drive executes it (the PI times
the current-setpoint filters at ``fs``) and its filters alone. Tables: the gains in their units, the figures of both
loops in every case on the first fitting FRF, and the certificate per loop per FRF and on the model (first crossover,
Ms, PM, GM, disk margin, closed-loop bandwidth, the limit that binds); every number is a cell of the analysis'
dictionary (``data["design"][file]["on"][FRF][case]``, the ``analysis`` of ``feedtune analyze GAINS --frf FRF --json``).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from functools import partial
from pathlib import Path, PurePath

from ..analysis.cascade import LOOPS, POSITION
from ..errors import DataError
from .collect import GainsInput, Inputs
from .content import Cell, FigureBlock, Paragraph, Section, Table, text_cell
from .design import (
    CASE_TITLES,
    controller_grid,
    design_warnings,
    model_band_top,
    sampling_warnings,
    shows,
    store_bandwidth,
    support_of,
    verdict_paragraph,
)
from .figures import Curve, controller_figure, loop_figure, nyquist_figure, sensitivity_figure
from .objective import objective_block
from .sections import Colors, ReportLimits, controller_label, parameter_table, tuning_table
from .trust import bandwidth_entry, limit_text, mask_note, trusted_mask

MODEL = "model"
"""The name of the model among the sources a design is analysed on (the certificate's name for it)."""
LOOP_TITLES = {"": "speed loop L_v", POSITION: "position loop L_p"}
"""The loops by the prefix of their case names (:data:`feedtune.analysis.cascade.LOOPS`), in the figures."""
LOOP_NAMES = {"": "speed", POSITION: "position"}
"""The loops in the tables' ``loop`` column."""
CASCADE_CASE_TITLES = {**CASE_TITLES, **{POSITION + k: f"position loop, {v}" for k, v in CASE_TITLES.items()}}
"""Case titles of both loops (the speed loop's are the usual ones)."""
FRF_STYLES = ("-", "-.", ":", (0, (5, 1, 1, 1, 1, 1)))
"""Line style of the curves on the first, second ... FRF (the model's: dashed)."""
MODEL_STYLE = "--"


@dataclass(frozen=True)
class Source:
    """One thing a design is analysed on: an FRF of the inputs (its display name and the Frf) or the model (``frf``
    None), with the analysis there (:class:`feedtune.machines.gains.GainsAnalysis`)."""

    name: str
    frf: object
    done: object

    @property
    def checked(self) -> str:
        """The speed loop's checked case here (``discrete`` on an FRF, ``ideal_discrete`` on the model)."""
        return "discrete" if self.frf is not None else "ideal_discrete"


@dataclass(frozen=True)
class CascadeReportDesign:
    """One analysed cascade gains file (the attributes the summary reads of every design, and its sources).

    ``analysis`` and ``result`` are those on the first fitting FRF (or the model), ``result`` with the ``check`` and
    ``verdict`` of every fitting FRF; ``sources`` every FRF it fits then the model; ``skipped`` the FRFs it does not
    fit, with the reason.
    """

    name: str
    label: str
    color: str
    analysis: object
    result: dict
    law: object
    frf: str | None
    doc: dict
    sources: tuple = ()
    skipped: tuple = ()
    masks: dict = field(default_factory=dict)
    support: dict = field(default_factory=dict)
    bandwidth: dict = field(default_factory=dict)
    notes: tuple = ()
    case_titles = CASCADE_CASE_TITLES

    @property
    def main_case(self) -> str:
        """``discrete`` when a measured FRF fits it, else ``ideal_discrete``."""
        return "discrete" if self.analysis.cases.get("discrete") is not None else "ideal_discrete"


# ------------------------------------------------------------------------------------------ analysis
def _sources(gi: GainsInput, inputs: Inputs, names: Mapping) -> tuple[list[Source], list[tuple[str, str]]]:
    """The design analysed on every FRF of the inputs that fits it and on its model (when the file holds one); the
    FRFs that do not fit."""
    from ..errors import cli_message
    from ..machines import analyze_gains

    where = str(gi.path)
    found, skipped = [], []
    for fi in inputs.frfs:
        try:
            found.append(Source(names[fi.path], fi.frf, analyze_gains(gi.doc, where, fi.frf)))
        except DataError as exc:
            skipped.append((names[fi.path], cli_message(exc)))
    if gi.doc.get("model") is not None:  # a drive's imported parameter set holds none
        found.append(Source(MODEL, None, analyze_gains(gi.doc, where, None)))
    elif not found:
        reasons = "; ".join(f"{name}: {why}" for name, why in skipped)
        raise DataError(f"{where}: the gains file holds no plant model ([model]) and no FRF among the report's inputs "
                        f"fits it{f' ({reasons})' if reasons else ''}; give the FRF it was made for as an input")
    return found, skipped


def _verdict(gi: GainsInput, inputs: Inputs, names: Mapping, sources: list[Source], limits: ReportLimits) -> dict:
    """``check`` and ``verdict`` of ``feedtune analyze GAINS --frf F1 --frf F2 ... --json`` on the fitting FRFs."""
    from ..machines.certificate import FrfSource, gains_verdict

    paths = {names[fi.path]: fi.path for fi in inputs.frfs}
    frfs = [s for s in sources if s.frf is not None]
    files = [FrfSource.from_file(paths[s.name], s.frf, s.name) for s in frfs]
    known = [(s.frf, s.done.analysis) for s in sources]
    verdict = gains_verdict(gi.doc, str(gi.path), files, limits.policy, known=known)
    return {"check": verdict.certificate.check_dict(), "verdict": verdict.to_dict()}


def _masks(sources: list[Source], limits: ReportLimits) -> dict:
    """``{source: {case: trusted points}}`` of the cases drawn from a measured FRF (coherence, lowest over its
    channels)."""
    out: dict = {}
    for s in sources:
        if s.frf is None:
            continue
        for case, c in s.done.analysis.cases.items():
            if c is not None and case.removeprefix(POSITION) in ("measured", "discrete"):
                mask = trusted_mask(s.frf, tuple(s.frf.channels), c.freq_hz, limits.coherence_trust)
                if mask is not None:
                    out.setdefault(s.name, {})[case] = mask
    return out


def _bandwidths(d: CascadeReportDesign) -> dict:
    """``{case: bandwidth_entry}``: each loop's closed-loop -3 dB band, shown below the top of the band that supports
    it (a position case as the speed case it is made of)."""
    return {case: bandwidth_entry(m["tracking_bandwidth_hz"], case.removeprefix(POSITION), d.support)
            for case, m in d.result["analysis"].items() if m is not None}


def _model_kind(doc: Mapping) -> str | None:
    return ((doc.get("model") or {}).get("mechanics") or {}).get("kind")


def build_cascade_designs(inputs: Inputs, names: Mapping, colors: Colors,
                          limits: ReportLimits) -> list[CascadeReportDesign]:
    """Analyse every cascade gains file on every FRF it fits and on its model (module docstring)."""
    out = []
    for gi in (g for g in inputs.gains if g.kind == "cascade"):
        sources, skipped = _sources(gi, inputs, names)
        main = sources[0]
        result = {**main.done.result, **_verdict(gi, inputs, names, sources, limits)}
        frf_name = main.name if main.frf is not None else None
        notes = tuple(w for s in sources if s.frf is not None
                      for w in sampling_warnings(s.name, s.frf, main.done.law))
        d = CascadeReportDesign(names[gi.path], controller_label(result["controller"]), "", main.done.analysis, result,
                                main.done.law, frf_name, gi.doc, tuple(sources), tuple(skipped),
                                _masks(sources, limits),
                                support_of(main.frf, tuple(main.frf.channels) if main.frf is not None else (),
                                           limits.coherence_trust, model_band_top(inputs, _model_kind(gi.doc))),
                                notes=notes)
        out.append(replace(d, bandwidth=_bandwidths(d)))
    labels = [d.label for d in out]
    # named by the gains file when two designs share a structure: one colour per design in every figure
    out = [replace(d, label=f"{d.label} ({PurePath(d.name).stem})") if labels.count(d.label) > 1 else d for d in out]
    return [replace(d, color=colors(d.label)) for d in out]


# ------------------------------------------------------------------------------------------ tables
def _units_paragraph(d: CascadeReportDesign) -> Paragraph:
    law, r = d.law, d.result
    pos = r["position_loop"]
    filters = ", ".join(r["filters"]) or "none"
    kv = ("open (Kv = 0)" if pos["open"] else
          f"at {pos['fs_hz']:g} Hz (every {pos['ratio']} speed samples) on the {pos['encoder']} encoder")
    return Paragraph(f"{d.label} ({d.name}): positions in {law.position_unit}, the command (current or torque "
                     f"setpoint) in {law.command_unit}; the speed loop at {law.fs:g} Hz with "
                     f"{law.delay_samples:g} sample(s) of computational delay, the position loop {kv}; "
                     f"current-setpoint filters: {filters}.")


def _tuning(d: CascadeReportDesign) -> dict:
    """The file's ``[design]`` with its tuning record (a drive's own tuning named as such)."""
    design = d.doc.get("design") if isinstance(d.doc.get("design"), Mapping) else {}
    tuning = design.get("tuning") if isinstance(design.get("tuning"), Mapping) else {}
    merged = {**design, **tuning}
    if "rule" not in merged and tuning.get("drive_tuning"):
        merged["rule"] = (f"the drive's own tuning: the {tuning.get('controller', 'tuned')} controller of "
                          f"{Path(str(tuning['drive_tuning'])).name}")
    return merged


def _figure_cells(key: list, m: Mapping) -> list[Cell]:
    return [Cell(m["stable"], key=[*key, "stable"]),
            Cell(m["first_crossover_hz"], "Hz", key=[*key, "first_crossover_hz"]),
            Cell(m["ms"], "", key=[*key, "ms"]), Cell(m["ms_freq_hz"], "Hz", key=[*key, "ms_freq_hz"]),
            Cell(m["phase_margin_deg"], "deg", key=[*key, "phase_margin_deg"]),
            Cell(m["gain_margin_db"], "dB", key=[*key, "gain_margin_db"]),
            Cell(m["disk_margin"], "", key=[*key, "disk_margin"]),
            Cell(m["tracking_bandwidth_hz"], "Hz", key=[*key, "tracking_bandwidth_hz"])]


FIGURE_COLUMNS = ["stable", "first crossover", "Ms", "Ms at", "PM", "GM", "disk margin", "closed-loop bandwidth"]
FIGURE_NOTE = ("PM: the crossover whose margin is closest to 0; GM: the phase crossover closest to 0 dB (negative: the "
               "gain may only be reduced); closed-loop bandwidth: the first frequency where L/(1+L) leaves 0 +- 3 dB.")


def _cases_table(designs: list[CascadeReportDesign]) -> Table:
    rows = []
    for d in designs:
        for case, m in d.result["analysis"].items():
            if m is None:
                continue
            loop = POSITION if case.startswith(POSITION) else ""
            rows.append([text_cell(d.label), text_cell(LOOP_NAMES[loop]),
                         text_cell(CASE_TITLES[case.removeprefix(loop)]),
                         *_figure_cells(["design", d.name, "analysis", case], m),
                         Cell(m["crossovers_hz"], "Hz", key=["design", d.name, "analysis", case, "crossovers_hz"])])
    frfs = sorted({d.frf for d in designs if d.frf})
    on = f" on {', '.join(frfs)}" if frfs else " on the model (no measured FRF fits)"
    return Table(f"Both loops in every analysis case{on} (feedtune analyze)",
                 ["controller", "loop", "case", *FIGURE_COLUMNS, "crossovers"], rows, FIGURE_NOTE)


def _certificate_table(d: CascadeReportDesign, limits: ReportLimits) -> Table:
    """Per FRF and on the model, per loop: the checked case's figures, the limit that binds and the loop's verdict."""
    from ..analysis.limits import check_analysis

    rows = []
    for s in d.sources:
        check, _ = check_analysis(s.done.analysis, limits.policy)
        for loop in LOOPS:
            case = loop + s.checked
            m = (s.done.result["analysis"].get(case) if s.done.result["analysis"] else None)
            if m is None:
                continue
            items = [i for i in check.items if i.case == case]
            scored = [i for i in items if i.slack is not None]
            active = min(scored, key=lambda i: i.slack) if scored else None
            failed = [i for i in items if not i.ok]
            rows.append([text_cell(s.name), text_cell(LOOP_NAMES[loop]),
                         *_figure_cells(["design", d.name, "on", s.name, case], m),
                         text_cell(limit_text(None if active is None else active.to_dict())),
                         text_cell("ok" if not failed else "FAILS: " + ", ".join(i.name for i in failed))])
    return Table(f"Certificate of {d.label} ({d.name}) per loop on every measured FRF and on its model, "
                 f"{limits.policy.describe()}",
                 ["FRF", "loop", *FIGURE_COLUMNS, "limit that binds", "verdict"], rows,
                 "Each FRF row is feedtune analyze GAINS --frf FRF --json in its checked case (the discrete "
                 "controller at its rates, ZOH and delay on the FRF), the model rows feedtune analyze GAINS --json "
                 f"(ideal_discrete); the position loop judged up to its Nyquist frequency. {FIGURE_NOTE}")


# ------------------------------------------------------------------------------------------ figures
def _curves(designs: list[CascadeReportDesign], loop: str, what: str) -> tuple[list[Curve], dict]:
    """One curve per design and source of ``what`` (``L`` or ``S``) of the loop, and ``{label: case}``."""
    curves, cases = [], {}
    for d in designs:
        k = 0
        for s in d.sources:
            case = s.done.analysis.cases.get(loop + s.checked)
            if case is None:
                continue
            if s.frf is not None:
                style, width, label = FRF_STYLES[k % len(FRF_STYLES)], 1.5, f"{d.label} on {s.name}"
                k += 1
            else:
                style, width, label = MODEL_STYLE, 1.1, f"{d.label}, model"
            curves.append(Curve(case.freq_hz, getattr(case, what), label, d.color, style, width,
                                d.masks.get(s.name, {}).get(loop + s.checked)))
            cases[label] = case
    return curves, cases


def _caption_tail(designs: list[CascadeReportDesign], loop: str, limits: ReportLimits) -> str:
    styles = "solid, dash-dot, dotted ... on the first, second, third FRF; dashed on the model"
    text = f" One colour per design; {styles}."
    open_ = [d.label for d in designs if loop and d.result["position_loop"]["open"]]
    if open_:
        text += " Position loop open (Kv = 0), not drawn: " + ", ".join(open_) + "."
    for d in designs:
        for s in d.sources:
            mask = d.masks.get(s.name, {}).get(loop + s.checked)
            case = s.done.analysis.cases.get(loop + s.checked)
            if mask is not None and case is not None:
                note = mask_note(mask, case.freq_hz, limits.coherence_trust, ", ".join(s.frf.channels))
                if note:
                    return text + note.replace(" Lines of the measured FRF", f" Lines of {s.name}")
    return text


def _loop_figures(designs: list[CascadeReportDesign], loop: str, limits: ReportLimits) -> list[FigureBlock]:
    drawn = [d for d in designs if any(s.done.analysis.cases.get(loop + s.checked) is not None for s in d.sources)]
    if not drawn:
        return []
    L, cases = _curves(drawn, loop, "L")
    S, _ = _curves(drawn, loop, "S")
    title = LOOP_TITLES[loop]
    what = ("L_v = C_v D G_1 H: the speed PI with the current-setpoint filters, the backward-difference speed, the "
            "motor side and the hold and delay" if not loop else
            "L_p = Kv H_N C_v G_p H / (1 + L_v): the position gain on the closed speed loop, held for the position "
            "loop's period, judged up to its Nyquist frequency")
    where = "in the checked case (discrete controller on each FRF; ideal_discrete on the model)"
    tail = _caption_tail(designs, loop, limits)
    cross = {label: c.metrics.crossovers_hz for label, c in cases.items()}
    ms = {label: c.metrics.ms for label, c in cases.items()}
    peaks = {label: (c.metrics.ms_freq_hz, c.metrics.ms) for label, c in cases.items()}
    name = "position" if loop else "speed"
    cap = title[0].upper() + title[1:]
    return [
        FigureBlock(f"cascade-{name}-loop", f"{cap} {where}, {what}; circles: crossovers.{tail}",
                    partial(loop_figure, L, cross, title=f"{cap}: Bode"), shows(drawn)),
        FigureBlock(f"cascade-{name}-nyquist", f"Nyquist plot of the {title} {where}; dotted circles: distance 1/Ms "
                    f"from -1.{tail}", partial(nyquist_figure, L, ms, title=f"{cap}: Nyquist"), shows(drawn)),
        FigureBlock(f"cascade-{name}-sensitivity", f"Sensitivity |S| = |1/(1 + L)| of the {title} {where}, Ms "
                    f"marked (the analysis' peak over every line).{tail}",
                    partial(sensitivity_figure, S, peaks, limits.ms_max, title=f"{cap}: sensitivity |S|"),
                    shows(drawn)),
    ]


def _controller_block(d: CascadeReportDesign) -> FigureBlock:
    """The speed controller as the drive executes it (PI times the current-setpoint filters at ``fs``) and the
    filters alone."""
    law = d.law
    f = controller_grid(law.fs)
    unit = f"{law.command_unit}/({law.position_unit}/s)"
    paths = [Curve(f, law.speed_controller_response(f, True), "C_v(z): speed PI with the filters", d.color, "-", 1.4)]
    filters = [Curve(f, law.filters_response(f, True), "current-setpoint filters", "0.25", "-", 1.3)]
    fig = partial(controller_figure, paths, filters, unit=unit, fs_hz=law.fs,
                  title=f"Speed controller and current-setpoint filters of {d.label}")
    return FigureBlock(f"design-controller-{d.name}", f"Speed controller of {d.label} ({d.name}) as the drive executes "
                       f"it at {law.fs:g} Hz: the PI (backward-Euler integral) times the current-setpoint filters "
                       f"(bilinear, prewarped) (left, dB re 1 {unit}), and the filters alone (right).", fig)


# ------------------------------------------------------------------------------------------ section
def cascade_subsections(inputs: Inputs, names: Mapping, limits: ReportLimits, data: dict, warnings: list[str],
                        colors: Colors) -> tuple[list[Section], list[CascadeReportDesign]]:
    """The drive-cascade subsection (none without cascade gains files) and the analysed designs: the report hook of
    the ``cascade`` gains format (:attr:`feedtune.structures.GainsFormat.report`; module docstring).

    Fills ``data["design"][file]`` with ``feedtune analyze FILE --frf F --json`` on the first fitting FRF (its
    ``check`` and ``verdict`` on every fitting FRF), ``frf``, ``frfs`` (the fitting ones), ``on[source]`` (the
    ``analysis`` on each FRF and on the ``model``), ``skipped_frfs`` and ``tracking_bandwidth``.
    """
    designs = build_cascade_designs(inputs, names, colors, limits)
    if not designs:
        return [], []
    store = data.setdefault("design", {})
    frfs = list(dict.fromkeys(s.name for d in designs for s in d.sources if s.frf is not None))
    where = (f"the measured FRF{'s' if len(frfs) > 1 else ''} {', '.join(frfs)} and on its model" if frfs
             else "its model only (no measured FRF given fits it)")
    blocks: list = [Paragraph(f"Each gains file is analysed as stored (no redesign) on {where}; the numbers equal "
                              "feedtune analyze GAINS [--frf FRF] --json, the verdict feedtune analyze GAINS"
                              + "".join(f" --frf {f}" for f in frfs) + " --json.")]
    for d in designs:
        store[d.name] = {**d.result, "frf": d.frf, "frfs": [s.name for s in d.sources if s.frf is not None],
                         "on": {s.name: s.done.result["analysis"] for s in d.sources},
                         "skipped_frfs": [{"frf": n, "reason": r} for n, r in d.skipped]}
        store_bandwidth(store, d, limits, response="closed loop L/(1+L)")
        blocks.append(parameter_table(f"Gains of {d.label} ({d.name})", d.result["gains"], ["design", d.name, "gains"],
                                      units=d.result.get("gain_units")))
        blocks.append(_units_paragraph(d))
        if d.skipped:
            blocks.append(Paragraph(f"{d.label} is not analysed on " + "; ".join(f"{n} ({r})" for n, r in d.skipped)
                                    + "."))
        warnings.extend(design_warnings(d, limits))
        blocks.append(verdict_paragraph(d, limits))
    blocks.append(tuning_table([(d.label, _tuning(d)) for d in designs]))
    blocks += [b for b in (objective_block(d.name, d.label, _tuning(d)) for d in designs) if b is not None]
    blocks.append(_cases_table(designs))
    blocks += [_certificate_table(d, limits) for d in designs]
    for loop in LOOPS:
        blocks += _loop_figures(designs, loop, limits)
    blocks += [_controller_block(d) for d in designs]
    return [Section("design-cascade", "Drive cascade (speed and position loop)", blocks)], designs


__all__ = ["CascadeReportDesign", "build_cascade_designs", "cascade_subsections"]
