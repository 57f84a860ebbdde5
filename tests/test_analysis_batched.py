"""The batched and cached ball-screw analysis (issue 11) against independent evaluations of the same loops.

References, none of them the analysis' own code: python-control (the loop as transfer functions, the model
discretized with ``control.c2d`` and evaluated as a state space), the documented interpolation of a measured FRF
re-implemented here with ``numpy.unwrap`` and ``numpy.interp``, and scipy (``brentq`` for every crossing,
``minimize_scalar`` for the peaks) on dense samples of those references. Adversarial: a lightly damped mode (damping
0.002) between two grid lines, in the loop that the target runs (discrete controller, hold and delay).
"""

from __future__ import annotations

import numpy as np
import pytest

from feedtune.analysis.ballscrew import _Controller, _SampledModel, analyze_ballscrew, analyze_case, plant_cases
from feedtune.analysis.cases import PlantCase, unit_circle
from feedtune.analysis.loop import LoopCase, analyze_loop, analyze_loops, model_extension
from feedtune.analysis.resolution import LineNoise, interpolate_frf, lightly_damped, noise_db
from feedtune.control.filters import THESIS_FILTER_PACK, FilterPack, Notch
from feedtune.design.mcppc import design_mcppc
from feedtune.design.ppi import design_ppi
from feedtune.frf import Frf
from feedtune.lti import delay_response, zoh_response
from feedtune.models import THESIS_TABLE_3_1 as MODEL

control = pytest.importorskip("control")
scipy_optimize = pytest.importorskip("scipy.optimize")

LAW = design_mcppc(MODEL, beta=4, pole_hz=50, zeta=0.7, filters=THESIS_FILTER_PACK).law()
LPF_LAW = design_mcppc(MODEL, beta=4, pole_hz=50, zeta=0.7, filters=FilterPack([], 2000.0)).law()
"""Crosses 0 dB five times with the mode of :func:`_frf_with_mode` (tests/test_exact_margins.py)."""
GRID = np.logspace(0, np.log10(9990.0), 3000)
MODE_HZ, MODE_ZETA = 1202.3, 0.002
"""Between two lines of a 2000-line grid from 1 Hz to 5 kHz (1199.7 and 1204.9 Hz), its half-power band too."""
REL = 1e-9


# ------------------------------------------------------------------------------------------ references
def _tf(zpk, dt=None):
    num, den = zpk.to_tf()
    return control.tf(num, den) if dt is None else control.tf(num, den, dt)


def _reference_paths(law, discrete: bool):
    """``K1``, ``K2`` at ``s`` or ``z`` (arrays): the filter pack as a python-control transfer function from its
    coefficients times the law's PD/PID factors written out (``s``, or the backward difference ``(1 - 1/z) fs``
    and the integrator ``T / (1 - 1/z)`` of eq. 3.5): products, not python-control's transfer-function sums, whose
    common denominators lose 1e-8 near ``z = 1``."""
    g = law.gains
    fp = _tf(law.filter_pack_discrete(), 1.0 / law.fs) if discrete else _tf(law.filter_pack)

    def paths(x):
        x = np.atleast_1d(x)
        d = law.fs * (1 - 1 / x) if discrete else x
        f = np.atleast_1d(fp(x))
        return f * (g["Kx1"] + g["Kv1"] * d), f * (g["Kx2"] + g["Kv2"] * d + g["Ki2"] / d)

    return paths


def _ideal_loop(law):
    nums, den = MODEL.numerators(), MODEL.denominator()
    paths = _reference_paths(law, False)
    G11, G21 = control.tf(nums["G11"], den), control.tf(nums["G21"], den)

    def fn(f):
        s = 2j * np.pi * np.atleast_1d(np.asarray(f, float))
        k1, k2 = paths(s)
        return k1 * np.atleast_1d(G11(s)) + k2 * np.atleast_1d(G21(s))

    return fn


