"""Drift of an axis' identified parameters: a trend with its uncertainty, and an alarm when a parameter moves beyond
its noise.

The noise of one measurement of a parameter has two parts: the fit's standard deviation ``s_i`` (from its Jacobian,
in the history) and the scatter ``tau`` between repeated measurements of an unchanged axis (temperature, table
position, preload warm-up, excitation level), which no single fit sees. ``tau`` is estimated from the fleet
(:func:`pooled_scatter`): every axis' residuals about its own straight line, relative to its level, corrected for
leverage and pooled over the axes by the median absolute deviation (robust to the few axes that drift), less the
fits' own share. The variance of measurement ``i`` is then ``sigma_i^2 = s_i^2 + (tau level)^2``.

**Alarm: a self-starting CUSUM** (Hawkins 1987; Montgomery, *Introduction to Statistical Quality Control*, 9.1).
Each measurement after the first :data:`DriftSettings.baseline` is standardised against the weighted mean of all
earlier ones, ``z_i = (y_i - mean_{j<i} y_j) / sqrt(sigma_i^2 + var(mean))``; without a change the ``z_i`` are
independent standard normal whatever the axis' own level, so one threshold serves every axis and parameter. The
two one-sided sums ``S+_i = max(0, S+_{i-1} + z_i - kappa)`` and ``S-`` accumulate evidence of a rise or a fall; the
alarm fires when either passes ``h``. ``kappa`` = 0.75 makes it quickest for a shift of 1.5 noise standard
deviations; ``h`` is set by simulation (:func:`cusum_threshold`) so that an unchanged parameter alarms with
probability :data:`DriftSettings.false_alarm` within :data:`DriftSettings.horizon` measurements (a year of weekly
ones). Why a CUSUM rather than a test on the slope of all the history: a drift that starts in the middle of the
record is diluted by the flat part before it in a straight-line fit, while the CUSUM accumulates only what has
changed since, is the optimal detector of a change of a given size (Lorden, Moustakides), and tells where the change
began: the last measurement where the alarming sum was zero.

**Trend**: weighted least squares of the parameter on time (weights ``1 / sigma_i^2``) over the measurements since
that change began (all of them when no alarm fired): the level at the newest measurement, the slope per week, their
covariance (inflated by the reduced chi-square when the residuals exceed the noise), and so the line's standard
deviation at any time (:meth:`Trend.at`), from which the forecast takes its interval.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, field

import numpy as np

WEEK_S = 7 * 86400.0

ALARM_PARAMETERS = ("m1", "m2", "k", "c", "coulomb", "viscous")
"""Parameters that raise alarms: the 2-mass model's inertias, stiffness and nut damping, and the friction fit's
Coulomb and viscous levels (b1, b2, the delay and the offset are trended but not alarmed: rarely determined by the
band, or not a property of the axis)."""
TRENDED_PARAMETERS = ("m1", "m2", "b1", "b2", "k", "c", "mode_hz", "delay_s", "mass", "viscous", "coulomb", "offset")
"""Parameters whose trend is computed (those of :data:`ALARM_PARAMETERS` and the ones shown only)."""
POORLY_DETERMINED = 0.5
"""A parameter whose fits' median relative standard deviation exceeds this is not alarmed on (b1, b2 on a band that
starts far above the real pole)."""


@dataclass(frozen=True)
class DriftSettings:
    """How drift is judged (module docstring).

    Attributes
    ----------
    baseline : int
        Measurements before the first test [-] (at least 2).
    kappa : float
        CUSUM allowance [noise standard deviations].
    false_alarm : float
        Probability that an unchanged parameter alarms within ``horizon`` measurements [-].
    horizon : int
        Measurements the false-alarm probability is counted over.
    """

    baseline: int = 3
    kappa: float = 0.75
    false_alarm: float = 0.0017
    horizon: int = 52

    def __post_init__(self) -> None:
        from ..errors import UsageError

        if not (isinstance(self.baseline, int) and self.baseline >= 2):
            raise UsageError(f"baseline must be a whole number >= 2, got {self.baseline!r}", parameter="baseline")
        if not (0 < self.false_alarm < 0.5):
            raise UsageError(f"false_alarm must be in (0, 0.5), got {self.false_alarm!r}", parameter="false_alarm")
        if not (self.kappa >= 0 and np.isfinite(self.kappa)):
            raise UsageError(f"kappa must be >= 0, got {self.kappa!r}", parameter="kappa")
        if not (isinstance(self.horizon, int) and self.horizon >= 1):
            raise UsageError(f"horizon must be a whole number >= 1, got {self.horizon!r}", parameter="horizon")

    @property
    def threshold(self) -> float:
        """The CUSUM threshold ``h`` of these settings."""
        return cusum_threshold(self.kappa, self.false_alarm, self.horizon)

    def to_dict(self) -> dict:
        """JSON-ready (with the threshold)."""
        return {"baseline": self.baseline, "kappa": self.kappa, "false_alarm": self.false_alarm,
                "horizon": self.horizon, "threshold": self.threshold}


@functools.lru_cache(maxsize=16)
def cusum_threshold(kappa: float, false_alarm: float, horizon: int, runs: int = 200_000, seed: int = 29) -> float:
    """``h`` such that a two-sided CUSUM with allowance ``kappa`` on independent standard normal ``z`` exceeds it
    within ``horizon`` steps with probability ``false_alarm`` (Monte Carlo, ``runs`` paths, fixed seed)."""
    rng = np.random.default_rng(seed)
    peak = np.zeros(runs)
    up = np.zeros(runs)
    down = np.zeros(runs)
    for _ in range(horizon):
        z = rng.standard_normal(runs)
        up = np.maximum(0.0, up + z - kappa)
        down = np.maximum(0.0, down - z - kappa)
        np.maximum(peak, np.maximum(up, down), out=peak)
    return float(np.quantile(peak, 1.0 - false_alarm))


@dataclass(frozen=True)
class Trend:
    """A parameter of one axis over time (module docstring).

    Attributes
    ----------
    name : str
    weeks : ndarray
        Times of the measurements [weeks since the axis' first].
    values, std : ndarray
        The fitted values and the fits' standard deviations (parameter unit).
    sigma : ndarray
        The noise of each measurement: fit and scatter between measurements.
    scatter : float
        The scatter between measurements ``tau level`` (parameter unit).
    since : int
        First measurement of the fitted line (where the change began; 0 without an alarm).
    level, level_std : float
        The line at the newest measurement and its standard deviation.
    slope, slope_std : float
        Per week.
    cov : float
        Covariance of level and slope.
    statistic : ndarray
        ``max(S+, S-)`` after each measurement (NaN before the baseline).
    threshold : float
    alarm_index : int or None
        The measurement at which the alarm fired.
    direction : int
        +1 a rise, -1 a fall, 0 no alarm.
    baseline, baseline_std : float
        Mean of the measurements before the change (all but the newest without an alarm).
    determined : bool
        Well determined by the fits (median relative std at most :data:`POORLY_DETERMINED`).
    alarmable : bool
        One of :data:`ALARM_PARAMETERS` and determined.
    """

    name: str
    weeks: np.ndarray
    values: np.ndarray
    std: np.ndarray
    sigma: np.ndarray
    scatter: float
    since: int
    level: float
    level_std: float
    slope: float
    slope_std: float
    cov: float
    statistic: np.ndarray
    threshold: float
    alarm_index: int | None
    direction: int
    baseline: float
    baseline_std: float
    determined: bool
    alarmable: bool
    notes: tuple[str, ...] = field(default_factory=tuple)

    @property
    def alarm(self) -> bool:
        """The parameter moved beyond its noise."""
        return self.alarm_index is not None

    @property
    def newest_week(self) -> float:
        """Time of the newest measurement [weeks since the first]."""
        return float(self.weeks[-1])

    def at(self, weeks_ahead) -> tuple[np.ndarray, np.ndarray]:
        """The line and its standard deviation ``weeks_ahead`` after the newest measurement."""
        d = np.asarray(weeks_ahead, float)
        var = self.level_std**2 + d**2 * self.slope_std**2 + 2 * d * self.cov
        return self.level + self.slope * d, np.sqrt(np.maximum(var, 0.0))

    @property
    def mean(self) -> float:
        """Weighted mean of every measurement (``1 / sigma^2``): the best level of a parameter that does not drift."""
        w = 1.0 / self.sigma**2
        return float((w * self.values).sum() / w.sum()) if self.values.size else float("nan")

    @property
    def change(self) -> float:
        """Relative change of the level since the baseline [-] (NaN when the baseline is 0)."""
        return (self.level - self.baseline) / abs(self.baseline) if self.baseline else float("nan")

    @property
    def slope_relative(self) -> float:
        """Slope relative to the baseline [1/week]."""
        return self.slope / abs(self.baseline) if self.baseline else float("nan")

    def to_dict(self, series: bool = True) -> dict:
        """JSON-ready summary; ``series``: with the measurements and the CUSUM after each."""
        def num(v):
            v = float(v)
            return v if np.isfinite(v) else None

        out = {"name": self.name, "alarm": self.alarm, "alarmable": self.alarmable, "determined": self.determined,
                "direction": {1: "rise", -1: "fall", 0: None}[self.direction],
                "alarm_index": self.alarm_index, "since_index": self.since,
                "level": num(self.level), "level_std": num(self.level_std), "slope_per_week": num(self.slope),
                "slope_std_per_week": num(self.slope_std), "slope_pct_per_week": num(100 * self.slope_relative),
                "baseline": num(self.baseline), "baseline_std": num(self.baseline_std),
                "change_pct": num(100 * self.change), "scatter": num(self.scatter), "threshold": num(self.threshold),
                "measurements": int(self.values.size), "notes": list(self.notes)}
        if series:
            out.update({"weeks": [float(w) for w in self.weeks], "values": [num(v) for v in self.values],
                        "std": [num(s) for s in self.std], "statistic": [num(s) for s in self.statistic]})
        return out


# ------------------------------------------------------------------------------------------ the scatter
def _line_residuals(t: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Residuals of an unweighted straight line, divided by ``sqrt(1 - leverage)`` (unit variance for unit noise)."""
    X = np.column_stack([np.ones_like(t), t - t.mean()])
    beta, *_ = np.linalg.lstsq(X, y, rcond=None)
    h = np.einsum("ij,jk,ik->i", X, np.linalg.pinv(X.T @ X), X)
    return (y - X @ beta) / np.sqrt(np.maximum(1.0 - h, 1e-12))


def pooled_scatter(series: list[tuple[np.ndarray, np.ndarray, np.ndarray]]) -> tuple[float, int]:
    """The relative scatter ``tau`` between measurements of a parameter over a fleet (module docstring).

    Parameters
    ----------
    series : list of (weeks, values, std)
        One entry per axis (finite values only).

    Returns
    -------
    (float, int)
        ``tau`` [-] and the residuals it rests on (0: none, ``tau`` = 0).
    """
    resid, fit_var = [], []
    for t, y, s in series:
        if y.size < 3:
            continue
        level = np.median(np.abs(y))
        if not level > 0:
            continue
        resid.append(_line_residuals(t, y / level))
        fit_var.append((s / level) ** 2)
    if not resid:
        return 0.0, 0
    r = np.concatenate(resid)
    total = (1.4826 * np.median(np.abs(r - np.median(r)))) ** 2
    return float(np.sqrt(max(total - float(np.median(np.concatenate(fit_var))), 0.0))), int(r.size)


# ------------------------------------------------------------------------------------------ one parameter
def _wls_line(t: np.ndarray, y: np.ndarray, sigma: np.ndarray, t0: float) -> tuple[float, float, np.ndarray]:
    """Level at ``t0``, slope, and their covariance (inflated by the reduced chi-square when it exceeds 1)."""
    w = 1.0 / sigma**2
    if t.size == 1 or np.ptp(t) == 0:
        var = 1.0 / w.sum()
        return float((w * y).sum() * var), 0.0, np.array([[var, 0.0], [0.0, np.inf]])
    X = np.column_stack([np.ones_like(t), t - t0])
    A = X.T @ (w[:, None] * X)
    cov = np.linalg.inv(A)
    beta = cov @ (X.T @ (w * y))
    dof = t.size - 2
    if dof >= 2:
        chi2 = float((w * (y - X @ beta) ** 2).sum()) / dof
        cov = cov * max(chi2, 1.0)
    return float(beta[0]), float(beta[1]), cov


def trend(name: str, weeks, values, std, tau: float, settings: DriftSettings | None = None) -> Trend:
    """The trend and alarm of one parameter of one axis (module docstring).

    Parameters
    ----------
    name : str
    weeks, values, std : array_like
        Times [weeks], fitted values and the fits' standard deviations, oldest first; non-finite entries (failed
        fits) are dropped.
    tau : float
        Relative scatter between measurements [-] (:func:`pooled_scatter`).
    settings : DriftSettings, optional
    """
    settings = settings or DriftSettings()
    t = np.asarray(weeks, float)
    y = np.asarray(values, float)
    s = np.asarray(std, float)
    s = np.where(np.isfinite(s) & (s >= 0), s, 0.0)
    keep = np.isfinite(t) & np.isfinite(y)
    t, y, s = t[keep], y[keep], s[keep]
    notes = []
    level0 = float(np.median(np.abs(y))) if y.size else 0.0
    rel = s / level0 if level0 > 0 else np.full_like(s, np.inf)
    determined = bool(y.size and np.median(rel) <= POORLY_DETERMINED)
    scatter = tau * level0
    sigma = np.sqrt(s**2 + scatter**2)
    floor = max(1e-12 * level0, 1e-300)
    if np.any(sigma <= floor):
        notes.append("no noise estimate for some measurements (fit std and scatter are 0): a floor is used")
        sigma = np.maximum(sigma, max(1e-6 * level0, floor))
    h = settings.threshold
    stat = np.full(y.size, np.nan)
    alarm_index, direction, since = None, 0, 0
    up = down = 0.0
    zero_up = zero_down = settings.baseline - 1
    for i in range(settings.baseline, y.size):
        w = 1.0 / sigma[:i] ** 2
        mean = float((w * y[:i]).sum() / w.sum())
        z = (y[i] - mean) / np.sqrt(sigma[i] ** 2 + 1.0 / w.sum())
        up, down = max(0.0, up + z - settings.kappa), max(0.0, down - z - settings.kappa)
        if up == 0.0:
            zero_up = i
        if down == 0.0:
            zero_down = i
        stat[i] = max(up, down)
        if alarm_index is None and stat[i] > h:
            alarm_index, direction = i, (1 if up >= down else -1)
            since = zero_up if direction > 0 else zero_down
    if y.size <= settings.baseline:
        notes.append(f"{y.size} measurement(s): no alarm before {settings.baseline + 1}")
    baseline_part = slice(0, since + 1) if alarm_index is not None else slice(0, max(y.size - 1, 1))
    wb = 1.0 / sigma[baseline_part] ** 2
    baseline = float((wb * y[baseline_part]).sum() / wb.sum()) if y.size else float("nan")
    baseline_std = float(np.sqrt(1.0 / wb.sum())) if y.size else float("nan")
    seg = slice(since, None)
    if y.size:
        level, slope, cov = _wls_line(t[seg], y[seg], sigma[seg], float(t[-1]))
    else:
        level, slope, cov = float("nan"), float("nan"), np.full((2, 2), np.nan)
    return Trend(name, t, y, s, sigma, float(scatter), int(since), level, float(np.sqrt(cov[0, 0])), slope,
                 float(np.sqrt(cov[1, 1])), float(cov[0, 1]) if np.isfinite(cov[0, 1]) else 0.0, stat, h,
                 alarm_index, direction, baseline, baseline_std, determined,
                 bool(name in ALARM_PARAMETERS and determined), tuple(notes))


def alarm_of(tr: Trend) -> bool:
    """An alarm that counts: the parameter is alarmable and its CUSUM passed the threshold."""
    return tr.alarmable and tr.alarm
