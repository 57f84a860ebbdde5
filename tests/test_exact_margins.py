"""Verdicts of the loop analysis against independent computations (issue 10, item 1).

Independent references: python-control's ``stability_margins`` (all crossovers, exact for rational loops) and
``disk_margins``, the roots of closed-loop characteristic polynomials, and brute-force evaluations of the same loop on
dense grids with python-control's own ZOH discretization. Adversarial cases: lightly damped modes between grid lines,
close crossovers around a lightly damped mode, a loop touching 0 dB over 0.7 %, loops whose grid starts above the
crossover, several |S| < 1 bands.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from feedtune.analysis.ballscrew import analyze_ballscrew, analyze_case, plant_cases
from feedtune.analysis.cases import PlantCase
from feedtune.analysis.limits import PROFILES
from feedtune.analysis.loop import BandLimitedError, analyze_loop, model_extension
from feedtune.analysis.resolution import ResolutionError, lightly_damped
from feedtune.control.filters import THESIS_FILTER_PACK, FilterPack
from feedtune.design.mcppc import design_mcppc
from feedtune.design.ppi import design_ppi
from feedtune.frf import Frf
from feedtune.lti import delay_response, zoh_response
from feedtune.models import THESIS_TABLE_3_1 as MODEL

control = pytest.importorskip("control")

GRID = np.logspace(0, 4, 2000)  # 1 Hz-10 kHz, 2000 points: 0.46 % spacing


def _rational(num, den):
    def fn(f):
        s = 2j * np.pi * np.asarray(f, float)
        return np.polyval(num, s) / np.polyval(den, s)

    return fn


def _rhp_closed_loop(num, den) -> int:
    return int(np.sum(np.roots(np.polyadd(den, num)).real > 0))


# ------------------------------------------------------------------ 24 lightly damped modes between grid lines
def _pd_with_mode(fp: float, k: float, collocated: bool):
    """PD + low-pass on a mass with a mode at ``fp`` Hz (damping 0.002): rational ``(num, den)`` of ``L``."""
    wc = 2 * np.pi * 50
    kp, td, n = wc**2 / 3, 3 / wc, 9 * wc
    wp = 2 * np.pi * fp
    if collocated:  # anti-resonance 10 % below the resonance
        wz = 0.9 * wp
        num_p = np.array([1, 2 * 0.002 * wz, wz * wz]) * (wp * wp) / (wz * wz)
    else:
        num_p = np.array([wp * wp])
    den = np.polymul(np.polymul([1 / n, 1.0], [1.0, 0.0, 0.0]), [1, 2 * 0.002 * wp, wp * wp])
    return k * np.polymul(kp * np.array([td, 1.0]), num_p), den


LIGHTLY_DAMPED = [(fp, k, c) for fp in (400.0, 650.0, 903.7, 1500.0) for k in (0.3, 1.0, 3.0) for c in (False, True)]


@pytest.mark.parametrize("fp, k, collocated", LIGHTLY_DAMPED)
def test_lightly_damped_loops_get_the_closed_loop_pole_verdict_or_a_refusal(fp, k, collocated):
    num, den = _pd_with_mode(fp, k, collocated)
    truth = _rhp_closed_loop(num, den) == 0
    fn = _rational(num, den)
    # samples on a grid that does not resolve the mode: the verdict is the truth, or refused
    try:
        on_grid = analyze_loop(GRID, fn(GRID))
        assert on_grid.stable == truth
    except ResolutionError as e:
        assert "does not resolve" in str(e)
    # the loop as a function: always the truth, and python-control's exact figures
    feats = np.vstack([lightly_damped(np.roots(den)), lightly_damped(np.roots(num))])
    m = analyze_loop(GRID, evaluate=fn, features=feats)
    assert m.stable == truth
    tf = control.tf(num, den)
    _, pm, sm, _, wp, _ = control.stability_margins(tf, returnall=True)
    assert m.ms == pytest.approx(1 / np.min(sm), rel=1e-5)
    pc_crossovers = np.sort(np.asarray(wp) / (2 * np.pi))
    assert np.array(m.crossovers_hz) == pytest.approx(pc_crossovers, rel=1e-6)
    pc_pm = np.asarray(pm)[np.argsort(np.asarray(wp))]
    assert np.array(m.phase_margins_deg) == pytest.approx((pc_pm + 180) % 360 - 180, abs=1e-3)


@pytest.mark.parametrize("fp, k, collocated", LIGHTLY_DAMPED[::5])
def test_disk_margin_equals_python_control(fp, k, collocated):
    num, den = _pd_with_mode(fp, k, collocated)
    fn = _rational(num, den)
    m = analyze_loop(GRID, evaluate=fn, features=lightly_damped(np.roots(den)))
    # python-control on a grid dense around our peak: its minimum can only be at or above the true one
    f = np.unique(np.r_[np.logspace(0, 4, 4000), m.disk_margin_freq_hz * (1 + np.linspace(-2e-3, 2e-3, 801))])
    dm, dgm, dpm = control.disk_margins(control.tf(num, den), 2 * np.pi * f, skew=0.0)
    assert m.disk_margin <= dm * (1 + 1e-9)
    assert m.disk_margin == pytest.approx(dm, rel=1e-4)
    assert m.disk_gain_margin_db == pytest.approx(dgm, rel=1e-3)
    assert m.disk_phase_margin_deg == pytest.approx(dpm, rel=1e-3)


# ------------------------------------------------------------------ a loop touching 0 dB over 0.7 %
def test_two_crossovers_0_7_percent_apart_are_both_reported_with_their_margins():
    w = 2 * np.pi * 100.0
    z = w * np.tan(np.radians(13.5))  # all-pass: about -153 deg at 100 Hz
    num = np.polymul([1.2 * 2 * 0.0035 * w, 0], [-1 / z, 1])  # band-pass peaking at |L| = 1.2
    den = np.polymul([1, 2 * 0.0035 * w, w * w], [1 / z, 1])
    m = analyze_loop(GRID, evaluate=_rational(num, den), features=lightly_damped(np.roots(den)))
    _, pm, _, _, wp, _ = control.stability_margins(control.tf(num, den), returnall=True)
    order = np.argsort(wp)
    assert len(m.crossovers_hz) == 2 and m.crossovers_hz[1] / m.crossovers_hz[0] < 1.01
    assert np.array(m.crossovers_hz) == pytest.approx(np.asarray(wp)[order] / (2 * np.pi), rel=1e-6)
    assert np.array(m.phase_margins_deg) == pytest.approx(np.asarray(pm)[order], abs=1e-3)
    assert m.merged_crossovers == []  # nothing is merged in a loop that is not measured
    # the worst margin decides the verdict
    assert abs(m.phase_margin_deg) == pytest.approx(np.min(np.abs(pm)), abs=1e-3)
    items = {i.name: i for i in PROFILES["textbook"].check(m, "test")}
    assert items["pm_deg"].ok == (np.min(np.abs(pm)) >= 30)


# ------------------------------------------------------------------ close crossovers around a lightly damped mode
def _mode(f, g=-0.12, fn=1200.0, zeta=0.002):
    s = 2j * np.pi * np.asarray(f, float)
    w = 2 * np.pi * fn
    return 1 + g * w * w / (s * s + 2 * zeta * w * s + w * w)


LAW = design_mcppc(MODEL, beta=4, pole_hz=50, zeta=0.7, filters=FilterPack([], 2000.0)).law()


@pytest.mark.slow
def test_close_crossovers_of_a_lightly_damped_mode_match_a_brute_force_evaluation():
    # the discrete case with the Table 3.1 model times a mode at 1200 Hz (damping 0.002), known exactly
    base = plant_cases(MODEL, LAW.fs, LAW.delay_samples)["ideal"]

    def plant(f):
        return base.plant(f) * _mode(f)

    pc = PlantCase("discrete", GRID, plant, base.model_plant, True,
                   lambda f: zoh_response(f, LAW.fs) * delay_response(f, 1, LAW.fs),
                   np.vstack([base.features, [[1200.0, 0.002]]]))
    m = analyze_case(LAW, pc).metrics
    # brute force: the same loop on 8 million points
    fb = np.linspace(1.0, 5000.0, 8_000_000)
    g = MODEL.frequency_response(fb)
    L = (zoh_response(fb, LAW.fs) * delay_response(fb, 1, LAW.fs) * _mode(fb)
         * (LAW.K1d().freqresp(fb) * g["G11"] + LAW.K2d().freqresp(fb) * g["G21"]))
    idx = np.flatnonzero(np.diff(np.signbit(np.log(np.abs(L)))))
    assert len(m.crossovers_hz) == idx.size == 5
    assert np.array(m.crossovers_hz) == pytest.approx(fb[idx], abs=1e-3)
    assert np.array(m.phase_margins_deg) == pytest.approx(np.degrees(np.angle(-L[idx])), abs=0.01)
    assert m.crossovers_hz[4] / m.crossovers_hz[3] < 1.03  # within the 3 % the analysis used to merge
    assert 20 < m.phase_margin_deg < 30 and m.stable  # below the usual 30 deg, at the close pair
    assert m.ms == pytest.approx(np.max(1 / np.abs(1 + L)), rel=1e-5)


def test_design_refuses_a_phase_margin_below_the_limit_at_a_close_crossover_pair(tmp_path, capsys, monkeypatch):
    from test_cli import run

    from feedtune.io import save_model, write_frf

    f = np.logspace(0, np.log10(5000.0), 2000)
    frf0 = MODEL.frf(f)
    frf = Frf(f, frf0.response * _mode(f), frf0.outputs, frf0.inputs, "position", None, "V", "rad",
              {"source": "mode.csv", "sampling": "removed", "sampling_fs_hz": "20000", "sampling_delay_samples": "1"})
    write_frf(frf, tmp_path / "mode.csv")
    save_model(tmp_path / "m.toml", MODEL)
    monkeypatch.chdir(tmp_path)
    args = ["design", "ppc", "m.toml", "--beta", "4", "--pole-hz", "50", "--zeta", "0.7", "--lpf", "2000",
            "--frf", "mode.csv", "--limits", "thesis", "--ms-max", "4", "--pm-min", "30"]
    code, _, err = run([*args, "--out", "g.toml"], capsys, monkeypatch)
    assert code == 1 and "phase margin" in err and "--pm-min" in err and not (tmp_path / "g.toml").exists()
    code, out, err = run([*args, "--json", "--out", "g.toml", "--allow-unstable"], capsys, monkeypatch)
    assert code == 0
    d = json.loads(out)["analysis"]["discrete"]
    assert len(d["crossovers_hz"]) == 5 and 1190 < d["crossovers_hz"][3] < d["crossovers_hz"][4] < 1210
    assert 25 < d["phase_margin_deg"] < 30
    assert any("do not resolve" in w for w in d["warnings"])  # the FRF's lines are coarser than the mode


# ------------------------------------------------------------------ every |S| < 1 band
def _z_loop_response(law, f):
    """The ``ideal_discrete`` loop on ``f`` [Hz] built with python-control: the model discretized with a ZOH by
    ``control.c2d`` and evaluated as a state space, the discrete law's factors, one sample of delay."""
    A, B, C = MODEL.state_space()
    sysd = control.c2d(control.ss(A, B[:, :1], C, np.zeros((2, 1))), 1 / law.fs, "zoh")
    z = np.exp(2j * np.pi * f / law.fs)
    resp = sysd.frequency_response(2 * np.pi * f)
    g11, g21 = resp.complex[0, 0], resp.complex[1, 0]
    return (law.K1d().evaluate(z) * g11 + law.K2d().evaluate(z) * g21) / z


