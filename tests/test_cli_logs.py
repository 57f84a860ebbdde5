"""Command line from logs to numbers: frf, identify rigid|friction, analyze track|ropesnap, log options, errors."""

from __future__ import annotations

import json
import math
import sys

import numpy as np
import pandas as pd
import pytest
from cli_run import run

from feedtune.cli.main import main
from feedtune.log import Log
from feedtune.models import THESIS_TABLE_3_1 as MODEL

FS = 20000.0
GTAU = 35.15065  # N/V, EMPS drive gain (README)
# EMPS_Description.pdf via data/real/EMPS/README.md: published IDIM-LS values
EMPS_SYMMETRIC = {"mass": 95.1089, "viscous": 203.5034, "coulomb": 20.3935, "offset": -3.1648}
EMPS_ASYMMETRIC = {"mass": 95.1540, "viscous_pos": 166.7061, "coulomb_pos": 20.1440, "viscous_neg": 240.4236,
                   "coulomb_neg": 20.6277}
EMPS_OPTIONS = ["--position", "qm", "--input", "vir", "--scale", f"vir={GTAU}", "--unit", "vir=N"]


def run_json(args, capsys, monkeypatch) -> dict:
    code, out, err = run([*args, "--json"], capsys, monkeypatch)
    assert code == 0, err
    return json.loads(out)


def _one_line_error(code: int, err: str, expected_code: int, fragment: str) -> None:
    assert code == expected_code, err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("feedtune: error: "), err
    assert fragment in lines[0], err


def _csv(path) -> pd.DataFrame:
    """A feedtune log CSV read independently (pandas), columns without their [unit]."""
    df = pd.read_csv(path, comment="#")
    df.columns = [c.split(" [")[0] for c in df.columns]
    return df


# ------------------------------------------------------------------------------------------ twin logs
@pytest.fixture(scope="module")
def twin_files(tmp_path_factory):
    """Gains file, and the logs of `feedtune simulate track` and `feedtune simulate ropesnap` (CSV)."""
    from feedtune.control.filters import THESIS_FILTER_PACK
    from feedtune.design.mcppc import design_mcppc
    from feedtune.io import save_model, write_document
    from feedtune.io.gains import gains_document

    d = tmp_path_factory.mktemp("twin")
    gains = d / "gains.toml"
    write_document(gains, gains_document(design_mcppc(MODEL, filters=THESIS_FILTER_PACK)))
    save_model(d / "model.toml", MODEL)
    mp = pytest.MonkeyPatch()
    for args in (["simulate", "track", "-g", gains, "-o", d / "track.csv", "--distance", "0.01",
                  "--v-max", "0.1", "--json"],
                 ["simulate", "ropesnap", "-g", gains, "-o", d / "ropesnap.csv", "--t-release", "0.3",
                  "--after", "0.4", "--json"]):
        mp.setattr(sys, "argv", ["feedtune", *map(str, args)])
        try:
            main()
        except SystemExit as exc:
            assert not exc.code, f"simulate failed: {args}"
        finally:
            mp.undo()
    return d


