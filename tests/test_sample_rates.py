"""The target's sample rate: taken from the FRF's sampling record, checked against --fs, said when defaulted; and
implausible time bases of logs refused with the fix.

The rule lives in :mod:`feedtune.cli.sampling_options` (docs/commands.md, "Sample rate of the target") and
:func:`feedtune.io.log_read.check_time_base`.
"""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest
from cli_run import run

from feedtune.errors import DataError
from feedtune.models import THESIS_TABLE_3_1

PPI_GAINS = ["--kpx", "60", "--kpv", "0.8", "--kiv", "100", "--allow-unstable"]
"""Fixed P-PI gains: no tuning, so every run is quick and the figures depend on fs and the delay alone."""




def run_json(args, capsys, monkeypatch) -> tuple[dict, str]:
    code, out, err = run([*args, "--json"], capsys, monkeypatch)
    assert code == 0, err
    return json.loads(out), err


def _write_frf(path, f_max: float, meta: dict) -> None:
    """The thesis model's response up to ``f_max`` [Hz] with ``meta`` added, written by feedtune's own writer."""
    from feedtune.io import write_frf

    frf = THESIS_TABLE_3_1.frf(np.linspace(2.0, f_max, 400))
    write_frf(replace(frf, meta={**frf.meta, **meta}), path)


def _record(fs: str, delay: str = "1") -> dict:
    return {"sampling": "removed", "sampling_fs_hz": fs, "sampling_delay_samples": delay}


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    """A ball-screw model file and FRFs recording 2500 Hz (delay 1 and 2), 5000 Hz, none, and one ending at 250 Hz."""
    from feedtune.io import save_model

    d = tmp_path_factory.mktemp("rates")
    paths = {"model": d / "model.toml", "f2500": d / "f2500.csv", "f2500_d2": d / "f2500_d2.csv",
             "f5000": d / "f5000.csv", "plain": d / "plain.csv", "short": d / "short.csv"}
    save_model(paths["model"], THESIS_TABLE_3_1)
    _write_frf(paths["f2500"], 1250.0, _record("2500"))
    _write_frf(paths["f2500_d2"], 1250.0, _record("2500", "2"))
    _write_frf(paths["f5000"], 2500.0, _record("5000"))
    _write_frf(paths["plain"], 3000.0, {})
    _write_frf(paths["short"], 250.0, _record("2500"))
    return paths


# ------------------------------------------------------------------------------------ design, analyze, tune
def test_design_takes_fs_and_delay_from_the_frf_record(files, tmp_path, capsys, monkeypatch):
    gains = tmp_path / "g.toml"
    base = ["design", "ppi", files["model"], *PPI_GAINS, "--frf", files["f2500"]]
    rec, _ = run_json([*base, "--out", gains], capsys, monkeypatch)
    assert (rec["fs_hz"], rec["fs_source"], rec["delay_samples"], rec["delay_source"]) == (2500.0, "frf", 1, "frf")
    explicit, _ = run_json([*base, "--fs", "2500", "--delay-samples", "1"], capsys, monkeypatch)
    assert (explicit["fs_hz"], explicit["fs_source"], explicit["delay_source"]) == (2500.0, "option", "option")
    assert rec["analysis"] == explicit["analysis"] and rec["gains"] == explicit["gains"]
    # independently of the JSON: the gains file is written for 2500 Hz
    doc = json.loads(gains.with_suffix(".json").read_text())  # the .json twin of the gains file
    fs = doc["sampling"]["fs_hz"]
    assert (fs["value"] if isinstance(fs, dict) else fs) == 2500.0 and doc["sampling"]["delay_samples"] == 1
    # and the figures do depend on it: the same gains at the old default 20 kHz analyse differently
    fast, _ = run_json([*base, "--fs", "20000", "--fs-override"], capsys, monkeypatch)
    assert fast["analysis"]["discrete"]["ms"] != pytest.approx(rec["analysis"]["discrete"]["ms"], rel=1e-3)
    # the text summary says where the rate came from
    code, out, err = run(base, capsys, monkeypatch)
    assert code == 0, err
    assert f"target sample rate 2500 Hz (recorded in {files['f2500']})" in out


