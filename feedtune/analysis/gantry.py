"""Frequency-domain analysis of gantry (2x2) and loop-shaped axis (SISO) controllers (thesis §4.4).

Cases, as for the ball screw (:mod:`feedtune.analysis.ballscrew`):

* ``ideal``: the model with the continuous controller.
* ``ideal_discrete``: the model discretized exactly with a zero-order hold, the discrete controller and the
  computational delay (a z-domain loop whose Nyquist contour is the unit circle).
* ``measured``: the measured FRF with the continuous controller (null without an FRF).
* ``discrete``: the measured FRF with the discrete controller, the zero-order hold and the delay.

Gantry (2x2, :mod:`feedtune.analysis.mimo`): loop ``L = G K``, ``S = (I + L)^-1``, disturbance transfer
``S G`` [m/V] against the open loop ``G`` (force disturbances at the actuators), CoM tracking
``ybar / y_r = alpha^T S G H (K r + M s^2 r)`` with the per-side pre-filtered references ``r`` (eq. 4.31,
4.32). The measured FRF is a 2x2 position FRF with channels ``y1/u1, y1/u2, y2/u1, y2/u2`` [m/V].

Axis (SISO, :func:`feedtune.analysis.loop.analyze_loop`): ``L = G C``, disturbance ``x/d = G S`` [m/V],
tracking ``x/x_r = G H (m_x s^2 + C P) S`` with the pre-filter ``P`` of eq. 4.20.

Nyquist counts: every case extends its loop below its grid with the model
(:func:`feedtune.analysis.loop.model_extension`, from 1e-5 Hz): the model itself in ``ideal``; the
continuous model times the hold ``(1 - e^{-sT})/(sT)`` in ``ideal_discrete`` (which equals the exact ZOH
model there to ``(w T)^2``); in ``measured`` and ``discrete`` the model scaled by the complex factor that
fits it to the FRF over the FRF's first octave, with the case's hold, delay and controller. The open-loop
poles at the origin are structural: 2 for the gantry's rigid body (1/(m s^2) for an axis) plus the
controller's integrators. The figures other than stability are those of the grid.
"""

from __future__ import annotations

import weakref
from dataclasses import dataclass, field
from functools import lru_cache

import numpy as np

from ..blas import blas_single_threaded
from ..control.gantry import GantryReference
from ..display import AnalysisDisplay, CaseDisplay
from ..errors import DataError
from ..frf import Frf
from ..frf_quality import averages_of
from ..lti import delay_response, zoh_double_integrator, zoh_response
from ..models.gantry import GantryModel
from .cases import CASES as CASES  # re-exported: the case names
from .cases import PlantCase, measured_cases, model_cases
from .loop import (
    EXTENSION_LOW_HZ,
    LoopExtension,
    LoopMetrics,
    analyze_loop,
    extension_grid,
    junction_scale,
    model_extension,
    scalar_loops,
)
from .mimo import (
    MimoMetrics,
    analyze_mimo,
    com_loop,
    level_bands,
    matmul,
    matvec,
    resolve_rounds,
    sensitivity,
    singular_values,
)
from .resolution import lightly_damped

GANTRY_CHANNELS = (("y1/u1", "y1/u2"), ("y2/u1", "y2/u2"))


# ------------------------------------------------------------------------------------ plant-case parts
_PARTS: dict[int, tuple] = {}


def _case_parts(pc: PlantCase) -> dict:
    """What the analyses of many controllers on one plant case share and keep (a search analyses hundreds): the
    plant with its hold on the base grid, at the last line and on the extension's grid below it, each computed once
    by the code that would compute it for every analysis (the same values: nothing depends on what was asked
    before). Kept while the plant case lives."""
    key = id(pc)
    hit = _PARTS.get(key)
    if hit is not None and hit[0]() is pc:
        return hit[1]
    parts: dict = {}
    _PARTS[key] = (weakref.ref(pc, lambda _, key=key, kept=_PARTS: kept.pop(key, None)), parts)  # (no global at exit)
    return parts


