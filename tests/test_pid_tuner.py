"""The gantry PID tuner (feedtune.tune.pid) against an independent brute force, hand-set designs and its own rules.

Independent references:

* a dense brute force written here: a grid of shapes ``(zeta, rho)`` over the tuner's box and, for each, a top-down
  scan of the bandwidth (ratio 1.25 from ``fs/40``) followed by a plain bisection to 0.2 %, every candidate judged by
  the analysis the design is judged by (``analyze_gantry_case`` on the checked plant case, ``Limits.check``) and the
  tuner's stated acceptance rule for band-limited FRFs re-implemented with ``numpy.linalg.svd``;
* hand-set PID pairs that meet the limits (verified with ``analyze_gantry`` and ``check_cases``);
* a plant built here with a lightly damped mode in series with the gantry (a drive compliance), on which a notch
  at the mode is known to raise the attainable crossover.

Tolerance: the tuner's first CoM crossover is at least 97 % of the brute force's best (``BRUTE_TOL``; the brute
force's shape grid is coarser than the tuner's, so the tuner may also exceed it).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from feedtune.analysis.gantry import analyze_gantry, analyze_gantry_case, gantry_plant_cases
from feedtune.analysis.limits import DEFAULT_LIMITS, check_cases
from feedtune.design.filters import Notch
from feedtune.design.gantry_pid import PidLaw, pid_gains
from feedtune.design.loopshape import LoopFilters
from feedtune.frf import Frf
from feedtune.models.gantry import THESIS_GANTRY as MODEL
from feedtune.tune.pid import RHO_BOUNDS, ZETA_BOUNDS, tune_gantry_pid

FS = 15000.0
NOTCH_LPF = LoopFilters([Notch(110, 0.5, 0.7), Notch(320, 0.2, 0.9), Notch(400, 0.15, 1.0), Notch(940, 0.6, 0.75)],
                        450.0, 2, 0.7)  # the thesis MIMO design's notches and low-pass (its lead left out)
BRUTE_TOL = 0.03
POLICY = DEFAULT_LIMITS  # textbook: Ms 2.5, PM 30 deg, GM 6 dB


# ------------------------------------------------------------------------------------------- brute force
def _sigma_l_top(law: PidLaw, pc) -> float:
    top = pc.freq_hz[-1:]
    G = (pc.plant(top) * pc.hold(top))[:, :, 0]
    K = np.diag([law.response_discrete(top)[i, i, 0] for i in range(2)])
    return float(np.linalg.svd(G @ K, compute_uv=False)[0])


def _passes(law: PidLaw, pc, weights, policy) -> tuple[bool, float]:
    """The check of the checked case plus the tuner's acceptance rule on band-limited FRFs (re-implemented)."""
    m = analyze_gantry_case(law, pc, weights).metrics
    ok = all(i.ok for i in policy.check(m, pc.name))
    ok = ok and abs(m.nyquist.winding - round(m.nyquist.winding)) <= 0.2
    if pc.freq_hz[-1] < 0.999 * FS / 2:
        ok = ok and _sigma_l_top(law, pc) <= 1 - 1 / policy.ms_max
    return ok, (m.crossovers_hz[0] if ok else math.nan)


def brute_force(model, filters, policy, *, x=0.0, frf=None, zetas=None, rhos=None) -> dict:
    """Best first crossover [Hz] over a grid of shapes, each at its largest passing bandwidth."""
    case = "discrete" if frf is not None else "ideal_discrete"
    pc = gantry_plant_cases(model, x, FS, 1, frf)[case]
    weights = model.alpha(x)
    zetas = np.geomspace(*ZETA_BOUNDS, 7) if zetas is None else zetas
    rhos = np.geomspace(*RHO_BOUNDS, 6) if rhos is None else rhos
    scan = FS / 40 / 1.25 ** np.arange(0, 40)
    scan = scan[scan >= 0.2]
    best = {"crossover_hz": 0.0}
    for z in zetas:
        for r in rhos:
            def law(bw, z=z, r=r):
                return PidLaw(**pid_gains(model, x, bw, z, r), filters=filters, fs=FS)
            hi = None
            for bw in scan:  # top down to the first pass
                ok, xo = _passes(law(bw), pc, weights, policy)
                if ok:
                    lo, xlo = bw, xo
                    break
                hi = bw
            else:
                continue
            while hi is not None and hi / lo > 1.002:
                mid = math.sqrt(lo * hi)
                ok, xo = _passes(law(mid), pc, weights, policy)
                if ok:
                    lo, xlo = mid, xo
                else:
                    hi = mid
            if xlo > best["crossover_hz"]:
                best = {"crossover_hz": xlo, "zeta": z, "rho": r, "bandwidth_hz": lo}
    return best


