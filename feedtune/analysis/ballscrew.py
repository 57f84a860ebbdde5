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

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from ..blas import blas_single_threaded
from ..control.ballscrew_law import BallScrewLaw
from ..errors import DataError
from ..frf import Frf
from ..lti import Zpk
from ..models.ballscrew import BallScrewModel
from .cases import PlantCase, measured_cases, model_cases
from .loop import LoopMetrics, analyze_loop, model_extension
from .resolution import lightly_damped


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


def _plant_from_frf(frf: Frf) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray | None]:
    """Lines [Hz], ``x1/u`` and ``x2/u`` [rad/V] and their coherence (None when not measured) of a measured FRF."""
    pos = frf.as_quantity("position")
    if not (pos.has("x1/u") and pos.has("x2/u")):
        raise DataError(
            f"{frf.source}: the analysis needs both channels x1/u and x2/u; found {', '.join(frf.channels)}"
        )
    f = pos.freq_hz
    keep = f > 0
    coh = None
    if pos.coherence is not None:
        c = np.array([pos.channel_coherence("x1/u")[keep], pos.channel_coherence("x2/u")[keep]])
        coh = c if np.all(np.isfinite(c)) else None
    return f[keep], pos.channel("x1/u")[keep], pos.channel("x2/u")[keep], coh


def _rhp(z: Zpk) -> int:
    if z.dt is None:
        return int(np.sum(z.poles.real > 1e-9))
    return int(np.sum(np.abs(z.poles) > 1 + 1e-9))


def zoh_plant(model: BallScrewModel, fs: float, freq_hz: np.ndarray) -> dict[str, np.ndarray]:
    """Exact zero-order-hold discretization of the model, evaluated at ``z = exp(j w T)``.

    Returns G11, G13, G21, G23 [rad/V] (disturbance inputs also held, as a sampled-data approximation).
    """
    return _zoh_tf(model, fs)(freq_hz)


@blas_single_threaded
def _zoh_tf(model: BallScrewModel, fs: float):
    """A function evaluating :func:`zoh_plant` on any grid (the discretization computed once)."""
    from scipy.signal import cont2discrete, ss2tf

    A, B, C = model.state_space()
    Ad, Bd, Cd, Dd, _ = cont2discrete((A, B, C, np.zeros((2, 3))), 1.0 / fs, method="zoh")
    polys = {}
    for j, inp in ((0, "1"), (2, "3")):
        num, den = ss2tf(Ad, Bd, Cd, Dd, input=j)
        for i, outp in ((0, "G1"), (1, "G2")):
            polys[outp + inp] = (num[i], den)

    def evaluate(freq_hz, keys=None) -> dict[str, np.ndarray]:
        z = np.exp(2j * np.pi * np.asarray(freq_hz, float) / fs)
        with np.errstate(divide="ignore", invalid="ignore"):
            inv_den = 1.0 / np.polyval(den, z)  # one denominator (ss2tf of one system)
        return {k: np.polyval(polys[k][0], z) * inv_den for k in (polys if keys is None else keys)}

    return evaluate


# ------------------------------------------------------------------------------------------- plant cases
def plant_cases(model: BallScrewModel, fs: float, delay_samples: float, frf: Frf | None = None,
                freq_hz: np.ndarray | None = None) -> dict[str, PlantCase | None]:
    """The four :class:`~feedtune.analysis.cases.PlantCase` of the module docstring; the plant is ``[G11, G21]``
    [rad/V] (shape ``(2, n)``), the model cases' disturbance ``[G13, G23]`` [rad/V]; ``measured``/``discrete`` are
    None without an FRF.

    Parameters
    ----------
    model : BallScrewModel
    fs : float
        Controller sample rate [Hz].
    delay_samples : float
        Computational delay [samples].
    frf : Frf, optional
        Measured ``x1/u``, ``x2/u`` [rad/V].
    freq_hz : ndarray, optional
        Base grid of the model cases [Hz] (default :func:`default_grid`).
    """
    f = default_grid(fs) if freq_hz is None else np.asarray(freq_hz, float)
    feats = np.vstack([lightly_damped(model.poles()),
                       *[lightly_damped(np.roots(n)) for n in model.numerators().values() if np.size(n) > 1]])
    zoh_tf = _zoh_tf(model, fs)

    def pick(fn, a, b):
        def out(fr):
            g = fn(fr, (a, b))
            return np.array([g[a], g[b]])

        return out

    cases: dict[str, PlantCase | None] = dict(model_cases(
        f, fs, delay_samples, model_plant=pick(model.frequency_response, "G11", "G21"),
        zoh_plant=pick(zoh_tf, "G11", "G21"), features=feats,
        disturbance=pick(model.frequency_response, "G13", "G23"), zoh_disturbance=pick(zoh_tf, "G13", "G23")))
    if frf is None:
        cases["measured"] = cases["discrete"] = None
        return cases
    fm, G11, G21, coh = _plant_from_frf(frf)
    cases.update(measured_cases(fm, np.array([G11, G21]), fs, delay_samples,
                                model_plant=pick(model.frequency_response, "G11", "G21"), coherence=coh))
    return cases


