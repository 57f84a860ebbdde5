"""What the measured data supports: which lines of a measured FRF are trusted (coherence), up to which frequency
a figure read from it means something, and the pass/fail line of a design.

* :func:`coherence_of` / :func:`trusted_mask` -- the lowest coherence over the channels a curve is built from,
  and the points of an analysis grid where it reaches the threshold (``ReportLimits.coherence_trust``). Curves
  drawn from the measured FRF (loop, sensitivity, tracking, Nyquist) leave the other points out.
* :func:`trusted_top_hz` -- the top of the trusted band: the last line before the coherence stays below the
  threshold (:data:`LOW_RUN` lines in a row).
* :func:`bandwidth_entry` -- the tracking bandwidth of an analysis case (the first frequency where the tracking
  response leaves 0 +- 3 dB), shown only below the top of the band that supports it.
* :func:`verdict_line` -- one line per design: PASS/FAIL under the limits used, with the figures checked.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

LOW_RUN = 3
"""Consecutive FRF lines below the coherence threshold that end the trusted band."""
BANDWIDTH_DEFINITION = ("first frequency where the {response} leaves 0 +- 3 dB; shown only below the top of the band "
                        "the data supports (measured cases: the FRF lines with coherence >= {thr:g}; model cases: the "
                        "model's fit band)")
"""What the report's tracking bandwidth is (``{response}``: of which response, :func:`bandwidth_definition`;
``{thr}``: the coherence threshold)."""
TRACKING_RESPONSE = "tracking response (with feedforward)"
"""The response a design's tracking bandwidth is read on (a drive cascade's: its closed loop ``L/(1+L)``)."""


def bandwidth_definition(thr: float, response: str = TRACKING_RESPONSE) -> str:
    """:data:`BANDWIDTH_DEFINITION` of ``response`` at the coherence threshold ``thr`` [-]."""
    return BANDWIDTH_DEFINITION.format(thr=thr, response=response)
MODEL_CASES = ("ideal", "ideal_discrete")
MEASURED_CASES = ("measured", "discrete")


def coherence_of(frf, channels: Sequence[str]) -> tuple[np.ndarray, np.ndarray] | None:
    """``(freq_hz, coherence)``: the lowest coherence [-] over the ``channels`` an FRF has (lines ``f > 0``), or
    None when it records none for them."""
    if frf is None:
        return None
    found = [frf.channel_coherence(ch) for ch in channels if frf.has(ch)]
    found = [c for c in found if c is not None]
    if not found:
        return None
    keep = frf.freq_hz > 0
    coh = np.min(np.vstack([np.asarray(c, float)[keep] for c in found]), axis=0)
    return frf.freq_hz[keep], np.where(np.isfinite(coh), coh, 0.0)


def trusted_mask(frf, channels: Sequence[str], freq_hz: np.ndarray, threshold: float) -> np.ndarray | None:
    """Points of ``freq_hz`` [Hz] where the FRF's coherence (lowest over ``channels``, linear between lines)
    reaches ``threshold``; None when the FRF records no coherence (nothing to judge: every point is drawn).

    Examples
    --------
    >>> from feedtune.frf import Frf
    >>> f = np.array([10.0, 20.0, 30.0, 40.0])
    >>> coh = np.array([0.9, 0.95, 0.2, 0.1]).reshape(1, 1, 4)
    >>> frf = Frf(f, np.ones((1, 1, 4), complex), ("x",), ("u",), coherence=coh)
    >>> trusted_mask(frf, ["x/u"], np.array([10.0, 15.0, 30.0]), 0.5).tolist()
    [True, True, False]
    """
    found = coherence_of(frf, channels)
    if found is None:
        return None
    f, coh = found
    return np.interp(np.asarray(freq_hz, float), f, coh) >= threshold


def trusted_top_hz(freq_hz: np.ndarray, coherence: np.ndarray, threshold: float) -> float | None:
    """The top of the trusted band [Hz]: the line before the first run of :data:`LOW_RUN` lines (or the last
    lines) with coherence below ``threshold``; the last line when there is no such run; None when the first
    lines are already below it.

    Examples
    --------
    >>> trusted_top_hz(np.arange(1.0, 9.0), np.array([1, 1, .2, 1, 1, .1, .1, .1]), 0.5)
    5.0
    """
    low = np.asarray(coherence, float) < threshold
    n = low.size
    for i in range(n):
        if low[i] and np.all(low[i:min(i + LOW_RUN, n)]):
            return float(freq_hz[i - 1]) if i > 0 else None
    return float(freq_hz[-1]) if n else None


def mask_note(mask: np.ndarray | None, freq_hz: np.ndarray, threshold: float, channels: str) -> str:
    """Caption text saying which measured lines a figure leaves out (empty when none is)."""
    if mask is None or bool(np.all(mask)):
        return ""
    left = int(np.count_nonzero(~mask))
    first = float(np.asarray(freq_hz)[~mask][0])
    return (f" Lines of the measured FRF whose coherence (lowest of {channels}) is below {threshold:g} are not "
            f"drawn ({left} of {mask.size} points, the first at {first:.4g} Hz).")


def bandwidth_entry(value_hz: float | None, case: str, support_hz: Mapping[str, float | None]) -> dict:
    """The tracking bandwidth of one analysis case as the report shows it.

    Parameters
    ----------
    value_hz : float or None
        ``tracking_bandwidth_hz`` of ``feedtune analyze`` for the case [Hz] (None: the response never leaves
        0 +- 3 dB on the grid).
    case : str
        Analysis case.
    support_hz : mapping
        ``{"measured": top of the trusted FRF band, "model": top of the model's fit band}`` [Hz] (None: no data
        supports that kind of case).

    Returns
    -------
    dict
        ``value_hz`` (the analysis value), ``supported_to_hz`` and ``shown`` (True when the value lies inside the
        supported band).
    """
    top = support_hz.get("measured" if case in MEASURED_CASES else "model")
    shown = value_hz is not None and top is not None and value_hz <= top
    return {"value_hz": value_hz, "supported_to_hz": top, "shown": bool(shown)}


ITEM_TEXT = {"ms": ("Ms", "", "<="), "pm_deg": ("PM", " deg", ">="), "gm_db": ("GM", " dB", ">="),
             "gm_low_db": ("gain-reduction GM", " dB", ">="), "disk_margin": ("disk margin", "", ">="),
             "band_top": ("|L| at the top of the proved band", "", "<=")}


def limit_text(item: Mapping | None) -> str:
    """The limit closest to binding (a limit item of ``feedtune analyze --json``'s certificate, ``active_limit``) in
    words: ``PM 30.13 deg (limit 30 deg) at 116.1 Hz on frf.csv``; ``-`` without one."""
    from ..display import number

    if not item:
        return "-"
    what, unit, _ = ITEM_TEXT.get(item["name"], (item["name"], "", ""))
    value = item.get("value")
    value = abs(value) if item["name"] == "gm_db" and value is not None else value
    text = f"{what} {number(value)}{unit} (limit {number(item.get('limit'))}{unit})"
    if item.get("freq_hz") is not None:
        text += f" at {number(item['freq_hz'])} Hz"
    return text + (f" on {item['frf']}" if item.get("frf") else "")


def verdict_line(label: str, name: str, check: Mapping, case_titles: Mapping[str, str], policy_text: str,
                 basis_text: str | None = None) -> str:
    """``"MC-PPC (mcppc.toml): PASS under textbook: Ms <= 2.5, ... in the case ...: Ms 2.26 at 176 Hz, ...;
    stable in 4 of 4 analysis cases."`` from a ``check`` entry of ``feedtune analyze --json``."""
    items = check.get("items") or []
    stable = [i for i in items if i["name"] == "stable"]
    n_stable = sum(1 for i in stable if i["ok"])
    case = check.get("checked_case")
    frfs = {i.get("frf") for i in items if i["name"] != "stable"}
    figures = []
    for i in items:
        if i["name"] not in ITEM_TEXT or i["value"] is None:
            continue
        what, unit, _ = ITEM_TEXT[i["name"]]
        value = abs(i["value"]) if i["name"] == "gm_db" else i["value"]
        where = f" at {i['freq_hz']:.4g} Hz" if i.get("freq_hz") is not None else ""
        # a figure of another loop's checked case (a cascade's position loop) or of one of several FRFs says so
        if i.get("case") and i["case"] != case:
            where += f" ({case_titles.get(i['case'], i['case'])})"
        if len(frfs) > 1 and i.get("frf"):
            where += f" on {i['frf']}"
        figures.append(f"{what} {value:.3g}{unit}{where}{'' if i['ok'] else ' (FAILS)'}")
    verdict = "PASS" if check.get("ok") else "FAIL"
    text = f"{label}{'' if name in label else f' ({name})'}: {verdict} under {policy_text}"
    if case:
        text += f", checked in the case '{case_titles.get(case, case)}'"
    text += ": " + (", ".join(figures) if figures else "no crossover to check")
    text += f"; stable in {n_stable} of {len(stable)} analysis cases."
    if not check.get("ok") and check.get("violations"):
        text += " Violations: " + "; ".join(check["violations"]) + "."
    if basis_text:
        text += f" Verdict on {basis_text}."
    return text
