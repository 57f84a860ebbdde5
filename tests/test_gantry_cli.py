"""Command line on the gantry twin: simulate gantry frf|mass|ropesnap|track|contour, identify gantry|mass."""

from __future__ import annotations

import json
import sys

import numpy as np
import pytest
from cli_run import run

from feedtune.cli.main import main
from feedtune.models.gantry import THESIS_GANTRY as MODEL

XS = ("-0.4", "0", "0.4")


def _x_options(xs=XS) -> list[str]:
    return [a for x in xs for a in ("--x", x)]


@pytest.fixture(scope="module")
def frf_dir(tmp_path_factory):
    """FRFs of the twin at three table positions written by ``feedtune simulate gantry frf``."""
    d = tmp_path_factory.mktemp("frf")
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(sys, "argv", ["feedtune", "simulate", "gantry", "frf", "--out", str(d / "frf.csv"),
                                 "--period", "0.25", "--periods", "3", *_x_options()])
        try:
            main()
        except SystemExit as exc:
            assert exc.code in (0, None)
    return d


@pytest.fixture(scope="module")
def gains_files(tmp_path_factory):
    """A MIMO, an unstable PID and an x-axis gains file written with the design library."""
    from feedtune.control.filters import FilterPack, LeadStage, Notch
    from feedtune.design.gantry_mimo import design_gantry_mimo
    from feedtune.design.gantry_pid import design_gantry_pid
    from feedtune.design.loopshape import design_loopshape
    from feedtune.io import write_document
    from feedtune.io.gantry_gains import axis_gains_document, gantry_gains_document

    d = tmp_path_factory.mktemp("gains")
    h = FilterPack([Notch(110, 0.5, 0.7), Notch(320, 0.2, 0.9), Notch(400, 0.15, 1.0), Notch(940, 0.6, 0.75)],
                    450.0, 2, 0.7, [LeadStage(154.0, 70.0)])
    write_document(d / "mimo.toml", gantry_gains_document(design_gantry_mimo(MODEL, filters=h)))
    # P + I without D on a double integrator: unstable
    bad = design_gantry_pid(MODEL, kp=5e5, kd=0.0, ki=1e5)
    write_document(d / "bad.toml", gantry_gains_document(bad))
    x_filters = FilterPack([Notch(186, 0.6, 0.7), Notch(332, 0.3, 0.7), Notch(404, 0.2, 0.7)], 1200.0)
    axis = design_loopshape(MODEL.m_x, crossover_hz=130.0, pm_deg=35.0, filters=x_filters)
    write_document(d / "axis.toml", axis_gains_document(axis))
    return d


# ------------------------------------------------------------------------------------ FRF -> model
def test_simulate_frf_writes_logs_and_frfs(frf_dir):
    names = sorted(p.name for p in frf_dir.iterdir())
    assert names == sorted([f"frf_x{x}.csv" for x in XS] + [f"frf_x{x}_frf.csv" for x in XS])
    text = (frf_dir / "frf_x0_frf.csv").read_text()
    assert "# output: y1 [m]" in text and "# input: u2 [V]" in text and "y2/u1.coh" in text


def test_identify_gantry_on_simulated_frfs(frf_dir, tmp_path, capsys, monkeypatch):
    from feedtune.io import load_model

    files = [frf_dir / f"frf_x{x}_frf.csv" for x in XS]
    out = tmp_path / "model.toml"
    code, stdout, err = run(["identify", "gantry", *files, *_x_options(), "--span", "1.484", "--out", out,
                             "--json"], capsys, monkeypatch)
    assert code == 0, err
    res = json.loads(stdout)
    for name in ("J0", "d", "m_x", "c", "k"):
        assert res["model"][name] == pytest.approx(getattr(MODEL, name), rel=0.05), name
    model = load_model(out)
    assert model.L == 1.484 and model.k == pytest.approx(MODEL.k, rel=0.05)
    assert (tmp_path / "model.json").exists()
    code, stdout, err = run(["identify", "gantry", *files, *_x_options(), "--span", "1.484"], capsys, monkeypatch)
    assert code == 0 and "J0" in stdout and "V*m*s^2" in stdout and "yaw mode" in stdout