# ------------------------------------------------------------------------------------------- law side
def feedback_paths(law: BallScrewLaw, discrete: bool) -> tuple[Zpk, Zpk]:
    """``(K1, K2)`` of the law, discrete (``K1d, K2d``) or continuous."""
    return (law.K1d(), law.K2d()) if discrete else (law.K1(), law.K2())


def controller_features(paths: tuple[Zpk, Zpk]) -> np.ndarray:
    """Lightly damped poles and zeros (Hz, damping) of the feedback paths ``(K1, K2)``."""
    return np.vstack([lightly_damped(r, k.dt) for k in paths for r in (k.poles, k.zeros)])


def loop_function(paths: tuple[Zpk, Zpk], pc: PlantCase) -> Callable[[np.ndarray], np.ndarray]:
    """``L(f) = hold (K1 G11 + K2 G21)`` of the feedback paths on a plant case, at any frequency [Hz]."""
    K1, K2 = paths

    def evaluate(fr):
        g = pc.plant(fr)
        return pc.hold(fr) * (K1.freqresp(fr) * g[0] + K2.freqresp(fr) * g[1])

    return evaluate


def analyze_case(law: BallScrewLaw, pc: PlantCase, *, responses: bool = True) -> CaseResponse:
    """One analysis case of a law on a plant case: the figures (refined) and, with ``responses``, the curves on the
    case's base grid (without: ``L`` only, for searches)."""
    f = pc.freq_hz
    paths = feedback_paths(law, pc.discrete)
    K = tuple(k.freqresp(f) for k in paths)
    rhp = _rhp(paths[0]) + _rhp(paths[1])
    g = pc.plant(f)
    H = pc.hold(f)
    L = H * (K[0] * g[0] + K[1] * g[1])

    def ext_loop(fe, ge):
        return pc.hold(fe) * (paths[0].freqresp(fe) * ge[0] + paths[1].freqresp(fe) * ge[1])

    extension = model_extension(f, g, pc.model_plant, ext_loop)
    feats = np.vstack([pc.features, controller_features(paths)])
    metrics = analyze_loop(f, L, evaluate=loop_function(paths, pc), features=feats, open_loop_rhp_poles=rhp,
                           extension=extension, noise_db=pc.noise_db, measured=pc.measured)
    S = 1.0 / (1.0 + L)
    if not responses:
        return CaseResponse(pc.name, f, L, S, None, None, None, metrics)
    ref = law.reference_paths()
    if pc.discrete:
        zP = np.exp(2j * np.pi * f / law.fs) ** ref["feedforward"].preview_samples
        ff, R1 = ref["feedforward"].discrete.freqresp(f) * zP, ref["rotary"].discrete.freqresp(f) * zP
    else:
        ff, R1 = law.feedforward.freqresp(f), law.rotary_reference.freqresp(f)
    tracking = g[1] * H * (ff + K[0] * R1 + K[1]) * S
    tracking_no_ff = g[1] * H * (K[0] + K[1]) * S
    dist = None
    if pc.disturbance is not None:
        d = pc.disturbance(f)  # [G13, G23]
        dist = (d[1] + H * K[0] * (g[0] * d[1] - d[0] * g[1])) * S
    return CaseResponse(pc.name, f, L, S, tracking, tracking_no_ff, dist, metrics)


def analyze_ballscrew(
    law: BallScrewLaw, model: BallScrewModel, frf: Frf | None = None, freq_hz: np.ndarray | None = None
) -> BallScrewAnalysis:
    """Analyse a ball-screw control law in all cases (see module docstring).

    Parameters
    ----------
    law : BallScrewLaw
    model : BallScrewModel
        The design model (ideal cases; the loop below the FRF's band in the measured cases).
    frf : Frf, optional
        Measured ``x1/u`` and ``x2/u`` (measured and discrete cases).
    freq_hz : ndarray, optional
        Grid for the model cases [Hz] (default :func:`default_grid`).

    Returns
    -------
    BallScrewAnalysis
    """
    cases = plant_cases(model, law.fs, law.delay_samples, frf, freq_hz)
    return BallScrewAnalysis({name: None if pc is None else analyze_case(law, pc) for name, pc in cases.items()})


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
