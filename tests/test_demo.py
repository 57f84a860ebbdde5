"""feedtune demo on the full twin (acceptance: MC-PPC beats P-PI) and the simulate/trajectory/demo commands."""

from __future__ import annotations

import json

import numpy as np
import pytest
import typer
from typer.testing import CliRunner

from feedtune.analysis.comparison import verdict_line
from feedtune.analysis.limits import DEFAULT_LIMITS
from feedtune.analysis.metrics import ropesnap_metrics, tracking_metrics
from feedtune.cli import demo_cmd, simulate_cmd, trajectory_cmd
from feedtune.errors import DataError, UsageError, cli_message
from feedtune.io import read_document, read_log, write_document
from feedtune.machines.ballscrew.runtime import GainsRuntime
from feedtune.models import THESIS_TABLE_3_1 as MODEL
from feedtune.workflows.ballscrew_demo import run_demo
from feedtune.workflows.files import write_texts


@pytest.fixture(scope="module")
def demo():
    return run_demo(seed=1)


@pytest.fixture(scope="module")
def cli():
    app = typer.Typer(pretty_exceptions_enable=False)
    app.add_typer(simulate_cmd.app, name="simulate")
    app.command("trajectory")(trajectory_cmd.trajectory)
    app.command("demo")(demo_cmd.demo)
    runner = CliRunner()

    def invoke(*args):
        return runner.invoke(app, [str(a) for a in args])

    return invoke


def _row(demo, test):
    return next(r for r in demo.rows if r["test"].startswith(test))


# ------------------------------------------------------------------------------------ acceptance
@pytest.mark.slow
def test_mcppc_beats_ppi_on_the_full_twin(demo):
    rope = _row(demo, "0.5 V")
    assert rope["mcppc"]["peak_um"] < rope["ppi"]["peak_um"]
    assert rope["mcppc"]["settling_time_s"] < rope["ppi"]["settling_time_s"]
    for speed in (200, 500, 1000):
        row = _row(demo, f"track {speed} mm/s")
        assert row["mcppc"]["max_um"] < 0.7 * row["ppi"]["max_um"], speed
        assert row["mcppc"]["rms_um"] < 0.7 * row["ppi"]["rms_um"], speed


@pytest.mark.slow
def test_demo_identifies_the_twin_and_tunes_both_controllers_under_the_same_limits(demo, tmp_path):
    got = demo.identified["params"]
    for name in ("m1", "m2", "k", "c"):
        assert got[name] == pytest.approx(getattr(MODEL, name), rel=0.05), name
    assert set(demo.designs) == {"mcppc", "ppi"}
    # the exported files, read back and checked by the command a user would run, pass the same limits
    paths = write_texts(demo.texts, out_dir=tmp_path / "out")
    frf = next(p for p in paths if p.name == "frf.csv")
    for name in ("mcppc", "ppi"):
        d = demo.designs[name]
        assert d["tuning"]["limits"] == demo.limits == DEFAULT_LIMITS.to_dict()
        assert d["tuning"]["objective"] == "stiffness"  # both by the same objective, the default
        assert d["tuning"]["objective_rule"] == demo.designs["mcppc"]["tuning"]["objective_rule"]
        code = _analyze(tmp_path / "out" / f"{name}_gains.toml", frf)
        assert code == 0, name
    # the verdict names the baseline where it wins
    assert "P-PI is better in" not in demo.table() or any(
        w == "ppi" for row in demo.rows for w in row["better"].values())


def _analyze(gains, frf):
    import sys

    from feedtune.cli.main import main

    argv = sys.argv
    sys.argv = ["feedtune", "analyze", str(gains), "--frf", str(frf), "--check", "--json"]
    try:
        main()
    except SystemExit as exc:
        return exc.code
    finally:
        sys.argv = argv
    return 0


def test_verdict_names_what_the_baseline_wins():
    rows = [{"test": "track 200 mm/s", "mcppc": {"max_um": 1.0, "rms_um": 0.5}, "ppi": {"max_um": 2.0, "rms_um": 0.4}},
            {"test": "0.5 V", "mcppc": {"peak_um": 10.0, "settling_time_s": None},
             "ppi": {"peak_um": 10.01, "settling_time_s": 0.1}}]
    text = verdict_line(rows)
    assert text.startswith("MC-PPC is better in 1 of 4 figures, P-PI in 2, 1 tie(s)")
    assert "P-PI is better in: track 200 mm/s RMS, 0.5 V settling time." in text


