"""Independent SISO PID baseline for the gantry (thesis §4.4.2, Fig. 4.14-4.15: PIDs reached 16 Hz).

One PID per side behind a filter pack ``h(s)``; the thesis gave its PIDs "identical notch and low-pass
filters" to the MIMO design's (not the second lead, which serves the MIMO law's damping loop)::

    K(s) = h(s) diag(C_1(s), C_2(s)),   C_i(s) = kp_i + kd_i s + ki_i / s

The gains are proportional to the mass each side carries, ``m_i = alpha_i m`` (the usual way of making
both sides respond alike), and placed from a bandwidth ``w``: the closed loop of ``m_i s^2`` with ``C_i``
has the characteristic polynomial ``(s^2 + 2 zeta w s + w^2)(s + w/rho)``, i.e.
``kd_i = m_i w (2 zeta + 1/rho)``, ``kp_i = m_i w^2 (1 + 2 zeta/rho)``, ``ki_i = m_i w^3 / rho``.

:func:`tune_gantry_pid` finds, over the shapes ``zeta`` in (0.5, 0.7, 1.0) and ``rho`` in (1, 2, 4), the
largest ``w`` whose loop is MIMO-Nyquist stable with a peak sensitivity ``Ms = max_w sigma_max(S)`` (the
largest singular value of the 2x2 sensitivity, the same measure as for the MIMO design) at or below the
limit, and keeps the shape with the highest crossover of the CoM loop; shapes within ``SHAPE_TIE`` (10 %) of
that crossover count as equal and the one with the largest phase margin wins (the crossovers of the nine
shapes lie within about 8 % of each other, so without the tie rule a 0.2 % change of the plant could swap
gains as different as ``w`` = 4 and 6.4 Hz). Checked on the ZOH-discretized model with the discrete
controller and delay, or on a measured FRF when given.

The check runs on one contour: the grid (the FRF's lines, or the model's grid closing at ``fs/2``) and,
below it down to 1e-5 Hz, the model (scaled to meet the FRF over its first octave; see
:func:`feedtune.analysis.gantry.gantry_extension`). ``Ms`` and the crossover are taken over the whole
contour and the MIMO Nyquist count is exact whatever the FRF's lowest line. Without that extension the
indentation of the Nyquist contour sat at the lowest line, where a PID loop of 2-8 Hz bandwidth is between
its ``1/s^3`` and ``1/s^4`` asymptotes (local slope 1.2-2.9 at 2-20 Hz of ``det(I + L) - 1``, which is
small there), so stable candidates were counted unstable and the result depended on the lowest line: on the
twin's FRF (2-1000 Hz) cut at 10 Hz no pair met Ms 1.5 and Ms 1.86 gave ``w`` = 3.8 Hz instead of 5.8 Hz,
cut at 20 Hz no Ms up to 3 could be met. With the extension the tuned ``w`` is 2.00, 3.50, 6.29 and 7.53 Hz
for Ms 1.5, 1.86, 2.6 and 3 whether the FRF starts at 2, 5, 10 or 20 Hz (2.02, 3.44, 6.20, 7.50 Hz on the
model).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from ..errors import DesignError, UsageError
from ..frf import Frf
from ..models.gantry import GantryModel
from .discretize import backward_difference, backward_euler_integrator, matched
from .gantry_mimo import GantrySchedule, default_x_grid, gantry_schedule
from .loopshape import TWO_PI, LoopFilters, PrefilterGains, check_sampling, preview_samples

SHAPES = tuple((z, r) for z in (0.5, 0.7, 1.0) for r in (1.0, 2.0, 4.0))
"""Closed-loop shapes ``(zeta, rho)`` searched by :func:`tune_gantry_pid`."""
SHAPE_TIE = 0.10
"""Shapes whose CoM crossover is within this fraction of the highest count as equal (largest PM wins)."""


@dataclass(frozen=True)
class PidLaw:
    """One PID per side behind the filter pack (module docstring).

    Attributes
    ----------
    kp, kd, ki : (float, float)
        Per-side gains [V/m, V/(m/s), V/(m s)].
    filters : LoopFilters
    fs : float
        Sample rate [Hz].
    delay_samples : int
    """

    kp: tuple
    kd: tuple
    ki: tuple
    filters: LoopFilters
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
        f = np.asarray(freq_hz, float)
        with np.errstate(divide="ignore", invalid="ignore"):
            return self._assemble(self.filter_pack_discrete().freqresp(f), self._zpk["diff"].freqresp(f),
                                  self._zpk["integ"].freqresp(f))

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


@dataclass(frozen=True)
class GantryPidDesign:
    """A PID baseline design.

    Attributes
    ----------
    model : GantryModel
    x : float
        Design table position [m].
    law : PidLaw
    schedule : GantrySchedule
        Feedforward and pre-filter tables (alpha is stored for information).
    prefilter_hz : float
    tuning : dict
        How the gains were obtained.
    """

    model: GantryModel
    x: float
    law: PidLaw
    schedule: GantrySchedule
    prefilter_hz: float
    tuning: dict = field(default_factory=dict)

    kind = "gantry"
    controller = "pid"

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

    def design_dict(self) -> dict:
        """Design parameters with units in the keys."""
        return {"method": "independent PID per side, gains proportional to the side masses", "x_m": self.x,
                "prefilter_hz": self.prefilter_hz, **self.tuning}


def pid_gains(model: GantryModel, x: float, bandwidth_hz: float, zeta: float = 0.7, rho: float = 2.0) -> dict:
    """Per-side ``kp, kd, ki`` [V/m, V/(m/s), V/(m s)] placing ``(s^2 + 2 zeta w s + w^2)(s + w/rho)``."""
    w = TWO_PI * bandwidth_hz
    masses = model.side_masses(x)
    return {
        "kp": tuple(m * w * w * (1 + 2 * zeta / rho) for m in masses),
        "kd": tuple(m * w * (2 * zeta + 1 / rho) for m in masses),
        "ki": tuple(m * w**3 / rho for m in masses),
    }


def design_gantry_pid(
    model: GantryModel,
    *,
    kp,
    kd,
    ki,
    filters: LoopFilters | None = None,
    fs: float = 15000.0,
    delay_samples: int = 1,
    x: float = 0.0,
    x_grid=None,
    prefilter1: PrefilterGains | None = None,
    prefilter2: PrefilterGains | None = None,
    prefilter_hz: float = 80.0,
    tuning: dict | None = None,
) -> GantryPidDesign:
    """PID baseline with the given per-side gains ``(side1, side2)`` [V/m, V/(m/s), V/(m s)]."""
    check_sampling(fs, delay_samples)
    pack = filters or LoopFilters()
    pack.check_nyquist(fs)
    gains = {}
    for name, v in (("kp", kp), ("kd", kd), ("ki", ki)):
        pair = tuple(float(g) for g in (v if isinstance(v, (list, tuple)) else (v, v)))
        if len(pair) != 2 or not all(math.isfinite(g) and g >= 0 for g in pair):
            raise UsageError(f"PID gain {name} must be one or two finite numbers >= 0, got {v!r}")
        gains[name] = pair
    law = PidLaw(gains["kp"], gains["kd"], gains["ki"], pack, float(fs), int(delay_samples))
    grid = default_x_grid(model) if x_grid is None else x_grid
    return GantryPidDesign(model, float(x), law, gantry_schedule(model, grid, prefilter1, prefilter2),
                           float(prefilter_hz), dict(tuning or {"method": "user gains"}))


def _best_shape(candidates: list[dict]) -> dict:
    """The candidate with the highest CoM crossover; within ``SHAPE_TIE`` of it, the largest phase margin."""
    top = max(c["com_crossover_hz"] for c in candidates)
    near = [c for c in candidates if c["com_crossover_hz"] >= (1.0 - SHAPE_TIE) * top]
    return max(near, key=lambda c: (c["com_phase_margin_deg"], c["com_crossover_hz"]))


def tune_gantry_pid(
    model: GantryModel,
    *,
    limits=None,
    ms_max: float | None = None,
    filters: LoopFilters | None = None,
    fs: float = 15000.0,
    delay_samples: int = 1,
    x: float = 0.0,
    frf: Frf | None = None,
    x_grid=None,
    prefilter1: PrefilterGains | None = None,
    prefilter2: PrefilterGains | None = None,
    prefilter_hz: float = 80.0,
    grid_points: int | None = None,
) -> GantryPidDesign:
    """Highest-bandwidth PID pair with ``max sigma_max(S) <= ms_max`` [-] and a stable MIMO loop.

    See the module docstring for the parametrisation, the search and the checking contour. ``ms_max`` is
    usually the Ms of the MIMO design in the same case (``feedtune design pid --match mimo.toml``).

    Parameters
    ----------
    model : GantryModel
        Design model (side masses, CoM weights; the plant below the FRF's band).
    ms_max : float
        Largest ``max sigma_max(S)`` [-], > 1.
    filters : LoopFilters, optional
        Filter pack ``h(s)`` in front of both PIDs.
    fs : float
        Sample rate [Hz].
    delay_samples : int
        Computational delay [samples].
    x : float
        Table position [m] of the design.
    frf : Frf, optional
        Measured 2x2 position FRF [m/V] to check on (``discrete`` case); default the model
        (``ideal_discrete`` case).
    x_grid, prefilter1, prefilter2, prefilter_hz
        Schedule grid [m], pre-filter gains and low-pass [Hz] of the design.
    grid_points : int, optional
        Points of the model's grid when no FRF is given; default that of
        :func:`feedtune.analysis.gantry.default_grid` (4000), so the analysis's ``ideal_discrete`` case sees
        the same ``Ms``.

    Raises
    ------
    DesignError
        No candidate meets the limit.
    """
    from ..analysis.cases import CHECKED_WITH_FRF, CHECKED_WITHOUT_FRF
    from ..analysis.gantry import analyze_gantry_case, default_grid, gantry_plant_cases
    from ..analysis.limits import DEFAULT_LIMITS
    from ..analysis.mimo import sensitivity, singular_values

    policy = (limits or DEFAULT_LIMITS).override(ms_max=ms_max)
    ms_max = policy.ms_max if policy.ms_max is not None else math.inf
    check_sampling(fs, delay_samples)
    pack = filters or LoopFilters()
    pack.check_nyquist(fs)
    grid = default_grid(fs) if grid_points is None else default_grid(fs, grid_points)
    case = CHECKED_WITH_FRF if frf is not None else CHECKED_WITHOUT_FRF
    pc = gantry_plant_cases(model, x, fs, delay_samples, frf, grid)[case]
    weights = model.alpha(x)
    f = pc.freq_hz
    Ge = pc.plant(f) * pc.hold(f)
    h = matched(pack.zpk(), fs).tf.freqresp(f)
    D = backward_difference(fs).freqresp(f)
    with np.errstate(divide="ignore", invalid="ignore"):
        Iz = backward_euler_integrator(fs).freqresp(f)
    masses = np.array(model.side_masses(x))

    def grid_ms(bw_hz, zeta, rho):
        """``Ms`` on the case's base grid: a lower bound of the checked (refined) one, to skip hopeless candidates."""
        w = TWO_PI * bw_hz
        c = h * (w * w * (1 + 2 * zeta / rho) + w * (2 * zeta + 1 / rho) * D + w**3 / rho * Iz)
        L = Ge * (masses * c[:, None]).T[None, :, :]  # column j scaled by m_j c
        return float(np.max(singular_values(sensitivity(L))[0]))

    def check(bw_hz, zeta, rho):
        """The analysis' own check of the candidate in the checked case (None when it fails)."""
        if grid_ms(bw_hz, zeta, rho) > ms_max:
            return None
        g = pid_gains(model, x, bw_hz, zeta, rho)
        law = PidLaw(g["kp"], g["kd"], g["ki"], pack, float(fs), int(delay_samples))
        m = analyze_gantry_case(law, pc, weights).metrics
        return m if all(i.ok for i in policy.check(m, case)) else None

    coarse = np.logspace(np.log10(0.5), np.log10(fs / 40), 48)
    candidates = []
    for zeta, rho in SHAPES:
        passing = [i for i, b in enumerate(coarse) if grid_ms(b, zeta, rho) <= ms_max]
        i = next((i for i in reversed(passing) if check(coarse[i], zeta, rho) is not None), None)
        if i is None:
            continue
        lo, hi = coarse[i], (coarse[i + 1] if i + 1 < coarse.size else coarse[i])
        best = check(lo, zeta, rho)
        while hi / lo > 1 + 2e-3:  # bisection in log frequency to the edge of the feasible range
            mid = math.sqrt(lo * hi)
            m = check(mid, zeta, rho)
            if m is not None:
                lo, best = mid, m
            else:
                hi = mid
        xo = best.crossovers_hz[0] if best.crossovers_hz else 0.0
        pm = abs(best.phase_margins_deg[0]) if best.phase_margins_deg else 0.0
        candidates.append({"com_crossover_hz": xo, "com_phase_margin_deg": pm, "bandwidth_hz": lo, "zeta": zeta,
                           "rho": rho, "ms": best.ms})
    if not candidates:
        raise DesignError(f"no PID pair reaches Ms <= {ms_max:g} with a stable loop; relax --ms-max or change "
                          "the filter pack")
    best = _best_shape(candidates)
    bw, zeta, rho = best["bandwidth_hz"], best["zeta"], best["rho"]
    g = pid_gains(model, x, bw, zeta, rho)
    tuning = {"method": "highest CoM crossover with max sigma_max(S) <= ms_max and MIMO Nyquist stability; "
                        f"shapes within {100 * SHAPE_TIE:g} % of the highest crossover: largest phase margin",
              "ms_measure": "max over frequency of the largest singular value of the 2x2 sensitivity",
              "ms_max": float(ms_max), "ms_found": float(best["ms"]), "bandwidth_hz": float(bw), "zeta": zeta,
              "rho": rho, "com_crossover_hz": float(best["com_crossover_hz"]),
              "com_phase_margin_deg": float(best["com_phase_margin_deg"]), "checked_case": case,
              "checked_from_hz": float(f[0]), "checked_to_hz": float(f[-1])}
    return design_gantry_pid(model, kp=g["kp"], kd=g["kd"], ki=g["ki"], filters=pack, fs=fs,
                             delay_samples=delay_samples, x=x, x_grid=x_grid, prefilter1=prefilter1,
                             prefilter2=prefilter2, prefilter_hz=prefilter_hz, tuning=tuning)
