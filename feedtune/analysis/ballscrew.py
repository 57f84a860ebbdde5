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

Evaluation: ``K1 = G_fp P1`` and ``K2 = G_fp P2`` with ``P1 = Kx1 + Kv1 d``, ``P2 = Kx2 + Kv2 d + Ki2 / d`` (``d = s``
or the backward difference), so that a case's loop is ``G_fp`` times five fixed responses weighted by the gains.
:func:`analyze_case` keeps those responses, the extension and the filter pack's response on the plant case (a
tuner's hundreds of laws on the same plant cases pay for them once); :func:`analyze_ballscrew` forms each case's
loop directly, one case after the other, and keeps nothing but the loop: ``S``, the tracking and the disturbance
responses of a :class:`CaseResponse` are computed when first read (from the loop, the law and the plant case's
functions, with the same operations as the loop: the same values as computed with it), so that an analysis whose
curves are not read (a check against limits) costs neither their time nor their memory. The four cases are refined
together, every model, FRF, hold and controller evaluated once per round for all of them
(:func:`feedtune.analysis.loop.analyze_loops`). The exact ZOH model is evaluated as ``N(z) / D(z)`` with its exact
poles (:class:`_SampledModel`), not from expanded polynomials.
"""

from __future__ import annotations

import functools
import itertools
import weakref
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from ..blas import blas_single_threaded
from ..control.ballscrew_law import BallScrewLaw
from ..display import AnalysisDisplay, CaseDisplay
from ..errors import DataError
from ..frf import Frf
from ..frf_quality import averages_of
from ..lti import Zpk
from ..models.ballscrew import BallScrewModel
from .cases import (
    PlantCase,
    analysis_scope,
    imaginary_axis,
    measured_cases,
    model_cases,
    release_shared,
    same_lines,
    unit_circle,
    work_array,
)
from .loop import LoopCase, LoopExtension, LoopMetrics, analyze_loops, extension_grid, junction_scale
from .resolution import lightly_damped


@dataclass(frozen=True, repr=False)
class CaseResponse(CaseDisplay):
    """Responses and figures of one analysis case.

    The loop ``L`` is kept; the other curves are computed from it (and, for tracking and disturbance, from the
    plant and the law on the grid) when first read, then kept: a search or a summary that reads the figures only
    does not pay for them, and an analysis holds one curve per case.

    Attributes
    ----------
    name : str
    freq_hz : ndarray
        Grid [Hz].
    L : ndarray
        Loop [-].
    metrics : LoopMetrics
    S : ndarray
        Sensitivity ``1 / (1 + L)`` [-] (computed on first access).
    tracking, tracking_no_ff : ndarray or None
        ``x2 / x_r`` with and without feedforward [-] (computed on first access; None from a search's
        :func:`analyze_case` without responses).
    disturbance : ndarray or None
        ``x2 / d2`` [rad/V] (model cases only; computed on first access).
    """

    name: str
    freq_hz: np.ndarray
    L: np.ndarray
    metrics: LoopMetrics
    _source: object = field(default=None, repr=False, compare=False)
    """What the tracking and disturbance responses are computed from: None (not asked for), their values
    ``(tracking, tracking_no_ff, disturbance)``, or an object whose ``compute(L, S)`` returns them."""

    @property
    def S(self) -> np.ndarray:
        """Sensitivity ``1 / (1 + L)`` [-]."""
        S = self.__dict__.get("_S")
        if S is None:
            with np.errstate(divide="ignore", invalid="ignore"):
                S = self.__dict__["_S"] = 1.0 / (1.0 + self.L)
        return S

    def _curves(self) -> tuple:
        """``(tracking, tracking_no_ff, disturbance)``, computed once from :attr:`_source`."""
        curves = self.__dict__.get("_curve_values")
        if curves is None:
            src = self._source
            if src is None:
                curves = (None, None, None)
            elif isinstance(src, tuple):
                curves = src
            else:
                curves = tuple(src.compute(self.L, self.S))
            self.__dict__["_curve_values"] = curves
            object.__setattr__(self, "_source", None)  # the plant and law are no longer held
        return curves

    @property
    def tracking(self) -> np.ndarray | None:
        """``x2 / x_r`` with feedforward [-]."""
        return self._curves()[0]

    @property
    def tracking_no_ff(self) -> np.ndarray | None:
        """``x2 / x_r`` without feedforward [-]."""
        return self._curves()[1]

    @property
    def disturbance(self) -> np.ndarray | None:
        """``x2 / d2`` [rad/V] (model cases)."""
        return self._curves()[2]

    def __getstate__(self) -> dict:
        """Pickled with every curve computed (the source of the lazy ones holds functions)."""
        self._curves()
        state = dict(self.__dict__)
        state["_S"] = self.S
        return state

    def __setstate__(self, state: dict) -> None:
        self.__dict__.update(state)

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


@dataclass(frozen=True, repr=False)
class BallScrewAnalysis(AnalysisDisplay):
    """All analysis cases of a design; ``cases[name]`` is None when the case needs a missing FRF."""

    cases: dict = field(default_factory=dict)


def default_grid(fs: float, n: int = 4000) -> np.ndarray:
    """Analysis grid for the model cases [Hz]: 0.5 Hz to just below ``fs/2``, log-spaced (measured cases use
    the FRF's own grid)."""
    return np.logspace(np.log10(0.5), np.log10(fs / 2 * 0.999), n)


def _plant_from_frf(frf: Frf) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """Lines [Hz], ``[x1/u, x2/u]`` [rad/V] (shape ``(2, n)``; rows of the FRF's own array when they are, not a copy)
    and their coherence (None when not measured) of a measured FRF."""
    pos = frf.as_quantity("position")
    if not (pos.has("x1/u") and pos.has("x2/u")):
        raise DataError(
            f"{frf.source}: the analysis needs both channels x1/u and x2/u; found {', '.join(frf.channels)}"
        )
    f = pos.freq_hz
    keep = slice(None) if np.all(f > 0) else f > 0
    (i1, j1), (i2, j2) = pos.index("x1/u"), pos.index("x2/u")
    if isinstance(keep, slice) and (i1, i2) == (0, 1) and j1 == j2:
        plant = pos.response[0:2, j1]
    else:
        plant = np.array([pos.response[i1, j1][keep], pos.response[i2, j2][keep]])
    coh = None
    if pos.coherence is not None:
        c = np.array([pos.channel_coherence("x1/u")[keep], pos.channel_coherence("x2/u")[keep]])
        coh = c if np.all(np.isfinite(c)) else None
    return f[keep], plant, coh


def _rhp(z: Zpk) -> int:
    if z.dt is None:
        return int(np.sum(z.poles.real > 1e-9))
    return int(np.sum(np.abs(z.poles) > 1 + 1e-9))


def zoh_plant(model: BallScrewModel, fs: float, freq_hz: np.ndarray) -> dict[str, np.ndarray]:
    """Exact zero-order-hold discretization of the model, evaluated at ``z = exp(j w T)``.

    Returns G11, G13, G21, G23 [rad/V] (disturbance inputs also held, as a sampled-data approximation).
    """
    return _zoh_tf(model, fs)(freq_hz)


def _horner(coeffs: np.ndarray, x: np.ndarray) -> np.ndarray:
    """``numpy.polyval(coeffs, x)`` (the same operations), in place in one array."""
    out = np.full(x.shape, coeffs[0], complex)
    for c in coeffs[1:]:
        out *= x
        out += c
    return out


class _Rational:
    """Responses ``num_k(x) / den(x)`` sharing one denominator, ``x`` from frequency [Hz] (``s``, or ``z`` at
    ``fs``)."""

    def __init__(self, nums: dict[str, np.ndarray], den: np.ndarray, fs: float | None) -> None:
        self.nums = {k: np.asarray(v, float) for k, v in nums.items()}
        self.den = np.asarray(den, float)
        self.fs = fs

    def _x(self, f: np.ndarray) -> np.ndarray:
        return imaginary_axis(f) if self.fs is None else unit_circle(f, self.fs)

    def _inverse_denominator(self, x: np.ndarray) -> np.ndarray:
        out = _horner(self.den, x)
        with np.errstate(divide="ignore", invalid="ignore"):
            np.divide(1.0, out, out=out)
        return out

    def stacked(self, freq_hz, keys: tuple[str, ...]) -> np.ndarray:
        """The responses ``keys`` as rows of one array (shape ``(len(keys), len(f))``), one denominator for all."""
        x = self._x(np.asarray(freq_hz, float))
        inv_den = self._inverse_denominator(x)
        out = np.empty((len(keys), x.size), complex)
        for row, k in zip(out, keys, strict=True):
            c = self.nums[k]
            row[...] = c[0]
            for ci in c[1:]:
                row *= x
                row += ci
            row *= inv_den
        return out

    def __call__(self, freq_hz, keys=None) -> dict[str, np.ndarray]:
        keys = tuple(self.nums if keys is None else keys)
        return dict(zip(keys, self.stacked(freq_hz, keys), strict=True))

    def pair(self, a: str, b: str) -> Callable[[np.ndarray], np.ndarray]:
        """``f -> [num_a / den, num_b / den]`` (shape ``(2, len(f))``); the function carries ``source`` and ``keys``
        so that an analysis can evaluate several pairs of one model with one denominator."""

        def evaluate(freq_hz):
            return self.stacked(freq_hz, (a, b))

        evaluate.source, evaluate.keys, evaluate.fresh = self, (a, b), True
        return evaluate


@functools.lru_cache(maxsize=16)
def _model_tf(model: BallScrewModel) -> _Rational:
    """The continuous model as :class:`_Rational` (G11, G13, G21, G23 [rad/V])."""
    return _Rational(model.numerators(), model.denominator(), None)


@functools.lru_cache(maxsize=16)
def _model_features(model: BallScrewModel) -> np.ndarray:
    """Lightly damped poles and zeros of the model (Hz, damping)."""
    return np.vstack([lightly_damped(model.poles()),
                      *[lightly_damped(np.roots(n)) for n in model.numerators().values() if np.size(n) > 1]])


class _SampledModel(_Rational):
    """The model discretized exactly with a zero-order hold, as ``N(z) / D(z)`` evaluated at ``z = exp(j w T)``.

    ``D(z) = prod(z - exp(p T))`` over the continuous poles ``p``, the exact poles of the discretization, in product
    form; ``N(z) = D(z) Cd (z I - Ad)^-1 Bd`` is a polynomial of degree ``n - 1``, its coefficients taken from
    ``2 n`` points on the unit circle away from the poles (an exact discrete Fourier transform, perfectly
    conditioned; the state space solved with pivoting there). The expanded polynomials of ``scipy.signal.ss2tf``
    lose up to 1e-5 of the response near the double pole at ``z = 1`` (rigid body and friction pole); this agrees
    with python-control's state-space evaluation of the same ``(Ad, Bd)`` to about 1e-12 (``G11``, ``G21``).
    """

    def __init__(self, model: BallScrewModel, fs: float) -> None:
        from scipy.signal import cont2discrete

        A, B, C = model.state_space()
        Ad, Bd, Cd, _, _ = cont2discrete((A, B, C, np.zeros((C.shape[0], B.shape[1]))), 1.0 / fs, method="zoh")
        n = A.shape[0]
        self.poles = np.exp(model.poles() / fs)
        zk = np.exp(2j * np.pi * (np.arange(2 * n) + 0.5) / (2 * n))
        N = np.array([np.prod(z - self.poles) * (Cd @ np.linalg.solve(z * np.eye(n) - Ad, Bd)) for z in zk])
        c = np.einsum("kij,km->mij", N, np.conj(zk)[:, None] ** np.arange(n)[None, :]) / (2 * n)
        self.nums = {f"G{o + 1}{i + 1}": c[::-1, o, i].real.copy() for o in range(C.shape[0]) for i in (0, 2)}
        self.fs = float(fs)

    def _x(self, f: np.ndarray) -> np.ndarray:
        return unit_circle(f, self.fs)

    def _inverse_denominator(self, z: np.ndarray) -> np.ndarray:
        den = np.ones(z.shape, complex)
        tmp = np.empty(z.shape, complex)
        for p in self.poles:
            np.subtract(z, p, out=tmp)
            den *= tmp
        with np.errstate(divide="ignore", invalid="ignore"):
            np.divide(1.0, den, out=den)
        return den


@functools.lru_cache(maxsize=16)
@blas_single_threaded
def _zoh_tf(model: BallScrewModel, fs: float) -> _SampledModel:
    """A function evaluating :func:`zoh_plant` on any grid (the discretization computed once per model and rate)."""
    return _SampledModel(model, fs)


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
    tf, zoh_tf = _model_tf(model), _zoh_tf(model, fs)
    model_plant = tf.pair("G11", "G21")  # one function object: the analysis evaluates it once for all its cases
    cases: dict[str, PlantCase | None] = dict(model_cases(
        f, fs, delay_samples, model_plant=model_plant, zoh_plant=zoh_tf.pair("G11", "G21"),
        features=_model_features(model), disturbance=tf.pair("G13", "G23"),
        zoh_disturbance=zoh_tf.pair("G13", "G23")))
    if frf is None:
        cases["measured"] = cases["discrete"] = None
        return cases
    fm, plant, coh = _plant_from_frf(frf)
    cases.update(measured_cases(fm, plant, fs, delay_samples, model_plant=model_plant, coherence=coh,
                                averages=averages_of(frf.meta), features=_model_features(model),
                                channels=("x1/u", "x2/u")))
    return cases


# ------------------------------------------------------------------------------------------- law side
def feedback_paths(law: BallScrewLaw, discrete: bool) -> tuple[Zpk, Zpk]:
    """``(K1, K2)`` of the law, discrete (``K1d, K2d``) or continuous."""
    return (law.K1d(), law.K2d()) if discrete else (law.K1(), law.K2())


def loop_function(paths: tuple[Zpk, Zpk], pc: PlantCase) -> Callable[[np.ndarray], np.ndarray]:
    """``L(f) = hold (K1 G11 + K2 G21)`` of the feedback paths on a plant case, at any frequency [Hz]."""
    K1, K2 = paths

    def evaluate(fr):
        g = pc.plant(fr)
        return pc.hold(fr) * (K1.freqresp(fr) * g[0] + K2.freqresp(fr) * g[1])

    return evaluate


_BLOCK = 8
"""Roots multiplied together before one division (as :meth:`feedtune.lti.Zpk.evaluate`)."""


def _zpk_blocked(z: Zpk, n: int) -> bool:
    """:func:`_zpk_at` of ``z`` at ``n`` points takes its own route (else :meth:`~feedtune.lti.Zpk.evaluate`'s)."""
    return n * max(z.zeros.size, z.poles.size, 1) > 4096


def _zpk_at(z: Zpk, x: np.ndarray) -> np.ndarray:
    """``z`` at the complex points ``x``: :meth:`~feedtune.lti.Zpk.evaluate` (roots in blocks of :data:`_BLOCK`, one
    division per block) with two work arrays besides the result."""
    n_roots = max(z.zeros.size, z.poles.size)
    if not _zpk_blocked(z, x.size):
        return z.evaluate(x)
    if n_roots == 0:
        return np.full(x.shape, z.gain, complex)
    den, tmp = work_array(x.size, 0).reshape(x.shape), work_array(x.size, 1).reshape(x.shape)
    out = None
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        # the products start from their first factor (gain times it, 1 times it: the same values as multiplied)
        for k in range(0, n_roots, _BLOCK):
            for r in z.zeros[k:k + _BLOCK]:
                if out is None:
                    out = np.subtract(x, r)
                    out *= z.gain
                else:
                    np.subtract(x, r, out=tmp)
                    out *= tmp
            if out is None:
                out = np.full(x.shape, z.gain, complex)
            poles = z.poles[k:k + _BLOCK]
            if poles.size:
                np.subtract(x, poles[0], out=den)
                for r in poles[1:]:
                    np.subtract(x, r, out=tmp)
                    den *= tmp
                out /= den
    return out


def _zpk_key(z: Zpk) -> tuple:
    return z.zeros.tobytes(), z.poles.tobytes(), z.gain, z.dt


_MATCHED: dict[tuple, Zpk] = {}


def _matched_filter(law: BallScrewLaw) -> Zpk:
    """``law.filter_pack_discrete()``, computed once per filter pack and rate (a tuner changes the gains only)."""
    key = (_zpk_key(law.filter_pack), float(law.fs))
    out = _MATCHED.get(key)
    if out is None:
        if len(_MATCHED) > 64:
            _MATCHED.clear()
        out = _MATCHED[key] = law.filter_pack_discrete()
    return out


class _Controller:
    """The feedback paths of a law as ``K1 = G_fp P1``, ``K2 = G_fp P2`` (:class:`BallScrewLaw`).

    Continuous: ``P1 = Kx1 + Kv1 s``, ``P2 = Kx2 + Kv2 s + Ki2 / s``; discrete: ``s`` is replaced by the backward
    difference ``d = fs (1 - z^-1)`` and ``G_fp`` by its matched discretization. The loop is then
    ``L = H G_fp (Kx1 [H G11] + Kv1 [d H G11] + Kx2 [H G21] + Kv2 [d H G21] + Ki2 [H G21 / d]) / H``: a fixed basis
    of five responses per plant case (:class:`_CaseParts`) weighted by the gains.
    """

    def __init__(self, law: BallScrewLaw, discrete: bool) -> None:
        g = law.gains
        self.discrete = discrete
        self.fs = float(law.fs)
        self.gains = np.array([g["Kx1"], g["Kv1"], g["Kx2"], g["Kv2"], g["Ki2"]], float)
        self.filter = _matched_filter(law) if discrete else law.filter_pack
        self.key = _zpk_key(self.filter)
        self.rhp = 2 * _rhp(self.filter)  # G_fp in K1 and in K2 (the sum of their counts, as the paths give it)
        kx1, kv1, kx2, kv2, ki2 = self.gains
        dt = 1.0 / self.fs if discrete else None
        if discrete:
            fs = self.fs
            p_zeros = [np.roots([kx1 + kv1 * fs, -kv1 * fs]),
                       np.roots([kx2 + kv2 * fs + ki2 / fs, -(kx2 + 2 * kv2 * fs), kv2 * fs])]
        else:
            p_zeros = [np.roots([kv1, kx1]), np.roots([kv2, kx2, ki2])]
        self.features = np.vstack([lightly_damped(self.filter.poles, dt), lightly_damped(self.filter.zeros, dt),
                                   *[lightly_damped(r, dt) for r in p_zeros]])

    def at(self, freq_hz: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(G_fp, P1, P2)`` at frequencies [Hz]."""
        x = _variable(freq_hz, self.fs, self.discrete)
        d, d_inv = _difference(x, self.fs, self.discrete)
        kx1, kv1, kx2, kv2, ki2 = self.gains
        p1 = d * kv1
        p1 += kx1
        p2 = d * kv2
        p2 += kx2
        d_inv *= ki2
        p2 += d_inv
        return _zpk_at(self.filter, x), p1, p2

    def paths(self, freq_hz: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(K1, K2) = (G_fp P1, G_fp P2)`` at frequencies [Hz]: the values of :meth:`at` multiplied out, bit for
        bit, with two arrays besides the results (no ``d`` or ``1 / d`` arrays: their parts are added as they are
        formed)."""
        x = _variable(freq_hz, self.fs, self.discrete)
        kx1, kv1, kx2, kv2, ki2 = self.gains
        gfp = _zpk_at(self.filter, x)
        release_shared(grids=False)  # the filter's work arrays: their memory serves what follows
        inv = np.empty(x.shape)  # the imaginary part of 1 / d (its real part is a constant)
        with np.errstate(divide="ignore", invalid="ignore"):
            if self.discrete:
                fs = self.fs
                p1 = np.conj(x)
                np.subtract(1.0, p1, out=p1)
                p1 *= fs  # d = fs (1 - z^-1)
                p2 = p1 * kv2
                p1 *= kv1
                np.add(x.real, 1.0, out=inv)
                inv /= x.imag
                inv *= -0.5 / fs
                inv_real = 0.5 / fs * ki2
            else:
                p1 = x * kv1
                p2 = x * kv2
                np.divide(-1.0, x.imag, out=inv)
                inv_real = 0.0
            p1 += kx1
            p2 += kx2
            inv *= ki2
            p2.real += inv_real
            p2.imag += inv
        del inv
        p1 *= gfp
        p2 *= gfp
        return p1, p2


_CONTROLLERS: dict[tuple, tuple] = {}


def _controller(law: BallScrewLaw, discrete: bool) -> _Controller:
    """The :class:`_Controller` of a law, made once per law (a tuner analyses each candidate in several cases)."""
    g = law.gains
    check = (tuple(g[k] for k in ("Kx1", "Kv1", "Kx2", "Kv2", "Ki2")), id(law.filter_pack), float(law.fs))
    key = (id(law), bool(discrete))
    hit = _CONTROLLERS.get(key)
    if hit is not None and hit[0]() is law and hit[1] == check:
        return hit[2]
    ctrl = _Controller(law, discrete)
    if len(_CONTROLLERS) >= 32:
        _CONTROLLERS.clear()
    _CONTROLLERS[key] = (weakref.ref(law), check, ctrl)
    return ctrl


def _variable(freq_hz: np.ndarray, fs: float, discrete: bool) -> np.ndarray:
    """``s`` or ``z`` on a grid [Hz] (inside :func:`~feedtune.analysis.cases.analysis_scope` shared: read only)."""
    return unit_circle(freq_hz, fs) if discrete else imaginary_axis(freq_hz)


def _difference(x: np.ndarray, fs: float, discrete: bool) -> tuple[np.ndarray, np.ndarray]:
    """``(d, 1 / d)`` for ``d = s = j w`` or the backward difference ``d = fs (1 - z^-1)`` [1/s] on the unit circle,
    without a complex division: ``1 / (j w) = -j / w`` and ``1 / (1 - z^-1) = 1/2 - (j/2) cot(theta / 2)`` with
    ``cot(theta / 2) = (1 + cos theta) / sin theta`` (``z = exp(j theta)``)."""
    d_inv = np.empty(x.shape, complex)
    with np.errstate(divide="ignore", invalid="ignore"):
        if not discrete:
            d_inv.real = 0.0
            np.divide(-1.0, x.imag, out=d_inv.imag)
            return x, d_inv
        d = np.conj(x)
        np.subtract(1.0, d, out=d)
        d *= fs
        d_inv.real = 0.5 / fs
        np.add(x.real, 1.0, out=d_inv.imag)
        d_inv.imag /= x.imag
        d_inv.imag *= -0.5 / fs
    return d, d_inv


def _combine(gains: np.ndarray, basis: np.ndarray) -> np.ndarray:
    """``sum_k gains[k] basis[k]`` (element-wise, without BLAS: no thread pool for a sum of five arrays)."""
    out = np.zeros(basis.shape[1:], complex)
    tmp = np.empty_like(out)
    for k, b in zip(gains, basis, strict=True):
        if k != 0.0:
            np.multiply(b, k, out=tmp)
            out += tmp
    return out


def _basis(d: tuple[np.ndarray, np.ndarray], Hg: np.ndarray) -> np.ndarray:
    """``[H G11, d H G11, H G21, d H G21, H G21 / d]`` (shape ``(5, n)``) from ``Hg = H [G11, G21]`` and
    ``(d, 1 / d)`` (:func:`_difference`)."""
    d, d_inv = d
    out = np.empty((5, d.size), complex)
    out[0] = Hg[0]
    np.multiply(Hg[0], d, out=out[1])
    out[2] = Hg[1]
    np.multiply(Hg[1], d, out=out[3])
    np.multiply(Hg[1], d_inv, out=out[4])
    return out


def _first_octave(f: np.ndarray) -> int:
    """Number of grid lines [-] in the first octave of the sorted grid ``f`` [Hz]."""
    return int(np.searchsorted(f, f[0] * 2.0, side="right"))


def _same_input(a, b) -> bool:
    """``a`` and ``b`` are the same input: one object, or arrays (floats) of the same type, shape and bits."""
    if a is b:
        return True
    if isinstance(a, np.ndarray) and isinstance(b, np.ndarray):
        return a.dtype == b.dtype and a.shape == b.shape and a.tobytes() == b.tobytes()
    if type(a) is float and type(b) is float:
        return np.float64(a).tobytes() == np.float64(b).tobytes()
    return False


class _Memo:
    """Within one analysis, ``fn(*args)`` computed once for the same function (or bound method) and the same inputs
    (:func:`_same_input`): the cases' extensions below their grids share the model there, the controller and, on the
    same lines, the junction. The values are shared: read only."""

    def __init__(self) -> None:
        self.items: list[tuple] = []

    def __call__(self, fn: Callable, *args):
        for f, a, out in self.items:
            if (f is fn or f == fn) and len(a) == len(args) and all(map(_same_input, a, args)):
                return out
        out = fn(*args)
        self.items.append((fn, args, out))
        return out

    def seed(self, fn: Callable, args: tuple, out) -> None:
        """``fn(*args)`` is ``out`` (known already)."""
        self.items.append((fn, args, out))


def _call(fn: Callable, *args):
    return fn(*args)


def _extension(pc: PlantCase, g: np.ndarray, memo: Callable = _call) -> tuple | None:
    """The model below the case's grid (:func:`~feedtune.analysis.loop.model_extension`): ``(f_ext [Hz], scale,
    junction band [Hz], H * scale * model plant on f_ext)``, or None when the grid starts at its lowest frequency;
    ``g`` is the plant on the grid (on its first octave at least); ``memo(fn, *args)`` computes ``fn(*args)``
    (:class:`_Memo`: once per analysis)."""
    f = pc.freq_hz
    f_ext = memo(extension_grid, float(f[0]))
    if not f_ext.size:
        return None
    m = _first_octave(f)
    fm = f[:m]
    scale, band = memo(junction_scale, fm, g[..., :m], memo(pc.model_plant, fm))
    return f_ext, scale, band, scale * memo(pc.model_plant, f_ext) * pc.hold(f_ext)


class _CaseParts:
    """What a ball-screw analysis case needs of its plant for any law at one sample rate, computed once: the
    gains' basis on the base grid and on the model extension below it (:class:`_Controller`), the
    extension's junction factor, and the filter pack's response per filter pack (the last few)."""

    FILTERS_KEPT = 4

    def __init__(self, pc: PlantCase, fs: float, discrete: bool) -> None:
        f = pc.freq_hz
        g = pc.plant(f)
        x = _variable(f, fs, discrete)
        Hg = g * pc.hold(f)
        self.basis = _basis(_difference(x, fs, discrete), Hg)
        del Hg
        self.x = x
        ext = _extension(pc, g)
        self.ext = None
        if ext is not None:
            f_ext, scale, band, He_ge = ext
            xe = _variable(f_ext, fs, discrete)
            self.ext = (f_ext, scale, band, xe, _basis(_difference(xe, fs, discrete), He_ge))
        self.filters: dict[tuple, tuple] = {}

    def filter_response(self, ctrl: _Controller) -> tuple[np.ndarray, np.ndarray | None]:
        """``G_fp`` of the controller on the grid and on the extension."""
        out = self.filters.get(ctrl.key)
        if out is None:
            if len(self.filters) >= self.FILTERS_KEPT:
                self.filters.pop(next(iter(self.filters)))
            out = self.filters[ctrl.key] = (_zpk_at(ctrl.filter, self.x),
                                            None if self.ext is None else _zpk_at(ctrl.filter, self.ext[3]))
        return out


def _case_parts(pc: PlantCase, fs: float, keep: bool) -> _CaseParts:
    """The :class:`_CaseParts` of ``pc`` at ``fs`` [Hz]: kept on the plant case when ``keep`` (the tuners evaluate
    hundreds of laws on the same plant cases), else made for this call."""
    if not keep:
        return _CaseParts(pc, fs, pc.discrete)
    store = pc.__dict__.setdefault("_ballscrew_parts", {})
    parts = store.get(float(fs))
    if parts is None:
        parts = store[float(fs)] = _CaseParts(pc, fs, pc.discrete)
    return parts


class _CaseLoop:
    """One case of a law on a plant case, evaluated anywhere: the grid's plant above its first line, the scaled model
    below it (:func:`~feedtune.analysis.loop.model_extension`)."""

    __slots__ = ("ctrl", "first", "pc", "scale")

    def __init__(self, pc: PlantCase, ctrl: _Controller, scale: complex | None) -> None:
        self.pc, self.ctrl, self.scale = pc, ctrl, scale
        self.first = float(pc.freq_hz[0])


def _evaluate_batch(loops: list[_CaseLoop]):
    """``evaluate_batch`` of :func:`~feedtune.analysis.loop.analyze_loops` for ball-screw cases: every plant, hold
    and controller that several cases share is evaluated once per round for all their points."""

    def evaluate_batch(requests):
        if len(requests) == 1:  # one case: its parts directly
            k, fq = requests[0]
            return [_evaluate_one(loops[k], np.asarray(fq, float))]
        jobs: dict[int, tuple] = {}

        def add(key, fn, fq, sink):
            job = jobs.get(key)
            if job is None:
                job = jobs[key] = (fn, [], [])
            job[1].append(fq)
            job[2].append(sink)

        plants, holds, ctrls = [], [], []
        for i, (k, fq) in enumerate(requests):
            c = loops[k]
            fq = np.asarray(fq, float)
            plants.append(np.empty((2, fq.size), complex))
            holds.append(None)
            ctrls.append(None)
            lo = fq < c.first if c.scale is not None else None
            if lo is not None and lo.any():
                add(id(c.pc.model_plant), c.pc.model_plant, fq[lo], ("ext", i, lo, c.scale))
                hi = ~lo
                if hi.any():
                    add(id(c.pc.plant), c.pc.plant, fq[hi], ("plant", i, hi, None))
            else:
                add(id(c.pc.plant), c.pc.plant, fq, ("plant", i, None, None))
            add(id(c.pc.hold), c.pc.hold, fq, ("hold", i, None, None))
            add(id(c.ctrl), c.ctrl.at, fq, ("ctrl", i, None, None))
        for fn, pieces, sinks in jobs.values():
            sizes = [p.size for p in pieces]
            res = fn(np.concatenate(pieces) if len(pieces) > 1 else pieces[0])
            ends = itertools.accumulate(sizes)
            for (kind, i, sel, scale), e, n in zip(sinks, ends, sizes, strict=True):
                if kind == "ctrl":
                    ctrls[i] = tuple(r[e - n:e] for r in res)
                elif kind == "hold":
                    holds[i] = res[..., e - n:e]
                else:
                    v = res[..., e - n:e]
                    if scale is not None:
                        v = v * scale
                    if sel is None:
                        plants[i][...] = v
                    else:
                        plants[i][:, sel] = v
        out = []
        for g, H, (gfp, p1, p2) in zip(plants, holds, ctrls, strict=True):
            L = p1 * g[0]
            L += p2 * g[1]
            L *= gfp
            L *= H
            out.append(L)
        return out

    return evaluate_batch


def _evaluate_one(c: _CaseLoop, fq: np.ndarray) -> np.ndarray:
    """The loop of one case at ``fq`` [Hz] (the scaled model below the grid's first line)."""
    lo = fq < c.first if c.scale is not None else None
    if lo is not None and lo.any():
        g = np.empty((2, fq.size), complex)
        g[:, lo] = c.scale * c.pc.model_plant(fq[lo])
        hi = ~lo
        if hi.any():
            g[:, hi] = c.pc.plant(fq[hi])
    else:
        g = c.pc.plant(fq)
    gfp, L, p2 = c.ctrl.at(fq)
    L *= g[0]
    p2 *= g[1]
    L += p2
    L *= gfp
    L *= c.pc.hold(fq)
    return L


def _analyze(law: BallScrewLaw, pcs: list[PlantCase], responses: bool, keep: bool) -> list[CaseResponse]:
    """Every case of ``law`` on the plant cases ``pcs``: each resolved on its own, all refined together
    (:func:`~feedtune.analysis.loop.analyze_loops`). With ``keep`` the fixed parts are kept on the plant cases
    (:class:`_CaseParts`: the loop is then five scaled sums) and the responses, when asked for, computed at once;
    else the loop is formed directly, nothing is kept and the responses are computed when first read
    (:class:`_LazyResponses`)."""
    loops: list[_CaseLoop] = []
    partial: list[tuple] = []
    ctrls = [_controller(law, pc.discrete) for pc in pcs]
    partners = {} if keep else _path_partners(pcs, ctrls)
    ready: dict[int, tuple] = {}  # the grid loops formed with an earlier case's paths
    memo = _Memo()

    def loop_cases():
        for i, (pc, ctrl) in enumerate(zip(pcs, ctrls, strict=True)):
            if keep:
                parts = _case_parts(pc, law.fs, keep)
                gfp, gfp_ext = parts.filter_response(ctrl)
                L = _combine(ctrl.gains, parts.basis)
                L *= gfp
                ext = None
                if parts.ext is not None:
                    f_ext, scale, band, _, basis_ext = parts.ext
                    L_ext = _combine(ctrl.gains, basis_ext)
                    L_ext *= gfp_ext
                    ext = (f_ext, scale, band, L_ext)
                resp = _basis_responses(law, pc, ctrl, parts, L, gfp) if responses else None
                del parts, gfp, gfp_ext
            else:
                L, ext = _direct(pc, ctrl, ready.pop(i, None), [(j, pcs[j]) for j in partners.get(i, ())], ready,
                                 memo)
                if i == len(pcs) - 1:
                    memo.items.clear()  # what the cases shared: its memory serves the last case's analysis
                resp = _LazyResponses(law, pc, ctrl) if responses else None
            extension = None
            if ext is not None:
                f_ext, scale, band, L_ext = ext
                extension = LoopExtension(f_ext, L_ext, scale, band, _one_case(batch, len(loops)))
            loops.append(_CaseLoop(pc, ctrl, None if extension is None else extension.scale))
            partial.append((pc, L, resp))
            yield LoopCase(pc.freq_hz, L, _one_case(batch, len(loops) - 1),
                           np.vstack([pc.features, ctrl.features]), ctrl.rhp, extension=extension,
                           noise_db=pc.noise_db, measured=pc.measured, band_edge=pc.band_edge)

    batch = _evaluate_batch(loops)
    with analysis_scope():
        metrics = analyze_loops(loop_cases(), batch)
    out = []
    for (pc, L, resp), m in zip(partial, metrics, strict=True):
        if isinstance(resp, tuple):  # computed with the loop: S too
            case = CaseResponse(pc.name, pc.freq_hz, L, m, resp[1:])
            case.__dict__["_S"] = resp[0]
        else:
            case = CaseResponse(pc.name, pc.freq_hz, L, m, resp)
        out.append(case)
    return out


def _path_partners(pcs: list[PlantCase], ctrls: list[_Controller]) -> dict[int, list[int]]:
    """For each case, the later cases whose feedback paths on the grid are its own: the same controller on the same
    lines (the same grid array, equal lines, or the first lines of its grid: ``measured`` on the model grid's lines
    beside ``ideal``, ``discrete`` beside ``ideal_discrete``, whose grid only adds ``fs / 2``). The paths are then
    evaluated once (element by element, by the same route: the same bits as on the later case's own grid)."""
    out: dict[int, list[int]] = {}
    taken: set[int] = set()
    for i, (pc, ctrl) in enumerate(zip(pcs, ctrls, strict=True)):
        f = pc.freq_hz
        for j in range(i + 1, len(pcs)):
            fj = pcs[j].freq_hz
            if (j not in taken and ctrls[j] is ctrl and f.ndim == fj.ndim == 1 and fj.size <= f.size
                    and _zpk_blocked(ctrl.filter, fj.size) and same_lines(f[:fj.size], fj)):
                out.setdefault(i, []).append(j)
                taken.add(j)
    return out


def _plant_on_grid(pc: PlantCase) -> tuple[np.ndarray, bool]:
    """``[G11, G21]`` on the case's grid and whether it is a new array (else: read only)."""
    lines = getattr(pc.plant, "lines", None)
    if lines is not None and lines[0] is pc.freq_hz:  # a measured FRF on its own lines: its values, read only
        return lines[1], False
    return pc.plant(pc.freq_hz), getattr(pc.plant, "source", None) is not None or getattr(pc.plant, "fresh", False)


def _grid_loop(pc: PlantCase, k1: np.ndarray, k2: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(L, plant on the grid's first octave)`` of the case from the paths ``k1 = K1``, ``k2 = K2`` on its grid
    (left alone): the operations of :func:`_direct`, into new arrays."""
    f = pc.freq_hz
    g, fresh = _plant_on_grid(pc)
    low = g[..., :_first_octave(f)].copy()
    H = None if getattr(pc.hold, "identity", False) else pc.hold(f)
    out = []
    # k * (H G) in this order, as k *= ... forms it (a complex product may differ in the last bit with its factors
    # swapped, as numpy does for an expression's temporary: written out)
    for k, row in ((k1, g[0]), (k2, g[1])):
        if H is None:
            out.append(np.multiply(k, row))
        elif fresh:
            row *= H
            out.append(np.multiply(k, row))
        else:
            hg = row * H
            out.append(np.multiply(k, hg, out=hg))
    del g, H
    L, t = out
    del out
    L += t
    return L, low


def _direct(pc: PlantCase, ctrl: _Controller, ready: tuple | None = None, partners: list[tuple] = (),
            later: dict | None = None, memo: Callable = _call) -> tuple:
    """The loop on the case's grid and its extension below the grid, formed directly: ``K1 = G_fp P1``,
    ``K2 = G_fp P2`` and ``H [G11, G21]`` on the grid (:class:`_Controller`), in place where the arrays are this
    function's own (the same operations, in the same order, as :meth:`_LazyResponses.compute`: the same bits).

    ``ready``: the grid loop and the plant on the first octave formed already (:func:`_grid_loop`); ``partners``:
    ``(index, plant case)`` of later cases with the same paths on (the first lines of) this grid
    (:func:`_path_partners`), their grid loops put in ``later``; ``memo``: :class:`_Memo` of the analysis."""
    f = pc.freq_hz
    if ready is not None:
        k1, low = ready
    else:
        k1, k2 = ctrl.paths(f)
        for j, q in partners:  # before this case's products use up the paths
            n = q.freq_hz.size
            later[j] = _grid_loop(q, k1[:n], k2[:n])
        g, fresh = _plant_on_grid(pc)
        low = g[..., :_first_octave(f)].copy()  # for the extension's junction
        if getattr(pc.hold, "identity", False):
            release_shared()  # this case's s or z: the extension and the next case have their own grids
            k1 *= g[0]
            k2 *= g[1]
        else:
            H = pc.hold(f)
            release_shared()
            for k, row in ((k1, g[0]), (k2, g[1])):  # K H G, a row at a time: H G as the product g * H
                if fresh:
                    row *= H
                    k *= row
                else:
                    k *= row * H
            del H
        del g
        k1 += k2  # K1 H G11 + K2 H G21
        del k2
    if isinstance(memo, _Memo) and pc.plant is pc.model_plant:
        # the model on the first octave is the plant's there (the same values, element by element)
        memo.seed(pc.model_plant, (f[:low.shape[-1]],), low)
    ext = _extension(pc, low, memo)
    if ext is not None:
        f_ext, scale, band, He_ge = ext
        gfp_e, p1_e, p2_e = memo(ctrl.at, f_ext)
        L_ext = p1_e * He_ge[0]
        L_ext += p2_e * He_ge[1]
        L_ext *= gfp_e
        ext = (f_ext, scale, band, L_ext)
    return k1, ext


def _times_hold(plant: Callable, hold: Callable, g: np.ndarray, f: np.ndarray) -> np.ndarray:
    """``H [G11, G21]`` from ``g = plant(f)`` on ``f`` [Hz]: in place when ``g`` is a new array of the plant case's
    own functions (:func:`plant_cases`), else a new array (a caller's plant function's array is left alone)."""
    if getattr(plant, "source", None) is not None or getattr(plant, "fresh", False):
        g *= hold(f)
        return g
    return g * hold(f)


class _LazyResponses:
    """What the tracking and disturbance responses of a case are computed from when first read
    (:class:`CaseResponse`): the law, its paths and the plant case's functions, not the plant case itself (whose
    measured scatter and interpolation tables are then released with it)."""

    __slots__ = ("ctrl", "disturbance", "freq_hz", "hold", "law", "plant")

    def __init__(self, law: BallScrewLaw, pc: PlantCase, ctrl: _Controller) -> None:
        self.law, self.ctrl, self.freq_hz = law, ctrl, pc.freq_hz
        self.plant = _on_lines(pc.plant, pc.freq_hz)
        self.hold, self.disturbance = pc.hold, pc.disturbance

    def compute(self, L: np.ndarray, S: np.ndarray) -> tuple:
        """``(tracking, tracking_no_ff, disturbance)`` on the grid (module docstring) for the loop ``L`` and
        sensitivity ``S`` [-]."""
        f = self.freq_hz
        with analysis_scope(), np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            source, d = getattr(self.plant, "source", None), None
            if source is not None and getattr(self.disturbance, "source", None) is source:
                both = source.stacked(f, self.plant.keys + self.disturbance.keys)  # one denominator for the four
                g, d = both[:2], both[2:]
            else:
                g = self.plant(f)
            if not getattr(self.hold, "identity", False):
                g = _times_hold(self.plant, self.hold, g, f)
            k1, k2 = self.ctrl.paths(f)
            return _path_responses(self.law, self.ctrl, f, self.disturbance, g, k1, k2, S, d)


def _on_lines(fn: Callable[[np.ndarray], np.ndarray], f: np.ndarray) -> Callable[[np.ndarray], np.ndarray]:
    """``fn``, or for a measured FRF on its own lines (:func:`~feedtune.analysis.resolution.interpolate_frf`) a
    function giving the same values that holds the measured response only (not its interpolation tables)."""
    lines = getattr(fn, "lines", None)
    if lines is None or not (lines[0] is f or np.array_equal(lines[0], f)):
        return fn
    h = lines[1]

    def evaluate(fq):
        return h.copy()

    evaluate.fresh = True
    return evaluate


def _references(law: BallScrewLaw, ctrl: _Controller, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(U_ff, R1)`` at ``x`` (``s``, or ``z`` with the previewed discrete filters times ``z^P``)."""
    if not ctrl.discrete:
        return _zpk_at(law.feedforward, x), _zpk_at(law.rotary_reference, x)
    refs = ctrl.__dict__.get("references")
    if refs is None:  # the previewed discrete filters times z^P: their poles at z = 0 cancel against the advance
        paths = law.reference_paths()
        refs = ctrl.__dict__["references"] = tuple(
            _strip_origin(paths[k].discrete, int(paths[k].preview_samples)) for k in ("feedforward", "rotary"))
    out = []
    for zpk, power in refs:
        r = _zpk_at(zpk, x)
        if power:
            xp = x if power > 0 else np.conj(x)  # z^-1 = conj(z) on the unit circle
            for _ in range(abs(power)):
                r *= xp
        out.append(r)
    return out[0], out[1]


def _strip_origin(z: Zpk, power: int) -> tuple[Zpk, int]:
    """``z(x) x^power`` as ``(z', p)`` with ``z'(x) x^p`` the same, ``z'`` without roots at exactly 0."""
    zeros, poles = z.zeros[z.zeros != 0], z.poles[z.poles != 0]
    return (Zpk(zeros, poles, z.gain, z.dt), power + (z.zeros.size - zeros.size) - (z.poles.size - poles.size))


def _path_responses(law: BallScrewLaw, ctrl: _Controller, f: np.ndarray, disturbance: Callable | None,
                    Hg: np.ndarray, k1: np.ndarray, k2: np.ndarray, S: np.ndarray,
                    d: np.ndarray | None = None) -> tuple:
    """Tracking with and without feedforward and the disturbance response (module docstring) on the grid ``f`` [Hz]
    from the plant times the hold ``Hg = H [G11, G21]``, the paths ``k1 = K1``, ``k2 = K2``, the sensitivity ``S``
    and the disturbance inputs ``d = disturbance(f) = [G13, G23]`` (evaluated when not given; ``k2`` and ``d`` are
    used up; None without ``disturbance``)."""
    no_ff = k2
    no_ff += k1  # K1 + K2 (k2 used up)
    no_ff *= Hg[1]
    ff, r1 = _references(law, ctrl, _variable(f, ctrl.fs, ctrl.discrete))
    tracking = ff
    tracking *= Hg[1]
    r1 -= 1.0
    r1 *= k1
    r1 *= Hg[1]
    tracking += r1  # H G21 (U_ff + K1 (R1 - 1))
    del r1
    tracking += no_ff
    tracking *= S
    no_ff *= S
    dist = None
    if disturbance is not None:
        d = disturbance(f) if d is None else d  # [G13, G23]
        dist = Hg[0] * d[1]
        d[0] *= Hg[1]
        dist -= d[0]
        dist *= k1  # H K1 (G11 G23 - G13 G21)
        dist += d[1]
        dist *= S
    return tracking, no_ff, dist


def _one_case(batch, k: int) -> Callable[[np.ndarray], np.ndarray]:
    """Case ``k``'s loop at any frequency [Hz] through the joint evaluator (the extension's below the grid)."""

    def evaluate(fq):
        return batch([(k, fq)])[0]

    return evaluate


def _basis_responses(law: BallScrewLaw, pc: PlantCase, ctrl: _Controller, parts: _CaseParts, L: np.ndarray,
                     gfp: np.ndarray) -> tuple:
    """``S``, tracking with and without feedforward, and the disturbance response on the case's grid (module
    docstring), from the parts' basis ``B`` (:class:`_Controller`): ``H G21 K1 = G_fp (Kx1 B2 + Kv1 B3)``,
    ``H G21 K2 = G_fp (Kx2 B2 + Kv2 B3 + Ki2 B4)``, ``H K1 (G11 G23 - G13 G21) = G_fp (Kx1 (B0 G23 - G13 B2) + Kv1
    (B1 G23 - G13 B3))``; two work arrays besides the four results."""
    B = parts.basis
    kx1, kv1, kx2, kv2, ki2 = ctrl.gains
    with np.errstate(divide="ignore", invalid="ignore"):
        S = 1.0 / (1.0 + L)
    tmp = np.empty(L.shape, complex)

    def axpy(out, a, x):  # out += a x
        np.multiply(x, a, out=tmp)
        out += tmp

    no_ff = B[2] * (kx2 + kx1)  # H G21 (K1 + K2) / G_fp
    axpy(no_ff, kv2 + kv1, B[3])
    axpy(no_ff, ki2, B[4])
    no_ff *= gfp
    k1g = B[2] * kx1  # H G21 K1
    axpy(k1g, kv1, B[3])
    k1g *= gfp
    ff, r1 = _references(law, ctrl, parts.x)
    r1 -= 1.0
    k1g *= r1  # H G21 K1 (R1 - 1)
    del r1
    tracking = ff
    tracking *= B[2]
    tracking += k1g
    del k1g
    tracking += no_ff  # H G21 (U_ff + K1 R1 + K2)
    tracking *= S
    no_ff *= S
    dist = None
    if pc.disturbance is not None:
        d = pc.disturbance(pc.freq_hz)  # [G13, G23]
        dist = B[0] * (kx1 * d[1])
        axpy(dist, -kx1, B[2] * d[0])
        y = B[1] * (kv1 * d[1])
        np.multiply(B[3], d[0], out=tmp)
        tmp *= -kv1
        y += tmp
        dist += y
        del y
        dist *= gfp
        dist += d[1]
        dist *= S
    return S, tracking, no_ff, dist


def loop_on_grid(law: BallScrewLaw, pc: PlantCase) -> np.ndarray:
    """The loop ``L`` [-] of ``law`` on the plant case's base grid ``pc.freq_hz``, from the fixed parts kept on ``pc``
    (:func:`analyze_case`): five scaled sums and one product, for a search's quick conditions on many candidates
    (the same values as :func:`loop_function` of :func:`feedback_paths` on the grid, to rounding)."""
    ctrl = _controller(law, pc.discrete)
    parts = _case_parts(pc, law.fs, True)
    L = _combine(ctrl.gains, parts.basis)
    L *= parts.filter_response(ctrl)[0]
    return L


def analyze_case(law: BallScrewLaw, pc: PlantCase, *, responses: bool = True) -> CaseResponse:
    """One analysis case of a law on a plant case: the figures (refined) and, with ``responses``, the curves on the
    case's base grid, computed with the loop (without: ``L``, and ``S`` computed when first read, for searches).

    What depends on the plant case alone (the plant and hold on the grid times the gains' basis, the model extension
    below the grid, the filter pack's response) is computed once and kept on ``pc``: a tuner calling this for
    hundreds of laws on the same plant cases pays for it once.
    """
    return _analyze(law, [pc], responses, keep=True)[0]


def analyze_ballscrew(
    law: BallScrewLaw, model: BallScrewModel, frf: Frf | None = None, freq_hz: np.ndarray | None = None, *,
    cases: dict | None = None,
) -> BallScrewAnalysis:
    """Analyse a ball-screw control law in all cases (see module docstring).

    The cases are resolved one after the other and refined together: every round of the refinement evaluates the
    loop at the points of all cases at once, each model, plant, hold and controller once
    (:func:`~feedtune.analysis.loop.analyze_loops`).

    Parameters
    ----------
    law : BallScrewLaw
    model : BallScrewModel
        The design model (ideal cases; the loop below the FRF's band in the measured cases).
    frf : Frf, optional
        Measured ``x1/u`` and ``x2/u`` (measured and discrete cases).
    freq_hz : ndarray, optional
        Grid for the model cases [Hz] (default :func:`default_grid`).
    cases : dict, optional
        :func:`plant_cases` of ``model`` and ``frf`` at the law's rate and delay, made already (a tuner checking many
        laws on the same FRF makes them once; their continuation above the FRF is a fit); ``freq_hz`` is then unused.

    Returns
    -------
    BallScrewAnalysis
        Each case keeps its loop ``L``; ``S``, ``tracking``, ``tracking_no_ff`` and ``disturbance`` are computed when
        first read (:class:`CaseResponse`).
    """
    if cases is None:
        cases = plant_cases(model, law.fs, law.delay_samples, frf, freq_hz)
    given = [pc for pc in cases.values() if pc is not None]
    done = iter(_analyze(law, given, True, keep=False))
    return BallScrewAnalysis({name: None if pc is None else next(done) for name, pc in cases.items()})


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
