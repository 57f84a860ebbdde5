"""A fleet run (feedtune/fleet/): the manifest, the Parquet history appended once per measurement, a failing axis as a
row, a killed run resumed, Dask and local processes giving the same history, the fleet page, the command line.

The fleet is small (6 simulated ball-screw axes x 4 weekly measurements, feedtune.fleet.simulated); the numbers of a
row are checked against the library calls the issue names, on the same file (identify ballscrew's fit_ballscrew, the
certificate of analyze GAINS --frf, identify rigid's fit_rigid), and the friction against the value simulated."""

from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from cli_run import run

pa = pytest.importorskip("pyarrow")

from feedtune.fleet import Engine, load_manifest, read_history, run_fleet, simulate_fleet  # noqa: E402
from feedtune.fleet.history import COLUMNS, part_files, schema  # noqa: E402

REPO = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def fleet(tmp_path_factory) -> Path:
    """6 axes x 4 weeks, one stiffness and one friction drift; its folder (copy it before changing files)."""
    d = tmp_path_factory.mktemp("fleet") / "fleet"
    simulate_fleet(d, 6, 4, drift_share=0.34, seed=2, truth=False)
    return d


@pytest.fixture(scope="module")
def local_history(fleet, tmp_path_factory) -> Path:
    """The fleet run on two local processes."""
    h = tmp_path_factory.mktemp("runs") / "history.parquet"
    with Engine(jobs=2) as engine:
        run_fleet(load_manifest(fleet / "fleet.toml"), h, engine=engine, status=False)
    return h


def _copy(fleet: Path, tmp_path: Path) -> Path:
    shutil.copytree(fleet, tmp_path / "fleet")
    return tmp_path / "fleet"


# ------------------------------------------------------------------------------------------ the manifest
def test_the_csv_manifest_is_the_toml_one(fleet, tmp_path):
    m = load_manifest(fleet / "fleet.toml")
    lines = ["machine,axis,gains,date,frf,log,log_position,log_input"]
    for a in m.axes:
        for meas in a.measurements:
            lines.append(f"{a.machine},{a.axis},{m.relative(a.gains)},{meas.date.isoformat()},"
                         f"{m.relative(meas.frfs[0])},{m.relative(meas.log)},x1,u")
    csv = fleet / "fleet_copy.csv"
    try:
        csv.write_text("\n".join(lines) + "\n", encoding="utf-8")
        c = load_manifest(csv)
    finally:
        csv.unlink()
    assert [a.id for a in c.axes] == [a.id for a in m.axes]
    for x, y in zip(c.axes, m.axes, strict=True):
        assert x.measurements == y.measurements and x.gains == y.gains and x.limits == y.limits
        assert x.log_options["position"] == y.log_options["position"] == "x1"


def test_option_tables_add_to_the_defaults(tmp_path):
    p = tmp_path / "fleet.toml"
    p.write_text('[defaults]\nlog_options = {position = "x1", velocity_threshold = 3.0}\nlimits = "thesis"\n'
                 '[[axis]]\nmachine = "A"\naxis = "X"\ngains = "g.toml"\nlog_options = {velocity_threshold = 2.0}\n'
                 '[[axis.measurement]]\ndate = 2025-01-06T08:30:00\nfrf = ["a.csv", "b.csv"]\nlog = "l.csv"\n',
                 encoding="utf-8")
    a = load_manifest(p).axes[0]
    assert a.log_options == {"position": "x1", "input": "u", "velocity_threshold": 2.0}
    assert [f.name for f in a.measurements[0].frfs] == ["a.csv", "b.csv"] and a.limits.name == "thesis"
    assert a.measurements[0].date.hour == 8 and a.measurements[0].log == tmp_path / "l.csv"


