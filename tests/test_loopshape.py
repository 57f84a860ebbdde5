"""x-axis loop shaping (thesis eq. 4.17-4.20): lead rule, design on the discrete loop, pre-filter, command."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from cli_run import run
from scipy.signal import cont2discrete, freqz_zpk, sosfilt, ss2tf

from feedtune.analysis.gantry import analyze_axis
from feedtune.analysis.loop import analyze_loop
from feedtune.control.filters import FilterPack, LeadStage, Notch, split_lead, thesis_gamma
from feedtune.control.prefilter import PrefilterGains, prefilter_terms, reference_filters
from feedtune.design.loopshape import design_loopshape
from feedtune.errors import DataError, UsageError
from feedtune.frf import Frf

M_X = 0.6977  # thesis §4.3.1 [V/(m/s^2)]
FS = 15000.0
THESIS_X_FILTERS = FilterPack([Notch(186, 0.6, 0.7), Notch(332, 0.3, 0.7), Notch(404, 0.2, 0.7)], 1200.0)


def discrete_loop(design, f):
    """Independent discrete loop: scipy ZOH of 1/(m s^2), one-sample delay, scipy evaluation of C(z)."""
    A = np.array([[0.0, 1.0], [0.0, 0.0]])
    B = np.array([[0.0], [1.0 / design.plant.mass]])
    Ad, Bd, Cd, Dd, _ = cont2discrete((A, B, np.array([[1.0, 0.0]]), np.zeros((1, 1))), 1 / design.fs, "zoh")
    num, den = ss2tf(Ad, Bd, Cd, Dd)
    z = np.exp(2j * np.pi * f / design.fs)
    G = np.polyval(num[0], z) / np.polyval(den, z) / z
    c = design.controller_discrete()
    _, C = freqz_zpk(c.zeros, c.poles, c.gain, worN=f, fs=design.fs)
    return G * C


def test_thesis_lead_rule():
    # 126 deg of lead -> two stages of 63 deg, gamma = sqrt((1 + sin 63)/(1 - sin 63)) = 4.2 (thesis §4.4.1)
    assert split_lead(126.0) == [63.0, 63.0]
    assert thesis_gamma(63.0) == pytest.approx(math.sqrt((1 + math.sin(math.radians(63))) /
                                                         (1 - math.sin(math.radians(63)))), rel=1e-12)
    assert round(thesis_gamma(63.0), 1) == 4.2
    stage = LeadStage(130.0, 63.0)
    w = 2 * np.pi * 130.0
    a, td = stage.gamma * w, stage.gamma / w  # pole a = gamma wc, zero 1/Td = wc/gamma
    h = (td * 1j * w + 1) / (1j * w / a + 1)
    assert np.angle(h, deg=True) == pytest.approx(63.0, abs=1e-9)
    assert stage.zpk().freqresp([130.0])[0] == pytest.approx(h, rel=1e-12)
    assert split_lead(45.0) == [45.0] and split_lead(140.0) == [70.0, 70.0] and split_lead(0.0) == []
    assert split_lead(150.0) == [50.0, 50.0, 50.0] and split_lead(-30.0) == [-30.0]


def test_thesis_x_axis_design_meets_crossover_and_phase_margin_on_the_discrete_loop():
    d = design_loopshape(M_X, crossover_hz=130, pm_deg=35, pi_lag_deg=10, filters=THESIS_X_FILTERS, fs=FS,
                         delay_samples=1)
    f = np.r_[np.logspace(np.log10(0.5), np.log10(FS / 2 * 0.9999), 5000), FS / 2]
    m = analyze_loop(f, discrete_loop(d, f))
    assert m.stable
    assert m.crossovers_hz[0] == pytest.approx(130.0, abs=1.0)
    assert m.phase_margins_deg[0] == pytest.approx(35.0, abs=1.0)
    # Ti gives the integral 10 deg of lag at the crossover
    w = 2 * np.pi * 130
    assert -np.degrees(np.angle((d.ti_s * 1j * w + 1) / (d.ti_s * 1j * w))) == pytest.approx(10.0, abs=1e-9)
    # |S| < 1 up to ~90 Hz (thesis, on the measured FRF: 98 Hz)
    assert 70 < m.rejection_band_hz[1] < 130
    a = analyze_axis(d).to_dict()["ideal_discrete"]
    assert a["crossovers_hz"][0] == pytest.approx(m.crossovers_hz[0], rel=1e-6)
    assert a["ms"] == pytest.approx(m.ms, rel=1e-3)


def test_design_on_a_measured_frf_needs_two_leads_and_estimates_the_mass():
    # FRF of 1/(m s^2) with 1.5 ms of extra lag (amplifier, sensors): about 120 deg of lead at 130 Hz
    f = np.logspace(0, np.log10(3000), 1500)
    s = 2j * np.pi * f
    frf = Frf(f, (np.exp(-s * 1.5e-3) / (M_X * s**2))[None, None, :], ("x",), ("u",), "position",
              output_unit="m", meta={"source": "synthetic.csv"})
    d = design_loopshape(frf, crossover_hz=130, pm_deg=35, fs=FS)
    assert len(d.lead_stages) == 2 and 90 < d.lead_deg < 140
    assert d.plant.mass == pytest.approx(M_X, rel=0.01)
    cases = analyze_axis(d).to_dict()
    m = cases["discrete"]
    assert m["stable"] and m["crossovers_hz"][0] == pytest.approx(130, abs=1)
    assert m["phase_margins_deg"][0] == pytest.approx(35, abs=1)


def test_prefilter_terms_and_reference_filters():
    wf = 2 * np.pi * 80.0
    f = np.array([3.0, 80.0, 500.0])
    s = 2j * np.pi * f
    for n, term in enumerate(prefilter_terms(80.0), start=1):
        assert np.allclose(term.freqresp(f), s**n * (wf / (s + wf)) ** (n + 1), rtol=1e-12)
    refs = reference_filters(80.0, FS)
    # parabola x = 0.5 a t^2 fed P = 2 samples ahead: acceleration path gives a, position path gives x[k]
    a, n = 3.0, 200
    t = np.arange(n + 2) / FS
    x = 0.5 * a * t**2
    ahead = x[2:]
    assert np.allclose(sosfilt(refs["acceleration"].to_sos(), ahead)[2:], a, rtol=1e-9)
    assert np.allclose(sosfilt(refs["position"].to_sos(), ahead)[2:], x[2:n], rtol=1e-12)
    # filtered velocity of a ramp settles at the velocity (G_lpf(0) = 1)
    ramp = 0.2 * np.arange(20000) / FS
    assert sosfilt(refs["prefilter_vel"].to_sos(), ramp)[-1] == pytest.approx(0.2, rel=1e-6)


def test_filters_round_trip_and_errors():
    fp = FilterPack([Notch(110, 0.5, 0.7)], 450.0, 2, 0.7, [LeadStage(154, 70)])
    assert FilterPack.from_dict(fp.to_dict()) == fp
    assert abs(fp.zpk().dc_gain()) == pytest.approx(1.0)
    with pytest.raises(DataError):
        FilterPack.from_dict({"notches": [{"freq_hz": 100}]})
    with pytest.raises(UsageError):
        FilterPack(lpf_order=3)
    with pytest.raises(UsageError):
        FilterPack(lpf_hz=9000.0).check_nyquist(FS)
    with pytest.raises(UsageError):
        PrefilterGains.parse("1,2,3")
    assert PrefilterGains.parse("1e-3,0,0,0").k_vel == 1e-3


@pytest.mark.parametrize("kw", [{"crossover_hz": 8000}, {"pm_deg": 0}, {"pi_lag_deg": 60}, {"fs": -1.0},
                                {"delay_samples": 1.5}])
def test_bad_parameters(kw):
    args = {"crossover_hz": 130, "pm_deg": 35, **kw}
    with pytest.raises(UsageError):
        design_loopshape(M_X, **args)


def test_unusable_plants():
    with pytest.raises(DataError):  # not a plant: the data are wrong
        design_loopshape("heavy", crossover_hz=130, pm_deg=35)
    f = np.logspace(0, 3, 50)
    two = Frf(f, np.ones((2, 1, 50)) / (2j * np.pi * f) ** 2, ("a", "b"), ("u",), output_unit="m")
    with pytest.raises(UsageError):
        design_loopshape(two, crossover_hz=130, pm_deg=35)
    with pytest.raises(DataError):
        design_loopshape(two, crossover_hz=2000, pm_deg=35, channel="a/u")  # FRF ends at 1 kHz


# ---------------------------------------------------------------------------------------------- CLI


def test_cli_loopshape_from_a_gantry_model_writes_and_analyzes(tmp_path, capsys, monkeypatch):
    from feedtune.io import save_model
    from feedtune.models.gantry import THESIS_GANTRY

    model = tmp_path / "gantry.toml"
    save_model(model, THESIS_GANTRY)
    out = tmp_path / "axis.toml"
    code, text, err = run(["design", "loopshape", model, "--crossover-hz", "130", "--pm-deg", "35",
                           "--notch", "186,0.6,0.7", "--notch", "332,0.3,0.7", "--notch", "404,0.2,0.7",
                           "--lpf", "1200", "--fs", "15000", "--out", out, "--json"], capsys, monkeypatch)
    assert code == 0, err
    res = json.loads(text)
    assert res["gains_kind"] == "axis" and res["check"]["ok"] and out.exists()
    assert res["design"]["plant"]["mass"] == pytest.approx(THESIS_GANTRY.m_x)
    d = res["analysis"]["ideal_discrete"]
    assert d["crossovers_hz"][0] == pytest.approx(130, abs=1) and d["phase_margin_deg"] == pytest.approx(35, abs=1)
    code, text, err = run(["analyze", out, "--json"], capsys, monkeypatch)
    assert code == 0, err
    again = json.loads(text)
    assert again["gains_kind"] == "axis"
    assert again["analysis"]["ideal_discrete"]["crossovers_hz"][0] == pytest.approx(d["crossovers_hz"][0], rel=1e-9)
    code, text, err = run(["design", "loopshape", model, "--crossover-hz", "130", "--pm-deg", "35", "--out", out],
                          capsys, monkeypatch)
    assert code == 2 and "exists" in err  # no overwrite without --force


def test_cli_loopshape_from_an_frf_file_and_a_too_strict_ms(tmp_path, capsys, monkeypatch):
    from feedtune.io import write_frf

    f = np.logspace(0, np.log10(3000), 800)
    s = 2j * np.pi * f
    path = tmp_path / "x_axis.csv"
    write_frf(Frf(f, (1 / (M_X * s**2))[None, None, :], ("x",), ("u",), output_unit="m"), path)
    code, text, err = run(["design", "loopshape", path, "--crossover-hz", "100", "--pm-deg", "40", "--json"],
                          capsys, monkeypatch)
    assert code == 0, err
    res = json.loads(text)
    assert res["analysis"]["discrete"]["crossovers_hz"][0] == pytest.approx(100, abs=1)
    code, text, err = run(["design", "loopshape", path, "--crossover-hz", "100", "--pm-deg", "40", "--ms-max",
                           "1.1", "--out", tmp_path / "a.toml"], capsys, monkeypatch)
    assert code == 1 and "--ms-max" in err and not (tmp_path / "a.toml").exists()
