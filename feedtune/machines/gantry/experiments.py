"""Experiments on the gantry twin (thesis §4.3, §4.5), each giving the log a real test would record.

* :func:`measure_gantry_frf` -- the 2x2 FRF at one table position: a random-phase multisine on ``u1`` for
  some periods, then the same on ``u2``, under a weak stabilising controller; the FRF ``y_i / u_j`` [m/V]
  is the indirect closed-loop estimate ``G = T_yr T_ur^-1`` per excited line, with coherence.
* :func:`measure_axis_frf` -- the x-axis FRF ``x / ux`` [m/V] the same way (multisine on ``ux``).
* :func:`run_mass` / :func:`run_axis_mass` -- slow back-and-forth moves of the gantry at a table position
  (or of the table) logging the commands and the commanded acceleration, for
  :func:`~feedtune.identify.mass.fit_mass_distribution` and :func:`~feedtune.identify.mass.fit_axis_mass`.
* :func:`run_gantry_ropesnap` -- 57 N pulling the table in -y, released at ``t_release``; the log holds the
  table displacement (interferometer), the encoders and the commands.
* :func:`run_gantry_tracking` -- a y trajectory (1 mm/s or 200 mm/s in §4.5) with the table held at ``x``.
* :func:`run_contour` -- an x-y contour (:mod:`feedtune.sim.contour`), the table under its own controller.

The identification runs need a controller before any design exists: :class:`HoldingController` (a
CoM/yaw PID with integral action on both, built from the machine's nominal mass, inertia and yaw stiffness)
and :class:`AxisHoldingController` (a PID on the table), the commissioning tuning of a real machine. Any
object with the runtime interface (``GantryRuntime``, ``AxisRuntime``) can replace them.

Units: positions m, commands and forces V (the drives' unit; the rope force is given in N and converted with
the twin's force constant), time s.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from ...errors import DataError, UsageError
from ...identify.frf_estimate import estimate_frf_2x2
from ...log import Log
from ...sim.excitations import multisine, ropesnap_force
from ...sim.experiment import ExperimentResult
from ...sim.params import excitation_settings, release_settings
from .twin import GantryRun, GantryTwin

ROPE_FORCE_N = 57.0
"""Rope-snap force of §4.5 [N]."""
THESIS_TRACKING = {
    "1mm_s": {"distance": 2e-3, "v_max": 1e-3, "a_max": 2.8e-3, "j_max": 10e-3},
    "200mm_s": {"distance": 0.1, "v_max": 0.2, "a_max": 2.0, "j_max": 50.0},
}
"""y tracking tests of §4.5: speed [m/s], acceleration [m/s^2], jerk [m/s^3]; the move lengths [m] are ours."""
MASS_MOVE = {"distance": 0.1, "v_max": 0.1, "a_max": 0.5, "j_max": 2.5}
"""Back-and-forth move of the mass runs [m, m/s, m/s^2, m/s^3]: slow against the holding loops."""


# ------------------------------------------------------------------------------------------ controllers
class _PidState:
    """PID ``kp e + ki int(e) + kd de/dt`` with a first-order low-pass on the derivative (backward Euler)."""

    __slots__ = ("a", "e_prev", "fs", "integral", "kd", "ki", "kp", "rate")

    def __init__(self, kp: float, ki: float, kd: float, fs: float, lowpass_hz: float) -> None:
        self.kp, self.ki, self.kd, self.fs = kp, ki, kd, fs
        self.a = math.exp(-2 * math.pi * lowpass_hz / fs)
        self.reset()

    def reset(self) -> None:
        self.e_prev: float | None = None
        self.integral = 0.0
        self.rate = 0.0

    def step(self, e: float) -> float:
        if self.e_prev is None:
            self.e_prev = e
        self.rate = self.a * self.rate + (1.0 - self.a) * (e - self.e_prev) * self.fs
        self.e_prev = e
        self.integral += e / self.fs
        return self.kp * e + self.ki * self.integral + self.kd * self.rate


def _rigid_pid(mass: float, bandwidth_hz: float, fs: float) -> _PidState:
    """PID on ``1/(mass s^2)``: crossover ``bandwidth_hz``, PD zero at a third of it, integral at a fifth.

    ``K = mass wc^2 / sqrt(10)`` makes ``|K (1 + 3 s / wc) / (mass s^2)| = 1`` at ``wc``; about 50 deg of
    phase margin with the derivative low-pass at ``5 wc`` and a sample of delay at 15 kHz.
    """
    wc = 2 * math.pi * bandwidth_hz
    K = mass * wc**2 / math.sqrt(10.0)
    return _PidState(K, K * wc / 5.0, 3.0 * K / wc, fs, 5.0 * bandwidth_hz)


def _check_bandwidth(value: float, name: str, fs: float) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not 0 < value < fs / 20:
        raise UsageError(f"{name} must be a number between 0 and fs/20 = {fs / 20:g} Hz, got {value!r}")
    return float(value)


class HoldingController:
    """CoM/yaw PID holding the gantry during identification runs (the gantry controller interface).

    The encoders are averaged with the nominal mass fractions, ``e_c = alpha1 e1 + alpha2 e2``, and a PID on
    ``1/(m s^2)`` gives the total force ``f_T``; the yaw error ``e_th = (e2 - e1)/L`` drives a PID on the
    torsional spring ``1/(J s^2 + c s + k)`` giving the torque ``tau`` (integral crossover
    ``yaw_bandwidth_hz`` on the spring, derivative adding ``yaw_damping`` of critical damping to the yaw
    mode); ``u1 = alpha1 f_T - tau/L``, ``u2 = alpha2 f_T + tau/L``. The yaw integral makes the two sides
    follow the same reference without a static yaw deflection, so the command split during slow moves is the
    machine's own mass distribution, whatever the nominal ``alpha1``.

    Parameters
    ----------
    m : float
        Nominal total mass [V/(m/s^2)].
    J : float
        Nominal yaw inertia [V m s^2].
    k : float
        Nominal torsional stiffness [V m].
    L : float
        Actuator span [m].
    fs : float
        Sample rate [Hz].
    alpha1 : float
        Nominal left mass fraction [-].
    bandwidth_hz : float
        Crossover of the CoM loop [Hz].
    yaw_bandwidth_hz : float
        Integral crossover of the yaw loop on the torsional spring [Hz].
    yaw_damping : float
        Damping ratio added to the yaw mode by the yaw derivative [-].
    """

    controller = "holding"
    delay_samples = 1
    preview_samples = 0

    def __init__(self, m: float, J: float, k: float, L: float, fs: float, *, alpha1: float = 0.5,
                 bandwidth_hz: float = 20.0, yaw_bandwidth_hz: float = 20.0, yaw_damping: float = 0.3) -> None:
        for name, v in (("m", m), ("J", J), ("k", k), ("L", L), ("fs", fs)):
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
                raise UsageError(f"holding controller: {name} must be finite and > 0, got {v!r}")
        if not 0 < alpha1 < 1:
            raise UsageError(f"holding controller: alpha1 must lie in (0, 1), got {alpha1!r}")
        self.fs = float(fs)
        self.L = float(L)
        self.alpha1 = float(alpha1)
        self.bandwidth_hz = _check_bandwidth(bandwidth_hz, "bandwidth_hz", fs)
        self.yaw_bandwidth_hz = _check_bandwidth(yaw_bandwidth_hz, "yaw_bandwidth_hz", fs)
        self.yaw_damping = float(yaw_damping)
        self.source = (f"built-in holding controller (CoM PID {bandwidth_hz:g} Hz, yaw PID {yaw_bandwidth_hz:g} Hz, "
                       f"+{yaw_damping:g} yaw damping)")
        self._com = _rigid_pid(m, bandwidth_hz, fs)
        kd_yaw = 2.0 * yaw_damping * math.sqrt(k * J)
        self._yaw = _PidState(0.0, k * 2 * math.pi * yaw_bandwidth_hz, kd_yaw, fs, 1000.0)

    @classmethod
    def for_twin(cls, twin: GantryTwin, **kwargs) -> HoldingController:
        """Built from the twin's model at ``x = 0`` (mass, inertia, stiffness, span); ``alpha1 = 0.5``."""
        model = twin.model
        return cls(model.m, model.inertia(0.0), model.k, model.L, twin.fs, **kwargs)

    def reset(self) -> None:
        """Clear the integrators and derivative states."""
        self._com.reset()
        self._yaw.reset()

    def check_target(self, fs: float, where: str | None = None) -> None:
        """DataError when the machine samples at another rate."""
        if not math.isclose(float(fs), self.fs, rel_tol=1e-9):
            raise DataError(f"{where or 'holding controller'}: built for {self.fs:g} Hz, the machine runs at {fs:g} Hz")

    def step(self, y_ref_preview: float, y1: float, y2: float, x: float) -> tuple[float, float]:
        """Commands ``(u1, u2)`` [V] from the reference and the encoder readings [m]."""
        e1 = y_ref_preview - y1
        e2 = y_ref_preview - y2
        a1 = self.alpha1
        f_total = self._com.step(a1 * e1 + (1.0 - a1) * e2)
        tau = self._yaw.step((e2 - e1) / self.L) / self.L
        return a1 * f_total - tau, (1.0 - a1) * f_total + tau

    def to_dict(self) -> dict:
        """Gains with units."""
        c, y = self._com, self._yaw
        return {"controller": self.controller, "source": self.source, "fs_hz": self.fs, "alpha1": self.alpha1,
                "com": {"kp": c.kp, "ki": c.ki, "kd": c.kd}, "yaw": {"kp": y.kp, "ki": y.ki, "kd": y.kd},
                "units": {"com": "V/m, V/(m s), V s/m", "yaw": "V m/rad, V m/(rad s), V m s/rad", "fs_hz": "Hz"}}


