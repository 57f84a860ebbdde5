"""Memory of the four-case ball-screw analysis (issue 11) and its curves computed on first access.

An analysis keeps ``L`` per case; ``S``, the tracking and the disturbance responses are computed when first read.
The peaks are traced with ``tracemalloc`` (every numpy allocation) on a 20,000-point grid; the bounds are generous
(the benchmark measures about 220 bytes per grid point for one analysis) so that the test does not depend on numpy's
temporaries. The curves read on demand are compared with their definitions written out here from the model's, the
FRF's and the law's own responses (python-style products, not the analysis' code).
"""

from __future__ import annotations

import gc
import pickle
import tracemalloc
from types import SimpleNamespace

import numpy as np
import pytest

from feedtune.analysis.ballscrew import analyze_ballscrew, analyze_case, plant_cases
from feedtune.control.filters import THESIS_FILTER_PACK
from feedtune.design.mcppc import design_mcppc
from feedtune.models import THESIS_TABLE_3_1 as MODEL

N = 20000
F = np.logspace(0, np.log10(9990.0), N)
LAW = design_mcppc(MODEL, filters=THESIS_FILTER_PACK).law()


def _peak_per_point(fn) -> tuple[float, object]:
    """Peak traced bytes per grid point [B] during ``fn()``, and its result."""
    gc.collect()
    tracemalloc.start()
    try:
        base = tracemalloc.get_traced_memory()[0]
        out = fn()
        peak = tracemalloc.get_traced_memory()[1] - base
    finally:
        tracemalloc.stop()
    return peak / N, out


def test_one_analysis_of_four_cases_peaks_below_260_bytes_per_point():
    frf = MODEL.frf(F)
    analyze_ballscrew(LAW, MODEL, frf, freq_hz=F)  # caches of the model's discretization and the law's paths
    per_point, a = _peak_per_point(lambda: analyze_ballscrew(LAW, MODEL, frf, freq_hz=F))
    assert per_point < 260.0
    # what the result holds: one loop per case (16 bytes a point) and the discrete case's own grid
    kept = {name: c.L.nbytes for name, c in a.cases.items()}
    assert all(v == 16 * c.freq_hz.size for v, c in zip(kept.values(), a.cases.values(), strict=True))
    assert all("_curve_values" not in c.__dict__ and "_S" not in c.__dict__ for c in a.cases.values())


def test_the_tuners_path_peaks_below_230_bytes_per_point():
    frf = MODEL.frf(F)
    pcs = [pc for pc in plant_cases(MODEL, LAW.fs, LAW.delay_samples, frf, F).values() if pc is not None]
    laws = [design_mcppc(MODEL, pole_hz=p, filters=THESIS_FILTER_PACK).law() for p in (45.0, 55.0)]
    for pc in pcs:  # the fixed parts, kept on the plant cases
        analyze_case(laws[0], pc, responses=False)
    per_point, _ = _peak_per_point(lambda: [analyze_case(laws[1], pc, responses=False) for pc in pcs])
    assert per_point < 230.0


def test_curves_read_on_demand_equal_their_definitions():
    f = np.logspace(0, np.log10(5000.0), 1500)
    frf = MODEL.frf(f)
    a = analyze_ballscrew(LAW, MODEL, frf, freq_hz=f).cases
    K1, K2 = LAW.K1().freqresp(f), LAW.K2().freqresp(f)
    ff, R1 = LAW.feedforward.freqresp(f), LAW.rotary_reference.freqresp(f)
    for name in ("ideal", "measured"):  # the model written out, and the measured FRF on its own lines
        c = a[name]
        assert np.array_equal(c.freq_hz[:f.size], f)  # a measured case continues above its lines
        c = SimpleNamespace(**{k: None if getattr(c, k) is None else getattr(c, k)[:f.size]
                               for k in ("L", "S", "tracking", "tracking_no_ff", "disturbance")})
        if name == "ideal":
            g = MODEL.frequency_response(f)
            G11, G21 = g["G11"], g["G21"]
        else:
            G11, G21 = frf.response[0, 0], frf.response[1, 0]
        L = K1 * G11 + K2 * G21
        S = 1 / (1 + L)
        assert c.L == pytest.approx(L, rel=1e-9)
        assert c.S == pytest.approx(1 / (1 + c.L), rel=1e-15)  # S from the kept loop, exactly its definition
        assert c.S == pytest.approx(S, rel=1e-9)
        assert c.tracking == pytest.approx(G21 * (ff + K1 * R1 + K2) * S, rel=1e-8)
        assert c.tracking_no_ff == pytest.approx(G21 * (K1 + K2) * S, rel=1e-9)
        if name == "ideal":
            assert c.disturbance == pytest.approx((g["G23"] + K1 * (G11 * g["G23"] - g["G13"] * G21)) * S, rel=1e-8)
        else:
            assert c.disturbance is None


