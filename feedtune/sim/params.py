"""Checks and ``--param NAME=VALUE`` overrides shared by every twin's parameters."""

from __future__ import annotations

import math

from ..errors import UsageError


def finite_param(v, name: str) -> float:
    """``v`` as a float; UsageError naming the twin parameter when it is not a finite number."""
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
        raise UsageError(f"twin parameter {name} must be a finite number, got {v!r}")
    return float(v)


def positive_param(v, name: str, unit: str = "") -> float:
    """``v`` as a float > 0; UsageError naming the twin parameter and its unit otherwise."""
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or v <= 0:
        raise UsageError(f"twin parameter {name} must be a finite number > 0 {unit}".rstrip() + f", got {v!r}")
    return float(v)


def non_negative_param(v, name: str) -> float:
    """``v`` as a float >= 0; UsageError naming the twin parameter otherwise."""
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or v < 0:
        raise UsageError(f"twin parameter {name} must be a finite number >= 0, got {v!r}")
    return float(v)


def parse_override_value(raw, key: str):
    """A ``--param NAME=VALUE`` value: a number (int when integral text), or None for none/off/null.

    Raises
    ------
    UsageError
        Neither a number nor none/off/null (names the parameter).
    """
    if raw is None or (isinstance(raw, (int, float)) and not isinstance(raw, bool)):
        return raw
    text = str(raw).strip()
    if text.lower() in ("none", "off", "null"):
        return None
    try:
        return int(text) if text.lstrip("+-").isdigit() else float(text)
    except ValueError:
        raise UsageError(f"twin parameter {key}: expected a number or 'none', got {raw!r}") from None


def positive_setting(v, name: str, unit: str, parameter: str | None = None) -> float:
    """An experiment setting ``v`` as a float > 0; UsageError naming the setting and its unit otherwise (carrying
    ``parameter``, the library parameter the command line names by its option)."""
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or v <= 0:
        raise UsageError(f"{name} must be a finite number > 0 {unit}, got {v!r}", parameter=parameter)
    return float(v)


MAX_EXCITATION_RMS = 1e3
"""Largest excitation RMS [command unit] of an FRF run: a drive's command spans volts to a few hundred amperes."""


def excitation_settings(fs: float, rms, f_lo, f_hi, period_s, periods, *, blocks: int = 1,
                        u_max: float | None = None) -> tuple[float, float, float, float, int]:
    """The settings of a periodic FRF excitation checked, and the memory of the run it implies checked against the
    budget (:mod:`feedtune.budget`) before anything is allocated: ``(rms, f_lo, f_hi, period_s, periods)``.

    Parameters
    ----------
    fs : float
        The twin's sample rate [Hz].
    rms, f_lo, f_hi, period_s, periods
        RMS [command unit] (at most ``u_max``, the command saturation, when there is one, and
        :data:`MAX_EXCITATION_RMS`), excited band [Hz] (``f_lo < f_hi < fs/2``), period [s] (at least 16 samples) and
        number of periods (>= 2, the first is dropped).
    blocks : int
        Runs of ``periods`` periods one after the other (the gantry excites one input after the other).
    u_max : float, optional
        The command saturation [command unit].

    Raises
    ------
    UsageError
        Naming the parameter (``rms``, ``f_lo``, ``f_hi``, ``period_s``, ``periods``).
    """
    from ..budget import TWIN_SAMPLE_BYTES, check_memory
    from .excitations import period_samples

    rms = positive_setting(rms, "rms", "V", "rms")
    limit = MAX_EXCITATION_RMS if u_max is None else min(u_max, MAX_EXCITATION_RMS)
    if rms > limit:
        why = f"the command saturation u_max = {u_max:g}" if u_max is not None and u_max <= MAX_EXCITATION_RMS else \
            f"{MAX_EXCITATION_RMS:g}, beyond any drive's command"
        raise UsageError(f"rms={rms:g} is above {why}: the excitation would saturate the drive", parameter="rms")
    f_lo, f_hi = positive_setting(f_lo, "f_lo", "Hz", "f_lo"), positive_setting(f_hi, "f_hi", "Hz", "f_hi")
    period_s = positive_setting(period_s, "period_s", "s", "period_s")
    if not f_lo < f_hi < fs / 2:
        raise UsageError(f"the excited band needs f_lo < f_hi < fs/2 = {fs / 2:g} Hz, got f_lo={f_lo:g}, "
                         f"f_hi={f_hi:g}", parameter=("f_lo", "f_hi"))
    if isinstance(periods, bool) or not isinstance(periods, (int, float)) or int(periods) != periods or periods < 2:
        raise UsageError(f"periods must be an integer >= 2 (the first is dropped), got {periods!r}",
                         parameter="periods")
    period_samples(fs, period_s)
    n = period_s * fs * periods * blocks
    check_memory(n * TWIN_SAMPLE_BYTES, f"period_s={period_s:g} s x periods={int(periods)} at {fs:g} Hz ({n:.3g} "
                 "samples)", parameter=("period_s", "periods"))
    return rms, f_lo, f_hi, period_s, int(periods)


def release_settings(fs: float, force, t_release, after_s, record_before_s, *, unit: str = "V",
                     force_parameter: str = "run_ropesnap.force", hold_limit: float | None = None
                     ) -> tuple[float, float, float, float]:
    """The settings of a rope snap checked, and the memory of its run checked against the budget before anything
    is allocated: ``(force, t_release, after_s, record_before_s)`` (see the machines' ``run_ropesnap``).

    ``hold_limit`` is the largest force the drive can hold [``unit``] (at its command saturation), None for none.

    Raises
    ------
    UsageError
        Naming the parameter (``force``, ``t_release``, ``after_s``).
    """
    from ..budget import TWIN_SAMPLE_BYTES, check_memory

    force = positive_setting(force, "force", unit, force_parameter)
    if hold_limit is not None and force > hold_limit:
        word = force_parameter.rsplit(".", 1)[-1]
        raise UsageError(f"{word}={force:g} {unit} is more than the drive can hold ({hold_limit:.4g} {unit} at its "
                         "command saturation u_max)", parameter=force_parameter)
    t_release = positive_setting(t_release, "t_release", "s", "t_release")
    after_s = positive_setting(after_s, "after_s", "s", "after_s")
    record_before_s = positive_setting(record_before_s, "record_before_s", "s", "record_before_s")
    if t_release < 0.1 + record_before_s:
        raise UsageError(f"t_release must leave the 0.1 s preload ramp and {record_before_s:g} s of record before "
                         f"it, i.e. be >= {0.1 + record_before_s:g} s, got {t_release:g}", parameter="t_release")
    n = (t_release + after_s) * fs
    check_memory(n * TWIN_SAMPLE_BYTES, f"a rope snap of t_release={t_release:g} s + after_s={after_s:g} s at "
                 f"{fs:g} Hz ({n:.3g} samples)", parameter=("t_release", "after_s"))
    return force, t_release, after_s, record_before_s
