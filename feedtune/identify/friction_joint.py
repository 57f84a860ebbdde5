"""Joint fit of mass, viscous friction and a friction law per direction on tracking logs (the IDIM-LS way).

Model, per sample (signed levels of :mod:`feedtune.models.friction`; the law's shape ``phi``)::

    u = M a + sum over the directions d of  I_d(v) [dc_d (1 - phi(|v|/vs_d)) + ds_d phi(|v|/vs_d) + Fv_d v]

with ``I_d(v)`` the indicator of the direction (``v > 0``, ``v < 0``; nothing at ``v = 0``: eq. 2.1 is 0 there).
It is linear in ``M, dc_d, ds_d, Fv_d`` and nonlinear in ``vs`` (one ``vs`` for both directions, as eq. 2.1 has
one ``Omega``, or one per direction).

Processing (:func:`fit_joint_friction`), each log on its own:

1. Velocity and acceleration as for IDIM-LS (:mod:`feedtune.identify.rigid`: zero-phase Butterworth on the
   position, central differences, edges trimmed), with a cut-off of at least :data:`JOINT_MIN_CUTOFF_HZ`: the
   friction changes within a few milliseconds of a reversal, and the law's columns are evaluated at the filtered
   velocity, which must follow it (the motion's own band, :func:`~feedtune.identify.rigid.auto_cutoff_hz`, is often
   lower: 14 Hz on a 1 Hz sine).
2. The command is taken at the sample instants: a command held from ``t_k`` to ``t_k+1`` (zero-order hold, the
   Kalman filter's convention) is ``(u[k-1] + u[k]) / 2`` at ``t_k`` for the central differences (for a pure mass
   ``(x[k+1] - 2 x[k] + x[k-1]) / dt^2`` is exactly ``(u[k-1] + u[k]) / (2 M)``).
3. Samples where the law does not hold are masked **before** any filtering: speeds below ``min_speed`` (sticking,
   creeping, the sign of a velocity close to zero) and ``guard_s`` either side of them (the Butterworth filter
   smears the kinks of the velocity there); the masked samples are set to zero in the command and in every column.
4. Parallel decimation (IDIM-LS): the masked command and the masked columns -- the law's columns computed at the
   full rate -- pass the same zero-phase decimation filter, so a friction jump at a reversal is smeared alike on
   both sides of the equation and needs no guard; the masking makes the equation exact on the decimated rows too
   (a masked sample contributes zero to both sides). Rows covered less than half by unmasked samples are dropped.
   Any linear filter keeps the equation exact as long as every column gets it, so a factor of 20 or more starts
   with block means of ``factor // 10`` samples (the law's columns are evaluated at the full rate at every step of
   the fit: 1.2 million samples at 20 kHz cost a block mean, not an order-8 filter run both ways) and the
   Chebyshev decimation of :func:`~feedtune.identify.rigid.decimate_columns` does the rest.

The fit: a grid over ``vs`` with the linear parameters solved at each point, then
``scipy.optimize.least_squares`` (trf, analytic Jacobian) over all parameters within their physical bounds (``M >
0``; ``dc, ds >= 0`` for ``v > 0`` and ``<= 0`` for ``v < 0``; ``Fv >= 0``; ``vs`` in ``[v_2 / 5, v_98 / 2]`` of the
speeds). Before that the unconstrained fit is read (:func:`~feedtune.identify.friction_curve.sign_diagnosis`): a
negative mass or Coulomb levels opposing the motion both ways are a mirrored command, Coulomb levels of one sign an
offset larger than the friction; both are refused. A parameter that ends on its bound is reported with its
unconstrained value: the data do not identify it. Standard deviations are those of the free parameters.

On 8 closed-loop simulations of eq. 2.1 (sine, chirp and trapezoid motions, 0.1 um encoder, command noise;
``tests/test_friction_joint.py``) the fit recovers ``dc, ds`` within 3 %, ``Omega`` within 10 % and the mass within
1 % (measured: 1.2 %, 2.6 %, 0.1 %); the former fit (law at the decimated velocity, reversal guard of
``5 / cutoff``, Kalman estimate after it) refused one of them (too few rows after its 14 Hz filter) and missed ``ds`` by
up to 15 % and ``Omega`` by up to 33 % on three others.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from .. import progress
from ..blas import blas_single_threaded
from ..errors import DataError, IllConditionedError, Notice, UsageError
from ..log import Log
from ..models.friction import COULOMB_VISCOUS, LAWS, SHAPED_LAWS, check_law, law_shape, law_shape_slope, level_shape
from .friction_curve import (
    DIRECTION_TEXT,
    OMEGA_SPEED_LIMITS,
    DirectionFit,
    FrictionLawFit,
    bin_by_speed,
    identifiability_warnings,
    parameter_std,
    sign_diagnosis,
)

JOINT_MIN_CUTOFF_HZ = 100.0
"""Lowest automatic cut-off of the joint fit's position filter [Hz] (the EMPS recipe's 100 Hz: it follows a friction
change within about 10 ms), capped at 0.4 fs."""
JOINT_GUARD_CUTOFFS = 1.0
"""Default ``guard_s``: one period of the cut-off, ``1 / cutoff_hz`` [s], either side of every slow sample."""
MIN_SAMPLES_PER_DIRECTION = 50
"""Fewest decimated rows per direction (above ``min_speed``) for that direction's law."""
DEFAULT_MIN_SPEED_FRACTION = 0.02
"""Default ``min_speed`` as a fraction of the peak speed: closer to zero the samples are dominated by stick and
creep rather than by the sliding friction of the laws."""
MAX_MASS_RELATIVE_STD = 0.25
"""Largest accepted relative standard deviation of the joint fit's mass."""
LAW_MISMATCH_RSS = 0.9
"""Another law whose residual sum of squares is below this fraction of the fitted law's is named in a warning."""
OMEGA_GRID = 30
"""Points of the ``vs`` grid that starts the fit."""
COMPARE_GRID = 12
"""Points of the ``vs`` grid on which the laws are compared (a step of 1.2-1.5 in ``vs``)."""


