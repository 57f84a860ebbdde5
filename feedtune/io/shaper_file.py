"""The input shaper in files: the ``[shaper]`` section of a gains file, and the shaper document of an axis without one.

``[shaper]`` holds the shaper's definition and, in a gains file, its taps at the file's sample rate -- what the
runtime, the twin and the C header execute (:class:`~feedtune.control.shapers.SampledShaper`)::

    [shaper]
    type = "ei"                      # zv, mzv, zvd, ei, 2hump_ei, 3hump_ei (Klipper's names)
    freq_hz = {value = 116.3, unit = "Hz"}
    damping = 0.03                   # damping ratio the shaper is designed for [-]
    vibration_tolerance = 0.05       # V of the EI family [-]
    amplitudes = [...]               # [-], summing to 1
    times_s = [...]                  # [s], the first 0
    execution = "..."
    [shaper.taps]                    # gains files only
    fs_hz = {value = 20000.0, unit = "Hz"}
    delays = [0, 86, 87, 172, 173]   # [samples]
    weights = [...]                  # [-], summing to 1
    [shaper.choice]                  # information: how design shaper chose it (modes, figures)

The taps act on the previewed reference before every reference path (pre-filter, friction feedforward included):
outside the feedback loop, so adding a shaper keeps a gains file's certificate valid
(:data:`feedtune.io.gains_certificate.UNCERTIFIED_SECTIONS`). A shaper document (``schema = "feedtune.shaper/1"``,
``kind = "shaper"``, ``axis = "x"``) carries the same section without taps, for targets that run their own shaper
(Klipper, Marlin: :mod:`feedtune.export.printer`).
"""

from __future__ import annotations

import copy
import math
from collections.abc import Mapping

import numpy as np

from .. import __version__
from ..control.shapers import SHAPER_TYPES, VIBRATION_TOLERANCE, InputShaper, SampledShaper
from ..errors import DataError, UsageError

SHAPER_SCHEMA = "feedtune.shaper/1"
"""The schema of a shaper document."""
SHAPER_KIND = "shaper"
AXES = ("x", "y", "z")
"""Axis names a shaper document may carry (the printers' axes)."""
EXECUTION = ("x_s[k+P] = sum_j weights[j] x_r[k+P-delays[j]] (zero history at start), then every reference path "
             "(pre-filter, feedforward, friction feedforward) runs on x_s instead of x_r")
MAX_TAP_SECONDS = 10.0
"""Longest shaper a file may hold [s]: the ring buffer of a target holds this much history at most."""


def _number(raw, where: str, unit: str | None = None) -> float:
    from .gains import value

    return value(raw, where, unit)


def _vector(raw, where: str) -> np.ndarray:
    try:
        a = np.asarray(raw, dtype=float)
    except (TypeError, ValueError):
        raise DataError(f"{where}: expected a list of numbers") from None
    if a.ndim != 1 or a.size == 0 or not np.all(np.isfinite(a)):
        raise DataError(f"{where}: expected a non-empty list of finite numbers")
    return a


def shaper_section(shaper: InputShaper, fs: float | None = None, choice: Mapping | None = None) -> dict:
    """The ``[shaper]`` section (module docstring): the definition, the taps at ``fs`` [Hz] when given, and the
    ``choice`` record when given."""
    sec: dict = {
        "type": shaper.kind,
        "freq_hz": {"value": shaper.freq_hz, "unit": "Hz"},
        "damping": shaper.damping,
        "vibration_tolerance": VIBRATION_TOLERANCE,
        "amplitudes": [float(a) for a in shaper.amplitudes],
        "times_s": [float(t) for t in shaper.times_s],
    }
    if fs is not None:
        taps = shaper.sampled(fs)
        sec["execution"] = EXECUTION
        sec["taps"] = {"fs_hz": {"value": float(fs), "unit": "Hz"}, "delays": taps.delays.tolist(),
                       "weights": taps.weights.tolist()}
    if choice is not None:
        sec["choice"] = dict(choice)
    return sec


