"""Friction laws fitted per direction, and the steady-state friction curve from constant-velocity plateaus.

Two tools share one least-squares core, :func:`fit_friction_law`:

* the law (:data:`~feedtune.models.friction.LAWS`: ``stribeck``, ``hump``, ``lugre``, each with a viscous term;
  :class:`~feedtune.models.friction.FrictionLaw`) fitted to speed/force samples, per direction, optionally with
  a shared mass term ``m a`` (the joint fit of :func:`feedtune.identify.friction.identify_friction` and ramps);
* the steady-state method (:func:`identify_friction_curve`), the way most engineers measure friction: the axis
  moves at a series of constant speeds both ways; on every constant-velocity plateau the inertial term vanishes,
  so the mean command is the friction at that speed; the law is fitted to those points.

Plateau rule (:func:`find_plateaus`, defaults in brackets)
-----------------------------------------------------------
1. Velocity and acceleration from the position: zero-phase Butterworth low-pass (order 4, cut-off
   ``cutoff_hz`` [the automatic rule of :func:`feedtune.identify.rigid.auto_cutoff_hz`]) and central
   differences; ``5 / cutoff_hz`` seconds at each end of the log are dropped (filter edges).
2. A sample is steady when ``|a| <= acc_tol`` [:data:`ACC_TOL_FRACTION` = 5 % of the 99th percentile of
   ``|a|`` in the log] and ``|v| >= min_speed`` [:data:`MIN_SPEED_FRACTION` = 0.2 % of the peak speed].
3. A run of consecutive steady samples moving the same way is cut wherever the velocity, averaged over
   ``min_duration / 5``, leaves the band ``|v - v_ref| <= vel_tol |v_ref|`` [:data:`VEL_TOL` = 2 %] around the
   median ``v_ref`` of the first ``min_duration`` of the piece; pieces of at least ``min_duration``
   [:data:`MIN_DURATION_S` = 0.1 s] are plateaus.
4. ``trim`` [:data:`TRIM_FRACTION` = 10 %] of each plateau is left out at both ends (the filter's and the
   loop's settling).
5. Pieces of one physical plateau are merged: consecutive pieces of a log join when the axis keeps moving the same
   way above ``min_speed`` between them (a stop ends a plateau), no acceleration above :data:`MERGE_ACC_FACTOR` x
   ``acc_tol`` lies between them (a speed step passes through the log's large accelerations, a slow drift does
   not) and the mean speeds of the joined pieces stay within
   :data:`MERGE_SPREAD_FACTOR` x ``vel_tol`` of their mean (a slow ramp is not one plateau). A torque step of a
   servo motor whose speed creeps towards its end value (HSM150: time constant J/B = 1.6 s) is one plateau, not
   ten pieces cut by the 2 % band.
6. The point is the mean velocity and the mean command of the plateau's samples, with the command's standard
   deviation as its scatter.

The law is then fitted to the points of each direction with its own parameters (levels, ``vs``, ``Fv``); a log
that moves one way only gives the fit of that direction (and a warning) but no model file.

Uncertainties: ``std = sqrt(diag(s^2 (J^T J)^-1))`` with ``s^2`` the residual variance of the points (so it
includes the law's misfit); ``vs`` is bounded to ``[v_lo / 5, v_hi / 2]`` of the speeds of the direction
(:data:`OMEGA_SPEED_LIMITS`), and a ``vs`` on a bound is reported (the data do not resolve it).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from .. import progress
from ..errors import DataError, IllConditionedError, UsageError
from ..log import Log
from ..models.friction import (
    COULOMB_VISCOUS,
    SHAPED_LAWS,
    FrictionLaw,
    check_law,
    law_shape,
    law_shape_slope,
    level_shape,
)

DIRECTIONS = ("pos", "neg")
DIRECTION_TEXT = {"pos": "v > 0", "neg": "v < 0"}
OMEGA_SPEED_LIMITS = (5.0, 2.0)
"""``vs`` is bounded to ``[v_lo / 5, v_hi / 2]`` (lowest and highest speed of a direction, 2nd and 98th percentile
for dense samples)."""
MIN_POINTS = 5
"""Fewest points (plateaus or samples) a direction needs for a fit (the law has 4 parameters)."""
FEW_POINTS = 8
"""Fewer points than this in a fitted direction give a warning."""
ACC_TOL_FRACTION = 0.05
"""Default acceleration tolerance of a plateau, as a fraction of the 99th percentile of ``|a|`` [-]."""
VEL_TOL = 0.02
"""Default relative velocity tolerance of a plateau [-]."""
MIN_DURATION_S = 0.1
"""Default shortest plateau [s]."""
TRIM_FRACTION = 0.1
"""Default part of each plateau left out at each end [-]."""
MIN_SPEED_FRACTION = 0.002
"""Default slowest plateau speed, as a fraction of the peak speed [-]."""
MERGE_ACC_FACTOR = 10.0
"""Pieces separated by an acceleration above this many ``acc_tol`` are different plateaus (rule step 5) [-]."""
MERGE_SPREAD_FACTOR = 5.0
"""Merged pieces' mean speeds stay within this many ``vel_tol`` of their mean (rule step 5) [-]."""
DRIFT_WINDOW_DIVISOR = 5
"""The velocity band is tested on the velocity averaged over ``min_duration / 5`` (fast noise does not cut)."""
STD_SIGMAS = 3.0
"""Standard deviations beyond which a sign or a difference counts as clear (:func:`sign_diagnosis`,
:func:`identifiability_warnings`)."""
POOR_OMEGA_STD = 0.25
"""Relative standard deviation of ``vs`` above which the law's characteristic velocity is called poorly resolved."""


# ------------------------------------------------------------------------------------------- helpers
def as_series(x, name: str) -> np.ndarray:
    """A finite 1-D float series (DataError naming ``name`` otherwise)."""
    try:
        a = np.asarray(x, dtype=float)
    except (TypeError, ValueError):
        raise DataError(f"{name} must be numeric") from None
    if a.ndim != 1:
        raise DataError(f"{name} must be 1-D, got shape {a.shape}")
    if not np.all(np.isfinite(a)):
        raise DataError(f"{name} has a NaN or infinite value at sample {int(np.flatnonzero(~np.isfinite(a))[0])}")
    return a


