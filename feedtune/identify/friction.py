"""Stribeck friction identification from a Kalman-filter disturbance estimate (thesis §2.1.3, eq. 2.1).

The method of the thesis (following its ref. [9]): a Kalman filter on the rigid-body model estimates the
*equivalent* disturbance ``d = u - m a - b v`` along a tracking log (:mod:`feedtune.identify.kalman`), and
eq. 2.1 is fitted to ``(v, d)`` by nonlinear least squares, separately for ``v > 0`` and ``v < 0``.

The disturbance estimate contains everything the model ``m, b`` does not explain: Stribeck friction, a
constant offset (gravity, cable drag, amplifier offset; it ends up in both ``dc+`` and ``dc-``: the
symmetric part ``(dc+ - dc-)/2`` is the Coulomb level and ``(dc+ + dc-)/2`` the offset), and -- when the
filter was run without a viscous coefficient -- ``b v``. Pass that ``b`` as ``viscous`` to
:func:`fit_stribeck` and it is subtracted before the fit.

Samples in which the estimate is not trustworthy are left out: the filter's initial transient, a guard
time after every velocity reversal (the friction jumps there and the estimate needs a few observer time
constants to follow) and speeds below ``min_speed``. On logs sampled much faster than the observer
bandwidth ``f_o`` the fit takes every ``fs / (20 f_o)``-th sample (the estimates carry no information
between them; it also keeps the fit fast). For a good Stribeck fit the test trajectory should
pass slowly through the low-speed range (low acceleration at reversals) and dwell at several speeds.

Friction laws (``law=``): ``"stribeck"`` (or None) fits eq. 2.1 as above (:func:`fit_stribeck`, a
:class:`~feedtune.models.friction.StribeckFriction`); ``"hump"`` and ``"lugre"`` fit those laws to the same
disturbance samples (:func:`feedtune.identify.friction_curve.fit_friction_law`, ``vs`` per direction, no viscous
term: the viscous friction is the model's), giving a :class:`~feedtune.models.friction.FrictionLaw`. A fitted
level whose sign is opposite to its direction is a :class:`DataError` naming it (a mirrored or sign-inverted
command).

Joint fit (``joint=True``, without a model or a mass; the default): mass, viscous friction per direction and the
law per direction are fitted together on the IDIM-LS regressor (:mod:`feedtune.identify.friction_joint`: zero-phase
filters, masked parallel decimation, bounded least squares) and that fit is the result: its law with its viscous
terms (:class:`~feedtune.models.friction.FrictionLaw`) is the friction model. The Kalman filter still runs with the
joint mass and viscous coefficient for the disturbance record (``disturbance``), but no law is fitted to it: the
causal filter's estimate lags the friction while the speed changes, which biased ``Omega`` by up to 33 % on eq. 2.1
simulations. The rigid-first path (``joint=False``) lets the IDIM-LS fit absorb the Stribeck decay of the low speeds
as a too small viscous coefficient and a biased mass.

Signs: a fit is bounded to the physical signs (levels with the sign of their direction, ``Fv >= 0``); before that
the unconstrained fit is read, and only a negative mass or Coulomb levels opposing the motion both ways are called a
mirrored or sign-inverted command (Coulomb levels of one sign: an offset larger than the friction,
:func:`~feedtune.identify.friction_curve.sign_diagnosis`). A level that ends on its bound otherwise is reported as
not identified, with its unconstrained value.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from .. import progress
from ..errors import DataError, IllConditionedError, Notice, UsageError
from ..log import Log
from ..models.ballscrew import BallScrewModel
from ..models.friction import StribeckFriction, check_law
from ..models.rigid import RigidBodyModel
from .data_quality import POOR_FIT_PCT
from .friction_curve import as_series, fit_friction_law, parameter_std, sign_diagnosis
from .friction_joint import (
    DEFAULT_MIN_SPEED_FRACTION,
    MIN_SAMPLES_PER_DIRECTION,
    JointFit,
    bound_warnings,
    fit_joint_friction,
)
from .friction_joint import (
    OneDirectionError as OneDirectionError,  # re-exported: the CLI and users catch it here
)
from .kalman import DisturbanceEstimate, estimate_disturbance
from .rigid import RigidFit, fit_rigid, position_si

MIN_SPEED_RATIO = 1.5
"""The 98th/2nd percentile ratio of the speeds in a direction must reach this for a Stribeck fit."""

OMEGA_SPEED_LIMITS = (5.0, 2.0)
"""``Omega`` is bounded to ``[v_2 / 5, v_98 / 2]`` (2nd and 98th speed percentiles of a direction): the static
level needs samples where ``exp(-|v|/Omega)`` is not negligible, the Coulomb level samples where it is small."""


@dataclass(frozen=True)
class StribeckFit:
    """Result of :func:`fit_stribeck`.

    Attributes
    ----------
    friction : StribeckFriction
        The fitted eq. 2.1 model.
    std : dict of str to float
        Standard deviations ``sqrt(diag(s^2 (J^T J)^-1))`` of ``dc_pos, ds_pos, dc_neg, ds_neg, omega_pos,
        omega_neg`` (``None`` in :meth:`to_dict` when not identifiable). Samples of a filtered estimate are
        correlated, so these are optimistic; compare fits of repeated runs for a realistic spread.
    rms_error : float
        RMS fit residual [command unit].
    relative_error_pct : float
        ``100 ||r|| / ||d||`` [%].
    n_pos, n_neg : int
        Samples used per direction.
    min_speed : float
        Speed threshold used [velocity unit].
    viscous_pos, viscous_neg : float
        Viscous coefficients subtracted before the fit [command/velocity unit].
    omega_bounds : dict of str to (float, float)
        Bounds of ``Omega`` per direction (``"pos"``, ``"neg"``) [velocity unit], see
        :data:`OMEGA_SPEED_LIMITS`; a fit that ends on a bound did not resolve the Stribeck velocity.
    on_bound : dict of str to dict
        Levels that ended on their sign bound (0): ``{name: {"bound", "unconstrained", "std"}}`` (their std is NaN).
    """

    friction: StribeckFriction
    std: dict[str, float]
    rms_error: float
    relative_error_pct: float
    n_pos: int
    n_neg: int
    min_speed: float
    viscous_pos: float = 0.0
    viscous_neg: float = 0.0
    omega_bounds: dict[str, tuple[float, float]] = field(default_factory=dict)
    on_bound: dict = field(default_factory=dict)

    @property
    def omega_at_bound(self) -> bool:
        """True when an ``Omega`` ended on one of its bounds: the Stribeck velocity was not resolved."""
        f = self.friction
        values = {"pos": f.omega_pos, "neg": f.omega_negative}
        return any(w <= 1.001 * self.omega_bounds[k][0] or w >= 0.999 * self.omega_bounds[k][1]
                   for k, w in values.items() if k in self.omega_bounds)

    @property
    def coulomb(self) -> float:
        """Symmetric Coulomb level ``(dc+ - dc-)/2`` [command unit]."""
        return (self.friction.dc_pos - self.friction.dc_neg) / 2.0

    @property
    def offset(self) -> float:
        """Direction-independent part ``(dc+ + dc-)/2`` [command unit] (offset carried by the fit)."""
        return (self.friction.dc_pos + self.friction.dc_neg) / 2.0

    def to_dict(self) -> dict:
        """JSON-ready summary with units."""
        c, v = self.friction.command_unit, self.friction.velocity_unit
        return {
            "friction": self.friction.to_dict(),
            "std": {k: (float(s) if np.isfinite(s) else None) for k, s in self.std.items()},
            "coulomb": self.coulomb,
            "offset": self.offset,
            "rms_error": self.rms_error,
            "relative_error_pct": self.relative_error_pct,
            "n_pos": self.n_pos,
            "n_neg": self.n_neg,
            "min_speed": self.min_speed,
            "viscous_pos": self.viscous_pos,
            "viscous_neg": self.viscous_neg,
            "omega_bounds": {k: [float(x) if np.isfinite(x) else None for x in b]
                             for k, b in self.omega_bounds.items()},
            "omega_at_bound": self.omega_at_bound,
            "on_bound": {k: dict(b) for k, b in self.on_bound.items()},
            "shape": self.friction.shapes() if getattr(self.friction, "has_static_level", True) else {},
            "units": {**self.friction.to_dict()["units"], "coulomb": c, "offset": c, "rms_error": c,
                      "relative_error_pct": "%", "min_speed": v, "viscous_pos": f"{c}/({v})",
                      "viscous_neg": f"{c}/({v})", "omega_bounds": v},
        }


@dataclass(frozen=True)
class FrictionIdentification:
    """Result of :func:`identify_friction`.

    Attributes
    ----------
    fit : StribeckFit
        Stribeck fit (``fit.friction`` is the model to feed forward).
    disturbance : DisturbanceEstimate
        The Kalman-filter estimate the fit was made on (of the first log when several were given).
    mass, viscous : float
        Rigid-body values the filter used [command/(position/s^2)], [command/(position/s)].
    rigid_fit : RigidFit or None
        The IDIM-LS fit made on the same log when neither a model nor a mass was given.
    n_used : int
        Samples that entered the fit (after transient, reversal guard and ``min_speed``).
    reversal_guard_s : float
        Time left out after every velocity reversal [s] (of the first log).
    n_logs : int
        Number of logs whose samples entered the fit.
    warnings : tuple of str
        What makes the identification unreliable: coarse position quantization, a clipped command, a poor
        fit, Omega on its bound, and the rigid fit's own warnings.
    law : str
        The friction law fitted to the disturbance (``"stribeck"``: eq. 2.1).
    joint_fit : JointFit or None
        The joint fit of mass, viscous friction and the law that gave ``mass`` and ``viscous`` (``joint=True``).
    """

    fit: StribeckFit
    disturbance: DisturbanceEstimate
    mass: float
    viscous: float
    rigid_fit: RigidFit | None
    n_used: int
    reversal_guard_s: float
    warnings: tuple = ()
    n_logs: int = 1
    law: str = "stribeck"
    joint_fit: JointFit | None = None

    @property
    def friction(self) -> StribeckFriction:
        """The identified model: eq. 2.1 (:class:`StribeckFriction`), or a
        :class:`~feedtune.models.friction.FrictionLaw` of another law (without viscous term)."""
        return self.fit.friction

    def to_dict(self) -> dict:
        """JSON-ready summary with units."""
        est = self.disturbance
        return {
            "source": est.source,
            "friction": self.fit.to_dict(),
            "disturbance": est.to_dict(),
            "mass": self.mass,
            "viscous": self.viscous,
            "rigid_fit": None if self.rigid_fit is None else self.rigid_fit.to_dict(),
            "joint_fit": None if self.joint_fit is None else self.joint_fit.to_dict(),
            "law": self.law,
            "n_used": self.n_used,
            "n_logs": self.n_logs,
            "reversal_guard_s": self.reversal_guard_s,
            "warnings": list(self.warnings),
            "units": {"mass": est.units["mass"], "viscous": est.units["viscous"], "reversal_guard_s": "s"},
        }


# ------------------------------------------------------------------------------------- Stribeck fitting
def _viscous_pair(viscous) -> tuple[float, float]:
    pair = viscous if isinstance(viscous, (tuple, list)) else (viscous, viscous)
    try:
        pos, neg = (float(b) for b in pair)
    except (TypeError, ValueError):
        raise UsageError(f"viscous must be a number or a (pos, neg) pair, got {viscous!r}",
                         parameter="viscous") from None
    if not (np.isfinite(pos) and np.isfinite(neg)):
        raise UsageError(f"viscous must be finite, got {viscous!r}", parameter="viscous")
    return pos, neg


def _direction(speed: np.ndarray, d: np.ndarray, label: str, unit: str) -> tuple[np.ndarray, np.ndarray]:
    """Check one direction's samples (count and speed range)."""
    if speed.size < MIN_SAMPLES_PER_DIRECTION:
        raise IllConditionedError(
            f"Stribeck fit: too few samples with v {label} 0 above min_speed ({speed.size}, need at least "
            f"{MIN_SAMPLES_PER_DIRECTION}); the log must move in both directions")
    lo, hi = np.percentile(speed, [2.0, 98.0])
    if hi < MIN_SPEED_RATIO * lo:
        raise IllConditionedError(
            f"Stribeck fit: the speeds with v {label} 0 only span {lo:.4g} to {hi:.4g} {unit}; a Stribeck "
            "curve needs samples over a range of speeds (not a constant-velocity run)")
    return speed, d


