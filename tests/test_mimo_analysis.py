"""MIMO analysis (feedtune.analysis.mimo / gantry): singular values, sensitivity, MIMO Nyquist.

Independent references: numpy.linalg.svd per frequency, the SISO analysis of feedtune.analysis.loop for a
diagonal loop, and closed-loop eigenvalues of the gantry model's state space in feedback with the
controller's state space (assembled here from first/second-order sections of the law's factors, continuous
and discrete with the ZOH plant and the one-sample delay).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from scipy.linalg import block_diag
from scipy.signal import cont2discrete, tf2ss

from feedtune.analysis.gantry import analyze_gantry
from feedtune.analysis.loop import analyze_loop
from feedtune.analysis.mimo import analyze_mimo, mimo_nyquist, sensitivity, singular_values
from feedtune.control.filters import FilterPack, LeadStage, Notch
from feedtune.control.gantry import PidLaw
from feedtune.design.gantry_mimo import design_gantry_mimo
from feedtune.design.gantry_pid import pid_gains
from feedtune.design.loopshape import design_loopshape
from feedtune.lti import Zpk, delay_response, zoh_double_integrator
from feedtune.models.gantry import THESIS_GANTRY as MODEL
from feedtune.tune.pid import tune_gantry_pid

THESIS_H = FilterPack([Notch(110, 0.5, 0.7), Notch(320, 0.2, 0.9), Notch(400, 0.15, 1.0), Notch(940, 0.6, 0.75)],
                       450.0, 2, 0.7, [LeadStage(154, 70)])
MIMO = design_gantry_mimo(MODEL, crossover_hz=60, pm_deg=40, damping_increase=5.9, filters=THESIS_H)
PID = tune_gantry_pid(MODEL, ms_max=1.86, filters=THESIS_H)


# ------------------------------------------------------------------------- state space of the controller
def _sections(z: Zpk) -> list[tuple[np.ndarray, np.ndarray]]:
    """Real first/second-order factors (num, den) of a Zpk; the gain goes on the first factor."""
    def groups(roots):
        roots = list(roots)
        out = []
        while roots:
            r = roots.pop(0)
            if abs(r.imag) > 1e-9 * max(1, abs(r)):
                j = int(np.argmin([abs(c - np.conj(r)) for c in roots]))
                roots.pop(j)
                out.append(np.real(np.poly([r, np.conj(r)])))
            else:
                out.append(np.array([1.0, -r.real]))
        return out

    nums, dens = groups(z.zeros), groups(z.poles)
    n = max(len(nums), len(dens))
    nums += [np.array([1.0])] * (n - len(nums))
    dens += [np.array([1.0])] * (n - len(dens))
    # pair each numerator with a denominator of at least its degree (proper factors)
    dens.sort(key=len, reverse=True)
    nums.sort(key=len, reverse=True)
    secs = list(zip(nums, dens, strict=True))
    if not secs:
        secs = [(np.array([1.0]), np.array([1.0]))]
    secs[0] = (secs[0][0] * z.gain, secs[0][1])
    return secs


def _ss(z: Zpk):
    """State space (A, B, C, D) of a proper SISO Zpk as a cascade of its factors (well conditioned)."""
    A = np.zeros((0, 0))
    B = np.zeros((0, 1))
    C = np.zeros((1, 0))
    D = np.eye(1)
    for num, den in _sections(z):
        a, b, c, d = tf2ss(num, den) if len(den) > 1 else (np.zeros((0, 0)), np.zeros((0, 1)), np.zeros((1, 0)),
                                                            np.array([[num[-1] / den[0]]]))
        # series: this factor after the cascade so far
        A = np.block([[A, np.zeros((A.shape[0], a.shape[0]))], [b @ C, a]])
        B = np.vstack([B, b @ D])
        C = np.hstack([d @ C, c])
        D = d @ D
    return A, B, C, D


def _combine(blocks, Min, Mout):
    """``u = Mout blockdiag(blocks) Min e`` as one state space."""
    A = block_diag(*[b[0] for b in blocks])
    B = block_diag(*[b[1] for b in blocks]) @ Min
    C = Mout @ block_diag(*[b[2] for b in blocks])
    D = Mout @ block_diag(*[b[3] for b in blocks]) @ Min
    return A, B, C, D


def _mimo_controller(law, discrete: bool):
    """K of eq. 4.30 from its factors: u_i = alpha_i [h D ebar +- beta h s ediff + h ki/s e_i]."""
    a1, a2 = law.alpha
    if discrete:
        T = 1.0 / law.fs
        h, d = law.filter_pack_discrete(), law.lead_discrete()
        deriv = Zpk([1.0], [0.0], law.fs, T)
        integ = Zpk([0.0], [1.0], T, T)
    else:
        h, d = law.filters.zpk(), law.lead()
        deriv, integ = Zpk([0.0], [], 1.0), Zpk([], [0.0], 1.0)
    blocks = [_ss(h * d), _ss(h * deriv), _ss(h * integ), _ss(h * integ)]
    Min = np.array([[a1, a2], [1.0, -1.0], [1.0, 0.0], [0.0, 1.0]])
    Mout = np.array([[a1, a1 * law.beta, a1 * law.ki, 0.0], [a2, -a2 * law.beta, 0.0, a2 * law.ki]])
    return _combine(blocks, Min, Mout)


def _pid_controller(law, discrete: bool):
    if discrete:
        T = 1.0 / law.fs
        h = law.filter_pack_discrete()
        deriv, integ = Zpk([1.0], [0.0], law.fs, T), Zpk([0.0], [1.0], T, T)
    else:
        h = law.filters.zpk()
        deriv, integ = Zpk([0.0], [], 1.0), Zpk([], [0.0], 1.0)
    blocks = [_ss(h), _ss(h * deriv), _ss(h * integ)] * 2
    Min = np.array([[1.0, 0], [1, 0], [1, 0], [0, 1], [0, 1], [0, 1]])
    Mout = np.array([[law.kp[0], law.kd[0], law.ki[0], 0, 0, 0], [0, 0, 0, law.kp[1], law.kd[1], law.ki[1]]])
    return _combine(blocks, Min, Mout)


def closed_loop_eigenvalues(law, discrete: bool, x: float = 0.0, model=MODEL) -> np.ndarray:
    """Eigenvalues of the model at table position ``x`` [m] in negative feedback with the controller (delay and ZOH
    when discrete)."""
    Ap, Bp, Cp = model.state_space(x)
    Ak, Bk, Ck, Dk = (_mimo_controller if law.controller == "mimo" else _pid_controller)(law, discrete)
    if discrete:
        Ad, Bd, Cd, _, _ = cont2discrete((Ap, Bp, Cp, np.zeros((2, 2))), 1.0 / law.fs, method="zoh")
        n = Ad.shape[0]
        # one-sample computational delay: the plant input is the command of the previous sample
        Ap = np.block([[Ad, Bd], [np.zeros((2, n)), np.zeros((2, 2))]])
        Bp = np.vstack([np.zeros((n, 2)), np.eye(2)])
        Cp = np.hstack([Cd, np.zeros((2, 2))])
    A = np.block([[Ap - Bp @ Dk @ Cp, Bp @ Ck], [-Bk @ Cp, Ak]])
    return np.linalg.eigvals(A)


def eig_stable(law, discrete: bool, x: float = 0.0, model=MODEL) -> bool:
    lam = closed_loop_eigenvalues(law, discrete, x, model)
    return bool(np.all(np.abs(lam) < 1 - 1e-9)) if discrete else bool(np.all(lam.real < -1e-6))


VARIANTS = {
    "thesis MIMO": MIMO.law,
    "no active damping": replace(MIMO.law, beta=0.0),
    "sign-flipped damping": replace(MIMO.law, beta=-MIMO.law.beta),
    "crossover far too high (gain x4)": replace(MIMO.law, lead_gain=4 * MIMO.law.lead_gain),
    "gain too low (x0.1)": replace(MIMO.law, lead_gain=0.1 * MIMO.law.lead_gain, ki=0.1 * MIMO.law.ki),
    "whole controller sign-flipped": replace(MIMO.law, lead_gain=-MIMO.law.lead_gain, ki=-MIMO.law.ki,
                                             beta=-MIMO.law.beta),
    "PID baseline": PID.law,
    # low bandwidth, no lead: at 0.5 Hz tr L ~ 1/s^3 still dominates det L ~ 1/s^4 (the analysis continues the
    # contour with the model down to 1e-5 Hz, where det L dominates)
    "PID 8 Hz, notches and low-pass only": PidLaw(**pid_gains(MODEL, 0.0, 8.0, 0.7, 2.0), fs=15000.0,
                                                  filters=FilterPack(THESIS_H.notches, 450.0, 2, 0.7)),
    # 120 Hz: stable in continuous time, unstable with the discrete controller and delay; 180 Hz: unstable
    **{f"PID {bw} Hz": PidLaw(**pid_gains(MODEL, 0.0, bw, 0.5, 4.0), filters=THESIS_H, fs=15000.0)
       for bw in (120, 180)},
}


@pytest.mark.parametrize("name", list(VARIANTS))
def test_mimo_nyquist_agrees_with_closed_loop_eigenvalues(name):
    law = VARIANTS[name]
    analysis = analyze_gantry(law, MODEL)
    for case, discrete in (("ideal", False), ("ideal_discrete", True)):
        ny = analysis.cases[case].metrics.nyquist
        assert ny.stable == eig_stable(law, discrete), (name, case, ny)
        # the number of closed-loop poles in the RHP (outside the unit circle) equals the encirclements
        lam = closed_loop_eigenvalues(law, discrete)
        n_unstable = int(np.sum(np.abs(lam) > 1 + 1e-9)) if discrete else int(np.sum(lam.real > 1e-6))
        assert ny.encirclements == n_unstable, (name, case)


def test_the_variants_cover_stable_and_unstable_loops():
    verdicts = {name: eig_stable(law, False) for name, law in VARIANTS.items()}
    assert verdicts["thesis MIMO"] and verdicts["PID baseline"]
    assert not verdicts["no active damping"] and not verdicts["crossover far too high (gain x4)"]
    assert not verdicts["PID 180 Hz"]
    assert verdicts["PID 120 Hz"] and not eig_stable(VARIANTS["PID 120 Hz"], True)


# --------------------------------------------------------------------------------- singular values
def test_singular_values_equal_numpy_svd_per_frequency():
    rng = np.random.default_rng(0)
    A = rng.standard_normal((2, 2, 7)) + 1j * rng.standard_normal((2, 2, 7))
    A[:, :, 3] = [[1.0, 2.0], [2.0, 4.0]]  # singular matrix
    A[:, :, 4] = [[1e-8, 0], [0, 5.0]]  # widely spread
    smax, smin = singular_values(A)
    for k in range(A.shape[2]):
        s = np.linalg.svd(A[:, :, k], compute_uv=False)
        assert smax[k] == pytest.approx(s[0], rel=1e-12)
        assert smin[k] == pytest.approx(s[1], rel=1e-9, abs=1e-14)


def test_singular_values_of_the_gantry_loop_and_sensitivity_equal_numpy_svd():
    case = analyze_gantry(MIMO.law, MODEL).cases["ideal_discrete"]
    idx = np.searchsorted(case.freq_hz, [1.0, 40.0, 94.0, 150.0, 900.0])
    for name, (smax, smin) in case.singular_values().items():
        M = getattr(case, name)
        for k in idx:
            s = np.linalg.svd(M[:, :, k], compute_uv=False)
            assert smax[k] == pytest.approx(s[0], rel=1e-10), name
            assert smin[k] == pytest.approx(s[1], rel=1e-7), name
    S_direct = np.linalg.inv(np.eye(2) + np.moveaxis(case.L, -1, 0))
    assert np.allclose(np.moveaxis(S_direct, 0, -1), case.S, rtol=1e-10, atol=1e-13)


# ---------------------------------------------------------------------------------- SISO special case
def _siso_loop(gain: float = 1.0):
    d = design_loopshape(0.6977, crossover_hz=130, pm_deg=35, filters=FilterPack([Notch(186, 0.6, 0.7)], 1200.0))
    f = np.r_[np.logspace(np.log10(0.5), np.log10(7499.0), 4000), 7500.0]
    L = gain * zoh_double_integrator(0.6977, d.fs, f) * delay_response(f, 1, d.fs) * d.controller_discrete().freqresp(f)
    return f, L


@pytest.mark.parametrize("gain", [1.0, 12.0, 0.02])
def test_diagonal_loop_reduces_to_the_siso_analysis(gain):
    f, ell = _siso_loop(gain)
    siso = analyze_loop(f, ell)
    L = np.zeros((2, 2, f.size), complex)
    L[0, 0] = L[1, 1] = ell
    mimo = analyze_mimo(f, L, weights=(0.5, 0.5), integrators=2 * siso.integrators)
    assert mimo.stable == siso.stable
    assert mimo.nyquist.encirclements == 2 * siso.nyquist_encirclements  # det(I + L) = (1 + l)^2
    assert mimo.ms == pytest.approx(siso.ms, rel=1e-12)
    assert mimo.crossovers_hz == pytest.approx(siso.crossovers_hz, rel=1e-9)
    assert mimo.sigma_max_l_crossovers_hz == pytest.approx(siso.crossovers_hz, rel=1e-6)
    if gain == 1.0:
        assert siso.stable and mimo.phase_margin_deg == pytest.approx(35.0, abs=0.01)
    if gain == 12.0:
        assert not siso.stable


@pytest.mark.parametrize("gain, first_hz", [(1.0, 400.0), (1.0, 800.0), (0.02, 20.0), (0.02, 200.0)])
def test_diagonal_loop_counts_like_the_siso_loop_when_the_grid_starts_above_crossover(gain, first_hz):
    # |det(I + L) - 1| < 1 at the first line: the indentation arc of det(I + L) = 1 + (det(I + L) - 1) stays
    # near 1 (as 1 + L does for the SISO loop) and must not be counted as a turn about the origin
    f, ell = _siso_loop(gain)
    keep = f >= first_hz
    f, ell = f[keep], ell[keep]
    # the loop is known to be c/s^2 below the grid: the arc is assumed, not refused (below_grid="assume")
    siso = analyze_loop(f, ell, integrators=2, below_grid="assume")
    L = np.zeros((2, 2, f.size), complex)
    L[0, 0] = L[1, 1] = ell
    ny = mimo_nyquist(f, L, integrators=4, below_grid="assume")
    assert abs(ell[0]) < 0.5
    assert ny.encirclements == 2 * siso.nyquist_encirclements == 0
    assert ny.stable and siso.stable


def test_one_sided_loop_counts_like_the_siso_loop():
    f, ell = _siso_loop(12.0)  # unstable SISO loop in channel 1, nothing in channel 2
    L = np.zeros((2, 2, f.size), complex)
    L[0, 0] = ell
    siso = analyze_loop(f, ell)
    ny = mimo_nyquist(f, L, integrators=siso.integrators)
    assert ny.encirclements == siso.nyquist_encirclements > 0
    assert not ny.stable
    S = sensitivity(L)
    assert np.allclose(S[0, 0], 1 / (1 + ell)) and np.allclose(S[1, 1], 1.0)


def test_thesis_design_figures():
    # eq. 4.16 model at x = 0 with the thesis' design parameters (60 Hz, 40 deg, +590 % damping, filters)
    a = analyze_gantry(MIMO.law, MODEL).to_dict()
    d = a["ideal_discrete"]
    assert d["stable"] and a["ideal"]["stable"]
    assert d["crossovers_hz"][0] == pytest.approx(60.0, abs=1.0)
    assert d["phase_margin_deg"] == pytest.approx(40.0, abs=1.0)
    assert d["sigma_max_s"] == d["ms"] and 1.2 < d["ms"] < 2.6  # thesis: 1.5-2.5 recommended, 2.6 measured
    lo, hi = d["damping_band_hz"]  # active damping around the 94 Hz yaw mode (thesis: 83-124 Hz measured)
    assert lo < 94.3 < hi
    assert d["disturbance_rejection_bands_hz"][0][0] == pytest.approx(0.5)
