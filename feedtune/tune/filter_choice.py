"""The tuners' own filter pack: notches and a low-pass placed where they raise the objective (issue 12).

Every tuner that chooses its filters does it the same way (:func:`choose_filters`). From the best design without
notches or low-pass (the leads of the given pack are kept), each round

1. seeds candidates (:func:`filter_candidates`): a notch at every plant resonance above half the current first
   crossover (:func:`resonance_peaks`: peaks of the accelerance, flat for a rigid body, with the damping from the
   half-power width) and at the sensitivity peaks of the current design (:func:`sensitivity_peaks`), each with the
   zero damping of the resonance and the pole dampings of :data:`NOTCH_POLE_DAMPING`; when the resonance moves
   across the FRFs (several measured positions or loads), also one wider notch covering the whole spread; and,
   without a low-pass yet, first- and second-order low-passes between the crossover and the highest sensitivity
   peak; the given filters are candidates too;
2. screens each candidate at the current winner's shape (the tuner's ``screen``), and keeps the one that raises the
   objective most, if by more than :data:`KEEP_GAIN`, after the tuner's local search from it (``refine``);
3. stops when no candidate helps or after :data:`MAX_OWN_FILTERS` filters;
4. compares the result with the given pack as a whole (an engineer's pack may hold more filters than the tuner adds,
   working together) and keeps the better.

When no design meets the limits without filters, the first round runs the whole search with each resonance's notch
(and each given filter; with a quick search given, only for the two it ranks best) and keeps the best that meets
them.

So a resonance is notched only when the notch raises the bandwidth under the limits, a moving resonance gets one
wide notch or narrow ones or none, by the same objective, and a plant without resonances gets no notch.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import replace
from typing import Any

import numpy as np

from ..control.filters import FilterPack, Notch
from ..errors import DesignError
from .search import Objective

MAX_OWN_FILTERS = 3
"""Most filters the tuner adds (notches and one low-pass)."""
KEEP_GAIN = 0.02
"""Relative rise of the objective [-] a filter must bring (screened at the current shape) to be kept."""
NOTCH_POLE_DAMPING = (0.3, 0.6)
"""Damping of the notch poles tried [-]; the zeros get the resonance's damping (0.05 at a sensitivity peak)."""
QUICK_KEEP = 2
"""Candidates run through the whole search after the quick ranking (when nothing is feasible without filters)."""
SAME_RESONANCE = 0.25
"""Peaks of several FRFs closer than this relative distance are one resonance that moves [-]."""
SEPARATE = 0.1
"""A sensitivity peak this close (relative) to a resonance is that resonance [-]."""


def resonance_peaks(freq_hz: np.ndarray, accelerance: np.ndarray, n: int = 3,
                    prominence_db: float = 6.0) -> list[tuple[float, float]]:
    """The ``n`` most prominent resonances ``(Hz, damping)`` of an accelerance magnitude.

    Parameters
    ----------
    freq_hz : ndarray
        Lines [Hz].
    accelerance : ndarray
        ``|G| (2 pi f)^2`` (flat for a rigid body) on the lines, e.g. of the largest singular value.
    n : int
        Most resonances returned, the most prominent first.
    prominence_db : float
        Height [dB] a peak must stand above its surroundings.

    Returns
    -------
    list of (float, float)
        Frequency [Hz] and damping [-] from the half-power width (0.05 when the lines do not resolve it).
    """
    from scipy.signal import find_peaks

    f = np.asarray(freq_hz, float)
    acc = np.asarray(accelerance, float)
    db = 20 * np.log10(np.maximum(acc, np.finfo(float).tiny))
    idx, props = find_peaks(db, prominence=prominence_db)
    out = []
    for i in idx[np.argsort(props["prominences"])[::-1]][:n]:
        half = acc[i] / math.sqrt(2)
        lo = i
        while lo > 0 and acc[lo] > half:
            lo -= 1
        hi = i
        while hi < f.size - 1 and acc[hi] > half:
            hi += 1
        ok = acc[lo] <= half and acc[hi] <= half and hi - lo >= 3
        out.append((float(f[i]), float((f[hi] - f[lo]) / (2 * f[i])) if ok else 0.05))
    return out


def sensitivity_peaks(freq_hz: np.ndarray, s_mag: np.ndarray, above_hz: float, n: int = 2) -> list[float]:
    """Frequencies [Hz] of the ``n`` highest local maxima of ``|S|`` (or ``sigma_max(S)``) above ``above_hz``."""
    from scipy.signal import find_peaks

    f = np.asarray(freq_hz, float)
    s = np.asarray(s_mag, float)
    idx, _ = find_peaks(np.r_[0.0, s, 0.0])
    idx = idx - 1
    idx = idx[(f[idx] > above_hz) & (s[idx] > 1.0)]
    return [float(f[i]) for i in idx[np.argsort(s[idx])[::-1]][:n]]