def _ideal_discrete_loop(law):
    T = 1.0 / law.fs
    A, B, C = MODEL.state_space()
    plant = control.c2d(control.ss(A, B[:, :1], C, np.zeros((2, 1))), T, "zoh")
    paths = _reference_paths(law, True)

    def fn(f):
        z = np.exp(2j * np.pi * np.atleast_1d(np.asarray(f, float)) * T)
        g = np.atleast_3d(plant(z)) if z.size > 1 else np.asarray(plant(z[0])).reshape(2, 1, 1)
        k1, k2 = paths(z)
        return (k1 * g[0, 0] + k2 * g[1, 0]) / z  # one sample of computational delay

    return fn


def _figures(fn, lo_hz: float, hi_hz: float, n: int = 40000) -> dict:
    """Crossovers, phase margins, phase crossovers, gain margins, Ms and the disk margin of the loop ``fn`` between
    ``lo_hz`` and ``hi_hz``: brackets on ``n`` log-spaced points, each crossing by brentq (xtol 1e-15 relative),
    each peak by a bounded scalar minimisation in log frequency."""
    brentq, minimize_scalar = scipy_optimize.brentq, scipy_optimize.minimize_scalar
    f = np.logspace(np.log10(lo_hz), np.log10(hi_hz), n)
    L = fn(f)

    def roots(g, mask):
        out = []
        for i in np.flatnonzero(mask):
            out.append(np.exp(brentq(lambda x: g(np.exp(x)), np.log(f[i]), np.log(f[i + 1]), xtol=1e-15,
                                     rtol=4 * np.finfo(float).eps)))
        return np.array(out)

    def one(x):
        return fn(np.array([x]))[0]

    a = np.abs(L)
    wc = roots(lambda x: np.log(abs(one(x))), np.diff(np.signbit(np.log(a))) != 0)
    im = np.signbit(L.imag)
    w180 = roots(lambda x: one(x).imag, (im[:-1] != im[1:]) & (L.real[:-1] + L.real[1:] < 0) & (a[:-1] > 1e-6))

    def peak(y_of):
        y = y_of(L)
        i = int(np.argmax(y))
        res = minimize_scalar(lambda x: -y_of(np.array([one(np.exp(x))]))[0],
                              bounds=(np.log(f[max(i - 1, 0)]), np.log(f[min(i + 1, f.size - 1)])), method="bounded",
                              options={"xatol": 1e-12})
        return float(np.exp(res.x)), float(-res.fun)

    ms_f, ms = peak(lambda v: 1 / np.abs(1 + v))
    _, dm = peak(lambda v: np.abs(1 - v) / np.abs(2 * (1 + v)))
    pm = np.degrees(np.angle(-fn(wc))) if wc.size else np.empty(0)
    gm = -20 * np.log10(np.abs(fn(w180))) if w180.size else np.empty(0)
    return {"wc": wc, "pm": pm, "w180": w180, "gm": gm, "ms": ms, "ms_f": ms_f, "disk": 1 / dm}


def _assert_same(m, ref, rel=REL):
    assert np.array(m.crossovers_hz) == pytest.approx(ref["wc"], rel=rel)
    assert np.array(m.phase_margins_deg) == pytest.approx(ref["pm"], rel=rel)
    assert np.array(m.phase_crossovers_hz) == pytest.approx(ref["w180"], rel=rel)
    assert np.array(m.gain_margins_db) == pytest.approx(ref["gm"], rel=rel)
    assert m.ms == pytest.approx(ref["ms"], rel=rel)
    assert m.ms_freq_hz == pytest.approx(ref["ms_f"], rel=1e-5)  # a flat maximum: located to ~sqrt(eps)
    assert m.disk_margin == pytest.approx(ref["disk"], rel=rel)


