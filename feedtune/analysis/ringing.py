"""How much a mode still rings after a move: the measured counterpart of a shaper's residual vibration.

:func:`ringing_after` band-passes a logged position around the mode's frequency ``f`` (a second-order Butterworth
band ``[f / BAND, f BAND]``, run forwards and backwards: no phase shift) and takes its RMS over
:data:`WINDOW_PERIODS` periods starting :data:`START_PERIODS` periods after the command ends (the band-pass's own
transient of the move has died out by then). The move's slow settling and the other modes fall outside the band.
Comparing two runs, each measured from the end of its own command (a shaped command ends the shaper's duration
later), gives the ratio a shaper's residual vibration ``V`` predicts: the mode decays at the same rate in both, so the
ratio does not depend on where the window starts.
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import DataError, UsageError

BAND = 1.2
"""The band-pass keeps ``[f / BAND, f BAND]`` [-] (a wider band lets neighbouring modes in: the gantry's 320 Hz mode
beside its 383 Hz one)."""
START_PERIODS = 2.0
"""The window starts this many periods of the mode after the command ends [-]."""
WINDOW_PERIODS = 10.0
"""Length of the window [periods of the mode]."""


def ringing_after(t, y, t_end: float, freq_hz: float) -> float:
    """RMS of ``y`` band-passed around ``freq_hz`` after the command ended at ``t_end`` (module docstring) [unit of
    ``y``].

    Parameters
    ----------
    t : array_like
        Uniform time [s].
    y : array_like
        The load's position (or error) [m].
    t_end : float
        When the command reached its end position [s].
    freq_hz : float
        The mode [Hz].

    Raises
    ------
    DataError
        A log that ends before the window does, or a mode above the Nyquist frequency.
    """
    from scipy.signal import butter, sosfiltfilt

    t = np.asarray(t, float)
    y = np.asarray(y, float)
    if t.size < 16 or t.size != y.size:
        raise DataError("ringing_after needs a uniformly sampled log of at least 16 samples, t and y equally long")
    fs = 1.0 / float(np.median(np.diff(t)))
    if not (math.isfinite(freq_hz) and 0 < freq_hz * BAND < fs / 2):
        raise UsageError(f"mode {freq_hz!r} Hz: the band around it must lie below the Nyquist frequency {fs / 2:g} Hz",
                         parameter="freq_hz")
    start, stop = t_end + START_PERIODS / freq_hz, t_end + (START_PERIODS + WINDOW_PERIODS) / freq_hz
    if stop > t[-1]:
        raise DataError(f"the log ends at {t[-1]:.4g} s, before the ringing window {start:.4g}-{stop:.4g} s after the "
                        f"command ended at {t_end:.4g} s: record {stop - t[-1]:.3g} s longer")
    sos = butter(2, [freq_hz / BAND, freq_hz * BAND], btype="bandpass", fs=fs, output="sos")
    band = sosfiltfilt(sos, y)
    sel = (t >= start) & (t <= stop)
    return float(np.sqrt(np.mean(band[sel] ** 2)))
