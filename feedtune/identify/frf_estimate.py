"""Frequency response functions estimated from excitation logs.

Two estimators turn a :class:`~feedtune.log.Log` holding an excitation and the measured responses into an
:class:`~feedtune.frf.Frf`:

``"h1"``
    Welch-averaged spectra of windowed, overlapping segments. Without a reference the H1 estimate
    ``G = S_uy / S_uu`` is returned with the coherence ``|S_uy|^2 / (S_uu S_yy)``. Measured in closed loop,
    H1 is biased towards ``-1/C`` (the inverse controller) wherever the loop feeds noise back into ``u``.
    Given the excitation ``r`` injected into the loop (``reference``), the indirect closed-loop estimate
    ``G = S_ry / S_ru`` is returned instead, with the coherence of ``y`` with ``r``; noise uncorrelated with
    ``r`` then averages out of both cross spectra.

``"periodic"``
    The log holds a periodic excitation (a multisine). Leading transient periods are dropped, each whole
    period is Fourier transformed without window, the complex spectra are averaged per line over the
    periods and the FRF is returned on the excited lines only: ``G = Y_avg / U_avg``, or with a reference
    ``G = avg(Y/R) / avg(U/R)``. The coherence per line is ``|sum E* Y|^2 / (sum |E|^2 sum |Y|^2)`` over
    the periods (``E`` = reference or input); for an exactly repeated excitation it reduces to
    ``|mean Y|^2 / mean |Y|^2``, one minus the relative period-to-period variance of the output.

Conventions: frequencies in Hz, ``exp(+j w t)`` phase convention, the FRF unit is
``output unit / input unit`` of the log's signals. The 0 Hz line is never returned.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from .. import progress
from ..errors import DataError, UsageError
from ..frf import Frf, normalize_quantity
from ..log import Log

METHODS = ("h1", "periodic")
DETRENDS = ("linear", "constant", "none")

#: Lines whose excitation amplitude is below this fraction of the largest line are never called excited.
LINE_FLOOR = 1e-3
#: The automatic line selection splits candidate lines at the largest amplitude ratio between neighbours
#: in sorted order when that ratio is at least this factor (6 dB).
LINE_GAP_MIN = 2.0
#: Autocorrelation (unbiased, normalised) that a detected period must reach.
PERIOD_MIN_CORRELATION = 0.5


# --------------------------------------------------------------------------------------------- public API
@progress.tasked("estimating the FRF")
def estimate_frf(
    log: Log,
    *,
    input: str,
    outputs: Sequence[str],
    reference: str | None = None,
    method: str = "h1",
    period_samples: int | None = None,
    transient_periods: int = 1,
    nperseg: int | None = None,
    overlap: float = 0.5,
    window: str = "hann",
    freq_range: tuple[float, float] | None = None,
    quantity: str = "position",
    detrend: str = "linear",
    line_threshold: float | None = None,
) -> Frf:
    """Estimate the FRF from ``input`` to each of ``outputs`` recorded in ``log``.

    Parameters
    ----------
    log : Log
        Uniformly sampled log with the input, output and (optional) reference signals.
    input : str
        Name of the plant input signal ``u`` (e.g. motor current [A] or drive command [V]).
    outputs : sequence of str
        Names of the measured outputs ``y`` (e.g. positions [m] or [rad]); all must share one unit.
    reference : str, optional
        Name of the excitation ``r`` injected into a closed loop. With it the plant ``u -> y`` is estimated
        indirectly as ``(r -> y) / (r -> u)`` and coherences are those of ``y`` with ``r``.
    method : {"h1", "periodic"}
        Welch H1 estimate (random or swept excitation) or periodic multisine averaging.
    period_samples : int, optional
        Period of a periodic excitation [samples]; detected from the autocorrelation of the excitation
        (reference, else input) when omitted. Only for ``method="periodic"``.
    transient_periods : int
        Leading whole periods dropped before averaging (``method="periodic"``).
    nperseg : int, optional
        Welch segment length [samples] (``method="h1"``); default the largest power of two not above
        1/8 of the log (at least 16).
    overlap : float
        Welch segment overlap as a fraction of ``nperseg``, 0 <= overlap < 1.
    window : str
        Window name understood by ``scipy.signal.get_window`` (``method="h1"``).
    freq_range : (float, float), optional
        Keep only ``lo <= f <= hi`` [Hz].
    quantity : str
        What the outputs measure: position, velocity or acceleration.
    detrend : {"linear", "constant", "none"}
        Trend removal: per Welch segment for ``"h1"``; once over the kept periods for ``"periodic"``,
        where the linear drift (of a free rigid body, which would otherwise leak into every line) is
        estimated from the period means so that the periodic part is left untouched.
    line_threshold : float, optional
        ``method="periodic"``: call a line excited when its excitation amplitude exceeds this fraction of
        the largest line. Default: automatic (lines above ``1e-3 * max``, split at the largest amplitude
        gap of at least 6 dB, which separates the excited lines from distortion and noise lines of a
        measured input).

    Returns
    -------
    Frf
        Shape ``(len(outputs), 1, n_freq)``, channels ``"y/u"``, units ``unit(y) / unit(u)``, coherence in
        0..1, ``meta`` describing the estimate (method, segments or periods, detected period, lines).

    Raises
    ------
    UsageError
        A parameter is out of range (method, overlap, nperseg, window, freq_range, detrend, quantity).
    DataError
        A signal is missing, the time base is not uniform, the outputs have different units, the log is
        too short for the segment length or period, or no periodicity or excitation is found.

    Examples
    --------
    >>> import numpy as np
    >>> from feedtune.log import Log
    >>> rng = np.random.default_rng(0)
    >>> u = rng.standard_normal(8192)
    >>> y = 0.5 * u
    >>> log = Log(np.arange(8192) * 1e-3, {"u": u, "y": y}, {"u": "V", "y": "m"})
    >>> frf = estimate_frf(log, input="u", outputs=["y"], nperseg=256)
    >>> bool(np.allclose(frf.channel("y/u"), 0.5))
    True
    """
    outs = _check_names(log, input, outputs, reference)
    method = _check_choice(method, METHODS, "method")
    detrend = _check_choice(detrend, DETRENDS, "detrend")
    quantity = _check_quantity(quantity)
    band = _check_freq_range(freq_range)
    log.check_uniform("FRF estimation")
    out_unit = _common_output_unit(log, outs)
    u = log.get(input)
    y = np.vstack([log.get(o) for o in outs])
    r = None if reference is None else log.get(reference)
    if method == "h1":
        freq, h, coh, meta = _h1(u, y, r, log.dt, nperseg, overlap, window, detrend, log.source)
    else:
        freq, h, coh, meta = _periodic(
            u, y, r, log.dt, period_samples, transient_periods, detrend, line_threshold, log.source
        )
    keep = _band_mask(freq, band)
    if not np.any(keep):
        raise DataError(f"{log.source}: no estimated frequency line lies in freq_range {band} Hz")
    meta.update({"source": log.source, "method": method, "input": input,
                 "reference": reference or "", "detrend": detrend})
    return Frf(
        freq_hz=freq[keep],
        response=h[:, None, keep],
        outputs=tuple(outs),
        inputs=(input,),
        quantity=quantity,
        coherence=np.clip(coh[:, None, keep], 0.0, 1.0),
        input_unit=log.unit(input),
        output_unit=out_unit,
        meta=meta,
    )


def detect_period(x: np.ndarray, *, where: str = "excitation") -> tuple[int, float]:
    """Detect the period of a periodic signal from its autocorrelation.

    The mean is removed, the biased autocorrelation is computed by FFT and normalised to 1 at lag 0. The
    main lobe around lag 0 is skipped (up to the first negative value) and the period is the lag of the
    highest autocorrelation up to half the record (so that at least two periods are present). The biased
    estimate decays with the lag, so multiples of the period lose against the period itself.

    Parameters
    ----------
    x : ndarray, shape (n,)
        Samples of the excitation.
    where : str
        Name used in error messages.

    Returns
    -------
    period : int
        Period [samples].
    correlation : float
        Unbiased normalised autocorrelation at that lag [-] (1 for an exactly periodic signal).

    Raises
    ------
    DataError
        The signal is constant, has no main-lobe end, or is not clearly periodic.
    """
    from scipy.fft import irfft, next_fast_len, rfft

    x = np.asarray(x, dtype=float)
    n = x.size
    e = x - x.mean()
    nfft = next_fast_len(2 * n, real=True)
    spec = rfft(e, nfft)
    ac = irfft(spec.real**2 + spec.imag**2, nfft)[: n // 2 + 1]
    if not ac[0] > 0:
        raise DataError(f"{where}: the excitation is constant; cannot detect a period")
    ac = ac / ac[0]
    negative = np.flatnonzero(ac < 0)
    if negative.size == 0:
        raise DataError(f"{where}: no periodic excitation found (autocorrelation never drops below 0); "
                        "pass period_samples")
    start = int(negative[0])
    lag = start + int(np.argmax(ac[start:]))
    unbiased = float(ac[lag] * n / (n - lag))
    if unbiased < PERIOD_MIN_CORRELATION:
        raise DataError(f"{where}: no periodic excitation found (best autocorrelation {unbiased:.2f} at lag "
                        f"{lag} samples, need >= {PERIOD_MIN_CORRELATION}); pass period_samples")
    return lag, unbiased


# ------------------------------------------------------------------------------------------- validation
def _check_names(log: Log, input: str, outputs: Sequence[str], reference: str | None) -> list[str]:
    """Check that the signal names exist, are distinct and usable as channel names; return the outputs."""
    outs = [outputs] if isinstance(outputs, str) else list(outputs)
    if not outs:
        raise UsageError("outputs: give at least one output signal name")
    if len(set(outs)) != len(outs):
        raise UsageError(f"outputs: duplicate signal names in {outs}")
    names = [input, *outs] + ([reference] if reference is not None else [])
    for name in names:
        if not isinstance(name, str) or "/" in name or not name:
            raise UsageError(f"signal name {name!r} must be a non-empty string without '/'")
        log.get(name)
    if input in outs:
        raise UsageError(f"input {input!r} is also listed as an output")
    return outs


def _check_choice(value: str, choices: tuple[str, ...], name: str) -> str:
    key = str(value).strip().lower()
    if key not in choices:
        raise UsageError(f"{name}: expected one of {', '.join(choices)}, got {value!r}")
    return key


def _check_quantity(quantity: str) -> str:
    try:
        return normalize_quantity(quantity)
    except DataError:
        raise UsageError(f"quantity: expected position, velocity or acceleration, got {quantity!r}") from None


def _check_freq_range(freq_range: tuple[float, float] | None) -> tuple[float, float] | None:
    if freq_range is None:
        return None
    try:
        lo, hi = (float(v) for v in freq_range)
    except (TypeError, ValueError):
        raise UsageError(f"freq_range: expected two numbers (lo, hi) in Hz, got {freq_range!r}") from None
    if not (np.isfinite(lo) and np.isfinite(hi) and 0 <= lo < hi):
        raise UsageError(f"freq_range: expected 0 <= lo < hi in Hz, got ({lo:g}, {hi:g})")
    return lo, hi


def _common_output_unit(log: Log, outputs: list[str]) -> str:
    units = {o: log.unit(o) for o in outputs}
    if len(set(units.values())) > 1:
        listed = ", ".join(f"{o} [{u or '-'}]" for o, u in units.items())
        raise DataError(f"{log.source}: output signals must share one unit, got {listed}")
    return units[outputs[0]]


def _band_mask(freq: np.ndarray, band: tuple[float, float] | None) -> np.ndarray:
    keep = freq > 0
    if band is not None:
        keep &= (freq >= band[0]) & (freq <= band[1])
    return keep


# ------------------------------------------------------------------------------------------------ Welch H1
def _default_nperseg(n: int) -> int:
    return max(16, 2 ** int(np.floor(np.log2(max(n // 8, 1)))))


def _welch_layout(n: int, nperseg: int | None, overlap: float, where: str) -> tuple[int, int]:
    """Validate segment length and overlap; return ``(nperseg, step)``."""
    if nperseg is None:
        nperseg = _default_nperseg(n)
    elif isinstance(nperseg, bool) or not isinstance(nperseg, (int, np.integer)) or nperseg < 8:
        raise UsageError(f"nperseg: expected an integer >= 8 samples, got {nperseg!r}")
    nperseg = int(nperseg)
    if not (isinstance(overlap, (int, float)) and 0 <= overlap < 1):
        raise UsageError(f"overlap: expected a fraction 0 <= overlap < 1, got {overlap!r}")
    step = nperseg - round(overlap * nperseg)
    if step < 1:
        raise UsageError(f"overlap {overlap} leaves no step between segments of {nperseg} samples")
    if n < nperseg:
        raise DataError(f"{where}: log has {n} samples, fewer than one segment of nperseg={nperseg}")
    return nperseg, step


def _scaled_rows(u: np.ndarray, y: np.ndarray, r: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
    """Stack ``[r,] u, y...`` as rows divided by their largest magnitude (keeps squared spectra of
    extreme-valued signals finite); return the rows and the divisors."""
    rows = np.vstack([u, y]) if r is None else np.vstack([r, u, y])
    scale = np.max(np.abs(rows), axis=1)
    scale[scale == 0] = 1.0
    return rows / scale[:, None], scale


def _detrend_last_axis(x: np.ndarray, kind: str) -> np.ndarray:
    """Remove the mean (``"constant"``) or the least-squares line (``"linear"``) along the last axis."""
    if kind == "none":
        return x
    out = x - x.mean(axis=-1, keepdims=True)
    if kind == "linear":
        m = x.shape[-1]
        ramp = np.arange(m, dtype=float) - 0.5 * (m - 1)
        slope = (out @ ramp) / (ramp @ ramp)
        out -= slope[..., None] * ramp
    return out


def _segment_spectra(
    x: np.ndarray, nperseg: int, step: int, window: np.ndarray, detrend: str
) -> np.ndarray:
    """FFT of windowed, detrended, overlapping segments: ``(n_ch, n) -> (n_ch, n_seg, n_line)``."""
    from numpy.lib.stride_tricks import sliding_window_view
    from scipy.fft import rfft

    segs = sliding_window_view(x, nperseg, axis=-1)[:, ::step, :]
    segs = _detrend_last_axis(segs, detrend)
    return rfft(segs * window, axis=-1, workers=-1)


def _get_window(window: str, nperseg: int) -> np.ndarray:
    from scipy.signal import get_window

    try:
        return np.asarray(get_window(window, nperseg), dtype=float)
    except (ValueError, TypeError):
        raise UsageError(f"window: {window!r} is not a window known to scipy.signal.get_window") from None


def _h1(
    u: np.ndarray,
    y: np.ndarray,
    r: np.ndarray | None,
    dt: float,
    nperseg: int | None,
    overlap: float,
    window: str,
    detrend: str,
    where: str,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, dict[str, str]]:
    """Welch H1 or indirect estimate; returns ``(freq, H (n_out, n_f), coherence, meta)``."""
    nperseg, step = _welch_layout(u.size, nperseg, overlap, where)
    win = _get_window(window, nperseg)
    rows, scale = _scaled_rows(u, y, r)
    spec = _segment_spectra(rows, nperseg, step, win, detrend)
    e_spec = spec[0]
    y_spec = spec[-y.shape[0]:]
    s_ee = np.mean(np.abs(e_spec) ** 2, axis=0)
    s_ey = np.mean(np.conj(e_spec)[None] * y_spec, axis=1)
    s_yy = np.mean(np.abs(y_spec) ** 2, axis=1)
    denom = s_ee if r is None else np.mean(np.conj(e_spec) * spec[1], axis=0)
    freq = np.fft.rfftfreq(nperseg, dt)
    if not np.max(np.abs(denom)) > 0:
        raise DataError(f"{where}: the {'reference' if r is not None else 'input'} signal carries no "
                        "excitation (zero spectrum); nothing to estimate")
    usable = np.abs(denom) > 1e-14 * np.max(np.abs(denom))
    freq, denom, s_ee = freq[usable], denom[usable], s_ee[usable]
    s_ey, s_yy = s_ey[:, usable], s_yy[:, usable]
    h = s_ey / denom * (scale[-y.shape[0]:, None] / scale[1 if r is not None else 0])
    with np.errstate(invalid="ignore", divide="ignore"):
        coh = np.nan_to_num(np.abs(s_ey) ** 2 / (s_ee * s_yy), nan=0.0, posinf=0.0)
    meta = {
        "estimator": "H1 = S_uy/S_uu" if r is None else "indirect G = S_ry/S_ru",
        "nperseg": str(nperseg),
        "segments": str(spec.shape[1]),
        "overlap": f"{overlap:g}",
        "window": str(window),
        "resolution_hz": f"{1.0 / (nperseg * dt):.6g}",
        "dropped_lines": str(int(np.count_nonzero(~usable))),
    }
    return freq, h, coh, meta


# ---------------------------------------------------------------------------------------------- periodic
def _period(
    exc: np.ndarray, period_samples: int | None, where: str
) -> tuple[int, str]:
    """Period [samples] given or detected, and a sentence for the metadata."""
    if period_samples is None:
        period, corr = detect_period(exc, where=where)
        return period, f"detected from the autocorrelation: peak {corr:.4f} at lag {period} samples"
    if isinstance(period_samples, bool) or not isinstance(period_samples, (int, np.integer)) \
            or period_samples < 2:
        raise UsageError(f"period_samples: expected an integer >= 2, got {period_samples!r}")
    return int(period_samples), "given"


def _period_count(n: int, period: int, transient_periods: int, where: str) -> int:
    if isinstance(transient_periods, bool) or not isinstance(transient_periods, (int, np.integer)) \
            or transient_periods < 0:
        raise UsageError(f"transient_periods: expected an integer >= 0, got {transient_periods!r}")
    whole = n // period
    kept = whole - int(transient_periods)
    if kept < 1:
        raise DataError(f"{where}: log has {n} samples = {whole} whole period(s) of {period} samples; "
                        f"dropping transient_periods={transient_periods} leaves none")
    return kept


def excited_lines(
    amplitude: np.ndarray, line_threshold: float | None = None, *, where: str = "excitation"
) -> tuple[np.ndarray, str]:
    """Select the excited lines of a periodic excitation from its line amplitudes.

    Parameters
    ----------
    amplitude : ndarray, shape (n_line,)
        Magnitude of the period-averaged excitation spectrum per line (any unit); line 0 (DC) is ignored.
    line_threshold : float, optional
        Fixed rule: excited when above ``line_threshold * max``. Default: automatic. Candidates are the
        lines above ``1e-3 * max``; sorted by amplitude, they are split at the largest ratio between
        neighbours when that ratio is at least 2 (6 dB), otherwise all candidates are excited. This keeps a
        flat or smoothly shaped multisine whole while rejecting the harmonic distortion and noise lines that
        a measured (closed-loop) input carries between the excited lines.

    Returns
    -------
    mask : ndarray of bool, shape (n_line,)
        True on excited lines.
    rule : str
        The rule that was applied, for the metadata.

    Raises
    ------
    DataError
        No line carries energy (message starts with ``where``).
    UsageError
        ``line_threshold`` is not a fraction in (0, 1).
    """
    a = np.asarray(amplitude, dtype=float).copy()
    a[0] = 0.0
    top = float(a.max())
    if not top > 0:
        raise DataError(f"{where}: the periodic excitation has no energy on any line")
    if line_threshold is not None:
        if not (isinstance(line_threshold, (int, float)) and 0 < line_threshold < 1):
            raise UsageError(f"line_threshold: expected a fraction 0 < t < 1, got {line_threshold!r}")
        return a > line_threshold * top, f"amplitude > {line_threshold:g} x max"
    cand = np.sort(a[a > LINE_FLOOR * top])[::-1]
    if cand.size < 2:
        return a > LINE_FLOOR * top, f"amplitude > {LINE_FLOOR:g} x max"
    ratio = cand[:-1] / cand[1:]
    k = int(np.argmax(ratio))
    if ratio[k] < LINE_GAP_MIN:
        return a > LINE_FLOOR * top, f"amplitude > {LINE_FLOOR:g} x max (no gap >= 6 dB)"
    cut = float(np.sqrt(cand[k] * cand[k + 1]))
    gap_db = 20 * np.log10(ratio[k])
    return a > cut, f"amplitude above the largest gap ({gap_db:.1f} dB at {cut / top:.3g} x max)"


def _remove_periodic_trend(rec: np.ndarray, detrend: str) -> np.ndarray:
    """Remove the mean and (``"linear"``) a drift from records shaped ``(n_ch, n_periods, period)``.

    A global least-squares line would also absorb part of the periodic signal. With two or more periods
    the drift slope is instead the slope of the period means over the period index divided by the period
    length, which is exact for ``periodic + a t + b``. A single period falls back to a line fit.
    """
    if detrend == "none":
        return rec
    n_per, period = rec.shape[1], rec.shape[2]
    out = rec - rec.mean(axis=(1, 2), keepdims=True)
    if detrend == "constant":
        return out
    if n_per == 1:
        return _detrend_last_axis(out, "linear")
    k = np.arange(n_per) - 0.5 * (n_per - 1)
    slope = (out.mean(axis=2) @ k) / (k @ k) / period
    ramp = np.arange(n_per * period, dtype=float).reshape(n_per, period)
    ramp -= ramp.mean()
    return out - slope[:, None, None] * ramp


def _periodic(
    u: np.ndarray,
    y: np.ndarray,
    r: np.ndarray | None,
    dt: float,
    period_samples: int | None,
    transient_periods: int,
    detrend: str,
    line_threshold: float | None,
    where: str,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, dict[str, str]]:
    """Periodic (multisine) estimate on the excited lines; returns ``(freq, H, coherence, meta)``."""
    from scipy.fft import rfft

    period, how = _period(u if r is None else r, period_samples, where)
    mismatch = _period_mismatch(u if r is None else r, period, where) if how == "given" else None
    if period > u.size:
        raise DataError(f"{where}: log has {u.size} samples, fewer than one period of {period} samples")
    kept = _period_count(u.size, period, transient_periods, where)
    start = int(transient_periods) * period
    rows, scale = _scaled_rows(u, y, r)
    rec = _remove_periodic_trend(rows[:, start:start + kept * period].reshape(rows.shape[0], kept, period),
                                 detrend)
    spec = rfft(rec, axis=-1, workers=-1)
    lines, rule = excited_lines(np.abs(spec[0].mean(axis=0)), line_threshold, where=where)
    spec = spec[:, :, lines]
    e_spec, u_spec, y_spec = spec[0], spec[1] if r is not None else spec[0], spec[-y.shape[0]:]
    if r is None:
        h = y_spec.mean(axis=1) / u_spec.mean(axis=0)
    else:
        h = (y_spec / e_spec).mean(axis=1) / (u_spec / e_spec).mean(axis=0)
    h = h * (scale[-y.shape[0]:, None] / scale[1 if r is not None else 0])
    s_ey = np.sum(np.conj(e_spec)[None] * y_spec, axis=1)
    s_ee = np.sum(np.abs(e_spec) ** 2, axis=0)
    s_yy = np.sum(np.abs(y_spec) ** 2, axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        coh = np.nan_to_num(np.abs(s_ey) ** 2 / (s_ee * s_yy), nan=0.0, posinf=0.0)
    line_idx = np.flatnonzero(lines)
    df = 1.0 / (period * dt)
    meta = {
        "estimator": "periodic Y/U" if r is None else "periodic (Y/R)/(U/R)",
        "period_samples": str(period),
        "period_s": f"{period * dt:.9g}",
        "period_detection": how,
        "periods_total": str(u.size // period),
        "transient_periods": str(int(transient_periods)),
        "periods_averaged": str(kept),
        "line_spacing_hz": f"{df:.9g}",
        "excited_lines": str(line_idx.size),
        "excited_band_hz": f"{line_idx[0] * df:.6g}..{line_idx[-1] * df:.6g}",
        "line_selection": rule,
    }
    if kept == 1:
        meta["coherence_note"] = "one period averaged: coherence is 1 by construction"
    if mismatch:
        meta["warning"] = mismatch
    return line_idx / (period * dt), h, coh, meta


def _period_mismatch(exc: np.ndarray, period: int, where: str) -> str | None:
    """Why a given period does not fit the excitation (it repeats every other number of samples, not a divisor of
    ``period``), or None."""
    try:
        lag, corr = detect_period(exc, where=where)
    except DataError:
        return None
    if period % lag == 0:  # the period itself or a multiple of it
        return None
    return (f"period_samples {period} does not fit the excitation, which repeats every {lag} samples "
            f"(autocorrelation {corr:.3f}): the FRF averages misaligned periods and is wrong; pass {lag} or leave "
            "period_samples out to detect it")


# ------------------------------------------------------------------------------------------ FRF
def estimate_frf_2x2(log: Log, *, period_samples: int, block_periods: int, band_hz: tuple[float, float],
                     transient_periods: int = 1):
    """Indirect closed-loop 2x2 FRF from a log whose first block excites ``r1`` and second ``r2``.

    Each block holds ``block_periods`` periods of ``period_samples``; its first ``transient_periods`` are
    dropped. Per excited line, ``T_y = [y/r1, y/r2]`` and ``T_u = [u/r1, u/r2]`` are the periodic estimates
    of :func:`~feedtune.identify.frf_estimate.estimate_frf` and the plant is ``G = T_y T_u^-1`` (noise
    uncorrelated with the excitation averages out of both). The coherence of ``y_i / u_j`` is that of
    ``y_i`` with ``r_j`` in block ``j``.

    Parameters
    ----------
    log : Log
        Uniform log with ``r1, r2, u1, u2`` [V] and ``y1, y2`` [m].
    period_samples : int
        Excitation period [samples].
    block_periods : int
        Periods per block.
    band_hz : (float, float)
        Excited band [Hz].
    transient_periods : int
        Periods dropped at the start of each block.

    Returns
    -------
    Frf
        Outputs ``y1, y2`` [m], inputs ``u1, u2`` [V], position, with coherence.
    """

    block = period_samples * block_periods
    if log.n < 2 * block:
        raise DataError(f"{log.source}: {log.n} samples, fewer than two blocks of {block}")
    Ty, Tu, coh = [], [], []
    freq = None
    for j in range(2):
        part = Log(log.t[j * block:(j + 1) * block],
                   {k: log.get(k)[j * block:(j + 1) * block] for k in (f"r{j + 1}", "u1", "u2", "y1", "y2")},
                   log.units, {"source": f"{log.source} (block {j + 1})"})
        half_line = 0.5 / (period_samples * log.dt)  # the band edges are lines: keep them despite rounding
        kw = {"input": f"r{j + 1}", "method": "periodic", "period_samples": int(period_samples),
              "transient_periods": int(transient_periods),
              "freq_range": (max(0.0, band_hz[0] - half_line), band_hz[1] + half_line)}
        ey = estimate_frf(part, outputs=["y1", "y2"], **kw)
        eu = estimate_frf(part, outputs=["u1", "u2"], **kw)
        if freq is not None and not (freq.size == ey.freq_hz.size and np.allclose(freq, ey.freq_hz, rtol=1e-9)):
            raise DataError(f"{log.source}: the two blocks excite different lines; use the same multisine")
        freq = ey.freq_hz if freq is None else freq
        Ty.append(ey.response[:, 0])
        Tu.append(eu.response[:, 0])
        coh.append(ey.coherence[:, 0])
    Ty_f = np.moveaxis(np.stack(Ty, axis=1), -1, 0)  # (n_freq, 2 outputs, 2 blocks)
    Tu_f = np.moveaxis(np.stack(Tu, axis=1), -1, 0)
    G = np.linalg.solve(np.swapaxes(Tu_f, 1, 2), np.swapaxes(Ty_f, 1, 2))  # G Tu = Ty  <=>  Tu^T G^T = Ty^T
    G = np.moveaxis(np.swapaxes(G, 1, 2), 0, -1)
    C = np.stack(coh, axis=1)
    return Frf(freq, G, ("y1", "y2"), ("u1", "u2"), "position", C, input_unit=log.unit("u1"),
               output_unit=log.unit("y1"),
               meta={"source": log.source, "estimator": "indirect closed-loop G = T_yr T_ur^-1 (periodic)",
                     "period_samples": str(period_samples), "block_periods": str(block_periods)})