# ------------------------------------------------------------------------------------------ model cases
def test_ideal_case_equals_python_control_with_scipy_refinement():
    m = analyze_ballscrew(LAW, MODEL, freq_hz=GRID).cases["ideal"].metrics
    _assert_same(m, _figures(_ideal_loop(LAW), 1e-5, GRID[-1]))
    assert m.stable and m.contour_low_hz == pytest.approx(1e-5)


def test_ideal_discrete_case_equals_python_controls_zoh_state_space():
    m = analyze_ballscrew(LAW, MODEL, freq_hz=GRID).cases["ideal_discrete"]
    _assert_same(m.metrics, _figures(_ideal_discrete_loop(LAW), GRID[0], LAW.fs / 2, n=20000))
    # the loop on the grid itself, point by point
    assert m.L == pytest.approx(_ideal_discrete_loop(LAW)(m.freq_hz), rel=1e-9)


def test_zoh_model_equals_python_control_where_expanded_polynomials_lose_1e_5():
    f = np.array([0.5, 6.0, 33.8, 120.0, 1000.0, 5000.0, 9990.0])
    A, B, C = MODEL.state_space()
    sysd = control.c2d(control.ss(A, B, C, np.zeros((2, 3))), 1 / LAW.fs, "zoh")
    ref = sysd.frequency_response(2 * np.pi * f).complex
    got = _SampledModel(MODEL, LAW.fs)(f)
    assert got["G11"] == pytest.approx(ref[0, 0], rel=1e-10)
    assert got["G21"] == pytest.approx(ref[1, 0], rel=1e-10)
    assert got["G23"] == pytest.approx(ref[1, 2], rel=1e-10)


@pytest.mark.parametrize("discrete", [False, True])
def test_the_factored_paths_equal_the_laws_own(discrete):
    f = np.logspace(-2, np.log10(9990.0), 500)
    ctrl = _Controller(LAW, discrete)
    gfp, p1, p2 = ctrl.at(f)
    K1, K2 = (LAW.K1d(), LAW.K2d()) if discrete else (LAW.K1(), LAW.K2())
    assert gfp * p1 == pytest.approx(K1.freqresp(f), rel=1e-9)
    assert gfp * p2 == pytest.approx(K2.freqresp(f), rel=1e-9)
    assert ctrl.rhp == 0


# ------------------------------------------------------------------------------------------ measured cases
def _frf_with_mode(f, fn=MODE_HZ, zeta=MODE_ZETA, g=-0.12):
    """The model's FRF times a lightly damped mode at ``fn`` [Hz], between two lines of ``f``."""
    s = 2j * np.pi * f
    w = 2 * np.pi * fn
    mode = 1 + g * w * w / (s * s + 2 * zeta * w * s + w * w)
    base = MODEL.frf(f)
    return Frf(f, base.response * mode, base.outputs, base.inputs, "position", None, "V", "rad", {"source": "mode"})


def _interpolated_loop(law, frf: Frf, discrete: bool):
    """The measured case's loop re-implemented: the FRF interpolated between its lines in log magnitude and
    unwrapped phase, linear in log frequency (``numpy.interp``), the controller from python-control."""
    f = frf.freq_hz
    lf = np.log(f)
    chans = [frf.channel("x1/u"), frf.channel("x2/u")]
    lm = [np.log(np.abs(c)) for c in chans]
    ph = [np.unwrap(np.angle(c)) for c in chans]
    paths = _reference_paths(law, discrete)

    def fn(fq):
        fq = np.atleast_1d(np.asarray(fq, float))
        x = np.log(fq)
        g = [np.exp(np.interp(x, lf, m) + 1j * np.interp(x, lf, p)) for m, p in zip(lm, ph, strict=True)]
        if discrete:
            z = np.exp(2j * np.pi * fq / law.fs)
            k = paths(z)
            hold = zoh_response(fq, law.fs) / z
        else:
            k = paths(2j * np.pi * fq)
            hold = 1.0
        return hold * (k[0] * g[0] + k[1] * g[1])

    return fn