@pytest.mark.parametrize(("text", "words"), [
    ('[[axis]]\nmachine = "A"\naxis = "X"\ngains = "g.toml"\n', ["axis A/X", "measurement"]),
    ('[[axis]]\nmachine = "A"\naxis = "X"\ngains = "g.toml"\n[[axis.measurement]]\ndate = "soon"\nfrf = "a.csv"\n',
     ["axis A/X, measurement 1: date", "2025-01-06"]),
    ('[[axis]]\nmachine = "A"\naxis = "X"\ngains = "g.toml"\nlimit = "textbook"\n', ["unknown key(s) limit"]),
    ('[[axis]]\nmachine = "A"\naxis = "X"\ngains = "g.toml"\nstructure = "gantry"\n'
     '[[axis.measurement]]\ndate = 2025-01-06\nfrf = "a.csv"\n', ["structure 'gantry'", "ballscrew"]),
    ('[[axis]]\nmachine = "A"\naxis = "X"\ngains = "g.toml"\nlimits = {ms_max = 0.5}\n'
     '[[axis.measurement]]\ndate = 2025-01-06\nfrf = "a.csv"\n', ["limits", "ms_max"]),
    ('[[axis]]\nmachine = "A"\naxis = "X"\ngains = "g.toml"\n[[axis.measurement]]\ndate = 2025-01-06\nfrf = "a.csv"'
     '\n[[axis]]\nmachine = "A"\naxis = "X"\ngains = "g.toml"\n[[axis.measurement]]\ndate = 2025-01-07\nfrf = "b.csv"'
     '\n', ["axis A/X is listed twice"]),
])
def test_a_bad_manifest_is_one_line_naming_the_file_axis_and_key(tmp_path, text, words):
    from feedtune.errors import DataError

    p = tmp_path / "fleet.toml"
    p.write_text(text, encoding="utf-8")
    with pytest.raises(DataError) as err:
        load_manifest(p)
    msg = str(err.value)
    assert "\n" not in msg and str(p) in msg and all(w in msg for w in words), msg


# ------------------------------------------------------------------------------------------ the history
def test_one_row_per_measurement_with_the_library_calls_numbers(fleet, local_history):
    """Every measurement once; the row's fit, certificate and friction are those of fit_ballscrew, certify and
    fit_rigid on the same files, and the Coulomb friction is within 3 standard deviations of the simulated level."""
    from feedtune.identify.ballscrew import fit_ballscrew
    from feedtune.identify.rigid import fit_rigid
    from feedtune.io import read_document, read_frf, read_log
    from feedtune.machines.certificate import certify

    table = read_history(local_history)
    keys = table.column("key").to_pylist()
    assert table.num_rows == 24 and len(set(keys)) == 24
    assert table.schema.equals(schema(), check_metadata=False)
    row = table.slice(5, 1).to_pylist()[0]
    frf = read_frf(fleet / row["frf_files"])
    fit = fit_ballscrew(frf)
    assert row["k"] == fit.model.k and row["k_std"] == fit.std["k"] and row["mode_hz"] == fit.modes[0].freq_hz
    cert = certify(read_document(fleet / row["gains_file"]), row["gains_file"], [(row["frf_files"], frf)])
    worst = cert.worst()
    assert row["cert_ok"] == cert.ok and row["ms"] == worst["ms"] and row["gm_db"] == worst["gm_db"]
    assert row["verdict"] == ("ok" if cert.ok else "fails")
    rigid = fit_rigid(read_log(fleet / row["log_file"]), force="u", position="x1", velocity_threshold=3.0)
    assert row["coulomb"] == rigid.values["coulomb"] and row["coulomb_std"] == rigid.std["coulomb"]
    truth = next(a for a in load_manifest(fleet / "fleet.toml").axes if a.id == row["axis_id"])
    assert truth.id == row["axis_id"] and row["input_unit"] == "V" and row["force_unit"] == "V"


