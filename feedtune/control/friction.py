"""Friction feedforward from an identified friction model (thesis §2, §3.2: "Stribeck-type friction compensation").

The command gets ``u_ff += d(v_r)`` where ``d`` is the friction of eq. 2.1 with its viscous term
(``d(v) = eq. 2.1 + Fv v``, Fv per direction; :class:`~feedtune.models.friction.FrictionLaw`, the force the drive must
supply, in the drive's command unit) and ``v_r`` the reference velocity of the law's previewed (and pre-filtered,
when there is a ``[prefilter]``) reference, by backward difference::

    v_r[k] = (x_r'[k+P] - x_r'[k+P-1]) * fs     [rad/s of screw rotation];  v_r = 0 on the first sample

It depends on the reference only, so it is computed with the other reference paths (for a whole trajectory
at once in :meth:`feedtune.machines.ballscrew.runtime.GainsRuntime.reference_signals`).

Near ``v = 0`` eq. 2.1 jumps between the static levels ``ds-`` and ``ds+``; a reference that dwells or
reverses would switch the full static friction on and off. Inside a small band ``|v| < v_band`` the
feedforward is the straight line through zero that meets the curve at the band edges
(:meth:`StribeckFriction.smoothed` of the whole curve, viscous term included): continuous, 0 at rest. ``v_band``
defaults to a tenth of the smaller Stribeck velocity ``Omega`` (where the friction changes fastest anyway); for the
``coulomb-viscous`` law, which has none, a tenth of the speed ``Fc / Fv`` at which its viscous term reaches its
Coulomb level.

Units: the ball-screw law's positions are rad of screw rotation, so a friction model identified on the table
in m/s is converted with the screw lead ``lead_m_per_rad`` (from the gains file's ``[model]``): the Stribeck
velocities and the band are stored in rad/s. A linear axis (the loop-shaped x axis, ``lead_m_per_rad=None``) runs
in m and m/s: its model must be in m/s and is stored as it is. The friction levels must be in the gains file's
command unit.

Viscous friction (one law for runtime, twin and C header): a model with a viscous term (the joint fit's
:class:`~feedtune.models.friction.FrictionLaw`; on EMPS 190 N/(m/s), about 25 N at 0.13 m/s, more than its 20 N
Coulomb level) is fed forward with it. A design whose linear feedforward already carries viscous friction (the ball
screw's ``U_ff = ... + (b1 + b2) s``: ``linear_viscous`` = its velocity gain ``U_ff'(0)``) gets the difference, so
the viscous friction is fed forward once, as identified: ``Fv_ff = Fv - linear_viscous`` (negative when the model's
damping exceeds the friction's). A model without a viscous term (eq. 2.1 alone, identified with a given mass and
viscous coefficient) adds none. The x axis and the gantry feed forward the mass only: they get the whole ``Fv``.

Laws: ``stribeck`` (eq. 2.1) and ``coulomb-viscous`` (``ds = dc``) are fed forward; ``hump`` and ``lugre`` are refused
(the gains file's ``[friction_feedforward]``, the runtime and the C export implement eq. 2.1's shape).
"""

from __future__ import annotations

import copy
import math
from dataclasses import dataclass

import numpy as np

from ..errors import DataError, UsageError
from ..models.friction import COULOMB_VISCOUS, FrictionLaw, StribeckFriction

LEVELS = ("dc_pos", "ds_pos", "dc_neg", "ds_neg")
VELOCITY = "rad/s"
"""Velocity unit of a rotary law (the ball screw's) [rad/s]."""
LINEAR_VELOCITY = "m/s"
"""Velocity unit of a linear axis' law (the loop-shaped x axis) [m/s]."""
VELOCITY_UNITS = (VELOCITY, LINEAR_VELOCITY)
BAND_FRACTION = 0.1
"""Default ``v_band`` as a fraction of the smaller Stribeck velocity [-]."""
VELOCITY_TEXT = ("v_r[k] = (x_r'[k+P] - x_r'[k+P-1]) * fs (backward difference of the previewed, pre-filtered "
                 "reference; 0 on the first sample); uff += d(v_r), linear through 0 for |v_r| < v_band")


