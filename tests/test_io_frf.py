"""FRF files: CSV, MATLAB v5/v7.3 and UFF58 readers/writers, checked against closed-form responses."""

from __future__ import annotations

import io
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from feedtune.errors import DataError, UsageError
from feedtune.frf import Frf
from feedtune.io import (
    read_frf,
    read_frf_csv,
    read_frf_mat,
    read_frf_uff,
    write_frf,
    write_frf_csv,
    write_frf_mat,
    write_frf_uff,
)
from feedtune.models.ballscrew import THESIS_TABLE_3_1

FIXTURES = Path(__file__).parent / "fixtures"


def _mass_spring(f, m, c, k):
    """Position FRF 1/(m s^2 + c s + k), s = j 2 pi f."""
    s = 2j * np.pi * np.asarray(f, float)
    return 1.0 / (m * s**2 + c * s + k)


def _ballscrew_frf(quantity="position", coherence=True) -> Frf:
    f = np.linspace(1.0, 500.0, 64)
    frf = THESIS_TABLE_3_1.frf(f, quantity)
    if coherence:
        coh = np.stack([np.linspace(0.5, 1.0, f.size), np.linspace(0.2, 0.9, f.size)])[:, None, :]
        frf = replace(frf, coherence=coh)
    return frf


def _write(tmp_path: Path, name: str, text: str) -> Path:
    p = tmp_path / name
    p.write_text(text)
    return p


# --------------------------------------------------------------------------------------------------- CSV
def test_csv_round_trip_is_exact(tmp_path):
    frf = _ballscrew_frf()
    p = tmp_path / "bs.csv"
    write_frf_csv(frf, p)
    back = read_frf_csv(p)
    assert back.channels == ["x1/u", "x2/u"]
    np.testing.assert_array_equal(back.freq_hz, frf.freq_hz)
    np.testing.assert_array_equal(back.response, frf.response)
    np.testing.assert_array_equal(back.coherence, frf.coherence)
    assert (back.quantity, back.input_unit, back.output_unit) == ("position", "V", "rad")
    assert back.meta["origin"] == "ball-screw model"
    assert "x1/u.re" in p.read_text().splitlines()[6]


def test_csv_magnitude_phase_columns(tmp_path):
    text = (
        "# quantity: position\n"
        "freq_hz,x1/u.mag,x1/u.phase_deg,x2/u.mag_db,x2/u.phase_deg\n"
        "1.0,2.0,90,20,-180\n"
        "2.0,0.5,-45,-6,0\n"
    )
    frf = read_frf_csv(_write(tmp_path, "mp.csv", text))
    np.testing.assert_allclose(frf.channel("x1/u"), [2j, 0.5 * (1 - 1j) / np.sqrt(2)], rtol=1e-15, atol=1e-15)
    np.testing.assert_allclose(frf.channel("x2/u"), [-10.0, 10 ** (-6 / 20)], rtol=1e-14, atol=1e-15)


def test_csv_phase_rad_and_reads_open_file():
    text = "freq_hz,x2/u.mag,x2/u.phase_rad\n5,3,3.141592653589793\n6,3,0\n"
    frf = read_frf_csv(io.StringIO(text))
    np.testing.assert_allclose(frf.channel("x2/u"), [-3.0, 3.0], atol=1e-15)
    assert frf.source == "<stream>"


def test_csv_acceleration_of_mass_converts_to_position(tmp_path):
    m = 0.25
    f = np.array([1.0, 3.0, 10.0, 100.0, 1234.5])
    rows = "\n".join(f"{float(fi)!r},{1 / m!r},0.0" for fi in f)
    text = f"# quantity: acceleration\n# output: x2 [m]\nfreq_hz,x2/u.re,x2/u.im\n{rows}\n"
    frf = read_frf_csv(_write(tmp_path, "acc.csv", text))
    assert frf.quantity == "acceleration"
    expected = 1.0 / (m * (2j * np.pi * f) ** 2)
    np.testing.assert_allclose(frf.as_quantity("position").channel("x2/u"), expected, rtol=1e-12, atol=0)
    assert frf.output_unit == "m"