def test_the_history_is_a_parquet_dataset_with_units(local_history, tmp_path):
    """pandas reads the folder as it is (the lock and the proposals are not rows); every column has its unit."""
    import pandas as pd

    (local_history / "_proposals").mkdir(exist_ok=True)
    df = pd.read_parquet(local_history)
    assert len(df) == 24 and list(df.columns) == [c[0] for c in COLUMNS]
    units = {f.name: f.metadata[b"unit"].decode() for f in schema()}
    assert units["k"] == "U/rad" and units["first_crossover_hz"] == "Hz" and units["pm_deg"] == "deg"


def test_a_rerun_of_the_same_files_writes_nothing(fleet, local_history):
    before = {p.name: p.stat().st_mtime_ns for p in part_files(local_history)}
    result = run_fleet(load_manifest(fleet / "fleet.toml"), local_history, engine=Engine(jobs=1), status=False)
    assert result.summary.written == 0 and result.summary.already == 24
    assert {p.name: p.stat().st_mtime_ns for p in part_files(local_history)} == before


def test_a_failing_axis_is_a_row_an_unreadable_file_waits_for_the_next_run(fleet, tmp_path):
    """A corrupt FRF (its content) is a row with the error; a missing log (the machine) is not written, and the next
    run, with the file back, writes it; every other measurement is written (two axes of the fleet)."""
    from dataclasses import replace

    d = _copy(fleet, tmp_path)
    m = load_manifest(d / "fleet.toml")
    m = replace(m, axes=m.axes[:2])
    bad_frf = m.axes[0].measurements[2].frfs[0]
    bad_frf.write_text("freq_hz,x1/u.re\n1,2\n", encoding="utf-8")
    log = m.axes[1].measurements[0].log
    log.rename(log.with_suffix(".away"))
    h = tmp_path / "h.parquet"
    first = run_fleet(m, h, engine=Engine(jobs=1), status=False).summary
    assert first.written == 7 and len(first.data_errors) == 1 and len(first.not_written) == 1
    assert first.data_errors[0]["axis_id"] == m.axes[0].id and "FRF" in first.data_errors[0]["error"]
    assert str(log) in first.not_written[0]["error"]
    row = next(r for r in read_history(h).to_pylist() if r["error"])
    assert row["verdict"] == "error" and row["k"] is None and row["coulomb"] is not None
    log.with_suffix(".away").rename(log)
    second = run_fleet(m, h, engine=Engine(jobs=1), status=False).summary
    assert second.written == 1 and not second.not_written
    keys = read_history(h).column("key").to_pylist()
    assert len(keys) == len(set(keys)) == 8


KILLED_RUN = """
import sys
from feedtune.fleet import Engine, load_manifest, run_fleet
if __name__ == "__main__":
    with Engine(jobs=2) as engine:
        run_fleet(load_manifest(sys.argv[1]), sys.argv[2], engine=engine, status=False, batch_rows=2,
                  batch_seconds=0.0)
"""


def _descendants(pid: int) -> list[int]:
    """Every process below ``pid`` (Linux /proc), the fork server and its workers included."""
    out, todo = [], [pid]
    while todo:
        p = todo.pop()
        for task in Path(f"/proc/{p}/task").glob("*"):
            try:
                kids = [int(c) for c in (task / "children").read_text().split()]
            except OSError:
                continue
            out += kids
            todo += kids
    return out