def test_the_delay_record_is_used_unless_given(files, capsys, monkeypatch):
    base = ["design", "ppi", files["model"], *PPI_GAINS, "--frf", files["f2500_d2"]]
    rec, _ = run_json(base, capsys, monkeypatch)
    assert (rec["delay_samples"], rec["delay_source"]) == (2, "frf")
    explicit, _ = run_json([*base, "--delay-samples", "2"], capsys, monkeypatch)
    assert rec["analysis"] == explicit["analysis"]
    given, _ = run_json([*base, "--delay-samples", "1"], capsys, monkeypatch)
    assert (given["delay_samples"], given["delay_source"]) == (1, "option")


@pytest.mark.parametrize("command", [
    ["design", "ppc", "{model}", "--frf", "{f2500}", "--fs", "20000"],
    ["design", "ppi", "{model}", *PPI_GAINS, "--frf", "{f2500}", "--fs", "20000"],
    ["tune", "mcppc", "{model}", "--frf", "{f2500}", "--fs", "20000"],
    ["design", "ppi", "{model}", *PPI_GAINS, "--frf", "{f2500}", "--fs", "2503"],  # 0.12 % off
], ids=["design-ppc", "design-ppi", "tune-mcppc", "just-over-0.1%"])
def test_fs_disagreeing_with_the_frf_is_a_data_error(command, files, capsys, monkeypatch):
    args = [a.format(**files) for a in command]
    code, out, err = run(args, capsys, monkeypatch)
    lines = err.strip().splitlines()
    assert code == 1 and out == "" and len(lines) == 1, err
    fs = args[-1]
    assert lines[0] == (f"feedtune: error: {files['f2500']} records a sample rate of 2500 Hz (sampling_fs_hz), but "
                        f"--fs is {fs} Hz; omit --fs to use the recorded rate, or pass --fs-override to proceed at "
                        f"{fs} Hz anyway")


def test_fs_within_the_tolerance_is_accepted(files, capsys, monkeypatch):
    rec, _ = run_json(["design", "ppi", files["model"], *PPI_GAINS, "--frf", files["f2500"], "--fs", "2502"],
                      capsys, monkeypatch)
    assert (rec["fs_hz"], rec["fs_source"], rec["sampling_warnings"]) == (2502.0, "option", [])


def test_fs_override_proceeds_with_a_warning(files, capsys, monkeypatch):
    args = ["design", "ppi", files["model"], *PPI_GAINS, "--frf", files["f2500"], "--fs", "20000", "--fs-override"]
    rec, err = run_json(args, capsys, monkeypatch)
    assert (rec["fs_hz"], rec["fs_source"]) == (20000.0, "option")
    text = (f"{files['f2500']} records a sample rate of 2500 Hz (sampling_fs_hz), but --fs is 20000 Hz: proceeding "
            "at 20000 Hz (--fs-override)")
    assert text in rec["sampling_warnings"] and text not in err  # --json: the warnings are in the result
    code, out, err = run(args, capsys, monkeypatch)
    assert code == 0 and f"feedtune: warning: {text}" in err.splitlines() and "P-PI gains" in out


def test_two_frfs_recording_different_rates_are_a_data_error(files, capsys, monkeypatch):
    code, _, err = run(["tune", "mcppc", files["model"], "--frf", files["f2500"], "--frf", files["f5000"]],
                       capsys, monkeypatch)
    assert code == 1 and err.strip().splitlines() == [
        f"feedtune: error: {files['f2500']} records a sample rate of 2500 Hz but {files['f5000']} records 5000 Hz "
        "(sampling_fs_hz); give the target's rate with --fs (and --fs-override)"]


