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

from dataclasses import dataclass, field

import numpy as np

from ..errors import DataError
from ..frf import Frf
from ..lti import delay_response, zoh_response
from ..models.gantry import GantryModel
from .loop import LoopExtension, LoopMetrics, analyze_loop, model_extension
from .mimo import MimoMetrics, analyze_mimo, com_loop, level_bands, matmul, matvec, sensitivity, singular_values

CASES = ("ideal", "ideal_discrete", "measured", "discrete")
GANTRY_CHANNELS = (("y1/u1", "y1/u2"), ("y2/u1", "y2/u2"))


def default_grid(fs: float, n: int = 4000) -> np.ndarray:
    """Analysis grid for the model cases [Hz]: 0.5 Hz to just below ``fs/2``, log-spaced."""
    return np.logspace(np.log10(0.5), np.log10(fs / 2 * 0.999), n)


def _discrete_grid(f: np.ndarray, fs: float) -> np.ndarray:
    return np.r_[f[f < fs / 2], fs / 2]


def _max_lag(f, t, f_max):
    m = f <= f_max
    return float(-np.min(np.angle(t[m], deg=True))) if m.any() else None


def _bandwidth(f, t, tol_db: float = 3.0):
    dev = np.abs(20 * np.log10(np.abs(t))) > tol_db
    return float(f[np.argmax(dev)]) if dev.any() else None


# ----------------------------------------------------------------------------------- reference
@dataclass(frozen=True)
class GantryReference:
    """What the reference path does at one table position (for the tracking figures).

    Attributes
    ----------
    mass_matrix : ndarray, shape (2, 2)
        Feedforward ``M`` [V/(m/s^2)] (eq. 4.31).
    prefilter1, prefilter2 : PrefilterGains
        Per-side pre-filter gains (eq. 4.32).
    prefilter_hz : float
        Pre-filter low-pass [Hz].
    """

    mass_matrix: np.ndarray
    prefilter1: object
    prefilter2: object
    prefilter_hz: float

    def responses(self, f: np.ndarray, fs: float | None) -> tuple[np.ndarray, np.ndarray]:
        """``(r, ff)``: per-side reference ``r_i / y_r`` [-] and feedforward ``u_ff / y_r`` [V/m], ``(2, n)``.

        Discrete (``fs`` given): matched filters with the preview compensated, as the runtime executes them.
        """
        from ..design.discretize import matched
        from ..design.loopshape import prefilter_response
        from ..lti import Zpk

        r = np.array([prefilter_response(p, self.prefilter_hz, f, fs) for p in (self.prefilter1, self.prefilter2)])
        s2 = Zpk([0.0, 0.0], [], 1.0)
        if fs is None:
            acc = s2.freqresp(f)
        else:
            m = matched(s2, fs)
            acc = m.tf.freqresp(f) * np.exp(2j * np.pi * f * m.delay_samples / fs)
        return r, np.einsum("ij,jn->in", self.mass_matrix, r * acc)


def reference_from_schedule(schedule, x: float, prefilter_hz: float) -> GantryReference:
    """The :class:`GantryReference` of a schedule at ``x`` [m]."""
    p1, p2 = schedule.prefilters(x)
    return GantryReference(schedule.mass_matrix(x), p1, p2, float(prefilter_hz))


# ----------------------------------------------------------------------------------- gantry cases
@dataclass(frozen=True)
class GantryCase:
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


@dataclass(frozen=True)
class GantryAnalysis:
    """All cases; ``cases[name]`` is None when the case needs a missing FRF."""

    cases: dict = field(default_factory=dict)

    def to_dict(self) -> dict:
        """``{case: figures or None}``."""
        return {name: (c.to_dict() if c is not None else None) for name, c in self.cases.items()}