def _grid_plant(pc: PlantCase) -> tuple[np.ndarray, np.ndarray]:
    """``(G, G H)`` on the plant case's base grid (kept; not to be modified)."""
    parts = _case_parts(pc)
    if "grid" not in parts:
        f = pc.freq_hz
        G = pc.plant(f)
        parts["grid"] = (G, G * pc.hold(f))
    return parts["grid"]


def plant_at_top(pc: PlantCase) -> np.ndarray:
    """The plant with its hold at the case's last line (kept): what the tuners' band-top rule multiplies the
    controller by."""
    parts = _case_parts(pc)
    if "top" not in parts:
        top = pc.freq_hz[-1:]
        parts["top"] = pc.plant(top) * pc.hold(top)
    return parts["top"]


def _extension(pc: PlantCase, G: np.ndarray, controller_loop) -> LoopExtension | None:
    """:func:`~feedtune.analysis.loop.model_extension` of the case with the loop ``controller_loop(f, g h)`` (the
    controller applied to the plant with its hold): the junction factor and the scaled model with its hold on the
    extension's grid depend on the plant case alone and are kept."""
    parts = _case_parts(pc)
    if "extension" not in parts:
        f = pc.freq_hz
        f_ext = extension_grid(float(f[0]), EXTENSION_LOW_HZ)
        if f_ext.size == 0:
            parts["extension"] = None
        else:
            sel = f <= f[0] * 2.0
            scale, band = junction_scale(f[sel], np.asarray(G)[..., sel], pc.model_plant(f[sel]))
            parts["extension"] = (f_ext, scale, band, scale * pc.model_plant(f_ext) * pc.hold(f_ext))
    if parts["extension"] is None:
        return None
    f_ext, scale, band, gh_ext = parts["extension"]

    def evaluate(fe):
        return controller_loop(fe, scale * pc.model_plant(fe) * pc.hold(fe))

    fr, L = resolve_rounds(f_ext, evaluate, scalar_loops, known=controller_loop(f_ext, gh_ext))
    return LoopExtension(fr, L, scale, band, evaluate)


def default_grid(fs: float, n: int = 4000) -> np.ndarray:
    """Analysis grid for the model cases [Hz]: 0.5 Hz to just below ``fs/2``, log-spaced."""
    return np.logspace(np.log10(0.5), np.log10(fs / 2 * 0.999), n)


def _max_lag(f, t, f_max):
    m = f <= f_max
    return float(-np.min(np.angle(t[m], deg=True))) if m.any() else None


def _bandwidth(f, t, tol_db: float = 3.0):
    dev = np.abs(20 * np.log10(np.abs(t))) > tol_db
    return float(f[np.argmax(dev)]) if dev.any() else None


