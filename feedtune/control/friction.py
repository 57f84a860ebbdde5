"""Friction feedforward from an identified Stribeck model (thesis §2, §3.2: "Stribeck-type friction compensation").

The command gets ``u_ff += d(v_r)`` where ``d`` is the friction of eq. 2.1 (:class:`StribeckFriction`, the
force the drive must supply, in the drive's command unit) and ``v_r`` the reference velocity of the law's
previewed (and pre-filtered, when there is a ``[prefilter]``) reference, by backward difference::

    v_r[k] = (x_r'[k+P] - x_r'[k+P-1]) * fs     [rad/s of screw rotation];  v_r = 0 on the first sample

It depends on the reference only, so it is computed with the other reference paths (for a whole trajectory
at once in :meth:`feedtune.machines.ballscrew.runtime.GainsRuntime.reference_signals`).

Near ``v = 0`` eq. 2.1 jumps between the static levels ``ds-`` and ``ds+``; a reference that dwells or
reverses would switch the full static friction on and off. Inside a small band ``|v| < v_band`` the
feedforward is the straight line through zero that meets the curve at the band edges
(:meth:`StribeckFriction.smoothed`): continuous, 0 at rest. ``v_band`` defaults to a tenth of the smaller
Stribeck velocity ``Omega`` (where the friction changes fastest anyway).

Units: the ball-screw law's positions are rad of screw rotation, so a friction model identified on the table
in m/s is converted with the screw lead ``lead_m_per_rad`` (from the gains file's ``[model]``): the Stribeck
velocities and the band are stored in rad/s. The friction levels must be in the gains file's command unit.

Friction laws (:class:`~feedtune.models.friction.FrictionLaw`): a ``stribeck`` law is fed forward as eq. 2.1
without its viscous term (the design's own feedforward ``(b1 + b2) s`` carries the viscous friction; the dropped
coefficients are recorded in ``source``). The ``hump`` and ``lugre`` laws are refused: the gains file's
``[friction_feedforward]``, the runtime and the C export implement eq. 2.1 only.
"""

from __future__ import annotations

import copy
import math
from dataclasses import dataclass

import numpy as np

from ..errors import DataError, UsageError
from ..models.friction import FrictionLaw, StribeckFriction

LEVELS = ("dc_pos", "ds_pos", "dc_neg", "ds_neg")
VELOCITY = "rad/s"
BAND_FRACTION = 0.1
"""Default ``v_band`` as a fraction of the smaller Stribeck velocity [-]."""
VELOCITY_TEXT = ("v_r[k] = (x_r'[k+P] - x_r'[k+P-1]) * fs (backward difference of the previewed, pre-filtered "
                 "reference; 0 on the first sample); uff += d(v_r), linear through 0 for |v_r| < v_band")


@dataclass(frozen=True)
class FrictionFeedforward:
    """Stribeck friction feedforward in the law's units (command unit, rad/s of screw rotation).

    Attributes
    ----------
    friction : StribeckFriction
        Eq. 2.1 with velocities in rad/s and levels in the command unit.
    v_band : float
        Half-width of the linear band around ``v = 0`` [rad/s], > 0.
    source : dict
        The model as given (its own units) and the lead used to convert it (information only).
    """

    friction: StribeckFriction
    v_band: float
    source: dict | None = None

    def __post_init__(self) -> None:
        if self.friction.velocity_unit != VELOCITY:
            raise DataError(f"friction feedforward needs velocities in {VELOCITY}, got {self.friction.velocity_unit}")
        if not (math.isfinite(self.v_band) and self.v_band > 0):
            raise UsageError(f"friction band must be > 0 {VELOCITY}, got {self.v_band!r}")

    @property
    def command_unit(self) -> str:
        """Unit of the feedforward command (the friction levels)."""
        return self.friction.command_unit

    def command(self, velocity) -> np.ndarray:
        """Feedforward ``d(v)`` [command unit] for reference velocities ``velocity`` [rad/s] (vectorised)."""
        return self.friction.smoothed(velocity, self.v_band)

    def edges(self) -> tuple[float, float]:
        """``d(+v_band), d(-v_band)`` [command unit]: the slopes' end points of the band."""
        pos, neg = self.friction.force(np.array([self.v_band, -self.v_band]))
        return float(pos), float(neg)

    def section(self) -> dict:
        """The ``[friction_feedforward]`` section of a gains file."""
        f, u = self.friction, self.command_unit
        sec = {
            "model": "stribeck",
            "velocity": VELOCITY_TEXT,
            **{n: {"value": getattr(f, n), "unit": u} for n in LEVELS},
            "omega_pos": {"value": f.omega_pos, "unit": VELOCITY},
            "omega_neg": {"value": f.omega_negative, "unit": VELOCITY},
            "v_band": {"value": float(self.v_band), "unit": VELOCITY},
        }
        if self.source:
            sec["source"] = copy.deepcopy(self.source)
        return sec

    def to_dict(self) -> dict:
        """JSON-ready parameters with units."""
        d = self.friction.to_dict()
        d["v_band"] = float(self.v_band)
        d["units"] = {**d["units"], "v_band": VELOCITY}
        return d


