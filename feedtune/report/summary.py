"""Summary (the verdict in numbers and every warning) and the list of inputs."""

from __future__ import annotations

from collections.abc import Mapping

from .collect import Inputs
from .content import Alert, Cell, Paragraph, Section, Table, text_cell
from .design import CASE_TITLES, bandwidth_cell, bandwidth_note, verdict_paragraph
from .sections import BASELINE_CONTROLLERS, ReportLimits


def _verdict_table(designs: list, limits: ReportLimits) -> Table:
    rows = []
    for d in designs:
        case = d.main_case
        m = d.result["analysis"][case]
        k = ["design", d.name, "analysis", case]
        rows.append([text_cell(d.label), text_cell("PASS" if d.result["check"].get("ok") else "FAIL"),
                     text_cell(CASE_TITLES[case]), Cell(m["stable"], key=[*k, "stable"]),
                     Cell(m["crossovers_hz"], "Hz", key=[*k, "crossovers_hz"]),
                     Cell(m["phase_margin_deg"], "deg", key=[*k, "phase_margin_deg"]),
                     Cell(m["gain_margin_db"], "dB", key=[*k, "gain_margin_db"]),
                     Cell(m["ms"], "", key=[*k, "ms"]), bandwidth_cell(d, case)])
    return Table("Controllers", ["controller", "verdict", "case", "stable", "crossovers", "phase margin",
                                 "gain margin", "Ms", "tracking bandwidth"], rows,
                 f"Verdict under {limits.policy.describe()}. " + bandwidth_note(limits))


def _span(values: list[float]) -> tuple[float, float] | None:
    vals = [v for v in values if v is not None]
    return (min(vals), max(vals)) if vals else None


def reductions(data: Mapping) -> dict:
    """Per controller: the range of max and RMS tracking-error reductions over the runs, the rope-snap peak and
    settling-time reductions and the range of maximum contour-error reductions against the baseline [%]."""
    out: dict = {}
    tracking = (data.get("comparison") or {}).get("tracking") or {}
    for row in tracking.get("rows", []):
        for label, red in row["reduction_pct"].items():
            entry = out.setdefault(label, {"baseline": row["baseline"], "max": [], "rms": []})
            entry["max"].append(red["max"])
            entry["rms"].append(red["rms"])
    result = {}
    for label, entry in out.items():
        result[label] = {"baseline": entry["baseline"], "tracking_max_pct": _span(entry["max"]),
                         "tracking_rms_pct": _span(entry["rms"])}
    for test, per in ((data.get("comparison") or {}).get("ropesnap") or {}).items():
        for label, red in per.items():
            r = result.setdefault(label, {"baseline": red["baseline"]})
            r.setdefault("ropesnap", {})[test] = {"peak_pct": red["peak"], "settling_time_pct": red["settling_time"]}
    contour: dict = {}
    for per in ((data.get("comparison") or {}).get("contour") or {}).values():
        for label, red in per.items():
            contour.setdefault(label, (red["baseline"], []))[1].append(red["max"])
    for label, (baseline, values) in contour.items():
        result.setdefault(label, {"baseline": baseline})["contour_max_pct"] = _span(values)
    return result


def _range_text(span) -> str:
    if span is None:
        return "-"
    lo, hi = span
    return f"{lo:.3g} %" if abs(hi - lo) < 0.05 else f"{lo:.3g} to {hi:.3g} %"


def _reduction_table(red: dict) -> Table | None:
    rows = []
    for label, r in red.items():
        snap = next(iter((r.get("ropesnap") or {}).values()), {})
        rows.append([text_cell(label), text_cell(r["baseline"] or "-"),
                     text_cell(_range_text(r.get("tracking_max_pct"))),
                     text_cell(_range_text(r.get("tracking_rms_pct"))),
                     Cell(snap.get("peak_pct"), "%", digits=3), Cell(snap.get("settling_time_pct"), "%", digits=3),
                     text_cell(_range_text(r.get("contour_max_pct")))])
    if not rows:
        return None
    return Table("Error reduction against the baseline controller (positive: smaller error)",
                 ["controller", "baseline", "max tracking error", "RMS tracking error", "rope-snap peak",
                  "rope-snap 5 % settling time", "max contour error"], rows,
                 "Ranges over the tracking and cutting runs of the Table 3.2 comparison and over the contours.")


