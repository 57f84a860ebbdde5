"""Command line end to end: FRF file -> model -> gains -> analysis -> C header, and bad input."""

from __future__ import annotations

import json

import numpy as np
import pytest
from cli_run import run

from feedtune.models import THESIS_TABLE_3_1

FILTERS = ["--notch", "420,0.55,0.7", "--notch", "1080,0.05,0.7", "--lpf", "2000"]


@pytest.fixture(scope="module")
def frf_files(tmp_path_factory):
    """The thesis model's FRF (noise-free) written in the three formats."""
    from feedtune.io import write_frf

    d = tmp_path_factory.mktemp("frf")
    frf = THESIS_TABLE_3_1.frf(np.logspace(0, np.log10(3000), 1200))
    paths = {}
    for ext in ("csv", "mat", "uff"):
        paths[ext] = d / f"bs.{ext}"
        write_frf(frf, paths[ext])
    return paths


@pytest.mark.parametrize("ext", ["csv", "mat", "uff"])
def test_frf_to_gains_to_header(ext, frf_files, tmp_path, capsys, monkeypatch):
    frf = frf_files[ext]
    model = tmp_path / "model.toml"
    code, out, err = run(["identify", "ballscrew", frf, "--out", model, "--json"], capsys, monkeypatch)
    assert code == 0, err
    res = json.loads(out)
    assert set(res) >= {"kind", "params", "modes", "fit"}
    for name, true in THESIS_TABLE_3_1.params().items():
        if name in ("m1", "m2", "k", "c"):
            assert res["params"][name]["value"] == pytest.approx(true, rel=0.01)
    assert res["modes"][0]["freq_hz"] == pytest.approx(130.0, abs=0.5)
    gains = tmp_path / "mcppc.toml"
    code, out, err = run(
        ["design", "ppc", model, *FILTERS, "--frf", frf, "--out", gains, "--json"], capsys, monkeypatch
    )
    assert code == 0, err
    res = json.loads(out)
    assert set(res["gains"]) >= {"Kx1", "Kx2", "Kv1", "Kv2", "Ki2"}
    for case in ("ideal", "measured", "discrete"):
        a = res["analysis"][case]
        assert set(a) >= {
            "crossovers_hz",
            "phase_margin_deg",
            "gain_margin_db",
            "ms",
            "ms_freq_hz",
            "rejection_band_hz",
            "stable",
        }
        assert a["stable"] is True
    assert gains.exists() and gains.with_suffix(".json").exists()
    assert json.loads(gains.with_suffix(".json").read_text())["schema"] == "feedtune.gains/1.1"
    header = tmp_path / "mcppc.h"
    code, out, err = run(["export", "c", gains, "--out", header], capsys, monkeypatch)
    assert code == 0, err
    assert "ft_step" in header.read_text()
    code, out, err = run(["analyze", gains, "--json"], capsys, monkeypatch)
    assert code == 0, err
    assert json.loads(out)["analysis"]["measured"] is None  # needs --frf


def test_ppi_user_gains_and_tuning(frf_files, tmp_path, capsys, monkeypatch):
    model = tmp_path / "m.toml"
    run(["identify", "ballscrew", frf_files["csv"], "--out", model], capsys, monkeypatch)
    code, out, err = run(
        ["design", "ppi", model, "--kpx", "60", "--kpv", "0.8", "--kiv", "100", "--limits", "thesis", "--json"], capsys,
        monkeypatch
    )
    assert code == 0, err
    res = json.loads(out)
    assert res["gains"]["Kpx"]["value"] == 60.0 and res["gains"]["Kx2"]["value"] == pytest.approx(0.8 * 60.0)
    code, out, err = run(["design", "ppi", model, "--ms-max", "2.5", *FILTERS, "--json"], capsys, monkeypatch)
    assert code == 0, err
    assert json.loads(out)["analysis"]["ideal_discrete"]["ms"] <= 2.5


def test_unstable_design_writes_nothing(frf_files, tmp_path, capsys, monkeypatch):
    model = tmp_path / "m.toml"
    run(["identify", "ballscrew", frf_files["csv"], "--out", model], capsys, monkeypatch)
    gains = tmp_path / "g.toml"
    args = ["design", "ppc", model, "--pole-hz", "600", *FILTERS, "--out", gains]
    code, _, err = run(args, capsys, monkeypatch)
    assert code == 1
    assert "unstable" in err and "Traceback" not in err and len(err.strip().splitlines()) == 1
    assert not gains.exists() and not gains.with_suffix(".json").exists()
    code, _, err = run([*args, "--allow-unstable"], capsys, monkeypatch)
    assert code == 0 and gains.exists() and "warning" in err  # written on request, with a warning


def test_bad_input_messages(frf_files, tmp_path, capsys, monkeypatch):
    bad = tmp_path / "bad.csv"
    bad.write_text("freq_hz,x1/u.re,x1/u.im,x2/u.re\n1,1,0,1\n2,1,0,1\n")
    code, _, err = run(["identify", "ballscrew", bad], capsys, monkeypatch)
    assert code == 1 and "bad.csv" in err and "x2/u" in err and len(err.strip().splitlines()) == 1
    nonnum = tmp_path / "nonnum.csv"
    nonnum.write_text("freq_hz,x1/u.re,x1/u.im\n1,abc,0\n2,1,0\n")
    code, _, err = run(["identify", "ballscrew", nonnum], capsys, monkeypatch)
    assert code == 1 and "nonnum.csv" in err
    code, _, err = run(["identify", "ballscrew", tmp_path / "missing.csv"], capsys, monkeypatch)
    assert code == 1 and "missing.csv" in err
    model = tmp_path / "m.toml"
    assert run(["identify", "ballscrew", frf_files["csv"], "--out", model], capsys, monkeypatch)[0] == 0
    code, _, err = run(["identify", "ballscrew", frf_files["csv"], "--out", model], capsys, monkeypatch)
    assert code == 2 and "--force" in err
    code, _, err = run(["design", "ppc", model, "--notch", "12000,0.1,0.7"], capsys, monkeypatch)
    assert code == 2 and "Nyquist" in err
    code, _, err = run(["design", "ppc", model, "--fs", "-5"], capsys, monkeypatch)
    assert code == 2 and "--fs" in err
    code, _, err = run(["identify", "ballscrew", frf_files["csv"], "--band", "300", "600"], capsys, monkeypatch)
    assert code == 1 and "mode" in err
    code, _, err = run(["design", "ppi", model, "--kpx", "10"], capsys, monkeypatch)
    assert code == 2 and "--kpv" in err