@pytest.mark.slow
def test_demo_files_hold_what_the_table_says(demo, tmp_path):
    paths = write_texts(demo.texts, out_dir=tmp_path / "out")
    names = {p.name for p in paths}
    assert {"frf_measurement.csv", "frf.csv", "model.toml", "mcppc_gains.toml", "ppi_gains.json", "summary.json",
            "ropesnap_mcppc.csv", "track_1000mm_s_ppi.csv"} <= names
    log = read_log(tmp_path / "out" / "track_500mm_s_mcppc.csv")
    e = log["x_ref"] - log["x2"] * MODEL.lead_m_per_rad  # the table error, from the encoder and the reference
    m = tracking_metrics(log.t, e, spectrum=False)
    assert m.overall.max_abs * 1e6 == pytest.approx(_row(demo, "track 500")["mcppc"]["max_um"], rel=1e-9)
    rope = read_log(tmp_path / "out" / "ropesnap_ppi.csv")
    rm = ropesnap_metrics(rope.t, rope["x2_table"], t_release=float(rope.meta["t_release_s"]))
    assert rm.peak * 1e6 == pytest.approx(_row(demo, "0.5 V")["ppi"]["peak_um"], rel=1e-9)
    rt = GainsRuntime.from_file(tmp_path / "out" / "mcppc_gains.toml")
    assert rt.controller == "mcppc" and rt.fs == 20000.0
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert summary["comparison"][0]["mcppc"]["peak_um"] == pytest.approx(_row(demo, "0.5 V")["mcppc"]["peak_um"])


