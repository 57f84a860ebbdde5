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