def test_csv_quantity_argument_overrides_metadata(tmp_path):
    p = _write(tmp_path, "q.csv", "# quantity: position\nfreq_hz,x1/u.re,x1/u.im\n1,1,0\n2,1,0\n")
    assert read_frf_csv(p, quantity="vel").quantity == "velocity"
    assert read_frf_csv(p).quantity == "position"


def test_csv_gantry_channels_and_units(tmp_path):
    text = (
        "# input: u1 [N]\n# input: u2 [N]\n# output_unit: m\n"
        "freq_hz,y1/u1.re,y1/u1.im,y1/u2.re,y1/u2.im,y2/u1.re,y2/u1.im,y2/u2.re,y2/u2.im\n"
        "1,1,0,2,0,3,0,4,0\n2,5,0,6,0,7,0,8,0\n"
    )
    frf = read_frf_csv(_write(tmp_path, "g.csv", text))
    assert frf.outputs == ("y1", "y2") and frf.inputs == ("u1", "u2")
    np.testing.assert_array_equal(frf.response[:, :, 1].real, [[5, 6], [7, 8]])
    assert (frf.input_unit, frf.output_unit) == ("N", "m")


BAD_CSV = {
    "no_freq.csv": ("f,x1/u.re,x1/u.im\n1,1,0\n", ["freq_hz"]),
    "re_only.csv": ("freq_hz,x1/u.re\n1,1\n", ["x1/u.re", "x1/u.im"]),
    "mag_only.csv": ("freq_hz,x1/u.mag\n1,1\n", ["x1/u.mag", "phase"]),
    "suffix.csv": ("freq_hz,x1/u.real,x1/u.imag\n1,1,0\n", ["x1/u.real", "re, im"]),
    "channel.csv": ("freq_hz,x1u.re,x1u.im\n1,1,0\n", ["x1u", "OUT/IN"]),
    "text_cell.csv": ("freq_hz,x1/u.re,x1/u.im\n1,1,0\n2,abc,0\n", ["line 3", "x1/u.re", "abc"]),
    "nan_cell.csv": ("# c\nfreq_hz,x1/u.re,x1/u.im\n1,1,0\n2,nan,0\n", ["line 4", "x1/u.re"]),
    "inf_cell.csv": ("freq_hz,x1/u.re,x1/u.im\n1,1,inf\n", ["line 2", "x1/u.im", "infinite"]),
    "empty_cell.csv": ("freq_hz,x1/u.re,x1/u.im\n1,1,\n", ["line 2", "x1/u.im"]),
    "dup_freq.csv": ("freq_hz,x1/u.re,x1/u.im\n1,1,0\n1,2,0\n", ["duplicate", "row 2"]),
    "decreasing.csv": ("freq_hz,x1/u.re,x1/u.im\n2,1,0\n1,2,0\n", ["decreasing"]),
    "empty.csv": ("", ["empty"]),
    "comments_only.csv": ("# quantity: position\n# nothing else\n", ["empty"]),
    "header_only.csv": ("freq_hz,x1/u.re,x1/u.im\n", ["no data rows"]),
    "no_header.csv": ("1,2,3\n", ["header"]),
    "missing_combo.csv": ("freq_hz,y1/u1.re,y1/u1.im,y1/u2.re,y1/u2.im,y2/u1.re,y2/u1.im\n1,1,0,1,0,1,0\n",
                          ["y2/u2", "missing"]),
    "coh_range.csv": ("freq_hz,x1/u.re,x1/u.im,x1/u.coh\n1,1,0,1.5\n", ["x1/u.coh", "line 2", "0..1"]),
    "extra_field.csv": ("freq_hz,x1/u.re,x1/u.im\n1,1,0\n2,1,0,7\n", ["line 3", "4 fields"]),
    "twice.csv": ("freq_hz,x1/u.re,x1/u.im,x1/u.mag\n1,1,0,1\n", ["x1/u"]),
    "quantity.csv": ("# quantity: jerk\nfreq_hz,x1/u.re,x1/u.im\n1,1,0\n", ["jerk"]),
}


