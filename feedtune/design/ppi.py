"""P-PI position-velocity cascade of a ball-screw drive (thesis Figure 3.9, eq. 3.25, 3.27).

Velocity PI on the motor side (``x1``), position P on the table (``x2``), velocity feedforward into the
velocity loop and acceleration (inertia and viscous) feedforward ``U_ff = (m1 + m2) s^2 + (b1 + b2) s``
into the command, the same filter pack as MC-PPC::

    u = G_fp (Kpv + Kiv / s) (Kpx (x_r - x2) + s x_r - s x1) + U_ff x_r

It is the shared ball-screw law (:mod:`feedtune.design.ballscrew_law`) with ``Kx1 = Kiv, Kv1 = Kpv,
Kx2 = Kpv Kpx, Kv2 = 0, Ki2 = Kiv Kpx`` and ``R1 = 1``. :func:`tune_ppi` searches the highest-bandwidth
gains whose peak sensitivity stays below a limit in the worst analysis case.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import DesignError, UsageError
from ..frf import Frf
from ..lti import Zpk, delay_response, zoh_response
from ..models.ballscrew import BallScrewModel
from .ballscrew_law import BallScrewLaw
from .discretize import matched
from .filters import FilterPack
from .mcppc import check_sampling

PPI_UNITS = {"Kpx": "1/s", "Kpv": "V/(rad/s)", "Kiv": "V/rad"}


@dataclass(frozen=True)
class PpiDesign:
    """A P-PI cascade design.

    Attributes
    ----------
    model : BallScrewModel
    ppi_gains : dict
        ``Kpx`` [1/s], ``Kpv`` [V/(rad/s)], ``Kiv`` [V/rad].
    filters : FilterPack
    fs : float
        Sample rate [Hz].
    delay_samples : int
        Computational delay [samples].
    tuning : dict
        How the gains were obtained (user, or the search and its limit).
    """

    model: BallScrewModel
    ppi_gains: dict
    filters: FilterPack
    fs: float
    delay_samples: int
    tuning: dict

    kind = "ppi"

    @property
    def gains(self) -> dict:
        """Equivalent gains of the shared law [V/rad, V/rad, V/(rad/s), V/(rad/s), V/(rad s)]."""
        return equivalent_gains(**self.ppi_gains)

    def law(self) -> BallScrewLaw:
        """The implementable control law."""
        return BallScrewLaw(
            self.gains,
            self.filters.zpk(),
            Zpk.constant(1.0),
            acceleration_feedforward(self.model),
            self.fs,
            self.delay_samples,
        )

    def design_dict(self) -> dict:
        """Design parameters with units."""
        return dict(self.tuning)


def equivalent_gains(Kpx: float, Kpv: float, Kiv: float) -> dict:
    """Shared-law gains of a P-PI cascade."""
    return {"Kx1": Kiv, "Kx2": Kpv * Kpx, "Kv1": Kpv, "Kv2": 0.0, "Ki2": Kiv * Kpx}


def acceleration_feedforward(model: BallScrewModel) -> Zpk:
    """``(m1 + m2) s^2 + (b1 + b2) s`` [V/rad]: inertia and viscous-friction feedforward."""
    return Zpk.from_tf([model.total_inertia, model.b1 + model.b2, 0.0], [1.0])


def _check_gains(Kpx: float, Kpv: float, Kiv: float) -> None:
    for name, v in (("--kpx", Kpx), ("--kpv", Kpv), ("--kiv", Kiv)):
        if not (np.isfinite(v) and v >= 0):
            raise UsageError(f"{name} must be a finite gain >= 0, got {v}")
    if Kpv <= 0:
        raise UsageError("--kpv must be > 0")


def design_ppi(
    model: BallScrewModel,
    *,
    Kpx: float,
    Kpv: float,
    Kiv: float,
    filters: FilterPack | None = None,
    fs: float = 20000.0,
    delay_samples: int = 1,
) -> PpiDesign:
    """P-PI with the user's gains ``Kpx`` [1/s], ``Kpv`` [V/(rad/s)], ``Kiv`` [V/rad]."""
    check_sampling(fs, delay_samples)
    _check_gains(Kpx, Kpv, Kiv)
    filters = filters or FilterPack()
    filters.check_nyquist(fs)
    return PpiDesign(
        model,
        {"Kpx": float(Kpx), "Kpv": float(Kpv), "Kiv": float(Kiv)},
        filters,
        float(fs),
        int(delay_samples),
        {"method": "user gains"},
    )