@pytest.mark.slow
@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="/proc")
def test_a_run_killed_midway_resumes_with_no_duplicate_and_no_lost_row(fleet, local_history, tmp_path):
    """SIGKILL once the first part files are written: its worker processes end too; the re-run writes exactly the
    missing measurements and the history equals an uninterrupted run's."""
    h = tmp_path / "h.parquet"
    script = tmp_path / "run.py"
    script.write_text(KILLED_RUN, encoding="utf-8")
    proc = subprocess.Popen([sys.executable, str(script), str(fleet / "fleet.toml"), str(h)],
                            env={**os.environ, "PYTHONPATH": str(REPO)}, stderr=subprocess.PIPE)
    deadline = time.monotonic() + 120
    while len(part_files(h)) < 2 and proc.poll() is None and time.monotonic() < deadline:
        time.sleep(0.02)
    family = _descendants(proc.pid)
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    gone = time.monotonic() + 10
    while any(Path(f"/proc/{p}").exists() for p in family) and time.monotonic() < gone:
        time.sleep(0.1)
    assert family and not [p for p in family if Path(f"/proc/{p}").exists()], "worker processes outlived the run"
    written = read_history(h).num_rows
    assert 0 < written < 24, (written, proc.stderr.read().decode())
    resumed = run_fleet(load_manifest(fleet / "fleet.toml"), h, engine=Engine(jobs=2), status=False).summary
    assert resumed.already == written and resumed.written == 24 - written
    table = read_history(h)
    assert len(set(table.column("key").to_pylist())) == table.num_rows == 24
    assert table.drop(["feedtune_version"]).equals(read_history(local_history).drop(["feedtune_version"]))


@pytest.mark.slow
def test_a_dask_local_cluster_and_local_processes_give_the_same_history(fleet, local_history, tmp_path):
    distributed = pytest.importorskip("distributed")
    h = tmp_path / "h.parquet"
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cl:
        with Engine(scheduler=cl.scheduler_address) as engine:
            summary = run_fleet(load_manifest(fleet / "fleet.toml"), h, engine=engine, status=False).summary
    assert summary.engine.startswith("Dask scheduler") and len(summary.workers) == 2
    assert read_history(h).equals(read_history(local_history))


# ------------------------------------------------------------------------------------------ status and page
def test_the_status_and_the_page(fleet, local_history, tmp_path):
    """Every axis one row of the page, worst first, with its sparkline; links relative to the page."""
    from feedtune.fleet import fleet_status, plan_fleet, write_fleet_report

    d = _copy(fleet, tmp_path)
    text = (d / "fleet.toml").read_text(encoding="utf-8").replace('axis = "Y"', 'axis = "Y"\nreport = "r/M 1.html"', 1)
    (d / "fleet.toml").write_text(text, encoding="utf-8")
    m = load_manifest(d / "fleet.toml")
    status = fleet_status(m, local_history, plan_fleet(m))
    (tmp_path / "page").mkdir()
    out = write_fleet_report(status, tmp_path / "page" / "fleet.html")
    page = (tmp_path / "page" / "fleet.html").read_text(encoding="utf-8")
    assert out["axes"] == 6 and page.count('<td class="light">') == 6 and page.count("<svg") == 6
    assert 'href="../fleet/r/M%201.html"' in page
    order = [a["light"] for a in sorted(status.to_dict()["axes"], key=lambda a: page.index(f">{a['axis_id']}<"))]
    assert order == sorted(order, key=["red", "amber", "green", "grey"].index)
    assert all(a["measurements"] == 4 and not a["pending"] for a in status.to_dict()["axes"])
    json.dumps(status.to_dict())  # JSON-ready


def test_names_and_links_from_the_manifest_cannot_inject_markup(fleet, local_history, tmp_path):
    from feedtune.fleet import fleet_status, plan_fleet, write_fleet_report

    d = _copy(fleet, tmp_path)
    text = (d / "fleet.toml").read_text(encoding="utf-8")
    text = text.replace('machine = "M001"', 'machine = "M<script>alert(1)</script>"', 1)
    text = text.replace('axis = "Y"', 'axis = "Y"\nreport = "javascript:alert(2)"', 1)
    text = text.replace('name = "', 'name = "<b onmouseover=x>', 1)
    (d / "fleet.toml").write_text(text, encoding="utf-8")
    m = load_manifest(d / "fleet.toml")
    status = fleet_status(m, local_history, plan_fleet(m))
    write_fleet_report(status, tmp_path / "fleet.html")
    page = (tmp_path / "fleet.html").read_text(encoding="utf-8")
    assert "<script" not in page and "javascript:" not in page and "<b onmouseover" not in page
    assert "M&lt;script&gt;alert(1)&lt;/script&gt;/X" in page
    assert {a.light for a in status.axes if a.machine.startswith("M<")} == {"grey"}  # new axis ids: no rows yet


