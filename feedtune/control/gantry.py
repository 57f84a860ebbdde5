"""Gantry laws (thesis section 4.4.2): the MIMO law of eq. 4.30, independent PIDs, the schedule tables in the table
position and the reference path (feedforward, per-side pre-filters) at one position."""

from __future__ import annotations

from dataclasses import dataclass, replace
from functools import cached_property

import numpy as np

from ..lti import Zpk
from .discretize import backward_difference, backward_euler_integrator, matched
from .filters import TWO_PI, FilterPack
from .prefilter import PrefilterGains, prefilter_response


# -------------------------------------------------------------------------------------- the law
def _s_values(freq_hz) -> np.ndarray:
    return TWO_PI * 1j * np.asarray(freq_hz, float)


@dataclass(frozen=True)
class MimoLaw:
    """The feedback law of eq. 4.30 at one table position.

    Attributes
    ----------
    alpha : (float, float)
        Mass distribution used for averaging [-].
    lead_gain : float
        ``K_D`` [V/m].
    lead_stages : tuple of LeadStage
        Stages of ``D(s)``.
    beta : float
        Active damping gain [V/(m/s)].
    ki : float
        Actuator-level integral gain [V/(m s)].
    filters : FilterPack
        ``h(s)``.
    fs : float
        Sample rate [Hz].
    delay_samples : int
        Computational delay [samples].
    """

    alpha: tuple
    lead_gain: float
    lead_stages: tuple
    beta: float
    ki: float
    filters: FilterPack
    fs: float
    delay_samples: int = 1

    controller = "mimo"

    @cached_property
    def _zpk(self) -> dict[str, Zpk]:
        """The law's transfer functions, computed once (the analysis evaluates them many times)."""
        d = Zpk.constant(self.lead_gain)
        for s in self.lead_stages:
            d = d * s.zpk()
        h = self.filters.zpk()
        return {"lead": d, "lead_discrete": matched(d, self.fs).tf, "h": h, "h_discrete": matched(h, self.fs).tf,
                "diff": backward_difference(self.fs), "integ": backward_euler_integrator(self.fs)}

    def lead(self) -> Zpk:
        """Continuous ``D(s)`` [V/m]."""
        return self._zpk["lead"]

    def lead_discrete(self) -> Zpk:
        """Matched ``D(z)``."""
        return self._zpk["lead_discrete"]

    def filter_pack_discrete(self) -> Zpk:
        """Matched ``h(z)``."""
        return self._zpk["h_discrete"]

    @property
    def integrators(self) -> int:
        """Controller poles at the origin (one per channel with integral action)."""
        return 2 if self.ki != 0 else 0

    def _assemble(self, h, d, deriv, integ) -> np.ndarray:
        a1, a2 = self.alpha
        n = h.size
        K = np.empty((2, 2, n), complex)
        b = self.beta * deriv
        i = self.ki * integ
        K[0, 0] = a1 * (d * a1 + b + i)
        K[0, 1] = a1 * (d * a2 - b)
        K[1, 0] = a2 * (d * a1 - b)
        K[1, 1] = a2 * (d * a2 + b + i)
        return K * h

    def response(self, freq_hz) -> np.ndarray:
        """Continuous ``K(j w)`` [V/m], shape ``(2, 2, n)``."""
        f = np.asarray(freq_hz, float)
        s = _s_values(f)
        with np.errstate(divide="ignore", invalid="ignore"):
            return self._assemble(self._zpk["h"].freqresp(f), self.lead().freqresp(f), s, 1.0 / s)

    def response_discrete(self, freq_hz) -> np.ndarray:
        """Discrete ``K(e^{j w T})`` [V/m] (backward difference and backward-Euler integral)."""
        h = self.filter_pack_discrete()
        z = h.variable(freq_hz)  # every part has the sample time 1/fs: z once for all
        with np.errstate(divide="ignore", invalid="ignore"):
            return self._assemble(h.evaluate(z), self.lead_discrete().evaluate(z), self._zpk["diff"].evaluate(z),
                                  self._zpk["integ"].evaluate(z))

    def rhp_poles(self, discrete: bool) -> int:
        """Controller poles in the right half plane (outside the unit circle)."""
        zs = (self.filter_pack_discrete(), self.lead_discrete()) if discrete else (self._zpk["h"], self.lead())
        if discrete:
            return int(sum(np.sum(np.abs(z.poles) > 1 + 1e-9) for z in zs))
        return int(sum(np.sum(z.poles.real > 1e-9) for z in zs))

    def to_dict(self) -> dict:
        """Gains and filters with units."""
        return {"controller": "mimo", "alpha": list(self.alpha), "lead_gain_V_per_m": self.lead_gain,
                "lead_stages": [s.to_dict() for s in self.lead_stages], "beta_V_per_m_s": self.beta,
                "ki_V_per_m_s": self.ki, "filters": self.filters.to_dict(), "fs_hz": self.fs,
                "delay_samples": self.delay_samples}


