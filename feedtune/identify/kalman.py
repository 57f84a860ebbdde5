"""Kalman-filter estimate of the equivalent disturbance of a rigid axis (thesis §2.1.3, ref. [9]).

Model (continuous time, position ``x``, velocity ``v``, disturbance ``d`` in the command unit)::

    x' = v
    m v' = u - b v - d          (d: everything the model m, b does not explain -- friction, offset, ...)
    d' = w                      (random walk, white noise w with spectral density q [unit^2/s])
    y = x + n                   (position measurement, noise variance r [position unit^2])

discretised with a zero-order hold on ``u`` (the command sample ``u[k]`` acts on ``[t_k, t_k+1)``) and the
Van Loan integral for the process noise. ``d`` has the sign convention of
:class:`~feedtune.models.friction.StribeckFriction`: ``u = m a + b v + d``.

Two implementations give the same estimates after the filter's initial transient:

* ``method="steady-state"`` (default, for long logs): the steady-state gain ``K`` from
  ``scipy.linalg.solve_discrete_are``; the time-invariant filter
  ``x+[k] = (I - K H) (F x+[k-1] + B u[k-1]) + K y[k]`` is run as a sum of compiled second-order-section
  filters (``scipy.signal.sosfilt``), one per input and state.
* ``method="filterpy"``: filterpy's ``KalmanFilter`` with a per-sample ``predict``/``update`` loop (the
  time-varying reference; ~25 us per sample, meant for short logs). It starts from a wide covariance, so
  its gain needs about 20 observer time constants to reach the steady state (the steady-state path's
  own transient, ``DisturbanceEstimate.transient_s``, is 5 time constants).

Both start from ``x = y[0], v = 0, d = 0``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..blas import blas_single_threaded
from ..errors import UsageError
from ..log import Log
from .rigid import default_force_unit, position_si, uniform_sample_time

METHODS = ("steady-state", "filterpy")
DEFAULT_BANDWIDTH_HZ = 50.0
"""Default observer bandwidth cap [Hz]; the default is ``min(0.05 fs, 50 Hz)``."""


@dataclass(frozen=True, eq=False)
class DisturbanceEstimate:
    """Filtered state estimates of :func:`estimate_disturbance`.

    Attributes
    ----------
    t : ndarray
        Time [s].
    position, velocity, disturbance : ndarray
        Filtered estimates ``x+[k]``: position [m or rad], velocity [m/s or rad/s], equivalent disturbance
        [command unit] (``u = m a + b v + d``).
    method : str
        ``"steady-state"`` or ``"filterpy"``.
    mass, viscous : float
        Model used [command/(position/s^2)], [command/(position/s)].
    q_disturbance : float
        Spectral density of the disturbance random walk [command unit^2/s].
    r_position : float
        Position measurement noise variance [position unit^2].
    gain : tuple of float
        Steady-state Kalman gain ``K`` for ``(x, v, d)`` per metre (or radian) of innovation.
    observer_poles_hz : tuple of float
        Magnitudes of the steady-state observer poles ``|ln z| / (2 pi dt)`` [Hz].
    transient_s : float
        Duration of the initial transient (five time constants of the slowest pole) [s].
    position_unit, command_unit : str
        ``"m"`` or ``"rad"``; unit of the (scaled) command.
    """

    t: np.ndarray
    position: np.ndarray
    velocity: np.ndarray
    disturbance: np.ndarray
    method: str
    mass: float
    viscous: float
    q_disturbance: float
    r_position: float
    gain: tuple[float, float, float]
    observer_poles_hz: tuple[float, ...]
    transient_s: float
    position_unit: str
    command_unit: str
    source: str = "log"

    @property
    def velocity_unit(self) -> str:
        """``"m/s"`` or ``"rad/s"``."""
        return f"{self.position_unit}/s"

    @property
    def units(self) -> dict[str, str]:
        """Units of the estimates and settings."""
        p, c = self.position_unit, self.command_unit
        return {
            "t": "s", "position": p, "velocity": f"{p}/s", "disturbance": c, "mass": f"{c}/({p}/s^2)",
            "viscous": f"{c}/({p}/s)", "q_disturbance": f"{c}^2/s", "r_position": f"{p}^2",
            "gain": f"[1, 1/s, {c}/{p}]", "observer_poles_hz": "Hz", "transient_s": "s",
        }

    def after_transient(self) -> np.ndarray:
        """Boolean mask of the samples after the initial transient."""
        return self.t >= self.t[0] + self.transient_s

    def to_log(self) -> Log:
        """The estimates as a :class:`~feedtune.log.Log` (signals ``x_hat``, ``v_hat``, ``d_hat``)."""
        u = self.units
        return Log(self.t, {"x_hat": self.position, "v_hat": self.velocity, "d_hat": self.disturbance},
                   {"x_hat": u["position"], "v_hat": u["velocity"], "d_hat": u["disturbance"]},
                   {"source": f"{self.source} (Kalman disturbance estimate)"})

    def to_dict(self, include_series: bool = False) -> dict:
        """JSON-ready summary with units; ``include_series`` adds the time series as lists."""
        settled = self.after_transient()
        d = self.disturbance[settled] if settled.any() else self.disturbance
        out = {
            "source": self.source,
            "method": self.method,
            "n_samples": int(self.t.size),
            "mass": self.mass,
            "viscous": self.viscous,
            "q_disturbance": self.q_disturbance,
            "r_position": self.r_position,
            "gain": list(self.gain),
            "observer_poles_hz": list(self.observer_poles_hz),
            "transient_s": self.transient_s,
            "disturbance_mean": float(np.mean(d)),
            "disturbance_rms": float(np.sqrt(np.mean(d**2))),
            "units": {**self.units, "disturbance_mean": self.command_unit,
                      "disturbance_rms": self.command_unit},
        }
        if include_series:
            out.update(t=self.t.tolist(), position=self.position.tolist(), velocity=self.velocity.tolist(),
                       disturbance=self.disturbance.tolist())
        return out


# ------------------------------------------------------------------------------------------ the model
@blas_single_threaded
def discrete_model(mass: float, viscous: float, dt: float, q_disturbance: float
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """ZOH discretisation ``(F, B, Q)`` of the ``[x, v, d]`` model (see module doc).

    Parameters
    ----------
    mass : float
        [command/(position/s^2)].
    viscous : float
        [command/(position/s)].
    dt : float
        Sample time [s].
    q_disturbance : float
        Spectral density of ``d'`` [command^2/s].

    Returns
    -------
    F : ndarray, shape (3, 3)
    B : ndarray, shape (3,)
        Input vector for ``u`` [command -> state].
    Q : ndarray, shape (3, 3)
        Process noise covariance per sample (Van Loan).
    """
    from scipy.linalg import expm

    A = np.array([[0.0, 1.0, 0.0], [0.0, -viscous / mass, -1.0 / mass], [0.0, 0.0, 0.0]])
    Bc = np.array([0.0, 1.0 / mass, 0.0])
    aug = np.zeros((4, 4))
    aug[:3, :3] = A
    aug[:3, 3] = Bc
    ez = expm(aug * dt)
    F, B = ez[:3, :3], ez[:3, 3]
    Qc = np.zeros((3, 3))
    Qc[2, 2] = q_disturbance
    van_loan = np.zeros((6, 6))
    van_loan[:3, :3] = -A
    van_loan[:3, 3:] = Qc
    van_loan[3:, 3:] = A.T
    ev = expm(van_loan * dt)
    Q = ev[3:, 3:].T @ ev[:3, 3:]
    return F, B, (Q + Q.T) / 2.0


@blas_single_threaded
def steady_state_gain(F: np.ndarray, Q: np.ndarray, r_position: float, mass: float, dt: float
                      ) -> tuple[np.ndarray, np.ndarray]:
    """Steady-state Kalman gain ``K`` (shape (3,)) and a-priori covariance ``P`` for ``y = x + n``.

    The Riccati equation is solved in states scaled to comparable size -- ``sqrt(r)``, ``sqrt(r) w`` and
    ``m sqrt(r) w^2`` with the observer bandwidth ``w = (q / (m^2 r dt))^(1/6)`` -- because ``diag(P)``
    spans many decades at high sample rates; the result is scaled back.
    """
    from scipy.linalg import solve_discrete_are

    H = np.array([[1.0, 0.0, 0.0]])
    w = (Q[2, 2] / dt / (mass**2 * r_position * dt)) ** (1.0 / 6.0)
    scale = np.sqrt(r_position) * np.array([1.0, w, mass * w**2])
    S = np.diag(scale)
    Si = np.diag(1.0 / scale)
    Ps = solve_discrete_are((Si @ F @ S).T, (H @ S).T, Si @ Q @ Si, np.array([[r_position]]))
    P = S @ Ps @ S
    P = (P + P.T) / 2.0
    K = (P @ H.T / (H @ P @ H.T + r_position)).ravel()
    return K, P


def observer_poles_hz(F: np.ndarray, K: np.ndarray, dt: float) -> np.ndarray:
    """Continuous-equivalent magnitudes ``|ln z| / (2 pi dt)`` [Hz] of the poles of ``(I - K H) F``."""
    H = np.array([[1.0, 0.0, 0.0]])
    z = np.linalg.eigvals((np.eye(3) - np.outer(K, H)) @ F)
    return np.sort(np.abs(np.log(z.astype(complex))) / (2 * np.pi * dt))


# ------------------------------------------------------------------------------------------ filtering
def _run_steady_state(F, B, K, u_prev: np.ndarray, y_rel: np.ndarray) -> np.ndarray:
    """``x[k] = Phi x[k-1] + G [u[k-1], y[k]]`` from zero initial state (shape (3, n)), one compiled pass.

    ``Phi = (I - K H) F`` and ``G = [(I - K H) B, K]``: the predict/update of the time-invariant filter folded into one
    state recursion, run sample by sample in a numba loop (:func:`_filter_pass`).
    """
    H = np.array([[1.0, 0.0, 0.0]])
    IKH = np.eye(3) - np.outer(K, H)
    Phi = np.ascontiguousarray(IKH @ F)
    G = np.ascontiguousarray(np.column_stack([IKH @ B, K]))
    out = np.empty((3, y_rel.size))
    _filter_pass()(Phi, G, np.ascontiguousarray(u_prev, dtype=float), np.ascontiguousarray(y_rel, dtype=float), out)
    return out


_KERNEL: list = []


def _filter_pass():
    """The compiled state recursion ``out[:, k] = Phi out[:, k-1] + G [u[k], y[k]]`` (compiled once, cached on
    disk)."""
    if not _KERNEL:
        import numba

        @numba.njit(cache=True, nogil=True)
        def run(Phi, G, u, y, out):
            x0 = x1 = x2 = 0.0
            for k in range(y.size):
                a, b = u[k], y[k]
                n0 = Phi[0, 0] * x0 + Phi[0, 1] * x1 + Phi[0, 2] * x2 + G[0, 0] * a + G[0, 1] * b
                n1 = Phi[1, 0] * x0 + Phi[1, 1] * x1 + Phi[1, 2] * x2 + G[1, 0] * a + G[1, 1] * b
                n2 = Phi[2, 0] * x0 + Phi[2, 1] * x1 + Phi[2, 2] * x2 + G[2, 0] * a + G[2, 1] * b
                x0, x1, x2 = n0, n1, n2
                out[0, k], out[1, k], out[2, k] = n0, n1, n2

        _KERNEL.append(run)
    return _KERNEL[0]


def _run_filterpy(F, B, Q, r, u_prev: np.ndarray, y_rel: np.ndarray, P0: np.ndarray) -> np.ndarray:
    """filterpy predict/update loop from ``x = 0`` (reference implementation, shape (3, n))."""
    from filterpy.kalman import KalmanFilter

    kf = KalmanFilter(dim_x=3, dim_z=1, dim_u=1)
    kf.F = F
    kf.B = B.reshape(3, 1)
    kf.H = np.array([[1.0, 0.0, 0.0]])
    kf.Q = Q
    kf.R = np.array([[r]])
    kf.x = np.zeros((3, 1))
    kf.P = P0
    out = np.empty((3, y_rel.size))
    for k in range(y_rel.size):
        if k:
            kf.predict(u=u_prev[k])
        kf.update(y_rel[k])
        out[:, k] = kf.x[:, 0]
    return out


# ----------------------------------------------------------------------------------------- parameters
def position_noise_variance(y: np.ndarray) -> float:
    """Position noise variance [unit^2]: larger of quantisation ``step^2/12`` and a robust 3rd-difference
    estimate ``(1.4826 MAD(diff3 y))^2 / 20`` (white noise: ``var(diff3) = 20 sigma^2``)."""
    steps = np.abs(np.diff(y))
    steps = steps[steps > 0]
    quant = float(steps.min()) ** 2 / 12.0 if steps.size else 0.0
    d3 = np.diff(y, 3)
    d3 = d3[:: max(1, d3.size // 100_000)]  # the median of 100 000 values is plenty
    mad = float(np.median(np.abs(d3 - np.median(d3)))) if d3.size else 0.0
    var = max(quant, (1.4826 * mad) ** 2 / 20.0)
    if var > 0:
        return var
    return (1e-9 * max(float(np.ptp(y)), float(np.max(np.abs(y))), 1e-3)) ** 2


def _check_positive(value, name: str, allow_zero: bool = False) -> float:
    try:
        x = float(value)
    except (TypeError, ValueError):
        raise UsageError(f"{name} must be a number, got {value!r}", parameter=name) from None
    ok = x >= 0 if allow_zero else x > 0
    if not (np.isfinite(x) and ok):
        raise UsageError(f"{name} must be {'>=' if allow_zero else '>'} 0, got {value!r}", parameter=name)
    return x


def _nonzero(value, name: str) -> float:
    try:
        x = float(value)
    except (TypeError, ValueError):
        raise UsageError(f"{name} must be a number, got {value!r}", parameter=name) from None
    if not (np.isfinite(x) and x != 0):
        raise UsageError(f"{name} must be a finite non-zero number, got {value!r}", parameter=name)
    return x


def _disturbance_intensity(mass: float, dt: float, r: float, q_disturbance, bandwidth_hz) -> float:
    """``q`` from the user or from a target observer bandwidth: ``q = m^2 r dt (2 pi f)^6``.

    The continuous-time analogue (triple integrator, noise density ``r dt``) places the observer poles in
    a third-order Butterworth pattern of radius ``(q / (m^2 r dt))^(1/6)``.
    """
    if q_disturbance is not None:
        if bandwidth_hz is not None:
            raise UsageError("give q_disturbance or bandwidth_hz, not both")
        return _check_positive(q_disturbance, "q_disturbance")
    fs = 1.0 / dt
    f = min(0.05 * fs, DEFAULT_BANDWIDTH_HZ) if bandwidth_hz is None else _check_positive(bandwidth_hz,
                                                                                          "bandwidth_hz")
    if f >= 0.25 * fs:
        raise UsageError(f"bandwidth_hz must be below a quarter of the sample rate ({0.25 * fs:g} Hz), "
                         f"got {f:g}", parameter="bandwidth_hz")
    return mass**2 * r * dt * (2 * np.pi * f) ** 6


# ------------------------------------------------------------------------------------------ public API
def estimate_disturbance(log: Log, *, position: str, command: str, mass: float, viscous: float = 0.0,
                         q_disturbance: float | None = None, r_position: float | None = None,
                         method: str = "steady-state", bandwidth_hz: float | None = None,
                         command_scale: float = 1.0, command_unit: str | None = None) -> DisturbanceEstimate:
    """Estimate the equivalent disturbance ``d = u - m a - b v`` with a Kalman filter.

    Parameters
    ----------
    log : Log
        Uniformly sampled log.
    position : str
        Measured position column [m or rad; mm, um, nm, deg converted].
    command : str
        Drive command column [V, N or N*m], multiplied by ``command_scale``.
    mass : float
        Moving mass or inertia in the (scaled) command unit per acceleration, > 0.
    viscous : float
        Viscous coefficient [command/(position/s)], >= 0; the estimate then excludes ``b v``.
    q_disturbance : float or None
        Spectral density of the disturbance random walk [command^2/s]; ``None`` derives it from
        ``bandwidth_hz``.
    r_position : float or None
        Position noise variance [position unit^2]; ``None`` estimates it from the log
        (:func:`position_noise_variance`).
    method : {"steady-state", "filterpy"}
        Fast time-invariant filter (default) or the per-sample filterpy reference loop.
    bandwidth_hz : float or None
        Target observer bandwidth [Hz] used when ``q_disturbance`` is ``None``; default
        ``min(0.05 fs, 50 Hz)``. Higher follows friction changes faster but passes more noise.
    command_scale : float
        Multiplies the command column (e.g. a drive gain in N/V).
    command_unit : str or None
        Unit of the scaled command (default: the column's unit when unscaled, else N or N*m).

    Returns
    -------
    DisturbanceEstimate
        Filtered position, velocity and disturbance estimates.
    """
    if method not in METHODS:
        raise UsageError(f"method must be one of {', '.join(METHODS)}, got {method!r}", parameter="method")
    m = _check_positive(mass, "mass")
    b = _check_positive(viscous, "viscous", allow_zero=True)
    scale = _nonzero(command_scale, "command_scale")
    dt = uniform_sample_time(log)
    y, pos_unit = position_si(log, position)
    u = log.get(command) * scale
    r = position_noise_variance(y) if r_position is None else _check_positive(r_position, "r_position")
    q = _disturbance_intensity(m, dt, r, q_disturbance, bandwidth_hz)
    F, B, Q = discrete_model(m, b, dt, q)
    K, P = steady_state_gain(F, Q, r, m, dt)
    u_prev = np.concatenate([[0.0], u[:-1]])
    y_rel = y - y[0]
    if method == "steady-state":
        x = _run_steady_state(F, B, K, u_prev, y_rel)
    else:
        x = _run_filterpy(F, B, Q, r, u_prev, y_rel, _diffuse_covariance(P, u, y, dt))
    poles = observer_poles_hz(F, K, dt)
    return DisturbanceEstimate(
        t=log.t, position=x[0] + y[0], velocity=x[1], disturbance=x[2], method=method, mass=m, viscous=b,
        q_disturbance=q, r_position=r, gain=(float(K[0]), float(K[1]), float(K[2])),
        observer_poles_hz=tuple(float(p) for p in poles), transient_s=float(5.0 / (2 * np.pi * poles.min())),
        position_unit=pos_unit, command_unit=command_unit or default_force_unit(log.unit(command), scale,
                                                                                pos_unit),
        source=log.source,
    )


def _diffuse_covariance(P_ss: np.ndarray, u: np.ndarray, y: np.ndarray, dt: float) -> np.ndarray:
    """Initial covariance of the reference filter: at least the steady state, and wide enough to cover
    the velocity and disturbance levels seen in the log (the filter starts at ``v = d = 0``)."""
    v_scale = float(np.max(np.abs(np.diff(y)))) / dt
    d_scale = float(np.max(np.abs(u)))
    return P_ss + np.diag([0.0, v_scale**2, d_scale**2])