def _fit_table(data: Mapping) -> Table | None:
    rows = []
    for name, model in (data.get("identification") or {}).items():
        quality = ((model.get("fit") or {}).get("fit") or {}) if isinstance(model.get("fit"), Mapping) else {}
        for ch, q in quality.items():
            if isinstance(q, Mapping) and "nrmse" in q:
                rows.append([text_cell(name), text_cell(ch),
                             Cell(q["nrmse"], "", key=["identification", name, "fit", "fit", ch, "nrmse"])])
    return Table("Model fit", ["model", "channel", "NRMSE"], rows) if rows else None


def _reduction_sentence(red: dict) -> str | None:
    parts = []
    for label, r in red.items():
        items = []
        if r.get("tracking_max_pct") is not None:
            items.append(f"the maximum tracking error by {_range_text(r['tracking_max_pct'])}")
        if r.get("tracking_rms_pct") is not None:
            items.append(f"the RMS tracking error by {_range_text(r['tracking_rms_pct'])}")
        for snap in (r.get("ropesnap") or {}).values():
            if snap.get("peak_pct") is not None:
                items.append(f"the rope-snap peak by {snap['peak_pct']:.3g} %")
            if snap.get("settling_time_pct") is not None:
                items.append(f"the rope-snap settling time by {snap['settling_time_pct']:.3g} %")
        if r.get("contour_max_pct") is not None:
            items.append(f"the maximum contour error by {_range_text(r['contour_max_pct'])}")
        if items:
            parts.append(f"Against {r['baseline']}, {label} reduces " + ", ".join(items) + ".")
    return " ".join(parts) or None


def _is_baseline(label: str) -> bool:
    return any(label == b or label.startswith(b + " ") for b in BASELINE_CONTROLLERS)


def _figures_by_label(data: Mapping) -> dict[str, dict[str, float]]:
    """``{label: {figure: value}}`` of every compared run (smaller is better): tracking max/RMS [m] per run, and for
    rope snaps and contours the value relative to the group's baseline ``1 - reduction / 100`` (the baseline's is
    1)."""
    comp = data.get("comparison") or {}
    out: dict[str, dict[str, float]] = {}
    for row in (comp.get("tracking") or {}).get("rows", []):
        for label, run in row["runs"].items():
            for key, what in (("max_m", "max"), ("rms_m", "RMS")):
                if run.get(key) is not None:
                    out.setdefault(label, {})[f"{row['run']} {what}"] = run[key]
    for section, figures in (("ropesnap", (("peak", "peak"), ("settling_time", "settling time"))),
                             ("contour", (("max", "max"),))):
        for test, per in (comp.get(section) or {}).items():
            for label, red in per.items():
                base = red.get("baseline")
                for key, what in figures:
                    if red.get(key) is not None:
                        out.setdefault(label, {})[f"{test} {what}"] = 1.0 - red[key] / 100.0
                        out.setdefault(base, {})[f"{test} {what}"] = 1.0
    return out


def _baseline_wins(data: Mapping) -> str | None:
    """A sentence naming, for every proposal and every baseline (P-PI, PID, and their variants), the figures in
    which the baseline is better (by more than 0.5 %), or None."""
    figs = _figures_by_label(data)
    proposals = [lb for lb in figs if not _is_baseline(lb)]
    baselines = [lb for lb in figs if _is_baseline(lb)]
    parts = []
    for p in proposals:
        for b in baselines:
            wins = [k for k, v in figs[b].items() if k in figs[p] and v < figs[p][k] - 0.005 * abs(figs[p][k])]
            if wins:
                parts.append(f"{b} is better than {p} in {len(wins)} of {len(set(figs[b]) & set(figs[p]))} "
                             f"figures: {', '.join(wins)}.")
    return " ".join(parts) or None


def summary_section(designs: list, data: dict, warnings: list[str],
                    limits: ReportLimits, inputs: Inputs | None = None) -> Section:
    """The summary shown first: the verdict in words and numbers, error reductions, model fit, warnings."""
    checked = checked_statements(designs, data, limits, inputs)
    blocks: list = []
    red = reductions(data)
    blocks.extend(verdict_paragraph(d, limits) for d in designs)
    sentence = _reduction_sentence(red)
    if sentence:
        blocks.append(Paragraph(sentence + " Negative values are increases."))
    wins = _baseline_wins(data)
    if wins:
        blocks.append(Alert("The baseline wins here: " + wins))
    data.setdefault("verdict", {})["baseline_wins"] = wins
    if designs:
        blocks.append(_verdict_table(designs, limits))
    data["summary"] = {"reductions": red, "warnings": list(warnings), "limits": limits.to_dict()}
    table = _reduction_table(red)
    if table is not None:
        blocks.append(table)
    fit = _fit_table(data)
    if fit is not None:
        blocks.append(fit)
    if warnings:
        blocks.append(Paragraph(f"Warnings ({len(warnings)}):"))
        blocks.extend(Alert(w) for w in warnings)
    else:
        blocks.append(Paragraph("No warnings: " + "; ".join(checked or ["nothing in the inputs to check"]) + "."))
    return Section("summary", "Summary", blocks)