# ----------------------------------------------------------------------------------- gantry cases
@dataclass(frozen=True, repr=False)
class GantryCase(CaseDisplay):
    """Responses and figures of one gantry analysis case.

    Attributes
    ----------
    name : str
    freq_hz : ndarray
        Grid [Hz].
    G : ndarray, shape (2, 2, n)
        Plant as the controller sees it (with ZOH and delay in the discrete cases) [m/V].
    L, S : ndarray, shape (2, 2, n)
        Loop and sensitivity [-].
    SG : ndarray, shape (2, 2, n)
        Closed-loop disturbance transfer (actuator forces to encoders) [m/V].
    G_open : ndarray, shape (2, 2, n)
        Open-loop disturbance transfer [m/V].
    tracking, tracking_no_ff : ndarray
        CoM ``ybar / y_r`` with and without feedforward and pre-filter [-].
    weights : (float, float)
        Mass distribution of the CoM output.
    metrics : MimoMetrics
    """

    name: str
    freq_hz: np.ndarray
    G: np.ndarray
    L: np.ndarray
    S: np.ndarray
    SG: np.ndarray
    G_open: np.ndarray
    tracking: np.ndarray
    tracking_no_ff: np.ndarray
    weights: tuple
    metrics: MimoMetrics

    def singular_values(self) -> dict[str, tuple[np.ndarray, np.ndarray]]:
        """Upper and lower singular values of ``L``, ``S``, ``S G`` and ``G`` on the grid."""
        return {name: singular_values(getattr(self, name)) for name in ("L", "S", "SG", "G_open")}

    def to_dict(self) -> dict:
        """Figures of the ``--json`` output for this case."""
        f = self.freq_hz
        d = self.metrics.to_dict()
        sg, _ = singular_values(self.SG)
        g, _ = singular_values(self.G_open)
        dcom = com_loop(matmul(self.SG, np.diag(self.weights)), self.weights)  # alpha^T SG alpha
        i = int(np.argmin(dcom.real))
        j = int(np.argmax(sg))
        d["disturbance_min_real_m_per_V"] = float(dcom.real[i])
        d["disturbance_min_real_freq_hz"] = float(f[i])
        d["disturbance_peak_m_per_V"] = float(sg[j])
        d["disturbance_peak_freq_hz"] = float(f[j])
        d["disturbance_rejection_bands_hz"] = level_bands(f, g / sg, 1.0)
        d["tracking_bandwidth_hz"] = _bandwidth(f, self.tracking)
        d["tracking_max_phase_lag_deg_below_100hz"] = _max_lag(f, self.tracking, 100.0)
        return d


@dataclass(frozen=True, repr=False)
class GantryAnalysis(AnalysisDisplay):
    """All cases; ``cases[name]`` is None when the case needs a missing FRF."""

    cases: dict = field(default_factory=dict)


def zoh_gantry(model: GantryModel, x: float, fs: float, freq_hz) -> np.ndarray:
    """Exact ZOH discretization of the gantry at ``x`` evaluated at ``z = e^{j w T}``, ``(2, 2, n)`` [m/V]."""
    return _zoh_gantry_fn(model, x, fs)(freq_hz)


@blas_single_threaded
def _zoh_gantry_fn(model: GantryModel, x: float, fs: float):
    """A function evaluating :func:`zoh_gantry` on any grid (the discretization computed once)."""
    from scipy.signal import cont2discrete

    A, B, C = model.state_space(x)
    Ad, Bd, Cd, _, _ = cont2discrete((A, B, C, np.zeros((2, 2))), 1.0 / fs, method="zoh")
    n = Ad.shape[0]

    def evaluate(freq_hz) -> np.ndarray:
        z = np.exp(2j * np.pi * np.asarray(freq_hz, float) / fs)
        Zi = z[:, None, None] * np.eye(n) - Ad  # (n_f, n, n)
        X = np.linalg.solve(Zi, np.broadcast_to(Bd, (z.size, n, 2)))
        return np.moveaxis(Cd @ X, 0, -1)

    return evaluate


def gantry_frf_matrix(frf: Frf) -> tuple[np.ndarray, np.ndarray]:
    """``(freq_hz, G)`` of a measured 2x2 position FRF [m/V] (channels y1/u1, y1/u2, y2/u1, y2/u2)."""
    pos = frf.as_quantity("position")
    missing = [c for row in GANTRY_CHANNELS for c in row if not pos.has(c)]
    if missing:
        raise DataError(f"{frf.source}: the gantry analysis needs channels y1/u1, y1/u2, y2/u1, y2/u2; missing "
                        f"{', '.join(missing)} (found {', '.join(frf.channels)})")
    keep = pos.freq_hz > 0
    G = np.array([[pos.channel(c)[keep] for c in row] for row in GANTRY_CHANNELS])
    return pos.freq_hz[keep], G


