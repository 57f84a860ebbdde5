"""Friction curve documents (``identify friction --curve-out``) and their Friction section in the report."""

from __future__ import annotations

import json
import re

import numpy as np
import pytest
from test_cli_logs import _one_line_error, run, run_json
from test_friction_laws import SPEEDS, _plateau_log, _truth

from feedtune.errors import DataError
from feedtune.identify.friction_curve import bin_by_speed
from feedtune.io import read_document, write_log_csv
from feedtune.io.friction_curve_file import read_friction_curve

MASS = 25.0  # N/(m/s^2) of the synthetic one-way run


@pytest.fixture(scope="module")
def one_way_log():
    """A one-way run (v > 0 only) of the hump law with a 25 kg mass: ramps and plateaus."""
    return _plateau_log(_truth("hump"), both=False, mass=MASS, noise=0.02)


def _report_data(html_path) -> dict:
    """The report's data document embedded in its HTML."""
    html = html_path.read_text(encoding="utf-8")
    m = re.search(r'<script[^>]*id="feedtune-report-data"[^>]*>(.*?)</script>', html, re.S)
    assert m, "no embedded report data"
    return json.loads(m.group(1))


def _param(doc: dict, direction: str, name: str) -> float:
    return float(doc["params"][direction][name]["value"])


def test_bin_by_speed_means_per_direction():
    v = np.concatenate([np.linspace(0.1, 1.0, 200), -np.linspace(0.1, 1.0, 50)])
    f = np.where(v > 0, 2.0, -3.0) + 0.0 * v
    pts = bin_by_speed(v, f, n_bins=10)
    pos = [p for p in pts if p["direction"] == "pos"]
    neg = [p for p in pts if p["direction"] == "neg"]
    assert len(pos) == 10 and len(neg) == 5  # 50 samples: 10 per bin at most 5 bins
    assert sum(p["n"] for p in pos) == 200 and sum(p["n"] for p in neg) == 50
    assert all(p["force"] == pytest.approx(2.0) and p["velocity"] > 0 for p in pos)
    assert all(p["force"] == pytest.approx(-3.0) and p["velocity"] < 0 for p in neg)
    assert bin_by_speed(v, f, min_speed=2.0) == []


def test_one_way_joint_fit_curve_document_and_report(tmp_path, capsys, monkeypatch, one_way_log):
    truth = _truth("hump")
    log_path, doc_path = tmp_path / "oneway.csv", tmp_path / "oneway_friction.toml"
    write_log_csv(one_way_log, log_path)
    result = run_json(["identify", "friction", log_path, "--law", "hump", "--curve-out", doc_path], capsys,
                      monkeypatch)
    assert result["method"] == "joint, one direction"
    assert result["files"] == [str(doc_path), str(doc_path.with_suffix(".json"))]
    doc = read_friction_curve(doc_path)
    assert read_document(doc_path.with_suffix(".json")) == read_document(doc_path)  # the JSON twin
    assert doc["schema"] == "feedtune.friction_curve/1" and doc["kind"] == "friction_curve"
    assert doc["law"] == "hump" and doc["directions"] == ["pos"] and doc["source"] == str(log_path)
    assert doc["command_unit"] == "N" and doc["velocity_unit"] == "m/s"
    # the truth within a few %: mass, Coulomb level and viscous coefficient
    assert doc["mass"] == {"value": pytest.approx(MASS, rel=0.02), "unit": "N/(m/s^2)"}
    assert _param(doc, "pos", "dc") == pytest.approx(truth.dc_pos, rel=0.05)
    assert _param(doc, "pos", "viscous") == pytest.approx(truth.viscous_pos, rel=0.1)
    assert doc["params"]["pos"]["omega"]["unit"] == "m/s" and doc["params"]["pos"]["viscous"]["unit"] == "N/(m/s)"
    assert all(q["value"] > 0 for q in doc["std"]["pos"].values())
    assert any("one way only" in w for w in doc["warnings"])
    # the points: F - m a binned by speed lie on the law
    pts = doc["points"]
    v, f = np.array(pts["velocity"]), np.array(pts["force"])
    assert v.size >= 5 and np.all(v > 0) and set(pts["direction"]) == {"pos"}
    assert np.max(np.abs(f - truth.force(v))) < 0.05 * np.max(np.abs(f))
    assert set(doc["curve"]) == {"pos"} and len(doc["curve"]["pos"]["velocity"]) == 100

    html = tmp_path / "r.html"
    summary = run_json(["report", doc_path, "--out", html], capsys, monkeypatch)
    assert "Identification" in summary["sections"] and summary["figures"] >= 1
    text = html.read_text(encoding="utf-8")
    assert 'id="friction"' in text and 'id="fig-friction-curve"' in text
    assert "one direction only (v &gt; 0)" in text and "[N versus m/s]" in text
    data = _report_data(html)
    ident = data["identification"][doc_path.name]
    assert ident["kind"] == "friction_curve" and ident["directions"] == ["pos"]
    assert ident["params"]["dc_pos"]["value"] == pytest.approx(_param(doc, "pos", "dc"))
    assert ident["params"]["mass"]["unit"] == "N/(m/s^2)"
    assert data["inputs"]["curves"] == [{"file": str(doc_path), "kind": "friction_curve", "law": "hump",
                                         "directions": ["pos"]}]


