"""The ball-screw tuners' own filter pack: resonances and sensitivity peaks of the checked plant cases, and the
choice of :func:`feedtune.tune.filter_choice.choose_filters` run with a tuner (MC-PPC or P-PI).

Resonances: on a measured FRF the peaks of the accelerance ``max(|x1/u|, |x2/u|) (2 pi f)^2`` (flat for the rigid
body), merged over the FRFs; without one, the model's lightly damped poles. Sensitivity peaks: of ``|S|`` of the
current design on every checked case, the highest first.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np

from ..analysis.ballscrew import analyze_case
from ..analysis.cases import PlantCase
from ..control.filters import TWO_PI, FilterPack
from ..errors import DesignError
from .filter_choice import choose_filters, merge_resonances, resonance_peaks, sensitivity_peaks


def ballscrew_resonances(pcs: Sequence[PlantCase], fs: float, n: int = 3,
                         prominence_db: float = 6.0) -> list[tuple[float, float, float, float]]:
    """Resonances ``(low Hz, high Hz, centre Hz, damping)`` of the checked plant cases (module docstring)."""
    per = []
    for pc in pcs:
        if not pc.measured:
            feats = [(float(f), float(z)) for f, z in np.asarray(pc.features).reshape(-1, 2) if 0 < f < 0.45 * fs]
            per.append(sorted(feats, key=lambda fz: fz[1])[:n])
            continue
        f = pc.freq_hz
        acc = np.max(np.abs(pc.plant(f)), axis=0) * (TWO_PI * f) ** 2
        per.append(resonance_peaks(f, acc, n, prominence_db))
    return merge_resonances(per)


def ballscrew_sensitivity_peaks(law, pcs: Sequence[PlantCase], above_hz: float, n: int = 2) -> list[float]:
    """The ``n`` highest peaks of ``|S|`` [Hz] of ``law`` above ``above_hz`` over the plant cases."""
    found = []
    for pc in pcs:
        r = analyze_case(law, pc)
        s = np.abs(r.S)
        for f in sensitivity_peaks(r.freq_hz, s, above_hz, n):
            found.append((float(np.interp(f, r.freq_hz, s)), f))
    return [f for _, f in sorted(found, reverse=True)[:n]]


def tune_with_own_filters(tune: Callable[..., object], screen_options: Callable[[object], dict], given: FilterPack,
                          pcs: Sequence[PlantCase], fs: float, quick_options: dict | None = None):
    """``(design, filter record)``: the best design of ``tune`` over the filter packs :func:`choose_filters` tries.

    Parameters
    ----------
    tune : callable
        ``tune(filters=pack, **options) -> design`` (a ball-screw tuner with its other arguments bound); raises
        DesignError when nothing meets the limits.
    screen_options : callable
        ``screen_options(design) -> dict``: the options that restrict ``tune`` to the design's shape (the cheap
        screen of a candidate filter).
    given : FilterPack
        The filters given (candidates; its leads are kept).
    pcs : sequence of PlantCase
        The checked plant cases (one per FRF).
    fs : float
        Sample rate [Hz].
    quick_options : dict, optional
        Options of ``tune`` for a cheaper search that ranks candidates when nothing is feasible without filters.
    """

    def attempt(pack: FilterPack, **options):
        try:
            return tune(filters=pack, **options)
        except DesignError:
            return None

    def objective(design) -> float:
        return float(design.tuning["first_crossover_hz"])

    def screen(pack: FilterPack, design, beat: float):
        d = attempt(pack, **screen_options(design))
        return (None if d is None else objective(d)), d, None

    _, design, record = choose_filters(
        given, run=attempt, objective=objective, screen=screen,
        refine=lambda pack, design, payload: attempt(pack), resonances=ballscrew_resonances(pcs, fs),
        peaks=lambda d: ballscrew_sensitivity_peaks(d.law(), pcs, objective(d)), fs=fs,
        quick=None if quick_options is None else (lambda pack: attempt(pack, **quick_options)))
    return design, record
