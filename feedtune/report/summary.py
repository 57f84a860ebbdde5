"""Summary (the verdict in numbers and every warning) and the list of inputs."""

from __future__ import annotations

from collections.abc import Mapping

from .collect import Inputs
from .content import Alert, Cell, Paragraph, Section, Table, text_cell
from .design import bandwidth_cell, bandwidth_note, verdict_paragraph
from .sections import BASELINE_CONTROLLERS, ReportLimits
from .trust import limit_text

BASIS_TEXT = {"frfs": "certified now on the FRF", "certificate": "the file's certificate",
              "model": "the design model only"}
"""What a verdict rests on, in a table cell (``verdict.basis`` of ``feedtune analyze --json``)."""


def headline_table(designs: list, limits: ReportLimits) -> Table:
    """One line per design: the verdict, the bandwidth it guarantees (the certificate's lowest first crossover over
    its FRFs, possible crossings counted), the limit that binds, the worst margins, what the verdict rests on and
    the tracking bandwidth, as ``feedtune analyze GAINS --json``'s ``verdict`` states them."""
    rows = []
    for d in designs:
        verdict = d.result.get("verdict") or {}
        worst = (verdict.get("certificate") or {}).get("worst") or {}
        k = ["design", d.name, "verdict", "certificate", "worst"]
        rows.append([text_cell(d.label), text_cell("PASS" if d.result["check"].get("ok") else "FAIL"),
                     Cell(worst.get("first_crossover_hz"), "Hz", key=[*k, "first_crossover_hz"]),
                     text_cell(limit_text(worst.get("active_limit"))),
                     Cell(worst.get("ms"), "", key=[*k, "ms"]), Cell(worst.get("pm_deg"), "deg", key=[*k, "pm_deg"]),
                     Cell(worst.get("gm_db"), "dB", key=[*k, "gm_db"]),
                     Cell(worst.get("gm_low_db"), "dB", key=[*k, "gm_low_db"]),
                     text_cell(BASIS_TEXT.get(verdict.get("basis"), "-")), _proved_cell(d),
                     bandwidth_cell(d, d.main_case)])
    return Table("Designs at a glance: verdict, guaranteed bandwidth and the limit that binds",
                 ["controller", "verdict", "guaranteed bandwidth", "limit that binds", "Ms", "PM", "GM",
                  "gain-reduction GM", "verdict rests on", "lines prove to", "tracking bandwidth"], rows,
                 f"Verdict under {limits.policy.describe()}, the worst over every FRF the design is certified on. "
                 "Guaranteed bandwidth: the first crossover the loop may have (possible crossings within the FRF's "
                 "scatter counted, docs/verdicts.md). Limit that binds: the limit with the least slack. Lines prove "
                 "to: the top of the band the measured lines prove the figures in; above it the analysis continues the "
                 "plant as the design section states. " + bandwidth_note(limits))


def _proved_cell(d) -> Cell:
    """Up to where the measured lines prove the checked case's figures (``band_edge.valid_to_hz``) [Hz]."""
    edge = (d.result["analysis"].get(d.main_case) or {}).get("band_edge") or {}
    if edge.get("valid_to_hz") is None:
        return text_cell("-")
    return Cell(edge["valid_to_hz"], "Hz", key=["design", d.name, "analysis", d.main_case, "band_edge", "valid_to_hz"])


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


def comparison_rows(data: Mapping) -> list[dict]:
    """The compared runs as the demos' comparison rows (:mod:`feedtune.analysis.comparison`): one row per test
    ``{"test": name, label: {"max_um", "rms_um"} or {"peak_um", "settling_time_s"}}``: tracking and cutting runs
    (Table 3.2), rope snaps (None where a run did not settle) and contours."""
    rows = []
    for row in ((data.get("comparison") or {}).get("tracking") or {}).get("rows", []):
        entry: dict = {"test": test_name(row["run"])}
        for label, run in row["runs"].items():
            entry[label] = {"max_um": _um(run.get("max_m")), "rms_um": _um(run.get("rms_m"))}
        rows.append(entry)
    tests: dict[str, dict] = {}
    for run in (data.get("ropesnap") or {}).values():
        m = run.get("metrics") or {}
        tests.setdefault(run.get("run") or "rope snap", {})[run["controller"]] = {
            "peak_um": _um(m.get("peak_abs_m")),
            "settling_time_s": m.get("settling_time_s") if m.get("settled", True) else None}
    for run in (data.get("contour") or {}).values():
        m = run.get("metrics") or {}
        tests.setdefault(run.get("run") or "contour", {})[run["controller"]] = {
            "max_um": _um(m.get("max_m")), "rms_um": _um(m.get("rms_m"))}
    rows += [{"test": test, **per} for test, per in tests.items()]
    return rows


def test_name(title: str) -> str:
    """A run group's title as the demos name their tests: ``tracking, peak speed 200 mm/s`` -> ``track 200 mm/s``,
    ``cut, peak speed 200 mm/s`` -> ``cut 200 mm/s``; other titles unchanged."""
    for prefix, shown in (("tracking, peak speed ", "track "), ("cut, peak speed ", "cut ")):
        if title.startswith(prefix):
            return shown + title[len(prefix):]
    return title


def _um(x):
    return None if x is None else 1e6 * float(x)


def comparison_sentences(data: Mapping) -> list[str]:
    """For every proposal (a controller other than P-PI, PID and their variants) against every baseline they were
    both run with: how many figures each wins and which ones the baseline wins, the sentence ``feedtune demo``
    prints (:func:`feedtune.analysis.comparison.verdict_line`, the same rows, the same tie rule)."""
    from ..analysis.comparison import verdict_line

    rows = comparison_rows(data)
    labels = list(dict.fromkeys(k for r in rows for k in r if k != "test"))
    out = []
    for p in (lb for lb in labels if not _is_baseline(lb)):
        for b in (lb for lb in labels if _is_baseline(lb)):
            if any(p in r and b in r for r in rows):
                out.append(verdict_line(rows, (p, p), (b, b)))
    return out


def summary_section(designs: list, data: dict, warnings: list[str],
                    limits: ReportLimits, inputs: Inputs | None = None) -> Section:
    """The summary shown first: the verdict in words and numbers, error reductions, model fit, warnings."""
    checked = checked_statements(designs, data, limits, inputs)
    blocks: list = []
    red = reductions(data)
    blocks.extend(verdict_paragraph(d, limits, assumes=False) for d in designs)
    sentence = _reduction_sentence(red)
    if sentence:
        blocks.append(Paragraph(sentence + " Negative values are increases."))
    sentences = comparison_sentences(data)
    blocks.extend(Paragraph(t) for t in sentences)
    data.setdefault("verdict", {})["comparison"] = sentences
    if designs:
        blocks.append(headline_table(designs, limits))
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