def parameter_std(jac: np.ndarray, s2: float) -> np.ndarray:
    """``sqrt(diag(s2 (J^T J)^-1))`` computed with column scaling; ``inf`` when not identifiable.

    Parameters
    ----------
    jac : ndarray, shape (n, p)
        Jacobian of the residuals at the solution.
    s2 : float
        Residual variance ``||r||^2 / (n - p)`` [residual unit^2].

    Returns
    -------
    ndarray, shape (p,)
        Standard deviations in the parameters' units (``inf`` for all when ``J^T J`` is singular).
    """
    jtj = jac.T @ jac
    scale = np.sqrt(np.diag(jtj))
    if np.any(scale == 0):
        return np.full(scale.size, np.inf)
    normalised = jtj / np.outer(scale, scale)
    if np.linalg.cond(normalised) > 1e12:
        return np.full(scale.size, np.inf)
    return np.sqrt(s2 * np.diag(np.linalg.inv(normalised)) / scale**2)


SIGN_HINT = ("the command looks mirrored or sign-inverted against the velocity (check the sign of the command "
             "column or its scale=)")
OFFSET_HINT = ("a constant force (gravity on a vertical axis, a cable, a drive offset) larger than the Coulomb level: "
               "the friction laws have no offset term; subtract it from the command first")


def check_fitted_signs(friction, where: str) -> None:
    """Raise a :class:`DataError` naming the first parameter of a fitted model with an unphysical sign.

    Parameters
    ----------
    friction : StribeckFriction or FrictionLaw
        The fitted model.
    where : str
        What was fitted, for the message.
    """
    problems = friction.sign_problems()
    if problems:
        raise DataError(f"{where}: {problems[0][1]}; {SIGN_HINT}, or {OFFSET_HINT}", parameter="read_log.scale")


def clearly_wrong_sign(name: str, value: float, std: float) -> bool:
    """True when the level ``name`` (``dc_pos`` ...: ``>= 0`` for ``_pos``, ``<= 0`` for ``_neg``) has the wrong sign
    by more than :data:`STD_SIGMAS` standard deviations (``std`` not finite: by any amount)."""
    wrong = -value if name.endswith("_pos") else value
    return wrong > (STD_SIGMAS * std if np.isfinite(std) else 0.0)


def sign_diagnosis(coulomb: dict[str, tuple[float, float]], command_unit: str, where: str,
                   mass: tuple[float, float] | None = None) -> None:
    """Refuse an unconstrained fit whose signs say the data are mirrored or carry an offset the law cannot hold.

    Before a friction law is fitted with its sign bounds (``dc, ds >= 0`` for ``v > 0``, ``<= 0`` for ``v < 0``,
    ``Fv >= 0``, mass > 0), the unconstrained fit is read: a mass below zero, or Coulomb levels opposing the motion
    in both directions, are a mirrored or sign-inverted command (the constrained fit would hide it); Coulomb levels of
    the same sign in both directions are a constant offset larger than the friction (no law here has an offset term).
    Anything else that ends outside the bounds is poor identifiability, and the constrained fit reports it.

    Parameters
    ----------
    coulomb : dict of str to (float, float)
        Unconstrained ``dc_pos`` and/or ``dc_neg`` with their standard deviations [command unit].
    command_unit : str
        For the messages.
    where : str
        What was fitted.
    mass : (float, float) or None
        Unconstrained mass and its std, when the fit has one.

    Raises
    ------
    DataError
        Naming the values and the cause.
    """
    wrong = {k: clearly_wrong_sign(k, *vs) for k, vs in coulomb.items()}
    mass_negative = mass is not None and mass[0] < -(STD_SIGMAS * mass[1] if np.isfinite(mass[1]) else 0.0)
    text = ", ".join(f"{k} = {v:.4g} +/- {sd:.2g} {command_unit}" for k, (v, sd) in coulomb.items())
    if mass_negative:
        raise DataError(f"{where}: mass = {mass[0]:.4g} +/- {mass[1]:.2g} < 0 ({text}); {SIGN_HINT}",
                        parameter="read_log.scale")
    if len(coulomb) == 2 and all(wrong.values()):
        raise DataError(f"{where}: both Coulomb levels oppose the motion ({text}); {SIGN_HINT}",
                        parameter="read_log.scale")
    if len(coulomb) == 2 and any(wrong.values()):
        (dp, _), (dn, _) = coulomb["dc_pos"], coulomb["dc_neg"]
        raise DataError(f"{where}: both Coulomb levels have the same sign ({text}): an offset of "
                        f"{(dp + dn) / 2:.4g} {command_unit} against a Coulomb level of {(dp - dn) / 2:.4g} "
                        f"{command_unit}; {OFFSET_HINT}", parameter="read_log.scale")
    if len(coulomb) == 1 and all(wrong.values()):
        raise DataError(f"{where}: the Coulomb level opposes the motion ({text}); {SIGN_HINT}, or {OFFSET_HINT}",
                        parameter="read_log.scale")


# ------------------------------------------------------------------------------------------- results
@dataclass(frozen=True)
class DirectionFit:
    """The law fitted to one direction (signed levels as in :class:`~feedtune.models.friction.FrictionLaw`).

    Attributes
    ----------
    direction : str
        ``"pos"`` (``v > 0``) or ``"neg"`` (``v < 0``).
    dc, ds : float
        Levels [command unit] (``dc`` Coulomb, ``ds`` static level, or the hump's peak; ``ds = dc`` for the
        coulomb-viscous law).
    omega : float
        ``vs`` [velocity unit] (NaN for the coulomb-viscous law).
    viscous : float
        ``Fv`` [command unit/(velocity unit)] (0 when not fitted).
    std : dict of str to float
        Standard deviations of ``dc, ds, omega`` (and ``viscous`` when fitted); ``inf`` when not identifiable, NaN
        for a parameter held on its bound.
    n : int
        Points (or samples) of the direction.
    rms_error : float
        RMS residual of the direction [command unit].
    speed_range : (float, float)
        Lowest and highest speed of the points [velocity unit].
    omega_bounds : (float, float)
        Bounds of ``vs`` [velocity unit].
    """

    direction: str
    dc: float
    ds: float
    omega: float
    viscous: float
    std: dict[str, float]
    n: int
    rms_error: float
    speed_range: tuple[float, float]
    omega_bounds: tuple[float, float]

    @property
    def omega_at_bound(self) -> bool:
        """True when ``vs`` ended on a bound (the data do not resolve it)."""
        lo, hi = self.omega_bounds
        return self.omega <= 1.001 * lo or self.omega >= 0.999 * hi

    def to_dict(self) -> dict:
        """JSON-ready values (``std`` None where not identifiable)."""
        return {"dc": self.dc, "ds": self.ds, "omega": self.omega if np.isfinite(self.omega) else None,
                "viscous": self.viscous,
                "std": {k: (float(s) if np.isfinite(s) else None) for k, s in self.std.items()},
                "n": self.n, "rms_error": self.rms_error, "speed_range": list(self.speed_range),
                "omega_bounds": [float(b) if np.isfinite(b) else None for b in self.omega_bounds],
                "omega_at_bound": self.omega_at_bound}