def test_analyze_track_twin_log_is_numpy_max_and_rms(twin_files, capsys, monkeypatch):
    path = twin_files / "track.csv"
    res = run_json(["analyze", "track", path], capsys, monkeypatch)
    assert set(res) == {"kind", "feedtune_version", "inputs", "log", "metrics", "units", "warnings"}
    assert res["log"] == str(path) and res["kind"] == "analyze.track" and res["units"]["max_m"] == "m"
    df = _csv(path)
    e = df["x_ref"].to_numpy() - df["x2_table"].to_numpy()
    v, a = np.abs(df["v_ref"].to_numpy()), np.abs(df["a_ref"].to_numpy())
    cruise = (v >= 0.98 * v.max()) & (a <= 0.02 * a.max())
    accel = a > 0.02 * a.max()
    m = res["metrics"]
    for part, mask in (("overall", np.ones(e.size, bool)), ("constant_velocity", cruise), ("acceleration", accel)):
        assert m[part]["n_samples"] == int(mask.sum()), part
        assert m[part]["max_m"] == pytest.approx(np.max(np.abs(e[mask])), rel=1e-9), part
        assert m[part]["rms_m"] == pytest.approx(np.sqrt(np.mean(e[mask] ** 2)), rel=1e-9), part
    assert 0.1e-6 < m["overall"]["max_m"] < 50e-6  # a real, non-trivial tracking error of the twin
    assert m["peaks"] and all(p["freq_hz"] > 0 for p in m["peaks"])
    # the report generator calls the library function on the same file: identical numbers
    from feedtune.analysis.log_analysis import analyze_tracking_log
    from feedtune.io import read_log

    assert json.loads(json.dumps(analyze_tracking_log(read_log(path)).to_dict())) == m
    code, out, _ = run(["analyze", "track", path], capsys, monkeypatch)
    assert code == 0 and "constant velocity" in out and " um" in out


def test_analyze_ropesnap_twin_log_is_numpy_peak_and_settling(twin_files, capsys, monkeypatch):
    path = twin_files / "ropesnap.csv"
    m = run_json(["analyze", "ropesnap", path], capsys, monkeypatch)["metrics"]
    df = _csv(path)
    t, x = df["t"].to_numpy(), df["x2_table"].to_numpy()
    assert m["t_release_s"] == pytest.approx(0.3) and not m["release_detected"]  # from the CSV metadata
    before, after = t < 0.3 - 1e-9, t >= 0.3 - 1e-9
    baseline = x[before].mean()
    dev = x[after] - baseline
    k = int(np.argmax(np.abs(dev)))
    assert m["peak_m"] == pytest.approx(dev[k], rel=1e-9)
    assert m["peak_time_s"] == pytest.approx(t[after][k] - t[after][0], abs=1e-9)
    final = x[-int(0.1 * x.size):].mean()
    outside = np.flatnonzero(np.abs(x[after] - final) >= 0.05 * abs(dev[k]))
    assert m["settled"] and m["settling_time_s"] == pytest.approx(t[after][outside[-1] + 1] - t[after][0], abs=1e-9)
    assert 1e-6 < m["peak_abs_m"] < 1e-4


def test_analyze_gains_file_still_works_both_ways(twin_files, capsys, monkeypatch):
    gains = twin_files / "gains.toml"
    short = run_json(["analyze", gains], capsys, monkeypatch)
    long = run_json(["analyze", "gains", gains], capsys, monkeypatch)
    assert short == long and short["controller"] == "mcppc" and short["analysis"]["ideal"]["stable"]
    code, _, err = run(["analyze", "trak", gains], capsys, monkeypatch)
    assert code == 2 and "no such command 'trak'" in err.lower() and err.count("\n") == 1


def test_analyze_unknown_machine_kind(twin_files, tmp_path, capsys, monkeypatch):
    doc = (twin_files / "gains.toml").read_text().replace('kind = "ballscrew"', 'kind = "spindle"')
    (tmp_path / "g.toml").write_text(doc)
    code, _, err = run(["analyze", tmp_path / "g.toml"], capsys, monkeypatch)
    _one_line_error(code, err, 1, "spindle")