def test_two_frfs_recording_different_delays_are_a_data_error(files, capsys, monkeypatch):
    code, _, err = run(["tune", "mcppc", files["model"], "--frf", files["f2500"], "--frf", files["f2500_d2"]],
                       capsys, monkeypatch)
    assert code == 1 and "--delay-samples" in err and str(files["f2500_d2"]) in err


def test_without_fs_and_record_the_default_is_named(files, capsys, monkeypatch):
    for frf in ([], ["--frf", files["plain"]]):
        rec, _ = run_json(["design", "ppi", files["model"], *PPI_GAINS, *frf], capsys, monkeypatch)
        assert (rec["fs_hz"], rec["fs_source"], rec["delay_samples"], rec["delay_source"]) == (
            20000.0, "default", 1, "default")
    code, out, _ = run(["design", "ppi", files["model"], *PPI_GAINS], capsys, monkeypatch)
    assert code == 0
    assert ("target sample rate 20000 Hz (default of design ppi: no --fs, no rate recorded in an FRF), "
            "computational delay 1 sample(s) (default)") in out.splitlines()


def test_analyze_checks_the_gains_file_rate_against_the_frf(files, tmp_path, capsys, monkeypatch):
    gains = tmp_path / "g20k.toml"
    code, _, err = run(["design", "ppi", files["model"], *PPI_GAINS, "--out", gains], capsys, monkeypatch)
    assert code == 0, err
    code, _, err = run(["analyze", gains, "--frf", files["f2500"]], capsys, monkeypatch)
    assert code == 1 and err.strip().splitlines() == [
        f"feedtune: error: {files['f2500']} records a sample rate of 2500 Hz (sampling_fs_hz), but {gains}'s "
        "sampling.fs_hz is 20000 Hz; pass --fs-override to proceed at 20000 Hz anyway"]
    rec, _ = run_json(["analyze", gains, "--frf", files["f2500"], "--fs-override"], capsys, monkeypatch)
    assert (rec["fs_hz"], rec["fs_source"]) == (20000.0, "gains")
    assert any("--fs-override" in w for w in rec["sampling_warnings"])
    code, _, err = run(["analyze", gains, "--frf", files["f2500"], "--fs-override"], capsys, monkeypatch)
    assert code == 0 and "feedtune: warning: " in err and "--fs-override" in err
    rec, _ = run_json(["analyze", gains, "--frf", files["plain"]], capsys, monkeypatch)
    assert (rec["fs_hz"], rec["fs_source"], rec["sampling_warnings"]) == (20000.0, "gains", [])
    assert "fs_hz" not in run_json(["analyze", gains], capsys, monkeypatch)[0]  # no FRF: nothing checked


def test_an_frf_far_below_nyquist_draws_a_warning(files, capsys, monkeypatch):
    args = ["design", "ppi", files["model"], *PPI_GAINS, "--frf", files["short"]]
    rec, _ = run_json(args, capsys, monkeypatch)
    text = (f"{files['short']}: the FRF ends at 250 Hz, far below the Nyquist frequency 1250 Hz of fs = 2500 Hz; "
            "the loop above it rests on the model")
    assert rec["fs_hz"] == 2500.0 and rec["sampling_warnings"] == [text]
    code, _, err = run(args, capsys, monkeypatch)
    assert code == 0 and f"feedtune: warning: {text}" in err.splitlines()
    # at 2500 Hz an FRF to 1250 Hz covers the band: no warning
    rec, err = run_json(["design", "ppi", files["model"], *PPI_GAINS, "--frf", files["f2500"]], capsys, monkeypatch)
    assert rec["sampling_warnings"] == [] and "Nyquist" not in err


def test_gantry_commands_follow_the_rule(files, tmp_path, capsys, monkeypatch):
    """The check comes before any gantry-specific use of the FRF, so a ball-screw FRF shows it."""
    from feedtune.io import save_model
    from feedtune.models.gantry import THESIS_GANTRY

    model = tmp_path / "gantry.toml"
    save_model(model, THESIS_GANTRY)
    for cmd in (["design", "gantry", model], ["design", "pid", model], ["tune", "gantry", model]):
        code, _, err = run([*cmd, "--frf", files["f2500"], "--fs", "15000"], capsys, monkeypatch)
        assert code == 1 and "--fs-override" in err and "15000 Hz" in err, (cmd, err)


