"""Checks of a log's raw channels that make an identification from it unreliable, as warning lines.

Each check looks at what a least-squares fit cannot see in its own residual: a position quantized coarsely for the
motion (double differentiation turns each step into an acceleration spike: the mass comes out far too small), a
command clipped at its limits (the fit then sees a force the drive did not produce), and a poor fit.
"""

from __future__ import annotations

import numpy as np

from ..errors import Notice

MIN_LEVELS = 2000
"""A position column should take at least this many quantization steps over the stroke [-]."""
MIN_STEPS_PER_SAMPLE_MOTION = 4.0
"""... and the motion per sample while moving (the 90th percentile of ``|x[k+1] - x[k]|``) should exceed this many
steps [-] (else velocity and acceleration by differentiation are a train of single steps)."""
CLIP_FRACTION = 0.01
"""Share of samples at the command's extreme values that counts as clipping [-]."""
POOR_FIT_PCT = 20.0
"""Relative error of a fit above which it is called poor [%]."""
POOR_STD = 0.1
"""Relative standard deviation of a parameter above which it is called poorly determined [-]."""


def _codes(x: np.ndarray) -> tuple[np.ndarray | None, float]:
    """``x`` as integer codes of ``span * 1e-9`` (values equal to rounding error merged; integer codes, at most 1e9,
    sort ~3x faster than the floats) and that unit; ``(None, 0)`` for an empty or constant signal."""
    x = np.asarray(x, float)
    span = float(np.ptp(x)) if x.size else 0.0
    if span <= 0:
        return None, 0.0
    return np.round((x - x.min()) / (span * 1e-9)).astype(np.int64), span * 1e-9


def _step_of_codes(codes: np.ndarray, unit: float) -> float:
    """The quantization step of a sampled signal given as its :func:`_codes`: the smallest non-zero difference
    between sorted distinct values (0 for a continuous-valued signal or one with fewer than 3 distinct values)."""
    v = np.unique(codes) * unit
    if v.size < 3:
        return 0.0
    d = np.diff(v)
    d = d[d > 0]
    step = float(np.min(d))
    # a continuous-valued signal has near-unique values: its smallest gap is far below its typical gap
    return step if step > 0.5 * float(np.median(d)) else 0.0


def quantization_warning(x: np.ndarray, name: str, unit: str) -> str | None:
    """A warning when the position ``x`` [unit] is quantized coarsely for its motion, else None."""
    x = np.asarray(x, float)
    moves = float(np.percentile(np.abs(np.diff(x)), 90)) if x.size > 1 else 0.0
    span = float(np.ptp(x)) if x.size else 0.0
    codes, code_unit = _codes(x)
    if codes is None:
        return None
    # the step (the smallest gap between distinct values) is at most the smallest change between two samples: when
    # even that change passes both rules, the step does too, and the distinct values need not be found (a sort)
    steps = np.abs(np.diff(codes))
    steps = steps[steps > 0]
    if steps.size:
        bound = float(steps.min()) * code_unit
        if span / bound >= MIN_LEVELS and moves / bound >= MIN_STEPS_PER_SAMPLE_MOTION:
            return None
    q = _step_of_codes(codes, code_unit)
    if q <= 0:
        return None
    levels = span / q
    per_sample = moves / q
    if levels >= MIN_LEVELS and per_sample >= MIN_STEPS_PER_SAMPLE_MOTION:
        return None
    return Notice(f"{name} is quantized to {q:.3g} {unit} ({levels:.0f} steps over the stroke, {per_sample:.2g} "
                  "steps per sample while moving): velocity and acceleration by differentiation are dominated by the "
                  "steps, so the mass and friction are unreliable; use a finer encoder column or a lower cutoff_hz",
                  parameter="cutoff_hz")


def clipping_warning(u: np.ndarray, name: str, unit: str) -> str | None:
    """A warning when the command ``u`` sits at its extreme values in more than :data:`CLIP_FRACTION` of the
    samples (saturation), else None; not for a two-level command (a step or a binary excitation, fewer than
    :data:`CLIP_FRACTION` of its samples between the two levels), whose levels the experiment set."""
    u = np.asarray(u, float)
    if u.size < 100:
        return None
    lo, hi = float(np.min(u)), float(np.max(u))
    span = hi - lo
    if span <= 0:
        return None
    tol = 1e-9 * max(abs(lo), abs(hi), span)
    at_hi, at_lo = np.abs(u - hi) <= tol, np.abs(u - lo) <= tol
    share = float(np.mean(at_hi | at_lo))
    # clipping: a plateau at an extreme (runs of equal samples), not a single peak sample
    if share < CLIP_FRACTION or max(int(at_hi.sum()), int(at_lo.sum())) < 5 or 1.0 - share < CLIP_FRACTION:
        return None
    return (f"{name} sits at its extremes ({lo:.4g} / {hi:.4g} {unit}) in {100 * share:.1f} % of the samples: the "
            "command looks clipped (saturation), and the fit sees a force the drive did not produce; leave those "
            "samples out or measure below the limit")


def fit_warnings(relative_error_pct: float, values: dict, std: dict, units: dict) -> list[str]:
    """Poor fit (relative error above :data:`POOR_FIT_PCT`) and poorly determined parameters."""
    out = []
    if relative_error_pct > POOR_FIT_PCT:
        out.append(f"poor fit: relative error {relative_error_pct:.3g} % > {POOR_FIT_PCT:g} %; the model does not "
                   "explain the log (check the columns, units and the motion)")
    for name, value in values.items():
        s = std.get(name)
        if s is not None and value != 0 and abs(s / value) > POOR_STD and name.startswith(("mass", "inertia")):
            out.append(f"{name} poorly determined: {value:.4g} +/- {s:.2g} {units.get(name, '')} "
                       f"({100 * abs(s / value):.0f} %)")
    return out
