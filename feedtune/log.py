"""The :class:`Log` value type: time series recorded on (or simulated for) a drive.

A log holds a time vector [s] and named signals, each with its unit. Signals are 1-D float arrays of the
same length as the time vector.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace

import numpy as np

from .errors import DataError, UsageError


@dataclass(frozen=True)
class Log:
    """Sampled signals with a common time base.

    Parameters
    ----------
    t : ndarray, shape (n,)
        Time [s], strictly increasing.
    signals : dict of str to ndarray
        Named signals, each shape (n,).
    units : dict of str to str
        Unit of each signal (``""`` when unknown).
    meta : dict
        Free-form metadata (source file, experiment description, events).
    """

    t: np.ndarray
    signals: Mapping[str, np.ndarray]
    units: Mapping[str, str] = field(default_factory=dict)
    meta: Mapping[str, object] = field(default_factory=dict)

    def __post_init__(self) -> None:
        where = str(self.meta.get("source", "log"))
        t = np.asarray(self.t, dtype=float)
        if t.ndim != 1 or t.size < 2:
            raise DataError(f"{where}: time vector must be 1-D with at least 2 samples")
        if not np.all(np.isfinite(t)):
            raise DataError(f"{where}: time column contains NaN or infinite values")
        if np.any(np.diff(t) <= 0):
            bad = int(np.flatnonzero(np.diff(t) <= 0)[0])
            raise DataError(f"{where}: time must be strictly increasing (row {bad + 2})")
        sig = {}
        for name, x in self.signals.items():
            a = np.asarray(x, dtype=float).reshape(-1)
            if a.size != t.size:
                raise DataError(f"{where}: signal {name!r} has {a.size} samples, time has {t.size}")
            if not np.all(np.isfinite(a)):
                bad = int(np.flatnonzero(~np.isfinite(a))[0])
                raise DataError(f"{where}: signal {name!r} has a NaN or infinite value at sample {bad}")
            sig[name] = a
        units = {k: str(self.units.get(k, "")) for k in sig}
        object.__setattr__(self, "t", t)
        object.__setattr__(self, "signals", sig)
        object.__setattr__(self, "units", units)
        object.__setattr__(self, "meta", dict(self.meta))

    @property
    def source(self) -> str:
        """Where the log came from (file name) or ``"log"``."""
        return str(self.meta.get("source", "log"))

    @property
    def n(self) -> int:
        """Number of samples."""
        return int(self.t.size)

    @property
    def dt(self) -> float:
        """Mean sample time [s]."""
        return float((self.t[-1] - self.t[0]) / (self.t.size - 1))

    @property
    def fs(self) -> float:
        """Mean sample rate [Hz]."""
        return 1.0 / self.dt

    def is_uniform(self, rtol: float = 1e-3) -> bool:
        """True when every sample interval is within ``rtol`` of the mean."""
        d = np.diff(self.t)
        return bool(np.all(np.abs(d - self.dt) <= rtol * self.dt))

    def check_uniform(self, purpose: str, rtol: float = 1e-3) -> float:
        """The sample time [s] of a uniformly sampled log; a :class:`DataError` naming ``purpose``, the intervals
        found and the resampler (:func:`feedtune.log_resample.resample_log`, ``feedtune log resample`` on the
        command line) when the intervals differ by more than ``rtol`` of their mean."""
        if self.is_uniform(rtol):
            return self.dt
        d = np.diff(self.t)
        found = (f"{purpose} needs a uniform time base and this one is not uniform (sample intervals "
                 f"{d.min() * 1e3:.4g}-{d.max() * 1e3:.4g} ms, median {np.median(d) * 1e3:.4g} ms)")
        raise DataError(f"{self.source}: {found}; resample the log first (feedtune.log_resample.resample_log)",
                        cli=f"{self.source}: {found}; resample the log first: feedtune log resample {self.source} "
                            "--fs HZ --out FILE.csv")

    def __contains__(self, name: str) -> bool:
        return name in self.signals

    def __getitem__(self, name: str) -> np.ndarray:
        return self.get(name)

    def get(self, name: str) -> np.ndarray:
        """Return one signal; a missing name is a :class:`DataError` that lists what exists."""
        try:
            return self.signals[name]
        except KeyError:
            raise DataError(
                f"{self.source}: no signal {name!r}; available: {', '.join(self.signals) or 'none'}"
            ) from None

    def unit(self, name: str) -> str:
        """Unit of a signal (``""`` when unknown)."""
        self.get(name)
        return self.units.get(name, "")

    def with_signals(self, signals: Mapping[str, np.ndarray], units: Mapping[str, str] | None = None) -> Log:
        """Return a copy with signals added or replaced."""
        sig = dict(self.signals)
        sig.update(signals)
        un = dict(self.units)
        un.update(units or {})
        return replace(self, signals=sig, units=un)

    def slice(self, t0: float | None = None, t1: float | None = None) -> Log:
        """Return the samples with ``t0 <= t <= t1``."""
        m = np.ones(self.n, bool)
        if t0 is not None:
            m &= self.t >= t0
        if t1 is not None:
            m &= self.t <= t1
        return replace(self, t=self.t[m], signals={k: v[m] for k, v in self.signals.items()})

    # --------------------------------------------------------------- notebooks
    def __repr__(self) -> str:
        from .display import call, log_parts

        return call("Log", log_parts(self))

    def _repr_html_(self) -> str:
        from .display import log_html

        return log_html(self)

    def plot(self, signals: Sequence[str] | None = None, *, title: str | None = None):
        """Signals over time [s], one panel each (long logs as a min/max envelope per pixel column).

        Parameters
        ----------
        signals : sequence of str, optional
            Signals to draw (default all, at most 8).
        title : str, optional
            Figure title (default the source).

        Returns
        -------
        matplotlib.figure.Figure
        """
        from .display import facade

        return facade("plot_log")(self, signals, title=title)

    def to_dataframe(self):
        """A pandas DataFrame: index ``t`` [s], one column per signal; units in ``attrs["units"]``."""
        import pandas as pd

        frame = pd.DataFrame(dict(self.signals), index=pd.Index(self.t, name="t"))
        frame.attrs["units"] = {"t": "s", **self.units}
        frame.attrs["source"] = self.source
        return frame


_LOG_LETTERS = ("v", "a", "j", "s")


def log_signal_names(prefix: str) -> tuple[str, str, str, str, str]:
    """Signal names ``(position, velocity, acceleration, jerk, snap)`` used by :meth:`Trajectory.to_log`.

    Parameters
    ----------
    prefix : str
        Position signal name, e.g. ``"x_ref"`` (gives ``v_ref`` ...) or ``"y_ref"`` (gives ``vy_ref`` ...).
    """
    if not isinstance(prefix, str) or not prefix.strip():
        raise UsageError(f"prefix must be a non-empty signal name such as 'x_ref', got {prefix!r}")
    stem, sep, tag = prefix.partition("_")
    kept = "" if stem == "x" else stem
    rest = sep + tag
    return (prefix, *(f"{letter}{kept}{rest}" for letter in _LOG_LETTERS))