def test_identify_gantry_bad_input(frf_dir, tmp_path, capsys, monkeypatch):
    from feedtune.io import read_frf, write_frf

    files = [frf_dir / f"frf_x{x}_frf.csv" for x in XS]
    # an FRF whose output unit is not m
    frf = read_frf(files[0])
    bad = tmp_path / "rad.csv"
    write_frf(type(frf)(frf.freq_hz, frf.response, frf.outputs, frf.inputs, "position", frf.coherence,
                        "V", "rad", {"source": "x"}), bad)
    code, _, err = run(["identify", "gantry", bad, files[1], files[2], *_x_options(), "--span", "1.484"], capsys,
                       monkeypatch)
    assert code == 1 and str(bad) in err and "'rad'" in err and "unit m" in err and err.count("\n") == 1
    # fewer than three positions: the --x options cannot make a J(x) fit
    code, _, err = run(["identify", "gantry", *files[:2], *_x_options(XS[:2]), "--span", "1.484"], capsys,
                       monkeypatch)
    assert code == 2 and ">= 3" in err and "--x" in err
    # --x count differs from the file count
    code, _, err = run(["identify", "gantry", *files, *_x_options(XS[:2]), "--span", "1.484"], capsys, monkeypatch)
    assert code == 2 and "3 FRF file(s) but 2 --x" in err
    # the span is required
    code, _, err = run(["identify", "gantry", *files, *_x_options()], capsys, monkeypatch)
    assert code == 2 and "--span" in err


# ------------------------------------------------------------------------------------ mass
def test_mass_runs_and_identify_mass_then_constrained_gantry_fit(frf_dir, tmp_path, capsys, monkeypatch):
    xs = ("-0.3", "0.3")
    code, stdout, err = run(["simulate", "gantry", "mass", "--out", tmp_path / "mass.csv", *_x_options(xs),
                             "--distance", "0.05", "--json"], capsys, monkeypatch)
    assert code == 0, err
    assert len(json.loads(stdout)["runs"]) == 3  # two positions and the x-axis run
    logs = [tmp_path / f"mass_x{x}.csv" for x in xs]
    doc = tmp_path / "massdoc.toml"
    code, stdout, err = run(["identify", "mass", *logs, *_x_options(xs), "--axis-log", tmp_path / "mass_axis.csv",
                             "--out", doc, "--json"], capsys, monkeypatch)
    assert code == 0, err
    res = json.loads(stdout)
    assert res["m"] == pytest.approx(MODEL.m, rel=0.02)
    assert res["m_x"] == pytest.approx(MODEL.m_x, rel=0.02)
    assert res["alpha1_0"] == pytest.approx(MODEL.alpha1_0, rel=0.01)
    assert res["dalpha1_dx"] == pytest.approx(MODEL.dalpha1_dx, rel=0.05)
    files = [frf_dir / f"frf_x{x}_frf.csv" for x in XS]
    code, stdout, err = run(["identify", "gantry", *files, *_x_options(), "--span", "1.484", "--mass", doc,
                             "--json"], capsys, monkeypatch)
    assert code == 0, err
    model = json.loads(stdout)["model"]
    assert model["m"] == pytest.approx(res["m"], rel=1e-9)  # imposed through the row sums (eq. 4.13)
    assert model["m_x"] == pytest.approx(res["m_x"], rel=1e-9)  # given: only J0 and d fitted
    assert model["J0"] == pytest.approx(MODEL.J0, rel=0.05) and model["d"] == pytest.approx(MODEL.d, rel=0.05)