def _levels(speed: np.ndarray, d: np.ndarray, omega: float) -> tuple[np.ndarray, float]:
    """Least-squares ``(dc, ds)`` for a fixed ``omega`` (2x2 normal equations) and the residual sum of
    squares."""
    e = np.exp(-speed / omega)
    f = 1.0 - e
    fe = float(f @ e)
    normal = np.array([[float(f @ f), fe], [fe, float(e @ e)]])
    rhs = np.array([float(f @ d), float(e @ d)])
    coef = np.linalg.lstsq(normal, rhs, rcond=None)[0]
    return coef, max(float(d @ d) - float(coef @ rhs), 0.0)


def _omega_bounds(dirs: list[tuple[np.ndarray, np.ndarray]], shared: bool) -> tuple[np.ndarray, np.ndarray]:
    """Lower and upper bounds of ``Omega`` (one shared or one per direction), see OMEGA_SPEED_LIMITS."""
    low_div, high_div = OMEGA_SPEED_LIMITS
    lo = np.array([float(np.percentile(speed, 2.0)) / low_div for speed, _ in dirs])
    hi = np.array([float(np.percentile(speed, 98.0)) / high_div for speed, _ in dirs])
    if not shared:
        return lo, hi
    if lo.max() >= hi.min():
        raise IllConditionedError(
            "Stribeck fit: the speed ranges of the two directions overlap too little for one shared Omega; "
            "use per_direction_omega=True")
    return lo.max(keepdims=True), hi.min(keepdims=True)