# ------------------------------------------------------------------------------------------ feedtune frf
@pytest.mark.parametrize("excitation", ["multisine", "chirp", "prbs"])
def test_frf_from_twin_excitation_log_matches_the_twin(excitation, tmp_path, capsys, monkeypatch):
    from feedtune.io import read_frf, write_log_csv
    from feedtune.machines.ballscrew.experiments import measure_frf
    from feedtune.machines.ballscrew.twin import BallScrewTwin

    twin = BallScrewTwin()
    log_path, frf_path = tmp_path / "excitation.csv", tmp_path / "frf.csv"
    write_log_csv(measure_frf(twin, excitation=excitation, periods=3).log, log_path)
    res = run_json(["frf", log_path, "--input", "u", "--output", "x1,x2", "--reference", "r", "--method",
                    "periodic", "--band", "2", "2000", "--out", frf_path], capsys, monkeypatch)
    period = round(0.5 * FS) if excitation != "prbs" else None
    assert res["estimate"]["period_detection"].startswith("detected")
    if period:
        assert res["estimate"]["period_samples"] == str(period)
    assert res["unit"] == "rad/V" and 2.0 <= res["band_hz"][0] < res["band_hz"][1] <= 2000.0
    frf = read_frf(frf_path)
    assert frf.freq_hz.size == res["lines"]
    g = twin.frequency_response(frf.freq_hz)
    f_mode = MODEL.modes()[0].freq_hz
    near = (frf.freq_hz > 0.85 * f_mode) & (frf.freq_hz < 1.15 * f_mode)
    for ch, out in (("x1/u", "x1"), ("x2/u", "x2")):
        good = near & (frf.channel_coherence(ch) > 0.999)
        assert good.sum() >= 5, ch
        assert np.max(np.abs(frf.channel(ch)[good] / g[out][good] - 1)) < 0.02, ch


# ------------------------------------------------------------------------------------------ identify rigid
def test_identify_rigid_reproduces_emps_from_the_command_line(real_data_dir, tmp_path, capsys, monkeypatch):
    from feedtune.io import load_model
    from feedtune.models.rigid import RigidBodyModel

    emps = real_data_dir / "EMPS"
    out = tmp_path / "rigid.toml"
    res = run_json(["identify", "rigid", emps / "DATA_EMPS.mat", *EMPS_OPTIONS, "--validate",
                    emps / "DATA_EMPS_PULSES.mat", "--out", out], capsys, monkeypatch)
    for name, ref in EMPS_SYMMETRIC.items():
        assert res["values"][name] == pytest.approx(ref, rel=0.02), name
    assert res["units"]["mass"] == "N/(m/s^2)" and res["units"]["coulomb"] == "N"
    assert res["relative_error_pct"] == pytest.approx(4.08, abs=0.2)
    assert res["validation"]["relative_error_pct"] == pytest.approx(5.98, abs=0.5)  # published cross-test
    model = load_model(out)
    assert isinstance(model, RigidBodyModel) and model.command_unit == "N" and model.position_unit == "m"
    assert model.mass == pytest.approx(EMPS_SYMMETRIC["mass"], rel=0.02)
    assert (tmp_path / "rigid.json").exists()
    asym = run_json(["identify", "rigid", emps / "DATA_EMPS.mat", *EMPS_OPTIONS, "--asymmetric"], capsys,
                    monkeypatch)
    for name, ref in EMPS_ASYMMETRIC.items():
        assert asym["values"][name] == pytest.approx(ref, rel=0.05), name


def test_ill_conditioned_logs_report_the_reason(tmp_path, capsys, monkeypatch):
    from feedtune.io import write_log_csv

    t = np.arange(5000) / 1000.0
    cruise = tmp_path / "cruise.csv"
    write_log_csv(Log(t, {"x": 0.05 * t, "u": np.full(t.size, 14.0)}, {"x": "m", "u": "N"}), cruise)
    code, _, err = run(["identify", "rigid", cruise], capsys, monkeypatch)
    _one_line_error(code, err, 1, "no acceleration, so the mass cannot be identified")
    code, _, err = run(["identify", "friction", cruise, "--mass", "20", "--out", tmp_path / "f.toml"], capsys,
                       monkeypatch)
    _one_line_error(code, err, 1, "a Stribeck curve needs samples over a range of speeds")
    assert not (tmp_path / "f.toml").exists() and not (tmp_path / "f.json").exists()
    still = tmp_path / "still.csv"
    write_log_csv(Log(t, {"x": np.zeros(t.size), "u": np.zeros(t.size)}, {"x": "m", "u": "N"}), still)
    code, _, err = run(["identify", "rigid", still], capsys, monkeypatch)
    _one_line_error(code, err, 1, "the axis did not move")


