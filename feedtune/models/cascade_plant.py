"""One drive axis as its speed loop sees it: the mechanics behind the drive's closed current loop.

The mechanics are a rigid body (:class:`~feedtune.models.rigid.RigidBodyModel`: one inertia or mass, rad or m, its
linear part ``1 / (J s^2 + B s)``) or a two-mass axis (:class:`~feedtune.models.ballscrew.BallScrewModel`: motor
side ``x1``, load side ``x2``, in rad). The drive's current loop, from the current setpoint to the current (or
torque) that moves the axis, is taken as a first-order lag ``1 / (1 + s / (2 pi f_c))`` at ``current_loop_hz``
(None: ideal). A measured FRF from the current setpoint contains that lag; a model identified from measured currents
(``identify rigid`` on a torque log) does not, and a design on the model alone rests on the lag assumed here.

Units: the command ``U`` is the mechanics' (A, N m, N, V); positions rad or m.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import DataError, UsageError
from ..frf import Frf
from .ballscrew import BallScrewModel
from .rigid import RigidBodyModel


@dataclass(frozen=True)
class CascadePlant:
    """Mechanics behind a first-order current loop (module docstring).

    Parameters
    ----------
    mechanics : RigidBodyModel or BallScrewModel
        The axis' mechanics [U, rad or m].
    current_loop_hz : float or None
        Bandwidth of the drive's closed current loop [Hz] (a first-order lag); None: ideal.
    """

    mechanics: object
    current_loop_hz: float | None = None

    def __post_init__(self) -> None:
        if not isinstance(self.mechanics, (RigidBodyModel, BallScrewModel)):
            raise UsageError(f"the mechanics of a drive axis are a rigid-body or a two-mass model, got a "
                             f"{type(self.mechanics).__name__}", parameter="plant")
        if self.current_loop_hz is not None:
            f = float(self.current_loop_hz)
            if not (math.isfinite(f) and f > 0):
                raise UsageError(f"current_loop_hz must be a bandwidth > 0 Hz, got {self.current_loop_hz!r}",
                                 parameter="current_loop_hz")
            object.__setattr__(self, "current_loop_hz", f)

    # ---------------------------------------------------------------- what it is
    @property
    def two_mass(self) -> bool:
        """The mechanics have a load side of their own (two encoders possible)."""
        return isinstance(self.mechanics, BallScrewModel)

    @property
    def command_unit(self) -> str:
        """``U``: the unit of the current setpoint (A, N*m, N, V)."""
        m = self.mechanics
        return m.input_unit if isinstance(m, BallScrewModel) else m.command_unit

    @property
    def position_unit(self) -> str:
        """rad or m."""
        return "rad" if isinstance(self.mechanics, BallScrewModel) else self.mechanics.position_unit

    @property
    def inertia(self) -> float:
        """The whole moving inertia ``J`` [U/(pos/s^2)] (the acceleration feedforward)."""
        m = self.mechanics
        return m.m1 + m.m2 if isinstance(m, BallScrewModel) else m.mass

    @property
    def viscous(self) -> float:
        """Linear viscous friction ``B`` [U/(pos/s)] (a rigid body's mean of both directions)."""
        m = self.mechanics
        return m.b1 + m.b2 if isinstance(m, BallScrewModel) else 0.5 * (m.viscous + m.viscous_negative)

    # ---------------------------------------------------------------- responses
    def current_loop(self, freq_hz) -> np.ndarray:
        """The current loop's lag [-] (1 when ideal)."""
        f = np.asarray(freq_hz, float)
        if self.current_loop_hz is None:
            return np.ones(f.shape, complex)
        return 1.0 / (1.0 + 1j * f / self.current_loop_hz)

    def response(self, freq_hz) -> np.ndarray:
        """``[x1/u, x2/u]`` on a grid [Hz], shape ``(2, n)`` [pos/U]: the motor and the load side (equal for a rigid
        body), current loop included."""
        f = np.asarray(freq_hz, float)
        m = self.mechanics
        cl = self.current_loop(f)
        if isinstance(m, BallScrewModel):
            g = m.frequency_response(f, ("G11", "G21"))
            return np.stack([g["G11"] * cl, g["G21"] * cl])
        s = 2j * np.pi * f
        with np.errstate(divide="ignore", invalid="ignore"):
            x = cl / (s * (m.mass * s + self.viscous))
        return np.stack([x, x])

    def features(self) -> np.ndarray:
        """Lightly damped poles ``(Hz, damping)`` of the mechanics, shape ``(k, 2)`` (none for a rigid body)."""
        m = self.mechanics
        if not isinstance(m, BallScrewModel):
            return np.empty((0, 2))
        return np.array([[md.freq_hz, md.zeta] for md in m.modes()]).reshape(-1, 2)

    def state_space(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(A, B, C)``: input the current setpoint [U], outputs ``[x1, x2]`` [pos]; states the mechanics'
        (rigid: ``[x, v]``; two-mass: ``[x1, x2, x1', x2']``) then the current (with a current loop)."""
        m = self.mechanics
        if isinstance(m, BallScrewModel):
            A, Bm, C = m.state_space()
            B = Bm[:, :1]
        else:
            A = np.array([[0.0, 1.0], [0.0, -self.viscous / m.mass]])
            B = np.array([[0.0], [1.0 / m.mass]])
            C = np.array([[1.0, 0.0], [1.0, 0.0]])
        if self.current_loop_hz is None:
            return A, B, C
        wc = 2 * np.pi * self.current_loop_hz
        n = A.shape[0]
        Aa = np.zeros((n + 1, n + 1))
        Aa[:n, :n] = A
        Aa[:n, n:] = B
        Aa[n, n] = -wc
        Ba = np.zeros((n + 1, 1))
        Ba[n, 0] = wc
        return Aa, Ba, np.hstack([C, np.zeros((2, 1))])

    def to_dict(self) -> dict:
        """The mechanics' ``to_dict()`` (a ball screw: its parameters) and the current loop [Hz]."""
        m = self.mechanics
        mech = m.to_dict() if isinstance(m, RigidBodyModel) else {"model": "ballscrew", **m.params(),
                                                                   "input_unit": m.input_unit}
        return {"mechanics": mech, "current_loop_hz": self.current_loop_hz, "inertia": self.inertia,
                "viscous": self.viscous, "command_unit": self.command_unit, "position_unit": self.position_unit}

    def __repr__(self) -> str:
        cl = "ideal current loop" if self.current_loop_hz is None else f"current loop {self.current_loop_hz:g} Hz"
        kind = "two-mass" if self.two_mass else "rigid"
        return (f"CascadePlant({kind}, J={self.inertia:.4g} {self.command_unit}/({self.position_unit}/s^2), "
                f"{cl})")


def measured_plant(frf: Frf, *, motor_channel: str | None = None, load_channel: str | None = None,
                   load: bool = False) -> tuple[np.ndarray, np.ndarray, np.ndarray | None, tuple]:
    """``(lines [Hz], [x1/u, xp/u] position response, coherence or None, channel names)`` of a measured FRF.

    Parameters
    ----------
    frf : Frf
        One channel (the motor side: speed or position per current setpoint), or the motor and the load side.
    motor_channel, load_channel : str, optional
        The channels ``OUT/IN`` (default: the only channel; with two, ``x1/...`` and ``x2/...``).
    load : bool
        The position loop closes on the load encoder (its channel needed).

    Raises
    ------
    DataError
        A channel that is not there, or none to choose by name.
    """
    motor = motor_channel or _channel(frf, "x1")
    if not frf.has(motor):
        raise DataError(f"{frf.source}: no channel {motor!r}; available: {', '.join(frf.channels)}")
    names = [motor]
    if load:
        lc = load_channel or _channel(frf, "x2", required="the position loop closes on the load encoder")
        if not frf.has(lc):
            raise DataError(f"{frf.source}: no channel {lc!r} for the load encoder; available: "
                            f"{', '.join(frf.channels)}")
        names.append(lc)
    pos = frf.as_quantity("position")
    keep = pos.freq_hz > 0
    h = np.stack([pos.channel(c)[keep] for c in names])
    cohs = [pos.channel_coherence(c) for c in names]
    coh = None if any(c is None or not np.all(np.isfinite(c[keep])) for c in cohs) else \
        np.stack([c[keep] for c in cohs])
    if not load:
        h = np.stack([h[0], h[0]])
        coh = None if coh is None else np.stack([coh[0], coh[0]])
        names = [motor, motor]
    return pos.freq_hz[keep], h, coh, tuple(names)


def _channel(frf: Frf, output: str, required: str | None = None) -> str:
    """The channel of ``output`` (``x1``/``x2``), or the FRF's only channel for ``x1``."""
    if output == "x1" and len(frf.channels) == 1:
        return frf.channels[0]
    found = [c for c in frf.channels if c.split("/")[0] == output]
    if len(found) == 1:
        return found[0]
    why = f" ({required})" if required else ""
    raise DataError(f"{frf.source}: the FRF has channels {', '.join(frf.channels)}; no single {output}/... "
                    f"channel{why}: name it (motor_channel=, load_channel=)")


__all__ = ["CascadePlant", "measured_plant"]
