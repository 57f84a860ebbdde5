"""Logs from ASAM MDF4 files (``.mf4``/``.mdf``) via asammdf, an optional extra (``feedtune[mdf]``).

Channels of different groups may have different time stamps. The log's time base is the time stamps of
the first mapped channel (or, without a mapping, of the channel with the most samples); with ``fs`` it
is a uniform grid ``t0 + arange(n) / fs`` over the span all channels cover. Channels on other time
stamps are linearly interpolated onto the time base.
"""

from __future__ import annotations

import os
from collections.abc import Sequence

import numpy as np

from ..errors import DataError
from ._table import check_readable_file
from .log_read import RawLog

MDF_EXTRA_MESSAGE = "reading MDF4 needs the optional extra: pip install 'feedtune[mdf]'"


def _import_asammdf(path: str):
    try:
        import asammdf
    except ImportError:
        raise DataError(f"{path}: {MDF_EXTRA_MESSAGE}") from None
    return asammdf


PROBE_TIMEOUT_S = 300.0
"""Longest time the crash probe may read a file [s]."""


def _probe(path: str) -> None:
    """Read the file once in a child process first: asammdf crashes the process (a segmentation fault) on some
    corrupt files instead of raising, which would end the caller without a word. A crash there is a DataError
    here; any other outcome leaves the reading (and its error message) to the caller's process."""
    import subprocess
    import sys

    code = ("import sys, asammdf\n"
            "with asammdf.MDF(sys.argv[1]) as m:\n"
            "    for s in m.iter_channels(skip_master=True):\n"
            "        s.samples, s.timestamps\n")
    try:
        res = subprocess.run([sys.executable, "-c", code, path], capture_output=True, timeout=PROBE_TIMEOUT_S)
    except subprocess.TimeoutExpired:
        raise DataError(f"{path}: the MDF reader did not finish within {PROBE_TIMEOUT_S:g} s") from None
    except OSError:
        return
    if res.returncode < 0:
        raise DataError(f"{path}: the MDF reader crashed on this file (signal {-res.returncode}): the file is "
                        "corrupt") from None


def _numeric_signals(path: str, channels: Sequence[str] | None) -> list:
    import gc
    import sys

    asammdf = _import_asammdf(path)
    _probe(path)
    hook = sys.unraisablehook
    sys.unraisablehook = lambda _: None  # a half-built asammdf object's __del__ prints a traceback on corrupt files
    failed = None
    try:
        with asammdf.MDF(path) as mdf:
            found = [s for s in mdf.iter_channels(skip_master=True)
                     if s.samples.ndim == 1 and s.samples.dtype.kind in "biuf" and s.samples.size >= 2]
    except DataError:
        raise
    except Exception as exc:  # the message is kept, the exception (whose traceback holds the object) let go
        failed = f"{path}: not a readable MDF file ({' '.join(str(exc).split())[:100]})"
    finally:
        gc.collect()  # the half-built object dies here, while its __del__ is silenced
        sys.unraisablehook = hook
    if failed is not None:
        raise DataError(failed)
    unique: dict[str, object] = {}
    for s in found:
        unique.setdefault(s.name, s)
    if channels:
        missing = [c for c in channels if c not in unique]
        if missing:
            raise DataError(f"{path}: no channel {missing[0]!r}; channels: {', '.join(unique) or 'none'}")
        return [unique[c] for c in dict.fromkeys(channels)]
    if not unique:
        raise DataError(f"{path}: no numeric channels in the MDF file")
    return list(unique.values())


def _time_base(signals: list, fs: float | None, name: str) -> np.ndarray:
    if fs is None:
        ref = signals[0] if len(signals) == 1 else max(signals, key=lambda s: s.timestamps.size)
        return np.asarray(ref.timestamps, dtype=float)
    t0 = max(float(s.timestamps[0]) for s in signals)
    t1 = min(float(s.timestamps[-1]) for s in signals)
    n = int(np.floor((t1 - t0) * fs + 1e-9)) + 1
    if n < 2:
        raise DataError(f"{name}: the channels share less than two samples at fs = {fs:g} Hz")
    return t0 + np.arange(n) / fs


def read_log_mdf_raw(path: str | os.PathLike[str], *, channels: Sequence[str] | None = None,
                     fs: float | None = None) -> RawLog:
    """Read numeric channels of an MDF4 file onto one time base (see module docstring).

    Parameters
    ----------
    path : path-like
        The ``.mf4`` file.
    channels : sequence of str, optional
        Channels to read (default all numeric 1-D channels); the first one sets the time base.
    fs : float, optional
        Resample every channel onto a uniform grid at this rate [Hz].
    """
    p = str(check_readable_file(path))
    signals = _numeric_signals(p, channels)
    if channels:
        signals.sort(key=lambda s: 0 if s.name == channels[0] else 1)
    t = _time_base(signals, fs, p)
    columns, units, resampled = {}, {}, []
    for s in signals:
        ts = np.asarray(s.timestamps, dtype=float)
        x = np.asarray(s.samples, dtype=float)
        if ts.shape == t.shape and np.array_equal(ts, t):
            columns[s.name] = x
        else:
            columns[s.name] = np.interp(t, ts, x)
            resampled.append(s.name)
        units[s.name] = str(s.unit or "")
    meta: dict[str, object] = {"format": "mdf4"}
    if resampled:
        meta["resampled"] = ", ".join(resampled)
    return RawLog(p, columns, units, meta, None, t)