class AxisHoldingController:
    """PID holding (or moving) the x table during identification runs (the x-axis controller interface).

    Parameters
    ----------
    m_x : float
        Nominal table mass [V/(m/s^2)].
    fs : float
        Sample rate [Hz].
    bandwidth_hz : float
        Crossover [Hz] (PD zero at a third, integral at a fifth of it).
    """

    controller = "holding"
    delay_samples = 1
    preview_samples = 0

    def __init__(self, m_x: float, fs: float, *, bandwidth_hz: float = 20.0) -> None:
        if not (isinstance(m_x, (int, float)) and math.isfinite(m_x) and m_x > 0):
            raise UsageError(f"axis holding controller: m_x must be finite and > 0, got {m_x!r}")
        self.fs = float(fs)
        self.bandwidth_hz = _check_bandwidth(bandwidth_hz, "bandwidth_hz", fs)
        self.source = f"built-in x holding controller (PID {bandwidth_hz:g} Hz)"
        self._pid = _rigid_pid(float(m_x), bandwidth_hz, self.fs)

    @classmethod
    def for_twin(cls, twin: GantryTwin, **kwargs) -> AxisHoldingController:
        """Built from the twin's table mass ``m_x``."""
        return cls(twin.model.m_x, twin.fs, **kwargs)

    def reset(self) -> None:
        """Clear the integrator and derivative state."""
        self._pid.reset()

    def check_target(self, fs: float, where: str | None = None) -> None:
        """DataError when the machine samples at another rate."""
        if not math.isclose(float(fs), self.fs, rel_tol=1e-9):
            raise DataError(f"{where or 'axis holding controller'}: built for {self.fs:g} Hz, the machine runs "
                            f"at {fs:g} Hz")

    def step(self, x_ref_preview: float, x: float) -> float:
        """Command ``u_x`` [V] from the reference and the table encoder [m]."""
        return self._pid.step(x_ref_preview - x)

    def to_dict(self) -> dict:
        """Gains with units."""
        p = self._pid
        return {"controller": self.controller, "source": self.source, "fs_hz": self.fs,
                "kp": p.kp, "ki": p.ki, "kd": p.kd, "units": {"kp": "V/m", "ki": "V/(m s)", "kd": "V s/m"}}