def test_one_way_steady_state_curve_document(tmp_path, capsys, monkeypatch, one_way_log):
    truth = _truth("hump")
    log_path, doc_path = tmp_path / "oneway.csv", tmp_path / "plateaus.json"
    write_log_csv(one_way_log, log_path)
    result = run_json(["identify", "friction", log_path, "--steady-state", "--law", "hump", "--curve-out",
                       doc_path], capsys, monkeypatch)
    assert result["files"] == [str(doc_path)]
    doc = read_friction_curve(doc_path)
    assert "mass" not in doc and doc["directions"] == ["pos"]
    assert len(doc["points"]["velocity"]) == SPEEDS.size
    for name, true in (("dc", truth.dc_pos), ("ds", truth.ds_pos), ("omega", truth.omega_pos),
                       ("viscous", truth.viscous_pos)):
        assert _param(doc, "pos", name) == pytest.approx(true, rel=0.03), name
    html = tmp_path / "r.html"
    run_json(["report", doc_path, "--out", html], capsys, monkeypatch)
    assert 'id="fig-friction-curve"' in html.read_text(encoding="utf-8")


def test_both_directions_joint_fit_writes_model_and_curve(tmp_path, capsys, monkeypatch):
    log_path = tmp_path / "both.csv"
    write_log_csv(_plateau_log(_truth("hump"), mass=MASS, noise=0.02), log_path)
    model, curve = tmp_path / "friction.toml", tmp_path / "curve.json"
    result = run_json(["identify", "friction", log_path, "--law", "hump", "--out", model, "--curve-out", curve],
                      capsys, monkeypatch)
    assert str(model) in result["files"] and str(curve) in result["files"]
    doc = read_friction_curve(curve)
    assert doc["directions"] == ["pos", "neg"] and _param(doc, "neg", "dc") < 0
    assert {p for p in doc["points"]["direction"]} == {"pos", "neg"}
    html = tmp_path / "r.html"
    run_json(["report", model, curve, "--out", html], capsys, monkeypatch)
    text = html.read_text(encoding="utf-8")
    assert 'id="fig-friction"' in text and 'id="fig-friction-curve"' in text
    assert "one direction only" not in text


