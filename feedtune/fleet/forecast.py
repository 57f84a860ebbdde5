"""When will the installed gains fail their limits? The identified drift carried forward and certified.

The forecast plant at a future time is the measured FRF carried there by the model: each channel (``x1/u``,
``x2/u``) of each of the last :data:`RECENT` measurements multiplied by the ratio of the 2-mass model with the
parameters the trends predict (the drifting ones extrapolated along their lines, the others held at their weighted
mean over the measurements: one fit's noise, 10 % on the nut damping, would otherwise move the mode's peak) to the
model of that measurement's own fit, and the carried responses averaged (when the measurements share their
frequency lines; else the newest alone). So everything the 2-mass model does not describe and the installed gains
depend on (torsional modes, the current loop, delays) stays as measured, the axial mode moves as the drift says, and
the measurement noise, which would otherwise decide a margin read at one noisy line, is averaged down. The installed
gains are certified on it with the axis' limits, exactly as a measurement would be
(:func:`feedtune.machines.certificate.certify`: Ms, phase, gain and disk margins, stability, in the discrete case).

The first failing time is found on a grid of weeks ahead (:data:`GRID_WEEKS`, up to the horizon) and refined by
bisection to :data:`TOLERANCE_WEEKS`; it assumes the margins erode monotonically along the drift between grid
points. The interval comes from the trends' uncertainty: the early bound is the first failure when every drifting
parameter runs ahead of its line by ``z`` standard deviations of the line (:meth:`feedtune.fleet.drift.Trend.at`,
in the direction it drifts), the late bound when each lags behind by as much; with one drifting parameter this is the
classical inverse-regression (calibration) interval of the time its line reaches the failing value. To it the noise
of the measured margins is added in quadrature (:func:`margin_weeks_std`: how much the failing limit's slack varies
between the measurements averaged, over how fast it erodes). ``z`` = 1.645: a 90 % two-sided interval. A late bound
beyond the horizon is open (``None``).
"""

from __future__ import annotations

import datetime as _dt
from dataclasses import dataclass, field, replace

import numpy as np

from .snapshot import Snapshot, model_of

GRID_WEEKS = (0.0, 1.0, 2.0, 3.0, 4.0, 6.0, 8.0, 10.0, 13.0, 17.0, 21.0, 26.0, 34.0, 43.0, 52.0)
"""Weeks ahead of the newest measurement where the forecast plant is certified before refining."""
TOLERANCE_WEEKS = 0.05
RECENT = 12
"""Measurements whose carried FRFs are averaged into the forecast plant: a margin read on one FRF with 2 % noise
comes out about 0.5 dB low at a phase crossover (the noise makes extra crossings), on the mean of 12 about 0.1 dB
(the simulated fleet, noise-free plant as reference)."""
INTERVAL_Z = 1.645
"""Normal quantile of the interval (90 % two-sided)."""
FLOOR = 0.05
"""A positive parameter extrapolated below this fraction of its newest fit is held there (a model must stay
physical); the forecast then says so."""


@dataclass(frozen=True)
class DriftLine:
    """A drifting parameter's line (:class:`feedtune.fleet.drift.Trend`), as the forecast task needs it."""

    name: str
    level: float
    slope: float
    level_std: float
    slope_std: float
    cov: float

    def at(self, weeks: float, shift: float = 0.0) -> float:
        """The line ``weeks`` after the newest measurement, moved by ``shift`` of its standard deviations in the
        direction it drifts."""
        sd = np.sqrt(max(self.level_std**2 + weeks**2 * self.slope_std**2 + 2 * weeks * self.cov, 0.0))
        return self.level + self.slope * weeks + shift * np.sign(self.slope) * sd


@dataclass(frozen=True)
class ForecastTask:
    """What one axis' forecast needs (picklable).

    Attributes
    ----------
    axis : Snapshot
        The installed gains, the limits and the newest measurement with its fit.
    lines : tuple of DriftLine
        The drifting model parameters.
    horizon_weeks : float
    recent : tuple of (tuple of str, dict)
        Earlier measurements (oldest first) averaged with the newest: their FRF files and fits.
    held : dict
        The model parameters that do not drift, at their mean over the measurements (default: the newest fit).
    """

    axis: Snapshot
    lines: tuple[DriftLine, ...]
    horizon_weeks: float = 52.0
    recent: tuple = ()
    held: dict = field(default_factory=dict)

    @property
    def axis_id(self) -> str:
        """The axis (``machine/axis``)."""
        return self.axis.axis_id


