"""What the gantry tuners (MIMO, PID; the x axis too) share: the table position of each FRF, a schedule that covers
them, the rule by which a candidate's verdict on a band-limited FRF is not trusted, the resonances and sensitivity
peaks their own filters are placed at, and their objective (no compliance cap)."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..analysis.gantry import plant_at_top
from ..analysis.mimo import matmul, sensitivity, singular_values
from ..control.filters import TWO_PI
from ..design.gantry_mimo import default_x_grid
from ..errors import UsageError
from ..frf import Frf
from ..models.gantry import GantryModel
from .filter_choice import resonance_peaks, sensitivity_peaks
from .search import Objective, band_top_doubt, unreliable


def frf_positions(frfs: Sequence[Frf], positions, x: float) -> list[float]:
    """The table position [m] of each FRF: ``positions`` when given (one per FRF), else each FRF's recorded
    position (:attr:`~feedtune.frf.Frf.position_m`), else ``x`` for a single FRF.

    Raises
    ------
    UsageError
        ``positions`` of the wrong length, or several FRFs of which one records no position.
    """
    if positions is not None:
        xs = [float(v) for v in positions]
        if len(xs) != len(frfs):
            raise UsageError(f"give one table position per FRF: {len(frfs)} FRF(s), {len(xs)} position(s)")
        return xs
    xs = [f.position_m for f in frfs]
    if len(frfs) > 1 and any(v is None for v in xs):
        missing = next(f.source for f, v in zip(frfs, xs, strict=True) if v is None)
        raise UsageError(f"{missing}: the FRF records no table position (x_m); give one position per FRF "
                         "(positions=)", parameter="positions")
    return [x if v is None else v for v in xs]


def schedule_grid(model: GantryModel, xs: Sequence[float], x_grid=None):
    """The schedule grid [m]: ``x_grid`` when given, else the default grid widened to cover every position of
    ``xs`` (the law at an FRF's position is the one the target runs there, not a clamped one)."""
    if x_grid is not None or not xs:
        return x_grid
    return default_x_grid(model, min(-0.3, min(xs)), max(0.3, max(xs)))


def untrusted(metrics, freq_hz: np.ndarray, fs: float, sigma_l_top: float, ms_max: float | None) -> str | None:
    """Why the analysis' verdict on a candidate cannot be relied on, or None.

    The tuner accepts no candidate whose Nyquist count the analysis calls unreliable
    (:func:`~feedtune.tune.search.unreliable`), nor on a band-limited FRF one whose loop is still large at the last
    line (:func:`~feedtune.tune.search.band_top_doubt`). On the gantry twin's 2-1000 Hz FRF an unfiltered PID tuned
    to Ms 2.5 without these rules crossed over at 336 Hz with a winding of -0.49 and ``sigma_max(S)`` still rising at
    1000 Hz; on the twin's analytic FRF to 7.5 kHz its Ms is 3.0 (at 1.28 kHz).
    """
    return unreliable(metrics.warnings) or band_top_doubt(sigma_l_top, float(freq_hz[-1]), fs, ms_max)


def top_line_doubt(law, pc, metrics, policy, fs: float) -> str | None:
    """:func:`untrusted` for a law on a plant case: ``sigma_max(L)`` at the case's last line from the plant with
    its hold there (:func:`~feedtune.analysis.gantry.plant_at_top`, kept per plant case) and the law's discrete
    response."""
    top = pc.freq_hz[-1:]
    l_top = float(singular_values(matmul(plant_at_top(pc), law.response_discrete(top)))[0][0])
    return untrusted(metrics, pc.freq_hz, fs, l_top, policy.ms_max)


def gantry_resonances(pc, fs: float, n: int = 3, prominence_db: float = 6.0) -> list[tuple[float, float]]:
    """The ``n`` most prominent resonances ``(Hz, damping)`` of a gantry plant case.

    Without an FRF, the model's lightly damped poles below ``0.45 fs``; with one, the peaks of
    ``sigma_max(G) (2 pi f)^2`` (flat for the rigid body) that stand ``prominence_db`` [dB] above their surroundings
    (:func:`feedtune.tune.filter_choice.resonance_peaks`).
    """
    if not pc.measured:
        feats = [(float(f), float(z)) for f, z in np.asarray(pc.features).reshape(-1, 2) if 0 < f < 0.45 * fs]
        return sorted(feats, key=lambda fz: fz[1])[:n]
    f = pc.freq_hz
    return resonance_peaks(f, singular_values(pc.plant(f))[0] * (TWO_PI * f) ** 2, n, prominence_db)


def gantry_sensitivity_peaks(laws_and_cases, above_hz: float, n: int = 2) -> list[float]:
    """The ``n`` highest peaks [Hz] of ``sigma_max(S)`` above ``above_hz`` over ``(law, plant case)`` pairs (the
    law each position runs, on that position's case)."""
    found = []
    for law, pc in laws_and_cases:
        f = pc.freq_hz
        K = law.response_discrete(f) if pc.discrete else law.response(f)
        s = singular_values(sensitivity(matmul(pc.plant(f) * pc.hold(f), K)))[0]
        found.extend((float(np.interp(p, f, s)), p) for p in sensitivity_peaks(f, s, above_hz, n))
    return [p for _, p in sorted(found, reverse=True)[:n]]


def gantry_objective(objective) -> Objective:
    """:meth:`Objective.of` for the gantry and x-axis tuners, which have no axial-mode compliance to cap.

    Raises
    ------
    UsageError
        An unknown objective, or an objective carrying a compliance cap.
    """
    obj = Objective.of(objective)
    if obj.compliance_max is not None:
        raise UsageError("compliance_max caps the ball screw's axial-mode compliance (x2/d2); the gantry and x-axis "
                         "tuners have none", parameter="compliance_max")
    return obj