def test_the_rule_in_the_library():
    from feedtune.cli.sampling_options import target_sampling
    from feedtune.frf_sampling import band_warning, rates_disagree, recorded_fs

    frf = THESIS_TABLE_3_1.frf(np.linspace(2.0, 1000.0, 50))
    assert recorded_fs(frf) is None
    rec = replace(frf, meta={**frf.meta, "sampling_fs_hz": "2500"})
    assert recorded_fs(rec) == 2500.0
    assert not rates_disagree(2502.5, 2500.0) and rates_disagree(2502.6, 2500.0)
    assert band_warning(rec, 2500.0) is None and "far below" in band_warning(rec, 20000.0)
    got = target_sampling(None, None, [("a.csv", rec), ("b.csv", None)], default_fs=20000.0)
    assert (got.fs_hz, got.fs_source, got.fs_files, got.delay_samples, got.delay_source) == (
        2500.0, "frf", ("a.csv",), 1, "default")
    with pytest.raises(DataError, match=r"a\.csv records a sample rate of 2500 Hz"):
        target_sampling(20000.0, None, [("a.csv", rec)], default_fs=20000.0)
    bad = replace(frf, meta={**frf.meta, "sampling_fs_hz": "fast"})
    with pytest.raises(DataError, match=r"x\.csv: metadata sampling_fs_hz = 'fast' is not a sample rate"):
        target_sampling(None, None, [("x.csv", bad)], default_fs=20000.0)
    half = replace(rec, meta={**rec.meta, "sampling_delay_samples": "0.5"})
    got = target_sampling(None, None, [("h.csv", half)], default_fs=20000.0)
    assert got.delay_samples == 1 and any("0.5 samples" in w for w in got.warnings)


# ------------------------------------------------------------------------------------------------------ logs
def _log_csv(path, t, header: str = "time") -> None:
    n = len(t)
    u = np.sin(2 * np.pi * 0.01 * np.arange(n))
    x = np.cumsum(u) * 1e-3
    lines = [f"{header},u,x"] + [f"{a},{float(b)!r},{float(c)!r}" for a, b, c in zip(t, u, x, strict=True)]
    path.write_text("\n".join(lines) + "\n")


@pytest.mark.parametrize(("step", "factor", "unit"), [(400, "1e-6", "microseconds"), (2, "1e-3", "milliseconds")])
def test_integer_time_stamps_name_the_unit_fix(step, factor, unit, tmp_path, capsys, monkeypatch):
    log = tmp_path / "log.csv"
    _log_csv(log, [k * step for k in range(2000)])
    args = ["frf", log, "--input", "u", "--output", "x"]
    code, out, err = run(args, capsys, monkeypatch)
    fs = 1.0 / step
    assert code == 1 and out == "" and err.strip().splitlines() == [
        f"feedtune: error: {log}: column 'time': time stamps are integers with a step of {step} (fs would be "
        f"{fs:.3g} Hz); if they are {unit}, pass --scale time={factor}"]
    rec, _ = run_json([*args, "--scale", f"time={factor}"], capsys, monkeypatch)
    assert rec["sampling"]["fs_hz"] == pytest.approx(1.0 / (step * float(factor)), rel=1e-9)