class OneDirectionError(IllConditionedError):
    """The data move one way only: a friction model of both directions cannot be identified (the joint fit of the
    moving direction can, ``fit_joint_friction(..., one_direction=True)``)."""


@dataclass(frozen=True)
class JointFit:
    """Result of :func:`fit_joint_friction`: mass, viscous friction and a friction law fitted together.

    Attributes
    ----------
    law_fit : FrictionLawFit
        The law per direction (levels, ``vs``, viscous ``Fv`` per direction) and the shared mass with their
        standard deviations (NaN for a parameter on its bound), on the decimated rows.
    cutoff_hz : float
        Butterworth cut-off of the position filter [Hz] (the highest of the logs').
    cutoff_rule : str
        ``"given"`` or how it was chosen (module docstring, step 1).
    decimate : int
        Decimation factor (the highest of the logs').
    guard_s : float
        Time masked either side of every slow sample [s].
    min_speed : float
        Speed threshold [velocity unit].
    n_samples : int
        Decimated rows in the fit.
    force_unit, position_unit : str
        Units of the command and of the position.
    warnings : tuple of str
        One direction only, parameters on their bounds, a poorly resolved ``vs``, a dip, a better-fitting law, and
        the law fit's own warnings.
    points : tuple of dict
        The measured friction ``F - M a`` of the fitted rows binned by speed
        (:func:`~feedtune.identify.friction_curve.bin_by_speed`): ``direction``, ``velocity`` [position unit/s],
        ``force``, ``force_std`` [command unit], ``n``.
    on_bound : dict of str to dict
        Parameters that ended on their bound: ``{name: {"bound": b, "unconstrained": value, "std": sd}}``.
    law_rms : dict of str to float
        RMS residual of the fitted law and of the other laws with a static level, each at the best point of the same
        bounded ``vs`` grid (:data:`COMPARE_GRID` points) on the same rows [command unit] (the comparison behind a
        law-mismatch warning).
    """

    law_fit: FrictionLawFit
    cutoff_hz: float
    cutoff_rule: str
    decimate: int
    guard_s: float
    min_speed: float
    n_samples: int
    force_unit: str
    position_unit: str
    warnings: tuple = ()
    points: tuple = ()
    on_bound: dict = field(default_factory=dict)
    law_rms: dict = field(default_factory=dict)

    @property
    def mass(self) -> float:
        """Mass or inertia [command unit/(position unit/s^2)]."""
        return float(self.law_fit.mass)

    @property
    def viscous_pair(self) -> tuple[float | None, float | None]:
        """Viscous coefficients ``(Fv+, Fv-)`` [command unit/(position unit/s)]; None for a direction without data."""
        d = self.law_fit.directions
        return tuple(d[k].viscous if k in d else None for k in ("pos", "neg"))

    @property
    def shapes(self) -> dict[str, str]:
        """``"peak"``, ``"dip"`` or ``"flat"`` per fitted direction (:func:`~feedtune.models.friction.level_shape`)."""
        if self.law_fit.law == COULOMB_VISCOUS:
            return {}
        return {k: level_shape(d.dc, d.ds) for k, d in self.law_fit.directions.items()}

    def to_dict(self) -> dict:
        """JSON-ready summary with units."""
        f, p = self.force_unit, self.position_unit
        return {
            "method": "joint nonlinear least squares on the IDIM-LS regressor (masked parallel decimation): "
                      "u = M a + Fv v + law(v)",
            "mass": self.mass, "mass_std": self.law_fit.mass_std,
            "viscous_pos": self.viscous_pair[0], "viscous_neg": self.viscous_pair[1],
            "law_fit": self.law_fit.to_dict(), "shape": self.shapes,
            "on_bound": {k: dict(v) for k, v in self.on_bound.items()},
            "law_rms": dict(self.law_rms),
            "cutoff_hz": self.cutoff_hz, "cutoff_rule": self.cutoff_rule, "decimate": self.decimate,
            "guard_s": self.guard_s, "min_speed": self.min_speed,
            "n_samples": self.n_samples, "curve": self.law_fit.curve(), "warnings": list(self.warnings),
            "units": {"mass": f"{f}/({p}/s^2)", "mass_std": f"{f}/({p}/s^2)", "viscous_pos": f"{f}/({p}/s)",
                      "viscous_neg": f"{f}/({p}/s)", "cutoff_hz": "Hz", "guard_s": "s", "min_speed": f"{p}/s",
                      "law_rms": f},
        }


