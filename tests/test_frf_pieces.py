"""One FRF from one file per channel: the ``FILE:OUT/IN`` pieces, their merge on the common lines, and the refusals.

The reference is the model the files were written from (Table 3.1's 2-mass model), not the code that merges them: two
vendor Bode files of its x1/u and of its sign-inverted x2/u, read as pieces, must give back that model's response and
its parameters; the refusals must name both files.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
from cli_run import run

from feedtune.cli.frf_options import FrfReadOptions, parse_frf_argument, read_frf_argument
from feedtune.errors import DataError, UsageError
from feedtune.frf import Frf
from feedtune.frf_merge import merge_frfs, pick_channel
from feedtune.identify.ballscrew import fit_ballscrew
from feedtune.models import THESIS_TABLE_3_1

F = np.geomspace(5.0, 800.0, 300)


def _bode_file(path, freq, h, coherence=None, digits=17):
    """A vendor Bode export: ``Frequency [Hz],Magnitude [dB],Phase [deg]`` (and a coherence column)."""
    head = "Frequency [Hz],Magnitude [dB],Phase [deg]" + (",Coherence" if coherence is not None else "")
    rows = [head]
    for k, (f, v) in enumerate(zip(freq, h, strict=True)):
        cells = [f"{f:.{digits}g}", f"{20 * np.log10(abs(v)):.{digits}g}", f"{np.degrees(np.angle(v)):.{digits}g}"]
        if coherence is not None:
            cells.append(f"{coherence[k]:.6g}")
        rows.append(",".join(cells))
    path.write_text("\n".join(rows) + "\n")
    return path


@pytest.fixture
def bode_pair(tmp_path):
    """Table 3.1's x1/u and its x2/u sign-inverted (a load encoder counting the other way) as two Bode files."""
    frf = THESIS_TABLE_3_1.frf(F)
    motor = _bode_file(tmp_path / "motor.csv", F, frf.channel("x1/u"))
    load = _bode_file(tmp_path / "load.csv", F, -frf.channel("x2/u"))
    return frf, motor, load


def test_pieces_give_back_the_model_response_and_parameters(bode_pair):
    frf, motor, load = bode_pair
    merged = read_frf_argument(f"{motor}:x1/u+{load}:x2/u,scale=-1", note=False)
    assert merged.channels == ["x1/u", "x2/u"] and np.array_equal(merged.freq_hz, F)
    for ch in ("x1/u", "x2/u"):
        assert np.max(np.abs(merged.channel(ch) / frf.channel(ch) - 1)) < 1e-12
    assert merged.source == f"{motor} + {load}" and "x2/u from" in merged.meta["merge"]
    fit = fit_ballscrew([merged], fit_delay=False)
    for name in ("m1", "m2", "k"):
        assert getattr(fit.model, name) == pytest.approx(getattr(THESIS_TABLE_3_1, name), rel=1e-6), name


def test_two_arguments_are_two_frfs_and_identify_reads_them_in_one_command(bode_pair, capsys, monkeypatch):
    _, motor, load = bode_pair
    code, out, err = run(["identify", "ballscrew", f"{motor}:x1/u", f"{load}:x2/u,scale=-1", "--no-delay",
                          "--frf-input-unit", "A", "--json"], capsys, monkeypatch)
    assert code == 0, err
    doc = json.loads(out)
    assert doc["params"]["k"]["value"] == pytest.approx(THESIS_TABLE_3_1.k, rel=1e-6)
    assert doc["params"]["m1"]["unit"] == "A/(rad/s^2)"  # the input unit given on the command line
    assert "x2/u.mag_db=Magnitude [dB]" in err  # the column note names the channel given, not the default


def test_the_same_pair_without_channel_names_is_refused_naming_both_files(bode_pair, capsys, monkeypatch):
    _, motor, load = bode_pair
    code, _, err = run(["identify", "ballscrew", motor, load], capsys, monkeypatch)
    assert code == 2 and str(motor) in err and str(load) in err and "name the channel of each file" in err
    assert "channels=" not in err and "auto_channel" not in err  # no library parameter on the command line
    again = motor.with_name("motor_again.csv")
    again.write_text(motor.read_text())
    code, _out, err = run(["identify", "ballscrew", motor, again, "--frf-channel", "x1/u", "--no-delay", "--json"],
                         capsys, monkeypatch)
    assert code == 0, err  # said explicitly: two motor-side measurements, fitted together


def test_merge_refuses_one_channel_twice_other_grids_and_other_units(tmp_path, bode_pair):
    _frf, motor, load = bode_pair
    with pytest.raises(DataError, match="both give channel x1/u") as err:
        read_frf_argument(f"{motor}:x1/u+{load}:x1/u", note=False)
    assert str(motor) in str(err.value) and str(load) in str(err.value)
    other = _bode_file(tmp_path / "other.csv", np.geomspace(5.0, 800.0, 250), np.ones(250))
    with pytest.raises(DataError, match="different frequency grids") as err:
        read_frf_argument(f"{motor}:x1/u+{other}:x2/u", note=False)
    assert str(motor) in str(err.value) and str(other) in str(err.value)
    with pytest.raises(DataError, match="differ in their input unit") as err:
        read_frf_argument(f"{motor}:x1/u,in=A+{load}:x2/u", note=False)
    assert "(A and V)" in str(err.value)
    options = FrfReadOptions.from_cli(frf_input_unit="A")
    assert read_frf_argument(f"{motor}:x1/u+{load}:x2/u", options=options, note=False).input_unit == "A"