def test_implausible_and_plausible_time_bases(tmp_path):
    from feedtune.io import read_log

    slow = tmp_path / "slow.csv"
    _log_csv(slow, [0.5 * k for k in range(100)], header="t")  # 2 Hz, not integers
    with pytest.raises(DataError, match=r"slow\.csv: column 't': the time stamps give fs = 2 Hz, below 100 Hz, "
                                        r"implausible for a servo log; check the time unit: convert it to seconds "
                                        r"with scale=t=FACTOR"):
        read_log(slow)
    fast = tmp_path / "fast.csv"
    _log_csv(fast, [1e-8 * k for k in range(100)])  # 100 MHz
    with pytest.raises(DataError, match=r"fs = 1e\+08 Hz, above 10 MHz"):
        read_log(fast)
    seconds = tmp_path / "seconds.csv"
    _log_csv(seconds, [k / 2500 for k in range(100)])
    assert read_log(seconds).fs == pytest.approx(2500.0)
    # the way out of each: a uniform time base (--fs), or a unit the user or the file states
    assert read_log(slow, fs=1000.0).fs == pytest.approx(1000.0)
    assert read_log(slow, scale={"t": 1e-3}).fs == pytest.approx(2000.0)
    stated = tmp_path / "stated.csv"
    _log_csv(stated, [400 * k for k in range(100)], header="time [us]")
    assert read_log(stated).fs == pytest.approx(2500.0)
    # a time in ms under a header that says s (a 20 kHz log read 1000 x too slow) is caught as well, as is a scale
    # that makes the rate implausible
    ms_as_s = tmp_path / "ms_as_s.csv"
    _log_csv(ms_as_s, [0.05 * k for k in range(100)], header="time [s]")
    with pytest.raises(DataError, match=r"column 'time': the time stamps \(in s, the unit the file states\) give "
                                        r"fs = 20 Hz, below 100 Hz"):
        read_log(ms_as_s)
    assert read_log(ms_as_s, scale={"time": 1e-3}).fs == pytest.approx(20000.0)
    with pytest.raises(DataError, match=r"\(with the scale given\) give fs = 2\.5 Hz"):
        read_log(stated, scale={"time": 1e3})


# ------------------------------------------------------------------------------------------------- real data
def test_real_two_mass_bench(real_data_dir, tmp_path, capsys, monkeypatch):
    """The FdiTools bench log stamps time in integer microseconds; its FRF records 2500 Hz, which design uses."""
    mat = real_data_dir / "twomass_motor_bench_FdiTools" / "MultisineTypeA.mat"
    frf, model = tmp_path / "bench.csv", tmp_path / "bench_model.toml"
    args = ["frf", mat, "--input", "u", "--output", "x1,x2", "--map", "u=iq_adx", "--map", "x1=theta_mx", "--map",
            "x2=theta_my", "--scale", "x2=-1", "--unit", "u=A", "--unit", "x1=rad", "--unit", "x2=rad", "--method",
            "periodic", "--period-samples", "2500"]
    code, _, err = run(args, capsys, monkeypatch)
    assert code == 1 and "column 'time': time stamps are integers with a step of 400" in err
    assert "pass --scale time=1e-6" in err
    rec, _ = run_json([*args, "--scale", "time=1e-6", "--out", frf], capsys, monkeypatch)
    assert rec["sampling"]["fs_hz"] == pytest.approx(2500.0) and rec["band_hz"] == pytest.approx([11.0, 250.0])
    code, _, err = run(["identify", "ballscrew", frf, "--out", model], capsys, monkeypatch)
    assert code == 0, err
    design = ["design", "ppc", model, "--beta", "2", "--pole-hz", "20", "--zeta", "0.7", "--frf", frf,
              "--allow-unstable"]
    rec, err = run_json(design, capsys, monkeypatch)
    assert (rec["fs_hz"], rec["fs_source"]) == (2500.0, "frf")
    nyquist = (f"{frf}: the FRF ends at 250 Hz, far below the Nyquist frequency 1250 Hz of fs = 2500 Hz; the loop "
               "above it rests on the model")
    assert rec["sampling_warnings"] == [nyquist]
    explicit, _ = run_json([*design, "--fs", "2500"], capsys, monkeypatch)
    assert explicit["analysis"] == rec["analysis"]
    code, _, err = run([*design, "--fs", "20000"], capsys, monkeypatch)
    assert code == 1 and "records a sample rate of 2500 Hz" in err and "--fs-override" in err