def _bands_brute(law, f):
    """Frequencies [Hz] where ``|S|`` crosses 1: on ``f``, then each on 4001 points around it."""
    below = np.abs(1 + _z_loop_response(law, f)) > 1
    out = []
    for i in np.flatnonzero(np.diff(below.astype(int))):
        fl = np.linspace(f[i], f[i + 1], 4001)
        b = np.abs(1 + _z_loop_response(law, fl)) > 1
        out.append(fl[np.flatnonzero(np.diff(b.astype(int)))[0]])
    return np.array(out)


BAND_TOP_HZ = 1000.0  # above, |L| is so small that |1 + L| = 1 is a matter of rounding on a brute-force grid


@pytest.mark.parametrize("name, law, expected", [
    ("MC-PPC of the thesis on Table 3.1", design_mcppc(MODEL, beta=4, pole_hz=50, zeta=0.7,
                                                        filters=THESIS_FILTER_PACK).law(), [[0, 86.3], [103.0, 143.4]]),
    ("P-PI close to the thesis' (0-46, 120-146 Hz)", design_ppi(MODEL, Kpx=60, Kpv=0.8, Kiv=100,
                                                                filters=THESIS_FILTER_PACK).law(),
     [[0, 43.4], [120.1, 146.8]]),
])
def test_every_rejection_band_is_reported(name, law, expected):
    m = analyze_ballscrew(law, MODEL).cases["ideal_discrete"].metrics
    bands = m.rejection_bands_hz
    f = np.linspace(0.05, BAND_TOP_HZ, 100_000)
    edges = _bands_brute(law, f)
    got = [x for b in bands for x in b if 0 < x < BAND_TOP_HZ]  # the first band starts at 0 Hz
    assert np.array(got) == pytest.approx(edges, abs=3e-3), name
    assert np.array(bands[:2]) == pytest.approx(np.array(expected), abs=0.06), name
    assert m.rejection_band_hz == bands[0]  # the key old scripts read is the first band


