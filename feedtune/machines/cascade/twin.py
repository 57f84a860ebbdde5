"""The twin of a one-encoder drive axis: a rigid or two-mass axis behind a first-order current loop
(:class:`~feedtune.models.cascade_plant.CascadePlant`), closed by the cascade law in one compiled loop.

The plant is discretized exactly for a current setpoint held over each speed-loop sample (:func:`feedtune.lti.zoh`);
the command computed at sample ``k`` acts from sample ``k + delay_samples`` (the computational delay), and an
optional disturbance [U] adds to it at the plant's input (a load torque or force in the command's unit). The closed
loop (:func:`closed_loop`) calls :func:`feedtune.machines.cascade.law.cascade_step` once per sample, the same
function the runtime runs; with the ``numba`` engine the loop and the law are compiled together, with ``python`` the
same source runs interpreted.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...errors import UsageError
from ...lti import zoh
from ...models.cascade_plant import CascadePlant
from ...models.rigid import RigidBodyModel
from ...sim.engine import choose_engine, kernel, sample_vector
from ...sim.params import non_negative_param, positive_param
from . import law as _law

_step = _law.cascade_step  # the compiled law once the numba engine ran


def closed_loop(Ad, Bd, C, par, sos, w, st, r, d, delay, u_out, x1_out, x2_out):
    """The closed loop over ``r.size`` samples (module docstring): fills the commands ``u_out`` [U] and the
    encoders ``x1_out``, ``x2_out`` [pos]."""
    n = r.size
    ns = Ad.shape[0]
    x = np.zeros(ns)
    xn = np.zeros(ns)
    for k in range(n):
        y1 = 0.0
        y2 = 0.0
        for i in range(ns):
            y1 += C[0, i] * x[i]
            y2 += C[1, i] * x[i]
        x1_out[k] = y1
        x2_out[k] = y2
        u_out[k] = _step(par, sos, w, st, r[k], y1, y2)
        ua = d[k]
        if k >= delay:
            ua += u_out[k - delay]
        for i in range(ns):
            acc = Bd[i, 0] * ua
            for j in range(ns):
                acc += Ad[i, j] * x[j]
            xn[i] = acc
        for i in range(ns):
            x[i] = xn[i]


@dataclass(frozen=True)
class CascadeRun:
    """A closed-loop run of the twin.

    Attributes
    ----------
    t : ndarray
        Time [s].
    r : ndarray
        Position setpoint [pos].
    x1, x2 : ndarray
        Motor and load encoders [pos] (equal for a rigid axis).
    u : ndarray
        The commands the law computed [U] (applied ``delay_samples`` later).
    engine : str
    """

    t: np.ndarray
    r: np.ndarray
    x1: np.ndarray
    x2: np.ndarray
    u: np.ndarray
    engine: str

    tripped = False

    def to_dict(self) -> dict:
        """Duration and the peaks."""
        return {"samples": int(self.t.size), "duration_s": float(self.t[-1] + (self.t[1] - self.t[0])
                                                                 if self.t.size > 1 else 0.0),
                "peak_command": float(np.max(np.abs(self.u))), "engine": self.engine}


class CascadeTwin:
    """A drive axis under a cascade law (module docstring).

    Parameters
    ----------
    plant : CascadePlant
        Mechanics and current loop.
    fs : float
        Speed-loop rate [Hz] (the twin's sample rate).
    delay_samples : int
        Computational delay [samples].
    """

    def __init__(self, plant: CascadePlant, fs: float = 8000.0, delay_samples: int = 1) -> None:
        self.plant = plant
        self.fs = positive_param(fs, "fs", "Hz")
        d = non_negative_param(delay_samples, "delay_samples")
        if d != int(d):
            raise UsageError(f"twin parameter delay_samples must be an integer >= 0, got {delay_samples!r}")
        self.delay_samples = int(d)
        A, B, self.C = plant.state_space()
        self.Ad, self.Bd = zoh(A, B, 1.0 / self.fs)

    @classmethod
    def default(cls, overrides: dict | None = None) -> CascadeTwin:
        """A rotary servo motor (J 1.2e-4 N m/(rad/s^2), B 7.03e-5 N m/(rad/s): the HSM150 data's own values, a
        1 kHz current loop) at 8 kHz with one sample of delay; ``overrides`` by name: ``J``, ``B``,
        ``current_loop_hz``, ``fs``, ``delay_samples``."""
        p = {"J": 1.2e-4, "B": 7.03e-5, "current_loop_hz": 1000.0, "fs": 8000.0, "delay_samples": 1}
        unknown = sorted(set(overrides or {}) - set(p))
        if unknown:
            raise UsageError(f"unknown twin parameter {unknown[0]!r}; known: {', '.join(p)}")
        p.update(overrides or {})
        mech = RigidBodyModel(mass=positive_param(p["J"], "J", "N*m/(rad/s^2)"),
                              viscous=non_negative_param(p["B"], "B"), command_unit="N*m", position_unit="rad")
        cl = p["current_loop_hz"]
        return cls(CascadePlant(mech, None if cl is None else positive_param(cl, "current_loop_hz", "Hz")), p["fs"],
                   p["delay_samples"])

    def simulate(self, runtime, r, *, disturbance=None, engine: str = "auto") -> CascadeRun:
        """Run the closed loop with ``runtime`` (a :class:`~feedtune.machines.cascade.runtime.CascadeRuntime`) for
        the position setpoints ``r`` [pos] (one per speed-loop sample) and an optional ``disturbance`` [U] at the
        plant's input.

        Raises
        ------
        DataError
            The runtime was made for another speed-loop rate.
        """
        global _step
        runtime.check_target(self.fs)
        rr = sample_vector(r, "r", min_size=1)
        d = np.zeros(rr.size) if disturbance is None else sample_vector(disturbance, "disturbance", rr.size,
                                                                       min_size=1)
        eng = choose_engine(engine)
        if eng == "numba":
            _step = _law.compiled_step()
        runtime.reset()
        u, x1, x2 = np.zeros(rr.size), np.zeros(rr.size), np.zeros(rr.size)
        kernel(closed_loop, eng)(self.Ad, self.Bd, self.C, *runtime.law.args(), rr, d, self.delay_samples, u, x1, x2)
        return CascadeRun(np.arange(rr.size) / self.fs, rr, x1, x2, u, eng)

    def to_dict(self) -> dict:
        """The plant, the rate and the delay."""
        return {"plant": self.plant.to_dict(), "fs_hz": self.fs, "delay_samples": self.delay_samples}


__all__ = ["CascadeRun", "CascadeTwin", "closed_loop"]
