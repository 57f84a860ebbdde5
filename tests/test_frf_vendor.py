"""FRF CSV files from other tools: vendor headers, column maps, unit rows, preambles and per-channel scale factors.

The example files in ``examples/vendor/`` are written by :func:`vendor_texts` from the thesis ball-screw model
(Table 3.1), so every test compares what is read against the model itself. Regenerate them with
``python tests/test_frf_vendor.py`` (from the repository root).
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pytest

from feedtune.errors import DataError, UsageError, cli_message
from feedtune.io import read_frf
from feedtune.models import THESIS_TABLE_3_1 as MODEL

VENDOR = Path(__file__).resolve().parents[1] / "examples" / "vendor"
REL_TOL = 1e-6
"""Largest relative difference [-] between a response read back and the model (numbers are written with 10-15
significant digits)."""


# ------------------------------------------------------------------------------------------ example files
def vendor_grid() -> np.ndarray:
    """200 frequencies [Hz], 1-1000 Hz, written exactly with 4 significant digits."""
    return np.array([float(f"{f:.4g}") for f in np.geomspace(1.0, 1000.0, 200)])


def vendor_coherence(f: np.ndarray, drop: float) -> np.ndarray:
    """A made-up coherence [-] falling towards high frequencies, exact with 4 decimals."""
    return np.round(0.999 - drop * (f / 1000.0) ** 2, 4)


def _db(h: np.ndarray) -> np.ndarray:
    return 20.0 * np.log10(np.abs(h))


def _deg(h: np.ndarray) -> np.ndarray:
    return np.degrees(np.angle(h))


def vendor_texts() -> dict[str, str]:
    """The example files' text by file name.

    * ``bode_db.csv``: one channel (x1/u), ``Frequency [Hz],Magnitude [dB],Phase [deg],Coherence``;
    * ``two_row_header.csv``: two preamble lines, a row of names and a row of units; frequency in rad/s, linear
      magnitude in rad/V, phase in rad (x1/u);
    * ``re_im_semicolon.csv``: German export, ``;`` delimiter and decimal commas, real and imaginary part (x1/u);
    * ``two_channels.csv``: x1/u and x2/u in dB and deg with coherences; the load encoder counts the other way
      (x2/u written with the opposite sign).
    """
    f = vendor_grid()
    frf = MODEL.frf(f)
    h1, h2 = frf.channel("x1/u"), frf.channel("x2/u")
    c1, c2 = vendor_coherence(f, 0.05), vendor_coherence(f, 0.2)
    texts = {}
    rows = [f"{a:.10g},{m:.10g},{p:.10g},{c:.4f}" for a, m, p, c in zip(f, _db(h1), _deg(h1), c1, strict=True)]
    texts["bode_db.csv"] = "\n".join(["Frequency [Hz],Magnitude [dB],Phase [deg],Coherence", *rows]) + "\n"
    rows = [f"{2 * np.pi * a:.15g},{abs(h):.12g},{np.angle(h):.12g}" for a, h in zip(f, h1, strict=True)]
    texts["two_row_header.csv"] = "\n".join(["Servo analyzer export", "Axis X, motor encoder, 5 averages",
                                             "Frequency,Magnitude,Phase", "rad/s,rad/V,rad", *rows]) + "\n"
    rows = [f"{a:.10g};{h.real:.12g};{h.imag:.12g}".replace(".", ",") for a, h in zip(f, h1, strict=True)]
    texts["re_im_semicolon.csv"] = "\n".join(["Frequenz [Hz];Realteil [rad/V];Imaginärteil [rad/V]", *rows]) + "\n"
    flipped = -h2
    rows = [f"{a:.10g},{m1:.10g},{p1:.10g},{m2:.10g},{p2:.10g},{k1:.4f},{k2:.4f}"
            for a, m1, p1, m2, p2, k1, k2 in zip(f, _db(h1), _deg(h1), _db(flipped), _deg(flipped), c1, c2,
                                                 strict=True)]
    header = ("Frequency [Hz],Motor Mag [dB],Motor Phase [deg],Load Mag [dB],Load Phase [deg],"
              "Motor Coherence,Load Coherence")
    texts["two_channels.csv"] = "\n".join([header, *rows]) + "\n"
    return texts


def write_vendor_files() -> None:
    """Write the example files into ``examples/vendor/``."""
    VENDOR.mkdir(parents=True, exist_ok=True)
    for name, text in vendor_texts().items():
        (VENDOR / name).write_text(text, encoding="utf-8")
        print(f"wrote {VENDOR / name}")


TWO_CHANNEL_MAP = {
    "freq": "Frequency [Hz]",
    "x1/u.mag_db": "Motor Mag [dB]",
    "x1/u.phase_deg": "Motor Phase [deg]",
    "x1/u.coh": "Motor Coherence",
    "x2/u.mag_db": "Load Mag",  # the name without its unit is enough
    "x2/u.phase_deg": "Load Phase [deg]",
    "x2/u.coh": "Load Coherence",
}

#: How each example is read: library keyword arguments, the same as command-line options, and its channels.
CASES = {
    "bode_db.csv": ({}, [], ["x1/u"]),
    "two_row_header.csv": ({"skip_rows": 2}, ["--frf-skip-rows", "2"], ["x1/u"]),
    "re_im_semicolon.csv": ({}, [], ["x1/u"]),
    "two_channels.csv": ({"columns": TWO_CHANNEL_MAP, "scale": {"x2/u": -1.0}},
                         [a for k, v in TWO_CHANNEL_MAP.items() for a in ("--frf-map", f"{k}={v}")]
                         + ["--frf-scale", "x2/u=-1"], ["x1/u", "x2/u"]),
}


def assert_matches_model(frf, channels) -> None:
    """Frequencies as written, every channel within :data:`REL_TOL` of the thesis model."""
    np.testing.assert_allclose(frf.freq_hz, vendor_grid(), rtol=1e-14)
    truth = MODEL.frf(frf.freq_hz)
    assert frf.channels == channels
    for ch in channels:
        h, ref = frf.channel(ch), truth.channel(ch)
        assert np.max(np.abs(h - ref) / np.abs(ref)) < REL_TOL, ch
    assert (frf.quantity, frf.input_unit, frf.output_unit) == ("position", "V", "rad")


# ------------------------------------------------------------------------------------------ the examples
def test_example_files_are_the_generated_ones():
    for name, text in vendor_texts().items():
        assert (VENDOR / name).read_text(encoding="utf-8") == text, f"regenerate {name}: python {__file__}"


@pytest.mark.parametrize("name", sorted(CASES))
def test_library_reads_each_example_like_the_model(name):
    kwargs, _, channels = CASES[name]
    frf = read_frf(VENDOR / name, **kwargs)
    assert_matches_model(frf, channels)
    assert frf.source == str(VENDOR / name) and frf.meta["columns"]


def test_recognised_columns_are_recorded():
    frf = read_frf(VENDOR / "bode_db.csv")
    assert frf.meta["columns"] == ("freq_hz=Frequency [Hz]; x1/u.mag_db=Magnitude [dB]; x1/u.phase_deg=Phase [deg]; "
                                   "x1/u.coh=Coherence")
    np.testing.assert_allclose(frf.channel_coherence("x1/u"), vendor_coherence(vendor_grid(), 0.05), atol=1e-12)
    two = read_frf(VENDOR / "two_row_header.csv", skip_rows=2)
    assert two.meta["columns"] == "freq_rad_s=Frequency; x1/u.mag=Magnitude; x1/u.phase_rad=Phase"
    both = read_frf(VENDOR / "two_channels.csv", **CASES["two_channels.csv"][0])
    assert both.meta["scale"] == "x2/u=-1"
    np.testing.assert_allclose(both.channel_coherence("x2/u"), vendor_coherence(vendor_grid(), 0.2), atol=1e-12)


def test_the_recorded_columns_read_back_as_a_map():
    frf = read_frf(VENDOR / "bode_db.csv")
    columns = dict(item.split("=", 1) for item in frf.meta["columns"].split("; "))
    again = read_frf(VENDOR / "bode_db.csv", columns=columns)
    np.testing.assert_array_equal(again.response, frf.response)


def test_the_channel_of_a_recognised_header_is_chosen(capsys, monkeypatch):
    frf = read_frf(VENDOR / "bode_db.csv", auto_channel="x2/u")
    assert frf.channels == ["x2/u"] and frf.meta["columns"].startswith("freq_hz=Frequency [Hz]; x2/u.mag_db=")
    np.testing.assert_array_equal(frf.response, read_frf(VENDOR / "bode_db.csv").response)
    code, _, err = _cli(["identify", "ballscrew", VENDOR / "bode_db.csv", "--frf-channel", "x2/u", "--channel",
                         "x2/u"], capsys, monkeypatch)
    assert "columns read as freq_hz=Frequency [Hz]; x2/u.mag_db=Magnitude [dB]" in err
    assert code == 1 and "channel x2/u alone cannot separate m1 and m2" in err  # the fit saw x2/u


def test_sign_flip_is_what_the_scale_undoes():
    kwargs = dict(CASES["two_channels.csv"][0])
    kwargs.pop("scale")
    raw = read_frf(VENDOR / "two_channels.csv", **kwargs)
    truth = MODEL.frf(raw.freq_hz)
    np.testing.assert_allclose(raw.channel("x2/u"), -truth.channel("x2/u"), rtol=REL_TOL)
    np.testing.assert_allclose(raw.channel("x1/u"), truth.channel("x1/u"), rtol=REL_TOL)


def test_a_frf_written_by_feedtune_keeps_the_record(tmp_path, capsys, monkeypatch):
    from feedtune.io import write_frf

    frf = read_frf(VENDOR / "re_im_semicolon.csv")
    write_frf(frf, tmp_path / "native.csv")
    back = read_frf(tmp_path / "native.csv")
    np.testing.assert_array_equal(back.response, frf.response)
    assert back.meta["columns"] == frf.meta["columns"]
    assert (frf.meta["format"], back.meta["format"]) == ("csv, recognised header", "csv")
    code, _, err = _cli(["identify", "ballscrew", tmp_path / "native.csv", "--no-delay"], capsys, monkeypatch)
    assert code == 0 and "note" not in err  # a feedtune file: nothing recognised


def test_scale_applies_to_every_format(tmp_path):
    from feedtune.io import write_frf

    frf = MODEL.frf(vendor_grid())
    for ext in ("csv", "mat", "uff"):
        write_frf(frf, tmp_path / f"bs.{ext}")
        flipped = read_frf(tmp_path / f"bs.{ext}", scale={"x2/u": -1})
        np.testing.assert_allclose(flipped.channel("x2/u"), -frf.channel("x2/u"), rtol=1e-10)
        np.testing.assert_allclose(flipped.channel("x1/u"), frf.channel("x1/u"), rtol=1e-10)
    with pytest.raises(UsageError, match=r"option\(s\) columns do not apply to MATLAB") as err:
        read_frf(tmp_path / "bs.mat", columns={"x1/u.re": "a", "x1/u.im": "b"})
    assert err.value.parameter == "read_frf.columns" and "option(s) --frf-map do not" in cli_message(err.value)


# ------------------------------------------------------------------------------------------ headers
def _write(tmp_path: Path, name: str, text: str) -> Path:
    p = tmp_path / name
    p.write_text(text, encoding="utf-8")
    return p


@pytest.mark.parametrize("header, unit_row, expect", [
    ("Freq (Hz),Mag (dB),Phase (deg)", None, "freq_hz=Freq (Hz); x1/u.mag_db=Mag (dB); x1/u.phase_deg=Phase (deg)"),
    ("frequency_hz,magnitude_db,phase_deg,coherence", None,
     "freq_hz=frequency_hz; x1/u.mag_db=magnitude_db; x1/u.phase_deg=phase_deg; x1/u.coh=coherence"),
    ("Frequency [kHz],Amplitude [m/V],Phase [°]", None,
     "freq_khz=Frequency [kHz]; x1/u.mag=Amplitude [m/V]; x1/u.phase_deg=Phase [°]"),
    ("Frequency,Gain,Phase", "[Hz],[dB],[deg]", "freq_hz=Frequency; x1/u.mag_db=Gain; x1/u.phase_deg=Phase"),
    ("f [Hz],Re,Im", None, "freq_hz=f [Hz]; x1/u.re=Re; x1/u.im=Im"),
])
def test_header_spellings_are_recognised(tmp_path, header, unit_row, expect):
    f = np.array([10.0, 20.0, 40.0])
    h = MODEL.frf(f).channel("x1/u")
    scale = 1e-3 if "kHz" in header else 1.0
    cols = {"Re": h.real, "Im": h.imag}
    if "Re" not in header:
        cols = {"mag": _db(h) if "dB" in header + (unit_row or "") or "_db" in header else np.abs(h),
                "phase": _deg(h)}
        if "coherence" in header:
            cols["coh"] = np.full(3, 0.9)
    lines = [header] + ([unit_row] if unit_row else [])
    lines += [",".join(repr(float(v)) for v in (a * scale, *(c[i] for c in cols.values())))
              for i, a in enumerate(f)]
    frf = read_frf(_write(tmp_path, "h.csv", "\n".join(lines) + "\n"))
    assert frf.meta["columns"] == expect
    np.testing.assert_allclose(frf.freq_hz, f, rtol=1e-15)
    np.testing.assert_allclose(frf.channel("x1/u"), h, rtol=1e-12)


def test_ignored_columns_are_named(tmp_path):
    p = _write(tmp_path, "extra.csv", "Index,Frequency [Hz],Re,Im,Averages\n0,1,1,0,5\n1,2,1,0,5\n")
    frf = read_frf(p)
    assert frf.meta["columns_ignored"] == "Index; Averages"


# ------------------------------------------------------------------------------------------ errors
BAD_VENDOR = {
    # no frequency column: the message shows the header and the map that would work
    "nofreq.csv": ("Magnitude [dB],Phase [deg]\n-20,-170\n", {}, DataError,
                   ["no frequency column", "expected 'freq_hz'", "or a columns=freq=COLUMN;",
                    "the header is: Magnitude [dB], Phase [deg]"]),
    "two_mags.csv": ("Frequency [Hz],Mag1 [dB],Mag2 [dB],Phase [deg]\n1,0,0,0\n", {}, DataError,
                     ["several magnitude columns", "Mag1 [dB], Mag2 [dB]",
                      "map the columns with columns=OUT/IN.KIND=COLUMN"]),
    "no_unit.csv": ("Frequency,Magnitude,Phase [deg]\n1,1,0\n", {}, DataError,
                    ["magnitude column 'Magnitude' gives no unit", "x1/u.mag_db=COLUMN"]),
    "phase_unit.csv": ("Frequency,Magnitude [dB],Phase [grad]\n1,1,0\n", {}, DataError,
                       ["phase column 'Phase [grad]'", "'grad' not understood"]),
    "freq_unit.csv": ("Frequency [rpm],Re,Im\n1,1,0\n", {}, DataError, ["unit 'rpm' not understood"]),
    "lonely.csv": ("Frequency [Hz],Magnitude [dB]\n1,1\n", {}, DataError,
                   ["no phase column to go with 'Magnitude [dB]'"]),
    "both.csv": ("Frequency [Hz],Magnitude [dB],Phase [deg],Re,Im\n1,1,0,1,0\n", {}, DataError,
                 ["both magnitude/phase and real/imaginary"]),
    "missing_col.csv": ("Frequency [Hz],Magnitude [dB],Phase [deg]\n1,1,0\n",
                        {"columns": {"x1/u.mag_db": "Magnitud", "x1/u.phase_deg": "Phase"}}, DataError,
                        ["missing_col.csv: columns=x1/u.mag_db=Magnitud: no such column",
                         "the header is: Frequency [Hz], Magnitude [dB], Phase [deg]"]),
    "wrong_kind.csv": ("Frequency [Hz],Magnitude [dB],Phase [deg]\n1,1,0\n",
                       {"columns": {"x1/u.mag": "Magnitude", "x1/u.phase_deg": "Phase"}}, DataError,
                       ["x1/u.mag=Magnitude [dB]", "unit is dB", "map it as x1/u.mag_db"]),
    "wrong_freq.csv": ("Frequency [rad/s],Magnitude [dB],Phase [deg]\n1,1,0\n",
                       {"columns": {"freq_hz": "Frequency", "x1/u.mag_db": "Magnitude", "x1/u.phase_deg": "Phase"}},
                       DataError, ["unit is rad/s", "freq_rad_s"]),
    "preamble.csv": ("Analyzer\nFrequency [Hz],Re,Im\n1,1,0\n", {}, DataError,
                     ["line 2", "is not a number", "pass skip_rows=N"]),
    "partial_map.csv": ("Frequency [Hz],Magnitude [dB],Phase [deg]\n1,1,0\n",
                        {"columns": {"x1/u.mag_db": "Magnitude"}}, UsageError,
                        ["channel x1/u has mag_db", "x1/u.phase_deg"]),
    "bad_kind.csv": ("Frequency [Hz],Magnitude [dB],Phase [deg]\n1,1,0\n",
                     {"columns": {"x1/u.magdb": "Magnitude"}}, UsageError, ["unknown KIND 'magdb'", "mag_db"]),
    "bad_channel.csv": ("Frequency [Hz],Magnitude [dB],Phase [deg]\n1,1,0\n",
                        {"columns": {"x1u.mag_db": "Magnitude", "x1u.phase_deg": "Phase"}}, UsageError,
                        ["channel 'x1u' must look like OUT/IN"]),
    "twice.csv": ("Frequency [Hz],Magnitude [dB],Phase [deg]\n1,1,0\n",
                  {"columns": {"x1/u.mag_db": "Magnitude", "x1/u.phase_deg": "Magnitude [dB]"}}, UsageError,
                  ["'Magnitude [dB]' is mapped twice"]),
    "scale_channel.csv": ("Frequency [Hz],Re,Im\n1,1,0\n2,1,0\n", {"scale": {"x2/u": -1}}, DataError,
                          ["scale x2/u=-1", "no channel 'x2/u'", "channels: x1/u"]),
    "native_channel.csv": ("freq_hz,x1/u.re,x1/u.im\n1,1,0\n", {"auto_channel": "x2/u"}, UsageError,
                           ["auto_channel names the channel", "names its channels"]),
}
BAD_VENDOR_PARAMETER = {"preamble.csv": "read_frf.skip_rows", "scale_channel.csv": "read_frf.scale",
                        "native_channel.csv": "read_frf.auto_channel"}
"""The ``parameter`` of each BAD_VENDOR error other than ``read_frf.columns`` (the column map, ``--frf-map``)."""


@pytest.mark.parametrize("name", sorted(BAD_VENDOR))
def test_bad_vendor_files_and_maps_are_one_line_errors(tmp_path, name):
    text, kwargs, error, fragments = BAD_VENDOR[name]
    with pytest.raises(error) as err:
        read_frf(_write(tmp_path, name, text), **kwargs)
    msg = str(err.value)
    assert "\n" not in msg
    assert "--" not in msg, msg  # the library names parameters (columns=), the command line flags
    assert err.value.parameter == BAD_VENDOR_PARAMETER.get(name, "read_frf.columns"), (err.value.parameters, msg)
    for frag in fragments:
        assert frag in msg, (frag, msg)


# ------------------------------------------------------------------------------------------ command line
def _cli(args, capsys, monkeypatch):
    from test_cli import run

    return run(args, capsys, monkeypatch)


@pytest.mark.parametrize("name", sorted(CASES))
def test_cli_identify_reads_each_example_like_the_model(name, capsys, monkeypatch):
    options = CASES[name][1]
    code, out, err = _cli(["identify", "ballscrew", VENDOR / name, *options, "--no-delay", "--json"],
                          capsys, monkeypatch)
    assert code == 0, err
    params = json.loads(out)["params"]
    for key, rel in (("m1", 1e-6), ("m2", 1e-6), ("k", 1e-6), ("c", 1e-5), ("b1", 1e-4)):
        assert params[key]["value"] == pytest.approx(getattr(MODEL, key), rel=rel), (key, params[key])
    recognised = not any(o == "--frf-map" for o in options)
    assert ("feedtune: note:" in err) == recognised
    if recognised:
        assert err.count("\n") == 1 and str(VENDOR / name) in err and "columns read as freq_" in err


def test_cli_analyze_with_a_vendor_frf_matches_the_native_file(tmp_path, capsys, monkeypatch):
    from feedtune.io import write_frf

    native = tmp_path / "native.csv"
    write_frf(MODEL.frf(vendor_grid()), native)
    model = tmp_path / "bs.toml"
    gains = tmp_path / "g.toml"
    assert _cli(["identify", "ballscrew", native, "--no-delay", "-o", model], capsys, monkeypatch)[0] == 0
    code, _, err = _cli(["design", "ppc", model, "--beta", "4", "--pole-hz", "40", "--zeta", "0.7", "-o", gains,
                         "--allow-unstable"], capsys, monkeypatch)
    assert code == 0, err
    options = CASES["two_channels.csv"][1]
    code, vendor_out, err = _cli(["analyze", gains, "--frf", VENDOR / "two_channels.csv", *options, "--json"],
                                 capsys, monkeypatch)
    assert code == 0, err
    code, native_out, err = _cli(["analyze", gains, "--frf", native, "--json"], capsys, monkeypatch)
    assert code == 0, err
    a, b = json.loads(vendor_out)["analysis"]["measured"], json.loads(native_out)["analysis"]["measured"]
    assert a is not None and a["ms"] == pytest.approx(b["ms"], rel=1e-6)


@pytest.mark.parametrize("args, code, words", [
    (["--frf-map", "x1/u.mag_db"], 2, "--frf-map expects NAME=COLUMN"),
    (["--frf-map", "x1/u.magdb=Magnitude"], 2, "unknown KIND 'magdb'"),
    (["--frf-map", "x1/u.mag_db=Magnitude [dB]"], 2, "channel x1/u has mag_db"),
    (["--frf-scale", "x1/u=minus"], 2, "--frf-scale x1/u=minus: FACTOR must be a number"),
    (["--frf-scale", "x1/u=0"], 2, "finite and non-zero"),
    (["--frf-scale", "x1=2"], 2, "OUT/IN"),
    (["--frf-scale", "x2/u=-1"], 1, "no channel 'x2/u'"),
    (["--frf-channel", "x1"], 2, "--frf-channel expects a channel name OUT/IN"),
    (["--frf-skip-rows", "-1"], 2, "--frf-skip-rows"),
    (["--frf-channel", "x1/u", "--frf-map", "x1/u.re=Re"], 2, "--frf-channel"),
    (["--frf-map", "x1/u.mag_db=Mag", "--frf-map", "x1/u.phase_deg=Phase [deg]"], 1, "no such column"),
    (["--frf-map", "x1/u.mag=Magnitude", "--frf-map", "x1/u.phase_deg=Phase"], 1, "map it as x1/u.mag_db"),
])
def test_cli_bad_maps_are_one_line_errors(args, code, words, capsys, monkeypatch):
    got, _, err = _cli(["identify", "ballscrew", VENDOR / "bode_db.csv", *args], capsys, monkeypatch)
    assert got == code and words in err, err
    if code == 1 or "--frf-skip-rows" not in args:
        assert err.count("\n") == 1, err


def test_cli_without_the_skip_rows_option_says_which_option(capsys, monkeypatch):
    code, _, err = _cli(["identify", "ballscrew", VENDOR / "two_row_header.csv"], capsys, monkeypatch)
    assert code == 1 and "two_row_header.csv: line 2" in err and "--frf-skip-rows" in err
    code, _, err = _cli(["identify", "ballscrew", VENDOR / "two_channels.csv"], capsys, monkeypatch)
    assert code == 1 and "several magnitude columns" in err and "--frf-map" in err


FRF_COMMANDS = {
    "design ppc": ["MODEL", "--frf", "FRF"],
    "design ppi": ["MODEL", "--frf", "FRF"],
    "design loopshape": ["FRF", "--frf", "FRF"],
    "design gantry": ["MODEL", "--frf", "FRF"],
    "design pid": ["MODEL", "--frf", "FRF"],
    "analyze gains": ["GAINS", "--frf", "FRF"],
    "tune": ["mcppc", "MODEL", "--frf", "FRF"],
    "identify ballscrew": ["FRF"],
    "identify gantry": ["FRF", "--span", "1", "--x", "0"],
}
"""Every command that reads FRF files, with arguments (MODEL and GAINS stand for missing or empty files)."""


@pytest.mark.parametrize("command", sorted(FRF_COMMANDS))
def test_every_frf_command_takes_the_options(command, tmp_path, capsys, monkeypatch):
    gains = tmp_path / "g.toml"
    gains.write_text("")
    names = {"FRF": VENDOR / "bode_db.csv", "MODEL": tmp_path / "missing.toml", "GAINS": gains}
    args = [*command.split(), *(names.get(a, a) for a in FRF_COMMANDS[command])]
    code, _, err = _cli([*args, "--frf-map", "x1/u.magdb=Magnitude"], capsys, monkeypatch)
    assert code == 2 and "--frf-map x1/u.magdb=Magnitude: unknown KIND 'magdb'" in err, err  # before any file
    code, out, _ = _cli([*command.split(), "--help"], capsys, monkeypatch)
    assert code == 0
    for option in ("--frf-map", "--frf-skip-rows", "--frf-scale", "--frf-channel"):
        assert option in out, option


if __name__ == "__main__":
    if sys.argv[1:] not in ([], ["--write"]):
        sys.exit("usage: python tests/test_frf_vendor.py  (writes examples/vendor/*.csv)")
    write_vendor_files()