def _hand(model, filters, policy, bw, zeta, rho, *, x=0.0, frf=None) -> float:
    """First crossover [Hz] of a hand-set PID pair, after checking that it meets the limits."""
    law = PidLaw(**pid_gains(model, x, bw, zeta, rho), filters=filters, fs=FS)
    full = analyze_gantry(law, model, x=x, frf=frf)
    checked = "discrete" if frf is not None else "ideal_discrete"
    verdict = check_cases(policy, {k: None if c is None else c.metrics for k, c in full.cases.items()}, [checked])
    assert verdict.ok, verdict.violations
    return full.cases[checked].metrics.crossovers_hz[0]


# ------------------------------------------------------------------------------------------------ plants
def series_mode_frf(freq_hz: float = 150.0, zeta: float = 0.02, x: float = 0.0) -> Frf:
    """The gantry model at ``x`` with a lightly damped mode in series with both drives (1 Hz lines to 2 kHz)."""
    f = np.arange(1.0, 2001.0)
    base = MODEL.frf(f, x)
    s, w = 2j * np.pi * f, 2 * np.pi * freq_hz
    mode = w * w / (s * s + 2 * zeta * w * s + w * w)
    return Frf(f, base.response * mode, base.outputs, base.inputs, "position", meta={"source": "series mode"})


@pytest.fixture(scope="module")
def twin_frf():
    from feedtune.sim.gantry_experiments import measure_gantry_frf
    from feedtune.sim.gantry_twin import GantryTwin

    res = measure_gantry_frf(GantryTwin(), 0.0, f_lo=2.0, f_hi=1000.0, seed=3)
    assert not res.tripped
    return res.frf


def _tuned(**kw):
    d = tune_gantry_pid(MODEL, limits=POLICY, fs=FS, **kw)
    return d, d.tuning["com_crossover_hz"]


# -------------------------------------------------------------------------------------------- the tests
def test_quick_brute_force_on_the_model():
    d, xo = _tuned(filters=NOTCH_LPF)
    bf = brute_force(MODEL, NOTCH_LPF, POLICY, zetas=np.geomspace(*ZETA_BOUNDS, 3), rhos=np.geomspace(*RHO_BOUNDS, 3))
    assert xo >= (1 - BRUTE_TOL) * bf["crossover_hz"], (xo, bf)
    # the judge: the design as written meets the limits in its checked case and is stable in every case
    full = analyze_gantry(d.law, MODEL)
    verdict = check_cases(POLICY, {k: None if c is None else c.metrics for k, c in full.cases.items()},
                          ["ideal_discrete"])
    assert verdict.ok, verdict.violations
    assert full.cases["ideal_discrete"].metrics.crossovers_hz[0] == pytest.approx(xo, rel=1e-9)


@pytest.mark.slow
@pytest.mark.parametrize("x", [0.0, 0.3, -0.3])
def test_dense_brute_force_on_the_model(x):
    _, xo = _tuned(filters=NOTCH_LPF, x=x)
    bf = brute_force(MODEL, NOTCH_LPF, POLICY, x=x)
    assert xo >= (1 - BRUTE_TOL) * bf["crossover_hz"], (xo, bf)


@pytest.mark.slow
@pytest.mark.parametrize("filters", ["notch_lpf", "none"])
def test_dense_brute_force_on_the_twin_frf(twin_frf, filters):
    pack = NOTCH_LPF if filters == "notch_lpf" else LoopFilters()
    _, xo = _tuned(filters=pack, frf=twin_frf)
    bf = brute_force(MODEL, pack, POLICY, frf=twin_frf)
    assert xo >= (1 - BRUTE_TOL) * bf["crossover_hz"], (xo, bf)


def test_never_below_hand_set_designs(twin_frf):
    # the old tuner's shape (zeta 1, rho 4) and the textbook one (0.7, 2), set a little inside the limits
    for frf in (None, twin_frf):
        _, xo = _tuned(filters=NOTCH_LPF, frf=frf)
        for bw, z, r in ((5.5, 1.0, 4.0), (6.0, 0.7, 2.0), (3.0, 0.5, 1.0)):
            assert xo >= _hand(MODEL, NOTCH_LPF, POLICY, bw, z, r, frf=frf)