def holding_state(gantry: HoldingController, axis: AxisHoldingController) -> tuple[np.ndarray, np.ndarray]:
    """``(gains, states)`` of both holding controllers as the twin's compiled holding loop takes them: gains
    ``(kp, ki, kd, a, fs)`` of the CoM, yaw and x PIDs, then ``alpha1`` and ``L``; states (previous error, has one,
    integral, rate) of each PID."""
    pids = (gantry._com, gantry._yaw, axis._pid)
    hp = np.array([v for p in pids for v in (p.kp, p.ki, p.kd, p.a, p.fs)] + [gantry.alpha1, gantry.L], float)
    hs = np.array([v for p in pids for v in (0.0 if p.e_prev is None else p.e_prev, float(p.e_prev is not None),
                                             p.integral, p.rate)], float)
    return hp, hs


def set_holding_state(gantry: HoldingController, axis: AxisHoldingController, hs: np.ndarray) -> None:
    """Write the states of the compiled holding loop back into the controllers (as if they had been stepped)."""
    for i, p in enumerate((gantry._com, gantry._yaw, axis._pid)):
        p.e_prev = float(hs[4 * i]) if hs[4 * i + 1] else None
        p.integral, p.rate = float(hs[4 * i + 2]), float(hs[4 * i + 3])


def _controllers(twin: GantryTwin, gantry, axis):
    return (gantry if gantry is not None else HoldingController.for_twin(twin),
            axis if axis is not None else AxisHoldingController.for_twin(twin))


# ------------------------------------------------------------------------------------------ results
GantryExperimentResult = ExperimentResult  # one result type for every machine


def _meta(run: GantryRun, kind: str, gantry, axis, **extra) -> dict:
    meta = {"source": f"gantry twin {kind} run", "experiment": kind, "controller": getattr(gantry, "controller", ""),
            "gains": getattr(gantry, "source", ""), "axis_controller": getattr(axis, "controller", ""),
            "axis_gains": getattr(axis, "source", ""), **extra}
    if run.tripped:
        meta["trip"] = run.trip_message
    return meta