@dataclass(frozen=True)
class FrictionLawFit:
    """Result of :func:`fit_friction_law`.

    Attributes
    ----------
    law : str
        The law fitted.
    directions : dict of str to DirectionFit
        The fitted directions (``"pos"``, ``"neg"``; one of them for a one-direction log).
    mass, mass_std : float or None
        The shared mass term [command unit/(velocity unit/s)], e.g. kg = N/(m/s^2), and its std when an
        acceleration was given.
    rms_error : float
        RMS residual over all samples [command unit].
    relative_error_pct : float
        ``100 ||r|| / ||F||`` [%].
    command_unit, velocity_unit : str
        Units.
    warnings : tuple of str
        ``vs`` on a bound, few points, a parameter held on its bound, a direction left out.
    on_bound : dict of str to dict
        Parameters held on their sign bound: ``{"ds_neg": {"bound", "unconstrained", "std"}, ...}``.
    """

    law: str
    directions: dict[str, DirectionFit]
    mass: float | None
    mass_std: float | None
    rms_error: float
    relative_error_pct: float
    command_unit: str
    velocity_unit: str
    warnings: tuple = ()
    on_bound: dict = field(default_factory=dict)

    @property
    def model(self) -> FrictionLaw | None:
        """The :class:`FrictionLaw` of both directions, or None when only one direction was fitted."""
        if set(self.directions) != set(DIRECTIONS):
            return None
        p, n = self.directions["pos"], self.directions["neg"]
        if self.law == COULOMB_VISCOUS:
            return FrictionLaw.coulomb_viscous(p.dc, n.dc, p.viscous, n.viscous, command_unit=self.command_unit,
                                               velocity_unit=self.velocity_unit)
        return FrictionLaw(dc_pos=p.dc, ds_pos=p.ds, dc_neg=n.dc, ds_neg=n.ds, omega_pos=p.omega, omega_neg=n.omega,
                           command_unit=self.command_unit, velocity_unit=self.velocity_unit, law=self.law,
                           viscous_pos=p.viscous, viscous_neg=n.viscous)

    def direction_force(self, direction: str, velocity) -> np.ndarray:
        """The fitted law of one direction at ``velocity`` [velocity unit] (signed as the direction) [command]."""
        d = self.directions[direction]
        v = np.asarray(velocity, dtype=float)
        if self.law == COULOMB_VISCOUS:
            return d.dc + d.viscous * v
        phi = law_shape(self.law, np.abs(v) / d.omega)
        return d.dc + (d.ds - d.dc) * phi + d.viscous * v

    def curve(self, n: int = 100) -> dict[str, dict[str, list[float]]]:
        """The fitted curve of every direction on ``n`` log-spaced speeds from half the lowest to 1.1 x the
        highest speed of its points: ``{"pos": {"velocity": [...], "force": [...]}, ...}`` (signed)."""
        out = {}
        for key, d in self.directions.items():
            lo, hi = d.speed_range
            speed = np.geomspace(max(lo / 2.0, 1e-12), max(1.1 * hi, lo), n)
            v = speed if key == "pos" else -speed
            out[key] = {"velocity": [float(x) for x in v], "force": [float(x) for x in self.direction_force(key, v)]}
        return out

    def to_dict(self) -> dict:
        """JSON-ready summary with units (the model's parameters when both directions were fitted)."""
        c, v = self.command_unit, self.velocity_unit
        model = self.model
        return {
            "law": self.law,
            "friction": None if model is None else model.to_dict(),
            "directions": {k: d.to_dict() for k, d in self.directions.items()},
            "mass": self.mass,
            "mass_std": self.mass_std,
            "rms_error": self.rms_error,
            "relative_error_pct": self.relative_error_pct,
            "warnings": list(self.warnings),
            "on_bound": {k: dict(b) for k, b in self.on_bound.items()},
            "units": {"dc": c, "ds": c, "omega": v, "viscous": f"{c}/({v})", "rms_error": c,
                      "relative_error_pct": "%", "mass": f"{c}/({v}^2)", "speed_range": v, "omega_bounds": v},
        }


# ------------------------------------------------------------------------------------------- the fit
@dataclass
class _Block:
    """Samples of one direction and where its parameters sit in the parameter vector."""

    key: str
    speed: np.ndarray
    v: np.ndarray
    y: np.ndarray
    a: np.ndarray | None
    cols: dict = field(default_factory=dict)  # parameter name (dc, ds, omega, viscous) -> index


def _block_names(law: str, viscous: bool) -> tuple[str, ...]:
    return (("dc", "ds", "omega") if law in SHAPED_LAWS else ("dc",)) + (("viscous",) if viscous else ())


def _linear_solve(block: _Block, law: str, omega: float, viscous: bool, with_mass: bool):
    """Least-squares levels (and viscous, mass) of one direction for a fixed ``omega``; coefficients, RSS."""
    if law in SHAPED_LAWS:
        phi = law_shape(law, block.speed / omega)
        cols = [1.0 - phi, phi]
    else:
        cols = [np.ones_like(block.speed)]
    cols += ([block.v] if viscous else []) + ([block.a] if with_mass else [])
    A = np.column_stack(cols)
    coef, *_ = np.linalg.lstsq(A, block.y, rcond=None)
    r = A @ coef - block.y
    return coef, float(r @ r)


def _residual_jacobian(theta: np.ndarray, blocks: list[_Block], law: str, viscous: bool, with_mass: bool):
    res, jac = [], []
    for b in blocks:
        c = b.cols
        J = np.zeros((b.y.size, theta.size))
        if "omega" in c:
            dc, ds, w = theta[c["dc"]], theta[c["ds"]], theta[c["omega"]]
            x = b.speed / w
            phi = law_shape(law, x)
            model = dc + (ds - dc) * phi
            J[:, c["dc"]] = 1.0 - phi
            J[:, c["ds"]] = phi
            J[:, c["omega"]] = (ds - dc) * law_shape_slope(law, x) * (-x / w)
        else:
            model = np.full(b.y.size, theta[c["dc"]])
            J[:, c["dc"]] = 1.0
        if viscous:
            model = model + theta[c["viscous"]] * b.v
            J[:, c["viscous"]] = b.v
        if with_mass:
            model = model + theta[0] * b.a
            J[:, 0] = b.a
        res.append(model - b.y)
        jac.append(J)
    return np.concatenate(res), np.vstack(jac)


