"""Put a log sampled at irregular instants on a uniform time base, anti-aliased, and say how irregular it was.

Loggers that poll a drive over USB or a fieldbus record rows when the host gets them: an ODrive log at a median
5.6 ms with intervals from 5.25 to 8.5 ms, rows missing where a read failed. FRF estimation and IDIM-LS need one
sample time. :func:`resample_log`:

1. reports the time base (:func:`time_base_report`): smallest, largest and median interval, the jitter (standard
   deviation of the intervals) and the largest gap;
2. refuses a gap longer than ``max_gap`` median intervals (default :data:`MAX_GAP`): resampling across it would
   invent the samples in it;
3. resamples every signal at ``fs`` (:func:`resample_signal`): when ``fs`` is below the log's median rate, the
   signal is first interpolated onto a uniform grid of at least twice the median rate that holds the target instants,
   low-passed there without phase (4th-order Butterworth forward and backward at :data:`ANTI_ALIAS_FRACTION` of
   ``fs``, so the new Nyquist band is not aliased) and then taken at the target instants; otherwise it is
   interpolated at them (nothing above the log's own rate is invented). The interpolation is the modified Akima
   cubic (:func:`_interpolate`): close for smooth signals, no overshoot at a step.

The same rule puts the logs of :func:`feedtune.log_merge.merge_logs` on their common base.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from .budget import check_memory
from .errors import DataError, UsageError
from .log import Log

ANTI_ALIAS_FRACTION = 0.4
"""Cut-off of the anti-alias low-pass as a fraction of the new sample rate [-]."""
MAX_GAP = 3.0
"""Longest interval accepted, in median intervals [-] (a failed read doubles one; a pause is longer)."""
FILTER_ORDER = 4
"""Order of the anti-alias Butterworth low-pass (applied forward and backward)."""


@dataclass(frozen=True)
class TimeBaseReport:
    """How regular a log's time stamps are.

    Attributes
    ----------
    n : int
        Samples.
    min_s, max_s, median_s, mean_s : float
        Smallest, largest, median and mean sample interval [s].
    jitter_s : float
        Standard deviation of the intervals [s].
    largest_gap : float
        Largest interval in median intervals [-].
    gap_at_s : float
        Time [s] where the largest interval starts.
    """

    n: int
    min_s: float
    max_s: float
    median_s: float
    mean_s: float
    jitter_s: float
    largest_gap: float
    gap_at_s: float

    @property
    def median_rate_hz(self) -> float:
        """``1 / median_s`` [Hz]."""
        return 1.0 / self.median_s

    @property
    def uniform(self) -> bool:
        """Whether every interval is within 0.1 % of the mean (:meth:`feedtune.log.Log.is_uniform`)."""
        return self.max_s - self.mean_s <= 1e-3 * self.mean_s and self.mean_s - self.min_s <= 1e-3 * self.mean_s

    def to_dict(self) -> dict:
        """The figures, with ``median_rate_hz``, ``uniform`` and ``units``."""
        return {"n": self.n, "min_s": self.min_s, "max_s": self.max_s, "median_s": self.median_s,
                "mean_s": self.mean_s, "jitter_s": self.jitter_s, "largest_gap": self.largest_gap,
                "gap_at_s": self.gap_at_s, "median_rate_hz": self.median_rate_hz, "uniform": self.uniform,
                "units": {"min_s": "s", "max_s": "s", "median_s": "s", "mean_s": "s", "jitter_s": "s",
                          "largest_gap": "median intervals", "gap_at_s": "s", "median_rate_hz": "Hz"}}

    def __str__(self) -> str:
        ms = 1e3
        return (f"{self.n} samples, intervals {self.min_s * ms:.4g}-{self.max_s * ms:.4g} ms, median "
                f"{self.median_s * ms:.4g} ms ({self.median_rate_hz:.4g} Hz), jitter {self.jitter_s * ms:.3g} ms rms, "
                f"largest interval {self.largest_gap:.3g} x the median at {self.gap_at_s:.4g} s")

    def __repr__(self) -> str:
        return f"TimeBaseReport({self})"


def time_base_report(t: np.ndarray) -> TimeBaseReport:
    """The regularity of time stamps ``t`` [s] (strictly increasing, at least two).

    Examples
    --------
    >>> r = time_base_report(np.array([0.0, 0.005, 0.010, 0.018, 0.023]))
    >>> round(r.median_s, 4), round(r.largest_gap, 2), r.gap_at_s
    (0.005, 1.6, 0.01)
    """
    t = np.asarray(t, dtype=float)
    if t.ndim != 1 or t.size < 2:
        raise DataError("a time base needs at least two samples")
    d = np.diff(t)
    median = float(np.median(d))
    k = int(np.argmax(d))
    return TimeBaseReport(int(t.size), float(d.min()), float(d.max()), median, float(d.mean()), float(d.std()),
                          float(d[k] / median), float(t[k]))


def _lowpass(x: np.ndarray, fs_grid: float, cutoff_hz: float, where: str) -> np.ndarray:
    from scipy import signal as sps

    sos = sps.butter(FILTER_ORDER, cutoff_hz, fs=fs_grid, output="sos")
    if x.size <= 3 * 2 * (sos.shape[0] + 1):
        raise DataError(f"{where} is too short ({x.size} samples) to low-pass before resampling")
    return sps.sosfiltfilt(sos, x)


def _interpolate(t: np.ndarray, x: np.ndarray, at: np.ndarray) -> np.ndarray:
    """``x`` at the instants ``at`` (inside ``t[0]..t[-1]``) by the modified Akima cubic (makima): local, exact for
    lines and close for smooth signals (a 3 Hz sine sampled every 4.6-9.6 ms: 7e-4 of its amplitude, where linear
    interpolation is 4e-3 off), and without the overshoot of a spline at a step (a command switched on)."""
    from scipy.interpolate import Akima1DInterpolator

    if t.size < 3:
        return np.interp(at, t, x)
    return Akima1DInterpolator(t, x, method="makima")(np.clip(at, t[0], t[-1]))


def resample_signal(t: np.ndarray, x: np.ndarray, t_out: np.ndarray, fs: float, where: str = "signal") -> np.ndarray:
    """One signal taken at the uniform instants ``t_out`` (rate ``fs`` [Hz]) from samples at ``t``, anti-aliased
    (module docstring, step 3).

    Parameters
    ----------
    t, x : ndarray
        Time stamps [s] (strictly increasing, regular or not) and samples.
    t_out : ndarray
        Uniform instants [s] ``t_out[0] + k / fs`` inside ``t[0]..t[-1]``.
    fs : float
        Their rate [Hz].
    where : str
        Name for messages.

    Returns
    -------
    ndarray
        The samples at ``t_out``.
    """
    t, x = np.asarray(t, dtype=float), np.asarray(x, dtype=float)
    d = np.diff(t)
    rate = 1.0 / float(np.median(d))
    if rate <= fs * 1.001:
        return _interpolate(t, x, t_out)
    if np.all(np.abs(d - d.mean()) <= 1e-3 * d.mean()):  # uniform: low-pass on its own grid
        return _interpolate(t, _lowpass(x, 1.0 / d.mean(), ANTI_ALIAS_FRACTION * fs, where), t_out)
    k = max(1, math.ceil(2.0 * rate / fs))
    grid_fs = k * fs
    n_before = math.floor((t_out[0] - t[0]) * grid_fs + 1e-9)
    n_after = math.floor((t[-1] - t_out[-1]) * grid_fs + 1e-9)
    grid = t_out[0] + np.arange(-n_before, (t_out.size - 1) * k + n_after + 1) / grid_fs
    fine = _lowpass(_interpolate(t, x, grid), grid_fs, ANTI_ALIAS_FRACTION * fs, where)
    return fine[n_before::k][: t_out.size]


def uniform_instants(t0: float, t1: float, fs: float) -> np.ndarray:
    """``t0 + k / fs`` for every ``k >= 0`` with the instant not after ``t1`` [s]."""
    return t0 + np.arange(int(np.floor((t1 - t0) * fs * (1 + 1e-12))) + 1) / fs


def resample_log(log: Log, fs: float | None = None, *, max_gap: float = MAX_GAP) -> Log:
    """The log on a uniform time base at ``fs``, anti-aliased (module docstring).

    Parameters
    ----------
    log : Log
        Sampled at irregular (or regular) instants.
    fs : float, optional
        New sample rate [Hz]; default the log's median rate rounded to 3 significant digits.
    max_gap : float
        Longest interval accepted [median intervals]; a longer one is a :class:`DataError` (pass a larger value
        to resample across it anyway).

    Returns
    -------
    Log
        Uniform from the first time stamp on; ``meta["resample"]`` records what was done and
        ``meta["time_base_report"]`` the original time base (:class:`TimeBaseReport`).

    Raises
    ------
    UsageError
        ``fs`` or ``max_gap`` not a positive number, a resampled log beyond the memory budget.
    DataError
        A gap longer than ``max_gap`` median intervals, a log too short to low-pass.

    Examples
    --------
    >>> t = np.cumsum(np.r_[0.0, np.tile([0.005, 0.006, 0.0055], 200)])
    >>> out = resample_log(Log(t, {"x": np.sin(2 * np.pi * 3 * t)}), 150.0)
    >>> out.is_uniform(), round(out.fs, 6)
    (True, 150.0)
    """
    if not (isinstance(max_gap, (int, float)) and math.isfinite(max_gap) and max_gap >= 1):
        raise UsageError(f"max_gap must be a number of median intervals >= 1, got {max_gap!r}", parameter="max_gap")
    report = time_base_report(log.t)
    if fs is None:
        fs = float(f"{report.median_rate_hz:.3g}")
    if not (isinstance(fs, (int, float)) and math.isfinite(fs) and fs > 0):
        raise UsageError(f"fs must be a sample rate > 0 Hz, got {fs!r}", parameter="fs")
    if report.largest_gap > max_gap:
        raise DataError(f"{log.source}: an interval of {report.max_s * 1e3:.4g} ms ({report.largest_gap:.3g} median "
                        f"intervals) at t = {report.gap_at_s:.6g} s is longer than the max_gap of {max_gap:g} median "
                        "intervals; resampling across it invents the samples in it (cut the log there, or pass a "
                        "larger max_gap)", parameter="max_gap")
    n = (float(log.t[-1]) - float(log.t[0])) * fs
    grid = max(1.0, math.ceil(2.0 * report.median_rate_hz / fs))  # the finer grid of a non-uniform log's low-pass
    check_memory(n * 8.0 * (2 + len(log.signals)) + n * grid * 8.0 * 3, f"resampling {len(log.signals)} signals "
                 f"over {log.t[-1] - log.t[0]:.6g} s at fs={fs:g} Hz ({n:.3g} samples)", parameter="fs")
    t_out = uniform_instants(float(log.t[0]), float(log.t[-1]), float(fs))
    if t_out.size < 2:
        raise DataError(f"{log.source}: {log.t[-1] - log.t[0]:.4g} s hold fewer than two samples at {fs:g} Hz")
    signals = {k: resample_signal(log.t, x, t_out, fs, f"{log.source}: {k}") for k, x in log.signals.items()}
    low = "" if report.median_rate_hz <= fs * 1.001 else \
        f", low-passed at {ANTI_ALIAS_FRACTION * fs:.4g} Hz (Butterworth {FILTER_ORDER}, zero phase)"
    record = f"resampled to {fs:g} Hz by Akima interpolation{low}"
    meta = {**log.meta, "resample": record, "time_base_report": str(report), "fs_hz": float(fs)}
    return replace(log, t=t_out, signals=signals, meta=meta)