# ---------------------------------------------------------------------------------------- schedule
@dataclass(frozen=True)
class GantrySchedule:
    """Tables over the table position for eq. 4.33 (linear interpolation, clamped at the ends).

    Attributes
    ----------
    x : ndarray
        Table positions [m], strictly increasing.
    alpha1, alpha2 : ndarray
        Mass distribution [-].
    m11, m12, m22 : ndarray
        Feedforward mass matrix ``M(x)`` [V/(m/s^2)] (eq. 4.31).
    prefilter1, prefilter2 : ndarray, shape (n_x, 4)
        Per-side pre-filter gains ``k_vel, k_acc, k_jerk, k_snap`` [s, s^2, s^3, s^4] (eq. 4.32).
    """

    x: np.ndarray
    alpha1: np.ndarray
    alpha2: np.ndarray
    m11: np.ndarray
    m12: np.ndarray
    m22: np.ndarray
    prefilter1: np.ndarray
    prefilter2: np.ndarray

    def table(self) -> np.ndarray:
        """Rows ``alpha1, alpha2, m11, m12, m22, k_*_1, k_*_2``, shape ``(n_x, 13)``."""
        return np.column_stack([self.alpha1, self.alpha2, self.m11, self.m12, self.m22,
                                self.prefilter1, self.prefilter2])

    def at(self, x: float) -> np.ndarray:
        """One interpolated row at ``x`` [m]."""
        return np.array([np.interp(x, self.x, col) for col in self.table().T])

    def alpha(self, x: float) -> tuple[float, float]:
        """Mass distribution ``(alpha1, alpha2)`` [-] interpolated at ``x`` [m] (clamped at the ends)."""
        return float(np.interp(x, self.x, self.alpha1)), float(np.interp(x, self.x, self.alpha2))

    def mass_matrix(self, x: float) -> np.ndarray:
        """``M(x)`` [V/(m/s^2)] interpolated."""
        r = self.at(x)
        return np.array([[r[2], r[3]], [r[3], r[4]]])

    def prefilters(self, x: float) -> tuple[PrefilterGains, PrefilterGains]:
        """Per-side pre-filter gains at ``x``."""
        r = self.at(x)
        return PrefilterGains(*r[5:9]), PrefilterGains(*r[9:13])


def law_at(law, schedule: GantrySchedule, x: float):
    """The feedback law the target runs at table position ``x`` [m]: a MIMO law with the schedule's averaging
    weights ``alpha(x)`` (eq. 4.33); a PID law as it is (its gains are not scheduled)."""
    if getattr(law, "controller", None) == "mimo":
        return replace(law, alpha=schedule.alpha(x))
    return law


@dataclass(frozen=True)
class PidLaw:
    """One PID per side behind the filter pack (module docstring).

    Attributes
    ----------
    kp, kd, ki : (float, float)
        Per-side gains [V/m, V/(m/s), V/(m s)].
    filters : FilterPack
    fs : float
        Sample rate [Hz].
    delay_samples : int
    """

    kp: tuple
    kd: tuple
    ki: tuple
    filters: FilterPack
    fs: float
    delay_samples: int = 1

    controller = "pid"

    @cached_property
    def _zpk(self) -> dict:
        """The law's transfer functions, computed once (the analysis evaluates them many times)."""
        h = self.filters.zpk()
        return {"h": h, "h_discrete": matched(h, self.fs).tf, "diff": backward_difference(self.fs),
                "integ": backward_euler_integrator(self.fs)}

    def filter_pack_discrete(self):
        """Matched ``h(z)``."""
        return self._zpk["h_discrete"]

    @property
    def integrators(self) -> int:
        """Controller poles at the origin."""
        return int(sum(1 for k in self.ki if k != 0))

    def _assemble(self, h, deriv, integ) -> np.ndarray:
        K = np.zeros((2, 2, h.size), complex)
        for i in range(2):  # two sides
            K[i, i] = h * (self.kp[i] + self.kd[i] * deriv + self.ki[i] * integ)
        return K

    def response(self, freq_hz) -> np.ndarray:
        """Continuous ``K(j w)`` [V/m], shape ``(2, 2, n)``."""
        f = np.asarray(freq_hz, float)
        s = TWO_PI * 1j * f
        with np.errstate(divide="ignore", invalid="ignore"):
            return self._assemble(self._zpk["h"].freqresp(f), s, 1.0 / s)

    def response_discrete(self, freq_hz) -> np.ndarray:
        """Discrete ``K(e^{j w T})`` [V/m] (backward difference, backward-Euler integral)."""
        h = self.filter_pack_discrete()
        z = h.variable(freq_hz)  # every part has the sample time 1/fs: z once for all
        with np.errstate(divide="ignore", invalid="ignore"):
            return self._assemble(h.evaluate(z), self._zpk["diff"].evaluate(z), self._zpk["integ"].evaluate(z))

    def rhp_poles(self, discrete: bool) -> int:
        """Controller poles in the right half plane (outside the unit circle)."""
        if discrete:
            return int(np.sum(np.abs(self.filter_pack_discrete().poles) > 1 + 1e-9))
        return int(np.sum(self._zpk["h"].poles.real > 1e-9))

    def to_dict(self) -> dict:
        """Gains with units."""
        return {"controller": "pid", "kp_V_per_m": list(self.kp), "kd_V_per_m_s": list(self.kd),
                "ki_V_per_m_s": list(self.ki), "filters": self.filters.to_dict(), "fs_hz": self.fs,
                "delay_samples": self.delay_samples}


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