def test_common_lines_lines_written_with_fewer_digits_and_another_quantity(tmp_path):
    """Lines outside the band both files cover are dropped (and counted); a grid written with 6 digits is the same
    grid; a velocity file is converted to the first file's quantity exactly."""
    frf = THESIS_TABLE_3_1.frf(F)
    a = _bode_file(tmp_path / "a.csv", F, frf.channel("x1/u"))
    b = _bode_file(tmp_path / "b.csv", F[20:], frf.channel("x2/u")[20:] * 2j * np.pi * F[20:], digits=6)
    merged = read_frf_argument(f"{a}:x1/u+{b}:x2/u,quantity=velocity", note=False)
    assert merged.quantity == "position" and np.array_equal(merged.freq_hz, F[20:])
    assert "a.csv 20" in merged.meta["merge"]
    assert np.max(np.abs(merged.channel("x2/u") / frf.channel("x2/u")[20:] - 1)) < 2e-5  # 6 digits


def test_pick_channel_renames_one_and_selects_one_of_several():
    frf = THESIS_TABLE_3_1.frf(F)
    one = pick_channel(frf, "x2/u")
    assert one.channels == ["x2/u"] and np.array_equal(one.channel("x2/u"), frf.channel("x2/u"))
    renamed = pick_channel(one, "y/q")
    assert renamed.channels == ["y/q"] and np.array_equal(renamed.channel("y/q"), frf.channel("x2/u"))
    with pytest.raises(DataError, match="no channel y/u"):
        pick_channel(frf, "y/u")
    with pytest.raises(UsageError, match="OUT/IN"):
        pick_channel(frf, "x2")


def test_merge_keeps_each_files_coherence_and_the_shared_metadata():
    a = Frf(F, np.ones((1, 1, F.size)), ("x1",), ("u",), coherence=np.full((1, 1, F.size), 0.9),
            meta={"source": "a.csv", "sampling": "removed", "method": "h1"})
    b = Frf(F, 2 * np.ones((1, 1, F.size)), ("x2",), ("u",), meta={"source": "b.csv", "sampling": "removed",
                                                                    "method": "periodic"})
    m = merge_frfs([a, b])
    assert np.all(m.channel_coherence("x1/u") == 0.9) and np.all(np.isnan(m.channel_coherence("x2/u")))
    assert m.meta["sampling"] == "removed" and "method" not in m.meta
    c = Frf(F, np.ones((1, 1, F.size)), ("x2",), ("u",), meta={"source": "c.csv"})
    with pytest.raises(DataError, match="'sampling' record") as err:
        merge_frfs([a, c])
    assert "a.csv" in str(err.value) and "c.csv" in str(err.value)


@pytest.mark.parametrize(("text", "files", "channels"), [
    ("m.csv:x1/u+l.csv:x2/u,scale=-1", ["m.csv", "l.csv"], ["x1/u", "x2/u"]),
    ("a+b.csv:x1/u+c.csv:x2/u,scale=1e+3,in=A", ["a+b.csv", "c.csv"], ["x1/u", "x2/u"]),
    ("m.csv", ["m.csv"], [None]),
    ("C:\\data\\m.csv", ["C:\\data\\m.csv"], [None]),
])
def test_the_argument_syntax(text, files, channels):
    pieces = parse_frf_argument(text)
    assert [str(p.path) for p in pieces] == files and [p.channel for p in pieces] == channels


def test_an_existing_file_is_the_file_and_bad_specs_name_the_item(tmp_path):
    odd = tmp_path / "run:x1" / "u+v.csv"  # a name that reads as a piece is the file when it exists
    odd.parent.mkdir()
    odd.write_text("x")
    assert [str(p.path) for p in parse_frf_argument(odd)] == [str(odd)]
    real = tmp_path / "m.csv"
    real.write_text("x")
    with pytest.raises(UsageError, match="'scal=-1'"):
        parse_frf_argument(f"{real}:x1/u,scal=-1")
    with pytest.raises(UsageError, match="name the channel of every file"):
        parse_frf_argument(f"{real}+{real}:x2/u")


def test_frf_merge_writes_the_merged_file_and_design_reads_pieces(bode_pair, tmp_path, capsys, monkeypatch):
    _frf, motor, load = bode_pair
    out = tmp_path / "merged.csv"
    code, text, err = run(["frf", "merge", f"{motor}:x1/u", f"{load}:x2/u,scale=-1", "--frf-input-unit", "A",
                           "--out", out], capsys, monkeypatch)
    assert code == 0, err
    assert "x1/u from" in text and "wrote" in text and "# merge: x1/u from" in out.read_text()
    code, text, err = run(["frf", "merge", motor, load, "--out", tmp_path / "m2.csv"], capsys, monkeypatch)
    assert code == 2 and "name the channel of every file" in err and not (tmp_path / "m2.csv").exists()
    model = tmp_path / "model.toml"
    assert run(["identify", "ballscrew", out, "--no-delay", "--out", model], capsys, monkeypatch)[0] == 0
    code, text, err = run(["design", "ppi", model, "--kpx", "60", "--kpv", "0.3", "--kiv", "20", "--frf",
                           f"{motor}:x1/u,in=A+{load}:x2/u,scale=-1,in=A", "--json"], capsys, monkeypatch)
    assert code in (0, 1), err
    assert json.loads(text)["analysis"]["measured"] is not None  # the pieces were the measured FRF
