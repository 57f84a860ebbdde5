"""What an FRF means with respect to sampling: the continuous plant, or the plant seen through a controller.

feedtune's analysis and fits expect the **continuous** plant response (what a dynamic signal analyser measuring
from the amplifier input to the encoders sees): the analysis's ``discrete`` case multiplies it by the zero-order
hold ``(1 - e^{-sT})/(sT)`` and the computational delay ``e^{-s d T}`` itself. An FRF estimated from a
controller's own log (logged command ``u[k]`` -> encoder reading ``x[k]``) already contains both; analysed as is,
they would be counted twice (about 4 deg of extra lag at 160 Hz at 20 kHz with one sample of delay).

:func:`remove_sampling` divides them out and records that in the FRF's metadata (flat keys, so the record
survives a CSV round trip):

* ``sampling = "removed"``, ``sampling_fs_hz``, ``sampling_delay_samples``: ZOH and delay divided out;
* ``sampling = "not_removed"``, ``sampling_fs_hz``: estimated from a log sampled at ``sampling_fs_hz`` and left
  as estimated (:func:`mark_sampling_kept`).

:func:`sampling_state` reads the record back (also recognising FRFs written before it existed);
:func:`double_counting_warning` is the one-line warning the analysis commands print for a ``not_removed`` FRF.

The record also tells design and analysis at which rate the FRF's machine was sampled: :func:`recorded_fs` and
:func:`recorded_delay` read it, :func:`rates_disagree` compares a target rate with it (more than
:data:`FS_TOLERANCE` apart) and :func:`band_warning` flags an FRF that ends far below the target's Nyquist
frequency (last line below :data:`NYQUIST_FRACTION` of ``fs / 2``), where the analysed loop rests on the model.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from .errors import DataError, Notice, UsageError
from .frf import Frf

#: Metadata key holding the sampling state of an FRF.
SAMPLING_KEY = "sampling"
SAMPLING_FS_KEY = "sampling_fs_hz"
SAMPLING_DELAY_KEY = "sampling_delay_samples"
REMOVED = "removed"
NOT_REMOVED = "not_removed"
UNKNOWN = "unknown"

#: Relative difference [-] above which a sample rate disagrees with the one an FRF records (0.1 %).
FS_TOLERANCE = 1e-3
#: An FRF ending below this fraction [-] of the target's Nyquist frequency ``fs / 2`` draws :func:`band_warning`.
NYQUIST_FRACTION = 0.25

#: Metadata ``method`` values written by :func:`feedtune.identify.frf_estimate.estimate_frf` (a sampled log).
_LOG_ESTIMATE_METHODS = ("h1", "periodic")

MAX_DELAY_SAMPLES = 100
"""Longest computational delay of a controller [samples]: a drive computes its command within a few samples."""


def _sample_rate(fs: float) -> float:
    try:
        value = float(fs)
    except (TypeError, ValueError):
        raise UsageError(f"sample rate fs must be a number in Hz, got {fs!r}") from None
    if not (math.isfinite(value) and value > 0):
        raise UsageError(f"sample rate fs must be > 0 Hz and finite, got {fs!r}")
    return value


def _delay(delay_samples: float) -> float:
    try:
        value = float(delay_samples)
    except (TypeError, ValueError):
        raise UsageError(f"delay_samples must be a number of samples >= 0, got {delay_samples!r}") from None
    if isinstance(delay_samples, bool) or not (math.isfinite(value) and 0 <= value <= MAX_DELAY_SAMPLES):
        raise UsageError(f"delay_samples must be a number of samples in 0 .. {MAX_DELAY_SAMPLES} (a drive's "
                         f"computational delay), got {delay_samples!r}", parameter="delay_samples")
    return value


def _number_text(value: float) -> str:
    """Shortest text of a number (``20000``, ``1``, ``0.5``) for the metadata."""
    return f"{value:.12g}"


def sampling_response(freq_hz: np.ndarray, fs: float, delay_samples: float) -> np.ndarray:
    """Zero-order hold times computational delay, ``(1 - e^{-sT})/(sT) e^{-s d T}``, on a grid [Hz].

    Parameters
    ----------
    freq_hz : ndarray
        Frequency grid [Hz].
    fs : float
        Controller sample rate [Hz] (``T = 1/fs`` [s]).
    delay_samples : float
        Computational delay ``d`` [samples].

    Returns
    -------
    ndarray of complex
        The factor [-] a controller's log adds to the continuous plant response.
    """
    from .lti import delay_response, zoh_response

    return zoh_response(freq_hz, fs) * delay_response(freq_hz, delay_samples, fs)


def remove_sampling(frf: Frf, fs: float, delay_samples: float) -> Frf:
    """The continuous plant response: ``frf`` divided by the ZOH and the computational delay.

    Use it for an FRF estimated from a controller's own log (input: the computed command ``u[k]``, outputs: the
    encoder readings ``x[k]``), which contains the zero-order hold and ``delay_samples`` of computational delay.

    Parameters
    ----------
    frf : Frf
        The FRF as estimated; every line must lie at or below the Nyquist frequency ``fs / 2``.
    fs : float
        Sample rate of the log / controller [Hz].
    delay_samples : float
        Computational delay [samples] (``u[k]`` acts from sample ``k + delay_samples``); 0 removes the ZOH only.

    Returns
    -------
    Frf
        Response divided by :func:`sampling_response` (coherence, quantity and units unchanged); ``meta`` records
        ``sampling = "removed"``, ``sampling_fs_hz`` [Hz] and ``sampling_delay_samples`` [samples].

    Raises
    ------
    UsageError
        ``fs`` or ``delay_samples`` out of range.
    DataError
        The FRF already had its sampling removed, or has lines above ``fs / 2``.
    """
    fs = _sample_rate(fs)
    delay = _delay(delay_samples)
    if sampling_state(frf) == REMOVED:
        raise DataError(f"{frf.source}: ZOH and delay were already removed from this FRF (metadata "
                        f"{_removed_text(frf.meta)}); removing them again would double the correction")
    f_max = float(frf.freq_hz[-1])
    if f_max > fs / 2 * (1 + 1e-12):
        raise DataError(f"{frf.source}: the FRF reaches {f_max:g} Hz, above the Nyquist frequency "
                        f"{fs / 2:g} Hz of the sampling to remove (fs = {fs:g} Hz); check fs")
    response = frf.response / sampling_response(frf.freq_hz, fs, delay)
    meta = {**frf.meta, SAMPLING_KEY: REMOVED, SAMPLING_FS_KEY: _number_text(fs),
            SAMPLING_DELAY_KEY: _number_text(delay)}
    return replace(frf, response=response, meta=meta)


def mark_sampling_kept(frf: Frf, fs: float) -> Frf:
    """``frf`` with ``meta`` saying it was estimated from a log sampled at ``fs`` [Hz] and left as estimated."""
    fs = _sample_rate(fs)
    meta = {k: v for k, v in frf.meta.items() if k != SAMPLING_DELAY_KEY}
    meta.update({SAMPLING_KEY: NOT_REMOVED, SAMPLING_FS_KEY: _number_text(fs)})
    return replace(frf, meta=meta)


def _removed_text(meta) -> str:
    fs = meta.get(SAMPLING_FS_KEY)
    delay = meta.get(SAMPLING_DELAY_KEY)
    if fs is None and "delay_removed_s" in meta:
        return f"delay_removed_s = {meta['delay_removed_s']}"
    return f"{SAMPLING_FS_KEY} = {fs}, {SAMPLING_DELAY_KEY} = {delay}"


def sampling_state(frf: Frf) -> str:
    """``"removed"``, ``"not_removed"`` or ``"unknown"``: what ``frf.meta`` says about ZOH and delay.

    ``sampling`` decides when present. Without it, ``delay_removed_s`` (the gantry twin's earlier record) means
    removed, and a ``method`` of ``h1`` or ``periodic`` (an FRF estimated from a sampled log by
    ``feedtune frf`` before the record existed) means not removed. Anything else (a file from a signal analyser,
    a model response) is unknown.
    """
    meta = frf.meta
    state = str(meta.get(SAMPLING_KEY, "")).strip().lower()
    if state in (REMOVED, NOT_REMOVED):
        return state
    if "delay_removed_s" in meta:
        return REMOVED
    if str(meta.get("method", "")).strip().lower() in _LOG_ESTIMATE_METHODS:
        return NOT_REMOVED
    return UNKNOWN


def double_counting_warning(frf: Frf, path: object | None = None) -> str | None:
    """One-line warning for an FRF estimated from a sampled log whose ZOH and delay were not removed, else None.

    Parameters
    ----------
    frf : Frf
    path : path-like, optional
        File name used in the message (default ``frf.source``).
    """
    if sampling_state(frf) != NOT_REMOVED:
        return None
    name = frf.source if path is None else str(path)
    fs = frf.meta.get(SAMPLING_FS_KEY)
    at = f" at {fs} Hz" if fs else ""
    text = (f"{name} was estimated from a sampled log{at} without removing the ZOH and the computational delay; "
            "if its input is the controller's command, the discrete case counts them twice")
    return Notice(f"{text} (divide them out with feedtune.frf_sampling.remove_sampling(frf, fs, delay_samples))",
                  cli=f"{text} (feedtune frf --remove-sampling DELAY_SAMPLES)")


def _recorded_number(frf: Frf, key: str, name: str, what: str, ok) -> float | None:
    text = frf.meta.get(key)
    if text is None or str(text).strip() == "":
        return None
    try:
        value = float(text)
    except (TypeError, ValueError):
        value = math.nan
    if not (math.isfinite(value) and ok(value)):
        raise DataError(f"{name}: metadata {key} = {text!r} is not {what}")
    return value


def recorded_fs(frf: Frf, name: str | None = None) -> float | None:
    """The sample rate [Hz] an FRF records (``sampling_fs_hz``), or None when it records none.

    Parameters
    ----------
    frf : Frf
    name : str, optional
        File name used in messages (default ``frf.source``).

    Raises
    ------
    DataError
        The record is not a sample rate > 0 Hz.
    """
    return _recorded_number(frf, SAMPLING_FS_KEY, frf.source if name is None else name, "a sample rate > 0 Hz",
                            lambda v: v > 0)


def recorded_delay(frf: Frf, name: str | None = None) -> float | None:
    """The computational delay [samples] divided out of an FRF (``sampling_delay_samples``), or None.

    Raises
    ------
    DataError
        The record is not a number of samples >= 0.
    """
    return _recorded_number(frf, SAMPLING_DELAY_KEY, frf.source if name is None else name,
                            "a number of samples >= 0", lambda v: v >= 0)


def rates_disagree(fs: float, recorded: float) -> bool:
    """True when a sample rate ``fs`` [Hz] differs from a ``recorded`` one [Hz] by more than :data:`FS_TOLERANCE`
    of the recorded rate."""
    return abs(fs - recorded) > FS_TOLERANCE * recorded


def band_warning(frf: Frf, fs: float, name: str | None = None) -> str | None:
    """One-line warning when an FRF ends far below the Nyquist frequency of the target, else None.

    The rule: the last line ``f_max`` [Hz] is below ``NYQUIST_FRACTION * fs / 2``; above ``f_max`` the measured and
    discrete analysis cases (and every check on them) rest on the model alone.

    Parameters
    ----------
    frf : Frf
    fs : float
        Sample rate of the target [Hz].
    name : str, optional
        File name used in the message (default ``frf.source``).
    """
    f_max = float(frf.freq_hz[-1])
    nyquist = fs / 2
    if f_max >= NYQUIST_FRACTION * nyquist:
        return None
    label = frf.source if name is None else name
    return (f"{label}: the FRF ends at {f_max:g} Hz, far below the Nyquist frequency {nyquist:g} Hz of "
            f"fs = {fs:g} Hz; the loop above it rests on the model")
