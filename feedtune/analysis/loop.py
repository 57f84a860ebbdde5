"""Vectorised SISO loop analysis on a frequency grid: crossovers, margins, sensitivity, Nyquist stability.

All functions take the loop transfer ``L(j w)`` sampled on a strictly increasing grid ``freq_hz`` [Hz]
(positive frequencies). No per-frequency Python loop.

Nyquist criterion with open-loop poles at the origin
----------------------------------------------------
The Nyquist contour runs up the imaginary axis and is indented into the right half plane around ``s = 0``
with radius ``w_min = 2 pi freq_hz[0]``. Along the positive axis the winding of ``1 + L`` is taken from the
unwrapped phase; the mirrored negative axis contributes the same by conjugate symmetry; the indentation
arc, where ``L(s) ~ L(j w_min) (j w_min / s)^n`` with ``n`` the low-frequency slope of ``|L|`` (integer
number of integrators, read from the data), turns ``L`` clockwise by about ``n pi`` from ``conj(L(j w_min))``
to ``L(j w_min)`` (the exact turn that closes the curve is used); the arc at infinity contributes
nothing when ``|L(j w_max)| < 1``. Closed-loop right-half-plane poles ``Z = N_cw + P`` where ``P`` is the
number of open-loop right-half-plane poles.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


def crossings(freq_hz: np.ndarray, y: np.ndarray, level: float = 0.0) -> np.ndarray:
    """Frequencies [Hz] where ``y`` crosses ``level``, linearly interpolated in ``log f``."""
    f = np.asarray(freq_hz, float)
    d = np.asarray(y, float) - level
    idx = np.flatnonzero(np.signbit(d[:-1]) != np.signbit(d[1:]))
    if idx.size == 0:
        return np.empty(0)
    lf = np.log(np.maximum(f, 1e-300))
    frac = d[idx] / (d[idx] - d[idx + 1])
    return np.exp(lf[idx] + frac * (lf[idx + 1] - lf[idx]))


def _interp_complex_at(freq_hz: np.ndarray, h: np.ndarray, f0: np.ndarray) -> np.ndarray:
    lf = np.log(freq_hz)
    mag = np.interp(np.log(f0), lf, np.log(np.abs(h)))
    ph = np.interp(np.log(f0), lf, np.unwrap(np.angle(h)))
    return np.exp(mag + 1j * ph)


@dataclass(frozen=True)
class LoopMetrics:
    """Frequency-domain figures of one loop.

    Attributes
    ----------
    crossovers_hz : list of float
        Every frequency [Hz] where ``|L| = 1``.
    phase_margins_deg : list of float
        Phase margin [deg] at each crossover (``180 + angle L`` wrapped to (-180, 180]).
    phase_margin_deg : float or None
        The one closest to 0 (the crossing nearest to -1 in angle; a crossing with ``L`` near +1 has a
        margin near +-180 deg and is harmless).
    gain_margin_db : float or None
        ``-20 log10 |L|`` [dB] at the phase crossover (``angle L = -180 deg``) closest to 0 dB; negative
        when the gain may only be reduced (conditionally stable loops).
    gain_margins_db, phase_crossovers_hz : list of float
        All gain margins [dB] and the phase-crossover frequencies [Hz].
    ms, ms_freq_hz : float
        Peak sensitivity ``max |S|`` [-] and its frequency [Hz].
    rejection_band_hz : [float, float] or None
        ``[f_low, f_high]`` [Hz]: the band from the grid's first frequency where ``|S| < 1``.
    stable : bool
        Closed-loop stability by the Nyquist criterion.
    nyquist_encirclements : int
        Clockwise encirclements of -1 by ``L`` over the whole contour.
    open_loop_rhp_poles : int
        ``P`` used in the criterion.
    integrators : int
        Open-loop poles at the origin found from the low-frequency slope.
    warnings : list of str
    """

    crossovers_hz: list
    phase_margins_deg: list
    phase_margin_deg: float | None
    gain_margin_db: float | None
    gain_margins_db: list
    phase_crossovers_hz: list
    ms: float
    ms_freq_hz: float
    rejection_band_hz: list | None
    stable: bool
    nyquist_encirclements: int
    open_loop_rhp_poles: int
    integrators: int
    warnings: list = field(default_factory=list)

    def to_dict(self) -> dict:
        """JSON-ready dict (keys carry units)."""
        return {
            "crossovers_hz": [float(x) for x in self.crossovers_hz],
            "phase_margins_deg": [float(x) for x in self.phase_margins_deg],
            "phase_margin_deg": _f(self.phase_margin_deg),
            "gain_margin_db": _f(self.gain_margin_db),
            "gain_margins_db": [float(x) for x in self.gain_margins_db],
            "phase_crossovers_hz": [float(x) for x in self.phase_crossovers_hz],
            "ms": float(self.ms),
            "ms_freq_hz": float(self.ms_freq_hz),
            "rejection_band_hz": None if self.rejection_band_hz is None else [float(x) for x in self.rejection_band_hz],
            "stable": bool(self.stable),
            "nyquist_encirclements": int(self.nyquist_encirclements),
            "open_loop_rhp_poles": int(self.open_loop_rhp_poles),
            "integrators": int(self.integrators),
            "warnings": list(self.warnings),
        }


def _f(x):
    return None if x is None or not np.isfinite(x) else float(x)


def margins(freq_hz: np.ndarray, L: np.ndarray) -> tuple[list, list, list, list]:
    """Crossovers [Hz], phase margins [deg], phase crossovers [Hz] and gain margins [dB] of ``L``."""
    f = np.asarray(freq_hz, float)
    mag_db = 20 * np.log10(np.abs(L))
    wc = merge_noisy_crossings(crossings(f, mag_db, 0.0))
    pm = []
    if wc.size:
        Lc = _interp_complex_at(f, L, wc)
        pm = list(np.rad2deg(np.angle(-Lc)))  # 180 + angle(L) wrapped to (-180, 180]
    # phase crossovers: Im(L) changes sign while Re(L) < 0
    im = L.imag
    idx = np.flatnonzero((np.signbit(im[:-1]) != np.signbit(im[1:])) & (L.real[:-1] + L.real[1:] < 0))
    w180, gm = [], []
    for i in idx:  # loop over sign changes (a handful), not over frequencies
        frac = im[i] / (im[i] - im[i + 1])
        fi = np.exp(np.log(f[i]) + frac * (np.log(f[i + 1]) - np.log(f[i])))
        mag = np.exp(np.log(abs(L[i])) + frac * (np.log(abs(L[i + 1])) - np.log(abs(L[i]))))
        w180.append(float(fi))
        gm.append(float(-20 * np.log10(mag)))
    return list(map(float, wc)), [float(x) for x in pm], w180, gm


def count_integrators(freq_hz: np.ndarray, L: np.ndarray, octaves: float = 1.0) -> int:
    """Number of open-loop poles at the origin from the low-frequency slope of ``|L|`` [-].

    The slope is fitted over the first ``octaves`` of the grid (at least 3 points), so measurement noise on
    single points does not change the count.
    """
    f = np.asarray(freq_hz, float)
    sel = f <= f[0] * 2.0**octaves
    if sel.sum() < 3:
        sel = np.arange(f.size) < min(3, f.size)
    if sel.sum() < 2:
        return 0
    slope = np.polyfit(np.log(f[sel]), np.log(np.abs(L[sel])), 1)[0]
    return max(0, int(np.round(-slope)))


def merge_noisy_crossings(freqs: np.ndarray, rel: float = 0.03) -> np.ndarray:
    """Merge crossings closer than ``rel`` (relative frequency): noise makes one crossing look like several.

    A cluster with an odd number of crossings is one crossing (its first member); an even cluster is a
    touch of the level without a net crossing and is dropped.
    """
    if freqs.size < 2:
        return freqs
    out, cluster = [], [freqs[0]]
    for f in freqs[1:]:  # a handful of crossings
        if f <= cluster[-1] * (1 + rel):
            cluster.append(f)
        else:
            if len(cluster) % 2:
                out.append(cluster[0])
            cluster = [f]
    if len(cluster) % 2:
        out.append(cluster[0])
    return np.array(out)


def nyquist_winding(freq_hz: np.ndarray, L: np.ndarray, integrators: int) -> float:
    """Counter-clockwise winding number of ``1 + L`` around 0 on the indented Nyquist contour."""
    one_plus = 1.0 + L
    ph = np.unwrap(np.angle(one_plus))
    along = ph[-1] - ph[0]  # 0+ -> +inf
    # indentation arc around s = 0 (z = 1) through the unstable region: L turns clockwise by about n*pi from
    # L(-j w0) = conj(L0) to L(+j w0) = L0; the exact turn is the one of that size closing the curve
    L0 = L[0]
    phi0 = float(np.angle(L0))
    k = np.round((-integrators * np.pi - 2 * phi0) / (2 * np.pi))
    turn = 2 * phi0 + 2 * np.pi * k
    arc = 1.0 + np.abs(L0) * np.exp(1j * (-phi0 + turn * np.linspace(0.0, 1.0, 721)))
    arc_ph = np.unwrap(np.angle(arc))
    arc_change = arc_ph[-1] - arc_ph[0]
    # negative frequencies: conjugate branch from -inf to -0 has the same phase change as 0 -> +inf
    total = 2 * along + arc_change
    return total / (2 * np.pi)


def analyze_loop(freq_hz, L, *, open_loop_rhp_poles: int = 0, integrators: int | None = None) -> LoopMetrics:
    """All loop figures of :class:`LoopMetrics` from ``L(j w)`` on a grid [Hz]."""
    f = np.asarray(freq_hz, float)
    L = np.asarray(L, complex)
    warnings = []
    wc, pm, w180, gm = margins(f, L)
    S = 1.0 / (1.0 + L)
    aS = np.abs(S)
    i_ms = int(np.argmax(aS))
    n_int = count_integrators(f, L) if integrators is None else int(integrators)
    if abs(L[0]) < 10 and n_int > 0:
        warnings.append(
            f"|L| is only {abs(L[0]):.3g} at the lowest frequency {f[0]:g} Hz; "
            "the Nyquist count near 0 Hz is less reliable"
        )
    if abs(L[-1]) >= 1:
        warnings.append(
            f"|L| = {abs(L[-1]):.3g} >= 1 at the highest frequency {f[-1]:g} Hz; "
            "extend the frequency grid for a valid Nyquist count"
        )
    winding = nyquist_winding(f, L, n_int)
    n_ccw = int(np.round(winding))
    if abs(winding - n_ccw) > 0.2:
        warnings.append(f"Nyquist winding number {winding:.2f} is not close to an integer; grid too coarse")
    n_cw = -n_ccw
    z = n_cw + int(open_loop_rhp_poles)
    stable = z == 0
    return LoopMetrics(
        wc,
        pm,
        min(pm, key=abs) if pm else None,
        min(gm, key=abs) if gm else None,
        gm,
        w180,
        float(aS[i_ms]),
        float(f[i_ms]),
        rejection_band(f, aS),
        bool(stable),
        n_cw,
        int(open_loop_rhp_poles),
        n_int,
        warnings,
    )


def rejection_band(freq_hz: np.ndarray, abs_s: np.ndarray) -> list | None:
    """``[f_low, f_high]`` [Hz] where ``|S| < 1`` starting at the first grid frequency, or None."""
    if abs_s[0] >= 1:
        return None
    up = crossings(freq_hz, 20 * np.log10(abs_s), 0.0)
    return [float(freq_hz[0]), float(up[0]) if up.size else float(freq_hz[-1])]