def test_bad_input_is_refused(tmp_path, capsys, monkeypatch, one_way_log):
    log_path, doc_path = tmp_path / "oneway.csv", tmp_path / "curve.toml"
    write_log_csv(one_way_log, log_path)
    args = ["identify", "friction", log_path, "--law", "hump", "--curve-out", doc_path]
    run_json(args, capsys, monkeypatch)
    before = doc_path.read_bytes()
    code, _, err = run(args, capsys, monkeypatch)  # exists: refused before any work
    _one_line_error(code, err, 2, "exists; pass --force to overwrite")
    assert doc_path.read_bytes() == before
    doc_path.unlink()  # the JSON twin alone is also protected
    doc_path.with_suffix(".json").write_text("{}")
    code, _, err = run(args, capsys, monkeypatch)
    _one_line_error(code, err, 2, "curve.json exists; pass --force to overwrite")
    assert not doc_path.exists() and doc_path.with_suffix(".json").read_text() == "{}"
    code, _, err = run([*args, "--force"], capsys, monkeypatch)
    assert code == 0, err
    assert read_friction_curve(doc_path.with_suffix(".json"))["kind"] == "friction_curve"
    code, _, err = run([*args[:-1], tmp_path / "curve.csv"], capsys, monkeypatch)
    _one_line_error(code, err, 2, "written as .toml (with a .json twin) or .json")
    code, _, err = run([*args[:-1], tmp_path / "x.toml", "--mass", "25"], capsys, monkeypatch)
    _one_line_error(code, err, 2, "--curve-out needs --steady-state or the joint fit")
    code, _, err = run([*args[:-1], tmp_path / "x.toml", "--out", tmp_path / "x.toml"], capsys, monkeypatch)
    _one_line_error(code, err, 2, "name the same file")
    # a model file still needs both directions; nothing is written
    code, _, err = run([*args[:-1], tmp_path / "y.toml", "--out", tmp_path / "m.toml"], capsys, monkeypatch)
    _one_line_error(code, err, 1, "a friction model file needs both directions")
    assert not (tmp_path / "y.toml").exists() and not (tmp_path / "m.toml").exists()
    # a damaged document is refused by the report with the key named
    bad = tmp_path / "bad.json"
    doc = read_document(doc_path.with_suffix(".json"))
    doc["params"]["pos"]["dc"]["unit"] = "V"
    bad.write_text(json.dumps(doc))
    with pytest.raises(DataError, match=re.escape("params.pos.dc: unit 'V' where 'N' is expected")):
        read_friction_curve(bad)
    code, _, err = run(["report", bad, "--out", tmp_path / "bad.html"], capsys, monkeypatch)
    _one_line_error(code, err, 1, "params.pos.dc")
    assert not (tmp_path / "bad.html").exists()


@pytest.mark.slow
def test_rack_pinion_sequence_and_report(real_data_dir, tmp_path, capsys, monkeypatch):
    """docs/real_data.md, rack and pinion: convert, merge, the one-direction joint fit to a curve document, the
    report of it."""
    root = real_data_dir / "rack_pinion_friction_Mnich"
    if not (root / "a3NI.csv").is_file():
        pytest.skip("rack_pinion_friction_Mnich not present")
    monkeypatch.chdir(tmp_path)
    steps = [
        ["log", "convert", root / "a3MR.csv", "--skip-rows", "3", "--time", "Time", "--map",
         "n=Servo motor speed", "--unit", "n=rpm", "--keep", "n", "--out", "amp.csv"],
        ["log", "convert", root / "a3NI.csv", "--skip-rows", "2", "--time", "col0", "--map", "f=Force",
         "--keep", "f", "--out", "daq.csv"],
        ["log", "merge", "daq.csv", "amp.csv", "--shift", "f=0.004", "--offset", "f=mean:10", "--scale", "f=-200",
         "--unit", "f=N", "--scale", "n=-3.3333333e-4", "--unit", "n=m/s", "--integrate", "x=n", "--out",
         "rack.csv"],
    ]
    for step in steps:
        code, _, err = run(step, capsys, monkeypatch)
        assert code == 0, err
    result = run_json(["identify", "friction", "rack.csv", "--position", "x", "--input", "f", "--law", "hump",
                       "--curve-out", "rack_friction.toml"], capsys, monkeypatch)
    assert result["joint_fit"]["mass"] == pytest.approx(24.7, rel=0.1)  # the author's 24.7 kg
    doc = read_friction_curve(tmp_path / "rack_friction.toml")
    assert doc["directions"] == ["pos"] and doc["mass"]["value"] == pytest.approx(24.7, rel=0.1)
    assert len(doc["points"]["velocity"]) >= 5
    summary = run_json(["report", "rack_friction.toml", "--out", "rack.html"], capsys, monkeypatch)
    assert summary["figures"] >= 1
    text = (tmp_path / "rack.html").read_text(encoding="utf-8")
    assert 'id="fig-friction-curve"' in text and "one direction only" in text