def merge_resonances(per_frf: Sequence[Sequence[tuple[float, float]]]) -> list[tuple[float, float, float, float]]:
    """Resonances of several FRFs grouped by frequency: a peak joins a resonance of the other FRFs within
    :data:`SAME_RESONANCE` (at most one peak per FRF in each).

    Returns
    -------
    list of (float, float, float, float)
        ``(lowest Hz, highest Hz, geometric-mean Hz, lowest damping)`` per resonance, the order of the first FRF's
        prominence kept.
    """
    groups: list[list[tuple[float, float, int]]] = []
    for k, peaks in enumerate(per_frf):
        for f, z in peaks:
            for g in groups:
                centre = math.sqrt(min(p[0] for p in g) * max(p[0] for p in g))
                if all(p[2] != k for p in g) and abs(math.log(f / centre)) < SAME_RESONANCE:
                    g.append((f, z, k))
                    break
            else:
                groups.append([(f, z, k)])
    out = []
    for g in groups:
        freqs = [p[0] for p in g]
        out.append((min(freqs), max(freqs), float(math.sqrt(min(freqs) * max(freqs))), min(p[1] for p in g)))
    return out


def describe(item) -> str:
    """``notch 420 Hz (zeta_z 0.05, zeta_p 0.3)`` or ``low-pass 800 Hz, order 2``."""
    if isinstance(item, tuple):
        return f"low-pass {item[0]:.4g} Hz, order {item[1]}"
    return f"notch {item.freq_hz:.4g} Hz (zeta_z {item.zeta_z:.3g}, zeta_p {item.zeta_p:.3g})"


def with_filter(pack: FilterPack, item) -> FilterPack:
    """``pack`` with a notch added or the low-pass ``(Hz, order)`` set."""
    if isinstance(item, tuple):
        return replace(pack, lpf_hz=item[0], lpf_order=item[1])
    return replace(pack, notches=(*pack.notches, item))


def _notches(f: float, z: float | None, why: str) -> list[tuple[Notch, str]]:
    zz = 0.05 if z is None else min(max(z, 0.005), 0.25)
    return [(Notch(f, zz, zp), f"{why} at {f:.4g} Hz") for zp in NOTCH_POLE_DAMPING if zz < zp]


def filter_candidates(pack: FilterPack, given: FilterPack, resonances: Sequence[tuple[float, float, float, float]],
                      peaks: Sequence[float], crossover_hz: float, fs: float) -> list[tuple[object, str]]:
    """Filters to try next: ``[(Notch or (lpf_hz, order), why)]`` (module docstring, step 1).

    Parameters
    ----------
    pack : FilterPack
        The filters kept so far.
    given : FilterPack
        The filters the user gave (candidates too).
    resonances : sequence of (float, float, float, float)
        From :func:`merge_resonances` ``(low Hz, high Hz, centre Hz, damping)``.
    peaks : sequence of float
        Sensitivity peaks of the current design [Hz].
    crossover_hz : float
        First crossover of the current design [Hz].
    fs : float
        Sample rate [Hz]: filters stay below 0.45 fs.
    """
    out: list = []
    top = 0.45 * fs
    seeds = [r for r in resonances if 0.5 * crossover_hz < r[2] < top]
    for lo, hi, centre, z in seeds:
        if any(abs(n.freq_hz / centre - 1) < 0.05 for n in pack.notches):
            continue
        if hi / lo > 1.05:  # it moves: a narrow notch at either end, or one notch as wide as the spread
            for f in (lo, hi):
                out += _notches(f, z, "plant resonance")
            out += _notches(centre, max(z, (hi - lo) / (2 * centre)), f"resonance moving {lo:.4g}-{hi:.4g} Hz")
        else:
            out += _notches(centre, z, "plant resonance")
    for f in peaks:
        if f < top and all(abs(f / s[2] - 1) > SEPARATE for s in seeds) and \
                all(abs(n.freq_hz / f - 1) >= 0.05 for n in pack.notches):
            out += _notches(f, None, "sensitivity peak")
    out += [(n, "given") for n in given.notches if all(abs(m.freq_hz / n.freq_hz - 1) > 1e-6 for m in pack.notches)]
    if pack.lpf_hz is None:
        if peaks and peaks[0] > 2 * crossover_hz:
            fp = peaks[0]
            out += [((fc, order), f"below the sensitivity peak at {fp:.4g} Hz")
                    for fc in (math.sqrt(crossover_hz * fp), fp / 2) for order in (1, 2) if fc < top]
        if given.lpf_hz is not None:
            out.append(((given.lpf_hz, given.lpf_order), "given"))
    return out