def _machine_signals(run: GantryRun) -> tuple[dict, dict]:
    sig = {"y1": run.y1, "y2": run.y2, "x": run.x, "u1": run.u1, "u2": run.u2, "ux": run.ux}
    return sig, dict.fromkeys(("y1", "y2", "x"), "m") | dict.fromkeys(("u1", "u2", "ux"), "V")


def _position(twin: GantryTwin, x, name: str = "table position x") -> float:
    parameter = name.split()[-1]
    if isinstance(x, bool) or not isinstance(x, (int, float)) or not math.isfinite(x):
        raise UsageError(f"{name} must be a finite number [m], got {x!r}", parameter=parameter)
    p = twin.params
    if not p.x_min_m <= x <= p.x_max_m:
        raise UsageError(f"{name} = {x:g} m is outside the table travel {p.x_min_m:g} .. {p.x_max_m:g} m",
                         parameter=parameter)
    return float(x)


MAX_CYCLES = 1000
"""Most back-and-forth cycles of a mass run (one takes about a second; the fit needs one)."""




def measure_gantry_frf(twin: GantryTwin, x: float = 0.0, *, rms: float = 0.5, f_lo: float = 2.0,
                       f_hi: float = 1000.0, period_s: float = 0.5, periods: int = 4, controller=None, axis=None,
                       remove_delay: bool = True, seed: int | None = 0, engine: str = "auto") -> GantryExperimentResult:
    """Measure the 2x2 FRF ``(u1, u2) -> (y1, y2)`` with the table at ``x`` [m].

    A random-phase multisine of ``rms`` [V] on the lines ``f_lo .. f_hi`` (spacing ``1/period_s``) is added to
    ``u1`` for ``periods`` periods, then the same multisine to ``u2`` for ``periods`` periods, while
    ``controller`` (default :class:`HoldingController`) holds ``y = 0`` and ``axis`` holds the table.
    With ``remove_delay`` (default) the known computational delay and the ZOH half sample are removed
    (:func:`feedtune.frf_sampling.remove_sampling`), so the FRF is the continuous plant the fit and the analysis
    expect; otherwise the file is marked as still containing them.

    Returns
    -------
    GantryExperimentResult
        ``log``: ``r1, r2, u1, u2, ux`` [V], ``y1, y2, x`` [m]; ``frf``: ``y_i / u_j`` [m/V] with coherence
        (:func:`estimate_frf_2x2`).
    """

    x = _position(twin, x)
    rms, f_lo, f_hi, period_s, periods = excitation_settings(twin.fs, rms, f_lo, f_hi, period_s, periods, blocks=2)
    gantry, axis = _controllers(twin, controller, axis)
    one = multisine(twin.fs, period_s, f_lo, f_hi, rms, np.random.default_rng(seed))
    block = np.tile(one, periods)
    zeros = np.zeros(block.size)
    r1, r2 = np.r_[block, zeros], np.r_[zeros, block]
    n = r1.size
    run = twin.simulate(gantry, axis, np.zeros(n), x_ref=x, excitation=np.column_stack([r1, r2]), seed=seed,
                        engine=engine).from_zero()
    m = run.t.size
    sig, units = _machine_signals(run)
    sig = {"r1": r1[:m], "r2": r2[:m], **sig}
    units = {"r1": "V", "r2": "V", **units}
    log = Log(run.t, sig, units, _meta(run, "frf", gantry, axis, x_m=x))
    summary = {"x_m": x, "rms_V": rms, "band_hz": [f_lo, f_hi], "period_s": one.size / twin.fs, "periods": periods,
               "u_peak_V": float(max(np.max(np.abs(run.u1)), np.max(np.abs(run.u2))))}
    if run.tripped:
        return GantryExperimentResult("frf", log, run, summary)
    frf = estimate_frf_2x2(log, period_samples=one.size, block_periods=periods, band_hz=(f_lo, f_hi))
    frf = replace(frf, meta={**frf.meta, "source": f"gantry twin FRF at x = {x:g} m", "x_m": f"{x:g}"})
    from ...frf_sampling import mark_sampling_kept, remove_sampling

    if remove_delay:
        frf = remove_sampling(frf, twin.fs, twin.params.delay_samples)
    else:
        frf = mark_sampling_kept(frf, twin.fs)
    summary["delay_removed"] = bool(remove_delay)
    summary["n_lines"] = int(frf.freq_hz.size)
    summary["coherence_min"] = float(np.min(frf.coherence))
    return GantryExperimentResult("frf", log, run, summary, frf=frf)