def _omega_start(dirs: list[tuple[np.ndarray, np.ndarray]], lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """Best ``Omega`` on a log-spaced grid within the bounds (variable projection on at most 5 000 samples
    per direction); one value when shared, else one per direction."""
    thin = [(s[:: max(1, s.size // 5_000)], d[:: max(1, d.size // 5_000)]) for s, d in dirs]
    groups = [thin] if lo.size == 1 else [[one] for one in thin]
    start = []
    for group, low, high in zip(groups, lo, hi, strict=True):
        grid = np.geomspace(low, high, 30)
        cost = [sum(_levels(s, d, w)[1] for s, d in group) for w in grid]
        start.append(float(grid[int(np.argmin(cost))]))
    return np.array(start)


def _residual_and_jacobian(theta: np.ndarray, dirs, shared: bool):
    """Residuals and Jacobian of eq. 2.1 for parameters ``[dc+, ds+, dc-, ds-, omega+ (, omega-)]``."""
    n_par = theta.size
    res, jac = [], []
    for k, (speed, d) in enumerate(dirs):
        dc, ds = theta[2 * k], theta[2 * k + 1]
        w = theta[4] if shared else theta[4 + k]
        e = np.exp(-speed / w)
        res.append(dc + (ds - dc) * e - d)
        J = np.zeros((speed.size, n_par))
        J[:, 2 * k] = 1.0 - e
        J[:, 2 * k + 1] = e
        J[:, 4 if shared else 4 + k] = (ds - dc) * e * speed / w**2
        jac.append(J)
    return np.concatenate(res), np.vstack(jac)


def fit_stribeck(velocity, disturbance, *, min_speed: float | None = None, per_direction_omega: bool = False,
                 viscous: float | tuple[float, float] = 0.0, command_unit: str = "N",
                 velocity_unit: str = "m/s") -> StribeckFit:
    """Fit eq. 2.1 to disturbance samples by bounded nonlinear least squares.

    ``dc, ds`` per direction and ``Omega`` (shared, or per direction) by ``scipy.optimize.least_squares``
    (trf, analytic Jacobian), started from the best ``Omega`` of a grid search with the levels solved
    linearly. ``Omega`` is bounded to ``[v_2 / 5, v_98 / 2]`` of the speeds in the data
    (:data:`OMEGA_SPEED_LIMITS`) so that both levels stay supported by samples; check
    ``StribeckFit.omega_at_bound``.

    Parameters
    ----------
    velocity : array_like, shape (n,)
        Velocity [m/s or rad/s].
    disturbance : array_like, shape (n,)
        Equivalent disturbance (friction the drive must supply) [command unit].
    min_speed : float or None
        Samples with ``|v| < min_speed`` are ignored [velocity unit]; default 2 % of the peak speed.
    per_direction_omega : bool
        Fit a separate ``Omega`` per direction (eq. 2.1 has one shared ``Omega``).
    viscous : float or (float, float)
        Viscous coefficient(s) ``b`` (or ``(b+, b-)``) [command/velocity unit] subtracted as ``b v`` before
        the fit; use it when the disturbance estimate was made without the model's viscous term.
    command_unit, velocity_unit : str
        Units recorded in the result.

    Returns
    -------
    StribeckFit
        Parameters, standard deviations and fit error.

    Raises
    ------
    IllConditionedError
        A direction has fewer than 50 samples above ``min_speed`` or no range of speeds.
    DataError
        Coulomb levels opposing the motion both ways (a mirrored or sign-inverted command) or of one sign (an offset
        larger than the friction; :func:`~feedtune.identify.friction_curve.sign_diagnosis`). Any other level of the
        wrong sign is held at 0 and reported in ``on_bound``.
    """
    v = as_series(velocity, "velocity")
    d = as_series(disturbance, "disturbance")
    if v.size != d.size:
        raise DataError(f"velocity has {v.size} samples but disturbance has {d.size}")
    if v.size == 0 or not np.any(v != 0):
        raise IllConditionedError("Stribeck fit: the velocity is zero everywhere")
    b_pos, b_neg = _viscous_pair(viscous)
    d = d - np.where(v > 0, b_pos, b_neg) * v
    peak = float(np.max(np.abs(v)))
    threshold = DEFAULT_MIN_SPEED_FRACTION * peak if min_speed is None else float(min_speed)
    if not (np.isfinite(threshold) and threshold >= 0):
        raise UsageError(f"min_speed must be >= 0 {velocity_unit}, got {min_speed!r}", parameter="min_speed")
    pos, neg = v >= max(threshold, np.finfo(float).tiny), v <= -max(threshold, np.finfo(float).tiny)
    dirs = [_direction(v[pos], d[pos], ">", velocity_unit), _direction(-v[neg], d[neg], "<", velocity_unit)]
    shared = not per_direction_omega
    omega_lo, omega_hi = _omega_bounds(dirs, shared)
    omega0 = np.clip(_omega_start(dirs, omega_lo, omega_hi), 1.001 * omega_lo, 0.999 * omega_hi)
    levels = [_levels(s, dd, omega0[min(k, omega0.size - 1)])[0] for k, (s, dd) in enumerate(dirs)]
    start = np.concatenate([*levels, omega0])
    free = _least_squares(dirs, start, omega_lo, omega_hi, shared)
    sd_free = parameter_std(free.jac, float(free.fun @ free.fun) / max(free.fun.size - free.x.size, 1))
    sign_diagnosis({"dc_pos": (free.x[0], sd_free[0]), "dc_neg": (free.x[2], sd_free[2])}, command_unit,
                   "Stribeck fit")
    sol, on_bound = free, {}
    if np.any(free.x[:4] * np.array([1.0, 1.0, -1.0, -1.0]) < 0):  # a level of the wrong sign: held at 0
        sol = _least_squares(dirs, start, omega_lo, omega_hi, shared, levels_bounded=True)
        for k, name in enumerate(("dc_pos", "ds_pos", "dc_neg", "ds_neg")):
            if sol.x[k] == 0.0:
                on_bound[name] = {"bound": 0.0, "unconstrained": float(free.x[k]),
                                  "std": float(sd_free[k]) if np.isfinite(sd_free[k]) else None}
    bounds = {key: (float(omega_lo[min(k, omega_lo.size - 1)]), float(omega_hi[min(k, omega_hi.size - 1)]))
              for k, key in enumerate(("pos", "neg"))}
    return _fit_result(sol.x, sol.fun, sol.jac, dirs, threshold, (b_pos, b_neg), shared, bounds, command_unit,
                       velocity_unit, on_bound)


def _least_squares(dirs, start: np.ndarray, omega_lo: np.ndarray, omega_hi: np.ndarray, shared: bool,
                   levels_bounded: bool = False):
    """``scipy.optimize.least_squares`` (trf, bounded ``Omega``, analytic Jacobian evaluated once per point); with
    ``levels_bounded`` the levels are held to their signs (``dc+, ds+ >= 0``, ``dc-, ds- <= 0``)."""
    from scipy.optimize import least_squares

    cache: dict[bytes, tuple[np.ndarray, np.ndarray]] = {}

    def evaluate(theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        key = theta.tobytes()
        if key not in cache:
            cache.clear()
            cache[key] = _residual_and_jacobian(theta, dirs, shared)
        return cache[key]

    lower = np.concatenate([np.array([0.0, 0.0, -np.inf, -np.inf]) if levels_bounded else np.full(4, -np.inf),
                            omega_lo])
    upper = np.concatenate([np.array([np.inf, np.inf, 0.0, 0.0]) if levels_bounded else np.full(4, np.inf),
                            omega_hi])
    start = np.clip(start, lower, upper)
    sol = least_squares(lambda th: evaluate(th)[0], start, jac=lambda th: evaluate(th)[1],
                        bounds=(lower, upper), x_scale="jac", method="trf")
    if levels_bounded:  # snap the levels that the solver left within round-off of 0 onto it
        near = np.abs(sol.x[:4]) <= 1e-9 * max(float(np.max(np.abs(sol.x[:4]))), 1e-300)
        sol.x[:4][near] = 0.0
    return sol


def _fit_result(theta, residual, jac, dirs, threshold, viscous, shared, omega_bounds, command_unit,
                velocity_unit, on_bound=None) -> StribeckFit:
    n = residual.size
    held = np.array([name in (on_bound or {}) for name in ("dc_pos", "ds_pos", "dc_neg", "ds_neg")]
                    + [False] * (theta.size - 4))
    s2 = float(residual @ residual) / max(n - int(np.count_nonzero(~held)), 1)
    std = np.full(theta.size, np.nan)
    std[~held] = parameter_std(jac[:, ~held], s2)
    omega_neg = theta[4] if shared else theta[5]
    names = ["dc_pos", "ds_pos", "dc_neg", "ds_neg", "omega_pos"]
    stds = {k: float(s) for k, s in zip(names, std[:5], strict=True)}
    stds["omega_neg"] = float(std[4] if shared else std[5])
    d_used = np.concatenate([dd for _, dd in dirs])
    friction = StribeckFriction(dc_pos=theta[0], ds_pos=theta[1], dc_neg=theta[2], ds_neg=theta[3],
                                omega_pos=theta[4], omega_neg=None if shared else omega_neg,
                                command_unit=command_unit, velocity_unit=velocity_unit)
    return StribeckFit(
        friction=friction, std=stds, rms_error=float(np.sqrt(np.mean(residual**2))),
        relative_error_pct=float(100.0 * np.linalg.norm(residual) / max(np.linalg.norm(d_used), 1e-300)),
        n_pos=int(dirs[0][0].size), n_neg=int(dirs[1][0].size), min_speed=float(threshold),
        viscous_pos=viscous[0], viscous_neg=viscous[1], omega_bounds=omega_bounds, on_bound=dict(on_bound or {}),
    )


# ------------------------------------------------------------------------------------- full procedure
def _in_screw_rotation(log: Log, position: str, model: BallScrewModel) -> Log:
    """The log with its position in rad of screw rotation (a table position in m divided by the lead)."""
    q, unit = position_si(log, position)
    if unit == "m" and not model.lead_given:
        raise DataError(f"{log.source}: position column {position!r} is in m but the ball-screw model has no lead "
                        "(identified without lead_m_per_rad): give the position in rad or identify the model with "
                        "lead_m_per_rad", parameter="fit_ballscrew.lead_m_per_rad")
    return log.with_signals({position: q / model.lead_m_per_rad}, {position: "rad"}) if unit == "m" else log


def _rigid_values(logs: list[Log], position: str, command: str, model, mass, viscous, command_scale,
                  joint: bool = False, law: str = "stribeck", command_unit: str | None = None,
                  cutoff_hz: float | None = None, joint_options: dict | None = None
                  ) -> tuple[list[Log], object, object, tuple[float, float], RigidFit | JointFit | None]:
    """Mass, observer viscous coefficient and residual viscous pair (for the fit) from the arguments, and the
    rigid or joint fit that gave them (None when given)."""
    if model is not None and (mass is not None or viscous is not None):
        raise UsageError("give either model= or mass=/viscous=, not both")
    if cutoff_hz is not None and (model is not None or mass is not None):
        raise UsageError("cutoff_hz= sets the low-pass of the rigid-body or joint fit, which a given model= or mass= "
                         "replaces; give one or the other", parameter="cutoff_hz")
    if isinstance(model, BallScrewModel):
        logs = [_in_screw_rotation(lg, position, model) for lg in logs]
        return logs, model.total_inertia, model.b1 + model.b2, (0.0, 0.0), None
    if isinstance(model, RigidBodyModel):
        for log in logs:
            unit = position_si(log, position)[1]
            if unit != model.position_unit:
                raise DataError(f"{log.source}: position column {position!r} is in {unit} but the rigid-body "
                                f"model is in {model.position_unit}")
        b_mean = (model.viscous + model.viscous_negative) / 2.0
        return logs, model.mass, b_mean, (model.viscous - b_mean, model.viscous_negative - b_mean), None
    if model is not None:
        raise UsageError(f"model must be a BallScrewModel or a RigidBodyModel, got {type(model).__name__}")
    if mass is not None:  # checked by estimate_disturbance
        return logs, mass, 0.0 if viscous is None else viscous, (0.0, 0.0), None
    if viscous is not None:
        raise UsageError("viscous= needs mass= as well")
    if joint:
        fit = fit_joint_friction(logs, position=position, command=command, law=law, command_scale=command_scale,
                                 command_unit=command_unit, cutoff_hz=cutoff_hz, **(joint_options or {}))
        b_pos, b_neg = fit.viscous_pair
        b_mean = (b_pos + b_neg) / 2.0
        return logs, fit.mass, b_mean, (b_pos - b_mean, b_neg - b_mean), fit
    rigid = fit_rigid(logs, force=command, position=position, force_scale=command_scale, cutoff_hz=cutoff_hz)
    return logs, rigid.model.mass, max(rigid.model.viscous, 0.0), (0.0, 0.0), rigid


def _guard_time(value) -> float:
    try:
        guard = float(value)
    except (TypeError, ValueError):
        raise UsageError(f"reversal_guard_s must be a number of seconds, got {value!r}",
                         parameter="reversal_guard_s") from None
    if not (np.isfinite(guard) and guard >= 0):
        raise UsageError(f"reversal_guard_s must be >= 0 s, got {value!r}", parameter="reversal_guard_s")
    return guard


def _reversal_mask(t: np.ndarray, v: np.ndarray, guard_s: float) -> np.ndarray:
    """True for samples at least ``guard_s`` after the latest sign change of ``v``."""
    change = np.flatnonzero(np.signbit(v[1:]) != np.signbit(v[:-1])) + 1
    marker = np.full(v.size, 0, dtype=np.int64)
    marker[change] = change
    last = np.maximum.accumulate(marker)
    ok = (t - t[last]) >= guard_s
    ok[: change[0] if change.size else 0] = True
    return ok


@progress.tasked("fitting the friction (Kalman disturbance estimate)")
def identify_friction(log: Log | Sequence[Log], *, position: str, command: str, model=None,
                      mass: float | None = None,
                      viscous: float | None = None, command_scale: float = 1.0,
                      command_unit: str | None = None,
                      q_disturbance: float | None = None, r_position: float | None = None,
                      bandwidth_hz: float | None = None, method: str = "steady-state",
                      min_speed: float | None = None, per_direction_omega: bool = False,
                      reversal_guard_s: float | None = None, law: str | None = None,
                      joint: bool = True, cutoff_hz: float | None = None) -> FrictionIdentification:
    """Identify friction from tracking logs: the joint fit of mass, viscous friction and the law (default), or the
    Kalman disturbance estimate and a law fit when the mass is given (thesis §2.1.3; module docstring).

    Parameters
    ----------
    log : Log or sequence of Log
        Uniformly sampled tracking log(s) with the same columns: each log is filtered on its own (no filter runs
        across the joint of two files) and the samples of all enter one fit.
    position, command : str
        Position column [m or rad] and drive command column (scaled by ``command_scale``).
    model : BallScrewModel or RigidBodyModel or None
        Source of mass and viscous friction. A ball-screw model gives ``m1 + m2`` [V/(rad/s^2)] and
        ``b1 + b2``; positions in metres are converted to screw rotation with its lead. A rigid-body model
        gives ``mass`` and the mean viscous coefficient (an asymmetric remainder is subtracted in the fit).
    mass, viscous : float or None
        Alternative to ``model`` [command/(position/s^2)], [command/(position/s)]. With neither a model
        nor a mass, :func:`fit_joint_friction` (``joint=True``) or :func:`~feedtune.identify.rigid.fit_rigid`
        gives them.
    command_scale : float
        Multiplies the command (e.g. a drive gain in N/V).
    command_unit : str or None
        Unit of the scaled command (default as in :func:`estimate_disturbance`).
    q_disturbance, r_position, bandwidth_hz, method
        Kalman-filter settings, see :func:`~feedtune.identify.kalman.estimate_disturbance`.
    min_speed : float or None
        Speed threshold of the fit [velocity unit] (default 2 % of the peak speed).
    per_direction_omega : bool
        Separate ``Omega`` per direction.
    reversal_guard_s : float or None
        Kalman path: time left out after each velocity reversal [s], default the observer's settling time
        (``DisturbanceEstimate.transient_s``); joint fit: time masked either side of every sample slower than
        ``min_speed``, default one period of the filter's cut-off.
    law : str or None
        ``None`` or ``"stribeck"`` (eq. 2.1), ``"hump"``, ``"lugre"`` or ``"coulomb-viscous"``. With a given
        mass the law is fitted to the disturbance without a viscous term (:func:`fit_stribeck`, or
        :func:`~feedtune.identify.friction_curve.fit_friction_law` with ``vs`` per direction); the joint fit fits
        it with its viscous terms, and its :class:`~feedtune.models.friction.FrictionLaw` is the result.
    joint : bool
        Without a model or a mass: the joint fit (:func:`fit_joint_friction`, the default); False: the rigid-body
        IDIM-LS fit first (it absorbs the Stribeck decay into the viscous term) and the Kalman path.
    cutoff_hz : float or None
        Position filter cut-off of that rigid or joint fit [Hz]; None chooses it from each log.

    Returns
    -------
    FrictionIdentification
        The friction model, its fit statistics and the disturbance estimate.

    Raises
    ------
    DataError
        A mirrored or sign-inverted command or an offset larger than the friction (named), bad columns or units.
    IllConditionedError
        Too few samples per direction, no range of speeds, no acceleration (rigid or joint fit).
    """
    logs = [log] if isinstance(log, Log) else list(log)
    if not logs:
        raise UsageError("identify_friction needs at least one log")
    law_name = "stribeck" if law is None else check_law(law)
    joint_options = {"min_speed": min_speed, "per_direction_omega": per_direction_omega,
                     "guard_s": None if reversal_guard_s is None else _guard_time(reversal_guard_s)}
    logs, m, b_obs, b_rest, prior = _rigid_values(logs, position, command, model, mass, viscous, command_scale,
                                                  joint=joint, law=law_name, command_unit=command_unit,
                                                  cutoff_hz=cutoff_hz, joint_options=joint_options)
    rigid = prior if isinstance(prior, RigidFit) else None
    joint_fit = prior if isinstance(prior, JointFit) else None
    from .rigid import data_warnings

    warnings = (list(rigid.warnings) if rigid is not None
                else [w for lg in logs for w in data_warnings(lg, command, position, "")])
    speeds, levels = [], []
    for lg in logs if joint_fit is None else logs[:1]:  # the joint fit's law is the result: one record suffices
        estimate = estimate_disturbance(lg, position=position, command=command, mass=m, viscous=b_obs,
                                        q_disturbance=q_disturbance, r_position=r_position, method=method,
                                        bandwidth_hz=bandwidth_hz, command_scale=command_scale,
                                        command_unit=command_unit)
        guard = estimate.transient_s if reversal_guard_s is None else _guard_time(reversal_guard_s)
        use = estimate.after_transient() & _reversal_mask(estimate.t, estimate.velocity, guard)
        # the estimates carry nothing above the observer bandwidth: 20 samples per period of it are plenty
        stride = max(1, int(lg.fs / (20.0 * max(estimate.observer_poles_hz))))
        use[np.arange(use.size) % stride != 0] = False
        speeds.append(estimate.velocity[use])
        levels.append(estimate.disturbance[use])
        if lg is logs[0]:
            first, first_guard = estimate, guard
    if joint_fit is not None:
        fit = _fit_of_joint(joint_fit)
        warnings += list(joint_fit.warnings)
        guard_s, n_used = joint_fit.guard_s, joint_fit.n_samples
    else:
        speed, level = np.concatenate(speeds), np.concatenate(levels)
        if law_name == "stribeck":
            fit = fit_stribeck(speed, level, min_speed=min_speed, per_direction_omega=per_direction_omega,
                               viscous=b_rest, command_unit=first.command_unit, velocity_unit=first.velocity_unit)
        else:
            fit = _law_fit_of_disturbance(speed, level, law_name, min_speed, b_rest, first)
        warnings += bound_warnings(fit.on_bound, first.command_unit, first.velocity_unit)
        if fit.omega_at_bound:
            warnings.append(_omega_bound_warning(speed, fit.min_speed, first.velocity_unit, min_speed is None))
        guard_s, n_used = first_guard, fit.n_pos + fit.n_neg
    if fit.relative_error_pct > POOR_FIT_PCT:
        warnings.append(f"poor {law_name} fit: relative error {fit.relative_error_pct:.3g} % > {POOR_FIT_PCT:g} %")
    return FrictionIdentification(fit=fit, disturbance=first, mass=first.mass, viscous=first.viscous,
                                  rigid_fit=rigid, n_used=n_used, reversal_guard_s=guard_s,
                                  warnings=tuple(dict.fromkeys(warnings)), n_logs=len(logs), law=law_name,
                                  joint_fit=joint_fit)


def _fit_of_joint(joint: JointFit) -> StribeckFit:
    """The joint fit's law (with its viscous terms) as a :class:`StribeckFit` (nothing subtracted before it)."""
    lf = joint.law_fit
    p, n = lf.directions["pos"], lf.directions["neg"]
    nan = float("nan")
    std = {f"{name}_{k}": d.std.get(name, nan) for k, d in (("pos", p), ("neg", n))
           for name in ("dc", "ds", "omega", "viscous")}
    return StribeckFit(friction=lf.model, std=std, rms_error=lf.rms_error, relative_error_pct=lf.relative_error_pct,
                       n_pos=p.n, n_neg=n.n, min_speed=joint.min_speed,
                       omega_bounds={"pos": p.omega_bounds, "neg": n.omega_bounds},
                       on_bound={k: v for k, v in joint.on_bound.items() if k != "mass"})


def _omega_bound_warning(speed: np.ndarray, min_speed: float, unit: str, default: bool) -> str:
    """Why ``Omega`` ended on its bound, and what to do: a lower ``min_speed`` when the log holds slow samples that
    it left out, else slower motion."""
    slow = int(np.count_nonzero((np.abs(speed) < min_speed) & (speed != 0)))
    head = "Omega ended on its bound; the fit does not resolve the Stribeck velocity"
    if slow >= MIN_SAMPLES_PER_DIRECTION:
        rule = f" ({DEFAULT_MIN_SPEED_FRACTION:.0%} of the peak speed, the default)" if default else ""
        return Notice(f"{head}: {slow} samples move slower than min_speed = {min_speed:.4g} {unit}{rule} and were "
                      "left out; the Stribeck velocity may lie there: pass a lower min_speed to use them",
                      parameter="min_speed")
    return f"{head} (move slowly through low speeds)"


def _law_fit_of_disturbance(speed: np.ndarray, level: np.ndarray, law: str, min_speed: float | None,
                            b_rest: tuple[float, float], estimate: DisturbanceEstimate) -> StribeckFit:
    """A hump or LuGre law fitted to the disturbance samples, as a :class:`StribeckFit` of a
    :class:`~feedtune.models.friction.FrictionLaw` (no viscous term: the residual viscous pair ``b_rest`` is
    subtracted first, as in :func:`fit_stribeck`)."""
    if speed.size == 0 or not np.any(speed != 0):
        raise IllConditionedError(f"{law} fit: the velocity is zero everywhere")
    threshold = DEFAULT_MIN_SPEED_FRACTION * float(np.max(np.abs(speed))) if min_speed is None else float(min_speed)
    if not (np.isfinite(threshold) and threshold >= 0):
        raise UsageError(f"min_speed must be >= 0 {estimate.velocity_unit}, got {min_speed!r}", parameter="min_speed")
    d = level - np.where(speed > 0, b_rest[0], b_rest[1]) * speed
    fit = fit_friction_law(speed, d, law=law, viscous=False, min_speed=threshold,
                           min_points=MIN_SAMPLES_PER_DIRECTION, command_unit=estimate.command_unit,
                           velocity_unit=estimate.velocity_unit, where=f"{law} fit")
    if len(fit.directions) < 2:
        missing = "v < 0" if "pos" in fit.directions else "v > 0"
        raise IllConditionedError(f"{law} fit: too few samples with {missing} above min_speed (need at least "
                                  f"{MIN_SAMPLES_PER_DIRECTION}); the log must move in both directions")
    p, n = fit.directions["pos"], fit.directions["neg"]
    std = {f"{name}_{k}": d.std[name] for k, d in (("pos", p), ("neg", n)) for name in ("dc", "ds", "omega")
           if name in d.std}
    return StribeckFit(friction=fit.model.without_viscous(), std=std, rms_error=fit.rms_error,
                       relative_error_pct=fit.relative_error_pct, n_pos=p.n, n_neg=n.n, min_speed=threshold,
                       viscous_pos=b_rest[0], viscous_neg=b_rest[1],
                       omega_bounds={"pos": p.omega_bounds, "neg": n.omega_bounds}, on_bound=dict(fit.on_bound))