def _candidate_loops(model, filters, fs, delay, frf, f):
    """Plant-and-filter responses of the worst case, precomputed once for the search.

    Returns ``(A11, A21, D, I)`` on ``f`` and the same four on the extension below ``f[0]``
    (:func:`feedtune.analysis.loop.model_extension`: the model, scaled to meet the FRF, down to 1e-5 Hz) so that
    each candidate's Nyquist count does not depend on the lowest line of the grid or of the FRF.
    """
    from ..analysis.ballscrew import zoh_plant
    from ..analysis.loop import model_extension

    def parts(fr, G11, G21, H):
        T = 1.0 / fs
        z1 = np.exp(-2j * np.pi * fr * T)
        Fd = matched(filters.zpk(), fs).tf.freqresp(fr)
        return G11 * H * Fd, G21 * H * Fd, (1 - z1) / T, T / (1 - z1)

    if frf is not None:
        pos = frf.as_quantity("position")

        def on_grid(channel):
            h = pos.channel(channel)
            return np.interp(f, pos.freq_hz, h.real) + 1j * np.interp(f, pos.freq_hz, h.imag)

        G11, G21 = on_grid("x1/u"), on_grid("x2/u")

        def hold(fr):
            return zoh_response(fr, fs) * delay_response(fr, delay, fs)

        def model_plant(fr):
            g = model.frequency_response(fr)
            return np.array([g["G11"], g["G21"]])
    else:
        g = zoh_plant(model, fs, f)
        G11, G21 = g["G11"], g["G21"]

        def hold(fr):
            return delay_response(fr, delay, fs)

        def model_plant(fr):
            g = model.frequency_response(fr)
            return np.array([g["G11"], g["G21"]]) * zoh_response(fr, fs)

    ext = model_extension(f, np.array([G11, G21]), model_plant)
    grid = parts(f, G11, G21, hold(f))
    below = None if ext is None else (ext, parts(ext.freq_hz, ext.L[0], ext.L[1], hold(ext.freq_hz)))
    return grid, below


INTEGRAL_RATIOS = (2.0, 3.0, 4.0, 6.0, 10.0)
POSITION_RATIOS = (2.0, 3.0, 4.0, 6.0, 8.0)
REFINE_POINTS = 12