@dataclass(frozen=True)
class FrictionFeedforward:
    """Friction feedforward in the law's units (command unit; rad/s of screw rotation or m/s of a linear axis).

    Attributes
    ----------
    friction : StribeckFriction or FrictionLaw
        Eq. 2.1 (:class:`StribeckFriction`, no viscous term) or a ``stribeck`` or ``coulomb-viscous``
        :class:`FrictionLaw` with the viscous coefficients to feed forward, velocities in the law's velocity unit
        (:data:`VELOCITY_UNITS`) and levels in the command unit.
    v_band : float
        Half-width of the linear band around ``v = 0`` [velocity unit], > 0.
    source : dict
        The model as given (its own units) and the lead used to convert it (information only).
    """

    friction: StribeckFriction
    v_band: float
    source: dict | None = None

    def __post_init__(self) -> None:
        if self.friction.velocity_unit not in VELOCITY_UNITS:
            raise DataError(f"friction feedforward needs velocities in {' or '.join(VELOCITY_UNITS)}, got "
                            f"{self.friction.velocity_unit}")
        if not (math.isfinite(self.v_band) and self.v_band > 0):
            raise UsageError(f"friction band v_band must be > 0 {self.velocity_unit}, got {self.v_band!r}",
                             parameter="v_band")
        omega = min(abs(self.friction.omega_pos), abs(self.friction.omega_negative))
        if self.v_band > omega:
            raise UsageError(f"friction band v_band={self.v_band:g} {self.velocity_unit} is wider than the Stribeck "
                             f"velocity {omega:g} {self.velocity_unit}: the feedforward would be a line where the "
                             "friction has its hump", parameter="v_band")

    @property
    def command_unit(self) -> str:
        """Unit of the feedforward command (the friction levels)."""
        return self.friction.command_unit

    @property
    def velocity_unit(self) -> str:
        """Unit of the reference velocity (rad/s or m/s)."""
        return self.friction.velocity_unit

    @property
    def law(self) -> str:
        """``"stribeck"`` or ``"coulomb-viscous"``."""
        return getattr(self.friction, "law", "stribeck")

    @property
    def viscous(self) -> tuple[float, float]:
        """Viscous coefficients fed forward ``(Fv+, Fv-)`` [command unit/(velocity unit)] (0 for eq. 2.1 alone)."""
        if isinstance(self.friction, FrictionLaw):
            return float(self.friction.viscous_pos), float(self.friction.viscous_negative)
        return 0.0, 0.0

    def command(self, velocity) -> np.ndarray:
        """Feedforward ``d(v)`` [command unit] for reference velocities ``velocity`` [velocity unit] (vectorised)."""
        return self.friction.smoothed(velocity, self.v_band)

    def edges(self) -> tuple[float, float]:
        """``d(+v_band), d(-v_band)`` [command unit], viscous term included: the slopes' end points of the band."""
        pos, neg = self.friction.force(np.array([self.v_band, -self.v_band]))
        return float(pos), float(neg)

    def section(self, velocity_text: str = VELOCITY_TEXT) -> dict:
        """The ``[friction_feedforward]`` section of a gains file (``velocity_text``: how the law forms ``v_r``)."""
        f, u, vu = self.friction, self.command_unit, self.velocity_unit
        cv = self.law == COULOMB_VISCOUS
        sec = {
            "model": self.law,
            "velocity": velocity_text,
            **{n: {"value": getattr(f, n), "unit": u} for n in LEVELS if not (cv and n.startswith("ds"))},
            **({} if cv else {"omega_pos": {"value": f.omega_pos, "unit": vu},
                              "omega_neg": {"value": f.omega_negative, "unit": vu}}),
            "viscous_pos": {"value": self.viscous[0], "unit": f"{u}/({vu})"},
            "viscous_neg": {"value": self.viscous[1], "unit": f"{u}/({vu})"},
            "v_band": {"value": float(self.v_band), "unit": vu},
        }
        if self.source:
            sec["source"] = copy.deepcopy(self.source)
        return sec

    def to_dict(self) -> dict:
        """JSON-ready parameters with units."""
        d = self.friction.to_dict()
        d["v_band"] = float(self.v_band)
        d["units"] = {**d["units"], "v_band": self.velocity_unit}
        return d


