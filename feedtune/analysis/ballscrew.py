"""Frequency-domain analysis of a ball-screw control law (thesis §3.3, eq. 3.24-3.27).

Cases (thesis §3.3):

* ``ideal``: the 2-mass model with the continuous controller.
* ``ideal_discrete``: the model, exactly discretized with a zero-order hold, with the discrete controller and
  the computational delay (a z-domain loop; its Nyquist contour is the unit circle).
* ``measured``: the measured FRF with the continuous controller (null without an FRF).
* ``discrete``: the measured FRF with the discrete controller, the zero-order hold ``(1 - e^{-sT})/(sT)`` and
  the computational delay ``e^{-s d T}`` (null without an FRF).

Loop (eq. 3.24/3.25): ``L = K1 G11 + K2 G21``. Disturbance ``d2 -> x2`` (eq. 3.26/3.27):
``(G23 + K1 (G11 G23 - G13 G21)) / (1 + L)`` [rad/V], on the model cases. Tracking ``x_r -> x2``:
``G21 (U_ff + K1 R1 + K2) / (1 + L)`` with feedforward, ``G21 (K1 + K2) / (1 + L)`` without.

Nyquist counts: each case extends its loop below its grid with the model
(:func:`feedtune.analysis.loop.model_extension`, from 1e-5 Hz, below the model's real pole near 0.07 Hz where
``G ~ 1/(b s)``): the model in ``ideal``, the continuous model times the hold ``(1 - e^{-sT})/(sT)`` in
``ideal_discrete``, and in ``measured``/``discrete`` the model scaled by one complex factor fitted to the
FRF's ``x1/u`` and ``x2/u`` over its first octave, with the case's hold, delay and controller.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..design.ballscrew_law import BallScrewLaw
from ..errors import DataError
from ..frf import Frf
from ..lti import Zpk, delay_response, zoh_response
from ..models.ballscrew import BallScrewModel
from .loop import LoopMetrics, analyze_loop, model_extension

CASES = ("ideal", "ideal_discrete", "measured", "discrete")


@dataclass(frozen=True)
class CaseResponse:
    """Responses and figures of one analysis case.

    Attributes
    ----------
    name : str
    freq_hz : ndarray
        Grid [Hz].
    L, S : ndarray
        Loop and sensitivity [-].
    tracking, tracking_no_ff : ndarray
        ``x2 / x_r`` with and without feedforward [-].
    disturbance : ndarray or None
        ``x2 / d2`` [rad/V] (model cases only).
    metrics : LoopMetrics
    """

    name: str
    freq_hz: np.ndarray
    L: np.ndarray
    S: np.ndarray
    tracking: np.ndarray
    tracking_no_ff: np.ndarray
    disturbance: np.ndarray | None
    metrics: LoopMetrics

    def disturbance_min_real(self) -> tuple[float, float] | tuple[None, None]:
        """Most negative real part of ``x2/d2`` [rad/V] and its frequency [Hz] (chatter indicator)."""
        if self.disturbance is None:
            return None, None
        i = int(np.argmin(self.disturbance.real))
        return float(self.disturbance.real[i]), float(self.freq_hz[i])

    def tracking_bandwidth_hz(self, tol_db: float = 3.0) -> float | None:
        """First frequency [Hz] where ``|x2/x_r|`` leaves ``0 +- tol_db`` dB."""
        dev = np.abs(20 * np.log10(np.abs(self.tracking))) > tol_db
        return float(self.freq_hz[np.argmax(dev)]) if dev.any() else None

    def to_dict(self) -> dict:
        """The figures of the ``--json`` output for this case."""
        d = self.metrics.to_dict()
        dmin, dmin_f = self.disturbance_min_real()
        d["disturbance_min_real_rad_per_V"] = dmin
        d["disturbance_min_real_freq_hz"] = dmin_f
        d["tracking_bandwidth_hz"] = self.tracking_bandwidth_hz()
        d["tracking_max_phase_lag_deg_below_100hz"] = _max_lag(self.freq_hz, self.tracking, 100.0)
        return d


def _max_lag(f, t, f_max):
    m = f <= f_max
    return float(-np.min(np.angle(t[m], deg=True))) if m.any() else None


@dataclass(frozen=True)
class BallScrewAnalysis:
    """All analysis cases of a design; ``cases[name]`` is None when the case needs a missing FRF."""

    cases: dict = field(default_factory=dict)

    def to_dict(self) -> dict:
        """``{case: figures or None}``."""
        return {name: (c.to_dict() if c is not None else None) for name, c in self.cases.items()}


def default_grid(fs: float, n: int = 4000) -> np.ndarray:
    """Analysis grid for the model cases [Hz]: 0.5 Hz to just below ``fs/2``, log-spaced (measured cases use
    the FRF's own grid)."""
    return np.logspace(np.log10(0.5), np.log10(fs / 2 * 0.999), n)


def _plant_from_frf(frf: Frf) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    pos = frf.as_quantity("position")
    if not (pos.has("x1/u") and pos.has("x2/u")):
        raise DataError(
            f"{frf.source}: the analysis needs both channels x1/u and x2/u; found {', '.join(frf.channels)}"
        )
    f = pos.freq_hz
    keep = f > 0
    return f[keep], pos.channel("x1/u")[keep], pos.channel("x2/u")[keep]


def _rhp(z: Zpk) -> int:
    if z.dt is None:
        return int(np.sum(z.poles.real > 1e-9))
    return int(np.sum(np.abs(z.poles) > 1 + 1e-9))


def _case(name, f, G11, G21, K1, K2, H, ff, R1, G13=None, G23=None, rhp=0, integrators=None,
          extension=None) -> CaseResponse:
    K1e, K2e = K1 * H, K2 * H
    L = K1e * G11 + K2e * G21
    S = 1.0 / (1.0 + L)
    tracking = G21 * H * (ff + K1 * R1 + K2) * S
    tracking_no_ff = G21 * (K1e + K2e) * S
    dist = None
    if G13 is not None:
        dist = (G23 + K1e * (G11 * G23 - G13 * G21)) * S
    metrics = analyze_loop(f, L, open_loop_rhp_poles=rhp, integrators=integrators, extension=extension)
    return CaseResponse(name, f, L, S, tracking, tracking_no_ff, dist, metrics)


def zoh_plant(model: BallScrewModel, fs: float, freq_hz: np.ndarray) -> dict[str, np.ndarray]:
    """Exact zero-order-hold discretization of the model, evaluated at ``z = exp(j w T)``.

    Returns G11, G13, G21, G23 [rad/V] (disturbance inputs also held, as a sampled-data approximation).
    """
    from scipy.signal import cont2discrete, ss2tf

    A, B, C = model.state_space()
    Ad, Bd, Cd, Dd, _ = cont2discrete((A, B, C, np.zeros((2, 3))), 1.0 / fs, method="zoh")
    z = np.exp(2j * np.pi * np.asarray(freq_hz) / fs)
    out = {}
    for j, inp in ((0, "1"), (2, "3")):
        num, den = ss2tf(Ad, Bd, Cd, Dd, input=j)
        for i, outp in ((0, "G1"), (1, "G2")):
            out[outp + inp] = np.polyval(num[i], z) / np.polyval(den, z)
    return out


def analyze_ballscrew(
    law: BallScrewLaw, model: BallScrewModel, frf: Frf | None = None, freq_hz: np.ndarray | None = None
) -> BallScrewAnalysis:
    """Analyse a ball-screw control law in all cases (see module docstring).

    Parameters
    ----------
    law : BallScrewLaw
    model : BallScrewModel
        The design model (ideal cases).
    frf : Frf, optional
        Measured ``x1/u`` and ``x2/u`` (measured and discrete cases).
    freq_hz : ndarray, optional
        Grid for the model cases [Hz] (default :func:`default_grid`).

    Returns
    -------
    BallScrewAnalysis
    """
    f = default_grid(law.fs) if freq_hz is None else np.asarray(freq_hz, float)
    K1, K2 = law.K1(), law.K2()
    K1d, K2d = law.K1d(), law.K2d()
    paths = law.reference_paths()
    rhp_c = _rhp(K1) + _rhp(K2)
    rhp_d = _rhp(K1d) + _rhp(K2d)
    cases: dict[str, CaseResponse | None] = {}

    def responses(freq: np.ndarray) -> dict[str, np.ndarray]:
        """Every controller response on one grid; s and z are computed once (no repeated exp)."""
        s = 2j * np.pi * freq
        z = np.exp(s / law.fs)
        zP = z ** paths["feedforward"].preview_samples
        return {
            "K1": K1.evaluate(s),
            "K2": K2.evaluate(s),
            "ff": law.feedforward.evaluate(s),
            "R1": law.rotary_reference.evaluate(s),
            "K1d": K1d.evaluate(z),
            "K2d": K2d.evaluate(z),
            "ffd": paths["feedforward"].discrete.evaluate(z) * zP,
            "R1d": paths["rotary"].discrete.evaluate(z) * zP,
        }

    def model_plant(fr: np.ndarray, zoh: bool = False) -> np.ndarray:
        """``[G11, G21]`` of the model [rad/V], shape ``(2, n)`` (times the hold when ``zoh``)."""
        gm = model.frequency_response(fr)
        return np.array([gm["G11"], gm["G21"]]) * (zoh_response(fr, law.fs) if zoh else 1.0)

    def extension(fr: np.ndarray, G11, G21, discrete: bool, zoh_in_plant: bool = False):
        """The loop below ``fr[0]`` from the model, scaled to meet ``(G11, G21)`` at the junction."""

        def loop(fe, g):
            re = responses(fe)
            if not discrete:
                return re["K1"] * g[0] + re["K2"] * g[1]
            h = delay_response(fe, law.delay_samples, law.fs) * (1.0 if zoh_in_plant else zoh_response(fe, law.fs))
            return h * (re["K1d"] * g[0] + re["K2d"] * g[1])

        return model_extension(fr, np.array([G11, G21]), lambda fe: model_plant(fe, zoh_in_plant), loop)

    g = model.frequency_response(f)
    r = responses(f)
    cases["ideal"] = _case(
        "ideal", f, g["G11"], g["G21"], r["K1"], r["K2"], 1.0, r["ff"], r["R1"], g["G13"], g["G23"], rhp_c,
        extension=extension(f, g["G11"], g["G21"], False),
    )
    fd = np.r_[f[f < law.fs / 2], law.fs / 2]  # the z-domain contour closes at the Nyquist frequency
    gd = zoh_plant(model, law.fs, fd)
    rd = responses(fd)
    Hd = delay_response(fd, law.delay_samples, law.fs)
    cases["ideal_discrete"] = _case(
        "ideal_discrete",
        fd,
        gd["G11"],
        gd["G21"],
        rd["K1d"],
        rd["K2d"],
        Hd,
        rd["ffd"],
        rd["R1d"],
        gd["G13"],
        gd["G23"],
        rhp_d,
        extension=extension(fd, gd["G11"], gd["G21"], True, zoh_in_plant=True),
    )
    if frf is None:
        cases["measured"] = cases["discrete"] = None
    else:
        fm, G11m, G21m = _plant_from_frf(frf)
        rm = r if np.array_equal(fm, f) else responses(fm)
        cases["measured"] = _case("measured", fm, G11m, G21m, rm["K1"], rm["K2"], 1.0, rm["ff"], rm["R1"], rhp=rhp_c,
                                  extension=extension(fm, G11m, G21m, False))
        H = zoh_response(fm, law.fs) * delay_response(fm, law.delay_samples, law.fs)
        cases["discrete"] = _case("discrete", fm, G11m, G21m, rm["K1d"], rm["K2d"], H, rm["ffd"], rm["R1d"], rhp=rhp_d,
                                  extension=extension(fm, G11m, G21m, True))
    return BallScrewAnalysis(cases)


def closed_loop_poles(law: BallScrewLaw, model: BallScrewModel) -> np.ndarray:
    """Poles [rad/s] of the continuous closed loop including the filter pack (roots of ``1 + L``).

    Characteristic polynomial ``s D_fp d + N_fp (s P1 n11 + P2 n21)`` with ``K1 = G_fp P1``,
    ``K2 = G_fp P2 / s``, evaluated in the scaled variable ``s / w0`` for accuracy.
    """
    nfp, dfp = law.filter_pack.to_tf()
    g = law.gains
    p1 = np.array([g["Kv1"], g["Kx1"]])
    p2 = np.array([g["Kv2"], g["Kx2"], g["Ki2"]])
    nums = model.numerators()
    d = model.denominator()
    w0 = float(np.sqrt(model.k * model.total_inertia / (model.m1 * model.m2)))

    def sc(p):  # p(s) -> p(w0 sigma), descending coefficients
        p = np.atleast_1d(np.asarray(p, float))
        return p * w0 ** np.arange(p.size - 1, -1, -1)

    s = sc([1.0, 0.0])
    feedback = np.polyadd(np.polymul(np.polymul(s, sc(p1)), sc(nums["G11"])), np.polymul(sc(p2), sc(nums["G21"])))
    char = np.polyadd(np.polymul(np.polymul(s, sc(dfp)), sc(d)), np.polymul(sc(nfp), feedback))
    return np.roots(char) * w0
