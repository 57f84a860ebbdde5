"""MC-PPC and P-PI designs and the ball-screw analysis against independent values."""

import numpy as np
import pytest

from feedtune.analysis.ballscrew import analyze_ballscrew, closed_loop_poles
from feedtune.analysis.loop import analyze_loop
from feedtune.control.filters import THESIS_FILTER_PACK, FilterPack
from feedtune.design.mcppc import design_mcppc, desired_poles
from feedtune.design.ppi import design_ppi
from feedtune.errors import UsageError
from feedtune.models import THESIS_TABLE_3_1 as MODEL
from feedtune.tune.ppi import tune_ppi


def test_table_3_1_mode_and_real_pole():
    # thesis §3.2.1: axial mode at 130 Hz with 2.7 % damping, real pole at 0.07 Hz
    (mode,) = MODEL.modes()
    assert mode.freq_hz == pytest.approx(130.0, abs=0.5)
    assert mode.zeta == pytest.approx(0.027, abs=0.0005)
    assert MODEL.real_pole_hz() == pytest.approx(0.07, abs=0.005)


def test_desired_poles_follow_eq_3_7_3_8():
    p = desired_poles(MODEL, 4.0, 50.0, 0.7)
    mode = MODEL.poles()[np.argmax(MODEL.poles().imag)]
    assert p[0] == pytest.approx(4 * mode.real + 1j * mode.imag)
    w2 = 2 * np.pi * 50
    assert p[4] == pytest.approx(-w2)
    assert abs(p[2]) == pytest.approx(w2)
    assert -p[2].real / abs(p[2]) == pytest.approx(0.7)


def test_mcppc_places_exactly_the_requested_poles():
    d = design_mcppc(MODEL, beta=4, pole_hz=50, zeta=0.7)
    got = np.sort_complex(d.closed_loop_poles())
    want = np.sort_complex(d.poles)
    assert np.max(np.abs(got - want) / np.abs(want)) < 1e-9


def test_closed_loop_poles_without_filters_are_the_placed_ones():
    # second, independent computation: roots of 1 + K1 G11 + K2 G21 from the transfer functions
    d = design_mcppc(MODEL)
    got = np.sort_complex(closed_loop_poles(d.law(), MODEL))
    assert np.allclose(got, np.sort_complex(d.poles), rtol=1e-6)


def test_thesis_filter_pack_crossovers_about_100_and_170_hz():
    d = design_mcppc(MODEL, beta=4, pole_hz=50, zeta=0.7, filters=THESIS_FILTER_PACK)
    ideal = analyze_ballscrew(d.law(), MODEL).cases["ideal"].metrics
    assert ideal.crossovers_hz[0] == pytest.approx(100.0, rel=0.10)
    assert ideal.crossovers_hz[-1] == pytest.approx(170.0, rel=0.10)
    assert ideal.stable


def test_nyquist_agrees_with_closed_loop_poles_over_beta_and_pole_frequency():
    for beta, pole_hz in [(1.0, 20.0), (4.0, 50.0), (4.0, 120.0), (6.0, 300.0), (2.0, 600.0)]:
        d = design_mcppc(MODEL, beta=beta, pole_hz=pole_hz, filters=THESIS_FILTER_PACK)
        law = d.law()
        stable_by_poles = bool(np.all(closed_loop_poles(law, MODEL).real < 0))
        f = np.logspace(-1, np.log10(9990), 30000)
        nyq = analyze_ballscrew(law, MODEL, freq_hz=f).cases["ideal"].metrics
        assert nyq.stable == stable_by_poles, (beta, pole_hz)


