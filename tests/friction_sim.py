"""Closed-loop tracking logs of a rigid axis with the thesis' friction law (eq. 2.1), by direct simulation.

Not the fitting code: ``m x'' = u - b x' - d(x')`` with ``d`` eq. 2.1 (or its Gaussian-shaped variant), integrated at
``substeps`` per sample (trapezoidal position); at rest the axis sticks until the command beats the static level of
the direction it pushes (Karnopp: eq. 2.1 is 0 at ``v = 0``, the static level is the break-away force). A PID
position loop with model feedforward ``m a_r + b v_r`` runs at the sample rate on the quantized (and noisy) position
and holds its command over the sample (zero-order hold); the logged command carries white measurement noise.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from feedtune.log import Log


@dataclass(frozen=True)
class Axis:
    """The simulated axis: mass [kg], viscous [N/(m/s)], eq. 2.1's signed levels [N] and Omega [m/s] (``omega_neg``:
    another Omega for ``v < 0``); ``gaussian`` uses ``exp(-(v/Omega)^2)`` instead of ``exp(-|v|/Omega)``."""

    mass: float = 20.0
    viscous: float = 60.0
    dc_pos: float = 12.0
    ds_pos: float = 20.0
    dc_neg: float = -10.0
    ds_neg: float = -17.0
    omega: float = 0.01
    gaussian: bool = False
    omega_neg: float | None = None


_KERNEL: list = []


def _kernel():
    if not _KERNEL:
        import numba

        @numba.njit(cache=False)
        def run(par, xr, vr, ar, fs, substeps, quant, noise_x, gains, out_y, out_u, out_v):  # pragma: no cover
            m, b, dcp, dsp, dcn, dsn, w, gauss, w_neg = par
            kp, kd, ki = gains
            h = 1.0 / (fs * substeps)
            x = xr[0]
            v = 0.0
            integ = 0.0
            y_prev = round(x / quant) * quant
            for k in range(xr.size):
                y = round((x + noise_x[k]) / quant) * quant
                e = xr[k] - y
                integ += e / fs
                u = m * ar[k] + b * vr[k] + kp * e + kd * (vr[k] - (y - y_prev) * fs) + ki * integ
                y_prev = y
                out_y[k] = y
                out_u[k] = u
                out_v[k] = v
                for _ in range(substeps):
                    s = abs(v) / (w if v >= 0 else w_neg)
                    shape = math.exp(-s * s) if gauss != 0.0 else math.exp(-s)
                    if v > 0:
                        d = dcp + (dsp - dcp) * shape
                    elif v < 0:
                        d = dcn + (dsn - dcn) * shape
                    else:
                        d = 0.0
                    v_new = v + h * (u - b * v - d) / m
                    if v == 0.0:  # at rest: stick until the command beats the static level it pushes against
                        if u > dsp:
                            v_new = h * (u - dsp) / m
                        elif u < dsn:
                            v_new = h * (u - dsn) / m
                        else:
                            v_new = 0.0
                    elif v_new * v < 0.0:  # the velocity reaches zero inside the sub-step: it stops there
                        v_new = 0.0
                    x += 0.5 * h * (v + v_new)
                    v = v_new
            return 0

        _KERNEL.append(run)
    return _KERNEL[0]


def simulate(axis: Axis, reference, *, fs: float = 1000.0, substeps: int = 20, quant: float = 1e-7,
             noise_u: float = 0.0, noise_x: float = 0.0, bandwidth_hz: float = 20.0, seed: int = 0,
             true_velocity: bool = False):
    """The closed-loop log (``x`` [m], ``u`` [N]) tracking ``reference = (t, x_r, v_r, a_r)``; with
    ``true_velocity`` also the simulated velocity at the samples [m/s]."""
    t, xr, vr, ar = (np.ascontiguousarray(r, float) for r in reference)
    rng = np.random.default_rng(seed)
    wn = 2 * math.pi * bandwidth_hz
    gains = np.array([axis.mass * wn**2, 2 * 0.8 * wn * axis.mass, axis.mass * wn**3 / 4])
    par = np.array([axis.mass, axis.viscous, axis.dc_pos, axis.ds_pos, axis.dc_neg, axis.ds_neg, axis.omega,
                    1.0 if axis.gaussian else 0.0, axis.omega if axis.omega_neg is None else axis.omega_neg])
    y, u, v = np.empty(t.size), np.empty(t.size), np.empty(t.size)
    _kernel()(par, xr, vr, ar, fs, substeps, quant, rng.normal(0.0, noise_x, t.size) if noise_x else np.zeros(t.size),
              gains, y, u, v)
    u = u + (rng.normal(0.0, noise_u, t.size) if noise_u else 0.0)
    log = Log(t, {"x": y, "u": u}, {"x": "m", "u": "N"}, {"source": "closed-loop simulation"})
    return (log, v) if true_velocity else log


def sine(amplitude: float, freq: float, seconds: float, fs: float = 1000.0):
    """``x_r = A (1 - cos(w t))``: starts at rest, reverses every half period at the peak acceleration."""
    t = np.arange(round(seconds * fs)) / fs
    w = 2 * math.pi * freq
    return t, amplitude * (1 - np.cos(w * t)), amplitude * w * np.sin(w * t), amplitude * w * w * np.cos(w * t)


def chirp(v_peak: float, f0: float, f1: float, seconds: float, fs: float = 1000.0):
    """A velocity chirp of constant amplitude ``v_peak`` from ``f0`` to ``f1`` [Hz], faded in and out over 0.5 s."""
    t = np.arange(round(seconds * fs)) / fs
    phase = 2 * math.pi * (f0 * t + 0.5 * (f1 - f0) / seconds * t * t)
    fade = np.sin(0.5 * math.pi * np.clip(t / 0.5, 0, 1) * np.clip((seconds - t) / 0.5, 0, 1)) ** 2
    v = v_peak * np.sin(phase) * fade
    x = np.concatenate([[0.0], np.cumsum((v[1:] + v[:-1]) / 2) / fs])
    return t, x, v, np.gradient(v, 1 / fs)


def trapezoid(speeds, acc: float, hold: float, fs: float = 1000.0, pause: float = 0.1):
    """A trapezoidal move to every speed each way (ramps at ``acc``, ``hold`` s at speed, ``pause`` s at rest)."""
    tb, vb = [0.0], [0.0]
    for s in speeds:
        for sign in (1.0, -1.0):
            ramp, t0 = s / acc, tb[-1]
            tb += [t0 + ramp, t0 + ramp + hold, t0 + 2 * ramp + hold, t0 + 2 * ramp + hold + pause]
            vb += [sign * s, sign * s, 0.0, 0.0]
    t = np.arange(0.0, tb[-1] + 0.2, 1 / fs)
    v = np.interp(t, tb, vb)
    x = np.concatenate([[0.0], np.cumsum((v[1:] + v[:-1]) / 2) / fs])
    return t, x, v, np.gradient(v, 1 / fs)