def zoh_gantry(model: GantryModel, x: float, fs: float, freq_hz) -> np.ndarray:
    """Exact ZOH discretization of the gantry at ``x`` evaluated at ``z = e^{j w T}``, ``(2, 2, n)`` [m/V]."""
    from scipy.signal import cont2discrete

    A, B, C = model.state_space(x)
    Ad, Bd, Cd, _, _ = cont2discrete((A, B, C, np.zeros((2, 2))), 1.0 / fs, method="zoh")
    z = np.exp(2j * np.pi * np.asarray(freq_hz, float) / fs)
    Zi = z[:, None, None] * np.eye(4) - Ad  # (n, 4, 4)
    X = np.linalg.solve(Zi, np.broadcast_to(Bd, (z.size, 4, 2)))
    return np.moveaxis(Cd @ X, 0, -1)


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


def _gantry_case(name, f, G, H, K, weights, reference, fs, integrators, rhp, extension=None) -> GantryCase:
    Ge = G * H
    L = matmul(Ge, K)
    S = sensitivity(L)
    SG = matmul(S, G)
    r, ff = reference.responses(f, fs)
    ones = np.ones((2, f.size), complex)
    SGe = matmul(S, Ge)
    y = matvec(SGe, matvec(K, r) + ff)
    y0 = matvec(SGe, matvec(K, ones))
    w1, w2 = weights
    metrics = analyze_mimo(f, L, weights=weights, integrators=integrators, open_loop_rhp_poles=rhp, S=S,
                           extension=extension)
    return GantryCase(name, f, Ge, L, S, SG, G, w1 * y[0] + w2 * y[1], w1 * y0[0] + w2 * y0[1], tuple(weights),
                      metrics)


def gantry_extension(f, G, model: GantryModel, x: float, controller, fs: float | None = None,
                     delay_samples: int = 0, zoh_in_plant: bool = False) -> LoopExtension | None:
    """The 2x2 loop below ``f[0]`` from the model at ``x`` [m], scaled to meet ``G`` [m/V] at the junction.

    Parameters
    ----------
    f : ndarray
        Grid of the case [Hz].
    G : ndarray, shape (2, 2, n)
        The case's plant on ``f`` [m/V] (FRF or model; with the hold when ``zoh_in_plant``).
    model : GantryModel
    x : float
        Table position [m].
    controller : callable
        ``controller(f)`` -> ``K`` on ``f``, shape ``(2, 2, m)`` [V/m].
    fs : float, optional
        Sample rate [Hz] of a discrete case: the hold and ``delay_samples`` join the loop.
    delay_samples : int
        Computational delay [samples] (discrete cases).
    zoh_in_plant : bool
        ``G`` already holds the zero-order hold (the exact ZOH model of ``ideal_discrete``).

    Returns
    -------
    LoopExtension or None
    """

    def plant(fr):
        g = model.frequency_response(fr, x)
        return g * zoh_response(fr, fs) if zoh_in_plant else g

    def loop(fr, g):
        h = 1.0 if fs is None else delay_response(fr, delay_samples, fs) * (1.0 if zoh_in_plant else
                                                                            zoh_response(fr, fs))
        return matmul(g * h, controller(fr))

    return model_extension(f, G, plant, loop)


