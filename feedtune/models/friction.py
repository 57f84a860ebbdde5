"""Stribeck friction model (thesis eq. 2.1).

The friction disturbance is, for a velocity ``v``::

    d(v) = dc+ + (ds+ - dc+) exp(-|v| / Omega+)    v > 0
    d(v) = 0                                         v = 0
    d(v) = dc- + (ds- - dc-) exp(-|v| / Omega-)    v < 0

``dc`` is the Coulomb level, ``ds`` the static (break-away) level and ``Omega`` the Stribeck velocity
constant. Values are signed: for a friction that opposes motion ``dc+, ds+ > 0`` and ``dc-, ds- < 0``.

Convention used throughout feedtune: ``d(v)`` is the friction force expressed in the drive's command unit
(N, N*m or V) that the drive must *supply* to overcome friction, i.e. the command of a rigid axis is
``u = m a + b v + d(v) + offset``. Friction feedforward is therefore ``+d(v_ref)`` (or the continuous
:meth:`StribeckFriction.smoothed` version of it).

Friction laws (:class:`FrictionLaw`, a choice of curve per direction, each with a viscous term ``Fv``). With
``s = |v|`` and the signed levels of the direction (``dc = dc+`` for ``v > 0``, ``dc-`` for ``v < 0``; as
magnitudes ``Fc = |dc|``, ``Fs = |ds|``), every law is ``d(v) = dc (1 - phi(s/vs)) + ds phi(s/vs) + Fv v``:

* ``stribeck``: ``phi(x) = exp(-x)``, i.e. ``F = sign(v) [Fc + (Fs - Fc) exp(-|v|/vs)] + Fv v`` (eq. 2.1 plus
  viscous friction; ``ds`` is the static level at ``v -> 0``);
* ``hump``: ``phi(x) = x exp(1 - x)``, i.e. ``F = Fv v + Fc + v (Fs - Fc) e / vs exp(-v / vs)`` for ``v > 0``,
  mirrored for ``v < 0`` (the exponential-hump law: ``F -> Fc`` at ``v -> 0``, ``ds`` is the peak ``Fmax``
  reached at ``|v| = vs``);
* ``lugre``: ``phi(x) = exp(-x^2)``, the LuGre model's steady-state curve
  ``F = sign(v) [Fc + (Fs - Fc) exp(-(v/vs)^2)] + Fv v``;
* ``coulomb-viscous``: ``phi(x) = 0``, i.e. ``F = sign(v) Fc + Fv v`` (no static level and no characteristic
  velocity: ``ds = dc``, :meth:`FrictionLaw.coulomb_viscous`).

Shape (:func:`level_shape`): a static level (the hump law's peak) above the Coulomb level is a ``peak`` (the
classical Stribeck effect: friction falls from rest to its sliding level), one below it a ``dip`` (friction rises
from rest to its sliding level, as EMPS and the rack-and-pinion show).

Physical signs (:meth:`StribeckFriction.sign_problems`): the levels have the sign of their direction (``dc+, ds+ >= 0``,
``dc-, ds- <= 0``), ``vs > 0`` and ``Fv >= 0``; a level of the wrong sign comes from a mirrored or
sign-inverted command (or from a constant offset such as gravity larger than the friction).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import DataError, UsageError

VELOCITY_UNITS = ("m/s", "rad/s")
MODEL_KIND = "friction"
"""``kind`` of a friction model file (``feedtune identify friction --out friction.toml``)."""
LEVEL_NAMES = ("dc_pos", "ds_pos", "dc_neg", "ds_neg")
OMEGA_NAMES = ("omega_pos", "omega_neg")
VISCOUS_NAMES = ("viscous_pos", "viscous_neg")
COULOMB_VISCOUS = "coulomb-viscous"
LAWS = ("stribeck", "hump", "lugre", COULOMB_VISCOUS)
"""Friction laws of :class:`FrictionLaw` (module docstring)."""
SHAPED_LAWS = ("stribeck", "hump", "lugre")
"""The laws with a static level ``ds`` and a characteristic velocity ``vs`` (``omega``)."""
LAW_FORMULAS = {
    "stribeck": "F = sign(v) [Fc + (Fs - Fc) exp(-|v|/vs)] + Fv v",
    "hump": "F = sign(v) [Fc + |v| (Fs - Fc) e/vs exp(-|v|/vs)] + Fv v",
    "lugre": "F = sign(v) [Fc + (Fs - Fc) exp(-(v/vs)^2)] + Fv v",
    COULOMB_VISCOUS: "F = sign(v) Fc + Fv v",
}
"""Each law per direction (``Fc, Fs`` magnitudes of the direction's levels ``dc, ds``; ``vs`` = ``omega``)."""


@dataclass(frozen=True)
class StribeckFriction:
    """Direction-dependent Stribeck friction, eq. 2.1 (signed levels, see module doc).

    Parameters
    ----------
    dc_pos, ds_pos : float
        Coulomb and static friction for ``v > 0`` [command unit], normally > 0.
    dc_neg, ds_neg : float
        Coulomb and static friction for ``v < 0`` [command unit], normally < 0.
    omega_pos : float
        Stribeck velocity constant for ``v > 0`` [velocity unit], > 0.
    omega_neg : float or None
        Stribeck velocity constant for ``v < 0`` [velocity unit]; ``None`` uses ``omega_pos`` (eq. 2.1 has
        one ``Omega`` for both directions).
    command_unit : str
        Unit of the friction levels (``"N"``, ``"N*m"`` or ``"V"``).
    velocity_unit : str
        ``"m/s"`` (linear axis) or ``"rad/s"`` (rotary axis).

    Examples
    --------
    >>> f = StribeckFriction(dc_pos=20.0, ds_pos=30.0, dc_neg=-18.0, ds_neg=-25.0, omega_pos=0.01)
    >>> [round(float(x), 3) for x in f.force([0.01, 0.0, -1.0])]
    [23.679, 0.0, -18.0]
    """

    dc_pos: float
    ds_pos: float
    dc_neg: float
    ds_neg: float
    omega_pos: float
    omega_neg: float | None = None
    command_unit: str = "N"
    velocity_unit: str = "m/s"

    def __post_init__(self) -> None:
        for name in ("dc_pos", "ds_pos", "dc_neg", "ds_neg", "omega_pos"):
            value = float(getattr(self, name))
            if not np.isfinite(value):
                raise DataError(f"Stribeck friction parameter {name} must be finite, got {value}")
            object.__setattr__(self, name, value)
        if self.omega_neg is not None:
            object.__setattr__(self, "omega_neg", float(self.omega_neg))
        for name, value in (("omega_pos", self.omega_pos), ("omega_neg", self.omega_negative)):
            if not (np.isfinite(value) and value > 0):
                raise DataError(f"Stribeck friction parameter {name} must be > 0 {self.velocity_unit}, "
                                f"got {value}")
        if self.velocity_unit not in VELOCITY_UNITS:
            raise DataError(f"Stribeck friction velocity_unit must be one of {', '.join(VELOCITY_UNITS)}, "
                            f"got {self.velocity_unit!r}")

    @property
    def omega_negative(self) -> float:
        """Stribeck velocity constant used for ``v < 0`` [velocity unit]."""
        return self.omega_pos if self.omega_neg is None else float(self.omega_neg)

    def force(self, velocity) -> np.ndarray:
        """Friction force ``d(v)`` of eq. 2.1 [command unit] (vectorised; exactly 0 at ``v = 0``).

        Parameters
        ----------
        velocity : array_like
            Velocity [velocity unit].

        Returns
        -------
        ndarray
            Friction force, same shape as ``velocity`` [command unit].
        """
        v = np.asarray(velocity, dtype=float)
        speed = np.abs(v)
        pos = self.dc_pos + (self.ds_pos - self.dc_pos) * np.exp(-speed / self.omega_pos)
        neg = self.dc_neg + (self.ds_neg - self.dc_neg) * np.exp(-speed / self.omega_negative)
        return np.where(v > 0, pos, np.where(v < 0, neg, 0.0))

    def sign_problems(self) -> list[tuple[str, str]]:
        """Parameters with an unphysical sign, as ``(name, sentence)`` pairs (empty: all fine).

        The levels must have the sign of their direction (``dc_pos, ds_pos >= 0``; ``dc_neg, ds_neg <= 0``: the
        command a drive supplies against friction points the way it moves; :func:`level_sign_problem`); the
        constructor accepts any sign (``omega > 0`` is checked there), fits and file loaders call this.

        Returns
        -------
        list of (str, str)
            Parameter name and what is wrong with it, in :data:`LEVEL_NAMES` order.
        """
        found = [(n, level_sign_problem(n, float(getattr(self, n)), self.command_unit)) for n in LEVEL_NAMES]
        return [(n, text) for n, text in found if text]

    @property
    def characteristic_speed(self) -> float:
        """The speed over which the curve changes shape [velocity unit]: the larger Stribeck velocity (plots span ten
        of it)."""
        return max(self.omega_pos, self.omega_negative)

    def shapes(self) -> dict[str, str]:
        """``{"pos": shape, "neg": shape}`` of :func:`level_shape` (``"peak"``, ``"dip"`` or ``"flat"``)."""
        return {"pos": level_shape(self.dc_pos, self.ds_pos), "neg": level_shape(self.dc_neg, self.ds_neg)}

    def smoothed(self, velocity, v_eps: float) -> np.ndarray:
        """Friction force made continuous through zero, for feedforward [command unit].

        Eq. 2.1 jumps from ``ds-`` to ``ds+`` at ``v = 0``; fed forward from a reference velocity that
        dwells near zero (or from a noisy measured velocity) the jump chatters. This variant equals
        :meth:`force` for ``|v| >= v_eps`` and, inside ``|v| < v_eps``, is the straight line through zero
        that meets the curve at the band edge: ``d(v) = d(+v_eps) v / v_eps`` for ``v >= 0`` and
        ``d(v) = d(-v_eps) |v| / v_eps`` for ``v < 0``. It is continuous and 0 at ``v = 0``; choose ``v_eps``
        a little above the velocity noise (or the reference's smallest non-zero speed).

        Parameters
        ----------
        velocity : array_like
            Velocity [velocity unit].
        v_eps : float
            Half-width of the linear band [velocity unit], > 0.

        Returns
        -------
        ndarray
            Smoothed friction force, same shape as ``velocity`` [command unit].
        """
        v_eps = float(v_eps)
        if not (np.isfinite(v_eps) and v_eps > 0):
            raise UsageError(f"v_eps must be > 0 {self.velocity_unit}, got {v_eps}")
        v = np.asarray(velocity, dtype=float)
        edge_pos, edge_neg = self.force(np.array([v_eps, -v_eps]))
        ramp = np.where(v >= 0, edge_pos, edge_neg) * np.abs(v) / v_eps
        return np.where(np.abs(v) < v_eps, ramp, self.force(v))

    def to_dict(self) -> dict:
        """JSON-ready parameters with their units."""
        return {
            "model": "stribeck",
            "dc_pos": self.dc_pos,
            "ds_pos": self.ds_pos,
            "dc_neg": self.dc_neg,
            "ds_neg": self.ds_neg,
            "omega_pos": self.omega_pos,
            "omega_neg": self.omega_negative,
            "units": {
                "dc_pos": self.command_unit, "ds_pos": self.command_unit,
                "dc_neg": self.command_unit, "ds_neg": self.command_unit,
                "omega_pos": self.velocity_unit, "omega_neg": self.velocity_unit,
            },
        }

    def __repr__(self) -> str:
        from ..display import call, params

        d = self.to_dict()
        units = d.pop("units")
        law = d.pop("model")
        d.pop("formula", None)
        return call(type(self).__name__, [f"law={law}", *params(d, units)])

    def plot(self, velocity=None, *, title: str | None = None):
        """The friction curve ``d(v)`` [command unit] over velocity (:func:`feedtune.plotting.plot_friction`)."""
        from ..display import facade

        return facade("plot_friction")(self, velocity, title=title)


# ------------------------------------------------------------------------------------------- friction laws
def check_law(law: str) -> str:
    """``law`` if it is one of :data:`LAWS`, else a :class:`UsageError` listing them."""
    if law not in LAWS:
        raise UsageError(f"friction law must be one of {', '.join(LAWS)}, got {law!r}", parameter="law")
    return law


def law_shape(law: str, x) -> np.ndarray:
    """The law's shape ``phi(x)`` of the normalised speed ``x = |v| / vs`` [-] (module docstring), vectorised.

    Parameters
    ----------
    law : str
        One of :data:`LAWS`.
    x : array_like
        Normalised speed ``|v| / vs`` [-], >= 0.

    Returns
    -------
    ndarray
        ``phi(x)`` [-]: the weight of the level ``ds`` (``1 - phi`` weighs ``dc``).
    """
    x = np.asarray(x, dtype=float)
    if law == "stribeck":
        return np.exp(-x)
    if law == "hump":
        return x * np.exp(1.0 - x)
    if law == "lugre":
        return np.exp(-(x**2))
    if law == COULOMB_VISCOUS:
        return np.zeros_like(x)
    raise UsageError(f"friction law must be one of {', '.join(LAWS)}, got {law!r}", parameter="law")


def law_shape_slope(law: str, x) -> np.ndarray:
    """Derivative ``phi'(x)`` of :func:`law_shape` [-] (for Jacobians), vectorised."""
    x = np.asarray(x, dtype=float)
    if law == "stribeck":
        return -np.exp(-x)
    if law == "hump":
        return (1.0 - x) * np.exp(1.0 - x)
    if law == "lugre":
        return -2.0 * x * np.exp(-(x**2))
    if law == COULOMB_VISCOUS:
        return np.zeros_like(x)
    raise UsageError(f"friction law must be one of {', '.join(LAWS)}, got {law!r}", parameter="law")


def level_shape(dc: float, ds: float) -> str:
    """``"peak"`` when the static level ``ds`` (the hump law's peak) lies above the Coulomb level ``dc`` in magnitude,
    ``"dip"`` when below, ``"flat"`` when equal (module docstring; signed levels of one direction)."""
    if abs(ds) > abs(dc):
        return "peak"
    return "dip" if abs(ds) < abs(dc) else "flat"


def level_sign_problem(name: str, value: float, unit: str) -> str | None:
    """What is wrong with the sign of one friction parameter, or None.

    Parameters
    ----------
    name : str
        ``dc_pos``, ``ds_pos``, ``dc_neg``, ``ds_neg``, ``viscous_pos`` or ``viscous_neg``.
    value : float
        Its value [command unit, or command unit/(velocity unit) for a viscous coefficient].
    unit : str
        Its unit, for the sentence.

    Returns
    -------
    str or None
        E.g. ``"ds_pos = -108 N must be >= 0 (the friction level for v > 0 has the sign of the motion)"``.
    """
    if name.startswith("viscous"):
        return None if value >= 0 else f"{name} = {value:.4g} {unit} must be >= 0"
    positive = name.endswith("_pos")
    if (value >= 0) if positive else (value <= 0):
        return None
    way, need = ("v > 0", ">= 0") if positive else ("v < 0", "<= 0")
    return f"{name} = {value:.4g} {unit} must be {need} (the friction level for {way} has the sign of the motion)"


@dataclass(frozen=True)
class FrictionLaw(StribeckFriction):
    """Friction curve of a chosen law with a viscous term, per direction (module docstring).

    Extends :class:`StribeckFriction` (same signed levels and characteristic velocities ``omega``, which are the
    laws' ``vs``) by the law and the viscous coefficients; ``FrictionLaw(law="stribeck")`` with zero viscous
    friction is eq. 2.1. For the ``hump`` law ``ds`` is the peak level reached at ``|v| = omega`` (not the level
    at rest, which is ``dc``).

    Parameters
    ----------
    dc_pos, ds_pos, dc_neg, ds_neg : float
        Signed levels [command unit] (``>= 0`` for ``v > 0``, ``<= 0`` for ``v < 0``; :meth:`sign_problems`).
    omega_pos, omega_neg : float
        ``vs`` per direction [velocity unit], > 0 (``omega_neg=None`` uses ``omega_pos``).
    command_unit, velocity_unit : str
        As for :class:`StribeckFriction`.
    law : str
        ``"stribeck"``, ``"hump"`` or ``"lugre"`` (:data:`LAWS`).
    viscous_pos : float
        Viscous coefficient ``Fv`` for ``v > 0`` [command unit/(velocity unit)].
    viscous_neg : float or None
        ``Fv`` for ``v < 0``; ``None`` uses ``viscous_pos``.

    Examples
    --------
    >>> f = FrictionLaw(dc_pos=20.0, ds_pos=30.0, dc_neg=-20.0, ds_neg=-30.0, omega_pos=0.01, law="hump",
    ...                 viscous_pos=100.0)
    >>> [round(float(x), 3) for x in f.force([0.01, 0.0, -0.01])]
    [31.0, 0.0, -31.0]
    """

    law: str = "stribeck"
    viscous_pos: float = 0.0
    viscous_neg: float | None = None

    def __post_init__(self) -> None:
        super().__post_init__()
        check_law(self.law)
        if self.law == COULOMB_VISCOUS and (self.ds_pos != self.dc_pos or self.ds_neg != self.dc_neg):
            raise DataError(f"a {COULOMB_VISCOUS} friction law has no static level: ds_pos, ds_neg must equal dc_pos, "
                            f"dc_neg (got {self.ds_pos:.4g} vs {self.dc_pos:.4g}, {self.ds_neg:.4g} vs "
                            f"{self.dc_neg:.4g})")
        for name in VISCOUS_NAMES:
            raw = getattr(self, name)
            if raw is None:
                continue
            value = float(raw)
            if not np.isfinite(value):
                raise DataError(f"friction parameter {name} must be finite, got {value}")
            object.__setattr__(self, name, value)

    @classmethod
    def coulomb_viscous(cls, dc_pos: float, dc_neg: float, viscous_pos: float, viscous_neg: float | None = None, *,
                        command_unit: str = "N", velocity_unit: str = "m/s") -> FrictionLaw:
        """The ``coulomb-viscous`` law ``F = dc + Fv v`` per direction (``ds = dc``; ``omega`` is not used and set to
        1 velocity unit).

        Parameters
        ----------
        dc_pos, dc_neg : float
            Signed Coulomb levels [command unit] (``>= 0`` for ``v > 0``, ``<= 0`` for ``v < 0``).
        viscous_pos, viscous_neg : float
            Viscous coefficients [command unit/(velocity unit)]; ``viscous_neg=None`` uses ``viscous_pos``.
        command_unit, velocity_unit : str
            As for :class:`StribeckFriction`.

        Examples
        --------
        >>> f = FrictionLaw.coulomb_viscous(20.0, -18.0, 200.0)
        >>> [round(float(x), 3) for x in f.force([0.1, 0.0, -0.1])]
        [40.0, 0.0, -38.0]
        """
        return cls(dc_pos=dc_pos, ds_pos=dc_pos, dc_neg=dc_neg, ds_neg=dc_neg, omega_pos=1.0,
                   command_unit=command_unit, velocity_unit=velocity_unit, law=COULOMB_VISCOUS,
                   viscous_pos=viscous_pos, viscous_neg=viscous_neg)

    @property
    def viscous_negative(self) -> float:
        """Viscous coefficient used for ``v < 0`` [command unit/(velocity unit)]."""
        return self.viscous_pos if self.viscous_neg is None else float(self.viscous_neg)

    @property
    def has_static_level(self) -> bool:
        """False for the ``coulomb-viscous`` law (no ``ds``, no ``omega``)."""
        return self.law != COULOMB_VISCOUS

    @property
    def characteristic_speed(self) -> float:
        """As :attr:`StribeckFriction.characteristic_speed`; for the ``coulomb-viscous`` law the speed ``Fc / Fv`` at
        which the viscous term reaches the Coulomb level (the larger of the directions; 0 without viscous friction)."""
        if self.has_static_level:
            return super().characteristic_speed
        return max((abs(dc) / fv for dc, fv in ((self.dc_pos, self.viscous_pos), (self.dc_neg, self.viscous_negative))
                    if fv > 0), default=0.0)

    def force(self, velocity) -> np.ndarray:
        """Friction force of the law [command unit] (vectorised; exactly 0 at ``v = 0``).

        Parameters
        ----------
        velocity : array_like
            Velocity [velocity unit].

        Returns
        -------
        ndarray
            ``dc (1 - phi) + ds phi + Fv v`` with the direction's parameters, same shape as ``velocity``.
        """
        v = np.asarray(velocity, dtype=float)
        speed = np.abs(v)
        phi_pos = law_shape(self.law, speed / self.omega_pos)
        phi_neg = law_shape(self.law, speed / self.omega_negative)
        pos = self.dc_pos + (self.ds_pos - self.dc_pos) * phi_pos + self.viscous_pos * v
        neg = self.dc_neg + (self.ds_neg - self.dc_neg) * phi_neg + self.viscous_negative * v
        return np.where(v > 0, pos, np.where(v < 0, neg, 0.0))

    def sign_problems(self) -> list[tuple[str, str]]:
        """As :meth:`StribeckFriction.sign_problems`, plus viscous coefficients that must be ``>= 0``."""
        unit = f"{self.command_unit}/({self.velocity_unit})"
        found = [(n, level_sign_problem(n, v, unit))
                 for n, v in (("viscous_pos", self.viscous_pos), ("viscous_neg", self.viscous_negative))]
        return super().sign_problems() + [(n, text) for n, text in found if text]

    def without_viscous(self) -> StribeckFriction | FrictionLaw:
        """The curve without its viscous term: a :class:`StribeckFriction` (eq. 2.1) for the ``stribeck`` law."""
        levels = {n: getattr(self, n) for n in LEVEL_NAMES}
        common = {**levels, "omega_pos": self.omega_pos, "omega_neg": self.omega_neg,
                  "command_unit": self.command_unit, "velocity_unit": self.velocity_unit}
        if self.law == "stribeck":
            return StribeckFriction(**common)
        return FrictionLaw(**common, law=self.law)

    def to_dict(self) -> dict:
        """JSON-ready parameters with their units (``model`` is the law; the ``coulomb-viscous`` law has no
        ``ds_*`` and ``omega_*``)."""
        d = super().to_dict()
        vu = f"{self.command_unit}/({self.velocity_unit})"
        d.update({"model": self.law, "formula": LAW_FORMULAS[self.law], "viscous_pos": self.viscous_pos,
                  "viscous_neg": self.viscous_negative})
        d["units"] = {**d["units"], "viscous_pos": vu, "viscous_neg": vu}
        if not self.has_static_level:
            for name in ("ds_pos", "ds_neg", "omega_pos", "omega_neg"):
                d.pop(name)
                d["units"].pop(name)
        return d

    __repr__ = StribeckFriction.__repr__