def friction_feedforward(friction: StribeckFriction, *, command_unit: str, lead_m_per_rad: float | None,
                         v_band: float | None = None, where: str = "friction model",
                         command_where: str = "the gains file", linear_viscous: float = 0.0) -> FrictionFeedforward:
    """Convert an identified friction model to the law's units.

    Parameters
    ----------
    friction : StribeckFriction or FrictionLaw
        Identified model; velocities in m/s (table travel) or rad/s (screw rotation). A ``stribeck`` or
        ``coulomb-viscous`` :class:`FrictionLaw` is fed forward with its viscous term (module docstring).
    command_unit : str
        The gains file's command unit; the model's levels must be in it.
    lead_m_per_rad : float or None
        Screw lead [m/rad] (table travel per rad of screw rotation), used for an m/s model of a rotary law
        (velocities stored in rad/s). ``None``: a linear axis whose law runs in m/s; the model must be in m/s and is
        not converted.
    v_band : float, optional
        Half-width of the linear band around zero velocity, in the MODEL's velocity unit (m/s or rad/s);
        default :data:`BAND_FRACTION` times the smaller Stribeck velocity (coulomb-viscous: of ``Fc / Fv``).
    where : str
        Name of the friction model for messages.
    command_where : str
        Name of what fixes ``command_unit`` (the gains file, the plant's file) for messages.
    linear_viscous : float
        Viscous coefficient the design's linear feedforward already carries [command unit/(law velocity unit)]
        (the ball screw's ``b1 + b2`` in V/(rad/s)); subtracted from a model's viscous term.

    Raises
    ------
    DataError
        The model's command unit differs from ``command_unit``, a bad lead, a rad/s model for a linear axis, or a
        ``hump`` or ``lugre`` law.
    UsageError
        ``v_band`` not > 0, or no default for it (a coulomb-viscous law without viscous friction).
    """
    law = getattr(friction, "law", "stribeck")
    if law not in ("stribeck", COULOMB_VISCOUS):
        raise DataError(f"{where}: a {law!r} friction law cannot be fed forward (the gains file's "
                        "[friction_feedforward] and the C export implement eq. 2.1 and its viscous term); identify the "
                        f"friction with law=stribeck or law={COULOMB_VISCOUS}", parameter="law")
    if friction.command_unit != command_unit:
        raise DataError(f"{where}: friction levels are in {friction.command_unit!r} but {command_where}'s command is "
                        f"in {command_unit!r}; identify the friction from the drive command in {command_unit}")
    if lead_m_per_rad is None:  # a linear axis: the law's velocities are m/s, the model's must be too
        if friction.velocity_unit != LINEAR_VELOCITY:
            raise DataError(f"{where}: friction velocities are in {friction.velocity_unit!r} but the linear axis of "
                            f"{command_where} moves in {LINEAR_VELOCITY!r}; identify the friction from the axis "
                            "position in m")
        per_rad, law_unit = 1.0, LINEAR_VELOCITY
    else:
        if not (isinstance(lead_m_per_rad, (int, float)) and math.isfinite(lead_m_per_rad) and lead_m_per_rad > 0):
            raise DataError(f"{where}: the screw lead must be > 0 m/rad, got {lead_m_per_rad!r}")
        per_rad, law_unit = (lead_m_per_rad if friction.velocity_unit == "m/s" else 1.0), VELOCITY  # model v per law v
    has_viscous = isinstance(friction, FrictionLaw)
    fv = (friction.viscous_pos, friction.viscous_negative) if has_viscous else (0.0, 0.0)
    if v_band is None:
        v_band = BAND_FRACTION * (min(friction.omega_pos, friction.omega_negative) if law != COULOMB_VISCOUS
                                  else min((abs(dc) / b for dc, b in ((friction.dc_pos, fv[0]),
                                                                      (friction.dc_neg, fv[1])) if b > 0),
                                           default=math.nan))
        if not math.isfinite(v_band):
            raise UsageError(f"{where}: a {COULOMB_VISCOUS} law without viscous friction has no speed to set the "
                             "feedforward's band by; give v_band", parameter="v_band")
    if isinstance(v_band, bool) or not isinstance(v_band, (int, float)) or not (math.isfinite(v_band) and v_band > 0):
        raise UsageError(f"friction band must be > 0 {friction.velocity_unit}, got {v_band!r}")
    # the viscous term in the law's units (command per law velocity), less what the linear feedforward carries
    fed = tuple(b * per_rad - (linear_viscous if has_viscous else 0.0) for b in fv)
    common = {"command_unit": command_unit, "velocity_unit": law_unit}
    if law == COULOMB_VISCOUS:
        converted = FrictionLaw.coulomb_viscous(friction.dc_pos, friction.dc_neg, fed[0], fed[1], **common)
    elif has_viscous:
        converted = FrictionLaw(friction.dc_pos, friction.ds_pos, friction.dc_neg, friction.ds_neg,
                                friction.omega_pos / per_rad, friction.omega_negative / per_rad, **common,
                                viscous_pos=fed[0], viscous_neg=fed[1])
    else:
        converted = StribeckFriction(friction.dc_pos, friction.ds_pos, friction.dc_neg, friction.ds_neg,
                                     friction.omega_pos / per_rad, friction.omega_negative / per_rad, **common)
    lead = {} if lead_m_per_rad is None else {"lead_m_per_rad": {"value": float(lead_m_per_rad), "unit": "m/rad"}}
    vu = f"{command_unit}/({law_unit})"
    carried = ({"viscous_in_linear_feedforward": {"value": float(linear_viscous), "unit": vu}}
               if has_viscous and linear_viscous else {})
    source = {**friction.to_dict(), "velocity_unit": friction.velocity_unit, **lead,
              "v_band": {"value": float(v_band), "unit": friction.velocity_unit}, **carried}
    return FrictionFeedforward(converted, float(v_band) / per_rad, source)


def reference_velocity(x_ref, fs: float) -> np.ndarray:
    """Backward difference ``(x[k] - x[k-1]) fs`` with 0 on the first sample [rad/s for x in rad, m/s for x in m]."""
    x = np.asarray(x_ref, dtype=float)
    return np.diff(x, prepend=x[:1]) * float(fs)