def analyze_gantry_case(law, pc: PlantCase, weights, reference: GantryReference | None = None, *,
                        integrators: int | None = None, figures: str = "all", disk_margin: bool = True) -> GantryCase:
    """One gantry case of a law (MIMO or PID) on a plant case (plant ``(2, 2, n)`` [m/V]).

    Parameters
    ----------
    law : MimoLaw or PidLaw
    pc : PlantCase
        From :func:`gantry_plant_cases`.
    weights : (float, float)
        Mass distribution ``alpha(x)`` of the CoM output.
    reference : GantryReference, optional
        For the tracking curves (None: no tracking curves, for searches).
    integrators : int, optional
        Open-loop poles at the origin; default ``2 + law.integrators`` (rigid body and integrating channels).
    figures : {"all", "limits", "stability"}
        ``"limits"``: only the figures the limits policy reads, ``"stability"`` only the Nyquist count
        (:func:`~feedtune.analysis.mimo.analyze_mimo`), for the candidates of a search; without a ``reference``
        the case then holds no ``S`` and ``SG`` (None), and its ``G`` and ``G_open`` are the plant case's own
        (kept for the next candidate: not to be modified).
    disk_margin : bool
        With ``figures="limits"``: also the disk margin.
    """
    f = pc.freq_hz
    n_int = 2 + law.integrators if integrators is None else int(integrators)
    G, Ge = _grid_plant(pc)
    if figures == "all":  # returned to the caller
        G, Ge = G.copy(), Ge.copy()
    K = law.response_discrete if pc.discrete else law.response

    def evaluate(fr):
        return matmul(pc.plant(fr) * pc.hold(fr), K(fr))

    Kf = K(f)
    L = matmul(Ge, Kf)

    def controller_loop(fr, gh):
        return matmul(gh, K(fr))

    extension = _extension(pc, G, controller_loop)
    feats = np.vstack([pc.features, law_features(law, pc.discrete)])
    metrics = analyze_mimo(f, L, evaluate=evaluate, features=feats, weights=weights, integrators=n_int,
                           open_loop_rhp_poles=law.rhp_poles(pc.discrete), extension=extension, noise_db=pc.noise_db,
                           measured=pc.measured, figures=figures, disk_margin=disk_margin, band_edge=pc.band_edge)
    if reference is None and figures != "all":  # a search's candidate: the figures alone
        return GantryCase(pc.name, f, Ge, L, None, None, G, None, None, tuple(weights), metrics)
    S = sensitivity(L)
    SG = matmul(S, G)
    if reference is None:
        return GantryCase(pc.name, f, Ge, L, S, SG, G, None, None, tuple(weights), metrics)
    r, ff = reference.responses(f, law.fs if pc.discrete else None)
    ones = np.ones((2, f.size), complex)
    SGe = matmul(S, Ge)
    y = matvec(SGe, matvec(Kf, r) + ff)
    y0 = matvec(SGe, matvec(Kf, ones))
    w1, w2 = weights
    return GantryCase(pc.name, f, Ge, L, S, SG, G, w1 * y[0] + w2 * y[1], w1 * y0[0] + w2 * y0[1], tuple(weights),
                      metrics)


def gantry_extension(f, G, model: GantryModel, x: float, controller, fs: float | None = None,
                     delay_samples: int = 0, zoh_in_plant: bool = False) -> LoopExtension | None:
    """The 2x2 loop below ``f[0]`` from the model at ``x`` [m], scaled to meet ``G`` [m/V] at the junction.

    ``controller(f)`` -> ``K`` [V/m] ``(2, 2, m)``; with ``fs`` [Hz] the hold and ``delay_samples`` join the loop
    (``zoh_in_plant``: ``G`` already holds the zero-order hold).
    """

    def plant(fr):
        g = model.frequency_response(fr, x)
        return g * zoh_response(fr, fs) if zoh_in_plant else g

    def loop(fr, g):
        h = 1.0 if fs is None else delay_response(fr, delay_samples, fs) * (1.0 if zoh_in_plant else
                                                                            zoh_response(fr, fs))
        return matmul(g * h, controller(fr))

    return model_extension(f, G, plant, loop)


