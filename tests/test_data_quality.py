"""The quantization warning of a position log: the shortcut that skips finding the distinct values (when even the
smallest change between two samples passes both rules) gives the warning of the rule written out with ``np.unique``:
on encoders from 1e-7 to 1e-2 of the stroke, slow and fast motion, continuous-valued signals and short logs."""

from __future__ import annotations

import numpy as np
import pytest

from feedtune.identify.data_quality import MIN_LEVELS, MIN_STEPS_PER_SAMPLE_MOTION, quantization_warning


def _rule(x: np.ndarray) -> bool:
    """The rule written out: the step is the smallest gap between distinct values (0 for a continuous-valued signal,
    whose smallest gap is below half the median gap); warn when few levels span the stroke or few steps pass per
    sample while moving."""
    span = float(np.ptp(x))
    if span <= 0:
        return False
    v = np.unique(np.round((x - x.min()) / (span * 1e-9))) * (span * 1e-9)
    if v.size < 3:
        return False
    d = np.diff(v)
    q = float(d.min())
    if q <= 0.5 * float(np.median(d)):
        return False
    moves = float(np.percentile(np.abs(np.diff(x)), 90))
    return not (span / q >= MIN_LEVELS and moves / q >= MIN_STEPS_PER_SAMPLE_MOTION)


@pytest.mark.parametrize("seed", range(6))
def test_the_quantization_warning_equals_the_rule_written_out(seed):
    rng = np.random.default_rng(seed)
    n = int(rng.integers(50, 20000))
    t = np.arange(n) / 1000.0
    speed = 10 ** rng.uniform(-3, 0)
    x = 0.1 * np.sin(2 * np.pi * speed * t) + 0.01 * np.cumsum(rng.standard_normal(n)) / np.sqrt(n)
    for q in (0.0, *10 ** rng.uniform(-8, -2.5, 5)):
        xq = x if q == 0 else np.round(x / q) * q
        got = quantization_warning(xq, "x", "m") is not None
        assert got == _rule(xq), (seed, q)
