"""Independent SISO PID baseline for the gantry (thesis §4.4.2, Fig. 4.14-4.15: PIDs reached 16 Hz).

One PID per side behind a filter pack ``h(s)``; the thesis gave its PIDs "identical notch and low-pass
filters" to the MIMO design's (not the second lead, which serves the MIMO law's damping loop)::

    K(s) = h(s) diag(C_1(s), C_2(s)),   C_i(s) = kp_i + kd_i s + ki_i / s

The gains are proportional to the mass each side carries, ``m_i = alpha_i m`` (the usual way of making
both sides respond alike), and placed from a bandwidth ``w``: the closed loop of ``m_i s^2`` with ``C_i``
has the characteristic polynomial ``(s^2 + 2 zeta w s + w^2)(s + w/rho)``, i.e.
``kd_i = m_i w (2 zeta + 1/rho)``, ``kp_i = m_i w^2 (1 + 2 zeta/rho)``, ``ki_i = m_i w^3 / rho``.

The tuner that finds the best such pair under the limits policy is :func:`feedtune.tune.pid.tune_gantry_pid`.

Each side gets its own row of the inertia feedforward ``M(x) [y_r1'', y_r2'']`` (eq. 4.31, as the MIMO law); an
optional friction feedforward of the gantry's travel (:meth:`GantryPidDesign.with_friction`) is split by the same
weights, ``u_i += alpha_i(x) d(v_r)`` (:mod:`feedtune.design.gantry_mimo`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

from ..control.discretize import check_sampling
from ..control.filters import TWO_PI, FilterPack
from ..control.friction import FrictionFeedforward
from ..control.gantry import GantrySchedule, PidLaw
from ..control.prefilter import PrefilterGains, preview_samples
from ..errors import UsageError
from ..models.gantry import GantryModel
from .gantry_mimo import default_x_grid, gantry_friction, gantry_schedule


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
    friction : FrictionFeedforward or None
        Friction feedforward of the gantry's travel [command unit, m/s], split ``alpha1 : alpha2`` like the inertia
        feedforward (:meth:`with_friction`).
    """

    model: GantryModel
    x: float
    law: PidLaw
    schedule: GantrySchedule
    prefilter_hz: float
    tuning: dict = field(default_factory=dict)
    friction: FrictionFeedforward | None = None

    kind = "gantry"
    controller = "pid"

    def with_friction(self, friction, *, v_band: float | None = None, where: str = "friction model",
                      model_where: str = "the gantry model") -> GantryPidDesign:
        """A copy with the friction feedforward of ``friction`` (replacing any; ``None`` removes it); see
        :func:`feedtune.design.gantry_mimo.gantry_friction` for the parameters [command unit, m/s] and errors."""
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
    filters: FilterPack | None = None,
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
    pack = filters or FilterPack()
    pack.check_nyquist(fs)
    gains = {}
    for name, v in (("kp", kp), ("kd", kd), ("ki", ki)):
        pair = tuple(float(g) for g in (v if isinstance(v, (list, tuple)) else (v, v)))
        if len(pair) != 2 or not all(math.isfinite(g) and g >= 0 for g in pair):
            raise UsageError(f"{name} must be one or two finite numbers >= 0 (a PID gain), got {v!r}", parameter=name)
        gains[name] = pair
    law = PidLaw(gains["kp"], gains["kd"], gains["ki"], pack, float(fs), int(delay_samples))
    grid = default_x_grid(model) if x_grid is None else x_grid
    return GantryPidDesign(model, float(x), law, gantry_schedule(model, grid, prefilter1, prefilter2),
                           float(prefilter_hz), dict(tuning or {"method": "user gains"}))
