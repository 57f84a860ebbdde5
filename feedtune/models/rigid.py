"""Rigid-body model of a feed drive: inertia, viscous and Coulomb friction, offset (thesis §2.1.1).

The command (force) that moves the axis with acceleration ``a`` and velocity ``v`` is::

    u = M a + Fv+ v + Fc+ + offset     v > 0
    u = M a + Fv- v - Fc- + offset     v < 0
    u = M a + offset                   v = 0

Coulomb levels ``Fc+`` and ``Fc-`` are *magnitudes* (both normally > 0), as published for IDIM-LS models
(``Fc sign(v)``); for a symmetric model ``Fc- = Fc+`` and ``Fv- = Fv+``. Units follow the command and
position units: mass [command/(position/s^2)], e.g. kg = N/(m/s^2); viscous [command/(position/s)];
Coulomb and offset [command].
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import DataError

POSITION_UNITS = ("m", "rad")
MODEL_KIND = "rigid"
"""``kind`` of a rigid-body model file (``feedtune identify rigid --out rigid.toml``)."""
PARAM_NAMES = ("mass", "viscous", "viscous_neg", "coulomb_pos", "coulomb_neg", "offset")
OPTIONAL_PARAMS = ("viscous_neg", "coulomb_neg")


@dataclass(frozen=True)
class RigidBodyModel:
    """Rigid axis with viscous and (possibly asymmetric) Coulomb friction and a constant offset.

    Parameters
    ----------
    mass : float
        Moving mass or inertia [command_unit/(position_unit/s^2)], > 0 (kg for N and m).
    viscous : float
        Viscous friction for ``v > 0`` (and ``v < 0`` unless ``viscous_neg`` is given)
        [command_unit/(position_unit/s)].
    coulomb_pos : float
        Coulomb friction magnitude for ``v > 0`` [command_unit].
    coulomb_neg : float or None
        Coulomb friction magnitude for ``v < 0`` [command_unit]; ``None`` uses ``coulomb_pos``.
    offset : float
        Constant command offset (gravity, cable force, amplifier offset) [command_unit].
    command_unit : str
        Unit of the command: ``"N"``, ``"N*m"`` or ``"V"``.
    position_unit : str
        ``"m"`` (linear axis) or ``"rad"`` (rotary axis).
    viscous_neg : float or None
        Viscous friction for ``v < 0`` [command_unit/(position_unit/s)]; ``None`` uses ``viscous``.

    Examples
    --------
    >>> m = RigidBodyModel(mass=95.0, viscous=200.0, coulomb_pos=20.0, offset=-3.0)
    >>> [float(x) for x in m.force([1.0, 0.0], [0.1, -0.1])]
    [132.0, -43.0]
    """

    mass: float
    viscous: float = 0.0
    coulomb_pos: float = 0.0
    coulomb_neg: float | None = None
    offset: float = 0.0
    command_unit: str = "N"
    position_unit: str = "m"
    viscous_neg: float | None = None

    def __post_init__(self) -> None:
        for name in ("mass", "viscous", "coulomb_pos", "coulomb_neg", "offset", "viscous_neg"):
            raw = getattr(self, name)
            if raw is None:
                continue
            value = float(raw)
            if not np.isfinite(value):
                raise DataError(f"rigid-body parameter {name} must be finite, got {value}")
            object.__setattr__(self, name, value)
        if not self.mass > 0:
            raise DataError(f"rigid-body mass must be > 0 {self.units['mass']}, got {self.mass}")
        if self.position_unit not in POSITION_UNITS:
            raise DataError(f"rigid-body position_unit must be one of {', '.join(POSITION_UNITS)}, "
                            f"got {self.position_unit!r}")

    @property
    def coulomb_negative(self) -> float:
        """Coulomb magnitude used for ``v < 0`` [command_unit]."""
        return self.coulomb_pos if self.coulomb_neg is None else float(self.coulomb_neg)

    @property
    def viscous_negative(self) -> float:
        """Viscous coefficient used for ``v < 0`` [command_unit/(position_unit/s)]."""
        return self.viscous if self.viscous_neg is None else float(self.viscous_neg)

    @property
    def is_symmetric(self) -> bool:
        """True when both directions share the viscous and Coulomb coefficients."""
        return self.coulomb_negative == self.coulomb_pos and self.viscous_negative == self.viscous

    @property
    def velocity_unit(self) -> str:
        """``"m/s"`` or ``"rad/s"``."""
        return f"{self.position_unit}/s"

    @property
    def units(self) -> dict[str, str]:
        """Unit of every parameter."""
        c, p = self.command_unit, self.position_unit
        return {
            "mass": f"{c}/({p}/s^2)", "viscous": f"{c}/({p}/s)", "viscous_neg": f"{c}/({p}/s)",
            "coulomb_pos": c, "coulomb_neg": c, "offset": c,
        }

    def friction(self, velocity) -> np.ndarray:
        """Viscous + Coulomb friction force [command_unit] at ``velocity`` [position_unit/s]."""
        v = np.asarray(velocity, dtype=float)
        pos = self.viscous * v + self.coulomb_pos
        neg = self.viscous_negative * v - self.coulomb_negative
        return np.where(v > 0, pos, np.where(v < 0, neg, 0.0))

    def force(self, acc, vel) -> np.ndarray:
        """Command that produces acceleration ``acc`` [position_unit/s^2] at velocity ``vel``.

        Parameters
        ----------
        acc : array_like
            Acceleration [position_unit/s^2].
        vel : array_like
            Velocity [position_unit/s], broadcast against ``acc``.

        Returns
        -------
        ndarray
            Command [command_unit].
        """
        return self.mass * np.asarray(acc, dtype=float) + self.friction(vel) + self.offset

    def __repr__(self) -> str:
        from ..display import call, params

        values = {"mass": self.mass, "viscous": self.viscous, "coulomb_pos": self.coulomb_pos,
                  "coulomb_neg": self.coulomb_neg, "viscous_neg": self.viscous_neg, "offset": self.offset}
        return call("RigidBodyModel", params({k: v for k, v in values.items() if v is not None}, self.units))

    def plot(self, velocity=None, *, title: str | None = None):
        """Friction (viscous + Coulomb) [command unit] over velocity (:func:`feedtune.plotting.plot_friction`)."""
        from ..display import facade

        return facade("plot_friction")(self, velocity, title=title)

    def to_control(self):
        """The linear part ``1 / (m s^2 + b s)`` as a python-control ``TransferFunction``
        (:func:`feedtune.interop_control.rigid_to_control`)."""
        from ..display import facade

        return facade("rigid_to_control")(self)

    def to_dict(self) -> dict:
        """JSON-ready parameters with their units."""
        return {
            "model": "rigid",
            "mass": self.mass,
            "viscous": self.viscous,
            "viscous_neg": self.viscous_negative,
            "coulomb_pos": self.coulomb_pos,
            "coulomb_neg": self.coulomb_negative,
            "offset": self.offset,
            "units": self.units,
        }