@pytest.mark.parametrize("case", ["measured", "discrete"])
def test_a_lightly_damped_mode_between_lines_gives_the_reference_figures(case):
    f = np.logspace(0, np.log10(5000.0), 2000)
    i = int(np.searchsorted(f, MODE_HZ))
    assert f[i - 1] < MODE_HZ * (1 - MODE_ZETA) and f[i] > MODE_HZ * (1 + MODE_ZETA)  # between two lines
    law = LPF_LAW
    frf = _frf_with_mode(f)
    m = analyze_ballscrew(law, MODEL, frf=frf).cases[case].metrics
    assert len(m.crossovers_hz) == 5  # two of them 1 % apart around the mode
    # the references above the FRF's first line (below it the analysis continues with the model)
    ref = _figures(_interpolated_loop(law, frf, case == "discrete"), f[0], f[-1], n=200000)
    grid = [x for x in m.crossovers_hz if x >= f[0]]
    assert np.array(grid) == pytest.approx(ref["wc"], rel=REL)
    pm = [p for x, p in zip(m.crossovers_hz, m.phase_margins_deg, strict=True) if x >= f[0]]
    assert np.array(pm) == pytest.approx(ref["pm"], rel=REL)
    w180 = [x for x in m.phase_crossovers_hz if x >= f[0]]
    gm = [g for x, g in zip(m.phase_crossovers_hz, m.gain_margins_db, strict=True) if x >= f[0]]
    assert np.array(w180) == pytest.approx(ref["w180"], rel=REL)
    assert np.array(gm) == pytest.approx(ref["gm"], rel=REL)
    assert m.ms == pytest.approx(ref["ms"], rel=REL)
    assert m.disk_margin == pytest.approx(ref["disk"], rel=REL)


def test_a_mode_between_lines_of_an_exact_plant_case_matches_python_control():
    """The plant known exactly (model times the mode), the target's loop: the analysis resolves the mode from its
    features and every figure equals the dense python-control evaluation refined by scipy."""
    fn_mode, zeta, law = MODE_HZ, MODE_ZETA, LPF_LAW
    grid = np.logspace(0, np.log10(5000.0), 2000)
    base = plant_cases(MODEL, law.fs, law.delay_samples)["ideal"]
    w = 2 * np.pi * fn_mode

    def mode(f):
        s = 2j * np.pi * np.asarray(f, float)
        return 1 - 0.12 * w * w / (s * s + 2 * zeta * w * s + w * w)

    pc = PlantCase("discrete", grid, lambda f: base.plant(f) * mode(f), base.model_plant, True,
                   lambda f: zoh_response(f, law.fs) * delay_response(f, 1, law.fs),
                   np.vstack([base.features, [[fn_mode, zeta]]]))
    m = analyze_case(law, pc).metrics
    nums, den = MODEL.numerators(), MODEL.denominator()
    mode_tf = control.tf([1, 2 * zeta * w, (1 - 0.12) * w * w], [1, 2 * zeta * w, w * w])
    G11, G21 = control.tf(nums["G11"], den) * mode_tf, control.tf(nums["G21"], den) * mode_tf
    paths = _reference_paths(law, True)

    def ref(f):
        f = np.atleast_1d(np.asarray(f, float))
        s, z = 2j * np.pi * f, np.exp(2j * np.pi * f / law.fs)
        k1, k2 = paths(z)
        return zoh_response(f, law.fs) / z * (k1 * np.atleast_1d(G11(s)) + k2 * np.atleast_1d(G21(s)))

    r = _figures(ref, grid[0], grid[-1], n=200000)
    on_grid = [x for x in m.crossovers_hz if x >= grid[0]]
    assert len(on_grid) == r["wc"].size == 5  # two of them within 1 % around the mode
    assert np.array(on_grid) == pytest.approx(r["wc"], rel=REL)
    pm = [p for x, p in zip(m.crossovers_hz, m.phase_margins_deg, strict=True) if x >= grid[0]]
    assert np.array(pm) == pytest.approx(r["pm"], rel=REL)
    assert m.ms == pytest.approx(r["ms"], rel=REL)
    assert m.disk_margin == pytest.approx(r["disk"], rel=REL)