# ------------------------------------------------------------------------------------------ identify friction
def _multi_speed_trajectory(speeds, hold: float = 0.3, acc: float = 0.05, jerk: float = 5.0):
    """Back and forth at each table speed [m/s] (rest-to-rest moves), as one Trajectory at FS."""
    from feedtune.sim.trajectory import Trajectory, point_to_point

    parts, x0 = [], 0.0
    for v in speeds:
        for sign in (1.0, -1.0):
            d = sign * (v * hold + v * v / acc)
            parts.append(point_to_point(d, v_max=v, a_max=acc, j_max=jerk, fs=FS, start=x0, dwell_after=0.02))
            x0 += d
    n = sum(p.n for p in parts)
    cat = {k: np.concatenate([getattr(p, k) for p in parts]) for k in ("pos", "vel", "acc", "jerk", "snap")}
    return Trajectory(np.arange(n) / FS, **cat, limits={"v_max": max(speeds)}, sample_rate=FS)


def test_identify_friction_recovers_the_twin_stribeck_parameters(twin_files, tmp_path, capsys, monkeypatch):
    from feedtune.control.filters import THESIS_FILTER_PACK
    from feedtune.design.mcppc import design_mcppc
    from feedtune.io import load_model, write_log_csv
    from feedtune.io.gains import gains_document
    from feedtune.machines.ballscrew.experiments import run_tracking
    from feedtune.machines.ballscrew.runtime import GainsRuntime
    from feedtune.machines.ballscrew.twin import BallScrewTwin, TwinParams
    from feedtune.models.friction import StribeckFriction

    # eq. 2.1 has one Omega: the twin's motor friction with omega_neg = omega_pos, no table friction
    params = TwinParams().with_overrides({"friction_table": "none", "friction_motor.omega_neg": "0.8"})
    truth = params.friction_motor
    runtime = GainsRuntime.from_document(gains_document(design_mcppc(MODEL, filters=THESIS_FILTER_PACK)), "mcppc")
    res = run_tracking(BallScrewTwin(params), runtime, _multi_speed_trajectory([0.5e-3, 1e-3, 2e-3, 4e-3, 8e-3,
                                                                                16e-3]))
    assert not res.tripped
    log_path, out = tmp_path / "friction_run.csv", tmp_path / "friction.toml"
    write_log_csv(res.log, log_path)
    result = run_json(["identify", "friction", log_path, "--model", twin_files / "model.toml", "--position", "x2",
                       "--input", "u", "--out", out], capsys, monkeypatch)
    fitted = result["friction"]["friction"]
    for name in ("dc_pos", "ds_pos", "dc_neg", "ds_neg", "omega_pos", "omega_neg"):
        true = truth.omega_negative if name == "omega_neg" else getattr(truth, name)
        assert fitted[name] == pytest.approx(true, rel=0.10), name
    assert fitted["units"]["dc_pos"] == "V" and fitted["units"]["omega_pos"] == "rad/s"
    model = load_model(out)
    assert isinstance(model, StribeckFriction)
    assert (model.command_unit, model.velocity_unit) == ("V", "rad/s")
    assert model.dc_pos == fitted["dc_pos"] and model.omega_negative == fitted["omega_neg"]
    code, _, err = run(["identify", "friction", log_path, "--model", out], capsys, monkeypatch)
    _one_line_error(code, err, 2, "gives no mass")


# ------------------------------------------------------------------------------------------ log options
def test_log_options_rename_scale_unit_and_fs(tmp_path, capsys, monkeypatch):
    e_um = 3.0 * np.sin(2 * np.pi * 25.0 * np.arange(2000) / 1000.0)  # um, no header, no time column
    path = tmp_path / "vendor.txt"
    path.write_text("vendor export v1\n" + "\n".join(f"{v:.12g};{2 * v:.12g}" for v in e_um) + "\n")
    res = run_json(["analyze", "track", path, "--skip-rows", "1", "--map", "err=col0", "--scale", "err=1e-6",
                    "--unit", "err=m", "--fs", "1000", "--error", "err"], capsys, monkeypatch)
    overall = res["metrics"]["overall"]
    assert overall["max_m"] == pytest.approx(3e-6, rel=1e-9)
    assert overall["rms_m"] == pytest.approx(3e-6 / math.sqrt(2), rel=1e-9)
    assert overall["duration_s"] == pytest.approx(2.0)
    assert res["metrics"]["peaks"][0]["freq_hz"] == pytest.approx(25.0)