def choose_filters(given: FilterPack, *, run: Callable[[FilterPack], Any],
                   objective: Callable[[Any], float],
                   screen: Callable[[FilterPack, Any, float], tuple[float | None, Any, str | None]],
                   refine: Callable[[FilterPack, Any, Any], Any],
                   resonances: Sequence[tuple[float, float, float, float]],
                   peaks: Callable[[Any], list[float]], fs: float,
                   quick: Callable[[FilterPack], Any] | None = None, what: str = "first crossover",
                   unit: str = "Hz") -> tuple[FilterPack, Any, dict]:
    """The tuner's own filter pack (module docstring): ``(pack, outcome or None, record)``.

    Parameters
    ----------
    given : FilterPack
        The filters given (candidates; its leads are kept in every pack).
    run : callable
        ``run(pack) -> outcome or None``: the tuner's whole search with a pack (None: nothing meets the limits).
    objective : callable
        ``objective(outcome) -> float``: the figure the tuner maximises (its objective's merit: the first crossover
        [Hz] or the integral gain) of an outcome.
    screen : callable
        ``screen(pack, outcome, beat) -> (objective or None, payload, note)``: a cheap check of a pack at the
        outcome's shape, which may give up early when it cannot beat ``beat`` [Hz] (``note`` says why).
    refine : callable
        ``refine(pack, outcome, payload) -> outcome or None``: the tuner's local search with the kept pack.
    resonances : sequence of (float, float, float, float)
        From :func:`merge_resonances`.
    peaks : callable
        ``peaks(outcome) -> [Hz]``: sensitivity peaks of an outcome's design above its crossover.
    fs : float
        Sample rate [Hz].
    quick : callable, optional
        ``quick(pack) -> outcome or None``: a cheaper search (fewer shapes). When nothing meets the limits without
        filters, the candidates are ranked by it and the whole search runs for the best :data:`QUICK_KEEP` only.
    what, unit : str
        The name and unit of ``objective`` in the record (``"first crossover"``, ``"Hz"``; ``"integral gain Ki2"``,
        ``"V/(rad s)"``).
    """
    u = f" {unit}" if unit else ""
    pack = replace(given, notches=(), lpf_hz=None)
    result = run(pack)
    rounds = []
    chosen = []
    if result is None:  # the resonances' notches (and the given filters), each with the whole search
        tried = []
        items = filter_candidates(pack, given, resonances, [], 0.0, fs)
        if quick is not None and len(items) > QUICK_KEEP:
            ranked = []
            for item, why in items:
                q = quick(with_filter(pack, item))
                ranked.append((-1.0 if q is None else objective(q), item, why))
            ranked.sort(key=lambda r: -r[0])
            items = [(item, why) for value, item, why in ranked[:QUICK_KEEP] if value >= 0]
        for item, why in items:
            r = run(with_filter(pack, item))
            tried.append({"filter": describe(item), "why": why, "item": item, "result": r,
                          "crossover_hz": None if r is None else objective(r)})
        rounds.append({"crossover_before_hz": None, "candidates": [
            {k: v for k, v in t.items() if k in ("filter", "why", "crossover_hz")} for t in tried]})
        good = [t for t in tried if t["result"] is not None]
        if not good:
            rounds[-1]["kept"] = None
            whole = run(given) if (given.notches or given.lpf_hz is not None) else None
            if whole is not None:
                return given, whole, {"choice": "own", "rounds": rounds, "chosen": [
                    f"the given filter pack as a whole: {what} {objective(whole):.4g}{u} (no design without "
                    "filters or with one notch at a resonance)"],
                    "why": "the given filters, kept together, are the only pack found that meets the limits"}
            return pack, None, {"choice": "own", "chosen": [], "rounds": rounds,
                                "why": "no design met the limits without filters or with one notch at a resonance"}
        top = max(good, key=lambda t: t["crossover_hz"])
        rounds[-1]["kept"] = top["filter"]
        chosen.append(f"{top['filter']} ({top['why']}): no design without it; {what} "
                      f"{top['crossover_hz']:.4g}{u} with it")
        pack, result = with_filter(pack, top["item"]), top["result"]
    for _ in range(MAX_OWN_FILTERS - len(chosen)):
        x0 = objective(result)
        beat = x0 * (1 + KEEP_GAIN)
        tried = []
        for item, why in filter_candidates(pack, given, resonances, peaks(result), x0, fs):
            value, payload, note = screen(with_filter(pack, item), result, beat)
            t = {"filter": describe(item), "why": why, "item": item, "payload": payload, "crossover_hz": value}
            if note:
                t["screen"] = note
            tried.append(t)
        rec = {"crossover_before_hz": x0,
               "candidates": [{k: v for k, v in t.items() if k in ("filter", "why", "crossover_hz", "screen")}
                              for t in tried]}
        rounds.append(rec)
        good = [t for t in tried if t["crossover_hz"] is not None and t["crossover_hz"] > beat]
        if not good:
            rec["kept"] = None
            break
        top = max(good, key=lambda t: t["crossover_hz"])
        trial = with_filter(pack, top["item"])
        local = refine(trial, result, top["payload"])
        if local is None or objective(local) <= beat:
            rec["kept"] = None
            break
        rec["kept"] = top["filter"]
        chosen.append(f"{top['filter']} ({top['why']}): {what} {x0:.4g} -> {objective(local):.4g}{u}")
        pack, result = trial, local
    why = (f"no notch or low-pass raised the {what} by more than "
           f"{100 * KEEP_GAIN:g} %" if not chosen else f"each kept filter raised the {what} by more than "
           f"{100 * KEEP_GAIN:g} % at the winner's shape")
    if (given.notches or given.lpf_hz is not None) and given != pack:  # the given pack as a whole, by the objective
        whole = run(given)
        if whole is not None and (result is None or objective(whole) > objective(result)):
            mine = "no design" if result is None else f"{objective(result):.4g}{u}"
            return given, whole, {"choice": "own", "chosen": [f"the given filter pack as a whole: {what} "
                                                              f"{objective(whole):.4g}{u} (own choice: {mine})"],
                                  "why": "the given filters, kept together, beat the tuner's own choice",
                                  "rounds": rounds}
        rounds.append({"given_pack_crossover_hz": None if whole is None else objective(whole)})
    return pack, result, {"choice": "own", "chosen": chosen, "why": why, "rounds": rounds}