def read_shaper_section(sec, where: str) -> InputShaper:
    """The :class:`~feedtune.control.shapers.InputShaper` of a ``[shaper]`` section (checked: a known type, a frequency
    > 0, a damping ratio in [0, 1), amplitudes summing to 1 at increasing times from 0)."""
    if not isinstance(sec, Mapping):
        raise DataError(f"{where}: [shaper] must be a table")
    kind = sec.get("type")
    if kind not in SHAPER_TYPES:
        raise DataError(f"{where}: shaper.type must be one of {', '.join(SHAPER_TYPES)}, got {kind!r}")
    freq = _number(sec.get("freq_hz"), f"{where}: shaper.freq_hz", "Hz")
    damping = _number(sec.get("damping"), f"{where}: shaper.damping")
    if not freq > 0:
        raise DataError(f"{where}: shaper.freq_hz must be > 0 Hz, got {freq:g}")
    if not 0 <= damping < 1:
        raise DataError(f"{where}: shaper.damping must be in [0, 1), got {damping:g}")
    a = _vector(sec.get("amplitudes"), f"{where}: shaper.amplitudes")
    t = _vector(sec.get("times_s"), f"{where}: shaper.times_s")
    if a.size != t.size:
        raise DataError(f"{where}: shaper.amplitudes has {a.size} entries, shaper.times_s {t.size}")
    if abs(a.sum() - 1.0) > 1e-9:
        raise DataError(f"{where}: shaper.amplitudes must sum to 1, got {a.sum():.12g}")
    if t[0] != 0.0 or np.any(np.diff(t) <= 0) or t[-1] > MAX_TAP_SECONDS:
        raise DataError(f"{where}: shaper.times_s must start at 0 and increase, within {MAX_TAP_SECONDS:g} s [s]")
    return InputShaper(str(kind), freq, damping, a, t)


def read_shaper_taps(doc: Mapping, where: str = "gains file") -> SampledShaper | None:
    """The taps a gains document's ``[shaper]`` makes the target run, or None without a ``[shaper]``.

    Raises
    ------
    DataError
        A ``[shaper]`` without taps, taps for another sample rate than ``[sampling].fs_hz``, or malformed taps.
    """
    sec = doc.get("shaper")
    if sec is None:
        return None
    read_shaper_section(sec, where)
    taps = sec.get("taps")
    if not isinstance(taps, Mapping):
        raise DataError(f"{where}: [shaper] has no [shaper.taps] (delays and weights at the file's sample rate); "
                        "add the shaper with feedtune design shaper --gains")
    fs = _number(taps.get("fs_hz"), f"{where}: shaper.taps.fs_hz", "Hz")
    fs_file = _number((doc.get("sampling") or {}).get("fs_hz"), f"{where}: sampling.fs_hz", "Hz")
    if not math.isclose(fs, fs_file, rel_tol=1e-9):
        raise DataError(f"{where}: shaper.taps are for fs = {fs:g} Hz, the gains for {fs_file:g} Hz")
    d = _vector(taps.get("delays"), f"{where}: shaper.taps.delays")
    w = _vector(taps.get("weights"), f"{where}: shaper.taps.weights")
    if d.size and d[-1] > MAX_TAP_SECONDS * fs:
        raise DataError(f"{where}: shaper.taps.delays reach {d[-1]:g} samples, beyond {MAX_TAP_SECONDS:g} s")
    try:
        return SampledShaper(d, w, fs)
    except UsageError as exc:
        raise DataError(f"{where}: {exc}") from None


def with_shaper(doc: Mapping, shaper: InputShaper, *, choice: Mapping | None = None,
                where: str = "gains file") -> dict:
    """A copy of a gains document (any kind) with a ``[shaper]`` at its sample rate (replacing any)."""
    from .gains import read_sampling

    fs, _, _ = read_sampling(dict(doc), where)
    out = copy.deepcopy(dict(doc))
    out["shaper"] = shaper_section(shaper, fs, choice)
    return out


def shaper_document(shaper: InputShaper, axis: str = "x", choice: Mapping | None = None) -> dict:
    """A shaper document for an axis (module docstring)."""
    if axis not in AXES:
        raise UsageError(f"axis must be one of {', '.join(AXES)}, got {axis!r}", parameter="axis")
    return {"schema": SHAPER_SCHEMA, "kind": SHAPER_KIND, "axis": axis, "created_by": f"feedtune {__version__}",
            "shaper": shaper_section(shaper, None, choice)}


def read_shaper(doc: Mapping, where: str) -> tuple[InputShaper, str | None]:
    """``(shaper, axis)`` of a shaper document or of a gains document's ``[shaper]`` (axis None for a gains file).

    Raises
    ------
    DataError
        Neither a shaper document nor a document with a ``[shaper]``.
    """
    if doc.get("kind") == SHAPER_KIND:
        if doc.get("schema") != SHAPER_SCHEMA:
            raise DataError(f"{where}: schema {doc.get('schema')!r} is not {SHAPER_SCHEMA!r}")
        axis = doc.get("axis", "x")
        if axis not in AXES:
            raise DataError(f"{where}: axis must be one of {', '.join(AXES)}, got {axis!r}")
        return read_shaper_section(doc.get("shaper"), where), str(axis)
    if doc.get("shaper") is None:
        raise DataError(f"{where}: no [shaper] section (write one with feedtune design shaper)")
    return read_shaper_section(doc["shaper"], where), None