def test_curves_on_demand_equal_the_curves_computed_with_the_loop():
    """Every case: the lazily computed curves equal those :func:`analyze_case` computes at once from the kept
    parts (another formula: the gains' basis), to rounding."""
    f = np.logspace(0, np.log10(5000.0), 1500)
    frf = MODEL.frf(f)
    fresh = analyze_ballscrew(LAW, MODEL, frf, freq_hz=f).cases
    for name, pc in plant_cases(MODEL, LAW.fs, LAW.delay_samples, frf, f).items():
        eager = analyze_case(LAW, pc)
        lazy = fresh[name]
        for key in ("S", "tracking", "tracking_no_ff", "disturbance"):
            x, y = getattr(lazy, key), getattr(eager, key)
            if y is None:
                assert x is None
            else:
                assert x == pytest.approx(y, rel=1e-9)
        a, b = lazy.to_dict(), eager.to_dict()
        for key in ("tracking_bandwidth_hz", "tracking_max_phase_lag_deg_below_100hz",
                    "disturbance_min_real_rad_per_V"):
            assert (a[key] is None and b[key] is None) or a[key] == pytest.approx(b[key], rel=1e-9)
        assert lazy._source is None  # computed: the plant and the law are no longer held


def test_a_case_pickles_with_its_curves():
    f = np.logspace(0, np.log10(5000.0), 800)
    case = analyze_ballscrew(LAW, MODEL, MODEL.frf(f), freq_hz=f).cases["discrete"]
    back = pickle.loads(pickle.dumps(case))
    assert np.array_equal(back.L, case.L) and np.array_equal(back.S, case.S)
    assert np.array_equal(back.tracking, case.tracking) and back.disturbance is None
    assert back.to_dict() == case.to_dict()


def test_an_analysis_gives_the_same_bits_whatever_ran_before():
    """Two analyses of the same inputs in one process are bit-identical, with the caches of the discretized models,
    controllers and measured tables evicted and refilled in between (other models and laws analysed)."""
    import dataclasses

    from feedtune.io import read_frf

    def run():
        frf = read_frf("examples/ballscrew_frf.csv")  # new objects each time, as two commands would read them
        law = design_mcppc(MODEL, filters=THESIS_FILTER_PACK).law()
        a = analyze_ballscrew(law, MODEL, frf)
        return {k: (c.to_dict(), c.L.copy(), c.S.copy(), c.tracking.copy()) for k, c in a.cases.items()}

    first = run()
    for k in range(20):  # more models and laws than the caches hold
        model = dataclasses.replace(MODEL, m1=MODEL.m1 * (1 + 0.01 * (k + 1)))
        law = design_mcppc(model, pole_hz=40.0 + k, filters=THESIS_FILTER_PACK).law()
        pcs = plant_cases(model, law.fs, law.delay_samples, MODEL.frf(np.logspace(0, 3, 300 + k)))
        for pc in pcs.values():
            analyze_case(law, pc, responses=False)
    second = run()
    for name, (d1, L1, S1, t1) in first.items():
        d2, L2, S2, t2 = second[name]
        assert d1 == d2
        assert np.array_equal(L1, L2) and np.array_equal(S1, S2) and np.array_equal(t1, t2)
