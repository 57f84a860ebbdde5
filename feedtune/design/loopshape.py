"""Classical loop shaping of a direct-drive axis (thesis §4.4.1, eq. 4.17-4.20) and the shared gantry pieces.

The x axis of the gantry is a double integrator ``G_x = 1/(m_x s^2)`` [m/V] (or a measured SISO FRF). The
controller of eq. 4.18 is::

    C(s) = K (Ti s + 1)/s * prod_i (Td_i s + 1)/(s/a_i + 1) * F(s)

* ``Ti`` gives the integral part a phase lag ``pi_lag_deg`` at the crossover: ``Ti = 1/(wc tan(lag))``.
* The lead needed at the crossover ``wc`` (eq. 4.17) is ``phi = -180 + PM - angle(G F ZOH delay PI)(j wc)``;
  it is split into ``ceil(phi / max_stage_deg)`` equal stages centred at ``wc`` (a single stage gives less
  than 90 deg). Each stage has the thesis' lead ratio ``gamma = sqrt((1 + sin phi_i)/(1 - sin phi_i))``:
  zero at ``wc / gamma``, pole at ``a = gamma wc`` (126 deg -> two stages of 63 deg, gamma = 4.2).
* ``F(s)`` is the filter pack (notches, low-pass, extra leads: :class:`FilterPack`).
* ``K`` makes ``|L(j wc)| = 1``.

The phase of the filters, of the zero-order hold and of the computational delay, and the distortion of the
pole-zero-matched controller, are all counted: the lead and the gain are iterated on the *discrete* loop
(ZOH-discretized model or measured FRF x ZOH x delay, with the matched controller) until the crossover and
phase margin hold there. Feedforward is ``u_ff = m_x x_r''`` (eq. 4.19) and the trajectory pre-filter
(eq. 4.20) ``x_r' = x_r + sum_n k_n s^n G_lpf^(n+1) x_r`` with ``G_lpf = w_f/(s + w_f)`` (80 Hz in the
thesis) for ``n = 1..4`` (velocity, acceleration, jerk, snap).

Optionally an identified friction model (eq. 2.1 and its viscous term, command unit and m/s) is fed forward from the
reference velocity ``v_r = (x_r[k+P] - x_r[k+P-1]) fs`` (0 on the first sample), linear through zero inside a small
band, as on the ball screw (:mod:`feedtune.control.friction`, :meth:`LoopShapeDesign.with_friction`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from functools import cached_property, lru_cache

import numpy as np

from ..control.axis import AxisLaw
from ..control.discretize import check_sampling, matched, matched_stages_response
from ..control.filters import (
    TWO_PI,
    FilterPack,
    LeadStage,
    _positive,
    split_lead,
)
from ..control.friction import FrictionFeedforward, friction_feedforward
from ..control.prefilter import (
    PrefilterGains,
)
from ..errors import DataError, DesignError, UsageError
from ..frf import Frf
from ..lti import Zpk, delay_response, zoh_double_integrator


# ----------------------------------------------------------------------------------------- x-axis plant
@dataclass(frozen=True)
class AxisPlant:
    """The plant of a loop-shaped axis: a double integrator ``1/(m s^2)`` and/or a measured position FRF.

    Attributes
    ----------
    mass : float
        Control-signal equivalent mass [U/(m/s^2)] (feedforward, ideal analysis cases; design plant
        when there is no FRF), U the command unit.
    frf : Frf or None
        Measured SISO position FRF [m/U]; when given, the design uses it.
    channel : str or None
        The FRF channel used (``"OUT/IN"``).
    source : str
        Where the plant came from (for the gains file).
    mass_method : str
        ``"given"`` or how the mass was estimated from the FRF.
    command_unit : str
        The drive's command unit U (V, A, N, %): from the FRF's input or the model's command.
    """

    mass: float
    frf: Frf | None = None
    channel: str | None = None
    source: str = "double integrator"
    mass_method: str = "given"
    command_unit: str = "V"

    def response(self, freq_hz) -> np.ndarray:
        """Continuous plant response [m/V] on a grid [Hz]: the FRF (interpolated as :func:`frf_at`) or
        ``1/(m s^2)``."""
        f = np.asarray(freq_hz, float)
        if self.frf is None:
            return 1.0 / (self.mass * (TWO_PI * 1j * f) ** 2)
        return self._interpolate(f)

    @cached_property
    def _interpolate(self):
        """:func:`frf_at` of the plant's channel with its tables made once (a search designs at hundreds of
        crossovers)."""
        return FrfInterpolator(self.frf, self.channel)

    def to_dict(self) -> dict:
        """Description with units."""
        return {"kind": "axis", "mass": self.mass, "frf": None if self.frf is None else self.frf.source,
                "channel": self.channel, "source": self.source, "mass_method": self.mass_method,
                "command_unit": self.command_unit, "units": {"mass": f"{self.command_unit}/(m/s^2)"}}


def frf_at(frf: Frf, channel: str, freq_hz: np.ndarray) -> np.ndarray:
    """Position FRF channel interpolated at ``freq_hz`` (log-frequency, magnitude and unwrapped phase)."""
    return FrfInterpolator(frf, channel)(freq_hz)


class FrfInterpolator:
    """:func:`frf_at` of one FRF channel at any frequencies [Hz], its tables (log frequency, log magnitude and
    unwrapped phase of the lines) made once (a search designs at hundreds of crossovers); a plain value (pickled with
    the designs that keep it)."""

    def __init__(self, frf: Frf, channel: str) -> None:
        pos = frf.as_quantity("position")
        keep = pos.freq_hz > 0
        fg, h = pos.freq_hz[keep], pos.channel(channel)[keep]
        self.source = frf.source
        self.lines_hz = fg
        self.log_f = np.log(fg)
        self.log_mag = np.log(np.abs(h))
        self.phase = np.unwrap(np.angle(h))

    def __call__(self, freq_hz) -> np.ndarray:
        fg = self.lines_hz
        f = np.asarray(freq_hz, float)
        if np.any(f < fg[0] * (1 - 1e-9)) or np.any(f > fg[-1] * (1 + 1e-9)):
            raise DataError(f"{self.source}: the FRF covers {fg[0]:g}-{fg[-1]:g} Hz; {f.min():g}-{f.max():g} Hz "
                            "needed")
        mag = np.interp(np.log(f), self.log_f, self.log_mag)
        ph = np.interp(np.log(f), self.log_f, self.phase)
        return np.exp(mag + 1j * ph)


def axis_plant(plant, *, mass: float | None = None, channel: str | None = None,
               crossover_hz: float | None = None) -> AxisPlant:
    """Normalise what a user gives as the x-axis plant.

    Parameters
    ----------
    plant : float, GantryModel, model with ``mass`` or ``m_x``, Frf, or AxisPlant
        A mass [V/(m/s^2)], a gantry model (its ``m_x``), a rigid-body model (its ``mass``) or a measured
        SISO FRF.
    mass : float, optional
        Mass [V/(m/s^2)] overriding the model's or the FRF estimate.
    channel : str, optional
        FRF channel ``"OUT/IN"`` when the FRF has several.
    crossover_hz : float, optional
        With an FRF and no ``mass``: the mass is estimated from the accelerance below ``crossover_hz/3``.
    """
    if isinstance(plant, AxisPlant):
        return plant
    if isinstance(plant, Frf):
        ch = channel
        if ch is None:
            if len(plant.channels) != 1:
                raise UsageError(f"{plant.source}: the FRF has channels {', '.join(plant.channels)}; "
                                 "choose one with channel=OUT/IN", parameter="channel")
            ch = plant.channels[0]
        elif not plant.has(ch):
            raise DataError(f"{plant.source}: no channel {ch!r}; available: {', '.join(plant.channels)}")
        unit = plant.input_unit
        if mass is not None:
            return AxisPlant(_positive(mass, f"mass [{unit}/(m/s^2)]", parameter="mass"), plant, ch, plant.source,
                             "given", unit)
        m, how = _mass_from_frf(plant, ch, crossover_hz)
        return AxisPlant(m, plant, ch, plant.source, how, unit)
    if mass is not None:
        return AxisPlant(_positive(mass, "mass [command unit/(m/s^2)]", parameter="mass"), source="given mass",
                         command_unit=_command_unit_of(plant))
    if isinstance(plant, (int, float)) and not isinstance(plant, bool):
        return AxisPlant(_positive(plant, "x-axis mass [V/(m/s^2)]"), source="given mass")
    if getattr(plant, "position_unit", "m") != "m":
        raise DataError(f"the x-axis plant must be a linear axis in m; this {type(plant).__name__} is in "
                        f"{plant.position_unit}")
    unit = _command_unit_of(plant)
    for attr in ("m_x", "mass"):
        if hasattr(plant, attr):
            return AxisPlant(_positive(getattr(plant, attr), f"model {attr} [{unit}/(m/s^2)]"),
                             source=f"{type(plant).__name__}.{attr}", command_unit=unit)
    raise DataError(f"cannot use a {type(plant).__name__} as the x-axis plant; give a mass, a gantry or "
                    "rigid-body model, or a measured FRF")


def _command_unit_of(model) -> str:
    """The command unit of a model (a rigid-body model's ``command_unit``, a gantry model's ``input_unit``; V for
    a bare mass)."""
    return str(getattr(model, "command_unit", None) or getattr(model, "input_unit", None) or "V")


def _mass_from_frf(frf: Frf, channel: str, crossover_hz: float | None) -> tuple[float, str]:
    """Median of ``1/|accelerance|`` over the low-frequency part of the FRF (thesis §4.3.1)."""
    acc = frf.as_quantity("acceleration")
    f = acc.freq_hz
    hi = (crossover_hz / 3.0) if crossover_hz else f[f > 0][0] * 10.0
    sel = (f > 0) & (f <= hi)
    if sel.sum() < 3:
        sel = (f > 0) & (np.arange(f.size) < np.flatnonzero(f > 0)[0] + 5)
    m = float(np.median(1.0 / np.abs(acc.channel(channel)[sel])))
    if not (math.isfinite(m) and m > 0):
        raise DataError(f"{frf.source}: cannot estimate the mass from the low-frequency accelerance; give mass=",
                        parameter="mass")
    return m, f"median of 1/|accelerance| over {f[sel][0]:.3g}-{f[sel][-1]:.3g} Hz"


# --------------------------------------------------------------------------------------- the x-axis design
@dataclass(frozen=True)
class LoopShapeDesign:
    """A loop-shaped axis controller (eq. 4.18) with feedforward (4.19) and pre-filter (4.20).

    Attributes
    ----------
    plant : AxisPlant
    crossover_hz, pm_deg, pi_lag_deg : float
        Design targets [Hz, deg, deg].
    gain : float
        ``K`` [V/(m s)].
    ti_s : float
        Integral time ``Ti`` [s].
    lead_stages : tuple of LeadStage
        The lead stages centred at the crossover.
    filters : FilterPack
    fs : float
        Sample rate [Hz].
    delay_samples : int
        Computational delay [samples].
    prefilter : PrefilterGains
    prefilter_hz : float
        Pre-filter low-pass frequency [Hz].
    iterations : int
        Lead/gain iterations on the discrete loop.
    max_stage_deg : float
        Largest phase of one lead stage [deg].
    tuning : dict
        How the targets were chosen (:func:`feedtune.tune.loopshape.tune_loopshape`); empty when given.
    friction : FrictionFeedforward or None
        Stribeck friction feedforward from the reference velocity [command unit, m/s] (:meth:`with_friction`).
    """

    plant: AxisPlant
    crossover_hz: float
    pm_deg: float
    pi_lag_deg: float
    gain: float
    ti_s: float
    lead_stages: tuple
    filters: FilterPack
    fs: float
    delay_samples: int
    prefilter: PrefilterGains
    prefilter_hz: float
    iterations: int
    max_stage_deg: float = 70.0
    tuning: dict = field(default_factory=dict)
    friction: FrictionFeedforward | None = None

    kind = "loopshape"

    def with_friction(self, friction, *, v_band: float | None = None, where: str = "friction model",
                      plant_where: str | None = None) -> LoopShapeDesign:
        """A copy with a Stribeck friction feedforward (replacing any; ``None`` removes it).

        Parameters
        ----------
        friction : StribeckFriction, FrictionLaw or None
            Identified model (``feedtune identify friction``): levels in the plant's command unit, velocities in
            m/s. A ``stribeck`` law is fed forward without its viscous term.
        v_band : float, optional
            Half-width of the linear band around zero velocity [m/s]; default 0.1 x the smaller Stribeck velocity.
        where : str
            Name of the friction model for messages.
        plant_where : str, optional
            Name of the plant's file for messages (default: the plant's source).

        Raises
        ------
        DataError
            The model's levels are not in the plant's command unit, or its velocities are not in m/s.
        UsageError
            ``v_band`` not > 0.
        """
        if friction is None:
            return replace(self, friction=None)
        ff = friction_feedforward(friction, command_unit=self.plant.command_unit, lead_m_per_rad=None,
                                  v_band=v_band, where=where, command_where=plant_where or self.plant.source)
        return replace(self, friction=ff)

    @cached_property
    def law(self) -> AxisLaw:
        """The control law alone (what runtimes, analyses and gains files need); made once per design."""
        return AxisLaw(self.plant.mass, self.gain, self.ti_s, tuple(self.lead_stages), self.filters, self.fs,
                       self.delay_samples, self.prefilter, self.prefilter_hz)

    @property
    def lead_deg(self) -> float:
        """Total phase lead of the stages at the crossover [deg]."""
        return self.law.lead_deg

    def pi_zpk(self) -> Zpk:
        """``(Ti s + 1)/s``."""
        return self.law.pi_zpk()

    def controller(self) -> Zpk:
        """Continuous ``C(s)`` [V/m] of eq. 4.18 including the filter pack."""
        return self.law.controller()

    def controller_discrete(self) -> Zpk:
        """Pole-zero-matched ``C(z)`` at ``fs``."""
        return self.law.controller_discrete()

    def feedforward(self) -> Zpk:
        """``m_x s^2`` [V/m] (eq. 4.19)."""
        return self.law.feedforward()

    @property
    def preview_samples(self) -> int:
        """Reference look-ahead of the discrete feedforward [samples]."""
        return self.law.preview_samples

    def design_dict(self) -> dict:
        """Design parameters and results with units in the keys."""
        return {
            "method": "loop shaping (thesis eq. 4.17-4.18), iterated on the discrete loop",
            "crossover_hz": self.crossover_hz,
            "pm_deg": self.pm_deg,
            "pi_lag_deg": self.pi_lag_deg,
            "max_stage_deg": self.max_stage_deg,
            "lead_deg": self.lead_deg,
            "lead_stages": [s.to_dict() for s in self.lead_stages],
            "gain_V_per_m_s": self.gain,
            "ti_s": self.ti_s,
            "iterations": self.iterations,
            "plant": self.plant.to_dict(),
            "prefilter_hz": self.prefilter_hz,
            "checked_case": "discrete" if self.plant.frf is not None else "ideal_discrete",
            **({"tuning": self.tuning} if self.tuning else {}),
        }


def design_plant_response(plant: AxisPlant, fs: float, delay_samples: int, freq_hz) -> np.ndarray:
    """The plant as the discrete controller sees it [m/V]: ZOH model or FRF x ZOH, times the delay."""
    from ..lti import zoh_response

    f = np.asarray(freq_hz, float)
    if plant.frf is None:
        g = zoh_double_integrator(plant.mass, fs, f)
    else:
        g = plant.response(f) * zoh_response(f, fs)
    return g * delay_response(f, delay_samples, fs)


@lru_cache(maxsize=32)
def matched_pack(pack: FilterPack, fs: float) -> Zpk:
    """The pole-zero-matched filter pack ``matched(pack.zpk(), fs).tf``, made once per pack and rate [Hz] (a search
    designs hundreds of controllers with one pack; the result is shared: do not modify it)."""
    return matched(pack.zpk(), fs).tf


def _matched_pi_pack_at(ti_s: float, pack: FilterPack, fs: float, f_hz: float) -> complex:
    """``matched((Ti s + 1)/s * pack)`` at ``f_hz`` [Hz] as the product of the matched parts: :func:`matched` maps
    every root on its own and matches the gain at 0 Hz (the integrator's factor removed), which for these parts is
    the product of their own gains, so the matched PI is ``T / (1 - e^(-T/Ti)) (z - e^(-T/Ti)) / (z - 1)`` (equal to
    ``matched`` of the whole to rounding, as :func:`~feedtune.control.discretize.matched_stages_response`)."""
    T = 1.0 / fs
    zd = math.exp(-T / ti_s)
    z = complex(np.exp(2j * np.pi * f_hz * T))
    return T / (1.0 - zd) * (z - zd) / (z - 1.0) * complex(matched_pack(pack, fs).freqresp([f_hz])[0])


def wrap_deg(a):
    """Angle [deg] wrapped to (-180, 180]."""
    return -((-np.asarray(a, float) + 180.0) % 360.0 - 180.0)


def design_loopshape(
    plant,
    *,
    crossover_hz: float,
    pm_deg: float,
    pi_lag_deg: float = 10.0,
    filters: FilterPack | None = None,
    fs: float = 15000.0,
    delay_samples: int = 1,
    max_stage_deg: float = 70.0,
    prefilter: PrefilterGains | None = None,
    prefilter_hz: float = 80.0,
    mass: float | None = None,
    channel: str | None = None,
    stages: int | None = None,
    friction=None,
    friction_band: float | None = None,
) -> LoopShapeDesign:
    """Double-lead-and-integral loop shaping of an axis (thesis eq. 4.17-4.18), see the module docstring.

    Parameters
    ----------
    plant : float, GantryModel, rigid-body model, Frf or AxisPlant
        The axis: a mass [V/(m/s^2)] (double integrator) or a measured SISO position FRF [m/V].
    crossover_hz : float
        Crossover frequency [Hz] of the discrete loop.
    pm_deg : float
        Phase margin at the crossover [deg].
    pi_lag_deg : float
        Phase lag of ``(Ti s + 1)/(Ti s)`` at the crossover [deg]; 0 for no integral action is not allowed.
    filters : FilterPack, optional
        Filter pack (notches, low-pass, extra leads).
    fs : float
        Sample rate [Hz].
    delay_samples : int
        Computational delay [samples].
    max_stage_deg : float
        Largest phase of one lead stage [deg].
    prefilter : PrefilterGains, optional
        Pre-filter gains (eq. 4.20); zeros by default.
    prefilter_hz : float
        Pre-filter low-pass frequency [Hz].
    mass : float, optional
        Mass [V/(m/s^2)] overriding the model's (or the FRF estimate).
    channel : str, optional
        FRF channel when the FRF has several.
    stages : int, optional
        Number of equal lead stages (each below 90 deg); default ``ceil(lead / max_stage_deg)``.
    friction : StribeckFriction or FrictionLaw, optional
        Friction model to feed forward from the reference velocity (:meth:`LoopShapeDesign.with_friction`):
        levels in the plant's command unit, velocities in m/s.
    friction_band : float, optional
        Half-width of the friction feedforward's linear band around zero velocity [m/s].

    Returns
    -------
    LoopShapeDesign

    Raises
    ------
    UsageError
        Invalid parameters (crossover above the Nyquist frequency, PM outside (0, 90) ...).
    DesignError
        The iteration did not converge (e.g. the required lead exceeds what the stages can give).
    """
    check_sampling(fs, delay_samples)
    wc_hz = _positive(crossover_hz, "crossover_hz", parameter="crossover_hz")
    if wc_hz >= fs / 2:
        raise UsageError(f"crossover_hz {wc_hz:g} must be below the Nyquist frequency {fs / 2:g} Hz",
                         parameter="crossover_hz")
    if not 0 < pm_deg < 90:
        raise UsageError(f"pm_deg must lie in (0, 90) deg, got {pm_deg}", parameter="pm_deg")
    if not 0 < pi_lag_deg < 45:
        raise UsageError(f"pi_lag_deg must lie in (0, 45) deg, got {pi_lag_deg}", parameter="pi_lag_deg")
    if stages is not None and (isinstance(stages, bool) or int(stages) != stages or stages < 1):
        raise UsageError(f"the number of lead stages must be an integer >= 1, got {stages!r}")
    pack = filters if filters is not None else FilterPack()
    pack.check_nyquist(fs)
    ap = axis_plant(plant, mass=mass, channel=channel, crossover_hz=wc_hz)
    wc = TWO_PI * wc_hz
    ti = 1.0 / (wc * math.tan(math.radians(pi_lag_deg)))
    base = LoopShapeDesign(ap, wc_hz, float(pm_deg), float(pi_lag_deg), 1.0, ti, (), pack, float(fs),
                           int(delay_samples), prefilter or PrefilterGains(), float(prefilter_hz), 0,
                           float(max_stage_deg))
    p_c = design_plant_response(ap, fs, delay_samples, [wc_hz])[0]
    target = -180.0 + pm_deg
    other = p_c * _matched_pi_pack_at(ti, pack, float(fs), wc_hz)  # matched, K = 1, no lead
    lead = float(wrap_deg(target - np.angle(other, deg=True)))
    # the matched transform maps each root on its own and matches the gain at 0 Hz, so the discrete controller is
    # the product of the matched parts: the loop at the crossover is ``other`` times the matched lead stages there
    for it in range(1, 31):
        if stages is None:
            split = split_lead(lead, max_stage_deg)
        elif abs(lead) / stages >= 89.9:
            raise DesignError(f"loop shaping needs {lead:.0f} deg of lead at {wc_hz:g} Hz, more than {stages} "
                              "stage(s) can give")
        else:
            split = [lead / stages] * int(stages)
        lead_stages = tuple(LeadStage(wc_hz, p) for p in split)
        loop = other * matched_stages_response(lead_stages, fs, [wc_hz])[0]
        err = float(wrap_deg(target - np.angle(loop, deg=True)))
        if abs(err) < 1e-6:
            design = replace(base, lead_stages=lead_stages, gain=float(1.0 / abs(loop)), iterations=it)
            break
        lead += err
        if abs(lead) >= 90.0 * 4:
            raise DesignError(f"loop shaping needs more than {lead:.0f} deg of lead at {wc_hz:g} Hz; "
                              "lower crossover_hz or pm_deg, or change the filters",
                              parameter=("crossover_hz", "pm_deg"))
    else:
        raise DesignError(f"loop shaping did not converge at {wc_hz:g} Hz (phase error {err:.3g} deg)")
    if friction is not None:
        design = design.with_friction(friction, v_band=friction_band)
    return design