@pytest.mark.slow
def test_writing_is_all_or_nothing(demo, tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    (out / "frf.csv").write_text("mine")
    with pytest.raises(UsageError, match="exists"):
        write_texts(demo.texts, out_dir=out)
    assert [p.name for p in out.iterdir()] == ["frf.csv"] and (out / "frf.csv").read_text() == "mine"


# ------------------------------------------------------------------------------------ command line
def test_demo_command_refuses_a_non_empty_folder(cli, tmp_path):
    (tmp_path / "keep.txt").write_text("x")
    res = cli("demo", "--out", tmp_path)
    assert isinstance(res.exception, UsageError) and "not empty" in str(res.exception)
    assert [p.name for p in tmp_path.iterdir()] == ["keep.txt"]


@pytest.mark.slow
def test_trajectory_command_writes_a_log_the_twin_can_track(cli, tmp_path, demo):
    traj = tmp_path / "traj.csv"
    res = cli("trajectory", "--distance", 0.02, "--v-max", 0.2, "--a-max", 4, "--j-max", 400,
              "--dwell-after", 0.02, "--out", traj, "--json")
    assert res.exit_code == 0, res.output
    info = json.loads(res.output)
    # closed form of the 7-segment profile: T1 = D/v, T2 = v/a, T3 = a/j
    assert info["duration"] == pytest.approx(0.02 / 0.2 + 0.2 / 4 + 4 / 400 + 0.02, abs=1e-4)
    log = read_log(traj)
    assert log["x_ref"][-1] == pytest.approx(0.02) and {"v_ref", "a_ref", "j_ref", "s_ref"} <= set(log.signals)
    gains = tmp_path / "g.toml"
    gains.write_text(demo.texts["mcppc_gains.toml"])
    out = tmp_path / "track.csv"
    res = cli("simulate", "track", "--gains", gains, "--trajectory", traj, "--out", out, "--json")
    assert res.exit_code == 0, res.output
    tracked = read_log(out)
    assert {"x_ref", "v_ref", "a_ref", "x1", "x2", "u", "e2"} <= set(tracked.signals)
    assert np.allclose(tracked["x_ref"], log["x_ref"])
    again = cli("simulate", "track", "--gains", gains, "--trajectory", traj, "--out", out)
    assert isinstance(again.exception, UsageError) and "pass --force" in cli_message(again.exception)


@pytest.mark.parametrize(
    ("args", "error", "needle"),
    [
        (("trajectory", "--distance", 0.1, "--v-max", -1, "--a-max", 5, "--j-max", 500), UsageError, "v_max"),
        (("trajectory", "--distance", 0.1, "--v-max", 1, "--a-max", 5, "--j-max", 500, "--s-max", 1), UsageError,
         "s_max"),
        (("simulate", "frf", "--machine", "gantry"), UsageError, "unknown machine 'gantry'"),
        (("simulate", "frf", "--param", "mass=2"), UsageError, "unknown twin parameter 'mass'"),
        (("simulate", "frf", "--excitation", "hammer"), UsageError, "excitation must be one of"),
    ],
)
def test_bad_options_are_clear_errors_without_files(cli, tmp_path, args, error, needle):
    out = tmp_path / "x.csv"
    res = cli(*args, "--out", out)
    assert isinstance(res.exception, error) and needle in str(res.exception)
    assert list(tmp_path.iterdir()) == []


@pytest.mark.slow
def test_gains_for_another_sample_rate_is_refused(cli, tmp_path, demo):
    doc = read_document_text(demo.texts["ppi_gains.toml"])
    doc["sampling"]["fs_hz"]["value"] = 10000.0
    write_document(tmp_path / "g.toml", doc)
    res = cli("simulate", "ropesnap", "--gains", tmp_path / "g.toml", "--out", tmp_path / "r.csv")
    assert isinstance(res.exception, DataError) and "10000 Hz" in str(res.exception)
    assert not (tmp_path / "r.csv").exists()


@pytest.mark.slow
def test_unstable_controller_stops_with_a_clear_error_and_a_log_that_says_so(cli, tmp_path, demo):
    doc = read_document_text(demo.texts["mcppc_gains.toml"])
    for g in doc["gains"].values():
        g["value"] = -g["value"]
    write_document(tmp_path / "g.toml", doc)
    out = tmp_path / "r.csv"
    res = cli("simulate", "ropesnap", "--gains", tmp_path / "g.toml", "--out", out)
    assert isinstance(res.exception, DataError) and "following-error trip" in str(res.exception)
    assert "trip" in read_log(out).meta


def test_frf_command_writes_log_and_frf(cli, tmp_path):
    out = tmp_path / "m.csv"
    res = cli("simulate", "frf", "--out", out, "--ideal", "--excitation", "prbs", "--periods", 3, "--json")
    assert res.exit_code == 0, res.output
    files = json.loads(res.output)["files"]
    assert files == [str(out), str(tmp_path / "m_frf.csv")]
    assert set(read_log(out).signals) == {"r", "u", "x1", "x2"}


def read_document_text(text: str) -> dict:
    from feedtune.io.document import loads_document

    return loads_document(text, "toml", "gains")


@pytest.mark.slow
def test_read_document_round_trip_of_demo_gains(tmp_path, demo):
    (tmp_path / "g.toml").write_text(demo.texts["ppi_gains.toml"])
    assert read_document(tmp_path / "g.toml")["controller"] == "ppi"


# ------------------------------------------------------------------------------------ pre-filter
@pytest.mark.slow
def test_demo_prefilter_from_one_run_improves_every_speed(demo, tmp_path):
    for speed in (200, 500, 1000):
        row = _row(demo, f"track {speed} mm/s")
        # measured (seed 1): RMS 0.346 -> 0.130, 0.572 -> 0.164, 0.727 -> 0.167 um
        assert row["mcppc_prefilter"]["rms_um"] < 0.6 * row["mcppc"]["rms_um"], speed
        assert row["mcppc_prefilter"]["max_um"] < row["mcppc"]["max_um"], speed
    assert demo.prefilter["speed_mm_s"] == 500 and set(demo.prefilter["gains"]) == {"K_vel", "K_acc", "K_jerk",
                                                                                      "K_snap"}
    write_texts(demo.texts, out_dir=tmp_path / "out")
    rt = GainsRuntime.from_file(tmp_path / "out" / "mcppc_prefilter_gains.toml")
    assert rt.to_dict()["prefilter"]["gains"] == pytest.approx(demo.prefilter["gains"])
    log = read_log(tmp_path / "out" / "track_1000mm_s_mcppc_prefilter.csv")
    e = log["x_ref"] - log["x2"] * MODEL.lead_m_per_rad  # table error from the encoder
    rms = float(np.sqrt(np.mean(e**2))) * 1e6
    assert rms == pytest.approx(_row(demo, "track 1000")["mcppc_prefilter"]["rms_um"], rel=1e-6)
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert summary["prefilter"]["gains"]["K_acc"] == pytest.approx(demo.prefilter["gains"]["K_acc"])
    assert "MC-PPC+PF" in demo.table()


@pytest.mark.slow
def test_the_demo_writes_the_certificate_design_writes_on_its_frf(demo, tmp_path, capsys, monkeypatch):
    """Issue 24: one delivery exit. The demo's MC-PPC certified on its twin FRF (from memory: its arrays), and
    ``design ppc`` with the same settings on the FRF file the demo wrote (a file: its bytes) write the same
    certificate; the FRF file holds the same arrays the demo certified on."""
    from cli_run import run

    from feedtune.io import read_document

    write_texts(demo.texts, out_dir=tmp_path)
    doc = read_document(tmp_path / "mcppc_gains.toml")
    d, s = doc["design"], doc["sampling"]
    code, _, err = run(["design", "ppc", tmp_path / "model.toml", "--beta", repr(d["beta"]), "--pole-hz",
                        repr(d["pole_hz"]), "--zeta", repr(d["zeta"]), "--notch", "420,0.55,0.7", "--notch",
                        "1080,0.05,0.7", "--lpf", "2000", "--fs", repr(s["fs_hz"]["value"]), "--delay-samples",
                        str(s["delay_samples"]), "--frf", tmp_path / "frf.csv", "--out", tmp_path / "designed.toml"],
                       capsys, monkeypatch)
    assert code == 0, err
    designed = read_document(tmp_path / "designed.toml")
    assert designed["gains"] == doc["gains"]
    a, b = doc["certificate"], designed["certificate"]
    assert a["frfs"][0]["identity"] == "arrays" and b["frfs"][0]["identity"] == "file"
    assert a["frfs"][0]["arrays_sha256"] == b["frfs"][0]["arrays_sha256"]

    def figures(c):
        return {**{k: v for k, v in c.items() if k not in ("frfs", "worst", "gains_sha256", "sections_sha256")},
                "frfs": [{k: v for k, v in e.items() if k not in ("frf", "sha256", "identity")} for e in c["frfs"]],
                "worst": {k: ({**v, "frf": None} if isinstance(v, dict) else v) for k, v in c["worst"].items()
                          if not k.endswith("_frf")}}

    assert figures(a) == figures(b)