# ------------------------------------------------------------------------------------ closed-loop tests
def test_ropesnap_track_and_contour_with_gains_files(gains_files, tmp_path, capsys, monkeypatch):
    g, a = gains_files / "mimo.toml", gains_files / "axis.toml"
    code, stdout, err = run(["simulate", "gantry", "ropesnap", "--gains", g, "--axis-gains", a, "--out",
                             tmp_path / "rope.csv", "--t-release", "0.3", "--after", "0.3", "--json"], capsys,
                            monkeypatch)
    assert code == 0, err
    res = json.loads(stdout)
    assert res["force_V"] == pytest.approx(57.0 / 30.0) and 0 < abs(res["peak_um"]) < 100
    text = (tmp_path / "rope.csv").read_text()
    assert "y_table [m]" in text and "F_table [V]" in text
    code, stdout, err = run(["simulate", "gantry", "track", "--gains", g, "--test", "200mm_s", "--x", "0.2", "--out",
                             tmp_path / "track.csv"], capsys, monkeypatch)
    assert code == 0, err
    assert "tracking 200 mm/s at x = 0.2 m" in stdout and "um" in stdout
    code, stdout, err = run(["simulate", "gantry", "contour", "--gains", g, "--axis-gains", a, "--shape", "diamond",
                             "--size", "0.01", "--v-max", "0.05", "--a-max", "1", "--j-max", "50", "--out",
                             tmp_path / "diamond.csv", "--json"], capsys, monkeypatch)
    assert code == 0, err
    res = json.loads(stdout)
    assert res["shape"] == "diamond" and 0 < res["max_um"] < 5.0
    header = next(ln for ln in (tmp_path / "diamond.csv").read_text().splitlines() if not ln.startswith("#"))
    for name in ("x_ref [m]", "y_ref [m]", "x [m]", "y [m]", "contour_error [m]"):
        assert name in header


def test_unstable_controller_trips_writes_the_log_and_exits_1(gains_files, tmp_path, capsys, monkeypatch):
    out = tmp_path / "run.csv"
    code, _, err = run(["simulate", "gantry", "track", "--gains", gains_files / "bad.toml", "--out", out],
                       capsys, monkeypatch)
    assert code == 1
    # the saturated oscillation hits the I2t limit (or the following-error envelope) first
    assert err.count("\n") == 1 and " trip at t = " in err and "is a controller unstable" in err
    assert [p.name for p in tmp_path.iterdir()] == ["run.csv"]  # the log, nothing else (no temporary files)
    lines = out.read_text().splitlines()
    assert any(ln.startswith("# trip: ") and "trip at t = " in ln for ln in lines)
    t_last = float(lines[-1].split(",")[0])
    assert t_last < 0.5  # stopped early


def test_bad_options_are_usage_errors(gains_files, tmp_path, capsys, monkeypatch):
    g, a = gains_files / "mimo.toml", gains_files / "axis.toml"
    code, _, err = run(["simulate", "gantry", "ropesnap", "--gains", g, "--out", tmp_path / "r.csv", "--param",
                        "nonsense=1"], capsys, monkeypatch)
    assert code == 2 and "unknown twin parameter 'nonsense'" in err
    code, _, err = run(["simulate", "gantry", "ropesnap", "--gains", a, "--out", tmp_path / "r.csv"], capsys,
                       monkeypatch)
    assert code == 1 and "kind 'gantry'" in err  # a file of the wrong kind: the data
    code, _, err = run(["simulate", "gantry", "frf", "--out", tmp_path / "r.txt"], capsys, monkeypatch)
    assert code == 2 and ".csv" in err
    code, _, err = run(["simulate", "gantry", "track", "--gains", g, "--out", tmp_path / "r.csv", "--x", "0.9"],
                       capsys, monkeypatch)
    assert code == 2 and "travel" in err
    assert not list(tmp_path.iterdir())


def test_params_reach_the_twin(tmp_path, capsys, monkeypatch):
    code, _, err = run(["simulate", "gantry", "frf", "--out", tmp_path / "f.csv", "--ideal", "--param", "k=100e3",
                        "--f-lo", "20", "--f-hi", "300", "--periods", "2", "--json"], capsys, monkeypatch)
    assert code == 0, err
    from feedtune.io import read_frf

    frf = read_frf(tmp_path / "f_frf.csv")
    d = frf.response[0, 0] - frf.response[0, 1] - frf.response[1, 0] + frf.response[1, 1]  # L^2/(J s^2 + c s + k)
    peak = frf.freq_hz[np.argmax(np.abs(d))]
    assert peak == pytest.approx(np.sqrt(100e3 / MODEL.inertia(0.0)) / (2 * np.pi), abs=2.0)