def friction_feedforward(friction: StribeckFriction, *, command_unit: str, lead_m_per_rad: float,
                         v_band: float | None = None, where: str = "friction model") -> FrictionFeedforward:
    """Convert an identified friction model to the law's units.

    Parameters
    ----------
    friction : StribeckFriction or FrictionLaw
        Identified model; velocities in m/s (table travel) or rad/s (screw rotation). A ``stribeck``
        :class:`FrictionLaw` is fed forward without its viscous term (module docstring).
    command_unit : str
        The gains file's command unit; the model's levels must be in it.
    lead_m_per_rad : float
        Screw lead [m/rad] (table travel per rad of screw rotation), used for an m/s model.
    v_band : float, optional
        Half-width of the linear band around zero velocity, in the MODEL's velocity unit (m/s or rad/s);
        default :data:`BAND_FRACTION` times the smaller Stribeck velocity.
    where : str
        Name of the friction model for messages.

    Raises
    ------
    DataError
        The model's command unit differs from ``command_unit``, a bad lead, or a law other than ``stribeck``.
    UsageError
        ``v_band`` not > 0.
    """
    dropped = {}
    if isinstance(friction, FrictionLaw):
        if friction.law != "stribeck":
            raise DataError(f"{where}: a {friction.law!r} friction law cannot be fed forward (the gains file's "
                            "[friction_feedforward] and the C export implement eq. 2.1 only); identify the friction "
                            "with --law stribeck")
        unit = f"{friction.command_unit}/({friction.velocity_unit})"
        dropped = {"viscous_not_fed_forward": {"pos": {"value": friction.viscous_pos, "unit": unit},
                                               "neg": {"value": friction.viscous_negative, "unit": unit}}}
        friction = friction.without_viscous()
    if friction.command_unit != command_unit:
        raise DataError(f"{where}: friction levels are in {friction.command_unit!r} but the gains file's command is "
                        f"in {command_unit!r}; identify the friction from the drive command in {command_unit}")
    if not (isinstance(lead_m_per_rad, (int, float)) and math.isfinite(lead_m_per_rad) and lead_m_per_rad > 0):
        raise DataError(f"{where}: the screw lead must be > 0 m/rad, got {lead_m_per_rad!r}")
    per_rad = lead_m_per_rad if friction.velocity_unit == "m/s" else 1.0  # model velocity per rad/s
    if v_band is None:
        v_band = BAND_FRACTION * min(friction.omega_pos, friction.omega_negative)
    if isinstance(v_band, bool) or not isinstance(v_band, (int, float)) or not (math.isfinite(v_band) and v_band > 0):
        raise UsageError(f"friction band must be > 0 {friction.velocity_unit}, got {v_band!r}")
    converted = StribeckFriction(friction.dc_pos, friction.ds_pos, friction.dc_neg, friction.ds_neg,
                                 friction.omega_pos / per_rad, friction.omega_negative / per_rad,
                                 command_unit=command_unit, velocity_unit=VELOCITY)
    source = {**friction.to_dict(), "velocity_unit": friction.velocity_unit,
              "lead_m_per_rad": {"value": float(lead_m_per_rad), "unit": "m/rad"},
              "v_band": {"value": float(v_band), "unit": friction.velocity_unit}, **dropped}
    return FrictionFeedforward(converted, float(v_band) / per_rad, source)


def reference_velocity(x_ref, fs: float) -> np.ndarray:
    """Backward difference ``(x[k] - x[k-1]) fs`` with 0 on the first sample [rad/s for x in rad]."""
    x = np.asarray(x_ref, dtype=float)
    return np.diff(x, prepend=x[:1]) * float(fs)