@dataclass(frozen=True)
class Forecast:
    """The forecast of one axis (module docstring).

    Attributes
    ----------
    weeks : float or None
        Weeks after the newest measurement when the installed gains first fail (0: already on the forecast plant);
        None: not within the horizon.
    early, late : float or None
        The interval [weeks]; ``late`` None: beyond the horizon.
    limit : str or None
        The limit that fails first (``ms``, ``pm_deg``, ``gm_db``, ``disk_margin``, ``stable``, ``band_top``).
    violation : str or None
        Its message at the failure.
    newest : datetime.datetime
    parameters : tuple of str
        The drifting parameters extrapolated.
    horizon_weeks : float
    evaluations : int
        Certificates computed.
    notes : tuple of str
    now : dict
        The forecast plant's certificate now (the trends' level): ``ok``, ``ms``, ``pm_deg``, ``gm_db``,
        ``disk_margin``, ``active_limit``.
    """

    weeks: float | None
    early: float | None
    late: float | None
    limit: str | None
    violation: str | None
    newest: _dt.datetime
    parameters: tuple[str, ...]
    horizon_weeks: float
    evaluations: int
    notes: tuple[str, ...] = ()
    now: dict = field(default_factory=dict)

    def date(self, weeks: float | None) -> _dt.date | None:
        """The calendar date ``weeks`` after the newest measurement."""
        if weeks is None:
            return None
        return (self.newest + _dt.timedelta(days=7.0 * weeks)).date()

    def to_dict(self) -> dict:
        """JSON-ready."""
        def iso(w):
            d = self.date(w)
            return None if d is None else d.isoformat()

        return {"weeks_ahead": self.weeks, "interval_weeks": [self.early, self.late], "date": iso(self.weeks),
                "interval_dates": [iso(self.early), iso(self.late)], "limit": self.limit, "violation": self.violation,
                "parameters": list(self.parameters), "horizon_weeks": self.horizon_weeks,
                "evaluations": self.evaluations, "now": self.now, "notes": list(self.notes)}


# ------------------------------------------------------------------------------------------ the forecast plant
def carried_frf(frf, fit_model, future_model):
    """``frf`` with ``x1/u`` and ``x2/u`` multiplied by ``future_model / fit_model`` (module docstring)."""
    f = frf.freq_hz
    old = fit_model.frequency_response(f, keys=("G11", "G21"))
    new = future_model.frequency_response(f, keys=("G11", "G21"))
    response = frf.response.copy()
    for channel, key in (("x1/u", "G11"), ("x2/u", "G21")):
        if frf.has(channel):
            i, j = frf.index(channel)
            with np.errstate(divide="ignore", invalid="ignore"):
                ratio = np.where(old[key] != 0, new[key] / old[key], 1.0)
            response[i, j] = response[i, j] * ratio
    return replace(frf, response=response, meta={**frf.meta, "source": f"{frf.source} (forecast)"})


def _same_lines(a, b) -> bool:
    return a.freq_hz.shape == b.freq_hz.shape and np.array_equal(a.freq_hz, b.freq_hz) and a.channels == b.channels \
        and a.quantity == b.quantity


def _mean_frf(frfs: list):
    """The complex mean of FRFs on the same lines (coherence averaged too); the FRF itself when alone."""
    if len(frfs) == 1:
        return frfs[0]
    response = np.mean([f.response for f in frfs], axis=0)
    coh = None if any(f.coherence is None for f in frfs) else np.mean([f.coherence for f in frfs], axis=0)
    return replace(frfs[0], response=response, coherence=coh)


class _Plant:
    """Certifies the installed gains on the forecast plant of given parameter values."""

    def __init__(self, task: ForecastTask):
        from ..io import read_document

        self.task = task
        axis = task.axis
        self.doc = read_document(axis.gains)
        self.fit_model = model_of(axis.fit)
        newest = axis.read_frfs()
        self.sources = [(newest, self.fit_model)]
        for paths, fit in task.recent:
            frfs = axis.read_frfs(paths)
            if len(frfs) == len(newest) and all(_same_lines(a, b) for a, b in zip(frfs, newest, strict=True)):
                self.sources.append((frfs, model_of(fit)))
        self.evaluations = 0
        self.clipped = False

    def values(self, weeks: float, shift: float) -> dict:
        out = dict(self.task.held)
        for line in self.task.lines:
            v = line.at(weeks, shift)
            low = FLOOR * float(self.task.axis.fit[line.name]) if line.name in ("m1", "m2", "k") else 0.0
            if v < low:
                v, self.clipped = low, True
            out[line.name] = v
        return out

    def certify(self, weeks: float, shift: float, only: int | None = None):
        """The certificate on the forecast plant (``only``: on the carried FRFs of that measurement alone)."""
        from ..machines.certificate import certify

        self.evaluations += 1
        axis = self.task.axis
        model = model_of(axis.fit, self.values(weeks, shift))
        sources = self.sources if only is None else [self.sources[only]]
        frfs = []
        for i, name in enumerate(axis.frf_names):
            carried = [carried_frf(frfs[i], fit_model, model) for frfs, fit_model in sources]
            frfs.append((f"{name} + {weeks:.2f} weeks", _mean_frf(carried)))
        return certify(self.doc, axis.gains_name, frfs, axis.limits)

    def first_failure(self, shift: float, horizon: float):
        """``(weeks, certificate)`` of the first failure along the path ``shift``, or ``(None, None)``."""
        grid = [w for w in GRID_WEEKS if w < horizon] + [horizon]
        prev = None
        for w in grid:
            cert = self.certify(w, shift)
            if not cert.ok:
                if prev is None:
                    return 0.0, cert
                lo, hi, bad = prev, w, cert
                while hi - lo > TOLERANCE_WEEKS:
                    mid = 0.5 * (lo + hi)
                    c = self.certify(mid, shift)
                    if c.ok:
                        lo = mid
                    else:
                        hi, bad = mid, c
                return hi, bad
            prev = w
        return None, None