def tune_ppi(
    model: BallScrewModel,
    *,
    limits=None,
    ms_max: float | None = None,
    pm_min_deg: float | None = None,
    filters: FilterPack | None = None,
    fs: float = 20000.0,
    delay_samples: int = 1,
    frf: Frf | None = None,
) -> PpiDesign:
    """Highest-bandwidth P-PI with ``Ms <= ms_max`` [-] and every |phase margin| >= ``pm_min_deg`` [deg].

    The velocity loop is parametrised by its crossover ``wv``: ``Kpv = (m1 + m2) wv``,
    ``Kiv = Kpv wv / r_i``, ``Kpx = wv / r_p``, over ratios ``r_i`` in (2, 3, 4, 6, 10) and ``r_p`` in
    (2, 3, 4, 6, 8); each candidate is checked with the discrete controller on the measured FRF (when given)
    or the zero-order-hold model, for Nyquist stability and both limits. The candidate with the highest
    first crossover of the position loop wins. ``wv`` runs over 60 log-spaced values from 5 Hz to ``fs/20``;
    past the last feasible value the interval to the first infeasible one is refined with 12 more values,
    so that a binding ``ms_max`` is met closely rather than to the coarse grid's step (9 %).
    """
    from ..analysis.loop import LoopExtension, analyze_loop
    from .check import resolve_limits

    policy = resolve_limits(limits, ms_max=ms_max, pm_min_deg=pm_min_deg)
    ms_max = policy.ms_max if policy.ms_max is not None else np.inf
    pm_min_deg = policy.pm_min_deg or 0.0
    check_sampling(fs, delay_samples)
    filters = filters or FilterPack()
    filters.check_nyquist(fs)
    f_hi = fs / 2 * 0.999 if frf is None else min(fs / 2 * 0.999, float(frf.freq_hz[-1]))
    f_lo = 0.5 if frf is None else max(0.5, float(frf.freq_hz[frf.freq_hz > 0][0]))
    f = np.logspace(np.log10(f_lo), np.log10(f_hi), 3000)
    (A11, A21, D, I), below = _candidate_loops(model, filters, fs, delay_samples, frf, f)
    M = model.total_inertia

    def best_at(wv: float):
        """Best admissible (ri, rp) candidate at velocity crossover ``wv`` [rad/s], or None."""
        found = None
        for ri in INTEGRAL_RATIOS:
            for rp in POSITION_RATIOS:
                Kpv = M * wv
                Kiv, Kpx = Kpv * wv / ri, wv / rp
                g = equivalent_gains(Kpx, Kpv, Kiv)
                L = (g["Kx1"] + g["Kv1"] * D) * A11 + (g["Kx2"] + g["Ki2"] * I) * A21
                ms = float(np.max(np.abs(1 / (1 + L))))
                if ms > ms_max:
                    continue
                ext = None
                if below is not None:
                    e, (a11, a21, d, i) = below
                    ext = LoopExtension(e.freq_hz, (g["Kx1"] + g["Kv1"] * d) * a11 + (g["Kx2"] + g["Ki2"] * i) * a21,
                                        e.scale, e.junction_hz)
                res = analyze_loop(f, L, extension=ext)
                if res.phase_margin_deg is None or not all(i.ok for i in policy.check(res, "discrete")):
                    continue
                bw = float(res.crossovers_hz[0])
                if found is None or bw > found[0]:
                    found = (bw, Kpx, Kpv, Kiv, ms, ri, rp, wv)
        return found

    best = None
    coarse = 2 * np.pi * np.logspace(np.log10(5.0), np.log10(fs / 20), 60)
    for i, wv in enumerate(coarse):
        cand = best_at(wv)
        if cand is None and best is not None:
            # bandwidth beyond the feasible range: refine between the last feasible and this grid point
            for wf in np.geomspace(coarse[i - 1], wv, REFINE_POINTS + 2)[1:-1]:
                cand = best_at(wf)
                if cand is not None and cand[0] > best[0]:
                    best = cand
            break
        if cand is not None and (best is None or cand[0] > best[0]):
            best = cand
    if best is None:
        raise DesignError(
            f"no P-PI gains reach Ms <= {ms_max:g} with phase margins >= {pm_min_deg:g} deg; "
            "relax --ms-max/--pm-min or adjust the filter pack"
        )
    bw, Kpx, Kpv, Kiv, ms, ri, rp, wv = best
    tuning = {
        "method": "highest bandwidth with Ms and phase-margin limits",
        "ms_max": float(ms_max),
        "pm_min_deg": float(pm_min_deg),
        "ms_found": ms,
        "velocity_crossover_hz": float(wv / (2 * np.pi)),
        "first_crossover_hz": bw,
        "integral_ratio": ri,
        "position_ratio": rp,
        "checked_case": "discrete" if frf is not None else "ideal_discrete",
    }
    return PpiDesign(
        model, {"Kpx": float(Kpx), "Kpv": float(Kpv), "Kiv": float(Kiv)}, filters, float(fs), int(delay_samples), tuning
    )