def analyze_gantry(law, model: GantryModel, *, x: float = 0.0, frf: Frf | None = None,
                   reference: GantryReference | None = None, freq_hz=None) -> GantryAnalysis:
    """Analyse a gantry law (MIMO or PID) in all cases (module docstring).

    Parameters
    ----------
    law : MimoLaw or PidLaw
        Provides ``response``, ``response_discrete``, ``integrators``, ``rhp_poles``, ``fs``,
        ``delay_samples``.
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
    from ..design.loopshape import PrefilterGains

    fs, delay = law.fs, law.delay_samples
    f = default_grid(fs) if freq_hz is None else np.asarray(freq_hz, float)
    weights = model.alpha(x)
    ref = reference or GantryReference(model.at(x).M, PrefilterGains(), PrefilterGains(), 80.0)
    n_int = 2 + law.integrators  # rigid body + integrating channels
    K, Kd = law.response, law.response_discrete
    cases: dict[str, GantryCase | None] = {}
    G = model.frequency_response(f, x)
    cases["ideal"] = _gantry_case("ideal", f, G, 1.0, K(f), weights, ref, None, n_int, law.rhp_poles(False),
                                  gantry_extension(f, G, model, x, K))
    fd = _discrete_grid(f, fs)
    Gd = zoh_gantry(model, x, fs, fd)
    cases["ideal_discrete"] = _gantry_case("ideal_discrete", fd, Gd, delay_response(fd, delay, fs), Kd(fd), weights,
                                           ref, fs, n_int, law.rhp_poles(True),
                                           gantry_extension(fd, Gd, model, x, Kd, fs, delay, zoh_in_plant=True))
    if frf is None:
        cases["measured"] = cases["discrete"] = None
    else:
        fm, Gm = gantry_frf_matrix(frf)
        cases["measured"] = _gantry_case("measured", fm, Gm, 1.0, K(fm), weights, ref, None, n_int,
                                         law.rhp_poles(False), gantry_extension(fm, Gm, model, x, K))
        H = zoh_response(fm, fs) * delay_response(fm, delay, fs)
        cases["discrete"] = _gantry_case("discrete", fm, Gm, H, Kd(fm), weights, ref, fs, n_int, law.rhp_poles(True),
                                         gantry_extension(fm, Gm, model, x, Kd, fs, delay))
    return GantryAnalysis(cases)


# ------------------------------------------------------------------------------------- axis cases
@dataclass(frozen=True)
class AxisCase:
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


@dataclass(frozen=True)
class AxisAnalysis:
    """All cases of a loop-shaped axis; ``cases[name]`` is None when the case needs a missing FRF."""

    cases: dict = field(default_factory=dict)

    def to_dict(self) -> dict:
        """``{case: figures or None}``."""
        return {name: (c.to_dict() if c is not None else None) for name, c in self.cases.items()}


def _axis_case(name, f, G, H, C, ff, pre, rhp, extension=None) -> AxisCase:
    L = G * H * C
    S = 1.0 / (1.0 + L)
    tracking = G * H * (ff + C * pre) * S
    tracking_no_ff = L * S
    return AxisCase(name, f, L, S, tracking, tracking_no_ff, G * S,
                    analyze_loop(f, L, open_loop_rhp_poles=rhp, extension=extension))


def analyze_axis(design, frf: Frf | None = None, *, channel: str | None = None, freq_hz=None) -> AxisAnalysis:
    """Analyse a :class:`~feedtune.design.loopshape.LoopShapeDesign` in all cases.

    Parameters
    ----------
    design : LoopShapeDesign
    frf : Frf, optional
        Measured SISO position FRF [m/V]; by default the design's own FRF (if it was designed on one).
    channel : str, optional
        FRF channel when the FRF has several.
    freq_hz : array_like, optional
        Grid for the model cases [Hz].
    """
    from ..design.discretize import matched
    from ..design.loopshape import frf_at, prefilter_response, zoh_double_integrator

    fs, delay = design.fs, design.delay_samples
    f = default_grid(fs) if freq_hz is None else np.asarray(freq_hz, float)
    C, Cd = design.controller(), design.controller_discrete()
    ffc = design.feedforward()
    ffm = matched(ffc, fs)
    rhp_c = int(np.sum(C.poles.real > 1e-9))
    rhp_d = int(np.sum(np.abs(Cd.poles) > 1 + 1e-9))
    m = design.plant.mass

    def resp(fr, discrete):
        if discrete:
            ff = ffm.tf.freqresp(fr) * np.exp(2j * np.pi * fr * ffm.delay_samples / fs)
            return Cd.freqresp(fr), ff, prefilter_response(design.prefilter, design.prefilter_hz, fr, fs)
        return C.freqresp(fr), ffc.freqresp(fr), prefilter_response(design.prefilter, design.prefilter_hz, fr)

    def rigid(fr):
        return 1.0 / (m * (2j * np.pi * fr) ** 2)

    def extension(fr, G, discrete, zoh_in_plant=False):
        K = Cd if discrete else C

        def plant(fe):
            return rigid(fe) * zoh_response(fe, fs) if zoh_in_plant else rigid(fe)

        def loop(fe, g):
            h = delay_response(fe, delay, fs) * (1.0 if zoh_in_plant else zoh_response(fe, fs)) if discrete else 1.0
            return g * h * K.freqresp(fe)

        return model_extension(fr, G, plant, loop)

    cases: dict[str, AxisCase | None] = {}
    G = rigid(f)
    cases["ideal"] = _axis_case("ideal", f, G, 1.0, *resp(f, False), rhp_c, extension(f, G, False))
    fd = _discrete_grid(f, fs)
    Gd = zoh_double_integrator(m, fs, fd)
    cases["ideal_discrete"] = _axis_case("ideal_discrete", fd, Gd, delay_response(fd, delay, fs), *resp(fd, True),
                                         rhp_d, extension(fd, Gd, True, zoh_in_plant=True))
    meas = frf if frf is not None else design.plant.frf
    if meas is None:
        cases["measured"] = cases["discrete"] = None
    else:
        ch = channel or (design.plant.channel if meas is design.plant.frf else None)
        if ch is None:
            if len(meas.channels) != 1:
                raise DataError(f"{meas.source}: the FRF has channels {', '.join(meas.channels)}; choose one")
            ch = meas.channels[0]
        pos = meas.as_quantity("position")
        fm = pos.freq_hz[pos.freq_hz > 0]
        Gm = frf_at(meas, ch, fm)
        cases["measured"] = _axis_case("measured", fm, Gm, 1.0, *resp(fm, False), rhp_c, extension(fm, Gm, False))
        H = zoh_response(fm, fs) * delay_response(fm, delay, fs)
        cases["discrete"] = _axis_case("discrete", fm, Gm, H, *resp(fm, True), rhp_d, extension(fm, Gm, True))
    return AxisAnalysis(cases)


# ------------------------------------------------------------------------------------------- checks
def limit_violations(cases: dict, checked_case: str, *, ms_max: float | None = None,
                     pm_min_deg: float | None = None) -> list[str]:
    """Stability in every analysed case and the Ms / phase-margin limits in ``checked_case``.

    Parameters
    ----------
    cases : dict
        ``GantryAnalysis.to_dict()`` or ``AxisAnalysis.to_dict()``.
    checked_case : str
        The case the limits apply to (``discrete`` with an FRF, else ``ideal_discrete``).
    ms_max : float, optional
        Largest acceptable peak sensitivity [-] (``max sigma_max(S)`` for a gantry).
    pm_min_deg : float, optional
        Smallest acceptable |phase margin| [deg].
    """
    out = []
    for name, c in cases.items():
        if c is not None and not c["stable"]:
            out.append(f"closed loop is unstable in the {name} case ({c['nyquist_encirclements']} clockwise "
                       "encirclements)")
    c = cases.get(checked_case)
    if c is None:
        return out
    if ms_max is not None and c["ms"] > ms_max:
        out.append(f"peak sensitivity Ms = {c['ms']:.3g} at {c['ms_freq_hz']:.4g} Hz exceeds --ms-max {ms_max:g} "
                   f"({checked_case} case)")
    pm = c.get("phase_margin_deg")
    if pm_min_deg is not None and pm is not None and abs(pm) < pm_min_deg:
        out.append(f"phase margin {pm:.3g} deg is below --pm-min {pm_min_deg:g} deg ({checked_case} case)")
    return out


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