def _slack(cert, limit: str) -> float | None:
    """The smallest slack of a limit over a certificate's FRFs."""
    values = [i.slack for c in cert.frfs for i in c.check.items if i.name == limit and i.slack is not None]
    return min(values) if values else None


def margin_weeks_std(plant: _Plant, weeks: float, limit: str | None) -> float | None:
    """The standard deviation [weeks] the measurement noise gives the failing time: the slack of the failing limit at
    ``weeks`` on each measurement's carried FRFs alone, its standard error over them, divided by how fast the mean
    plant's slack erodes per week there. None with fewer than 3 measurements or a margin that does not erode."""
    n = len(plant.sources)
    if limit is None or n < 3:
        return None
    each = [_slack(plant.certify(weeks, 0.0, only=j), limit) for j in range(n)]
    if any(v is None for v in each):
        return None
    before, at = max(weeks - 1.0, 0.0), max(weeks, 1.0)
    s0, s1 = _slack(plant.certify(before, 0.0), limit), _slack(plant.certify(at, 0.0), limit)
    if s0 is None or s1 is None or not s1 < s0:
        return None
    return float(np.std(each, ddof=1) / np.sqrt(n) / ((s0 - s1) / (at - before)))


def forecast_axis(task: ForecastTask) -> Forecast:
    """The forecast of one axis (module docstring); runs in a worker (:func:`run_forecast`)."""
    plant = _Plant(task)
    horizon = float(task.horizon_weeks)
    now = plant.certify(0.0, 0.0)
    from .task import certificate_columns

    cols = certificate_columns(now)
    now_dict = {k: cols[k] for k in ("cert_ok", "ms", "pm_deg", "gm_db", "disk_margin", "active_limit")}
    weeks, cert = (0.0, now) if not now.ok else plant.first_failure(0.0, horizon)
    early, _ = plant.first_failure(INTERVAL_Z, horizon)
    late, _ = plant.first_failure(-INTERVAL_Z, horizon)
    limit = violation = None
    if cert is not None:
        failed = [i for c in cert.frfs for i in c.check.items if not i.ok]
        worst = min(failed, key=lambda i: i.slack if i.slack is not None else -np.inf) if failed else None
        limit = None if worst is None else worst.name
        violation = next((v for c in cert.frfs for v in c.check.violations), None)
    if weeks is not None and early is not None:
        early = min(early, weeks)
    if weeks is not None and late is not None:
        late = max(late, weeks)
    notes = [f"forecast plant: the mean of {len(plant.sources)} measured FRFs carried forward"]
    spread = margin_weeks_std(plant, weeks, limit) if weeks is not None and weeks > 0 else None
    if spread is not None:  # the noise of the measured margins, with the trend's uncertainty (quadrature)
        z = INTERVAL_Z * spread
        early = max(weeks - float(np.hypot(weeks - (weeks if early is None else early), z)), 0.0)
        late = None if late is None else weeks + float(np.hypot(late - weeks, z))
        notes.append(f"the measured margins' noise adds {spread:.2g} weeks (1 sigma) to the failing time")
    if plant.clipped:
        notes.append(f"a parameter's line reaches {FLOOR:.0%} of its newest fit within the horizon; it is held there")
    return Forecast(weeks, early, late, limit, violation, task.axis.date, tuple(ln.name for ln in task.lines), horizon,
                    plant.evaluations, tuple(notes), now_dict)


def run_forecast(task: ForecastTask):
    """:func:`forecast_axis` under the worker settings; a failure is returned as its message (one line)."""
    from .task import _one_line, worker_settings

    with worker_settings():
        try:
            return forecast_axis(task)
        except Exception as exc:  # one axis' forecast never stops the fleet's status
            return f"forecast: {_one_line(exc)}"
