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

from collections.abc import Mapping
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

    def to_doc(self) -> dict:
        """Body of a rigid-body model file: units and ``[params]`` as quantities (see :func:`rigid_to_doc`)."""
        units = self.units
        params = {}
        for name in PARAM_NAMES:
            value = getattr(self, name)
            if value is not None:
                params[name] = {"value": float(value), "unit": units[name]}
        return {"command_unit": self.command_unit, "position_unit": self.position_unit, "params": params}

    @classmethod
    def from_doc(cls, doc: Mapping[str, object], where: str = "rigid-body model") -> RigidBodyModel:
        """Build the model from a document written by :meth:`to_doc` (errors name ``where`` and the key)."""
        from ..quantity import value_of

        command_unit = doc.get("command_unit")
        position_unit = doc.get("position_unit")
        for key, unit in (("command_unit", command_unit), ("position_unit", position_unit)):
            if not isinstance(unit, str) or not unit:
                raise DataError(f"{where}: {key} must be a unit string, got {unit!r}")
        if position_unit not in POSITION_UNITS:
            raise DataError(f"{where}: position_unit = {position_unit!r}; expected one of {', '.join(POSITION_UNITS)}")
        params = doc.get("params")
        if not isinstance(params, Mapping):
            raise DataError(f"{where}: missing [params] table with {', '.join(PARAM_NAMES)}")
        unknown = sorted(set(params) - set(PARAM_NAMES))
        if unknown:
            raise DataError(f"{where}: unknown rigid-body parameter params.{unknown[0]}")
        probe = cls(mass=1.0, command_unit=command_unit, position_unit=position_unit)
        values: dict[str, float | None] = {}
        for name in PARAM_NAMES:
            if name not in params:
                if name in OPTIONAL_PARAMS:
                    values[name] = None
                    continue
                raise DataError(f"{where}: params.{name} is missing")
            values[name] = value_of(params[name], probe.units[name], f"{where}: params.{name}")
        try:
            return cls(**values, command_unit=command_unit, position_unit=position_unit)
        except DataError as exc:
            raise DataError(f"{where}: {exc}") from None


def rigid_to_doc(model: RigidBodyModel) -> dict:
    """Document body of a rigid-body model file (registered as model kind ``"rigid"``).

    Example file (``feedtune identify rigid LOG --out rigid.toml``)::

        schema = "feedtune.model/1"
        kind = "rigid"
        command_unit = "N"
        position_unit = "m"

        [params]
        mass = { value = 95.1, unit = "N/(m/s^2)" }
        viscous = { value = 203.5, unit = "N/(m/s)" }
        coulomb_pos = { value = 20.39, unit = "N" }
        coulomb_neg = { value = 20.39, unit = "N" }     # optional: omitted = coulomb_pos
        offset = { value = -3.16, unit = "N" }
        viscous_neg = { value = 203.5, unit = "N/(m/s)" }  # optional: omitted = viscous
    """
    return model.to_doc()


def rigid_from_doc(doc: Mapping[str, object], where: str = "rigid-body model") -> RigidBodyModel:
    """Build a :class:`RigidBodyModel` from a rigid-body model document (see :func:`rigid_to_doc`)."""
    return RigidBodyModel.from_doc(doc, where)