def measure_axis_frf(twin: GantryTwin, x: float = 0.0, *, rms: float = 0.5, f_lo: float = 2.0, f_hi: float = 1000.0,
                     period_s: float = 0.5, periods: int = 4, controller=None, axis=None, remove_delay: bool = True,
                     seed: int | None = 0, engine: str = "auto") -> GantryExperimentResult:
    """Measure the x-axis FRF ``ux -> x`` [m/V] with the table held at ``x`` [m] (thesis Fig. 4.3).

    A random-phase multisine of ``rms`` [V] on the lines ``f_lo .. f_hi`` (spacing ``1/period_s``) is added to
    the x command ``ux`` for ``periods`` periods while ``axis`` (default :class:`AxisHoldingController`) holds
    the table and ``controller`` (default :class:`HoldingController`) the gantry at ``y = 0``. The plant is the
    indirect closed-loop estimate ``(r -> x) / (r -> ux)`` of the periodic averages (first period dropped). With
    ``remove_delay`` (default) the known computational delay and the ZOH are removed, as in
    :func:`measure_gantry_frf`; the amplifier and the table's modes stay in (they are the plant).

    Returns
    -------
    GantryExperimentResult
        ``kind = "axis_frf"``; ``log``: ``rx, u1, u2, ux`` [V], ``y1, y2, x`` [m]; ``frf``: channel ``x/ux``
        [m/V] with coherence.
    """
    from ...frf_sampling import mark_sampling_kept, remove_sampling
    from ...identify.frf_estimate import estimate_frf

    x = _position(twin, x)
    rms, f_lo, f_hi, period_s, periods = excitation_settings(twin.fs, rms, f_lo, f_hi, period_s, periods)
    gantry, axis = _controllers(twin, controller, axis)
    one = multisine(twin.fs, period_s, f_lo, f_hi, rms, np.random.default_rng(seed))
    rx = np.tile(one, periods)
    n = rx.size
    exc = np.column_stack([np.zeros(n), np.zeros(n), rx])
    run = twin.simulate(gantry, axis, np.zeros(n), x_ref=x, excitation=exc, seed=seed, engine=engine).from_zero()
    m = run.t.size
    sig, units = _machine_signals(run)
    log = Log(run.t, {"rx": rx[:m], **sig}, {"rx": "V", **units}, _meta(run, "axis_frf", gantry, axis, x_m=x))
    summary = {"x_m": x, "rms_V": rms, "band_hz": [f_lo, f_hi], "period_s": one.size / twin.fs, "periods": periods,
               "ux_peak_V": float(np.max(np.abs(run.ux)))}
    if run.tripped:
        return GantryExperimentResult("axis_frf", log, run, summary)
    half_line = 0.5 / period_s  # the band edges are lines: keep them despite rounding
    kw = {"input": "rx", "method": "periodic", "period_samples": int(one.size), "transient_periods": 1,
          "freq_range": (max(0.0, f_lo - half_line), f_hi + half_line)}
    tx = estimate_frf(log, outputs=["x"], **kw)
    tu = estimate_frf(log, outputs=["ux"], **kw)
    frf = replace(tx, response=tx.response / tu.response, inputs=("ux",), input_unit="V",
                  meta={**tx.meta, "source": f"gantry twin x-axis FRF at x = {x:g} m", "x_m": f"{x:g}",
                        "estimator": "indirect closed-loop (r -> x) / (r -> ux) (periodic)"})
    frf = remove_sampling(frf, twin.fs, twin.params.delay_samples) if remove_delay else mark_sampling_kept(frf, twin.fs)
    summary["delay_removed"] = bool(remove_delay)
    summary["n_lines"] = int(frf.freq_hz.size)
    summary["coherence_min"] = float(np.min(frf.coherence))
    return GantryExperimentResult("axis_frf", log, run, summary, frf=frf)


# ------------------------------------------------------------------------------------------ mass runs
def back_and_forth(start: float, *, distance: float, v_max: float, a_max: float, j_max: float, fs: float,
                   cycles: int = 1, dwell: float = 0.1):
    """Trajectory ``start -> start + distance -> start`` repeated ``cycles`` times, ``dwell`` [s] at each end."""
    from ...sim.trajectory import multi_segment

    if isinstance(cycles, bool) or int(cycles) != cycles or not 1 <= cycles <= MAX_CYCLES:
        raise UsageError(f"cycles must be an integer in 1 .. {MAX_CYCLES}, got {cycles!r}", parameter="cycles")
    points = [start] + [start + distance, start] * int(cycles)
    points = [start, *points, start]  # dwell at rest before the first and after the last move
    return multi_segment(points, v_max=v_max, a_max=a_max, j_max=j_max, fs=fs, dwell=dwell)


