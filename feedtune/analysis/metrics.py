"""Tracking, rope-snap (step disturbance) and contouring metrics (thesis §3.4, §4.5).

* :func:`tracking_metrics` -- maximum and RMS tracking error over the whole run, the constant-velocity parts
  and the acceleration parts, and the error amplitude spectrum with its dominant peaks (Table 3.2,
  Fig. 3.15, §4.5).
* :func:`ropesnap_metrics` -- release instant, peak displacement, 5 % settling time and the amplitude
  spectral density of the response after a step disturbance (Fig. 3.14, Fig. 4.17).
* :func:`contour_error` -- normal distance of an x-y path from its reference polyline (Fig. 4.20-4.22).

All lengths in metres [m], times in seconds [s], frequencies in Hz; the dictionaries returned by
``to_dict()`` name the unit in each key (``max_m``, ``settling_time_s``, ``asd_m_per_rthz``...).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import DataError, UsageError

#: Relative tolerance on the sample interval for spectra (as :meth:`feedtune.log.Log.is_uniform`).
UNIFORM_RTOL = 1e-3
#: Noise standard deviations a displacement must exceed to count as the release.
RELEASE_SIGMAS = 5.0
#: Consecutive samples that must exceed the release threshold (rejects single noise spikes).
RELEASE_RUN = 3
#: Fraction of the log (from its start) used as the pre-release baseline when the release is detected.
BASELINE_FRACTION = 0.05
#: Fraction of the log (at its end) averaged for the final displacement.
FINAL_FRACTION = 0.10


# ------------------------------------------------------------------------------------------ value types
@dataclass(frozen=True)
class ErrorStats:
    """Maximum and RMS of an error signal over a set of samples.

    Parameters
    ----------
    max_abs : float
        max |e| [m].
    rms : float
        sqrt(mean(e^2)) [m].
    n_samples : int
        Number of samples in the part.
    duration : float
        Number of samples times the mean sample interval [s].
    """

    max_abs: float
    rms: float
    n_samples: int
    duration: float

    def to_dict(self) -> dict:
        """JSON-ready dictionary with units in the keys."""
        return {"max_m": self.max_abs, "rms_m": self.rms, "n_samples": self.n_samples,
                "duration_s": self.duration}


@dataclass(frozen=True)
class SpectrumPeak:
    """One peak of a spectrum: frequency [Hz] and level (amplitude [m] or ASD [m/sqrt(Hz)])."""

    freq_hz: float
    level: float


@dataclass(frozen=True)
class TrackingMetrics:
    """Tracking-error statistics and spectrum.

    Parameters
    ----------
    overall : ErrorStats
        Over the whole run.
    constant_velocity : ErrorStats or None
        Over samples with ``|v| >= (1 - v_tol) max|v|`` and ``|a| <= a_tol max|a|``; None without a
        velocity profile, at standstill, or when no sample qualifies.
    acceleration : ErrorStats or None
        Over samples with ``|a| > a_tol max|a|``; None without a profile or when no sample qualifies.
    freq_hz : ndarray or None
        Spectrum frequencies [Hz] (None when the spectrum was not requested).
    amplitude : ndarray or None
        Single-sided, Hann-windowed, amplitude-correct spectrum of the mean-free error [m]: a sinusoid of
        amplitude A on a frequency line reads A.
    peaks : tuple of SpectrumPeak
        Dominant spectrum peaks, largest first (level = amplitude [m]).
    unit : str
        Unit of the errors and amplitudes: ``m``, or ``rad`` for a rotary axis (the ``_m`` keys of :meth:`to_dict`
        then hold rad).
    """

    overall: ErrorStats
    constant_velocity: ErrorStats | None
    acceleration: ErrorStats | None
    freq_hz: np.ndarray | None
    amplitude: np.ndarray | None
    peaks: tuple[SpectrumPeak, ...]
    unit: str = "m"

    def to_dict(self, include_spectrum: bool = False) -> dict:
        """JSON-ready dictionary; the full spectrum only with ``include_spectrum=True``."""
        out = {
            "overall": self.overall.to_dict(),
            "constant_velocity": None if self.constant_velocity is None else self.constant_velocity.to_dict(),
            "acceleration": None if self.acceleration is None else self.acceleration.to_dict(),
            "peaks": [{"freq_hz": p.freq_hz, "amplitude_m": p.level} for p in self.peaks],
        }
        if include_spectrum and self.freq_hz is not None:
            out["spectrum"] = {"freq_hz": self.freq_hz.tolist(), "amplitude_m": self.amplitude.tolist()}
        return out


@dataclass(frozen=True)
class RopeSnapMetrics:
    """Response to a released step disturbance (rope-snap test).

    Parameters
    ----------
    t_release : float
        Release instant [s] (given, or detected: see :func:`ropesnap_metrics`).
    release_detected : bool
        True when ``t_release`` was detected from the signal.
    baseline : float
        Mean displacement before the release [m].
    peak : float
        Signed peak displacement relative to ``baseline`` [m].
    peak_time : float
        Time of the peak after the release [s].
    final : float
        Mean displacement over the last 10 % of the log [m].
    settle_band : float
        ``settle_fraction * |peak|`` [m].
    settling_time : float or None
        Time after the release from which ``|x - final|`` stays below ``settle_band`` [s]; None when the
        response never settles within the log (it still leaves the band during the last 10 %).
    settled : bool
        False when the response did not settle within the log.
    asd_freq_hz, asd : ndarray
        Amplitude spectral density of the post-release displacement [m/sqrt(Hz)] on its grid [Hz].
    peaks : tuple of SpectrumPeak
        Dominant ASD peaks, highest first (level in m/sqrt(Hz)).
    """

    t_release: float
    release_detected: bool
    baseline: float
    peak: float
    peak_time: float
    final: float
    settle_band: float
    settling_time: float | None
    settled: bool
    asd_freq_hz: np.ndarray
    asd: np.ndarray
    peaks: tuple[SpectrumPeak, ...]

    @property
    def peak_abs(self) -> float:
        """|peak| [m]."""
        return abs(self.peak)

    def to_dict(self, include_spectrum: bool = False) -> dict:
        """JSON-ready dictionary; the full ASD only with ``include_spectrum=True``."""
        out = {
            "t_release_s": self.t_release,
            "release_detected": self.release_detected,
            "baseline_m": self.baseline,
            "peak_m": self.peak,
            "peak_abs_m": self.peak_abs,
            "peak_time_s": self.peak_time,
            "final_m": self.final,
            "settle_band_m": self.settle_band,
            "settling_time_s": self.settling_time,
            "settled": self.settled,
            "asd_peaks": [{"freq_hz": p.freq_hz, "asd_m_per_rthz": p.level} for p in self.peaks],
        }
        if include_spectrum:
            out["asd"] = {"freq_hz": self.asd_freq_hz.tolist(), "asd_m_per_rthz": self.asd.tolist()}
        return out


@dataclass(frozen=True)
class ContourError:
    """Normal distance of an actual x-y path from its reference polyline.

    Parameters
    ----------
    distance : ndarray, shape (n,)
        Signed distance of each actual point from the nearest point of the reference path [m]; positive
        to the left of the path direction (outside of a clockwise, inside of a counter-clockwise contour).
    segment : ndarray of int, shape (n,)
        Index of the nearest reference segment (between reference points ``k`` and ``k + 1``).
    """

    distance: np.ndarray
    segment: np.ndarray

    @property
    def max_abs(self) -> float:
        """Maximum contour error [m]."""
        return float(np.max(np.abs(self.distance)))

    @property
    def rms(self) -> float:
        """RMS contour error [m]."""
        return float(np.sqrt(np.mean(self.distance**2)))

    def to_dict(self) -> dict:
        """JSON-ready dictionary with units in the keys."""
        return {"max_m": self.max_abs, "rms_m": self.rms, "n_points": int(self.distance.size)}


# ------------------------------------------------------------------------------------------- validation
def _vector(x, name: str, n: int | None = None) -> np.ndarray:
    """1-D finite float array (of length ``n`` when given), else DataError naming ``name``."""
    try:
        a = np.asarray(x, dtype=float)
    except (TypeError, ValueError):
        raise DataError(f"{name}: expected numbers") from None
    if a.ndim != 1 or a.size == 0:
        raise DataError(f"{name}: expected a non-empty 1-D array, got shape {a.shape}")
    if n is not None and a.size != n:
        raise DataError(f"{name}: has {a.size} samples, expected {n} (the length of the time vector)")
    if not np.all(np.isfinite(a)):
        raise DataError(f"{name}: sample {int(np.flatnonzero(~np.isfinite(a))[0])} is NaN or infinite")
    return a


def _time(t, min_samples: int) -> np.ndarray:
    t = _vector(t, "t")
    if t.size < min_samples:
        raise DataError(f"t: needs at least {min_samples} samples, got {t.size}")
    d = np.diff(t)
    if np.any(d <= 0):
        raise DataError(f"t: time must be strictly increasing (sample {int(np.flatnonzero(d <= 0)[0]) + 1})")
    return t


def _uniform_dt(t: np.ndarray, what: str) -> float:
    d = np.diff(t)
    dt = float((t[-1] - t[0]) / (t.size - 1))
    if np.any(np.abs(d - dt) > UNIFORM_RTOL * dt):
        raise DataError(f"t: the {what} needs uniformly sampled data; resample first")
    return dt


def _fraction(value: float, name: str, allow_zero: bool = False) -> float:
    """A number in (0, 1), or [0, 1) with ``allow_zero``; else UsageError naming ``name``."""
    ok = isinstance(value, (int, float)) and not isinstance(value, bool) and value < 1 \
        and (value >= 0 if allow_zero else value > 0)
    if not ok:
        span = "0 <= value < 1" if allow_zero else "0 < value < 1"
        raise UsageError(f"{name}: expected a fraction {span}, got {value!r}")
    return float(value)


def _count(value: int, name: str, minimum: int) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < minimum:
        raise UsageError(f"{name}: expected an integer >= {minimum}, got {value!r}")
    return int(value)


# ---------------------------------------------------------------------------------------------- tracking
def _stats(e: np.ndarray, mask: np.ndarray | None, dt: float) -> ErrorStats | None:
    part = e if mask is None else e[mask]
    if part.size == 0:
        return None
    return ErrorStats(float(np.max(np.abs(part))), float(np.sqrt(np.mean(part**2))), int(part.size),
                      float(part.size * dt))


def _motion_masks(
    t: np.ndarray, vel: np.ndarray | None, acc: np.ndarray | None, v_tol: float, a_tol: float
) -> tuple[np.ndarray | None, np.ndarray | None]:
    """Boolean masks of the constant-velocity and acceleration parts (None when not defined)."""
    if vel is None and acc is None:
        return None, None
    if acc is None:
        acc = np.gradient(vel, t)
    a_max = float(np.max(np.abs(acc)))
    accelerating = np.abs(acc) > a_tol * a_max if a_max > 0 else np.zeros(t.size, bool)
    if vel is None:
        return None, accelerating
    v_max = float(np.max(np.abs(vel)))
    if v_max == 0:
        return None, accelerating
    cruising = (np.abs(vel) >= (1 - v_tol) * v_max) & ~accelerating
    return cruising, accelerating


def amplitude_spectrum(x: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """Single-sided amplitude spectrum of the mean-free signal with a Hann window, amplitude-correct.

    Parameters
    ----------
    x : ndarray, shape (n,)
        Uniformly sampled signal (any unit).
    dt : float
        Sample interval [s].

    Returns
    -------
    freq_hz, amplitude : ndarray
        Frequencies [Hz] and amplitudes [unit of x]: a sinusoid ``A sin(2 pi f t)`` with ``f`` on a
        frequency line reads ``A`` (``2 |X_k| / sum(w)``; DC and Nyquist lines are not doubled).
    """
    from scipy.fft import rfft
    from scipy.signal import get_window

    w = get_window("hann", x.size)
    amp = np.abs(rfft((x - x.mean()) * w)) * (2.0 / w.sum())
    amp[0] /= 2.0
    if x.size % 2 == 0:
        amp[-1] /= 2.0
    return np.fft.rfftfreq(x.size, dt), amp


def _dominant_peaks(
    freq: np.ndarray, level: np.ndarray, n_peaks: int, *, prominence: float, log_scale: bool
) -> tuple[SpectrumPeak, ...]:
    """The ``n_peaks`` highest local maxima with at least ``prominence`` (linear fraction of the max, or
    decades of ``log10(level)`` when ``log_scale``), highest first."""
    from scipy.signal import find_peaks

    top = float(np.max(level)) if level.size else 0.0
    if not top > 0:
        return ()
    if log_scale:
        curve = np.log10(np.maximum(level, top * 1e-15))
        idx, _ = find_peaks(curve, prominence=prominence)
    else:
        idx, _ = find_peaks(level, prominence=prominence * top)
    idx = idx[np.argsort(level[idx])[::-1][:n_peaks]]
    return tuple(SpectrumPeak(float(freq[i]), float(level[i])) for i in idx)


def tracking_metrics(
    t,
    error,
    *,
    vel=None,
    acc=None,
    v_tol: float = 0.02,
    a_tol: float = 0.02,
    spectrum: bool = True,
    n_peaks: int = 5,
    peak_prominence: float = 0.05,
) -> TrackingMetrics:
    """Maximum and RMS tracking error per motion phase and the error amplitude spectrum.

    Parameters
    ----------
    t : array_like, shape (n,)
        Time [s], strictly increasing (uniform when ``spectrum`` is True).
    error : array_like, shape (n,)
        Tracking error, commanded minus actual position [m].
    vel, acc : array_like, shape (n,), optional
        Commanded velocity [m/s] and acceleration [m/s^2]. With ``vel`` only, the acceleration is its
        numerical derivative. Constant-velocity part: ``|vel| >= (1 - v_tol) max|vel|`` and
        ``|acc| <= a_tol max|acc|``; acceleration part: ``|acc| > a_tol max|acc|``.
    v_tol, a_tol : float
        Relative tolerances [-].
    spectrum : bool
        Also compute the error amplitude spectrum and its peaks.
    n_peaks : int
        Number of spectrum peaks reported.
    peak_prominence : float
        Minimum peak prominence as a fraction of the largest amplitude (0.05 keeps the Hann side lobes,
        -31 dB, of a strong line from counting as peaks).

    Returns
    -------
    TrackingMetrics

    Examples
    --------
    >>> t = np.arange(1000) * 1e-3
    >>> m = tracking_metrics(t, 2e-6 * np.sin(2 * np.pi * 50 * t))
    >>> round(m.overall.max_abs * 1e6, 6), round(m.peaks[0].freq_hz, 3), round(m.peaks[0].level * 1e6, 6)
    (2.0, 50.0, 2.0)
    """
    t = _time(t, 2)
    e = _vector(error, "error", t.size)
    v = None if vel is None else _vector(vel, "vel", t.size)
    a = None if acc is None else _vector(acc, "acc", t.size)
    v_tol = _fraction(v_tol, "v_tol", allow_zero=True)
    a_tol = _fraction(a_tol, "a_tol", allow_zero=True)
    n_peaks = _count(n_peaks, "n_peaks", 0)
    peak_prominence = _fraction(peak_prominence, "peak_prominence")
    dt = float((t[-1] - t[0]) / (t.size - 1))
    cruising, accelerating = _motion_masks(t, v, a, v_tol, a_tol)
    freq = amp = None
    peaks: tuple[SpectrumPeak, ...] = ()
    if spectrum:
        freq, amp = amplitude_spectrum(e, _uniform_dt(t, "error spectrum"))
        peaks = _dominant_peaks(freq, amp, n_peaks, prominence=peak_prominence, log_scale=False)
    return TrackingMetrics(
        overall=_stats(e, None, dt),
        constant_velocity=None if cruising is None else _stats(e, cruising, dt),
        acceleration=None if accelerating is None else _stats(e, accelerating, dt),
        freq_hz=freq,
        amplitude=amp,
        peaks=peaks,
    )


# --------------------------------------------------------------------------------------------- rope snap
def detect_release(t: np.ndarray, x: np.ndarray) -> tuple[int, float, float]:
    """Find the release of a rope-snap test from the displacement alone.

    The first 5 % of the log is taken as the pre-release baseline (mean ``m`` and standard deviation
    ``s``). The release is found where ``|x - m|`` first exceeds ``5 s`` (at least ``1e-6`` of the largest
    departure) on 3 consecutive samples; from there the index steps back to the last sample still within
    ``s`` of the baseline, which is returned as the release sample (exact for noise-free data, late by the
    rise out of the noise otherwise).

    Parameters
    ----------
    t : ndarray, shape (n,)
        Time [s].
    x : ndarray, shape (n,)
        Displacement [m].

    Returns
    -------
    index : int
        Release sample.
    baseline : float
        Pre-release mean [m].
    noise : float
        Pre-release standard deviation [m].

    Raises
    ------
    DataError
        The displacement never leaves the baseline.
    """
    n_base = max(10, int(BASELINE_FRACTION * x.size))
    base = x[:n_base]
    mean, noise = float(base.mean()), float(base.std())
    dev = np.abs(x - mean)
    scale = float(dev.max())
    threshold = max(RELEASE_SIGMAS * noise, 1e-6 * scale)
    over = dev > threshold
    run = over[: over.size - RELEASE_RUN + 1].copy()
    for k in range(1, RELEASE_RUN):
        run &= over[k: over.size - RELEASE_RUN + 1 + k]
    hits = np.flatnonzero(run)
    if scale == 0 or hits.size == 0:
        raise DataError("x: the displacement never departs from its pre-release level (first 5 % of the "
                        f"log, noise {noise:.3g} m); pass t_release")
    quiet = np.flatnonzero(dev[: hits[0]] <= max(noise, 1e-12 * scale))
    index = int(quiet[-1]) if quiet.size else int(hits[0])
    return index, mean, noise


def _settling(
    tau: np.ndarray, x_post: np.ndarray, final: float, band: float, n_final: int
) -> float | None:
    """Time from which ``|x - final| < band`` holds to the end of the log.

    None (not settled) when the response leaves the band within the last ``n_final`` samples, the window
    that defines ``final``: a response must stay settled over that whole window to count as settled.
    """
    outside = np.flatnonzero(np.abs(x_post - final) >= band)
    if outside.size == 0:
        return 0.0
    last = int(outside[-1])
    if last >= x_post.size - n_final:
        return None
    return float(tau[last + 1])


def amplitude_spectral_density(
    x: np.ndarray, dt: float, nperseg: int | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Welch amplitude spectral density (Hann, 50 % overlap, mean removed per segment).

    Parameters
    ----------
    x : ndarray, shape (n,)
        Uniformly sampled signal [m].
    dt : float
        Sample interval [s].
    nperseg : int, optional
        Segment length [samples]; default the largest power of two not above half the record (three
        segments), at least 16 and at most the record.

    Returns
    -------
    freq_hz, asd : ndarray
        Frequencies [Hz] and ASD [m/sqrt(Hz)].
    """
    from scipy.signal import welch

    if nperseg is None:
        nperseg = min(x.size, max(16, 2 ** int(np.floor(np.log2(max(x.size // 2, 1))))))
    f, pxx = welch(x, fs=1.0 / dt, window="hann", nperseg=nperseg, noverlap=nperseg // 2,
                   detrend="constant", scaling="density")
    return f, np.sqrt(pxx)


def ropesnap_metrics(
    t,
    x,
    *,
    t_release: float | None = None,
    settle_fraction: float = 0.05,
    n_peaks: int = 5,
    nperseg: int | None = None,
    prominence_db: float = 6.0,
) -> RopeSnapMetrics:
    """Metrics of a rope-snap (released step disturbance) test.

    Parameters
    ----------
    t : array_like, shape (n,)
        Uniform time [s].
    x : array_like, shape (n,)
        Displacement of the table [m].
    t_release : float, optional
        Release instant [s]; detected with :func:`detect_release` when omitted (the log must then start
        with at least 5 % of quiet pre-release data).
    settle_fraction : float
        Settling band as a fraction of |peak| (0.05 for the thesis's 5 % settling time).
    n_peaks : int
        Number of ASD peaks reported.
    nperseg : int, optional
        Welch segment length for the ASD [samples] (see :func:`amplitude_spectral_density`).
    prominence_db : float
        Minimum prominence of an ASD peak over its surroundings [dB, 20 log10].

    Returns
    -------
    RopeSnapMetrics
        The baseline is the mean before the release; the peak is ``x - baseline`` of largest magnitude
        after the release; ``final`` the mean of the last 10 % of the log; the settling time the time
        after the release from which ``|x - final| < settle_fraction * |peak|`` holds to the end of the log
        (None, with ``settled`` False, when the band is still left during those last 10 %).
    """
    t = _time(t, 32)
    x = _vector(x, "x", t.size)
    settle_fraction = _fraction(settle_fraction, "settle_fraction")
    n_peaks = _count(n_peaks, "n_peaks", 0)
    if nperseg is not None:
        nperseg = _count(nperseg, "nperseg", 8)
    if not (isinstance(prominence_db, (int, float)) and prominence_db > 0):
        raise UsageError(f"prominence_db: expected a positive number of dB, got {prominence_db!r}")
    dt = _uniform_dt(t, "rope-snap ASD")
    i0, baseline, detected = _release_index(t, x, t_release)
    post_x, tau = x[i0:], t[i0:] - t[i0]
    if post_x.size < 16:
        raise DataError(f"x: only {post_x.size} samples after the release at {t[i0]:.6g} s; need >= 16")
    dev = post_x - baseline
    k = int(np.argmax(np.abs(dev)))
    peak = float(dev[k])
    n_final = max(1, int(FINAL_FRACTION * x.size))
    final = float(x[-n_final:].mean())
    band = settle_fraction * abs(peak)
    settling = _settling(tau, post_x, final, band, min(n_final, post_x.size))
    freq, asd = amplitude_spectral_density(post_x, dt, None if nperseg is None else min(nperseg, post_x.size))
    peaks = _dominant_peaks(freq[1:], asd[1:], n_peaks, prominence=prominence_db / 20.0, log_scale=True)
    return RopeSnapMetrics(
        t_release=float(t[i0]), release_detected=detected, baseline=baseline, peak=peak,
        peak_time=float(tau[k]), final=final, settle_band=band, settling_time=settling,
        settled=settling is not None, asd_freq_hz=freq, asd=asd, peaks=peaks,
    )


def _release_index(t: np.ndarray, x: np.ndarray, t_release: float | None) -> tuple[int, float, bool]:
    """Release sample, pre-release mean and whether the release was detected."""
    if t_release is None:
        index, baseline, _ = detect_release(t, x)
        return index, baseline, True
    if not (isinstance(t_release, (int, float)) and t[0] <= t_release < t[-1]):
        raise UsageError(f"t_release: expected a time within the log ({t[0]:.6g} .. {t[-1]:.6g} s), "
                         f"got {t_release!r}")
    index = int(np.searchsorted(t, t_release, side="left"))
    baseline = float(x[:index].mean()) if index > 0 else float(x[0])
    return index, baseline, False


# -------------------------------------------------------------------------------------------- contouring
def contour_error(x_ref, y_ref, x, y, *, chunk_elements: int = 2_000_000) -> ContourError:
    """Normal distance of each actual point from the reference path polyline.

    Every point is projected on every reference segment (clamped to the segment) and the nearest
    projection wins; points are processed in chunks of at most ``chunk_elements`` point-segment pairs,
    so memory stays bounded while the work is O(n_points x n_segments).

    Parameters
    ----------
    x_ref, y_ref : array_like, shape (m,)
        Reference path vertices [m], in path order (m >= 2, not all equal).
    x, y : array_like, shape (n,)
        Actual positions [m].
    chunk_elements : int
        Upper bound of point-segment pairs evaluated at once.

    Returns
    -------
    ContourError
        Signed distances (positive to the left of the path direction), nearest segments, max and RMS.

    Examples
    --------
    >>> c = contour_error([0.0, 1.0], [0.0, 0.0], [0.5, 0.2], [1e-6, -2e-6])
    >>> c.distance.tolist(), c.max_abs
    ([1e-06, -2e-06], 2e-06)
    """
    xr = _vector(x_ref, "x_ref")
    yr = _vector(y_ref, "y_ref", xr.size)
    xa = _vector(x, "x")
    ya = _vector(y, "y", xa.size)
    if xr.size < 2:
        raise DataError("x_ref: the reference path needs at least 2 points")
    chunk_elements = _count(chunk_elements, "chunk_elements", 1)
    start = np.column_stack([xr[:-1], yr[:-1]])
    seg = np.column_stack([np.diff(xr), np.diff(yr)])
    length2 = np.einsum("ij,ij->i", seg, seg)
    if not np.any(length2 > 0):
        raise DataError("x_ref, y_ref: all reference points coincide; the path has no length")
    inv_len2 = np.divide(1.0, length2, out=np.zeros_like(length2), where=length2 > 0)
    pts = np.column_stack([xa, ya])
    rows = max(1, chunk_elements // start.shape[0])
    dist = np.empty(pts.shape[0])
    nearest = np.empty(pts.shape[0], dtype=np.intp)
    for lo in range(0, pts.shape[0], rows):
        dist[lo:lo + rows], nearest[lo:lo + rows] = _nearest_segment(
            pts[lo:lo + rows], start, seg, inv_len2)
    return ContourError(distance=dist, segment=nearest)


def _nearest_segment(
    pts: np.ndarray, start: np.ndarray, seg: np.ndarray, inv_len2: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Signed distance to, and index of, the nearest segment for a block of points."""
    rel = pts[:, None, :] - start[None, :, :]
    s = np.clip(np.einsum("pki,ki->pk", rel, seg) * inv_len2, 0.0, 1.0)
    off = rel - s[..., None] * seg
    d2 = np.einsum("pki,pki->pk", off, off)
    k = np.argmin(d2, axis=1)
    p = np.arange(pts.shape[0])
    cross = seg[k, 0] * rel[p, k, 1] - seg[k, 1] * rel[p, k, 0]
    sign = np.where(cross < 0, -1.0, 1.0)
    return sign * np.sqrt(d2[p, k]), k