@pytest.mark.parametrize("name", sorted(BAD_CSV))
def test_csv_bad_input_is_one_line_data_error(tmp_path, name):
    text, fragments = BAD_CSV[name]
    p = _write(tmp_path, name, text)
    with pytest.raises(DataError) as err:
        read_frf_csv(p)
    msg = str(err.value)
    assert "\n" not in msg and name in msg
    for frag in fragments:
        assert frag in msg, (frag, msg)


def test_csv_unreadable_files(tmp_path):
    with pytest.raises(DataError, match="not found"):
        read_frf_csv(tmp_path / "missing.csv")
    with pytest.raises(DataError, match="folder"):
        read_frf_csv(tmp_path)
    garbage = tmp_path / "garbage.csv"
    garbage.write_bytes(bytes(range(256)) * 4)
    with pytest.raises(DataError, match=r"garbage\.csv: binary"):
        read_frf_csv(garbage)


def test_csv_writer_refuses_overwrite_without_force(tmp_path):
    frf = _ballscrew_frf(coherence=False)
    p = tmp_path / "a.csv"
    write_frf_csv(frf, p)
    with pytest.raises(UsageError, match=r"a\.csv exists; pass force=True to overwrite") as err:
        write_frf_csv(frf, p)
    assert err.value.parameter == "force"
    write_frf_csv(frf.select(1, 100), p, force=True)
    assert read_frf_csv(p).freq_hz.max() <= 100


# --------------------------------------------------------------------------------------------------- MAT
def test_mat_v5_round_trip_is_exact(tmp_path):
    frf = _ballscrew_frf("velocity")
    p = tmp_path / "bs.mat"
    write_frf_mat(frf, p)
    back = read_frf_mat(p)
    np.testing.assert_array_equal(back.freq_hz, frf.freq_hz)
    np.testing.assert_array_equal(back.response, frf.response)
    np.testing.assert_array_equal(back.coherence, frf.coherence)
    assert back.quantity == "velocity" and back.channels == ["x1/u", "x2/u"]


def test_mat_v5_user_variable_names(tmp_path):
    import scipy.io

    f = np.array([[1.0], [2.0], [4.0]])
    h_rot = _mass_spring(f[:, 0], 1.0, 2.0, 300.0)
    h_lin = np.array([1.0, 2.0, 3.0])  # real-valued channel is allowed
    scipy.io.savemat(tmp_path / "u.mat", {"f": f, "H_rot": h_rot[None, :], "H_lin": h_lin,
                                           "C_rot": np.array([0.9, 0.8, 0.7]), "output_unit": "m"})
    frf = read_frf_mat(tmp_path / "u.mat", freq_var="f", channels={"x1/u": "H_rot", "x2/u": "H_lin"},
                       coherence={"x1/u": "C_rot"}, quantity="position")
    np.testing.assert_array_equal(frf.channel("x1/u"), h_rot)
    np.testing.assert_array_equal(frf.channel("x2/u"), h_lin)
    np.testing.assert_array_equal(frf.channel_coherence("x1/u"), [0.9, 0.8, 0.7])
    assert np.all(np.isnan(frf.channel_coherence("x2/u")))
    assert frf.output_unit == "m"


def write_mat73(path: Path, variables: dict) -> None:
    """Write a MATLAB v7.3 file as MATLAB does: HDF5 with a 512-byte user block holding the MAT header,
    arrays stored transposed, complex as a compound (real, imag), char as uint16 with MATLAB_class."""
    import h5py

    with h5py.File(path, "w", userblock_size=512) as fh:
        for name, value in variables.items():
            if isinstance(value, str):
                ds = fh.create_dataset(name, data=np.array([[ord(c)] for c in value], dtype=np.uint16))
                ds.attrs["MATLAB_class"] = np.bytes_("char")
                ds.attrs["MATLAB_int_decode"] = np.int32(2)
                continue
            a = np.asarray(value)
            a = a.reshape(-1, 1) if a.ndim == 1 else a  # MATLAB column vector
            stored = np.ascontiguousarray(a.T)
            if np.iscomplexobj(stored):
                ctype = np.dtype([("real", "<f8"), ("imag", "<f8")])
                comp = np.empty(stored.shape, ctype)
                comp["real"], comp["imag"] = stored.real, stored.imag
                stored = comp
            ds = fh.create_dataset(name, data=stored)
            cls = {"f": "double", "i": f"int{8 * a.dtype.itemsize}", "u": f"uint{8 * a.dtype.itemsize}",
                   "c": "double"}[a.dtype.kind]
            ds.attrs["MATLAB_class"] = np.bytes_(cls)
    text = b"MATLAB 7.3 MAT-file, Platform: GLNXA64, Created on: Mon Jan  1 00:00:00 2024 HDF5 schema 1.00 ."
    header = text.ljust(116, b" ") + b"\x00" * 8 + b"\x00\x02" + b"IM"
    with open(path, "r+b") as fh:
        fh.write(header.ljust(512, b"\x00"))