# ------------------------------------------------------------------------------------------ batched and cached
def _figures_of(m) -> tuple:
    return (m.crossovers_hz, m.phase_margins_deg, m.phase_crossovers_hz, m.gain_margins_db, m.ms, m.disk_margin,
            m.rejection_bands_hz, m.stable, m.nyquist_encirclements, m.points, m.warnings, m.merged_crossovers)


def test_the_cached_path_equals_a_fresh_analysis_for_every_case_and_law():
    rng = np.random.default_rng(3)
    f = np.logspace(0, np.log10(5000.0), 1500)
    frf = _frf_with_mode(f)
    frf = Frf(f, frf.response * (1 + 0.02 * rng.standard_normal(f.size)), frf.outputs, frf.inputs, "position", None,
              "V", "rad", {"source": "noisy"})
    pcs = plant_cases(MODEL, LAW.fs, LAW.delay_samples, frf, GRID)
    packs = [THESIS_FILTER_PACK, FilterPack([Notch(800.0, 0.05, 0.3)], 2500.0)]
    for k in range(6):  # several laws on the same plant cases, the filter pack changing too
        law = design_mcppc(MODEL, pole_hz=40.0 + 5 * k, filters=packs[k % 2]).law()
        fresh = analyze_ballscrew(law, MODEL, frf=frf, freq_hz=GRID).cases
        for name, pc in pcs.items():
            cached = analyze_case(law, pc, responses=k % 3 == 0)
            a, b = _figures_of(fresh[name].metrics), _figures_of(cached.metrics)
            assert a[7:11] == b[7:11]  # stable, encirclements, points, warnings
            for x, y in zip(a[:7], b[:7], strict=True):
                assert np.array(x) == pytest.approx(np.array(y), rel=1e-12)
            assert [x for r in a[11] for x in r["freq_hz"]] == pytest.approx([x for r in b[11] for x in r["freq_hz"]],
                                                                             rel=1e-12)
            assert cached.L == pytest.approx(fresh[name].L, rel=1e-12)
            if k % 3 == 0:
                for key in ("S", "tracking", "tracking_no_ff"):
                    assert getattr(cached, key) == pytest.approx(getattr(fresh[name], key), rel=1e-9)
    assert all(len(pc.__dict__["_ballscrew_parts"]) == 1 for pc in pcs.values())  # the fixed parts, kept once


def test_responses_equal_their_definitions():
    law = design_ppi(MODEL, Kpx=60, Kpv=0.8, Kiv=100, filters=THESIS_FILTER_PACK).law()
    a = analyze_ballscrew(law, MODEL, freq_hz=GRID).cases["ideal"]
    f = a.freq_hz
    g = MODEL.frequency_response(f)
    K1, K2 = law.K1().freqresp(f), law.K2().freqresp(f)
    S = 1 / (1 + K1 * g["G11"] + K2 * g["G21"])
    ff, R1 = law.feedforward.freqresp(f), law.rotary_reference.freqresp(f)
    assert a.S == pytest.approx(S, rel=1e-9)
    assert a.tracking == pytest.approx(g["G21"] * (ff + K1 * R1 + K2) * S, rel=1e-8)
    assert a.tracking_no_ff == pytest.approx(g["G21"] * (K1 + K2) * S, rel=1e-9)
    assert a.disturbance == pytest.approx((g["G23"] + K1 * (g["G11"] * g["G23"] - g["G13"] * g["G21"])) * S,
                                          rel=1e-8)


