"""Library errors name parameters, the command line names flags (issue 15).

Each case raises one error through the library (a :class:`ValueError` whose message has no ``--`` and whose
``parameter`` is set) and the same bad input through the command line, which prints the flag.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from cli_run import run

from feedtune.control.filters import FilterPack, Notch
from feedtune.design.mcppc import design_mcppc
from feedtune.errors import DataError, UsageError
from feedtune.export.c_header import c_header
from feedtune.io import atomic_write_text, read_frf, read_log, write_document, write_log_csv
from feedtune.io.gains import gains_document
from feedtune.log import Log
from feedtune.models import THESIS_TABLE_3_1
from feedtune.report.build import build_report

VENDOR = Path(__file__).resolve().parents[1] / "examples" / "vendor"


def _library_error(kind, call, *args, **kwargs):
    with pytest.raises(kind) as err:
        call(*args, **kwargs)
    exc = err.value
    assert isinstance(exc, ValueError)
    assert "--" not in str(exc), str(exc)
    assert exc.parameter, str(exc)
    return exc


def _cli_error(args, capsys, monkeypatch, code):
    got, _, err = run(args, capsys, monkeypatch)
    assert got == code and err.startswith("feedtune: error: ") and err.count("\n") == 1, err
    return err


@pytest.fixture(scope="module")
def gains_doc():
    return gains_document(design_mcppc(THESIS_TABLE_3_1, filters=FilterPack([Notch(420.0, 0.55, 0.7)], 2000.0)))


def test_an_existing_output_needs_force(tmp_path, capsys, monkeypatch):
    out = tmp_path / "a.txt"
    atomic_write_text(out, "one")
    exc = _library_error(UsageError, atomic_write_text, out, "two")
    assert exc.parameter == "force" and "a.txt exists; pass force=True to overwrite" in str(exc)
    traj = tmp_path / "traj.csv"
    args = ["trajectory", "--distance", 0.02, "--v-max", 0.2, "--a-max", 4, "--j-max", 400, "--out", traj]
    code, _, err = run(args, capsys, monkeypatch)
    assert code == 0, err
    err = _cli_error(args, capsys, monkeypatch, 2)
    assert "traj.csv exists; pass --force to overwrite" in err


def test_c_export_options(gains_doc, tmp_path, capsys, monkeypatch):
    exc = _library_error(UsageError, c_header, gains_doc, u_max=-1.0)
    assert exc.parameter == "u_max" and "u_max must be a positive number, got -1.0" in str(exc)
    exc = _library_error(UsageError, c_header, gains_doc, anti_windup="clamp")
    assert exc.parameters == ("anti_windup", "u_max") and "anti_windup=clamp needs u_max" in str(exc)
    exc = _library_error(UsageError, c_header, gains_doc, prefix="9x")
    assert exc.parameter == "prefix" and "prefix '9x' is not a valid C identifier" in str(exc)
    gains = tmp_path / "g.toml"
    write_document(gains, gains_doc)
    err = _cli_error(["export", "c", gains, "--u-max", "-1"], capsys, monkeypatch, 2)
    assert "--u-max must be a positive number, got -1.0" in err
    err = _cli_error(["export", "c", gains, "--anti-windup", "clamp"], capsys, monkeypatch, 2)
    assert "--anti-windup clamp needs --u-max (the limit" in err
    err = _cli_error(["export", "c", gains, "--prefix", "9x"], capsys, monkeypatch, 2)
    assert "--prefix '9x' is not a valid C identifier" in err


def test_integer_microsecond_stamps_name_the_time_scale(tmp_path, capsys, monkeypatch):
    path = tmp_path / "us.csv"
    path.write_text("time,x\n" + "".join(f"{400 * i},{0.001 * i}\n" for i in range(50)))
    exc = _library_error(DataError, read_log, path)
    assert exc.parameter == "read_log.scale" and "pass scale=time=1e-6" in str(exc)
    err = _cli_error(["log", "convert", path, "--out", tmp_path / "out.csv"], capsys, monkeypatch, 1)
    assert "step of 400" in err and "pass --scale time=1e-6" in err


def test_frf_read_options(capsys, monkeypatch):
    exc = _library_error(DataError, read_frf, VENDOR / "bode_db.csv", scale={"x2/u": -1})
    assert exc.parameter == "read_frf.scale" and "scale x2/u=-1: " in str(exc) and "no channel 'x2/u'" in str(exc)
    exc = _library_error(DataError, read_frf, VENDOR / "two_row_header.csv")
    assert exc.parameter == "read_frf.skip_rows" and "pass skip_rows=N" in str(exc)
    err = _cli_error(["identify", "ballscrew", VENDOR / "bode_db.csv", "--frf-scale", "x2/u=-1"], capsys, monkeypatch,
                     1)
    assert "--frf-scale x2/u=-1.0: " in err and "no channel 'x2/u'" in err
    err = _cli_error(["identify", "ballscrew", VENDOR / "two_row_header.csv"], capsys, monkeypatch, 1)
    assert "pass --frf-skip-rows N" in err


def test_a_bad_frf_column_map_names_columns(capsys, monkeypatch):
    exc = _library_error(UsageError, read_frf, VENDOR / "bode_db.csv", columns={"x1/u.magdb": "Magnitude"})
    assert exc.parameter == "read_frf.columns" and "columns=x1/u.magdb=Magnitude: unknown KIND 'magdb'" in str(exc)
    err = _cli_error(["identify", "ballscrew", VENDOR / "bode_db.csv", "--frf-map", "x1/u.magdb=Magnitude"], capsys,
                     monkeypatch, 2)
    assert "--frf-map x1/u.magdb=Magnitude: unknown KIND 'magdb'" in err and "columns=" not in err


def test_an_ambiguous_frf_header_asks_for_a_column_map(capsys, monkeypatch):
    exc = _library_error(DataError, read_frf, VENDOR / "two_channels.csv")
    msg = str(exc)
    assert exc.parameter == "read_frf.columns" and "several magnitude columns" in msg
    assert "map the columns with columns=OUT/IN.KIND=COLUMN" in msg
    err = _cli_error(["identify", "ballscrew", VENDOR / "two_channels.csv"], capsys, monkeypatch, 1)
    assert "several magnitude columns" in err and "map the columns with --frf-map OUT/IN.KIND=COLUMN" in err


def test_a_log_of_unknown_kind_names_the_kind_option(tmp_path, capsys, monkeypatch):
    t = np.arange(2000) / 1000.0
    write_log_csv(Log(t, {"x": 1e-5 * np.sin(t), "u": 0.1 * np.ones_like(t)}, {"x": "m", "u": "V"}),
                  tmp_path / "snap.csv")
    exc = _library_error(DataError, build_report, [tmp_path / "snap.csv"])
    assert exc.parameter == "log_kinds" and "pass log_kinds=snap.csv=KIND" in str(exc)
    err = _cli_error(["report", tmp_path / "snap.csv", "--out", tmp_path / "r.html"], capsys, monkeypatch, 1)
    assert "pass --log-kind snap.csv=KIND with KIND one of" in err


REVERSALS = Path(__file__).resolve().parents[1] / "examples" / "ballscrew_reversals.csv"
IDENTIFY_OPTIONS = [
    (["rigid", REVERSALS, "--map", "x=x2", "--lpf-hz", "-1"], "--lpf-hz must be > 0"),
    (["rigid", REVERSALS, "--map", "x=x2", "--lpf-hz", "1e6"], "--lpf-hz must be below the Nyquist frequency"),
    (["rigid", REVERSALS, "--map", "x=x2", "--filter-order", "20"], "--filter-order must be an integer from 1 to 12"),
    (["rigid", REVERSALS, "--map", "x=x2", "--decimate", "0"], "--decimate must be an integer >= 1"),
    (["friction", REVERSALS, "--map", "x=x2", "--min-speed", "-1"], "--min-speed must be >= 0 rad/s"),
    (["friction", REVERSALS, "--map", "x=x2", "--reversal-guard", "-1"], "--reversal-guard must be >= 0 s"),
    (["friction", REVERSALS, "--map", "x=x2", "--bandwidth-hz", "1e9"], "--bandwidth-hz must be below a quarter"),
    (["friction", REVERSALS, "--map", "x=x2", "--mass", "-1"], "--mass must be > 0"),
    (["ballscrew", Path(__file__).resolve().parents[1] / "examples" / "ballscrew_frf.csv", "--lead", "-1"],
     "--lead must be a finite number > 0 m/rad"),
]


@pytest.mark.parametrize(("args", "words"), IDENTIFY_OPTIONS, ids=lambda a: " ".join(map(str, a[3:])) if
                         isinstance(a, list) else None)
def test_identify_settings_name_their_options(args, words, capsys, monkeypatch):
    """A bad identification setting is a usage error (exit 2) whose line names the option as typed, also where the
    library calls it otherwise (``cutoff_hz`` is ``--lpf-hz``, ``reversal_guard_s`` is ``--reversal-guard``)."""
    err = _cli_error(["identify", *args], capsys, monkeypatch, 2)
    assert words in err, err
    assert "_" not in err.split(" must ")[0], err  # no library spelling left before the message
