"""Merge logs recorded by different instruments into one :class:`~feedtune.log.Log` on a common time base.

A servo amplifier's trace and a DAQ's load-cell channel rarely share a clock: different rates, a start-up shift,
a sensor offset to take off, a speed instead of a position. :func:`merge_logs` does, per signal and in this order:

1. time shift: the signal's time stamps plus ``shift_s[name]`` [s] (a DAQ that started 4 ms late gets +0.004);
2. offset: subtract a constant, given as a number or as ``"mean:N"`` (the mean of the signal's first ``N``
   samples, e.g. a load cell's zero before the motion);
3. scale: multiply by ``scale[name]`` (e.g. -200 N/V for a load cell, -20e-3/60 m/s per rpm);
then it puts every signal on one time base:

4. the common base runs over the span every signal covers (the latest start to the earliest end), uniformly at
   ``fs`` [Hz] (default: the lowest rate among the logs, so that nothing is invented between samples);
5. a signal sampled faster than the base is low-passed first (zero-phase 4th-order Butterworth at 0.4 times the
   base rate, so the base's Nyquist band is not aliased), then every signal is interpolated (modified Akima cubic) at
   the base's time stamps (:func:`feedtune.log_resample.resample_signal`, the one home of this rule);
6. ``integrate[new] = name`` adds the running integral (trapezoidal, starting at 0) of a signal on the base, e.g.
   a position from a measured speed for the commands that need a position (unit: the speed's unit without
   ``/s``).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from .budget import check_memory
from .errors import DataError, UsageError
from .log import Log
from .log_resample import ANTI_ALIAS_FRACTION, resample_signal, uniform_instants

__all__ = ["ANTI_ALIAS_FRACTION", "merge_logs"]

FS_MAX_HZ = 10e6
"""Highest sample rate of a merged log [Hz] (the plausible rates of :mod:`feedtune.io.log_read`)."""


@dataclass(frozen=True)
class _Signal:
    name: str
    t: np.ndarray
    x: np.ndarray
    unit: str
    fs: float
    source: str


def _offset_value(spec, x: np.ndarray, name: str) -> float:
    """The constant to subtract: a number, or ``"mean:N"`` (mean of the first ``N`` samples)."""
    if isinstance(spec, str):
        head, _, count = spec.partition(":")
        if head.strip() != "mean" or not count.strip().isdigit() or int(count) < 1:
            raise UsageError(f"offset of {name!r}: expected a number or 'mean:N' (N >= 1 samples), got {spec!r}",
                             parameter="offset")
        n = int(count)
        if n > x.size:
            raise DataError(f"offset of {name!r}: 'mean:{n}' needs {n} samples, the signal has {x.size}",
                            parameter="offset")
        return float(np.mean(x[:n]))
    value = float(spec)
    if not np.isfinite(value):
        raise UsageError(f"offset of {name!r} must be finite, got {spec!r}", parameter="offset")
    return value


def _integral_unit(unit: str, name: str) -> str:
    for suffix in ("/s", "/ s"):
        if unit.endswith(suffix):
            return unit[: -len(suffix)].strip()
    raise DataError(f"integrate {name!r}: its unit {unit!r} is not a rate (.../s); give it with a unit such as m/s "
                    "or rad/s (scale it first, e.g. rpm to rad/s)")


def _collect(logs: Sequence[Log], shift_s: Mapping[str, float]) -> list[_Signal]:
    signals: dict[str, _Signal] = {}
    for log in logs:
        if not log.is_uniform():
            raise DataError(f"{log.source}: the time stamps are not uniform; merge needs uniformly sampled logs")
        for name, x in log.signals.items():
            if name in signals:
                raise DataError(f"signal {name!r} is in {signals[name].source} and in {log.source}; rename one "
                                "when reading it (mapping=) so every signal of the merged log has one source",
                                parameter="read_log.mapping")
            shift = float(shift_s.get(name, 0.0))
            signals[name] = _Signal(name, log.t + shift, x, log.unit(name), log.fs, log.source)
    for name in shift_s:
        if name not in signals:
            raise DataError(f"shift_s: no signal {name!r} in the logs (signals: {', '.join(sorted(signals))})",
                            parameter="shift_s")
    return list(signals.values())


def merge_logs(logs: Sequence[Log], *, fs: float | None = None, shift_s: Mapping[str, float] | None = None,
               offset: Mapping[str, float | str] | None = None, scale: Mapping[str, float] | None = None,
               units: Mapping[str, str] | None = None, integrate: Mapping[str, str] | None = None) -> Log:
    """Merge logs onto one uniform time base (module docstring).

    Parameters
    ----------
    logs : sequence of Log
        Uniformly sampled logs; every signal name must occur once over all of them.
    fs : float, optional
        Sample rate of the merged log [Hz]; default the lowest rate among the logs.
    shift_s : dict of str to float, optional
        Time shift per signal [s], added to its time stamps.
    offset : dict of str to (float or str), optional
        Constant subtracted per signal [its unit], or ``"mean:N"``.
    scale : dict of str to float, optional
        Factor per signal, applied after the offset.
    units : dict of str to str, optional
        Unit per signal after scaling (default: the log's unit when not scaled or scaled by +-1, else unknown,
        ``""``).
    integrate : dict of str to str, optional
        ``{new_name: signal}``: a running integral of ``signal`` on the common base.

    Returns
    -------
    Log
        The merged log; ``meta["merge"]`` says what was done to which signal.

    Raises
    ------
    UsageError
        Bad offsets, a sample rate outside (0, 10 MHz], a base that would exceed the memory budget.
    DataError
        Options naming no signal of the logs, a signal twice, logs that do not overlap in time, a rate to
        integrate without a ``/s`` unit.
    """
    if not logs:
        raise UsageError("merge_logs needs at least one log")
    shift_s, offset, scale = dict(shift_s or {}), dict(offset or {}), dict(scale or {})
    units, integrate = dict(units or {}), dict(integrate or {})
    sigs = _collect(logs, shift_s)
    names = {s.name for s in sigs}
    for what, table in (("offset", offset), ("scale", scale), ("units", units)):
        unknown = sorted(set(table) - names)
        if unknown:
            raise DataError(f"{what}: no signal {unknown[0]!r} in the logs (signals: {', '.join(sorted(names))})",
                            parameter=what)
    rate = min(s.fs for s in sigs) if fs is None else float(fs)
    if not (np.isfinite(rate) and 0 < rate <= FS_MAX_HZ):
        raise UsageError(f"fs must be a sample rate in (0, {FS_MAX_HZ:g}] Hz, got {fs!r}", parameter="fs")
    start, end = max(s.t[0] for s in sigs), min(s.t[-1] for s in sigs)
    if end - start < 2.0 / rate:
        spans = "; ".join(f"{s.name} {s.t[0]:.6g}-{s.t[-1]:.6g} s" for s in sigs)
        after = " after shift_s" if shift_s else ""
        raise DataError(f"the logs do not overlap in time{after} ({spans})", parameter="shift_s" if shift_s else None)
    n = (end - start) * rate
    check_memory(n * 8.0 * (4 + len(sigs) + len(integrate)), f"merging {len(sigs)} signals over {end - start:.6g} s "
                 f"at fs={rate:g} Hz ({n:.3g} samples)", parameter="fs")
    t = uniform_instants(start, end, rate)
    out: dict[str, np.ndarray] = {}
    out_units: dict[str, str] = {}
    steps: dict[str, str] = {}
    for s in sigs:
        x = s.x
        done = []
        if s.name in shift_s:
            done.append(f"shifted {shift_s[s.name]:+g} s")
        if s.name in offset:
            c = _offset_value(offset[s.name], x, s.name)
            x = x - c
            done.append(f"offset {c:.6g} {s.unit}".rstrip() + f" removed ({offset[s.name]})")
        if s.name in scale:
            x = x * float(scale[s.name])
            done.append(f"scaled by {float(scale[s.name]):g}")
        out[s.name] = resample_signal(s.t, x, t, rate, f"{s.source}: signal {s.name!r}")
        keeps_unit = s.name not in scale or abs(float(scale[s.name])) == 1.0  # a sign flip keeps the unit
        out_units[s.name] = units.get(s.name, s.unit if keeps_unit else "")
        done.append(f"from {s.fs:.6g} Hz ({s.source})")
        steps[s.name] = ", ".join(done)
    for new, name in integrate.items():
        if name not in out:
            raise DataError(f"integrate {new}={name}: no signal {name!r} in the logs", parameter="integrate")
        if new in out:
            raise DataError(f"integrate {new}={name}: a signal {new!r} exists already", parameter="integrate")
        x = out[name]
        out[new] = np.concatenate([[0.0], np.cumsum((x[1:] + x[:-1]) * 0.5) / rate])
        out_units[new] = _integral_unit(out_units[name], name)
        steps[new] = f"running integral of {name} (trapezoidal, 0 at {t[0]:.6g} s)"
    source = " + ".join(log.source for log in logs)
    meta = {"source": f"merged: {source}", "merge": steps, "fs_hz": rate}
    return Log(t, out, out_units, meta)