# ------------------------------------------------------------------------------------------ the command line
@pytest.mark.parametrize(("args", "code", "words"), [
    (["--jobs", "0"], 2, ["--jobs", ">= 1"]),
    (["--jobs", "2", "--scheduler", "tcp://127.0.0.1:1"], 2, ["--jobs", "--scheduler"]),
    (["--horizon", "-3"], 2, ["--horizon"]),
])
def test_bad_options_are_one_line_before_any_work(fleet, tmp_path, capsys, monkeypatch, args, code, words):
    got, _out, err = run(["fleet", "run", fleet / "fleet.toml", "--history", tmp_path / "h.parquet", *args], capsys,
                        monkeypatch)
    assert got == code and err.count("\n") == 1 and all(w in err for w in words), err
    assert not (tmp_path / "h.parquet").exists()


def test_a_missing_manifest_or_history_is_one_line(tmp_path, capsys, monkeypatch):
    code, _, err = run(["fleet", "run", tmp_path / "none.toml", "--history", tmp_path / "h.parquet"], capsys,
                       monkeypatch)
    assert code == 1 and "none.toml" in err and err.count("\n") == 1
    (tmp_path / "file.parquet").write_text("x")
    code, _, err = run(["fleet", "report", tmp_path / "none.toml", "--history", tmp_path / "file.parquet", "--out",
                        tmp_path / "p.html"], capsys, monkeypatch)
    assert code == 1 and "file.parquet" in err and "folder" in err