def checked_statements(designs: list, data: Mapping, limits: ReportLimits, inputs: Inputs | None = None) -> list[str]:
    """What was checked and found in order, one statement per kind of input (used when there is no warning):
    designs, model fits, FRF coherence in a fit band, logs. Nothing is claimed for inputs that were not given."""
    out = []
    if designs:
        out.append(f"every design ({len(designs)}) is stable in every analysis case and meets the limits "
                   f"({limits.policy.describe()})")
    fits = [m for m in (data.get("identification") or {}).values()
            if isinstance(m, Mapping) and isinstance(m.get("fit"), Mapping) and m["fit"].get("fit")]
    if fits:
        out.append(f"every model fit ({len(fits)}) has NRMSE <= {limits.nrmse_max:g} per channel")
        if any(m["fit"].get("band_hz") for m in fits) and (inputs is None or inputs.frfs):
            out.append(f"the coherence of the measured FRF is >= {limits.coherence_min:g} inside the fit band")
    elif inputs is not None and inputs.frfs:
        out.append(f"the measured FRFs ({len(inputs.frfs)}) are shown without a model fit band to judge their "
                   "coherence against (see Identification)")
    if inputs is not None and not designs and not inputs.gains:
        out.append("no gains file was given, so no stability or margin is claimed")
    runs = len(data.get("tracking") or {}) + len(data.get("ropesnap") or {}) + len(data.get("contour") or {})
    if runs:
        out.append(f"no run ({runs}) tripped or held its command at the largest magnitude for "
                   f"{limits.saturation_samples} samples or more")
    return out


def inputs_section(inputs: Inputs, names: Mapping) -> Section:
    """The files used, what each was taken for, and the files left out."""
    rows = []
    for m in inputs.models:
        rows.append([text_cell(names[m.path]), text_cell(f"model ({m.kind})"), text_cell(m.note or str(m.path))])
    for g in inputs.gains:
        rows.append([text_cell(names[g.path]), text_cell(f"gains ({g.kind}, {g.controller or '-'})"),
                     text_cell(str(g.path))])
    for f in inputs.frfs:
        rows.append([text_cell(names[f.path]), text_cell(f"FRF ({f.frf.quantity}, {', '.join(f.frf.channels)})"),
                     text_cell(f"{f.frf.freq_hz.size} lines, {f.frf.freq_hz[0]:g}-{f.frf.freq_hz[-1]:g} Hz")])
    for li in inputs.logs:
        how = {"meta": "from its metadata", "option": "from --log-kind", "columns": "from its columns"}[li.kind_from]
        rows.append([text_cell(names[li.path]), text_cell(f"log ({li.kind}, {how})"),
                     text_cell(f"{li.log.n} samples at {li.log.fs:.6g} Hz, signals {', '.join(li.log.signals)}")])
    for c in inputs.curves:
        doc = c.doc
        directions = " and ".join({"pos": "v > 0", "neg": "v < 0"}.get(d, d) for d in doc.get("directions") or [])
        rows.append([text_cell(names.get(c.path, c.path.name)), text_cell(f"friction curve ({doc.get('law', '-')})"),
                     text_cell(f"{directions or 'no direction'}; {len((doc.get('points') or {}).get('velocity') or [])}"
                               f" measured points; from {doc.get('source', '-')}")])
    for o in inputs.others:
        rows.append([text_cell(o.path.name), text_cell("listed only" if o.doc is None else "supplementary data"),
                     text_cell(o.description)])
    blocks: list = [Table("Files", ["file", "taken as", "details"], rows)]
    if inputs.skipped:
        blocks.append(Table("Files left out", ["file", "reason"],
                            [[text_cell(str(s.path)), text_cell(s.reason)] for s in inputs.skipped]))
    return Section("inputs", "Inputs", blocks)