# ------------------------------------------------------------------ band-limited loops without extension
def test_a_grid_starting_above_the_crossover_is_refused_without_a_model_below_it():
    # conditionally stable: L = K (s + a)^2 / (s^3 (s / p + 1)); with a low K the crossover is below the zeros and
    # the closed loop has 2 right-half-plane poles
    a, p, K = 2 * np.pi * 20.0, 2 * np.pi * 500.0, 10.0  # |L(10 Hz)| = 0.8
    num = K * np.polymul([1, a], [1, a])
    den = np.polymul([1 / p, 1], [1, 0, 0, 0])
    assert _rhp_closed_loop(num, den) == 2
    fn = _rational(num, den)
    f = np.logspace(1, 4, 3000)
    with pytest.raises(BandLimitedError, match="10 Hz"):
        analyze_loop(f, fn(f))
    assumed = analyze_loop(f, fn(f), below_grid="assume")  # what the analysis used to answer
    assert assumed.stable  # wrong: the reason for refusing
    ext = model_extension(f, fn(f), fn)  # the model below the grid (here exact)
    m = analyze_loop(f, evaluate=fn, extension=ext)
    assert not m.stable and m.nyquist_encirclements == 2
    assert m.below_band_crossovers_hz and m.below_band_crossovers_hz[0] < 10.0  # the crossover lies below the grid
