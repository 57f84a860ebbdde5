"""The high-frequency roll-off a plant model lacks, identified from the top of a measured band.

A physical model (2-mass ball screw, gantry, rigid body) describes the mechanics; a measured FRF also holds what
sits between the command and the mechanics: the current loop or amplifier (a low-pass) and delays (the drive's
computation, the measurement chain). Above the band an FRF shows, only these decide where the loop goes, so the loop
there is continued with ``G(s) = R(s) M(s)``: the model ``M`` times the roll-off ``R`` fitted to the ratio of the
measured plant to the model over the top of the band (:func:`fit_rolloff`)::

    R(s) = c exp(-s tau) P(s)

with ``c`` a complex factor [-] (what the model misses in gain and phase at the junction), ``tau`` a delay [s] and
``P`` one of

* ``delay``: ``P = 1``;
* ``pole``: ``P = 1 / (1 + s / w1)`` (a first-order current loop or amplifier);
* ``two_poles``: ``P = 1 / ((1 + s / w1) (1 + s / w2))``;
* ``second_order``: ``P = wn^2 / (s^2 + 2 zeta wn s + wn^2)``, ``zeta >= MIN_DAMPING``,

chosen by the data: each structure is fitted by nonlinear least squares to the log magnitude and the phase of the
ratio, the residuals weighted by the inverse of each line's relative scatter and taken through a Cauchy loss
(``rho(z) = ln(1 + z^2)``, scale one scatter): a lightly damped mode the model lacks (a torsional mode in the top
octave) is an outlier to a roll-off, not a part of it, and is weighed down instead of bending the roll-off around
it. The structure with the lowest Bayesian information criterion of the robust cost, ``BIC = n ln(C / n) + k ln n``
(``n`` residuals, ``k`` parameters), wins. The standard deviations come from the (loss-weighted) Jacobian at the
optimum, ``cov = (J^T J)^-1 C / (n - k)``. A fit over a band that shows no roll-off gives a delay near 0 and poles
far above it: the extension then follows the model, and says so.

On the example FRF of the m2 x 1.3 machine (Table 3.1, torsional modes at 440 and 1100 Hz, a 450 Hz current loop;
the fit band 1000-2000 Hz holds the 1100 Hz mode) the continuation from the true model is within 6 % and 10 deg of
the true plant at 3-10 kHz (``tests/test_band_edge.py``); a plain least-squares fit bends into a second-order
roll-off at the mode and is 7 times too small at 10 kHz.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

STRUCTURES = ("delay", "pole", "two_poles", "second_order")
"""The roll-off structures :func:`fit_rolloff` chooses from."""
MIN_LINES = 6
"""Fewer lines than this in the fitted band: no roll-off is fitted (the extension is the model, scaled)."""
MIN_DAMPING = 0.5
"""Smallest damping of the ``second_order`` roll-off [-]: a roll-off, not a resonance (at most 1.25 dB of peak). A
lightly damped mode above the band is not something the top of the band can show; a fit free to place one there
puts poles where no line was measured (on the two-mass bench's 125-250 Hz octave: a resonance near 850 Hz that made
a hand-tuned P-PI unstable)."""
TOP_OCTAVES = 1.0
"""Width of the fitted band below the top of the trusted band [octaves] (at least :data:`MIN_LINES` lines)."""
_PARAMS = {"delay": (), "pole": ("pole_hz",), "two_poles": ("pole_hz", "pole2_hz"),
           "second_order": ("natural_hz", "damping")}


@dataclass(frozen=True)
class Rolloff:
    """``R(s) = c exp(-s tau) P(s)`` of the module docstring.

    Attributes
    ----------
    structure : str
        One of :data:`STRUCTURES`, ``"scale"`` when too few lines gave only a factor (``R = c``), or ``"none"``
        when nothing was continued (``R = 1``).
    gain : complex
        ``c`` [-].
    delay_s : float
        ``tau`` [s].
    params : dict
        ``pole_hz``, ``pole2_hz`` [Hz] or ``natural_hz`` [Hz] and ``damping`` [-], by structure.
    std : dict
        Standard deviation of each fitted parameter (``delay_s`` [s] and the keys of ``params``).
    band_hz : (float, float)
        The band it was fitted on [Hz].
    rms_db, rms_deg : float
        Residual of the fit over the band: magnitude [dB] and phase [deg], rms.
    bic : dict
        The BIC of every structure tried (the lowest was chosen).
    """

    structure: str
    gain: complex
    delay_s: float
    params: dict = field(default_factory=dict)
    std: dict = field(default_factory=dict)
    band_hz: tuple = (math.nan, math.nan)
    rms_db: float = math.nan
    rms_deg: float = math.nan
    bic: dict = field(default_factory=dict)

    def response(self, freq_hz) -> np.ndarray:
        """``R(j 2 pi f)`` [-] on ``freq_hz`` [Hz]."""
        return _response(self.structure, self.gain, self.delay_s, self.params, np.asarray(freq_hz, float))

    def describe(self) -> str:
        """One line: the structure with its parameters and their standard deviations, and the band."""
        def pm(key, value, unit, scale=1.0, fmt=".3g"):
            s = self.std.get(key)
            err = "" if s is None or not np.isfinite(s) else f" +- {s * scale:{fmt}}"
            return f"{value * scale:{fmt}}{err} {unit}".strip()

        lo, hi = self.band_hz
        parts = [f"delay {pm('delay_s', self.delay_s, 'us', 1e6)}"]
        p = self.params
        if self.structure == "pole":
            parts.append(f"a real pole at {pm('pole_hz', p['pole_hz'], 'Hz')}")
        elif self.structure == "two_poles":
            parts.append(f"real poles at {pm('pole_hz', p['pole_hz'], 'Hz')} and {pm('pole2_hz', p['pole2_hz'], 'Hz')}")
        elif self.structure == "second_order":
            parts.append(f"a second-order roll-off at {pm('natural_hz', p['natural_hz'], 'Hz')}, damping "
                         f"{pm('damping', p['damping'], '')}")
        elif self.structure == "none":
            return "not continued"
        elif self.structure == "scale":
            phase = math.degrees(float(np.angle(self.gain)))
            return (f"the model scaled by {abs(self.gain):.3g} ({phase:+.0f} deg): too few lines to fit a roll-off "
                    f"at {lo:.4g}-{hi:.4g} Hz")
        return (f"the model times {' and '.join(parts)} (fitted at {lo:.4g}-{hi:.4g} Hz, residual "
                f"{self.rms_db:.2g} dB / {self.rms_deg:.2g} deg rms)")

    def to_dict(self) -> dict:
        """JSON-ready dict (units in the keys)."""
        return {"structure": self.structure, "gain": abs(self.gain),
                "gain_phase_deg": math.degrees(float(np.angle(self.gain))), "delay_s": float(self.delay_s),
                **{k: float(v) for k, v in self.params.items()},
                "std": {k: float(v) for k, v in self.std.items()},
                "band_hz": [float(x) for x in self.band_hz], "rms_db": float(self.rms_db),
                "rms_deg": float(self.rms_deg), "bic": {k: float(v) for k, v in self.bic.items()}}


def _response(structure: str, gain: complex, delay_s: float, params: dict, f: np.ndarray) -> np.ndarray:
    s = 2j * np.pi * f
    out = gain * np.exp(-s * delay_s)
    if structure == "pole":
        out = out / (1 + s / (2 * np.pi * params["pole_hz"]))
    elif structure == "two_poles":
        out = out / ((1 + s / (2 * np.pi * params["pole_hz"])) * (1 + s / (2 * np.pi * params["pole2_hz"])))
    elif structure == "second_order":
        wn = 2 * np.pi * params["natural_hz"]
        out = out * wn**2 / (s**2 + 2 * params["damping"] * wn * s + wn**2)
    return out


def fitted_band(freq_hz: np.ndarray, top_hz: float) -> np.ndarray:
    """Boolean mask of the lines :func:`fit_rolloff` uses: the top :data:`TOP_OCTAVES` octaves up to ``top_hz``
    [Hz], at least :data:`MIN_LINES` lines (the highest ones) when the grid has them."""
    f = np.asarray(freq_hz, float)
    under = f <= top_hz
    sel = under & (f >= top_hz / 2.0**TOP_OCTAVES)
    if sel.sum() < MIN_LINES:
        idx = np.flatnonzero(under)[-MIN_LINES:]
        sel = np.zeros(f.size, bool)
        sel[idx] = True
    return sel


def fit_rolloff(freq_hz: np.ndarray, ratio: np.ndarray, sigma_rel: np.ndarray | None = None) -> Rolloff:
    """The roll-off of the module docstring fitted to ``ratio`` = measured plant / model [-] on ``freq_hz`` [Hz].

    Parameters
    ----------
    freq_hz : ndarray, shape (n,)
        The lines of the band to fit [Hz], increasing.
    ratio : ndarray, shape (n,)
        The ratio on them (channels already combined) [-].
    sigma_rel : ndarray, shape (n,), optional
        1-sigma relative scatter of each line [-] (default: equal weights).
    """
    from scipy.optimize import least_squares

    f = np.asarray(freq_hz, float)
    r = np.asarray(ratio, complex)
    ok = np.isfinite(r) & (np.abs(r) > 0) & np.isfinite(f) & (f > 0)
    f, r = f[ok], r[ok]
    band = (float(f[0]), float(f[-1])) if f.size else (math.nan, math.nan)
    if f.size < MIN_LINES:
        gain = complex(np.mean(r)) if r.size else 1.0 + 0j
        return Rolloff("scale", gain, 0.0, band_hz=band)
    w = 1.0 / np.maximum(np.ones(f.size) if sigma_rel is None else np.asarray(sigma_rel, float)[ok], 1e-4)
    lr = np.log(r)
    om = 2 * np.pi * f
    ph = np.unwrap(np.angle(r))
    slope = np.polyfit(om, ph, 1)[0] if f.size > 1 else 0.0
    tau0 = max(-slope, 0.0)
    lo_hz, hi_hz = band
    tau_max = max(4.0 / (2 * np.pi * lo_hz), 10 * tau0, 1e-6)

    def unpack(structure, p):
        params = {}
        if structure == "pole":
            params = {"pole_hz": math.exp(p[3])}
        elif structure == "two_poles":
            params = {"pole_hz": math.exp(p[3]), "pole2_hz": math.exp(p[4])}
        elif structure == "second_order":
            params = {"natural_hz": math.exp(p[3]), "damping": p[4]}
        return complex(math.exp(min(p[0], 700.0)) * np.exp(1j * p[1])), float(p[2]), params

    def residual(p, structure):
        gain, tau, params = unpack(structure, p)
        d = lr - np.log(_response(structure, gain, tau, params, f))
        d = d.real + 1j * np.angle(np.exp(1j * d.imag))
        return np.concatenate([w * d.real, w * d.imag])

    n = 2 * f.size
    base = [float(np.log(np.abs(r[-1]))), float(np.angle(r[-1] * np.exp(1j * om[-1] * tau0))), tau0]
    lf_lo, lf_hi = math.log(lo_hz / 10), math.log(hi_hz * 100)
    starts = {"delay": [base],
              "pole": [[*base, math.log(x)] for x in (hi_hz / 2, hi_hz, 3 * hi_hz)],
              "two_poles": [[*base, math.log(x), math.log(y)] for x, y in ((hi_hz, 3 * hi_hz), (hi_hz / 2, 2 * hi_hz))],
              "second_order": [[*base, math.log(x), z] for x in (hi_hz, 2 * hi_hz) for z in (MIN_DAMPING, 0.7)]}
    g_lo, g_hi = base[0] - 20.0, base[0] + 20.0
    bounds = {"delay": ([g_lo, -4 * np.pi, 0.0], [g_hi, 4 * np.pi, tau_max]),
              "pole": ([g_lo, -4 * np.pi, 0.0, lf_lo], [g_hi, 4 * np.pi, tau_max, lf_hi]),
              "two_poles": ([g_lo, -4 * np.pi, 0.0, lf_lo, lf_lo], [g_hi, 4 * np.pi, tau_max, lf_hi, lf_hi]),
              "second_order": ([g_lo, -4 * np.pi, 0.0, lf_lo, MIN_DAMPING], [g_hi, 4 * np.pi, tau_max, lf_hi, 2.0])}
    fits = {}
    for structure in STRUCTURES:
        k = 3 + len(_PARAMS[structure])
        if n - k < 2:
            continue
        best = None
        for p0 in starts[structure]:
            lo_b, hi_b = (np.asarray(b, float) for b in bounds[structure])
            inside = np.where(np.isfinite(lo_b), lo_b, -1e300) + 1e-9, np.where(np.isfinite(hi_b), hi_b, 1e300) - 1e-9
            p0 = np.clip(np.asarray(p0, float), *inside)
            try:
                sol = least_squares(residual, p0, bounds=(lo_b, hi_b), args=(structure,), method="trf",
                                    x_scale="jac", max_nfev=400, loss="cauchy", f_scale=1.0)
            except (ValueError, FloatingPointError, np.linalg.LinAlgError):
                continue
            if best is None or sol.cost < best.cost:
                best = sol
        if best is None:
            continue
        rss = max(2 * best.cost, 1e-300)
        fits[structure] = (best, rss, n * math.log(rss / n) + k * math.log(n), k)
    if not fits:
        return Rolloff("scale", complex(np.mean(r)), 0.0, band_hz=band)
    structure = min(fits, key=lambda s: fits[s][2])
    sol, rss, _, k = fits[structure]
    gain, tau, params = unpack(structure, sol.x)
    std = _std(sol.jac, rss, n, k)
    names = ["delay_s", *_PARAMS[structure]]
    stds = {}
    for name, i in zip(names, range(2, k), strict=True):
        s = std[i]
        if name in ("pole_hz", "pole2_hz", "natural_hz"):  # fitted as a log: the std of the value
            s = s * params[name]
        stds[name] = float(s)
    if structure == "two_poles" and params["pole2_hz"] < params["pole_hz"]:
        params = {"pole_hz": params["pole2_hz"], "pole2_hz": params["pole_hz"]}
        stds = {"delay_s": stds["delay_s"], "pole_hz": stds["pole2_hz"], "pole2_hz": stds["pole_hz"]}
    d = lr - np.log(_response(structure, gain, tau, params, f))
    rms_db = float(np.sqrt(np.mean((20 / np.log(10) * d.real) ** 2)))
    rms_deg = float(np.sqrt(np.mean(np.degrees(np.angle(np.exp(1j * d.imag))) ** 2)))
    return Rolloff(structure, gain, tau, params, stds, band, rms_db, rms_deg, {s: v[2] for s, v in fits.items()})


def _std(jac: np.ndarray, rss: float, n: int, k: int) -> np.ndarray:
    """Standard deviations of the parameters from the Jacobian of the weighted residuals (nan where undetermined)."""
    try:
        cov = np.linalg.pinv(jac.T @ jac) * rss / max(n - k, 1)
        return np.sqrt(np.maximum(np.diag(cov), 0.0))
    except np.linalg.LinAlgError:
        return np.full(jac.shape[1], np.nan)






