# ------------------------------------------------------------------------------------------- columns
def _parallel_decimation(x: np.ndarray, factor: int) -> np.ndarray:
    """The joint fit's decimation of full-rate columns ``x`` (n, k) (module docstring, step 4): block means of
    ``factor // 10`` samples first when ``factor >= 20``, then :func:`~feedtune.identify.rigid.decimate_columns`."""
    from .rigid import decimate_columns

    block, rest = _stages(factor)
    if block > 1:
        n = x.shape[0] // block * block
        x = x[:n].reshape(n // block, block, x.shape[1]).mean(axis=1)
    return decimate_columns(x, rest)


def _stages(factor: int) -> tuple[int, int]:
    """Block length and the Chebyshev decimation factor after it."""
    block = factor // 10 if factor >= 20 else 1
    return block, max(1, round(factor / block))


def _row_instants(n_rows: int, factor: int) -> np.ndarray:
    """Full-rate sample index of each decimated row (the middle of its block)."""
    block, rest = _stages(factor)
    return np.arange(n_rows) * rest * block + block // 2


@dataclass
class _LogRows:
    """One log's full-rate speed and mask per direction, and its decimation (module docstring).

    The law's columns are non-zero only on the unmasked samples of their direction (``where[d]``), so they are
    evaluated there alone and summed into their blocks (``np.bincount``) before the Chebyshev stages."""

    n: int
    where: dict  # direction -> indices of the unmasked samples moving that way
    speed: dict  # direction -> their speeds
    factor: int
    keep: np.ndarray = field(default_factory=lambda: np.ones(0, bool))  # decimated rows kept

    def decimated_values(self, values: list[tuple[str, np.ndarray]]) -> np.ndarray:
        """Columns given by their values on ``where[d]`` (zero elsewhere), decimated, at the kept rows."""
        from .rigid import decimate_columns

        block, rest = _stages(self.factor)
        n_blocks = self.n // block
        out = np.zeros((n_blocks, len(values)))
        for k, (d, vals) in enumerate(values):
            idx = self.where[d]
            if block > 1:
                inside = idx < n_blocks * block
                out[:, k] = np.bincount(idx[inside] // block, weights=vals[inside], minlength=n_blocks) / block
            else:
                out[idx, k] = vals
        return decimate_columns(out, rest)[self.keep]


def _joint_cutoff(log: Log, position: str) -> tuple[float, str]:
    """The automatic cut-off of the joint fit (module docstring, step 1) and how it was chosen."""
    from .rigid import auto_cutoff_hz, position_si, uniform_sample_time

    try:
        cut, how = auto_cutoff_hz(position_si(log, position)[0], uniform_sample_time(log))
    except DataError as exc:
        raise DataError(f"{log.source}: {exc}") from None
    floor = float(f"{min(JOINT_MIN_CUTOFF_HZ, 0.4 * log.fs):.2g}")
    if cut >= floor:
        return cut, how
    return floor, (f"{floor:g} Hz, the joint fit's lowest (the motion's band gives {cut:g} Hz: {how}; the filtered "
                   "velocity must follow the friction's change at reversals)")


def _zoh_centred(u: np.ndarray) -> np.ndarray:
    """A held command at the sample instants: ``(u[k-1] + u[k]) / 2`` (module docstring, step 2)."""
    out = u.copy()
    out[1:] = 0.5 * (u[1:] + u[:-1])
    return out


def _mask(speed: np.ndarray, threshold: float, guard: int) -> np.ndarray:
    """1.0 where the speed reaches ``threshold`` and no slower sample lies within ``guard`` samples, else 0.0."""
    from scipy.ndimage import maximum_filter1d

    slow = (speed < threshold).astype(np.uint8)
    near = maximum_filter1d(slow, size=2 * guard + 1) > 0 if guard > 0 else slow > 0
    return (~near).astype(float)


def _guard_samples(guard_s, cutoff_hz: float, dt: float) -> tuple[float, int]:
    if guard_s is None:
        g = JOINT_GUARD_CUTOFFS / cutoff_hz
    else:
        try:
            g = float(guard_s)
        except (TypeError, ValueError):
            raise UsageError(f"guard_s must be a number of seconds, got {guard_s!r}", parameter="guard_s") from None
        if not (np.isfinite(g) and g >= 0):
            raise UsageError(f"guard_s must be >= 0 s, got {guard_s!r}", parameter="guard_s")
    return g, round(g / dt)


# ------------------------------------------------------------------------------------------- the fit
class _Problem:
    """The decimated rows of every log and the parameter layout of one law (module docstring: the fit).

    Linear parameters: ``M``, then per direction ``dc, ds, Fv`` (``dc, Fv`` for the coulomb-viscous law); then the
    characteristic velocities (one shared, or one per direction).
    """

    def __init__(self, rows: list[_LogRows], fixed: np.ndarray, dirs: list[str], law: str, shared: bool):
        self.rows, self.fixed, self.dirs, self.law, self.shared = rows, fixed, dirs, law, shared
        self.a = fixed[:, 0]
        self.ind = {"pos": fixed[:, 1], "neg": fixed[:, 2]}
        self.vel = {"pos": fixed[:, 3], "neg": fixed[:, 4]}
        self.u = fixed[:, 5]
        self.shaped = law in SHAPED_LAWS
        per = ("dc", "ds", "viscous") if self.shaped else ("dc", "viscous")
        self.names = ["mass"] + [f"{p}_{d}" for d in dirs for p in per]
        self.n_lin = len(self.names)
        if self.shaped:
            self.names += ["omega"] if shared else [f"omega_{d}" for d in dirs]

    def with_law(self, law: str) -> _Problem:
        """The same rows with another law."""
        return _Problem(self.rows, self.fixed, self.dirs, law, self.shared)

    def omega_of(self, theta: np.ndarray) -> dict[str, float]:
        if not self.shaped:
            return {}
        if self.shared:
            return {d: float(theta[self.n_lin]) for d in self.dirs}
        return {d: float(theta[self.n_lin + k]) for k, d in enumerate(self.dirs)}

    def shape_columns(self, omega: dict[str, float], slope: bool = False) -> dict[str, np.ndarray]:
        """Decimated ``phi`` (and ``d phi / d vs``) columns per direction for ``vs`` = ``omega``."""
        return self.shape_columns_many([omega], slope)[0]

    def shape_columns_many(self, omegas: list[dict[str, float]], slope: bool = False) -> list[dict[str, np.ndarray]]:
        """:meth:`shape_columns` for several ``vs`` at once: one decimation of all their columns per log (the
        filter runs along the samples of a 2-D array once instead of once per column)."""
        step = 2 if slope else 1
        per = step * len(self.dirs)
        out = [{d: [] for d in self.dirs} for _ in omegas]
        for r in self.rows:
            cols = []
            for omega in omegas:
                for d in self.dirs:
                    x = r.speed[d] / omega[d]
                    cols.append((d, law_shape(self.law, x)))
                    if slope:
                        cols.append((d, law_shape_slope(self.law, x) * (-x / omega[d])))
            dec = r.decimated_values(cols)
            for i in range(len(omegas)):
                for k, d in enumerate(self.dirs):
                    first = i * per + step * k
                    out[i][d].append(dec[:, first: first + step])
        return [{d: np.vstack(parts) for d, parts in o.items()} for o in out]

    def design(self, shape: dict[str, np.ndarray] | None) -> np.ndarray:
        """The linear columns in the order of ``names[:n_lin]``."""
        cols = [self.a]
        for d in self.dirs:
            if self.shaped:
                phi = shape[d][:, 0]
                cols += [self.ind[d] - phi, phi, self.vel[d]]
            else:
                cols += [self.ind[d], self.vel[d]]
        return np.column_stack(cols)

    def bounds(self, omega_bounds: dict[str, tuple[float, float]]) -> tuple[np.ndarray, np.ndarray]:
        lo, hi = [], []
        for name in self.names:
            if name == "mass" or name.startswith("viscous"):
                lo.append(0.0), hi.append(np.inf)
            elif name.endswith("_pos") and not name.startswith("omega"):
                lo.append(0.0), hi.append(np.inf)
            elif name.endswith("_neg") and not name.startswith("omega"):
                lo.append(-np.inf), hi.append(0.0)
            elif name == "omega":
                lo.append(max(b[0] for b in omega_bounds.values()))
                hi.append(min(b[1] for b in omega_bounds.values()))
            else:
                b = omega_bounds[name.split("_")[1]]
                lo.append(b[0]), hi.append(b[1])
        return np.array(lo), np.array(hi)

    def residual_jacobian(self, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        omega = self.omega_of(theta)
        shape = self.shape_columns(omega, slope=True) if self.shaped else None
        W = self.design(shape)
        res = W @ theta[: self.n_lin] - self.u
        if not self.shaped:
            return res, W
        extra = []
        for d in self.dirs:
            dc, ds = theta[self.names.index(f"dc_{d}")], theta[self.names.index(f"ds_{d}")]
            extra.append((ds - dc) * shape[d][:, 1])
        J_omega = np.column_stack([sum(extra)] if self.shared else extra)
        return res, np.column_stack([W, J_omega])

    def grid(self, omega_bounds, n: int = OMEGA_GRID) -> dict[str, tuple[float, np.ndarray, np.ndarray]]:
        """Best point of a log grid of ``n`` values over ``vs`` (the same relative place in every direction's bounds)
        with the linear parameters unconstrained (``"free"``) and within their bounds (``"bounded"``): its RSS, the
        full parameter vector and the linear design there."""
        from scipy.optimize import lsq_linear

        lo_lin, hi_lin = self.bounds(omega_bounds)
        lo_lin, hi_lin = lo_lin[: self.n_lin], hi_lin[: self.n_lin]
        if self.shaped:
            omegas = []
            for f in np.linspace(0.0, 1.0, n):
                if self.shared:
                    lo = max(b[0] for b in omega_bounds.values())
                    hi = min(b[1] for b in omega_bounds.values())
                    omegas.append({d: lo * (hi / lo) ** f for d in self.dirs})
                else:
                    omegas.append({d: omega_bounds[d][0] * (omega_bounds[d][1] / omega_bounds[d][0]) ** f
                                   for d in self.dirs})
            chunk = max(1, int(2e7 // max(sum(r.n for r in self.rows) * len(self.dirs), 1)))
            shapes = [sh for k in range(0, n, chunk) for sh in self.shape_columns_many(omegas[k: k + chunk])]
        else:
            omegas, shapes = [{}], [None]
        best: dict[str, tuple[float, np.ndarray, np.ndarray]] = {}
        for omega, shape in zip(omegas, shapes, strict=True):
            W = self.design(shape)
            extra = [] if not self.shaped else ([omega[self.dirs[0]]] if self.shared else [omega[d] for d in self.dirs])
            for kind in ("free", "bounded"):
                coef = (np.linalg.lstsq(W, self.u, rcond=None)[0] if kind == "free"
                        else lsq_linear(W, self.u, bounds=(lo_lin, hi_lin), method="bvls").x)
                r = W @ coef - self.u
                rss = float(r @ r)
                if kind not in best or rss < best[kind][0]:
                    best[kind] = (rss, np.concatenate([coef, extra]), W)
        return best


def _solve(problem: _Problem, start: np.ndarray, lower: np.ndarray, upper: np.ndarray):
    from scipy.optimize import least_squares

    cache: dict[bytes, tuple[np.ndarray, np.ndarray]] = {}

    def evaluate(theta):
        key = theta.tobytes()
        if key not in cache:
            cache.clear()
            cache[key] = problem.residual_jacobian(theta)
        return cache[key]

    start = np.clip(start, lower, upper)
    return least_squares(lambda th: evaluate(th)[0], start, jac=lambda th: evaluate(th)[1], bounds=(lower, upper),
                         x_scale="jac", method="trf", xtol=1e-10, ftol=1e-10, gtol=1e-10, max_nfev=200)


def _at_bound(theta: np.ndarray, lower: np.ndarray, upper: np.ndarray, jac: np.ndarray) -> np.ndarray:
    """Parameters on a bound (within a relative 1e-9 of it, or a hundredth of their std scale)."""
    scale = np.linalg.norm(jac, axis=0)
    tol = np.where(scale > 0, 1e-9 * np.abs(theta) + 1e-6 / np.where(scale > 0, scale, 1.0), 1e-12)
    return ((theta - lower) <= tol) | ((upper - theta) <= tol)


@blas_single_threaded
@progress.tasked("fitting the friction (joint fit)")
def fit_joint_friction(log: Log | Sequence[Log], *, position: str, command: str, law: str = "stribeck",
                       command_scale: float = 1.0, command_unit: str | None = None, cutoff_hz: float | None = None,
                       filter_order: int = 4, decimate: int | None = None, min_speed: float | None = None,
                       guard_s: float | None = None, one_direction: bool = False,
                       per_direction_omega: bool = False, compare_laws: bool = True) -> JointFit:
    """Fit mass, viscous friction per direction and a friction law per direction together (module docstring).

    Parameters
    ----------
    log : Log or sequence of Log
        Uniformly sampled tracking log(s) moving at several speeds, with accelerations (both ways for a model).
    position, command : str
        Position column [m or rad; mm, um, deg converted] and command column (times ``command_scale``).
    law : str
        ``"stribeck"`` (eq. 2.1), ``"hump"``, ``"lugre"`` or ``"coulomb-viscous"``.
    command_scale : float
        Multiplies the command (e.g. a drive gain in N/V).
    command_unit : str or None
        Unit of the scaled command (default as in :func:`~feedtune.identify.rigid.fit_rigid`).
    cutoff_hz : float or None
        Position filter cut-off [Hz]; None: the automatic rule (module docstring, step 1), per log.
    filter_order, decimate
        As for :func:`~feedtune.identify.rigid.fit_rigid`.
    min_speed : float or None
        Samples slower than this are masked [velocity unit]; default 2 % of the peak speed.
    guard_s : float or None
        Time masked either side of every slow sample [s]; default ``1 / cutoff_hz``.
    one_direction : bool
        Accept data that move one way (a one-way friction run): the law of that direction, with a warning.
        Without it such data raise :class:`OneDirectionError`.
    per_direction_omega : bool
        One ``vs`` per direction instead of eq. 2.1's shared one.
    compare_laws : bool
        Fit the other laws of the family to the same rows and name one that fits clearly better
        (:data:`LAW_MISMATCH_RSS`).

    Returns
    -------
    JointFit
        The law fit with the mass, the filter settings and the rows used.

    Raises
    ------
    IllConditionedError
        No motion or acceleration, no direction with enough rows, speeds without a range, or a mass that the log
        does not determine.
    DataError
        A mirrored command or an offset larger than the friction (:func:`~feedtune.identify.friction_curve.
        sign_diagnosis`), logs with different units.
    """
    from .rigid import _check_kinematics, _prepare

    law = check_law(law)
    logs = [log] if isinstance(log, Log) else list(log)
    if not logs:
        raise UsageError("fit_joint_friction needs at least one log")
    prepared, rules = [], []
    for lg in logs:
        cut = cutoff_hz
        if cut is None:
            cut, how = _joint_cutoff(lg, position)
            rules.append(f"{cut:g} Hz: {how}")
        smp = _prepare(lg, command, position, cut, filter_order, decimate, command_scale, command_unit)
        _check_kinematics(smp, f"{lg.source}: joint friction fit")
        first = prepared[0] if prepared else smp
        if (smp.position_unit, smp.force_unit) != (first.position_unit, first.force_unit):
            raise DataError(f"{lg.source}: position in {smp.position_unit} and command in {smp.force_unit}, but "
                            f"{logs[0].source} has {first.position_unit} and {first.force_unit}")
        prepared.append(smp)
    first = prepared[0]
    velocity_unit = f"{first.position_unit}/s"
    peak = max(float(np.max(np.abs(s.velocity))) for s in prepared)
    threshold = DEFAULT_MIN_SPEED_FRACTION * peak if min_speed is None else float(min_speed)
    if not (np.isfinite(threshold) and threshold >= 0):
        raise UsageError(f"min_speed must be >= 0 {velocity_unit}, got {min_speed!r}", parameter="min_speed")
    guards = [_guard_samples(guard_s, smp.cutoff_hz, smp.dt) for smp in prepared]
    rows, fixed, centre = zip(*(_log_rows(smp, threshold, n_guard) for smp, (_, n_guard) in
                                zip(prepared, guards, strict=True)), strict=True)
    fixed = np.vstack(fixed)
    coverage = fixed[:, 6]
    vd = np.concatenate(centre)  # the full-rate velocity at each kept row's instant
    counts = {"pos": int(np.count_nonzero(vd >= threshold)), "neg": int(np.count_nonzero(vd <= -threshold))}
    dirs = [d for d in ("pos", "neg") if counts[d] >= MIN_SAMPLES_PER_DIRECTION]
    warnings: list = []
    if not dirs:
        raise IllConditionedError(f"joint friction fit: fewer than {MIN_SAMPLES_PER_DIRECTION} rows move either way "
                                  f"above min_speed = {threshold:.4g} {velocity_unit}", parameter="min_speed")
    if len(dirs) < 2:
        missing = DIRECTION_TEXT["neg" if dirs == ["pos"] else "pos"]
        if not one_direction:
            raise OneDirectionError(f"joint friction fit: too few rows with {missing} above min_speed ({counts}; "
                                    f"need at least {MIN_SAMPLES_PER_DIRECTION}); the log must move in both "
                                    "directions", parameter="min_speed")
        warnings.append(Notice(f"the data move one way only (no rows with {missing} above min_speed): the friction "
                               "law of the other direction is not identified", parameter="min_speed"))
    omega_bounds, speed_range = {}, {}
    for d in dirs:
        sp = np.abs(vd[(vd >= threshold) if d == "pos" else (vd <= -threshold)])
        lo, hi = np.percentile(sp, [2.0, 98.0])
        speed_range[d] = (float(sp.min()), float(sp.max()))
        if law in SHAPED_LAWS and not hi >= 1.5 * lo:
            raise IllConditionedError(
                f"joint friction fit: the speeds with {DIRECTION_TEXT[d]} only span {lo:.4g} to {hi:.4g} "
                f"{velocity_unit}; a {law} law needs a range of speeds (or fit law={COULOMB_VISCOUS!r})")
        omega_bounds[d] = (float(lo / OMEGA_SPEED_LIMITS[0]), float(hi / OMEGA_SPEED_LIMITS[1]))
    shared = not per_direction_omega
    if law in SHAPED_LAWS and shared and (max(b[0] for b in omega_bounds.values())
                                          >= min(b[1] for b in omega_bounds.values())):
        raise IllConditionedError("joint friction fit: the speed ranges of the two directions overlap too little for "
                                  "one shared vs; use per_direction_omega=True")
    problem = _Problem(list(rows), fixed, dirs, law, shared)
    where = "joint friction fit"
    theta, on_bound, std, res = _fit(problem, omega_bounds, first.force_unit, where)
    mass = float(theta[0])
    mass_std = float(std[0])
    if not (mass > 0 and np.isfinite(mass_std) and mass_std <= MAX_MASS_RELATIVE_STD * mass):
        raise IllConditionedError(
            f"joint friction fit: the acceleration carries no usable information (mass = {mass:.4g} +/- "
            f"{mass_std:.2g} {first.force_unit}/({first.position_unit}/s^2)); the log needs clear acceleration "
            "phases")
    law_fit = _law_fit(problem, theta, std, res, vd, omega_bounds, speed_range, first.force_unit, velocity_unit,
                       threshold)
    warnings += bound_warnings(on_bound, first.force_unit, velocity_unit)
    warnings += identifiability_warnings(law_fit)
    warnings += list(law_fit.warnings)
    law_rms = _law_rms(problem, omega_bounds) if compare_laws else {}
    if compare_laws:
        better = [k for k in law_rms if k != law and law_rms[k] ** 2 < LAW_MISMATCH_RSS * law_rms[law] ** 2]
        if better:
            best = min(better, key=law_rms.get)
            warnings.append(f"law mismatch: the {best} law fits these samples with an RMS residual of "
                            f"{law_rms[best]:.4g} {first.force_unit} against the {law} law's {law_rms[law]:.4g} "
                            f"{first.force_unit}: the friction curve has another shape (fit it with law={best!r})")
    # the measured friction u - M a of the rows (the masked share of a row divided out), for plots
    friction = (fixed[:, 5] - mass * fixed[:, 0]) / np.maximum(coverage, 1e-12) * (coverage > 0)
    return JointFit(law_fit=law_fit, cutoff_hz=max(s.cutoff_hz for s in prepared),
                    cutoff_rule="given" if cutoff_hz is not None else "; ".join(dict.fromkeys(rules)),
                    decimate=max(s.decimate for s in prepared), guard_s=max(g for g, _ in guards), min_speed=threshold,
                    n_samples=int(vd.size), force_unit=first.force_unit, position_unit=first.position_unit,
                    warnings=tuple(dict.fromkeys(warnings)),
                    points=tuple(bin_by_speed(vd, friction, min_speed=threshold)), on_bound=on_bound,
                    law_rms=law_rms)


def _log_rows(smp, threshold: float, n_guard: int) -> tuple[_LogRows, np.ndarray, np.ndarray]:
    """One log's rows (module docstring, steps 2-4): its :class:`_LogRows`, the decimated fixed columns ``a, I+, I-,
    v I+, v I-, u, coverage`` of the kept rows, and the full-rate velocity at each kept row's instant."""
    v = smp.velocity
    ind = {"pos": (v > 0).astype(float), "neg": (v < 0).astype(float)}
    weight = _mask(np.abs(v), threshold, n_guard)
    where = {d: np.flatnonzero(weight * ind[d]) for d in ind}
    r = _LogRows(v.size, where, {d: np.abs(v[idx]) for d, idx in where.items()}, smp.decimate)
    dec = _parallel_decimation(np.column_stack([smp.acceleration, ind["pos"], ind["neg"], v * ind["pos"],
                                                v * ind["neg"], _zoh_centred(smp.force), weight]) * weight[:, None],
                               smp.decimate)
    ones = _parallel_decimation(np.ones((v.size, 1)), smp.decimate)[:, 0]
    r.keep = dec[:, 6] >= 0.5 * ones
    instants = np.minimum(_row_instants(dec.shape[0], smp.decimate), v.size - 1)
    return r, dec[r.keep], v[instants][r.keep]


def _fit(problem: _Problem, omega_bounds: dict, unit: str, where: str):
    """Unconstrained grid fit (read by :func:`sign_diagnosis`), then the bounded fit; parameters, those on their
    bounds (with the unconstrained values), std (NaN on a bound) and residuals."""
    grid = problem.grid(omega_bounds)
    rss_u, theta_u, W_u = grid["free"]
    n = problem.u.size
    std_u = parameter_std(W_u, rss_u / max(n - W_u.shape[1], 1))
    free_u = dict(zip(problem.names, zip(theta_u, np.concatenate([std_u, np.full(theta_u.size - std_u.size,
                                                                                   np.nan)]), strict=True),
                      strict=True))
    sign_diagnosis({k: free_u[k] for k in (f"dc_{d}" for d in problem.dirs)}, unit, where,
                   mass=free_u["mass"])
    start = grid["bounded"][1]
    lower, upper = problem.bounds(omega_bounds)
    sol = _solve(problem, start, lower, upper)
    theta, res, jac = sol.x, sol.fun, sol.jac
    bound = _at_bound(theta, lower, upper, jac)
    lin_bound = bound.copy()
    lin_bound[problem.n_lin:] = False  # a vs on its bound is reported by the law fit
    nearer_lower = theta - lower <= upper - theta
    theta = np.where(lin_bound, np.where(nearer_lower, lower, upper), theta)  # exactly on it (trf stays inside)
    free = ~lin_bound
    s2 = float(res @ res) / max(n - int(np.count_nonzero(free)), 1)
    std = np.full(theta.size, np.nan)
    std[free] = parameter_std(jac[:, free], s2)
    on_bound = {name: {"bound": float(lower[k] if theta[k] - lower[k] <= upper[k] - theta[k] else upper[k]),
                       "unconstrained": float(free_u[name][0]), "std": _finite(free_u[name][1])}
                for k, name in enumerate(problem.names) if lin_bound[k]}
    return theta, on_bound, std, res


def _finite(x: float) -> float | None:
    return float(x) if np.isfinite(x) else None


def _law_fit(problem: _Problem, theta, std, res, vd, omega_bounds, speed_range, command_unit, velocity_unit,
             threshold) -> FrictionLawFit:
    """The :class:`FrictionLawFit` of the joint parameters (directions with their std, rms per direction)."""
    names = problem.names
    value = dict(zip(names, theta, strict=True))
    sd = dict(zip(names, std, strict=True))
    omega = problem.omega_of(theta)
    dirs, warnings = {}, []
    for d in problem.dirs:
        sel = (vd >= threshold) if d == "pos" else (vd <= -threshold)
        o_name = "omega" if problem.shared else f"omega_{d}"
        shaped = problem.shaped
        fit = DirectionFit(
            direction=d, dc=float(value[f"dc_{d}"]), ds=float(value[f"ds_{d}"] if shaped else value[f"dc_{d}"]),
            omega=float(omega[d]) if shaped else float("nan"), viscous=float(value[f"viscous_{d}"]),
            std={"dc": float(sd[f"dc_{d}"]), **({"ds": float(sd[f"ds_{d}"]), "omega": float(sd[o_name])}
                                                  if shaped else {}), "viscous": float(sd[f"viscous_{d}"])},
            n=int(np.count_nonzero(sel)), rms_error=float(np.sqrt(np.mean(res[sel] ** 2))) if np.any(sel) else 0.0,
            speed_range=speed_range[d],
            omega_bounds=omega_bounds[d] if shaped and not problem.shared else
            ((max(b[0] for b in omega_bounds.values()), min(b[1] for b in omega_bounds.values())) if shaped
             else (float("nan"), float("nan"))))
        dirs[d] = fit
        if fit.omega_at_bound:
            warnings.append(f"vs for {DIRECTION_TEXT[d]} ended on its bound ({fit.omega:.4g} {velocity_unit}): the "
                            "samples do not resolve it (move slowly through the low speeds)")
    return FrictionLawFit(law=problem.law, directions=dirs, mass=float(theta[0]), mass_std=_finite(sd["mass"]),
                          rms_error=float(np.sqrt(np.mean(res**2))),
                          relative_error_pct=float(100.0 * np.linalg.norm(res) / max(np.linalg.norm(problem.u),
                                                                                     1e-300)),
                          command_unit=command_unit, velocity_unit=velocity_unit, warnings=tuple(warnings))


def bound_warnings(on_bound: dict, unit: str, velocity_unit: str) -> list[str]:
    """One line per parameter that ended on its bound, with its unconstrained value."""
    out = []
    for name, b in on_bound.items():
        u = f"{unit}/({velocity_unit})" if name.startswith("viscous") else unit
        sd = "" if b["std"] is None else f" +/- {b['std']:.2g}"
        out.append(f"{name} ended on its bound {b['bound']:g} {u} (unconstrained {b['unconstrained']:.4g}{sd} {u}): "
                   "the data do not identify it; it is held at the bound")
    return out


def _law_rms(problem: _Problem, omega_bounds: dict) -> dict[str, float]:
    """RMS residual of the fitted law and of the other laws with a static level on the same rows, each at the best
    point of the same bounded grid of :data:`COMPARE_GRID` values of ``vs`` (the comparison is fair: no law is
    refined further than the others) [command unit]."""
    n = max(problem.u.size, 1)
    family = [problem.law] + [k for k in LAWS if k != problem.law and k in SHAPED_LAWS]
    return {k: float(np.sqrt(problem.with_law(k).grid(omega_bounds, COMPARE_GRID)["bounded"][0] / n)) for k in family}
