"""The gantry's mass and its distribution over the two actuators versus table position (thesis §4.3.1).

Value types of :mod:`feedtune.identify.mass` (which fits them from tracking logs) and of the mass document
(:mod:`feedtune.io.mass_file`). Masses are control-signal equivalents [command unit/(m/s^2)].
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class SideMassFit:
    """Least-squares fit of the two actuator commands at one table position.

    Attributes
    ----------
    x : float
        Table position [m].
    m1, m2 : float
        Masses carried by the left / right actuator [V/(m/s^2)].
    offset1, offset2 : float
        Constant command offsets [V] (gravity, cable forces, amplifier offsets).
    viscous1, viscous2 : float or None
        Viscous coefficients [V/(m/s)] when a velocity reference was used, else None.
    rms_residual1, rms_residual2 : float
        RMS of the fit residual of each command [V].
    n_samples : int
        Number of samples used.
    """

    x: float
    m1: float
    m2: float
    offset1: float
    offset2: float
    viscous1: float | None
    viscous2: float | None
    rms_residual1: float
    rms_residual2: float
    n_samples: int

    @property
    def m(self) -> float:
        """Total mass ``m1 + m2`` [V/(m/s^2)]."""
        return self.m1 + self.m2

    @property
    def alpha1(self) -> float:
        """Left mass fraction ``m1 / m`` [-]."""
        return self.m1 / self.m

    @property
    def alpha2(self) -> float:
        """Right mass fraction ``m2 / m`` [-]."""
        return self.m2 / self.m

    def to_dict(self) -> dict:
        """JSON-ready dict with a ``units`` entry."""
        return {
            "x": self.x, "m1": self.m1, "m2": self.m2, "m": self.m, "alpha1": self.alpha1,
            "alpha2": self.alpha2, "offset1": self.offset1, "offset2": self.offset2,
            "viscous1": self.viscous1, "viscous2": self.viscous2, "rms_residual1": self.rms_residual1,
            "rms_residual2": self.rms_residual2, "n_samples": self.n_samples,
            "units": {"x": "m", "m1": "V/(m/s^2)", "m2": "V/(m/s^2)", "m": "V/(m/s^2)", "alpha1": "-",
                      "alpha2": "-", "offset1": "V", "offset2": "V", "viscous1": "V/(m/s)",
                      "viscous2": "V/(m/s)", "rms_residual1": "V", "rms_residual2": "V"},
        }


@dataclass(frozen=True)
class MassFit:
    """Gantry mass and its distribution versus table position.

    Attributes
    ----------
    positions : tuple of SideMassFit
        The per-position fits, in the order given.
    m : float
        Total mass [V/(m/s^2)], mean of ``m1 + m2`` over the positions.
    alpha1_0 : float
        Left mass fraction at ``x = 0`` from the straight-line fit [-].
    dalpha1_dx : float
        Slope of the left mass fraction with table position [1/m].
    alpha1_rms_residual : float
        RMS deviation of the per-position ``alpha1`` from the line [-].
    """

    positions: tuple[SideMassFit, ...]
    m: float
    alpha1_0: float
    dalpha1_dx: float
    alpha1_rms_residual: float

    def alpha(self, x: float) -> tuple[float, float]:
        """``(alpha1, alpha2)`` [-] at table position ``x`` [m] from the straight-line fit."""
        a1 = self.alpha1_0 + self.dalpha1_dx * float(x)
        return a1, 1.0 - a1

    def side_masses(self, x: float) -> tuple[float, float]:
        """``(m1, m2) = (alpha1 m, alpha2 m)`` [V/(m/s^2)] at ``x`` [m]: the constraint of eq. 4.13."""
        a1, a2 = self.alpha(x)
        return a1 * self.m, a2 * self.m

    def to_dict(self) -> dict:
        """JSON-ready dict with a ``units`` entry."""
        return {
            "m": self.m, "alpha1_0": self.alpha1_0, "dalpha1_dx": self.dalpha1_dx,
            "alpha1_rms_residual": self.alpha1_rms_residual,
            "positions": [p.to_dict() for p in self.positions],
            "units": {"m": "V/(m/s^2)", "alpha1_0": "-", "dalpha1_dx": "1/m", "alpha1_rms_residual": "-"},
        }