def run_mass(twin: GantryTwin, x: float = 0.0, *, controller=None, axis=None, move: dict | None = None,
             cycles: int = 1, seed: int | None = 0, engine: str = "auto") -> GantryExperimentResult:
    """Gantry mass run: y back and forth (:data:`MASS_MOVE`) with the table at ``x`` [m].

    Returns
    -------
    GantryExperimentResult
        ``log``: ``y_ref, vy_ref, ay_ref`` [m, m/s, m/s^2], ``y1, y2, x`` [m], ``u1, u2, ux`` [V];
        ``meta["x_m"]`` the table position. Fit with ``fit_mass_distribution(logs, xs, acc_ref="ay_ref")``.
    """
    x = _position(twin, x)
    mv = {**MASS_MOVE, **(move or {})}
    gantry, axis = _controllers(twin, controller, axis)
    tr = back_and_forth(0.0, distance=mv["distance"], v_max=mv["v_max"], a_max=mv["a_max"], j_max=mv["j_max"],
                        fs=twin.fs, cycles=cycles)
    run = twin.simulate(gantry, axis, tr.pos, x_ref=x, seed=seed, engine=engine).from_zero()
    ref = tr.to_log("y_ref")
    m = run.t.size
    sig, units = _machine_signals(run)
    sig = {**{k: ref[k][:m] for k in ("y_ref", "vy_ref", "ay_ref")}, **sig}
    units = {**{k: ref.unit(k) for k in ("y_ref", "vy_ref", "ay_ref")}, **units}
    log = Log(run.t, sig, units, _meta(run, "mass", gantry, axis, x_m=x))
    return GantryExperimentResult("mass", log, run, {"x_m": x, "move": mv, "duration_s": float(run.t[-1])})


def run_axis_mass(twin: GantryTwin, *, x_start: float = -0.1, controller=None, axis=None, move: dict | None = None,
                  cycles: int = 1, seed: int | None = 0, engine: str = "auto") -> GantryExperimentResult:
    """x-axis mass run: the table back and forth from ``x_start`` [m] while the gantry holds ``y = 0``.

    Returns
    -------
    GantryExperimentResult
        ``log``: ``x_ref, v_ref, a_ref`` [m, m/s, m/s^2], ``y1, y2, x`` [m], ``u1, u2, ux`` [V]. Fit with
        ``fit_axis_mass(log, u="ux", acc_ref="a_ref")``.
    """
    mv = {**MASS_MOVE, **(move or {})}
    x_start = _position(twin, x_start, "x_start")
    _position(twin, x_start + mv["distance"], "x_start + distance")
    gantry, axis = _controllers(twin, controller, axis)
    tr = back_and_forth(x_start, distance=mv["distance"], v_max=mv["v_max"], a_max=mv["a_max"],
                        j_max=mv["j_max"], fs=twin.fs, cycles=cycles)
    run = twin.simulate(gantry, axis, np.zeros(tr.n), x_ref=tr.pos, seed=seed, engine=engine).from_zero()
    m = run.t.size
    ref = tr.to_log("x_ref")
    sig, units = _machine_signals(run)
    sig = {**{k: ref[k][:m] for k in ("x_ref", "v_ref", "a_ref")}, **sig}
    units = {**{k: ref.unit(k) for k in ("x_ref", "v_ref", "a_ref")}, **units}
    log = Log(run.t, sig, units, _meta(run, "axis_mass", gantry, axis))
    summary = {"x_start_m": x_start, "move": mv, "duration_s": float(run.t[-1])}
    return GantryExperimentResult("axis_mass", log, run, summary)


def _tracking_result(kind: str, run: GantryRun, ref: Log, gantry, axis, **extra) -> GantryExperimentResult:
    """Log of a y run (reference, machine signals, side errors) and its tracking metrics."""
    from ...analysis.metrics import tracking_metrics

    m = run.t.size
    sig, units = _machine_signals(run)
    sig = {**{k: v[:m] for k, v in ref.signals.items()}, **sig}
    units = {**ref.units, **units}
    sig["e1"] = sig["y_ref"] - run.y1
    sig["e2"] = sig["y_ref"] - run.y2
    units.update(e1="m", e2="m")
    log = Log(run.t, sig, units, _meta(run, kind, gantry, axis, **extra))
    summary = {"controller": getattr(gantry, "controller", ""), **extra, "duration_s": float(run.t[-1])}
    if run.tripped:
        return GantryExperimentResult(kind, log, run, summary)
    mets = [tracking_metrics(run.t, sig[e], vel=sig["vy_ref"], acc=sig["ay_ref"]) for e in ("e1", "e2")]
    summary["tracking"] = {"y1": mets[0].to_dict(), "y2": mets[1].to_dict()}
    summary["max_um"] = max(mt.overall.max_abs for mt in mets) * 1e6
    summary["rms_um"] = math.sqrt(sum(mt.overall.rms**2 for mt in mets) / 2) * 1e6
    cv = [mt.constant_velocity for mt in mets if mt.constant_velocity is not None]
    summary["constant_velocity_max_um"] = max(c.max_abs for c in cv) * 1e6 if cv else None
    return GantryExperimentResult(kind, log, run, summary, metrics=tuple(mets))