# ------------------------------------------------------------------------------------------ bad input
@pytest.fixture
def small_log(tmp_path):
    from feedtune.io import write_log_csv

    t = np.arange(4000) / 1000.0
    x = 0.01 * np.sin(2 * np.pi * 0.5 * t)
    path = tmp_path / "small.csv"
    write_log_csv(Log(t, {"x": x, "u": np.cos(2 * np.pi * 0.5 * t), "y": x}, {"x": "m", "u": "N", "y": "m"}), path)
    return path


@pytest.mark.parametrize("args, code, fragment", [
    (["identify", "rigid", "{log}", "--position", "nope"], 1, "no signal 'nope'; available: x, u, y"),
    (["frf", "{log}", "--output", "x", "--input", "missing"], 1, "no signal 'missing'"),
    (["analyze", "track", "{log}", "--map", "x"], 2, "--map expects NAME=COLUMN, got 'x'"),
    (["analyze", "track", "{log}", "--map", "e=nowhere"], 1, "no column 'nowhere'"),
    (["analyze", "track", "{log}", "--scale", "x=abc"], 2, "--scale x=abc: FACTOR must be a number"),
    (["analyze", "track", "{log}", "--unit", "q=m"], 1, "--unit: no signal 'q'"),
    (["frf", "{log}", "--output", "x,,y"], 2, "--output expects comma-separated signal names"),
    (["frf", "{log}", "--output", "x", "--method", "magic"], 2, "method: expected one of h1, periodic"),
    (["identify", "rigid", "{dir}/run.xyz"], 1, "unknown log file type '.xyz'"),
    (["identify", "rigid", "{dir}/absent.csv"], 1, "absent.csv: file not found"),
])
def test_bad_input_is_one_line(args, code, fragment, small_log, capsys, monkeypatch):
    (small_log.parent / "run.xyz").write_text("t,x\n0,1\n")
    argv = [a.format(log=small_log, dir=small_log.parent) for a in args]
    got, _, err = run(argv, capsys, monkeypatch)
    _one_line_error(got, err, code, fragment)


def test_existing_or_unwritable_outputs_leave_no_file(small_log, capsys, monkeypatch):
    d = small_log.parent
    (d / "frf.csv").write_text("keep me\n")
    code, _, err = run(["frf", small_log, "--output", "x", "--out", d / "frf.csv"], capsys, monkeypatch)
    _one_line_error(code, err, 2, "exists; pass --force")
    assert (d / "frf.csv").read_text() == "keep me\n"
    code, _, err = run(["frf", small_log, "--output", "x", "--out", d / "frf.txt2"], capsys, monkeypatch)
    _one_line_error(code, err, 2, "--out")  # an output name the command cannot write: the command line's error
    (d / "rigid.json").write_text("{}")
    code, _, err = run(["identify", "rigid", small_log, "--out", d / "rigid.toml"], capsys, monkeypatch)
    _one_line_error(code, err, 2, "rigid.json exists")
    assert sorted(p.name for p in d.iterdir()) == ["frf.csv", "rigid.json", "small.csv"]


def test_mdf_without_the_extra_names_the_install_command(tmp_path, capsys, monkeypatch):
    p = tmp_path / "run.mf4"
    p.write_bytes(b"MDF     4.10    ")
    monkeypatch.setitem(sys.modules, "asammdf", None)
    code, _, err = run(["analyze", "track", p], capsys, monkeypatch)
    _one_line_error(code, err, 1, "pip install 'feedtune[mdf]'")
