"""MIMO control of the linear-motor T-gantry (thesis §4.4.2, eq. 4.22-4.33).

Sensor averaging ``ybar = alpha1 y1 + alpha2 y2`` (eq. 4.23) and actuator averaging ``f_i = alpha_i f_T``
turn the 2x2 plant into ``Gbar = alpha^T G alpha = 1/(m s^2)`` whatever the yaw mode (eq. 4.24), because
``alpha^T [-a1, a2]^T = 0``. The feedback law of eq. 4.30 is::

    K(s) = h(s) diag(alpha) { [1, 1]^T D(s) [alpha1, alpha2] + beta [[1, -1], [-1, 1]] s + (ki/s) I }

* ``D(s) = K_D prod_i (Td_i s + 1)/(s/a_i + 1)`` (eq. 4.26, usually one stage) makes the CoM loop
  ``h (D + ki/s) / (m s^2)`` cross over at ``crossover_hz`` with phase margin ``pm_deg`` on the discrete
  loop (ZOH, delay and the matched filters counted, like :func:`feedtune.design.loopshape.design_loopshape`).
* Active damping (eq. 4.27-4.28) adds ``2 a1 a2 beta`` to the torsional damping ``c``:
  ``beta = damping_increase c / (2 a1 a2)`` at the design position.
* Actuator-level integral action (eq. 4.29) ``diag(alpha) ki/s`` on each side's error.
* ``h(s)`` is the filter pack (notches, low-pass, second lead).

Feedforward ``u_ff = M(x) [y_r1'', y_r2'']`` (eq. 4.31) and per-side pre-filters (eq. 4.32) use the tables of
:class:`GantrySchedule`, scheduled in the table position ``x`` (eq. 4.33).

Optionally an identified friction model of the gantry's travel (eq. 2.1 + viscous term, command unit, m/s) is fed
forward from the reference velocity ``v_r = (y_r[k+P] - y_r[k+P-1]) fs`` (0 on the first sample), linear through
zero inside a small band (:mod:`feedtune.control.friction`, :meth:`GantryMimoDesign.with_friction`). The friction
force ``d(v_r)`` of the moving gantry is split between the drives as the inertia feedforward splits a rigid
acceleration: ``M(x) [a, a]^T = a m [alpha1, alpha2]^T`` (the row sums of ``M(x)`` are ``alpha_i m``, eq. 4.3), so
``u_i += alpha_i(x) d(v_r)`` with ``alpha(x)`` from the schedule; the PID baseline splits it the same way.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from functools import lru_cache

import numpy as np

from ..control.discretize import backward_euler_integrator, check_sampling, matched_stages_response
from ..control.filters import TWO_PI, FilterPack, LeadStage, split_lead
from ..control.friction import FrictionFeedforward, friction_feedforward
from ..control.gantry import GantrySchedule, MimoLaw
from ..control.prefilter import PrefilterGains, preview_samples
from ..errors import DesignError, UsageError
from ..lti import zoh_double_integrator
from ..models.gantry import GantryModel
from .loopshape import matched_pack, wrap_deg


# ------------------------------------------------------------------------------------- averaging
def averaging_vectors(alpha) -> tuple[np.ndarray, np.ndarray]:
    """Sensor averaging row ``[alpha1, alpha2]`` and actuator averaging column ``[alpha1, alpha2]^T``."""
    a = np.asarray(alpha, float).reshape(2)
    return a.reshape(1, 2), a.reshape(2, 1)


def averaged_plant(model: GantryModel, x: float, freq_hz, alpha=None) -> np.ndarray:
    """``alpha^T G(x) alpha`` [m/V] on a grid [Hz] (eq. 4.24); equals ``1/(m s^2)`` when ``alpha = alpha(x)``.

    Parameters
    ----------
    model : GantryModel
    x : float
        Table position [m].
    freq_hz : array_like
        Grid [Hz], > 0.
    alpha : (float, float), optional
        The averaging weights; the model's ``alpha(x)`` by default.
    """
    a = np.asarray(model.alpha(x) if alpha is None else alpha, float)
    G = model.frequency_response(freq_hz, x)
    return np.einsum("i,ijn,j->n", a, G, a)


def damping_gain(model: GantryModel, damping_increase: float, x: float = 0.0) -> float:
    """``beta`` [V/(m/s)] that raises the torsional damping by ``damping_increase * c`` at ``x`` (eq. 4.28)."""
    if not (math.isfinite(damping_increase) and damping_increase >= 0):
        raise UsageError(f"damping_increase must be a number >= 0 (5.9 = +590 %), got {damping_increase}",
                         parameter="damping_increase")
    a1, a2 = model.arms(x)
    return float(damping_increase * model.c / (2.0 * a1 * a2))


def torsional_damping(model: GantryModel, beta: float, x: float = 0.0) -> float:
    """Torsional damping with active damping ``c + 2 a1 a2 beta`` [V m s] at ``x`` (eq. 4.28)."""
    a1, a2 = model.arms(x)
    return float(model.c + 2.0 * a1 * a2 * beta)







MAX_SCHEDULE_POINTS = 1001
"""Most positions of a gain schedule (rows of the tables in the gains file and the C header)."""


def default_x_grid(model: GantryModel, x_min: float = -0.3, x_max: float = 0.3, n: int = 13) -> np.ndarray:
    """Schedule grid [m]: ``n`` points over ``[x_min, x_max]`` (UsageError if alpha leaves (0, 1))."""
    if not (math.isfinite(x_min) and math.isfinite(x_max) and x_min < x_max):
        raise UsageError(f"schedule range must satisfy x_min < x_max [m], got {x_min:g}, {x_max:g}",
                         parameter=("x_min", "x_max"))
    if not 2 <= int(n) <= MAX_SCHEDULE_POINTS:
        raise UsageError(f"n={n}: the schedule needs 2 .. {MAX_SCHEDULE_POINTS} positions (each is a row of the "
                         "tables the controller holds; a finer table than 1 mm over a metre gains nothing)",
                         parameter="default_x_grid.n")
    grid = np.linspace(x_min, x_max, int(n))
    for xx in (x_min, x_max):
        model.alpha(xx)
    return grid


def gantry_schedule(model: GantryModel, x_grid, prefilter1: PrefilterGains | None = None,
                    prefilter2: PrefilterGains | None = None) -> GantrySchedule:
    """Tables of ``alpha(x)``, ``M(x)`` (eq. 4.3 at each x) and constant per-side pre-filter gains."""
    xs = np.asarray(x_grid, float)
    if xs.ndim != 1 or xs.size < 1 or np.any(np.diff(xs) <= 0):
        raise UsageError("schedule positions must be a strictly increasing list [m]")
    alphas = np.array([model.alpha(v) for v in xs])
    Ms = np.array([model.at(v).M for v in xs])
    p1 = np.tile((prefilter1 or PrefilterGains()).values(), (xs.size, 1))
    p2 = np.tile((prefilter2 or PrefilterGains()).values(), (xs.size, 1))
    return GantrySchedule(xs, alphas[:, 0], alphas[:, 1], Ms[:, 0, 0], Ms[:, 0, 1], Ms[:, 1, 1], p1, p2)


@lru_cache(maxsize=16)
def _schedule(model: GantryModel, x_grid: tuple, prefilter1, prefilter2) -> GantrySchedule:
    """:func:`gantry_schedule`, made once for equal arguments (a search designs hundreds of laws on one schedule;
    the schedule is a frozen value shared by those designs)."""
    return gantry_schedule(model, x_grid, prefilter1, prefilter2)


# ------------------------------------------------------------------------------ friction feedforward
def gantry_friction(model: GantryModel, friction, *, v_band: float | None = None, where: str = "friction model",
                    model_where: str = "the gantry model") -> FrictionFeedforward | None:
    """The friction feedforward of the gantry's travel (y), in the model's command unit and m/s (None for None).

    Parameters
    ----------
    model : GantryModel
        Its ``input_unit`` is the command unit the friction levels must be in.
    friction : StribeckFriction, FrictionLaw or None
        Identified model (``feedtune identify friction``) of the moving gantry: the total friction force of both
        drives [command unit] over the travel velocity [m/s]. A ``stribeck`` law is fed forward without its viscous
        term.
    v_band : float, optional
        Half-width of the linear band around zero velocity [m/s]; default 0.1 x the smaller Stribeck velocity.
    where, model_where : str
        Names of the friction model and of the gantry model's file for messages.

    Raises
    ------
    DataError
        The levels are not in the model's command unit, or the velocities not in m/s (message naming both).
    UsageError
        ``v_band`` not > 0.
    """
    if friction is None:
        return None
    return friction_feedforward(friction, command_unit=model.input_unit, lead_m_per_rad=None, v_band=v_band,
                                where=where, command_where=model_where)


# ----------------------------------------------------------------------------------------- design
@dataclass(frozen=True)
class GantryMimoDesign:
    """A gantry MIMO design (eq. 4.22-4.33).

    Attributes
    ----------
    model : GantryModel
    x : float
        Design table position [m].
    law : MimoLaw
    schedule : GantrySchedule
    crossover_hz, pm_deg : float
        CoM-loop targets [Hz, deg].
    damping_increase : float
        Requested increase of the torsional damping [-] (5.9 = +590 %).
    integral : str
        How ``ki`` was chosen.
    prefilter_hz : float
        Pre-filter low-pass [Hz].
    iterations : int
    extra : dict
        Further design records (tuning).
    friction : FrictionFeedforward or None
        Friction feedforward of the gantry's travel [command unit, m/s], split ``alpha1 : alpha2``
        (:meth:`with_friction`).
    """

    model: GantryModel
    x: float
    law: MimoLaw
    schedule: GantrySchedule
    crossover_hz: float
    pm_deg: float
    damping_increase: float
    integral: str
    prefilter_hz: float
    iterations: int
    extra: dict = field(default_factory=dict)
    friction: FrictionFeedforward | None = None

    kind = "gantry"
    controller = "mimo"

    def with_friction(self, friction, *, v_band: float | None = None, where: str = "friction model",
                      model_where: str = "the gantry model") -> GantryMimoDesign:
        """A copy with the friction feedforward of ``friction`` (replacing any; ``None`` removes it); see
        :func:`gantry_friction` for the parameters [command unit, m/s] and errors."""
        return replace(self, friction=gantry_friction(self.model, friction, v_band=v_band, where=where,
                                                      model_where=model_where))

    @property
    def fs(self) -> float:
        """Sample rate [Hz]."""
        return self.law.fs

    @property
    def delay_samples(self) -> int:
        """Computational delay [samples]."""
        return self.law.delay_samples

    @property
    def preview_samples(self) -> int:
        """Reference look-ahead [samples]."""
        return preview_samples(self.law.fs)

    @property
    def tuning(self) -> dict:
        """How a tuner chose the design (``extra["tuning"]``; empty for a design by hand)."""
        return dict(self.extra.get("tuning", {}))

    def design_dict(self) -> dict:
        """Design parameters and results, units in the keys."""
        a1, a2 = self.model.arms(self.x)
        return {
            "method": "sensor/actuator averaging, lead D(s), active damping, actuator-level integral (eq. 4.30)",
            "x_m": self.x,
            "crossover_hz": self.crossover_hz,
            "pm_deg": self.pm_deg,
            "damping_increase": self.damping_increase,
            "torsional_damping_V_m_s": self.model.c,
            "torsional_damping_with_active_damping_V_m_s": torsional_damping(self.model, self.law.beta, self.x),
            "arms_m": [a1, a2],
            "lead_gain_V_per_m": self.law.lead_gain,
            "lead_stages": [s.to_dict() for s in self.law.lead_stages],
            "integral": self.integral,
            "iterations": self.iterations,
            "prefilter_hz": self.prefilter_hz,
            "checked_case": "ideal_discrete",
            **self.extra,
        }


def _unit_magnitude_gain(A: complex, B: complex) -> float | None:
    """Largest ``K > 0`` with ``|K A + B| = 1`` (None if there is none)."""
    a = abs(A) ** 2
    b = 2.0 * (A * np.conj(B)).real
    c = abs(B) ** 2 - 1.0
    disc = b * b - 4 * a * c
    if a == 0 or disc < 0:
        return None
    k = (-b + math.sqrt(disc)) / (2 * a)
    return k if k > 0 else None


def design_gantry_mimo(
    model: GantryModel,
    *,
    crossover_hz: float = 60.0,
    pm_deg: float = 40.0,
    damping_increase: float = 5.9,
    ki: float | None = None,
    integral_lag_deg: float = 10.0,
    filters: FilterPack | None = None,
    fs: float = 15000.0,
    delay_samples: int = 1,
    x: float = 0.0,
    x_grid=None,
    prefilter1: PrefilterGains | None = None,
    prefilter2: PrefilterGains | None = None,
    prefilter_hz: float = 80.0,
    max_stage_deg: float = 70.0,
) -> GantryMimoDesign:
    """Design the gantry MIMO controller of eq. 4.30 at table position ``x`` (see the module docstring).

    Parameters
    ----------
    model : GantryModel
    crossover_hz : float
        Crossover of the CoM loop [Hz] (thesis: 60).
    pm_deg : float
        Phase margin of the CoM loop [deg] (thesis: 40).
    damping_increase : float
        Increase of the torsional damping by active damping [-] (thesis: 5.9 = +590 %).
    ki : float, optional
        Actuator-level integral gain [V/(m s)]. Default: ``ki = K_D wc tan(integral_lag_deg)``, so that the
        integral corner ``ki / K_D`` lies where a PI would lag ``integral_lag_deg`` at the crossover
        (the x-axis rule of eq. 4.17); 0 disables the integral.
    integral_lag_deg : float
        See ``ki`` [deg].
    filters : FilterPack, optional
        ``h(s)``: notches, low-pass, second lead.
    fs : float
        Sample rate [Hz] (thesis: 15 kHz).
    delay_samples : int
        Computational delay [samples].
    x : float
        Design table position [m] (alpha, beta and the lead are computed there).
    x_grid : array_like, optional
        Schedule positions [m]; default 13 points over -0.3..0.3 m.
    prefilter1, prefilter2 : PrefilterGains, optional
        Per-side pre-filter gains (eq. 4.32), constant over x.
    prefilter_hz : float
        Pre-filter low-pass frequency [Hz] (thesis: 80).
    max_stage_deg : float
        Largest phase of one stage of ``D(s)`` [deg].

    Raises
    ------
    UsageError
        Bad parameter. DesignError: the crossover cannot be reached with a positive gain.
    """
    check_sampling(fs, delay_samples)
    if not (math.isfinite(crossover_hz) and 0 < crossover_hz < fs / 2):
        raise UsageError(f"crossover_hz must lie between 0 and the Nyquist frequency {fs / 2:g} Hz, "
                         f"got {crossover_hz}", parameter="crossover_hz")
    if not 0 < pm_deg < 90:
        raise UsageError(f"pm_deg must lie in (0, 90) deg, got {pm_deg}", parameter="pm_deg")
    if ki is not None and not (math.isfinite(ki) and ki >= 0):
        raise UsageError(f"ki must be a gain >= 0 [V/(m s)], got {ki}", parameter="ki")
    if ki is None and not 0 < integral_lag_deg < 45:
        raise UsageError(f"integral lag must lie in (0, 45) deg, got {integral_lag_deg}")
    pack = filters or FilterPack()
    pack.check_nyquist(fs)
    alpha = model.alpha(x)
    beta = damping_gain(model, damping_increase, x)
    wc = TWO_PI * crossover_hz
    fc = [float(crossover_hz)]
    plant = zoh_double_integrator(model.m, fs, fc)[0] * np.exp(-1j * wc * delay_samples / fs)
    h = matched_pack(pack, float(fs)).freqresp(fc)[0]
    integ = backward_euler_integrator(fs).freqresp(fc)[0]
    ratio = wc * math.tan(math.radians(integral_lag_deg)) if ki is None else 0.0
    target = -180.0 + pm_deg

    def loop_parts(stages) -> tuple[complex, complex]:
        d = matched_stages_response(stages, fs, fc)[0]  # matched(D(s)) at the crossover, in closed form
        A = h * plant * (d + ratio * integ)
        B = 0.0 if ki is None else ki * h * plant * integ
        return A, B

    A0, B0 = loop_parts(())
    k0 = _unit_magnitude_gain(A0, B0)
    lead = float(wrap_deg(target - np.angle((k0 or 1.0) * A0 + B0, deg=True)))
    for count in range(1, 51):
        iterations = count
        stages = tuple(LeadStage(crossover_hz, p) for p in split_lead(lead, max_stage_deg))
        A, B = loop_parts(stages)
        k = _unit_magnitude_gain(A, B)
        if k is None:
            raise DesignError(f"the integral gain ki {ki:g} V/(m s) alone exceeds unit loop gain at "
                              f"{crossover_hz:g} Hz; lower ki or raise crossover_hz",
                              parameter=("ki", "crossover_hz"))
        err = float(wrap_deg(target - np.angle(k * A + B, deg=True)))
        if abs(err) < 1e-6:
            break
        lead += err
        if abs(lead) > 270:
            raise DesignError(f"the CoM loop needs {lead:.0f} deg of lead at {crossover_hz:g} Hz; lower "
                              "crossover_hz or pm_deg, or change the filter pack", parameter=("crossover_hz", "pm_deg"))
    else:
        raise DesignError(f"lead design did not converge at {crossover_hz:g} Hz (phase error {err:.3g} deg)")
    ki_value = float(ratio * k) if ki is None else float(ki)
    law = MimoLaw(tuple(float(a) for a in alpha), float(k), stages, beta, ki_value, pack, float(fs),
                  int(delay_samples))
    how = (f"ki = K_D wc tan({integral_lag_deg:g} deg)" if ki is None else "given")
    grid = np.asarray(default_x_grid(model) if x_grid is None else x_grid, float)
    schedule = (_schedule(model, tuple(grid.tolist()), prefilter1, prefilter2) if grid.ndim == 1
                else gantry_schedule(model, grid, prefilter1, prefilter2))
    return GantryMimoDesign(model, float(x), law, schedule,
                            float(crossover_hz), float(pm_deg), float(damping_increase), how, float(prefilter_hz),
                            iterations)


def with_beta(design: GantryMimoDesign, beta: float) -> GantryMimoDesign:
    """The same design with another active-damping gain [V/(m/s)] (e.g. 0 to see the loop without it)."""
    return replace(design, law=replace(design.law, beta=float(beta)))