def test_loops_analysed_together_equal_loops_analysed_alone():
    num, den = np.array([3e6, 4e8]), np.polymul([1, 0, 0], [1 / 3000, 1])

    def rational(n, d):
        return lambda f: np.polyval(n, 2j * np.pi * f) / np.polyval(d, 2j * np.pi * f)

    f = np.logspace(0, 4, 800)
    fns = [rational(k * num, den) for k in (0.3, 1.0, 3.0)]
    feats = lightly_damped(np.roots(den))
    alone = [analyze_loop(f, evaluate=fn, features=feats) for fn in fns]
    together = analyze_loops([LoopCase(f, evaluate=fn, features=feats) for fn in fns])
    for a, b in zip(alone, together, strict=True):
        assert _figures_of(a) == _figures_of(b)
    # an extension given by model_extension without a loop is resolved with the rest of the contour
    ext = model_extension(f, fns[1](f), fns[1])
    m = analyze_loop(f, evaluate=fns[1], extension=ext)
    assert m.contour_low_hz == pytest.approx(1e-5) and m.stable == alone[1].stable


def test_scatter_on_demand_and_interpolation_tables_equal_the_whole_computation():
    rng = np.random.default_rng(0)
    f = np.logspace(0, 3, 700)
    h = np.exp(rng.standard_normal((2, 700)) * 0.1 + 1j * np.cumsum(rng.standard_normal((2, 700)), axis=1))
    coh = rng.uniform(0.5, 1.0, (2, 700))
    whole = noise_db(f, h, coh)
    for idx in ([0], [699], [1, 2, 3, 350, 698], list(range(0, 700, 97))):
        assert np.array_equal(LineNoise(f, h, coh).lines(np.array(idx)), whole[idx])
    assert np.array_equal(np.asarray(LineNoise(f, h, coh)), whole)
    fn = interpolate_frf(f, h)
    q = np.sort(rng.uniform(1.0, 1000.0, 333))
    first = fn(q)
    assert all(np.array_equal(first, fn(q)) for _ in range(12))  # before and after the tables are made
    # the interpolation's definition: log magnitude and unwrapped phase, linear in log frequency
    ref = np.exp(np.interp(np.log(q), np.log(f), np.log(np.abs(h[0])))
                 + 1j * np.interp(np.log(q), np.log(f), np.unwrap(np.angle(h[0]))))
    assert first[0] == pytest.approx(ref, rel=1e-12)
    assert np.array_equal(fn(f), h)


def test_unit_circle_is_the_complex_exponential():
    f = np.logspace(-3, np.log10(10000.0), 1000)
    assert unit_circle(f, 20000.0) == pytest.approx(np.exp(2j * np.pi * f / 20000.0), rel=1e-15, abs=1e-15)


def test_values_do_not_depend_on_what_was_asked_before():
    """The measured parts give the same bits whether a search asked a thousand times before or not (numpy's
    vectorised log can differ in the last bit between a whole array and a few gathered lines)."""
    from feedtune.analysis.resolution import LineNoise, interpolate_frf, noise_db

    rng = np.random.default_rng(3)
    f = np.geomspace(1, 2000, 1537)
    h = (1 / (1j * f) ** 2 * (1 + 0.05 * rng.standard_normal(f.size)))[None, :] * np.array([[1.0], [2.0 + 1j]])
    coh = np.clip(1 - 0.3 * rng.random(h.shape), 0, 1)
    probe = np.array([1.37, 13.7, 137.3, 1373.1])
    fresh = interpolate_frf(f, h)(probe)
    busy = interpolate_frf(f, h)
    for _ in range(50):
        busy(rng.uniform(1, 2000, 31))
    assert np.array_equal(busy(probe), fresh)
    idx = np.array([0, 5, 700, 1536])
    whole = noise_db(f, h, coh)
    assert np.array_equal(LineNoise(f, h, coh).lines(idx), whole[idx])
    many = LineNoise(f, h, coh)
    for _ in range(20):
        many.lines(rng.integers(0, f.size, 3))
    assert np.array_equal(many.lines(idx), whole[idx])
