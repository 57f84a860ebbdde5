"""Control-signal equivalent masses from tracking logs (thesis §4.3.1 and §4.3.3, Fig. 4.5).

During controlled tracking the drive command follows the commanded acceleration: ``u_i = m_i a_ref +
offset_i [+ b_i v_ref]``. A least-squares fit of each actuator command against ``a_ref`` gives the mass
``m_i`` [V/(m/s^2)] carried by that side of the gantry; their sum is the total mass ``m`` and the ratios
``alpha_i = m_i / m`` are the mass distribution. Repeating this at several table positions ``x`` gives
``alpha1(x)``, fitted as a straight line.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from ..errors import DataError, IllConditionedError, UsageError
from ..log import Log
from ..models.gantry_mass import MassFit, SideMassFit

# largest condition number of the column-normalised regressor accepted by the log fits
MAX_REGRESSOR_CONDITION = 1e6

_ACC_UNITS = {"": 1.0, "m/s^2": 1.0, "m/s2": 1.0, "m/s²": 1.0, "m/s/s": 1.0, "mm/s^2": 1e-3,
              "mm/s2": 1e-3, "mm/s²": 1e-3}
_VEL_UNITS = {"": 1.0, "m/s": 1.0, "mm/s": 1e-3}






# ------------------------------------------------------------------------------------ helpers
def _scaled_signal(log: Log, name: str, table: dict[str, float], expected: str) -> np.ndarray:
    unit = log.unit(name).strip()
    if unit not in table:
        raise DataError(f"{log.source}: signal {name!r} has unit {unit!r}; expected {expected}")
    return log.get(name) * table[unit]


def _command_fit(log: Log, commands: Sequence[str], acc_ref: str, vel_ref: str | None
                 ) -> tuple[np.ndarray, np.ndarray]:
    """Least squares ``u = m a + offset [+ b v]`` for each command; returns ``(theta, rms_residual)``.

    ``theta`` has shape ``(n_regressors, n_commands)`` with rows ``[m, offset, (b)]``.
    """
    a = _scaled_signal(log, acc_ref, _ACC_UNITS, "m/s^2 (or mm/s^2)")
    columns = [a, np.ones_like(a)]
    if vel_ref is not None:
        columns.append(_scaled_signal(log, vel_ref, _VEL_UNITS, "m/s (or mm/s)"))
    Phi = np.column_stack(columns)
    U = np.column_stack([log.get(name) for name in commands])
    norms = np.linalg.norm(Phi, axis=0)
    names = [acc_ref, "offset", vel_ref]
    if np.any(norms == 0):
        bad = names[int(np.flatnonzero(norms == 0)[0])]
        raise IllConditionedError(f"{log.source}: signal {bad!r} is identically zero; the mass fit needs "
                                  "a log with acceleration")
    Phi_n = Phi / norms
    sv = np.linalg.svd(Phi_n, compute_uv=False)
    if sv[-1] <= sv[0] / MAX_REGRESSOR_CONDITION:
        raise IllConditionedError(
            f"{log.source}: mass fit regressor [{', '.join(n for n in names[:Phi.shape[1]] if n)}] is "
            f"ill-conditioned (cond {sv[0] / max(sv[-1], 1e-300):.2g}); the log needs varying acceleration")
    theta_n, *_ = np.linalg.lstsq(Phi_n, U, rcond=None)
    theta = theta_n / norms[:, None]
    rms = np.sqrt(np.mean((U - Phi @ theta) ** 2, axis=0))
    return theta, rms


def _line_fit(xs: np.ndarray, values: np.ndarray) -> tuple[float, float, float]:
    """Straight line ``values = v0 + slope * x``; returns ``(v0, slope, rms_residual)``."""
    A = np.column_stack([np.ones_like(xs), xs])
    coef, *_ = np.linalg.lstsq(A, values, rcond=None)
    rms = float(np.sqrt(np.mean((values - A @ coef) ** 2)))
    return float(coef[0]), float(coef[1]), rms


def _check_positions(xs: Sequence[float], n_items: int, what: str) -> np.ndarray:
    try:
        x = np.asarray(xs, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        raise UsageError(f"table positions xs must be numbers [m], got {xs!r}") from None
    if x.size != n_items:
        raise UsageError(f"got {n_items} {what} but {x.size} table positions xs; "
                         f"give one position per {what[:-1]}")
    if not np.all(np.isfinite(x)):
        raise UsageError("table positions xs must be finite [m]")
    return x


# ------------------------------------------------------------------------------------ public API
def fit_mass_distribution(logs: Sequence[Log], xs: Sequence[float], *, u1: str = "u1", u2: str = "u2",
                          acc_ref: str = "a_ref", vel_ref: str | None = None) -> MassFit:
    """Gantry mass distribution from tracking logs recorded at several table positions.

    Parameters
    ----------
    logs : sequence of Log
        One tracking log per table position, each with the two actuator commands [V] and the commanded
        y-axis acceleration [m/s^2] (optionally the commanded velocity [m/s]).
    xs : sequence of float
        Table position [m] of each log; at least two distinct positions.
    u1, u2 : str
        Names of the left and right actuator command signals [V].
    acc_ref : str
        Name of the commanded acceleration [m/s^2].
    vel_ref : str, optional
        Name of the commanded velocity [m/s]; adds a viscous term to each fit.

    Returns
    -------
    MassFit
        Per-position ``m1, m2`` and offsets, the mean total mass and ``alpha1(x)`` as a straight line.

    Raises
    ------
    DataError
        A missing signal, a unit that is not an acceleration/velocity, or fewer than two positions.
    IllConditionedError
        A log without acceleration (or with acceleration proportional to velocity).
    """
    logs = list(logs)
    x = _check_positions(xs, len(logs), "logs")
    if np.unique(x).size < 2:
        raise UsageError("mass distribution needs logs at >= 2 distinct table positions xs, "
                         f"got {np.unique(x).size}", parameter="xs")
    fits = []
    for log, xi in zip(logs, x, strict=True):
        theta, rms = _command_fit(log, (u1, u2), acc_ref, vel_ref)
        visc = (None, None) if vel_ref is None else (float(theta[2, 0]), float(theta[2, 1]))
        fits.append(SideMassFit(
            x=float(xi), m1=float(theta[0, 0]), m2=float(theta[0, 1]), offset1=float(theta[1, 0]),
            offset2=float(theta[1, 1]), viscous1=visc[0], viscous2=visc[1], rms_residual1=float(rms[0]),
            rms_residual2=float(rms[1]), n_samples=log.n))
    totals = np.array([f.m for f in fits])
    if np.any(totals <= 0):
        bad = fits[int(np.flatnonzero(totals <= 0)[0])]
        raise DataError(f"log at x = {bad.x:g} m gives total mass {bad.m:.3g} <= 0; check the sign of "
                        f"{acc_ref!r} against {u1!r} and {u2!r}")
    alpha1 = np.array([f.alpha1 for f in fits])
    a0, slope, rms_alpha = _line_fit(x, alpha1)
    return MassFit(positions=tuple(fits), m=float(totals.mean()), alpha1_0=a0, dalpha1_dx=slope,
                   alpha1_rms_residual=rms_alpha)


def fit_axis_mass(log: Log, *, u: str = "u", acc_ref: str = "a_ref") -> float:
    """Control-signal equivalent mass ``m_x`` [V/(m/s^2)] of a double-integrator axis (§4.3.1).

    Fits ``u = m_x a_ref + offset`` by least squares over the whole log (air bearings: no friction).

    Parameters
    ----------
    log : Log
        Tracking log with the axis command ``u`` [V] and the commanded acceleration ``acc_ref`` [m/s^2].
    u, acc_ref : str
        Signal names.

    Returns
    -------
    float
        ``m_x`` [V/(m/s^2)].

    Raises
    ------
    IllConditionedError
        The log has no acceleration.
    DataError
        The fitted mass is not positive.
    """
    theta, _ = _command_fit(log, (u,), acc_ref, None)
    m_x = float(theta[0, 0])
    if not (math.isfinite(m_x) and m_x > 0):
        raise DataError(f"{log.source}: fitted axis mass {m_x:.3g} V/(m/s^2) is not > 0; check the sign of "
                        f"{acc_ref!r} against {u!r}")
    return m_x