def measure_mass(twin: GantryTwin, xs, *, axis_run: bool = True, controller=None, axis=None,
                 move: dict | None = None, cycles: int = 1, seed: int | None = 0, engine: str = "auto"
                 ) -> tuple[list[GantryExperimentResult], GantryExperimentResult | None]:
    """Mass runs (:func:`run_mass`) at every table position of ``xs`` [m] and (``axis_run``) one x-axis run.

    ``move`` overrides entries of :data:`MASS_MOVE` (``distance`` [m], ``v_max``, ``a_max``, ``j_max``).
    """
    runs = [run_mass(twin, float(x), controller=controller, axis=axis, move=move, cycles=cycles, seed=seed,
                     engine=engine) for x in xs]
    ax = run_axis_mass(twin, controller=controller, axis=axis, move=move, cycles=cycles, seed=seed,
                       engine=engine) if axis_run else None
    return runs, ax


# ------------------------------------------------------------------------------------------ rope snap
def run_gantry_ropesnap(twin: GantryTwin, gantry, axis=None, *, force_n: float = ROPE_FORCE_N, x: float = 0.0,
                        t_release: float = 0.5, after_s: float = 0.5, record_before_s: float = 0.1,
                        seed: int | None = 0, engine: str = "auto") -> GantryExperimentResult:
    """Rope snap (§4.5): ``force_n`` [N] pulls the table (at ``x``) in -y, released at ``t_release`` [s].

    The force is ramped in over 0.1 s; the log covers ``record_before_s`` before the release to ``after_s``
    after it.

    Returns
    -------
    GantryExperimentResult
        ``log``: ``y_table`` (interferometer: table displacement) [m], ``y1, y2, x`` [m], ``u1, u2, ux`` [V],
        ``F_table`` [V]; ``metrics``: :class:`~feedtune.analysis.metrics.RopeSnapMetrics` of ``y_table``.
    """
    from ...analysis.metrics import ropesnap_metrics

    x = _position(twin, x)
    u_max = getattr(twin.params, "u_max", None)
    force_n, t_release, after_s, record_before_s = release_settings(
        twin.fs, force_n, t_release, after_s, record_before_s, unit="N", force_parameter="force_n",
        hold_limit=None if not u_max else 2 * u_max / twin.params.rope_v_per_n)
    force_v = force_n * twin.params.rope_v_per_n
    gantry, axis = _controllers(twin, gantry, axis)
    f = ropesnap_force(twin.fs, t_release + after_s, force_v, t_release)
    run = twin.simulate(gantry, axis, np.zeros(f.size), x_ref=x, table_force=f, seed=seed, engine=engine).from_zero()
    sig, units = _machine_signals(run)
    sig = {"y_table": run.y_table, **sig, "F_table": f[: run.t.size]}
    units = {"y_table": "m", **units, "F_table": "V"}
    keep = run.t >= t_release - record_before_s - 0.5 / twin.fs
    if keep.sum() < 2:
        keep = np.ones(run.t.size, bool)
    meta = _meta(run, "ropesnap", gantry, axis, x_m=x, t_release_s=t_release, force_N=force_n, force_V=force_v)
    log = Log(run.t[keep], {k: v[keep] for k, v in sig.items()}, units, meta)
    summary = {"controller": getattr(gantry, "controller", ""), "force_N": force_n, "force_V": force_v,
               "x_m": x, "t_release_s": t_release}
    if run.tripped:
        return GantryExperimentResult("ropesnap", log, run, summary)
    met = ropesnap_metrics(log.t, log["y_table"], t_release=t_release)
    summary["ropesnap"] = met.to_dict()
    summary["peak_um"] = met.peak * 1e6
    summary["settling_time_s"] = met.settling_time
    return GantryExperimentResult("ropesnap", log, run, summary, metrics=met)


# ------------------------------------------------------------------------------------------ tracking
def tracking_trajectory(name_or_move, fs: float, *, dwell_before: float = 0.05, dwell_after: float = 0.2):
    """The y move of a tracking test: a :data:`THESIS_TRACKING` name or a dict of distance and limits."""
    from ...sim.trajectory import point_to_point

    if isinstance(name_or_move, str):
        if name_or_move not in THESIS_TRACKING:
            raise UsageError(f"tracking test must be one of {', '.join(THESIS_TRACKING)}, got {name_or_move!r}",
                             parameter="test")
        mv = THESIS_TRACKING[name_or_move]
    else:
        mv = dict(name_or_move)
    return point_to_point(mv["distance"], v_max=mv["v_max"], a_max=mv["a_max"], j_max=mv["j_max"],
                          s_max=mv.get("s_max"), fs=fs, dwell_before=dwell_before, dwell_after=dwell_after)