def law_features(law, discrete: bool) -> np.ndarray:
    """Lightly damped poles and zeros (Hz, damping) of a gantry law's filter pack (found once per pack and rate: the
    laws of a search share one pack)."""
    return _pack_features(law.filters, float(law.fs), bool(discrete)).copy()


@lru_cache(maxsize=32)
def _pack_features(pack, fs: float, discrete: bool) -> np.ndarray:
    from ..control.discretize import matched

    h = pack.zpk()
    if discrete:
        h = matched(h, fs).tf
    return np.vstack([lightly_damped(h.poles, h.dt), lightly_damped(h.zeros, h.dt)])


def model_features(model: GantryModel, x: float) -> np.ndarray:
    """Lightly damped poles (Hz, damping) of the gantry model at ``x`` [m]."""
    A, _, _ = model.state_space(x)
    return lightly_damped(np.linalg.eigvals(A))


def gantry_plant_cases(model: GantryModel, x: float, fs: float, delay_samples: float, frf: Frf | None = None,
                       freq_hz=None) -> dict[str, PlantCase | None]:
    """The four :class:`~feedtune.analysis.cases.PlantCase` of the gantry at table position ``x`` [m]; plant
    ``(2, 2, n)`` [m/V]; ``measured``/``discrete`` None without an FRF."""
    f = default_grid(fs) if freq_hz is None else np.asarray(freq_hz, float)

    at_x = model.at(x)  # the model at the position, made once (the extension evaluates it for every candidate)

    def model_plant(fr):
        return at_x.frequency_response(fr)

    zoh_model = _zoh_gantry_fn(model, x, fs)
    cases: dict[str, PlantCase | None] = dict(model_cases(f, fs, delay_samples, model_plant=model_plant,
                                                          zoh_plant=zoh_model, features=model_features(model, x)))
    if frf is None:
        cases["measured"] = cases["discrete"] = None
        return cases
    fm, Gm = gantry_frf_matrix(frf)
    cases.update(measured_cases(fm, Gm, fs, delay_samples, model_plant=model_plant, coherence=_gantry_coherence(frf),
                                averages=averages_of(frf.meta), features=model_features(model, x),
                                channels=("y1/u1", "y1/u2", "y2/u1", "y2/u2")))
    return cases


def analyze_gantry(law, model: GantryModel, *, x: float = 0.0, frf: Frf | None = None,
                   reference: GantryReference | None = None, freq_hz=None) -> GantryAnalysis:
    """Analyse a gantry law (MIMO or PID) in all cases (module docstring).

    Parameters
    ----------
    law : MimoLaw or PidLaw
        Provides ``response``, ``response_discrete``, ``integrators``, ``rhp_poles``, ``fs``,
        ``delay_samples``, ``filters``.
    model : GantryModel
        Design model (ideal cases; CoM weights ``alpha(x)``; the loop below the FRF's band in the measured
        cases).
    x : float
        Table position [m] of the model.
    frf : Frf, optional
        Measured 2x2 position FRF [m/V] (measured and discrete cases).
    reference : GantryReference, optional
        Feedforward and pre-filters; default ``M(x)`` of the model, no pre-filter.
    freq_hz : array_like, optional
        Grid for the model cases [Hz].
    """
    from ..control.prefilter import PrefilterGains

    ref = reference or GantryReference(model.at(x).M, PrefilterGains(), PrefilterGains(), 80.0)
    weights = model.alpha(x)
    cases = gantry_plant_cases(model, x, law.fs, law.delay_samples, frf, freq_hz)
    return GantryAnalysis({name: None if pc is None else analyze_gantry_case(law, pc, weights, ref)
                           for name, pc in cases.items()})