def _solve(blocks, law, start, lower, upper, viscous, with_mass):
    from scipy.optimize import least_squares

    cache: dict[bytes, tuple[np.ndarray, np.ndarray]] = {}

    def evaluate(theta):
        key = theta.tobytes()
        if key not in cache:
            cache.clear()
            cache[key] = _residual_jacobian(theta, blocks, law, viscous, with_mass)
        return cache[key]

    start = np.clip(start, lower, upper)
    return least_squares(lambda th: evaluate(th)[0], start, jac=lambda th: evaluate(th)[1], bounds=(lower, upper),
                         x_scale="jac", method="trf", xtol=1e-12, ftol=1e-12, gtol=1e-12, max_nfev=500)


def _blocks(v: np.ndarray, y: np.ndarray, a: np.ndarray | None, min_speed: float, min_points: int,
            notes: list[str]) -> list[_Block]:
    blocks = []
    for key, sel in (("pos", v > min_speed), ("neg", v < -min_speed)):
        n = int(np.count_nonzero(sel))
        if n >= min_points:
            blocks.append(_Block(key, np.abs(v[sel]), v[sel], y[sel], None if a is None else a[sel]))
        else:
            other = DIRECTION_TEXT["neg" if key == "pos" else "pos"]
            notes.append(f"no points with {DIRECTION_TEXT[key]}: fitted {other} only" if n == 0 else
                         f"{n} point(s) with {DIRECTION_TEXT[key]} (need {min_points}): fitted {other} only")
    return blocks


def _sign_bounds(name: str, key: str) -> tuple[float, float]:
    """Physical bounds of a level or viscous coefficient of direction ``key``."""
    if name == "viscous" or key == "pos":
        return 0.0, np.inf
    return -np.inf, 0.0