def run_gantry_tracking(twin: GantryTwin, gantry, trajectory, axis=None, *, x: float = 0.0, seed: int | None = 0,
                        engine: str = "auto") -> GantryExperimentResult:
    """Track a y trajectory (:class:`~feedtune.sim.trajectory.Trajectory`, m) with the table at ``x`` [m].

    Returns
    -------
    GantryExperimentResult
        ``log``: ``y_ref, vy_ref, ay_ref, jy_ref, sy_ref``, ``y1, y2, x``, ``u1, u2, ux``, errors ``e1 = y_ref -
        y1``, ``e2 = y_ref - y2`` [m]; ``metrics``: tracking metrics of ``e1`` and ``e2``; ``summary``: worst
        ``max_um`` and the joint ``rms_um``.
    """
    x = _position(twin, x)
    if not math.isclose(trajectory.fs, twin.fs, rel_tol=1e-9):
        raise UsageError(f"the trajectory is sampled at {trajectory.fs:g} Hz; the twin runs at {twin.fs:g} Hz")
    gantry, axis = _controllers(twin, gantry, axis)
    run = twin.simulate(gantry, axis, trajectory.pos, x_ref=x, seed=seed, engine=engine).from_zero()
    extra = {"x_m": x, "v_max_m_per_s": trajectory.limits.get("v_max")}
    return _tracking_result("track", run, trajectory.to_log("y_ref"), gantry, axis, **extra)


# ------------------------------------------------------------------------------------------ contouring
def run_contour(twin: GantryTwin, gantry, axis, path, *, seed: int | None = 0,
                engine: str = "auto") -> GantryExperimentResult:
    """Run an x-y contour (:class:`~feedtune.sim.contour.ContourPath`): table on x, gantry on y.

    The table's y position is taken from the encoders at its place on the beam, ``y = (1 - s) y1 + s y2``
    (``s`` its lever weight); the contour error is the signed normal distance of ``(x, y)`` from the path.

    Returns
    -------
    GantryExperimentResult
        ``log``: the references ``x_ref``, ``y_ref`` [m] and the feed [m/s] (all derivatives are in
        ``path.to_log()``), ``x``, ``y``, ``y1``, ``y2`` [m], ``u1, u2, ux`` [V], ``contour_error`` [m]; ``metrics``:
        :class:`~feedtune.analysis.metrics.ContourError`; ``summary``: its maximum and RMS [um].
    """
    from .twin import table_weights

    if not math.isclose(path.fs, twin.fs, rel_tol=1e-9):
        raise UsageError(f"the contour is sampled at {path.fs:g} Hz; the twin runs at {twin.fs:g} Hz")
    if gantry is None or axis is None:
        raise UsageError("contouring needs both a gantry controller and an x-axis controller")
    run = twin.simulate(gantry, axis, path.y.pos, x_ref=path.x.pos, seed=seed, engine=engine).from_zero()
    m = run.t.size
    w1, w2 = table_weights(twin.params, run.x)
    y_table = w1 * run.y1 + w2 * run.y2
    sig, units = _machine_signals(run)
    sig = {"x_ref": path.x.pos[:m], "y_ref": path.y.pos[:m], "feed": path.path.vel[:m], "y": y_table, **sig}
    units = {"x_ref": "m", "y_ref": "m", "feed": "m/s", "y": "m", **units}
    extra = {"shape": path.shape, "size_m": path.size_m, "feed_m_per_s": path.path.limits.get("v_max")}
    summary = {"controller": getattr(gantry, "controller", ""), **extra, "duration_s": float(run.t[-1])}
    if run.tripped:
        return GantryExperimentResult("contour", Log(run.t, sig, units, _meta(run, "contour", gantry, axis, **extra)),
                                      run, summary)
    err = path.contour_error(run.x, y_table)
    sig["contour_error"] = err.distance
    units["contour_error"] = "m"
    log = Log(run.t, sig, units, _meta(run, "contour", gantry, axis, **extra))
    summary["contour"] = err.to_dict()
    summary["max_um"] = err.max_abs * 1e6
    summary["rms_um"] = err.rms * 1e6
    summary["x_max_error_um"] = float(np.max(np.abs(sig["x_ref"] - run.x))) * 1e6
    summary["y_max_error_um"] = float(np.max(np.abs(sig["y_ref"] - y_table))) * 1e6
    return GantryExperimentResult("contour", log, run, summary, metrics=err)