def _gantry_coherence(frf: Frf) -> np.ndarray | None:
    """Coherence ``(2, 2, n)`` of the four gantry channels on the positive lines, None when not all measured."""
    pos = frf.as_quantity("position")
    if pos.coherence is None:
        return None
    keep = pos.freq_hz > 0
    c = np.array([[pos.channel_coherence(ch)[keep] for ch in row] for row in GANTRY_CHANNELS])
    return c if np.all(np.isfinite(c)) else None


# ------------------------------------------------------------------------------------- axis cases
@dataclass(frozen=True, repr=False)
class AxisCase(CaseDisplay):
    """Responses and figures of one loop-shaped axis case.

    Attributes
    ----------
    name : str
    freq_hz : ndarray
    L, S : ndarray
        Loop and sensitivity [-].
    tracking, tracking_no_ff : ndarray
        ``x / x_r`` with feedforward and pre-filter, and with neither [-].
    disturbance : ndarray
        ``x / d`` for a force disturbance at the actuator [m/V].
    metrics : LoopMetrics
    """

    name: str
    freq_hz: np.ndarray
    L: np.ndarray
    S: np.ndarray
    tracking: np.ndarray
    tracking_no_ff: np.ndarray
    disturbance: np.ndarray
    metrics: LoopMetrics

    def to_dict(self) -> dict:
        """Figures of the ``--json`` output (ball-screw keys; the disturbance is in m/V)."""
        d = self.metrics.to_dict()
        i = int(np.argmin(self.disturbance.real))
        d["sigma_max_s"] = d["ms"]
        d["disturbance_min_real_m_per_V"] = float(self.disturbance.real[i])
        d["disturbance_min_real_freq_hz"] = float(self.freq_hz[i])
        d["tracking_bandwidth_hz"] = _bandwidth(self.freq_hz, self.tracking)
        d["tracking_max_phase_lag_deg_below_100hz"] = _max_lag(self.freq_hz, self.tracking, 100.0)
        return d


@dataclass(frozen=True, repr=False)
class AxisAnalysis(AnalysisDisplay):
    """All cases of a loop-shaped axis; ``cases[name]`` is None when the case needs a missing FRF."""

    cases: dict = field(default_factory=dict)


def analyze_axis_case(design, pc: PlantCase, *, responses: bool = True) -> AxisCase:
    """One case of a loop-shaped axis design on a plant case (plant ``(n,)`` [m/V]); without ``responses`` the
    tracking curves are None (for searches)."""
    from ..control.discretize import matched
    from ..control.prefilter import prefilter_response

    fs = design.fs
    C = design.controller_discrete() if pc.discrete else design.controller()
    rhp = int(np.sum(np.abs(C.poles) > 1 + 1e-9)) if pc.discrete else int(np.sum(C.poles.real > 1e-9))
    f = pc.freq_hz
    G, GH = _grid_plant(pc)
    Cf = C.freqresp(f)
    L = GH * Cf
    S = 1.0 / (1.0 + L)

    def evaluate(fr):
        return pc.plant(fr) * pc.hold(fr) * C.freqresp(fr)

    def controller_loop(fe, gh):
        return gh * C.freqresp(fe)

    extension = _extension(pc, G, controller_loop)
    feats = np.vstack([pc.features, lightly_damped(C.poles, C.dt), lightly_damped(C.zeros, C.dt)])
    metrics = analyze_loop(f, L, evaluate=evaluate, features=feats, open_loop_rhp_poles=rhp, extension=extension,
                           noise_db=pc.noise_db, measured=pc.measured, band_edge=pc.band_edge)
    if not responses:
        return AxisCase(pc.name, f, L, S, None, None, G * S, metrics)
    if pc.discrete:
        ffm = matched(design.feedforward(), fs)
        ff = ffm.tf.freqresp(f) * np.exp(2j * np.pi * f * ffm.delay_samples / fs)
        pre = prefilter_response(design.prefilter, design.prefilter_hz, f, fs)
    else:
        ff = design.feedforward().freqresp(f)
        pre = prefilter_response(design.prefilter, design.prefilter_hz, f)
    tracking = GH * (ff + Cf * pre) * S
    return AxisCase(pc.name, f, L, S, tracking, L * S, G * S, metrics)