def tune_with_own_filters(tune: Callable[..., object], screen_options: Callable[[object], dict], given: FilterPack,
                          resonances: Sequence[tuple[float, float, float, float]],
                          peaks: Callable[[object], list[float]], fs: float, quick_options: dict | None = None,
                          objective: Objective | None = None):
    """``(design, filter record)``: the best design of ``tune`` over the filter packs :func:`choose_filters` tries.

    Parameters
    ----------
    tune : callable
        ``tune(filters=pack, **options) -> design`` (a tuner over a fixed list of shapes with its other arguments
        bound; ``design.tuning["first_crossover_hz"]`` is its objective); raises DesignError when nothing meets
        the limits.
    screen_options : callable
        ``screen_options(design) -> dict``: the options that restrict ``tune`` to the design's shape (the cheap
        screen of a candidate filter).
    given : FilterPack
        The filters given (candidates; its leads are kept).
    resonances : sequence of (float, float, float, float)
        The plant's resonances (:func:`merge_resonances` over the FRFs).
    peaks : callable
        ``peaks(design) -> [Hz]``: sensitivity peaks of a design above its first crossover, over the FRFs.
    fs : float
        Sample rate [Hz].
    quick_options : dict, optional
        Options of ``tune`` for a cheaper search that ranks candidates when nothing is feasible without filters.
    objective : Objective, optional
        What a filter must raise: the integral gain (``design.tuning["integral_gain"]``) under ``stiffness`` and
        ``pareto``, the first crossover under ``bandwidth`` (the default without one).
    """

    def attempt(pack: FilterPack, **options):
        try:
            return tune(filters=pack, **options)
        except DesignError:
            return None

    by_gain = objective is not None and objective.by_gain

    def merit(design) -> float:
        return float(design.tuning["integral_gain"]["value"] if by_gain else design.tuning["first_crossover_hz"])

    def screen(pack: FilterPack, design, beat: float):
        d = attempt(pack, **screen_options(design))
        return (None if d is None else merit(d)), d, None

    what, unit = ("first crossover", "Hz") if not by_gain else ("integral gain", "")
    _, design, record = choose_filters(
        given, run=attempt, objective=merit, screen=screen, what=what, unit=unit,
        refine=lambda pack, design, payload: attempt(pack), resonances=resonances, peaks=peaks, fs=fs,
        quick=None if quick_options is None else (lambda pack: attempt(pack, **quick_options)))
    return design, record