def _discrete_closed_loop_eigs(law):
    """Eigenvalues of the sampled loop (ZOH plant, discrete controller, delay) from a state-space assembly."""
    from scipy.signal import cont2discrete, tf2ss

    from feedtune.control.discretize import backward_difference, backward_euler_integrator

    T = 1 / law.fs
    A, B, C = MODEL.state_space()
    Ad, Bd, Cd, _, _ = cont2discrete((A, B[:, :1], C, np.zeros((2, 1))), T, method="zoh")
    g = law.gains

    def ss(z):
        num, den = z.to_tf()
        num = np.r_[np.zeros(len(den) - len(num)), num]
        return tf2ss(num, den)

    from feedtune.control.ballscrew_law import _sum_zpk
    from feedtune.lti import Zpk

    p1 = _sum_zpk(Zpk.constant(g["Kx1"], T), backward_difference(law.fs) * g["Kv1"])
    p2 = _sum_zpk(
        _sum_zpk(Zpk.constant(g["Kx2"], T), backward_difference(law.fs) * g["Kv2"]),
        backward_euler_integrator(law.fs) * g["Ki2"],
    )
    blocks = [ss(p1), ss(p2), ss(law.filter_pack_discrete())]
    (Aa, Ba, Ca, Da), (Ab, Bb, Cb, Db), (Af, Bf, Cf, Df) = blocks
    na, nb, nf = Aa.shape[0], Ab.shape[0], Af.shape[0]
    n = 4 + na + nb + nf + 1
    M = np.zeros((n, n))
    ip, ia, ib, i_f, idl = 0, 4, 4 + na, 4 + na + nb, n - 1
    c1, c2 = Cd[0:1], Cd[1:2]
    M[ip : ip + 4, ip : ip + 4] = Ad
    M[ip : ip + 4, idl : idl + 1] = Bd
    M[ia : ia + na, ia : ia + na] = Aa
    M[ia : ia + na, ip : ip + 4] = Ba @ c1
    M[ib : ib + nb, ib : ib + nb] = Ab
    M[ib : ib + nb, ip : ip + 4] = Bb @ c2
    # v = -(Ca xa + Da x1 + Cb xb + Db x2)
    v_row = np.zeros((1, n))
    v_row[:, ia : ia + na] = -Ca
    v_row[:, ib : ib + nb] = -Cb
    v_row[:, ip : ip + 4] = -(Da @ c1 + Db @ c2)
    M[i_f : i_f + nf, i_f : i_f + nf] = Af
    M[i_f : i_f + nf, :] += Bf @ v_row
    u_row = Df @ v_row
    u_row[:, i_f : i_f + nf] += Cf
    M[idl : idl + 1, :] = u_row  # one-sample computational delay
    return np.linalg.eigvals(M)


def test_discrete_nyquist_agrees_with_z_domain_eigenvalues():
    for pole_hz in (50.0, 300.0, 900.0, 1500.0):
        d = design_mcppc(MODEL, pole_hz=pole_hz, filters=THESIS_FILTER_PACK)
        law = d.law()
        case = analyze_ballscrew(law, MODEL).cases["ideal_discrete"].metrics
        stable_z = bool(np.all(np.abs(_discrete_closed_loop_eigs(law)) < 1))
        assert case.stable == stable_z, pole_hz


def test_loop_metrics_match_python_control():
    control = pytest.importorskip("control")
    f = np.logspace(-2, 3, 20000)
    s = 2j * np.pi * f
    for K in (0.5, 5.0):
        L = K / (s * (s + 1) * (0.1 * s + 1))
        m = analyze_loop(f, L, below_grid="assume")  # exactly K / (s (s + 1) (0.1 s + 1)): its asymptote holds
        gm, pm, sm, _, wgc, _ = control.stability_margins(control.tf([K], [0.1, 1.1, 1, 0]))
        assert m.phase_margin_deg == pytest.approx(pm, abs=1e-3)
        assert m.gain_margin_db == pytest.approx(20 * np.log10(gm), abs=1e-3)
        assert m.crossovers_hz[0] == pytest.approx(wgc / (2 * np.pi), rel=1e-5)
        assert m.ms == pytest.approx(1 / sm, rel=1e-3)


def test_ballscrew_margins_match_python_control_on_ideal_loop():
    control = pytest.importorskip("control")
    d = design_mcppc(MODEL, pole_hz=50.0)  # no filters: L is rational and python-control can take it
    law = d.law()
    nums = MODEL.numerators()
    den = MODEL.denominator()
    K1 = control.tf([law.gains["Kv1"], law.gains["Kx1"]], [1])
    K2 = control.tf([law.gains["Kv2"], law.gains["Kx2"], law.gains["Ki2"]], [1, 0])
    L = K1 * control.tf(nums["G11"], den) + K2 * control.tf(nums["G21"], den)
    f = np.logspace(-0.5, 4, 40000)
    case = analyze_ballscrew(law, MODEL, freq_hz=f).cases["ideal"]
    L_ct = np.squeeze(control.frequency_response(L, 2 * np.pi * f).complex)
    assert np.allclose(case.L, L_ct, rtol=1e-8)
    # brute force on python-control's response (its stability_margins 'sm' finds a local minimum of |1+L|
    # here, while the supremum of |S| is approached at high frequency)
    assert case.metrics.ms == pytest.approx(np.max(np.abs(1 / (1 + L_ct))), rel=1e-9)
    pm_all = control.stability_margins(L, returnall=True)[1]
    assert np.allclose(np.sort(case.metrics.phase_margins_deg), np.sort(pm_all), atol=0.01)


