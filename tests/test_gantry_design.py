"""Gantry MIMO design (eq. 4.22-4.33), the independent-PID baseline and their commands."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from cli_run import run

from feedtune.analysis.gantry import analyze_gantry
from feedtune.control.filters import FilterPack, LeadStage, Notch
from feedtune.control.gantry import reference_from_schedule
from feedtune.design.gantry_mimo import (
    averaged_plant,
    damping_gain,
    design_gantry_mimo,
    torsional_damping,
)
from feedtune.errors import DesignError, UsageError
from feedtune.models.gantry import THESIS_GANTRY as MODEL
from feedtune.tune.pid import tune_gantry_pid

THESIS_H = FilterPack([Notch(110, 0.5, 0.7), Notch(320, 0.2, 0.9), Notch(400, 0.15, 1.0), Notch(940, 0.6, 0.75)],
                       450.0, 2, 0.7, [LeadStage(154, 70)])
THESIS_H_ARGS = ["--notch", "110,0.5,0.7", "--notch", "320,0.2,0.9", "--notch", "400,0.15,1.0", "--notch",
                 "940,0.6,0.75", "--lpf", "450", "--lpf-order", "2", "--lead", "154,70"]
NOTCH_LPF = FilterPack(THESIS_H.notches, 450.0, 2, 0.7)  # the PIDs' "identical notch and low-pass filters"
F = np.logspace(0, 3, 400)


@pytest.fixture(scope="module")
def mimo():
    return design_gantry_mimo(MODEL, crossover_hz=60, pm_deg=40, damping_increase=5.9, filters=THESIS_H)


# ------------------------------------------------------------------------------ averaging (eq. 4.24)
@pytest.mark.parametrize("x", [-0.3, 0.0, 0.25])
def test_averaged_plant_is_the_rigid_body_for_any_position(x):
    got = averaged_plant(MODEL, x, F)
    expected = 1.0 / (MODEL.m * (2j * np.pi * F) ** 2)
    assert np.max(np.abs(got / expected - 1)) < 1e-9


def test_averaging_with_the_wrong_mass_distribution_keeps_the_yaw_mode():
    # at x = 0.25 m alpha1 = 0.457; averaging with 0.5/0.5 lets the 94 Hz yaw mode through
    got = averaged_plant(MODEL, 0.25, F, alpha=(0.5, 0.5))
    expected = 1.0 / (MODEL.m * (2j * np.pi * F) ** 2)
    assert np.max(np.abs(got / expected - 1)) > 1e-3


# ------------------------------------------------------------------------- active damping (eq. 4.28)
@pytest.mark.parametrize("x", [0.0, 0.2])
def test_active_damping_adds_2_a1_a2_beta_to_the_torsional_damping(x):
    beta = damping_gain(MODEL, 5.9, x)
    a1, a2 = MODEL.arms(x)
    assert 2 * a1 * a2 * beta == pytest.approx(5.9 * MODEL.c, rel=1e-12)  # +590 %
    assert torsional_damping(MODEL, beta, x) == pytest.approx(6.9 * MODEL.c, rel=1e-12)
    # closed loop of the model (eq. 4.3 at x) with u_AD = -diag(alpha) beta [[1, -1], [-1, 1]] y' (eq. 4.27)
    at = MODEL.at(x)
    alpha = np.diag(MODEL.alpha(x))
    W = np.array([[1.0, -1.0], [-1.0, 1.0]])
    Minv = np.linalg.inv(at.M)
    A = np.block([[np.zeros((2, 2)), np.eye(2)], [-Minv @ at.K, -Minv @ (at.C + alpha @ W * beta)]])
    lam = np.linalg.eigvals(A)
    lam = lam[np.argsort(np.abs(lam))]
    assert np.all(np.abs(lam[:2]) < 1e-7 * abs(lam[2]))  # rigid body untouched (a double pole at 0: ~sqrt(eps))
    J = MODEL.inertia(x)
    expected = np.roots([J, MODEL.c + 2 * a1 * a2 * beta, MODEL.k])  # eq. 4.28
    assert np.allclose(np.sort_complex(lam[2:]), np.sort_complex(expected), rtol=1e-9)
    zeta = -expected[0].real / abs(expected[0])
    assert zeta == pytest.approx(6.9 * MODEL.yaw_mode(x).zeta, rel=1e-9)


# --------------------------------------------------------------------------------- the thesis design
def test_thesis_design_at_x0_crosses_over_at_60_hz_and_is_stable(mimo):
    a = analyze_gantry(mimo.law, MODEL, reference=reference_from_schedule(mimo.schedule, 0.0, 80.0)).to_dict()
    for case in ("ideal", "ideal_discrete"):
        assert a[case]["stable"]
        assert a[case]["crossovers_hz"][0] == pytest.approx(60.0, abs=1.0)
    assert a["ideal_discrete"]["phase_margin_deg"] == pytest.approx(40.0, abs=1.0)
    # the CoM loop is h (D + ki/s) / (m s^2): check the lead gain against that formula at 60 Hz
    f = np.array([60.0])
    law = mimo.law
    s = 2j * np.pi * f
    com = law.filters.zpk().freqresp(f) * (law.lead().freqresp(f) + law.ki / s) / (MODEL.m * s**2)
    assert abs(com[0]) == pytest.approx(1.0, rel=0.02)  # continuous loop (the design is exact on the discrete one)
    # integral corner at wc tan(10 deg) by default
    assert law.ki / law.lead_gain == pytest.approx(2 * np.pi * 60 * math.tan(math.radians(10)), rel=1e-12)


def test_without_active_damping_the_thesis_design_is_unstable(mimo):
    # thesis: "In the current design, the active damping was necessary to avoid instability"
    from dataclasses import replace

    a = analyze_gantry(replace(mimo.law, beta=0.0), MODEL)
    assert not a.cases["ideal"].metrics.stable


def test_given_ki_is_used_and_targets_still_met():
    d = design_gantry_mimo(MODEL, crossover_hz=60, pm_deg=40, ki=2.0e6, filters=THESIS_H)
    assert d.law.ki == 2.0e6
    m = analyze_gantry(d.law, MODEL).cases["ideal_discrete"].metrics
    assert m.crossovers_hz[0] == pytest.approx(60.0, abs=0.01) and m.phase_margin_deg == pytest.approx(40, abs=0.01)


def test_schedule_tables_follow_the_model():
    d = design_gantry_mimo(MODEL, filters=THESIS_H, x_grid=np.linspace(-0.2, 0.2, 5))
    for i, xx in enumerate(d.schedule.x):
        assert (d.schedule.alpha1[i], d.schedule.alpha2[i]) == pytest.approx(MODEL.alpha(xx), rel=1e-12)
        M = MODEL.at(xx).M
        assert (d.schedule.m11[i], d.schedule.m12[i], d.schedule.m22[i]) == pytest.approx(
            (M[0, 0], M[0, 1], M[1, 1]), rel=1e-12)
        # eq. 4.3: row sums are the side masses
        assert d.schedule.m11[i] + d.schedule.m12[i] == pytest.approx(MODEL.side_masses(xx)[0], rel=1e-12)


@pytest.mark.parametrize("kw, exc", [
    ({"crossover_hz": 8000.0}, UsageError),
    ({"pm_deg": 95.0}, UsageError),
    ({"ki": -1.0}, UsageError),
    ({"damping_increase": -1.0}, UsageError),
    ({"ki": 1e12}, DesignError),
])
def test_bad_parameters(kw, exc):
    with pytest.raises(exc):
        design_gantry_mimo(MODEL, filters=THESIS_H, **kw)


# ---------------------------------------------------------------------------------------- PID baseline
def test_pid_baseline_is_stable_at_the_matched_ms_and_slower_than_mimo(mimo):
    ms_mimo = analyze_gantry(mimo.law, MODEL).cases["ideal_discrete"].metrics.ms
    pid = tune_gantry_pid(MODEL, ms_max=ms_mimo, filters=NOTCH_LPF)
    m = analyze_gantry(pid.law, MODEL).cases["ideal_discrete"].metrics
    assert m.stable and analyze_gantry(pid.law, MODEL).cases["ideal"].metrics.stable
    assert m.ms <= ms_mimo * (1 + 1e-9) and m.ms == pytest.approx(ms_mimo, rel=0.01)
    # thesis: the PIDs reached 16 Hz where the MIMO law reached 52 Hz (here: 60 Hz)
    assert m.crossovers_hz[0] < 0.3 * 60.0
    # gains proportional to the side masses
    assert pid.law.kp[0] / pid.law.kp[1] == pytest.approx(MODEL.side_masses(0.0)[0] / MODEL.side_masses(0.0)[1])


def test_pid_tuning_gives_up_below_ms_one():
    with pytest.raises(UsageError):
        tune_gantry_pid(MODEL, ms_max=0.9, filters=THESIS_H)


# ---------------------------------------------------------------------------------------------- CLI


@pytest.fixture(scope="module")
def model_file(tmp_path_factory):
    from feedtune.io import save_model

    p = tmp_path_factory.mktemp("gantry") / "gantry.toml"
    save_model(p, MODEL)
    return p


def test_cli_design_gantry_and_pid_then_analyze(model_file, tmp_path, capsys, monkeypatch):
    mimo_file, pid_file = tmp_path / "mimo.toml", tmp_path / "pid.toml"
    code, out, err = run(["design", "gantry", model_file, "--crossover-hz", "60", "--pm-deg", "40",
                          "--damping-increase", "5.9", *THESIS_H_ARGS, "--fs", "15000", "--out", mimo_file,
                          "--json"], capsys, monkeypatch)
    assert code == 0, err
    res = json.loads(out)
    assert res["controller"] == "mimo" and res["check"]["ok"] and mimo_file.exists()
    assert mimo_file.with_suffix(".json").exists()
    d = res["analysis"]["ideal_discrete"]
    assert d["crossovers_hz"][0] == pytest.approx(60, abs=1) and d["stable"]
    assert res["gains"]["beta"]["value"] == pytest.approx(5.9 * MODEL.c / (2 * 0.742**2), rel=1e-9)
    code, out, err = run(["design", "pid", model_file, "--match", mimo_file, "--out", pid_file, "--json"], capsys,
                         monkeypatch)
    assert code == 0, err
    pid = json.loads(out)
    assert pid["controller"] == "pid" and pid["analysis"]["ideal_discrete"]["ms"] == pytest.approx(d["ms"], rel=0.01)
    from feedtune.io import read_document

    pid_filters = read_document(pid_file)["filters"]["continuous"]  # notches and low-pass of --match, no lead
    assert len(pid_filters["notches"]) == 4 and pid_filters["lpf_hz"] == 450.0 and not pid_filters.get("leads")
    for f in (mimo_file, pid_file):
        code, out, err = run(["analyze", f, "--json"], capsys, monkeypatch)
        assert code == 0, err
        again = json.loads(out)
        assert again["gains_kind"] == "gantry"
        assert again["analysis"]["ideal_discrete"]["ms"] == pytest.approx(
            (d if f == mimo_file else pid["analysis"]["ideal_discrete"])["ms"], rel=1e-9)
    code, out, err = run(["analyze", mimo_file], capsys, monkeypatch)
    assert code == 0 and "CoM crossover" in out and "ideal_discrete" in out


def test_cli_unstable_design_is_refused_unless_allowed(model_file, tmp_path, capsys, monkeypatch):
    out_file = tmp_path / "bad.toml"
    args = ["design", "gantry", model_file, "--damping-increase", "0", *THESIS_H_ARGS, "--out", out_file]
    code, _, err = run(args, capsys, monkeypatch)
    assert code == 1 and "unstable" in err and len(err.strip().splitlines()) == 1
    assert not out_file.exists()
    code, _, err = run([*args, "--allow-unstable"], capsys, monkeypatch)
    assert code == 0 and out_file.exists() and "warning" in err


def test_cli_bad_input(model_file, tmp_path, capsys, monkeypatch):
    from feedtune.io import save_model
    from feedtune.models import THESIS_TABLE_3_1

    bs = tmp_path / "bs.toml"
    save_model(bs, THESIS_TABLE_3_1)
    code, _, err = run(["design", "gantry", bs], capsys, monkeypatch)
    assert code == 1 and "gantry model" in err  # a file of the wrong kind: a data error (docs/conventions.md)
    code, _, err = run(["design", "gantry", model_file, "--lead", "154"], capsys, monkeypatch)
    assert code == 2 and "--lead" in err
    code, _, err = run(["design", "pid", model_file, "--ms-max", "0.5"], capsys, monkeypatch)
    assert code == 2 and "--ms-max" in err
    code, _, err = run(["design", "pid", model_file, "--kp", "1000"], capsys, monkeypatch)
    assert code == 2 and "--kd" in err


def test_measured_and_discrete_cases_on_the_model_frf(mimo, tmp_path, capsys, monkeypatch, model_file):
    from feedtune.io import write_frf

    f = np.logspace(np.log10(0.5), np.log10(7400), 3000)
    frf = MODEL.frf(f, 0.0)  # channels y1/u1, y1/u2, y2/u1, y2/u2 [m/V]
    a = analyze_gantry(mimo.law, MODEL, frf=frf).to_dict()
    assert a["measured"]["stable"] and a["discrete"]["stable"]
    # the FRF is the model: continuous cases agree closely, the ZOH x delay case approximates ideal_discrete
    assert a["measured"]["ms"] == pytest.approx(a["ideal"]["ms"], rel=1e-3)
    assert a["discrete"]["ms"] == pytest.approx(a["ideal_discrete"]["ms"], rel=0.02)
    assert a["discrete"]["crossovers_hz"][0] == pytest.approx(60.0, abs=1.0)
    for case in ("measured", "discrete"):  # the Nyquist contour continues below 0.5 Hz with the model
        ext = a[case]["model_extension"]
        assert a[case]["nyquist_low_frequency_hz"] == pytest.approx(1e-5)
        assert ext["scale_gain"] == pytest.approx(1.0, rel=1e-9) and abs(ext["scale_phase_deg"]) < 1e-6
        assert ext["junction_hz"] == pytest.approx([0.5, 1.0], rel=3e-3)  # the FRF's first octave
        assert a[case]["nyquist_low_frequency_slope"] == pytest.approx(4.0, abs=0.05)  # rigid body + 2 integrals
    path = tmp_path / "gantry_frf.csv"
    write_frf(frf, path)
    code, out, err = run(["design", "gantry", model_file, *THESIS_H_ARGS, "--frf", path, "--json"], capsys,
                         monkeypatch)
    assert code == 0, err
    res = json.loads(out)
    assert res["analysis"]["discrete"]["stable"] and res["analysis"]["discrete"]["integrators"] == 4


def test_a_siso_frf_is_refused_for_the_gantry(mimo):
    from feedtune.errors import DataError
    from feedtune.frf import Frf

    f = np.logspace(0, 3, 100)
    siso = Frf(f, np.ones((1, 1, 100)), ("y1",), ("u1",), output_unit="m", meta={"source": "one.csv"})
    with pytest.raises(DataError, match="y1/u2"):
        analyze_gantry(mimo.law, MODEL, frf=siso)