def test_run_then_report_from_the_command_line(fleet, local_history, tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    shutil.copytree(local_history, tmp_path / "h.parquet")
    code, out, err = run(["fleet", "run", fleet / "fleet.toml", "--history", "h.parquet", "--jobs", "1"], capsys,
                         monkeypatch)
    assert code == 0, err
    assert "24 measurements, 24 already in h.parquet, 0 written" in out and "axes:" in out
    code, out, err = run(["fleet", "report", fleet / "fleet.toml", "--history", "h.parquet", "--out", "p.html",
                          "--jobs", "1"], capsys, monkeypatch)
    assert code == 0 and "wrote p.html" in out and (tmp_path / "p.html").stat().st_size > 2000, err
    code, _, err = run(["fleet", "report", fleet / "fleet.toml", "--history", "h.parquet", "--out", "p.html"],
                       capsys, monkeypatch)
    assert code == 2 and "--force" in err


def test_every_row_has_a_value_for_every_figure_it_claims(local_history):
    """A row without an error has the fit, the certificate and the friction columns filled, finite."""
    for r in read_history(local_history).to_pylist():
        assert r["error"] is None and r["verdict"] in ("ok", "fails")
        for name in ("m1", "m2", "k", "c", "mode_hz", "ms", "pm_deg", "gm_db", "disk_margin", "first_crossover_hz",
                     "coulomb", "viscous", "mass"):
            assert r[name] is not None and np.isfinite(r[name]), name


@pytest.mark.slow
def test_a_red_axis_gets_a_re_tune_certified_on_its_newest_frf(tmp_path):
    """Limits the installed P-PI does not meet (GM >= 8.5 dB): the axis is red, --retune writes a P-PI whose
    certificate, computed again here on the newest FRF, meets them; a second run proposes nothing new."""
    from feedtune.analysis.limits import limits_profile
    from feedtune.io import read_document, read_frf
    from feedtune.machines.certificate import certify

    d = tmp_path / "one"
    simulate_fleet(d, 1, 3, drift_share=0.0, seed=4, truth=False)
    text = (d / "fleet.toml").read_text(encoding="utf-8").replace('limits = "textbook"',
                                                                  "limits = {profile = \"textbook\", gm_min_db = 8.5}")
    (d / "fleet.toml").write_text(text, encoding="utf-8")
    m = load_manifest(d / "fleet.toml")
    h = tmp_path / "h.parquet"
    result = run_fleet(m, h, engine=Engine(jobs=1), retune=True)
    axis = result.status.axes[0]
    assert axis.light == "red" and axis.proposal is not None, axis.reason
    assert result.summary.proposals == [{"axis_id": axis.axis_id, "file": axis.proposal["file"]}]
    doc = read_document(h / axis.proposal["file"])
    newest = m.axes[0].measurements[-1].frfs[0]
    limits = limits_profile("textbook").override(gm_min_db=8.5)
    cert = certify(doc, "proposal", [("newest", read_frf(newest))], limits)
    assert cert.ok and cert.worst()["gm_db"] >= 8.5 and doc["controller"] == "ppi"
    again = run_fleet(m, h, engine=Engine(jobs=1), retune=True)
    assert again.summary.proposals == [] and again.status.axes[0].proposal == axis.proposal


def test_docs_list_every_history_column():
    text = (REPO / "docs" / "fleet.md").read_text(encoding="utf-8")
    missing = [name for name, *_ in COLUMNS if f"| `{name}` |" not in text]
    assert not missing, missing


@pytest.mark.slow
def test_a_fleet_of_the_real_two_mass_bench(real_data_dir, tmp_path, capsys, monkeypatch):
    """The FdiTools bench's two multisine experiments as two weekly measurements of one axis (CSV manifest), its
    MC-PPC tuned on the first: both rows carry the coupling's mode (76 Hz, docs/real_data.md) and the certificate
    analyze GAINS --frf gives on the same file, in A; the light follows the newest certificate."""
    bench = real_data_dir / "twomass_motor_bench_FdiTools"
    monkeypatch.chdir(tmp_path)
    for t in "AB":
        code, _, err = run(["frf", bench / f"MultisineType{t}.mat", "--map", "u=iq_adx", "--map", "x1=theta_mx",
                            "--map", "x2=theta_my", "--scale", "x2=-1", "--scale", "time=1e-6", "--unit", "u=A",
                            "--unit", "x1=rad", "--unit", "x2=rad", "-y", "x1,x2", "--method", "periodic",
                            "--period-samples", "2500", "--out", f"frf_{t}.csv"], capsys, monkeypatch)
        assert code == 0, err
    for args in (["identify", "ballscrew", "frf_A.csv", "--out", "tm.toml"],
                 ["tune", "mcppc", "tm.toml", "--frf", "frf_A.csv", "--out", "gains.toml"]):
        code, _, err = run(args, capsys, monkeypatch)
        assert code == 0, err
    Path("fleet.csv").write_text("machine,axis,gains,date,frf\nbench,motor,gains.toml,2019-01-07,frf_A.csv\n"
                                 "bench,motor,gains.toml,2019-01-14,frf_B.csv\n", encoding="utf-8")
    code, out, err = run(["fleet", "run", "fleet.csv", "--history", "h.parquet", "--jobs", "1", "--json"], capsys,
                         monkeypatch)
    assert code == 0, err
    doc = json.loads(out)
    rows = read_history("h.parquet").to_pylist()
    light = "green" if rows[-1]["verdict"] == "ok" else "red"  # tuned to PM 30.0 deg on A, B may fail it
    assert doc["run"]["written"] == 2 and doc["status"]["counts"][light] == 1
    for row, t in zip(rows, "AB", strict=True):
        assert row["frf_files"] == f"frf_{t}.csv" and 70 < row["mode_hz"] < 82 and row["input_unit"] == "A"
        code, out, err = run(["analyze", "gains.toml", "--frf", f"frf_{t}.csv", "--json"], capsys, monkeypatch)
        check = json.loads(out)["check"]
        assert row["cert_ok"] == check["ok"]
        assert row["ms"] == pytest.approx(next(i["value"] for i in check["items"] if i["name"] == "ms"), rel=1e-9)
