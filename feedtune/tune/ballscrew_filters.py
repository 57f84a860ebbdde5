"""The ball-screw tuners' own filter pack: resonances and sensitivity peaks of the checked plant cases, for
:func:`feedtune.tune.filter_choice.tune_with_own_filters` run with a tuner (MC-PPC or P-PI).

Resonances: on a measured FRF the peaks of the accelerance ``max(|x1/u|, |x2/u|) (2 pi f)^2`` (flat for the rigid
body), merged over the FRFs; without one, the model's lightly damped poles. Sensitivity peaks: of ``|S|`` of the
current design on every checked case, the highest first.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from .. import progress
from ..analysis.ballscrew import analyze_case, plant_cases
from ..analysis.cases import PlantCase
from ..control.filters import TWO_PI
from .filter_choice import merge_resonances, resonance_peaks, sensitivity_peaks


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
        r = analyze_case(law, pc, responses=False)  # S is all it reads
        s = np.abs(r.S)
        for f in sensitivity_peaks(r.freq_hz, s, above_hz, n):
            found.append((float(np.interp(f, r.freq_hz, s)), f))
    return [f for _, f in sorted(found, reverse=True)[:n]]


def search_cases(model, fs: float, delay_samples: int, frfs: Sequence, by_gain: bool) -> list[dict]:
    """The plant cases (:func:`~feedtune.analysis.ballscrew.plant_cases`, one dict per FRF, or of the model alone
    when ``frfs`` is empty) every search of a ball-screw tuner shares, made once; names the figure of the running
    :func:`feedtune.progress.search` (``Ki2`` when ``by_gain``, else the first crossover)."""
    progress.figure(*(("Ki2", f"{model.input_unit}/(rad s)") if by_gain else ("first crossover", "Hz")))
    progress.note(f"the plant cases of {len(frfs)} FRF(s), continued above their lines" if frfs else
                  "the plant cases of the model")
    return [plant_cases(model, fs, delay_samples, f) for f in (frfs or [None])]