def test_mat_v73_defaults(tmp_path):
    f = np.linspace(5.0, 50.0, 10)
    h1 = _mass_spring(f, 0.5, 2.0, 2000.0)
    h2 = _mass_spring(f, 0.7, 1.0, 900.0)
    p = tmp_path / "v73.mat"
    write_mat73(p, {"freq": f, "x1_u": h1, "x2_u": h2, "x2_u_coh": np.full(10, 0.95),
                    "quantity": "velocity", "input_unit": "A", "notes": np.arange(3.0)})
    frf = read_frf_mat(p)
    assert frf.channels == ["x1/u", "x2/u"] and frf.quantity == "velocity" and frf.input_unit == "A"
    np.testing.assert_array_equal(frf.freq_hz, f)
    np.testing.assert_array_equal(frf.channel("x1/u"), h1)
    np.testing.assert_array_equal(frf.channel("x2/u"), h2)
    np.testing.assert_array_equal(frf.channel_coherence("x2/u"), np.full(10, 0.95))
    assert frf.meta["format"] == "mat v7.3"


def test_mat_errors_name_file_and_variable(tmp_path):
    import scipy.io

    p = tmp_path / "e.mat"
    scipy.io.savemat(p, {"f": np.arange(1.0, 4.0), "H": np.ones(3) + 1j, "short": np.ones(2) + 0j})
    with pytest.raises(DataError, match=r"e\.mat: no channel x1/u variable 'Hx'.*numeric variables: .*H 1x3"):
        read_frf_mat(p, channels={"x1/u": "Hx"})
    with pytest.raises(DataError, match=r"e\.mat: channel x1/u variable 'short' has 2 values.* has 3"):
        read_frf_mat(p, channels={"x1/u": "short"})
    with pytest.raises(DataError, match=r"e\.mat: no frequency variable 'fz'"):
        read_frf_mat(p, freq_var="fz", channels={"x1/u": "H"})
    with pytest.raises(DataError, match=r"e\.mat: no channel variables found"):
        read_frf_mat(p)
    fake = _write(tmp_path, "fake.mat", "freq_hz,x1/u.re\n")
    with pytest.raises(DataError, match=r"fake\.mat: not a MATLAB \.mat file"):
        read_frf_mat(fake)


# --------------------------------------------------------------------------------------------------- UFF
def test_uff_ascii_round_trip(tmp_path):
    import pyuff

    f = np.arange(1, 201) * 2.5
    frf = replace(THESIS_TABLE_3_1.frf(f, "acceleration"),
                  coherence=np.stack([np.full(f.size, 0.75), np.full(f.size, 0.5)])[:, None, :])
    p = tmp_path / "bs.uff"
    write_frf_uff(frf, p)
    back = read_frf_uff(p)
    assert back.channels == ["x1/u", "x2/u"] and back.quantity == "acceleration"
    np.testing.assert_array_equal(back.freq_hz, f)
    np.testing.assert_allclose(back.response, frf.response, rtol=1e-11)
    np.testing.assert_allclose(back.coherence, frf.coherence, rtol=1e-11)
    sets = pyuff.UFF(str(p)).read_sets()
    assert [s["func_type"] for s in sets] == [4, 4, 6, 6]
    assert {s["abscissa_spec_data_type"] for s in sets} == {18}
    assert [s["ordinate_spec_data_type"] for s in sets[:2]] == [12, 12]
    assert [(s["rsp_ent_name"], s["ref_ent_name"], s["id1"]) for s in sets[:2]] == [
        ("x1", "u", "x1/u"), ("x2", "u", "x2/u")]
    assert sets[0]["rsp_node"] != sets[1]["rsp_node"] and sets[0]["ref_node"] == sets[2]["ref_node"]