def test_ppi_equivalent_loop_is_eq_3_25():
    d = design_ppi(MODEL, Kpx=60.0, Kpv=0.8, Kiv=100.0, filters=THESIS_FILTER_PACK)
    f = np.logspace(0, 3.5, 500)
    s = 2j * np.pi * f
    g = MODEL.frequency_response(f)
    gfp = THESIS_FILTER_PACK.zpk().freqresp(f)
    L_eq = gfp * (0.8 * s + 100.0) / s * (g["G11"] * s + g["G21"] * 60.0)  # eq. 3.25
    L = analyze_ballscrew(d.law(), MODEL, freq_hz=f).cases["ideal"].L
    assert np.allclose(L, L_eq, rtol=1e-9)


def test_tuned_ppi_meets_its_limits_and_mcppc_rejects_better():
    ppi = tune_ppi(MODEL, ms_max=3.25, filters=THESIS_FILTER_PACK)
    a_ppi = analyze_ballscrew(ppi.law(), MODEL)
    worst = a_ppi.cases["ideal_discrete"].metrics
    assert worst.stable and worst.ms <= 3.25 and abs(worst.phase_margin_deg) >= 30
    mc = design_mcppc(MODEL, filters=THESIS_FILTER_PACK)
    a_mc = analyze_ballscrew(mc.law(), MODEL)
    # thesis §3.3: the MC-PPC disturbance transfer has a smaller negative real part (0.0083 vs 0.014 rad/V)
    assert a_mc.cases["ideal"].disturbance_min_real()[0] > a_ppi.cases["ideal"].disturbance_min_real()[0]


def test_tracking_with_model_inversion_is_unity_for_ideal_continuous():
    # eq. 3.15: with G_ff and G_r the ideal tracking transfer is exactly 1
    d = design_mcppc(MODEL, filters=THESIS_FILTER_PACK)
    case = analyze_ballscrew(d.law(), MODEL).cases["ideal"]
    assert np.allclose(case.tracking, 1.0, atol=1e-8)


def test_measured_case_is_extended_below_the_frf_by_the_model_and_warns_on_a_mismatch():
    from dataclasses import replace

    law = design_mcppc(MODEL, filters=THESIS_FILTER_PACK).law()
    frf = MODEL.frf(np.logspace(np.log10(5.0), np.log10(9990.0), 2000))
    ok = analyze_ballscrew(law, MODEL, frf=frf).cases["measured"].metrics
    assert ok.stable and ok.contour_low_hz == pytest.approx(1e-5)
    assert ok.integrators == 2  # below the 0.07 Hz real pole G ~ 1/(b s); K2 ~ Ki2/s
    assert ok.model_extension["scale_gain"] == pytest.approx(1.0, rel=1e-9)
    assert not any("differs from the FRF" in w for w in ok.warnings)
    # an FRF of the opposite sign (e.g. a reversed encoder): the extension follows the FRF, the loop is positive
    # feedback and unstable, and the mismatch with the model is reported
    flipped = analyze_ballscrew(law, MODEL, frf=replace(frf, response=-frf.response)).cases["measured"].metrics
    assert abs(flipped.model_extension["scale_phase_deg"]) == pytest.approx(180.0, abs=1e-6)
    assert any("differs from the FRF" in w for w in flipped.warnings)
    assert not flipped.stable


def test_bad_design_parameters():
    with pytest.raises(UsageError, match="beta"):
        design_mcppc(MODEL, beta=0.5)
    with pytest.raises(UsageError, match="fs"):
        design_mcppc(MODEL, fs=-1)
    with pytest.raises(UsageError, match="Nyquist"):
        design_mcppc(MODEL, filters=FilterPack(lpf_hz=12000.0))