def axis_plant_cases(design, frf: Frf | None = None, *, channel: str | None = None,
                     freq_hz=None) -> dict[str, PlantCase | None]:
    """The four plant cases of a loop-shaped axis: the double integrator ``1/(m s^2)`` of the design's mass and the
    measured SISO FRF (by default the design's own, if it was designed on one) [m/V]."""
    fs, delay = design.fs, design.delay_samples
    f = default_grid(fs) if freq_hz is None else np.asarray(freq_hz, float)
    plant = getattr(design, "plant", None)  # a LoopShapeDesign knows the FRF it was designed on; an AxisLaw not
    m = design.mass if plant is None else plant.mass

    def rigid(fr):
        return 1.0 / (m * (2j * np.pi * np.asarray(fr, float)) ** 2)

    cases: dict[str, PlantCase | None] = dict(model_cases(
        f, fs, delay, model_plant=rigid, zoh_plant=lambda fr: zoh_double_integrator(m, fs, fr),
        features=np.empty((0, 2))))
    own = None if plant is None else plant.frf
    meas = frf if frf is not None else own
    if meas is None:
        cases["measured"] = cases["discrete"] = None
        return cases
    ch = channel or (plant.channel if meas is own else None)
    if ch is None:
        if len(meas.channels) != 1:
            raise DataError(f"{meas.source}: the FRF has channels {', '.join(meas.channels)}; choose one")
        ch = meas.channels[0]
    pos = meas.as_quantity("position")
    keep = pos.freq_hz > 0
    fm = pos.freq_hz[keep]
    coh = pos.channel_coherence(ch)
    coh = None if coh is None or not np.all(np.isfinite(coh[keep])) else coh[keep]
    cases.update(measured_cases(fm, pos.channel(ch)[keep], fs, delay, model_plant=rigid, coherence=coh,
                                averages=averages_of(meas.meta), channels=(ch,)))
    return cases


def analyze_axis(design, frf: Frf | None = None, *, channel: str | None = None, freq_hz=None) -> AxisAnalysis:
    """Analyse an x-axis law (:class:`~feedtune.control.axis.AxisLaw` or a ``LoopShapeDesign``) in all cases.

    Parameters
    ----------
    design : AxisLaw or LoopShapeDesign
    frf : Frf, optional
        Measured SISO position FRF [m/V]; by default the design's own FRF (if it was designed on one).
    channel : str, optional
        FRF channel when the FRF has several.
    freq_hz : array_like, optional
        Grid for the model cases [Hz].
    """
    cases = axis_plant_cases(design, frf, channel=channel, freq_hz=freq_hz)
    return AxisAnalysis({name: None if pc is None else analyze_axis_case(design, pc) for name, pc in cases.items()})


# ------------------------------------------------------------------------------------------- checks
def target_violations(case: dict | None, crossover_hz: float, pm_deg: float, *, tol_hz: float = 1.0,
                      tol_deg: float = 1.0, name: str = "checked") -> list[str]:
    """The first crossover [Hz] and its phase margin [deg] must match the design targets within tolerance."""
    if case is None:
        return []
    xs, pms = case["crossovers_hz"], case["phase_margins_deg"]
    if not xs:
        return [f"the loop has no crossover ({name} case); requested {crossover_hz:g} Hz"]
    out = []
    if abs(xs[0] - crossover_hz) > tol_hz:
        out.append(f"crossover {xs[0]:.4g} Hz differs from the requested {crossover_hz:g} Hz ({name} case)")
    if abs(pms[0] - pm_deg) > tol_deg:
        out.append(f"phase margin {pms[0]:.3g} deg differs from the requested {pm_deg:g} deg ({name} case)")
    return out