def test_uff_binary_round_trip_is_exact(tmp_path):
    f = np.geomspace(1.0, 1000.0, 50)
    frf = _ballscrew_frf("position", coherence=False)
    frf = THESIS_TABLE_3_1.frf(f)
    with pytest.raises(DataError, match="6 significant digits"):
        write_frf_uff(replace(frf, freq_hz=1000 + np.arange(50) * 1e-3), tmp_path / "fine.uff")
    assert not (tmp_path / "fine.uff").exists()
    write_frf_uff(frf, tmp_path / "b.uff", binary=True)
    back = read_frf_uff(tmp_path / "b.uff")
    np.testing.assert_array_equal(back.freq_hz, f)
    np.testing.assert_array_equal(back.response, frf.response)
    assert back.output_unit == "rad" and back.input_unit == "V"


def test_uff_hand_written_named_records():
    frf = read_frf_uff(FIXTURES / "frf_named_even.uff")
    assert frf.channels == ["x1/u", "x2/u"] and frf.quantity == "acceleration"
    assert (frf.output_unit, frf.input_unit) == ("m", "V")
    f = np.array([10.0, 12.0, 14.0, 16.0, 18.0])
    np.testing.assert_array_equal(frf.freq_hz, f)
    pos = frf.as_quantity("position")
    np.testing.assert_allclose(pos.channel("x1/u"), _mass_spring(f, 0.5, 2.0, 2000.0), rtol=1e-11)
    np.testing.assert_allclose(pos.channel("x2/u"), 4.0 / (2j * np.pi * f) ** 2, rtol=1e-12)
    np.testing.assert_array_equal(frf.channel_coherence("x1/u"), [0.5, 0.6, 0.7, 0.8, 0.9])


def test_uff_hand_written_node_records_default_and_mapping():
    p = FIXTURES / "frf_nodes_uneven.uff"
    frf = read_frf_uff(p)
    assert frf.channels == ["n7d3/n2d3"] and frf.quantity == "position"
    assert (frf.output_unit, frf.input_unit) == ("m", "N")
    f = np.array([1.0, 2.0, 5.0, 10.0])
    np.testing.assert_array_equal(frf.freq_hz, f)
    np.testing.assert_allclose(frf.response[0, 0], _mass_spring(f, 1.5, 30.0, 6e4), rtol=1e-11)
    mapped = read_frf(p, channels={"7:3/2:3": "x2/f"}, quantity="velocity")
    assert mapped.channels == ["x2/f"] and mapped.quantity == "velocity"


def test_uff_without_frf_records(tmp_path):
    p = _write(tmp_path, "none.uff", "just text\n")
    with pytest.raises(DataError, match=r"none\.uff: no FRF records"):
        read_frf_uff(p)


# ---------------------------------------------------------------------------------------------- dispatch
@pytest.mark.parametrize("ext", [".csv", ".txt", ".mat", ".uff", ".unv"])
def test_read_write_dispatch_by_extension(tmp_path, ext):
    frf = THESIS_TABLE_3_1.frf(np.arange(1.0, 41.0))
    p = tmp_path / f"frf{ext}"
    write_frf(frf, p)
    back = read_frf(p)
    np.testing.assert_allclose(back.response, frf.response, rtol=1e-11)
    assert back.channels == frf.channels


def test_unknown_extension_lists_accepted(tmp_path):
    with pytest.raises(DataError, match=r"frf\.xlsx: unknown FRF file type '\.xlsx'; accepted: \.csv"):
        read_frf(tmp_path / "frf.xlsx")
    with pytest.raises(UsageError, match="freq_var"):
        read_frf(tmp_path / "frf.csv", freq_var="f")