def fit_friction_law(velocity, force, *, law: str = "stribeck", acceleration=None, viscous: bool = True,
                     min_speed: float = 0.0, min_points: int = MIN_POINTS, command_unit: str = "N",
                     velocity_unit: str = "m/s", where: str = "friction fit") -> FrictionLawFit:
    """Fit a friction law to ``(v, F)`` samples per direction by bounded nonlinear least squares.

    Model per direction (signed levels, module docstring of :mod:`feedtune.models.friction`)::

        F = dc (1 - phi(|v|/vs)) + ds phi(|v|/vs) + Fv v  [+ m a]

    ``dc, ds, vs, Fv`` per direction (``dc, Fv`` for the coulomb-viscous law), ``m`` shared (only with
    ``acceleration``). Started from the best ``vs`` of a log-spaced grid with the linear parameters solved
    exactly, then ``scipy.optimize.least_squares`` (trf, analytic Jacobian, ``vs`` bounded, see
    :data:`OMEGA_SPEED_LIMITS`). The unconstrained fit is read first
    (:func:`sign_diagnosis`: a mirrored command or an offset larger than the friction is refused); then the levels
    and viscous coefficients are held to their physical signs (``dc, ds >= 0`` for ``v > 0``, ``<= 0`` for
    ``v < 0``, ``Fv >= 0``, ``m >= 0``), and a parameter that ends on its bound is named in a warning with its
    unconstrained value.

    Parameters
    ----------
    velocity : array_like, shape (n,)
        Velocity [velocity unit].
    force : array_like, shape (n,)
        Friction force (or command) [command unit].
    law : str
        ``"stribeck"``, ``"hump"``, ``"lugre"`` or ``"coulomb-viscous"``.
    acceleration : array_like or None
        Acceleration [velocity unit/s]: adds a shared mass term ``m a`` (fit on ramps or whole tracking logs).
    viscous : bool
        Fit ``Fv`` per direction (False: ``Fv = 0``, the viscous friction is known elsewhere).
    min_speed : float
        Samples with ``|v| <= min_speed`` are left out [velocity unit].
    min_points : int
        A direction with fewer samples is not fitted (a warning says so); none left is an error.
    command_unit, velocity_unit : str
        Units recorded in the result.
    where : str
        What is fitted, for messages.

    Returns
    -------
    FrictionLawFit
        Parameters per direction with standard deviations, the mass term, residuals, warnings.

    Raises
    ------
    IllConditionedError
        No direction has ``min_points`` samples, or a direction's speeds span no range.
    DataError
        A mirrored or sign-inverted command, or an offset larger than the friction (:func:`sign_diagnosis`).
    """
    law = check_law(law)
    v = as_series(velocity, "velocity")
    y = as_series(force, "force")
    a = None if acceleration is None else as_series(acceleration, "acceleration")
    if v.size != y.size or (a is not None and a.size != v.size):
        raise DataError(f"{where}: velocity, force (and acceleration) must have the same length, got {v.size}, "
                        f"{y.size}" + ("" if a is None else f", {a.size}"))
    if not (np.isfinite(min_speed) and min_speed >= 0):
        raise UsageError(f"min_speed must be >= 0 {velocity_unit}, got {min_speed!r}", parameter="min_speed")
    notes: list[str] = []
    blocks = _blocks(v, y, a, float(min_speed), int(min_points), notes)
    if not blocks:
        raise IllConditionedError(f"{where}: fewer than {min_points} points move either way above "
                                  f"{min_speed:g} {velocity_unit}")
    with_mass = a is not None
    shaped = law in SHAPED_LAWS
    names = _block_names(law, viscous)
    col = 1 if with_mass else 0
    starts, lowers, uppers = ([0.0] if with_mass else []), ([0.0] if with_mass else []), \
        ([np.inf] if with_mass else [])
    masses = []
    for b in blocks:
        lo, hi = (np.percentile(b.speed, [2.0, 98.0]) if b.speed.size > 50 else (b.speed.min(), b.speed.max()))
        if shaped and not hi >= 1.5 * lo:
            raise IllConditionedError(
                f"{where}: the speeds with {DIRECTION_TEXT[b.key]} only span {lo:.4g} to {hi:.4g} {velocity_unit}; "
                f"a {law} law needs points over a range of speeds (or fit the {COULOMB_VISCOUS} law)")
        w_lo, w_hi = lo / OMEGA_SPEED_LIMITS[0], hi / OMEGA_SPEED_LIMITS[1]
        if shaped:
            step = max(1, b.speed.size // 5000)
            thin = _Block(b.key, b.speed[::step], b.v[::step], b.y[::step], None if a is None else b.a[::step])
            grid = np.geomspace(w_lo, w_hi, 40)
            costs = [_linear_solve(thin, law, w, viscous, with_mass)[1] for w in grid]
            w0 = float(grid[int(np.argmin(costs))])
        else:
            w0 = 1.0
        coef = _linear_solve(b, law, w0, viscous, with_mass)[0]
        if with_mass:
            masses.append(coef[-1])
        linear = dict(zip(("dc", "ds") if shaped else ("dc",), coef, strict=False))
        if viscous:
            linear["viscous"] = coef[2 if shaped else 1]
        b.cols = {name: col + k for k, name in enumerate(names)}
        col += len(names)
        for name in names:
            starts.append(w0 if name == "omega" else linear[name])
            lo_b, hi_b = (w_lo, w_hi) if name == "omega" else (-np.inf, np.inf)
            lowers.append(lo_b)
            uppers.append(hi_b)
    if with_mass:
        starts[0] = float(np.mean(masses))
        lowers[0] = -np.inf
    start, lower, upper = np.array(starts), np.array(lowers), np.array(uppers)
    free = _solve(blocks, law, start, lower, upper, viscous, with_mass)
    std_free = parameter_std(free.jac, float(free.fun @ free.fun) / max(free.fun.size - free.x.size, 1))
    sign_diagnosis({f"dc_{b.key}": (float(free.x[b.cols["dc"]]), float(std_free[b.cols["dc"]])) for b in blocks},
                   command_unit, where,
                   mass=(float(free.x[0]), float(std_free[0])) if with_mass else None)
    for b in blocks:  # the physical signs
        for name, k in b.cols.items():
            if name != "omega":
                lower[k], upper[k] = _sign_bounds(name, b.key)
    if with_mass:
        lower[0] = 0.0
    sol = free
    outside = (free.x < lower) | (free.x > upper)
    on_bound = {}
    if np.any(outside):
        sol = _solve(blocks, law, free.x, lower, upper, viscous, with_mass)
        # a level or viscous coefficient the solver left within round-off of its bound 0 is on it
        tol = 1e-9 * max(float(np.max(np.abs(sol.x[1 if with_mass else 0:]))), 1e-300)
        for b in blocks:
            for name, k in b.cols.items():
                if name != "omega" and abs(sol.x[k]) <= tol:
                    sol.x[k] = 0.0
                    on_bound[f"{name}_{b.key}"] = {"bound": 0.0, "unconstrained": float(free.x[k]),
                                                   "std": float(std_free[k]) if np.isfinite(std_free[k]) else None}
    theta, jac, res = sol.x, sol.jac, sol.fun
    keep = np.ones(theta.size, bool)
    for b in blocks:
        for name, k in b.cols.items():
            if f"{name}_{b.key}" in on_bound:
                keep[k] = False
    std = np.full(theta.size, np.nan)
    std[keep] = parameter_std(jac[:, keep], float(res @ res) / max(res.size - int(np.count_nonzero(keep)), 1))
    notes += [f"{name} ended on its bound 0 (unconstrained {b['unconstrained']:.4g}"
              + ("" if b["std"] is None else f" +/- {b['std']:.2g}")
              + f" {command_unit if not name.startswith('viscous') else f'{command_unit}/({velocity_unit})'}): "
              + ("the law does not describe these points (a friction that falls over the whole speed range?); "
                 if name.startswith("viscous") and b["std"] is not None
                 and b["unconstrained"] + STD_SIGMAS * b["std"] < 0 else "the data do not identify it; ")
              + "it is held at 0" for name, b in on_bound.items()]
    return _result(theta, std, res, blocks, law, viscous, with_mass, lower, upper, command_unit, velocity_unit,
                   notes, on_bound)


def _result(theta, std, res, blocks, law, viscous, with_mass, lower, upper, command_unit, velocity_unit,
            notes, on_bound=None) -> FrictionLawFit:
    dirs = {}
    warnings = list(notes)
    y_all = np.concatenate([b.y for b in blocks])
    offset = 0
    nan = float("nan")
    for b in blocks:
        r = res[offset: offset + b.y.size]
        offset += b.y.size
        c = b.cols
        fit = DirectionFit(
            direction=b.key, dc=float(theta[c["dc"]]), ds=float(theta[c.get("ds", c["dc"])]),
            omega=float(theta[c["omega"]]) if "omega" in c else nan,
            viscous=float(theta[c["viscous"]]) if viscous else 0.0,
            std={n: float(std[k]) for n, k in c.items()}, n=int(b.y.size),
            rms_error=float(np.sqrt(np.mean(r**2))), speed_range=(float(b.speed.min()), float(b.speed.max())),
            omega_bounds=(float(lower[c["omega"]]), float(upper[c["omega"]])) if "omega" in c else (nan, nan))
        dirs[b.key] = fit
        if fit.omega_at_bound:
            warnings.append(f"vs for {DIRECTION_TEXT[b.key]} ended on its bound ({fit.omega:.4g} {velocity_unit}): "
                            "the points do not resolve it (add speeds around the friction's low-speed change)")
        if fit.n < FEW_POINTS:
            warnings.append(f"only {fit.n} points with {DIRECTION_TEXT[b.key]} for a {len(c)}-parameter law: "
                            "the parameters rest on few plateaus (add speeds)")
    return FrictionLawFit(
        law=law, directions=dirs, mass=float(theta[0]) if with_mass else None,
        mass_std=float(std[0]) if with_mass and np.isfinite(std[0]) else None,
        rms_error=float(np.sqrt(np.mean(res**2))),
        relative_error_pct=float(100.0 * np.linalg.norm(res) / max(np.linalg.norm(y_all), 1e-300)),
        command_unit=command_unit, velocity_unit=velocity_unit, warnings=tuple(dict.fromkeys(warnings)),
        on_bound=dict(on_bound or {}))


def identifiability_warnings(fit: FrictionLawFit) -> list[str]:
    """What the fitted law's parameters say about the data: a poorly resolved ``vs`` (relative std above
    :data:`POOR_OMEGA_STD`), a static level indistinguishable from the Coulomb level (within :data:`STD_SIGMAS` std:
    the law's low-speed shape is not identified), and a dip (a static level below the Coulomb level by more than that,
    :func:`~feedtune.models.friction.level_shape`; within it the first warning names the dip)."""
    out = []
    if fit.law == COULOMB_VISCOUS:
        return out
    unit, vu = fit.command_unit, fit.velocity_unit
    what = "peak level" if fit.law == "hump" else "static level"
    dips = []
    for d, f in fit.directions.items():
        way = DIRECTION_TEXT[d]
        w_sd = f.std.get("omega", float("nan"))
        if np.isfinite(w_sd) and w_sd > POOR_OMEGA_STD * f.omega and not f.omega_at_bound:
            out.append(f"vs for {way} is poorly resolved: {f.omega:.4g} +/- {w_sd:.2g} {vu} "
                       f"({100 * w_sd / f.omega:.0f} %): the samples hold little motion around that speed")
        step_sd = float(np.hypot(f.std.get("ds", np.nan), f.std.get("dc", np.nan)))
        shape = level_shape(f.dc, f.ds)
        if np.isfinite(step_sd) and abs(f.ds - f.dc) <= STD_SIGMAS * step_sd:
            side = {"dip": ", below: a dip within its uncertainty", "peak": ", above: a peak within its uncertainty",
                    "flat": ""}[shape]
            out.append(f"for {way} the {what} ({f.ds:.4g} {unit}{side}) is not distinguishable from the Coulomb level "
                       f"({f.dc:.4g} {unit}, difference within {STD_SIGMAS:g} std = {STD_SIGMAS * step_sd:.2g} "
                       f"{unit}): the law's low-speed shape is not identified (the {COULOMB_VISCOUS} law may do)")
        elif shape == "dip":
            dips.append(d)
    if dips:
        levels = "; ".join(f"{DIRECTION_TEXT[d]}: ds = {fit.directions[d].ds:.4g} {unit}, dc = "
                           f"{fit.directions[d].dc:.4g} {unit}" for d in dips)
        out.append(f"dip, not a Stribeck peak ({levels}): the {what} lies below the Coulomb level, so the friction "
                   "rises from rest to its sliding level; the model and its feedforward follow that")
    return out


# ------------------------------------------------------------------------------------------ binned points
SPEED_BINS = 30
"""Most speed bins per direction of the binned friction points of dense samples (:func:`bin_by_speed`)."""
SAMPLES_PER_BIN = 10
"""Fewer bins are used when a direction has fewer than this many samples per bin on average."""


def bin_by_speed(velocity, force, *, min_speed: float = 0.0, n_bins: int = SPEED_BINS) -> list[dict]:
    """Friction points of dense samples: the mean force in equal-width speed bins, per direction.

    Parameters
    ----------
    velocity : array_like
        Velocity samples [velocity unit].
    force : array_like
        Friction force samples, e.g. ``F - m a`` of a joint fit [command unit].
    min_speed : float
        Samples slower than this are left out [velocity unit].
    n_bins : int
        Most bins per direction between the slowest and the fastest kept speed (fewer when a direction has less
        than :data:`SAMPLES_PER_BIN` samples per bin).

    Returns
    -------
    list of dict
        Per non-empty bin, slow to fast, ``v > 0`` first: ``direction`` (``"pos"``/``"neg"``), ``velocity`` and
        ``force`` (means, signed) [velocity unit], [command unit], ``force_std`` [command unit] and ``n``.
    """
    v = as_series(velocity, "velocity")
    f = as_series(force, "force")
    if v.size != f.size:
        raise DataError(f"velocity and force have different lengths ({v.size}, {f.size})")
    if n_bins < 1:
        raise UsageError(f"n_bins must be >= 1, got {n_bins!r}", parameter="n_bins")
    points = []
    for key, sign in (("pos", 1.0), ("neg", -1.0)):
        sel = (sign * v > 0) & (np.abs(v) >= min_speed)
        if not np.any(sel):
            continue
        speed, force_d = np.abs(v[sel]), f[sel]
        bins = int(np.clip(speed.size // SAMPLES_PER_BIN, 1, n_bins))
        edges = np.linspace(float(speed.min()), float(speed.max()), bins + 1)
        index = np.clip(np.searchsorted(edges, speed, side="right") - 1, 0, bins - 1)
        for k in range(bins):
            m = index == k
            if np.any(m):
                points.append({"direction": key, "velocity": float(sign * np.mean(speed[m])),
                               "force": float(np.mean(force_d[m])), "force_std": float(np.std(force_d[m])),
                               "n": int(np.count_nonzero(m))})
    return points


# ------------------------------------------------------------------------------------------ plateaus
@dataclass(frozen=True)
class Plateau:
    """One constant-velocity plateau and its friction point (module docstring: plateau rule).

    Attributes
    ----------
    t_start, t_end : float
        Time span averaged (after the trim) [s].
    velocity, velocity_std : float
        Mean and standard deviation of the filtered velocity over it [velocity unit].
    force, force_std : float
        Mean and standard deviation (scatter) of the command over it [command unit].
    n : int
        Samples averaged.
    log : int
        Index of the log it came from.
    """

    t_start: float
    t_end: float
    velocity: float
    velocity_std: float
    force: float
    force_std: float
    n: int
    log: int = 0

    @property
    def direction(self) -> str:
        """``"pos"`` or ``"neg"``."""
        return "pos" if self.velocity > 0 else "neg"

    def to_dict(self) -> dict:
        """JSON-ready point."""
        return {"direction": self.direction, "velocity": self.velocity, "velocity_std": self.velocity_std,
                "force": self.force, "force_std": self.force_std, "n": self.n, "t_start": self.t_start,
                "t_end": self.t_end, "duration_s": self.t_end - self.t_start, "log": self.log}


@dataclass(frozen=True)
class PlateauSettings:
    """The plateau rule's settings (module docstring), resolved for one log where they depend on it.

    Attributes
    ----------
    acc_tol : float or None
        Acceleration tolerance [velocity unit/s]; None: :data:`ACC_TOL_FRACTION` of the log's ``|a|`` (99th pct).
    vel_tol : float
        Relative velocity tolerance [-].
    min_duration : float
        Shortest plateau [s].
    min_speed : float or None
        Slowest plateau [velocity unit]; None: :data:`MIN_SPEED_FRACTION` of the log's peak speed.
    trim : float
        Part left out at each end of a plateau [-], in ``[0, 0.5)``.
    """

    acc_tol: float | None = None
    vel_tol: float = VEL_TOL
    min_duration: float = MIN_DURATION_S
    min_speed: float | None = None
    trim: float = TRIM_FRACTION

    def __post_init__(self) -> None:
        for name in ("acc_tol", "min_speed"):
            value = getattr(self, name)
            if value is not None and not (np.isfinite(value) and value >= 0):
                raise UsageError(f"plateau {name} must be >= 0, got {value!r}", parameter=f"PlateauSettings.{name}")
        if not (np.isfinite(self.vel_tol) and 0 < self.vel_tol < 1):
            raise UsageError(f"plateau vel_tol must be in (0, 1), got {self.vel_tol!r}",
                             parameter="PlateauSettings.vel_tol")
        if not (np.isfinite(self.min_duration) and self.min_duration > 0):
            raise UsageError(f"plateau min_duration must be > 0 s, got {self.min_duration!r}",
                             parameter="PlateauSettings.min_duration")
        if not (np.isfinite(self.trim) and 0 <= self.trim < 0.5):
            raise UsageError(f"plateau trim must be in [0, 0.5), got {self.trim!r}")

    def to_dict(self) -> dict:
        """JSON-ready settings (None: chosen per log)."""
        return {"acc_tol": self.acc_tol, "vel_tol": self.vel_tol, "min_duration": self.min_duration,
                "min_speed": self.min_speed, "trim": self.trim}


def _runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """``[start, stop)`` index ranges of the True runs of a boolean array."""
    edges = np.diff(np.concatenate([[0], mask.astype(np.int8), [0]]))
    return list(zip(np.flatnonzero(edges == 1).tolist(), np.flatnonzero(edges == -1).tolist(), strict=True))


def _physical_plateaus(pieces: list[tuple[int, int]], v: np.ndarray, a: np.ndarray, acc_tol: float,
                       vel_tol: float, min_speed: float) -> list[list[tuple[int, int]]]:
    """Consecutive pieces (sample ranges, in time order) grouped per physical plateau (module docstring, step 5)."""
    groups: list[list[tuple[int, int]]] = []
    means: list[list[float]] = []
    for i, j in pieces:
        mean = float(np.mean(v[i:j]))
        if groups:
            previous_stop = groups[-1][-1][1]
            joined = means[-1] + [mean]
            centre = float(np.mean(joined))
            between = np.sign(mean) * v[previous_stop:i]
            if (np.sign(mean) == np.sign(means[-1][-1]) and bool(np.all(between >= min_speed))
                    and float(np.max(np.abs(a[previous_stop:i]), initial=0.0)) <= MERGE_ACC_FACTOR * acc_tol
                    and max(abs(m - centre) for m in joined) <= MERGE_SPREAD_FACTOR * vel_tol * abs(centre)):
                groups[-1].append((i, j))
                means[-1] = joined
                continue
        groups.append([(i, j)])
        means.append([mean])
    return groups


def find_plateaus(t, velocity, acceleration, force, *, settings: PlateauSettings | None = None,
                  log_index: int = 0) -> tuple[list[Plateau], dict]:
    """Constant-velocity plateaus of a motion and the mean command on each (module docstring: plateau rule).

    Parameters
    ----------
    t : array_like
        Time [s], uniform.
    velocity, acceleration : array_like
        Filtered velocity [velocity unit] and acceleration [velocity unit/s].
    force : array_like
        Command [command unit].
    settings : PlateauSettings or None
        The rule's tolerances (default :class:`PlateauSettings()`).
    log_index : int
        Recorded in each :class:`Plateau`.

    Returns
    -------
    (list of Plateau, dict)
        The plateaus in time order and the resolved ``acc_tol``, ``min_speed`` of this log.
    """
    settings = settings or PlateauSettings()
    t, v, a, u = (as_series(x, n) for x, n in ((t, "t"), (velocity, "velocity"), (acceleration, "acceleration"),
                                             (force, "force")))
    if not (t.size == v.size == a.size == u.size) or t.size < 2:
        raise DataError("plateau search: time, velocity, acceleration and force must have the same length (>= 2)")
    dt = float(t[1] - t[0])
    acc_tol = (ACC_TOL_FRACTION * float(np.percentile(np.abs(a), 99.0)) if settings.acc_tol is None
               else settings.acc_tol)
    min_speed = (MIN_SPEED_FRACTION * float(np.max(np.abs(v))) if settings.min_speed is None
                 else settings.min_speed)
    if settings.min_duration > t[-1] - t[0]:
        raise DataError(f"plateau min_duration={settings.min_duration:g} s is longer than the log "
                        f"({t[-1] - t[0]:.4g} s): no plateau can last that long",
                        parameter="PlateauSettings.min_duration")
    n_min = max(2, int(np.ceil(settings.min_duration / dt)))
    window = max(1, n_min // DRIFT_WINDOW_DIVISOR)
    padded = np.pad(v, (window // 2, window - 1 - window // 2), mode="edge")  # centred, edges held
    v_drift = np.convolve(padded, np.full(window, 1.0 / window), mode="valid")  # the band test ignores fast noise
    steady = (np.abs(a) <= acc_tol) & (np.abs(v) >= max(min_speed, np.finfo(float).tiny))
    pieces = []  # (first, stop) sample ranges after the trim
    for sign in (1.0, -1.0):
        for start, stop in _runs(steady & (sign * v > 0)):
            s = start
            while stop - s >= n_min:
                ref = float(np.median(v[s: s + n_min]))
                out = np.flatnonzero(np.abs(v_drift[s:stop] - ref) > settings.vel_tol * abs(ref))
                end = stop if out.size == 0 else s + int(out[0])
                if end - s >= n_min:
                    cut = int(settings.trim * (end - s))
                    pieces.append((s + cut, end - cut))
                    s = end
                else:
                    s = max(end, s + max(1, n_min // 4))
    plateaus = []
    for group in _physical_plateaus(sorted(pieces), v, a, acc_tol, settings.vel_tol,
                                    max(min_speed, np.finfo(float).tiny)):
        idx = np.concatenate([np.arange(i, j) for i, j in group])
        plateaus.append(Plateau(t_start=float(t[group[0][0]]), t_end=float(t[group[-1][1] - 1]),
                                velocity=float(np.mean(v[idx])), velocity_std=float(np.std(v[idx])),
                                force=float(np.mean(u[idx])), force_std=float(np.std(u[idx])), n=int(idx.size),
                                log=log_index))
    plateaus.sort(key=lambda p: p.t_start)
    return plateaus, {"acc_tol": acc_tol, "min_speed": min_speed}


# ------------------------------------------------------------------------------------- steady state
@dataclass(frozen=True)
class SteadyStateFriction:
    """Result of :func:`identify_friction_curve`.

    Attributes
    ----------
    plateaus : tuple of Plateau
        The friction points (every log), in time order per log.
    fit : FrictionLawFit
        The law fitted per direction to the points.
    settings : PlateauSettings
        The rule's settings as given.
    resolved : list of dict
        ``acc_tol`` [velocity unit/s] and ``min_speed`` [velocity unit] used per log.
    cutoff_hz : list of float
        Position filter cut-off per log [Hz].
    n_logs : int
        Logs searched.
    warnings : tuple of str
        Few plateaus, one direction only, ``vs`` on a bound, clipped or coarse data.
    """

    plateaus: tuple
    fit: FrictionLawFit
    settings: PlateauSettings
    resolved: list
    cutoff_hz: list
    n_logs: int = 1
    warnings: tuple = ()

    @property
    def friction(self) -> FrictionLaw | None:
        """The fitted :class:`FrictionLaw` (both directions), or None for a one-direction log."""
        return self.fit.model

    def to_dict(self) -> dict:
        """JSON-ready summary: points, fit, fitted curve (for plots), settings, warnings, units."""
        c, v = self.fit.command_unit, self.fit.velocity_unit
        return {
            "method": "steady-state",
            "law": self.fit.law,
            "points": [p.to_dict() for p in self.plateaus],
            "fit": self.fit.to_dict(),
            "friction": None if self.friction is None else self.friction.to_dict(),
            "curve": self.fit.curve(),
            "plateau_rule": {**self.settings.to_dict(), "resolved": self.resolved, "cutoff_hz": self.cutoff_hz},
            "n_logs": self.n_logs,
            "warnings": list(self.warnings),
            "units": {"velocity": v, "force": c, "velocity_std": v, "force_std": c, "t_start": "s", "t_end": "s",
                      "duration_s": "s", "acc_tol": f"{v}/s", "min_speed": v, "min_duration": "s", "vel_tol": "-",
                      "trim": "-", "cutoff_hz": "Hz"},
        }


@progress.tasked("fitting the friction curve")
def identify_friction_curve(log: Log | Sequence[Log], *, position: str, command: str, law: str = "stribeck",
                            command_scale: float = 1.0, command_unit: str | None = None,
                            cutoff_hz: float | None = None, settings: PlateauSettings | None = None
                            ) -> SteadyStateFriction:
    """Steady-state friction curve: constant-velocity plateaus, the mean command on each, a law fitted per direction.

    Parameters
    ----------
    log : Log or sequence of Log
        Uniformly sampled log(s) holding constant-speed runs at many speeds (both ways for a model).
    position, command : str
        Position column [m or rad; mm, um, deg converted] and command column (times ``command_scale``).
    law : str
        ``"stribeck"``, ``"hump"`` or ``"lugre"`` (each with a viscous term, per direction).
    command_scale : float
        Multiplies the command (e.g. a drive gain in N/V).
    command_unit : str or None
        Unit of the scaled command (default as in :func:`~feedtune.identify.rigid.fit_rigid`).
    cutoff_hz : float or None
        Position filter cut-off [Hz]; None: :func:`~feedtune.identify.rigid.auto_cutoff_hz` per log.
    settings : PlateauSettings or None
        Plateau rule (module docstring).

    Returns
    -------
    SteadyStateFriction
        Points, fit (``fit.model`` is the :class:`FrictionLaw` when both directions were fitted), curve, warnings.

    Raises
    ------
    IllConditionedError
        Fewer than :data:`MIN_POINTS` plateaus in either direction, or their speeds span no range.
    DataError
        A fitted level or viscous coefficient has the wrong sign (named, with the likely cause).
    """
    from .rigid import _prepare, auto_cutoff_hz, data_warnings, position_si, uniform_sample_time

    law = check_law(law)
    settings = settings or PlateauSettings()
    logs = [log] if isinstance(log, Log) else list(log)
    if not logs:
        raise UsageError("identify_friction_curve needs at least one log")
    plateaus, resolved, cutoffs, units = [], [], [], None
    for k, lg in enumerate(logs):
        cut = cutoff_hz
        if cut is None:
            try:
                cut = auto_cutoff_hz(position_si(lg, position)[0], uniform_sample_time(lg))[0]
            except DataError as exc:
                raise DataError(f"{lg.source}: {exc}") from None
        smp = _prepare(lg, command, position, cut, 4, 1, command_scale, command_unit)
        if units is None:
            units = (smp.force_unit, smp.position_unit)
        elif units != (smp.force_unit, smp.position_unit):
            raise DataError(f"{lg.source}: command in {smp.force_unit} and position in {smp.position_unit}, but "
                            f"{logs[0].source} has {units[0]} and {units[1]}")
        border = (lg.n - smp.force.size) // 2
        t = lg.t[border: border + smp.force.size]
        found, res = find_plateaus(t, smp.velocity, smp.acceleration, smp.force, settings=settings, log_index=k)
        plateaus += found
        resolved.append(res)
        cutoffs.append(smp.cutoff_hz)
    force_unit, position_unit = units
    velocity_unit = f"{position_unit}/s"
    if not plateaus:
        raise IllConditionedError(
            "steady-state friction: no constant-velocity plateau found (|a| <= acc_tol and the velocity within "
            f"{100 * settings.vel_tol:g} % for at least {settings.min_duration:g} s); the log needs runs at "
            "constant speeds (or loosen the plateau tolerances)")
    v = np.array([p.velocity for p in plateaus])
    f = np.array([p.force for p in plateaus])
    fit = fit_friction_law(v, f, law=law, viscous=True, min_points=MIN_POINTS, command_unit=force_unit,
                           velocity_unit=velocity_unit, where=f"steady-state {law} fit")
    warnings = list(fit.warnings) + identifiability_warnings(fit)
    if len(fit.directions) < 2:
        warnings.append("one direction only: no friction model (a model file and a feedforward need both "
                        "directions)")
    warnings += [w for lg in logs for w in data_warnings(lg, command, position, force_unit)]
    return SteadyStateFriction(plateaus=tuple(plateaus), fit=fit, settings=settings, resolved=resolved,
                               cutoff_hz=cutoffs, n_logs=len(logs), warnings=tuple(dict.fromkeys(warnings)))
