"""The drive cascade of a one-encoder axis with given values (:mod:`feedtune.control.cascade`), and the plant it is
made for.

:func:`cascade_plant` turns what a user gives into the plant model of the analysis
(:class:`~feedtune.models.cascade_plant.CascadePlant`) and the measured FRF, if any:

* a rigid-body model (``identify rigid``: one inertia or mass, rad or m) or a two-mass model (``identify
  ballscrew``): the mechanics; without a measured FRF the drive's current loop is *assumed* a first-order lag at
  ``current_loop_hz`` (:data:`ASSUMED_CURRENT_LOOP_HZ` unless given), which the design then rests on and says so;
* a measured FRF of one channel (current or torque setpoint in; motor speed or position out, converted by its
  quantity) or of both encoders: the FRF is the plant; the model below and above its band is a rigid body fitted to
  its lowest lines (:func:`plant_from_frf`), unless a model is given too.

:func:`design_cascade` builds the law from given values (``feedtune design cascade``); :func:`feedtune.tune.cascade.
tune_cascade` tunes it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from ..control.cascade import CascadeLaw, describe_filter
from ..errors import DataError, UsageError
from ..frf import Frf
from ..models.ballscrew import BallScrewModel
from ..models.cascade_plant import CascadePlant, measured_plant
from ..models.rigid import RigidBodyModel

ASSUMED_CURRENT_LOOP_HZ = 1000.0
"""The current-loop bandwidth [Hz] assumed for a model without a measured FRF: a drive's closed current loop at a
125 us speed-loop clock (62.5 us current clock) typically reaches 1-2 kHz; the lower end is assumed (a slower current
loop costs phase at the speed loop's crossover). Give the drive's own value (``current_loop_hz``) when known."""
FIT_OCTAVES = 2.0
"""The rigid body of an FRF is fitted on its lines from the first up to this many octaves above it."""
FIT_MIN_LINES = 3


def plant_from_frf(frf: Frf, command_unit: str | None = None, position_unit: str | None = None, *,
                   channel: str | None = None) -> tuple[CascadePlant, str]:
    """A rigid body fitted to the lowest lines of an FRF's motor channel, and how (one line).

    ``u / v = J s + B`` (``v`` the speed) by least squares on the lines from the first up to :data:`FIT_OCTAVES`
    above it (at least :data:`FIT_MIN_LINES`): the inertia and the viscous friction the drive's current setpoint
    sees there (a two-mass axis below its anti-resonance: the whole inertia). No current loop: the FRF holds it.

    Raises
    ------
    DataError
        Units that differ from the ones asked, or lines that give no positive inertia.
    """
    if (command_unit is not None and frf.input_unit != command_unit) or \
            (position_unit is not None and frf.output_unit != position_unit):
        raise DataError(f"{frf.source}: the FRF is in {frf.output_unit} per {frf.input_unit}, the controller in "
                        f"{position_unit} per {command_unit}")
    lines, h, _, names = measured_plant(frf, motor_channel=channel)
    sel = lines <= lines[0] * 2.0 ** FIT_OCTAVES
    if sel.sum() < FIT_MIN_LINES:
        sel = np.arange(lines.size) < FIT_MIN_LINES
    s = 2j * np.pi * lines[sel]
    inv = 1.0 / (s * h[0, sel])  # u / v
    A = np.column_stack([np.r_[np.zeros(s.size), s.imag], np.r_[np.ones(s.size), np.zeros(s.size)]])
    (J, B), *_ = np.linalg.lstsq(A, np.r_[inv.real, inv.imag], rcond=None)
    if not (math.isfinite(J) and J > 0):
        raise DataError(f"{frf.source}: the lowest lines ({lines[sel][0]:.4g}-{lines[sel][-1]:.4g} Hz) of "
                        f"{names[0]} give no positive inertia (J = {J:.3g}); is it a speed or position response to "
                        "the current setpoint?")
    B = max(float(B), 0.0)
    mech = RigidBodyModel(mass=float(J), viscous=B, command_unit=frf.input_unit, position_unit=frf.output_unit)
    note = (f"rigid body J = {J:.4g} {frf.input_unit}/({frf.output_unit}/s^2), B = {B:.4g} "
            f"{frf.input_unit}/({frf.output_unit}/s) fitted on {frf.source} {names[0]} at "
            f"{lines[sel][0]:.4g}-{lines[sel][-1]:.4g} Hz (the model below and above the FRF's band)")
    return CascadePlant(mech), note


@dataclass(frozen=True)
class CascadeSource:
    """What the design's plant is and what it rests on.

    Attributes
    ----------
    plant : CascadePlant
        The model (model cases; the measured plant below and above its band).
    frf : Frf or None
        The measured FRF the design is made on.
    motor_channel, load_channel : str or None
        Its channels.
    rests_on : str
        One line: the measured FRF, or the model with the current loop assumed.
    """

    plant: CascadePlant
    frf: Frf | None = None
    motor_channel: str | None = None
    load_channel: str | None = None
    rests_on: str = ""

    def channels(self) -> dict:
        """``motor_channel``, ``load_channel`` as keyword arguments of the analysis."""
        return {"motor_channel": self.motor_channel, "load_channel": self.load_channel}


def cascade_plant(plant, *, frf: Frf | None = None, current_loop_hz: float | None = None,
                  motor_channel: str | None = None, load_channel: str | None = None) -> CascadeSource:
    """Normalise what a user gives as the plant of a cascade (module docstring).

    Parameters
    ----------
    plant : RigidBodyModel, BallScrewModel, CascadePlant, Frf or CascadeSource
        The model, or a measured FRF (then the plant is the FRF).
    frf : Frf, optional
        A measured FRF beside a model (the design is then made on it).
    current_loop_hz : float, optional
        The drive's current-loop bandwidth [Hz]; default: none beside a measured FRF (it holds the current loop),
        :data:`ASSUMED_CURRENT_LOOP_HZ` for a model alone.
    motor_channel, load_channel : str, optional
        The FRF's channels (default: its only one; ``x1/...`` and ``x2/...`` of two).
    """
    if isinstance(plant, CascadeSource):
        return plant
    if isinstance(plant, Frf):
        if frf is not None and frf is not plant:
            raise UsageError("give the measured FRF once: as the plant or as frf=", parameter="frf")
        made, note = plant_from_frf(plant, channel=motor_channel)
        if current_loop_hz is not None:
            made = replace(made, current_loop_hz=float(current_loop_hz))
        return CascadeSource(made, plant, motor_channel, load_channel,
                             f"the measured FRF {plant.source}; model: {note}")
    if isinstance(plant, CascadePlant):
        made = plant if current_loop_hz is None else replace(plant, current_loop_hz=float(current_loop_hz))
    elif isinstance(plant, (RigidBodyModel, BallScrewModel)):
        cl = current_loop_hz if current_loop_hz is not None else (None if frf is not None else ASSUMED_CURRENT_LOOP_HZ)
        made = CascadePlant(plant, cl)
    else:
        raise UsageError(f"cannot use a {type(plant).__name__} as the plant of a cascade; give a rigid-body or "
                         "two-mass model, or a measured FRF", parameter="plant")
    if frf is not None:
        if frf.input_unit != made.command_unit or frf.output_unit != made.position_unit:
            raise DataError(f"{frf.source}: the FRF is in {frf.output_unit} per {frf.input_unit}, the model in "
                            f"{made.position_unit} per {made.command_unit}")
        return CascadeSource(made, frf, motor_channel, load_channel, f"the measured FRF {frf.source}")
    cl = ("an ideal current loop" if made.current_loop_hz is None else
          f"a first-order current loop at {made.current_loop_hz:g} Hz")
    assumed = " (assumed: give the drive's own with current_loop_hz)" if current_loop_hz is None and \
        made.current_loop_hz == ASSUMED_CURRENT_LOOP_HZ else ""
    return CascadeSource(made, None, rests_on=f"the model alone ({'two-mass' if made.two_mass else 'rigid body'}) "
                                              f"with {cl}{assumed} and the computational delay; no measured FRF")


@dataclass(frozen=True)
class CascadeDesign:
    """A cascade law with the plant it was made for.

    Attributes
    ----------
    law : CascadeLaw
    source : CascadeSource
        The plant model, the measured FRF and what the design rests on.
    tuning : dict or None
        The tuner's record (None for given values).
    """

    law: CascadeLaw
    source: CascadeSource
    tuning: dict | None = field(default=None, repr=False)

    kind = "cascade"

    @property
    def plant(self) -> CascadePlant:
        """The plant model."""
        return self.source.plant

    @property
    def frf(self) -> Frf | None:
        """The measured FRF it was made on."""
        return self.source.frf

    @property
    def gains(self) -> dict:
        """:meth:`CascadeLaw.gains`."""
        return self.law.gains()

    def design_dict(self) -> dict:
        """The design record of the gains file: the law, the plant, what it rests on, the tuning."""
        return {"structure": "cascade", "rests_on": self.source.rests_on, "plant": self.plant.to_dict(),
                "frf": None if self.frf is None else self.frf.source,
                "filters": [describe_filter(f) for f in self.law.enabled_filters],
                "speed_fs_hz": self.law.fs, "position_fs_hz": self.law.fp,
                "checked_case": "discrete" if self.frf is not None else "ideal_discrete",
                **({"tuning": self.tuning} if self.tuning else {})}

    def __repr__(self) -> str:
        return f"CascadeDesign({self.law!r}; on {self.source.rests_on})"


def design_cascade(plant, *, kp: float, tn_s: float, filters=(), kv: float = 0.0, fs: float = 8000.0,
                   position_ratio: int = 8, delay_samples: int = 1, kv_ff: float = 1.0,
                   inertia_ff: float | None = None, position_encoder: str = "motor", frf: Frf | None = None,
                   current_loop_hz: float | None = None, motor_channel: str | None = None,
                   load_channel: str | None = None, tuning: dict | None = None) -> CascadeDesign:
    """A cascade with given values.

    Parameters
    ----------
    plant : RigidBodyModel, BallScrewModel, CascadePlant, Frf or CascadeSource
        See :func:`cascade_plant`.
    kp : float
        Speed-loop gain ``Kp`` [U/(pos/s)].
    tn_s : float
        Integral time ``Tn`` [s] (``inf``: none).
    filters : sequence of DriveFilter
        Current-setpoint filters (:mod:`feedtune.control.drive_tuning`), in order.
    kv : float
        Position-loop gain [1/s] (0: no position loop).
    fs : float
        Speed-loop rate [Hz].
    position_ratio : int
        Speed samples per position sample (the position loop at ``fs / position_ratio``).
    delay_samples : int
        Computational delay [speed samples].
    kv_ff : float
        Velocity feedforward factor [-].
    inertia_ff : float, optional
        Acceleration feedforward [U/(pos/s^2)]; default the plant's inertia.
    position_encoder : {"motor", "load"}
        The encoder of the position loop (``load``: a two-mass model or an FRF with ``x2``).
    frf, current_loop_hz, motor_channel, load_channel
        See :func:`cascade_plant`.
    tuning : dict, optional
        A tuner's record.
    """
    src = cascade_plant(plant, frf=frf, current_loop_hz=current_loop_hz, motor_channel=motor_channel,
                        load_channel=load_channel)
    p = src.plant
    if position_encoder == "load" and not p.two_mass and (src.frf is None or len(src.frf.outputs) < 2):
        raise UsageError("the position loop on the load encoder needs a two-mass model or an FRF with the load "
                         "channel (x2)", parameter="position_encoder")
    law = CascadeLaw(kp, tn_s, tuple(filters), kv, fs, position_ratio, delay_samples, kv_ff,
                     p.inertia if inertia_ff is None else inertia_ff, position_encoder, p.command_unit,
                     p.position_unit)
    return CascadeDesign(law, src, tuning)


__all__ = ["ASSUMED_CURRENT_LOOP_HZ", "CascadeDesign", "CascadeSource", "cascade_plant", "design_cascade",
           "plant_from_frf"]
