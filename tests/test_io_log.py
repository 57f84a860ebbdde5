"""Log readers (CSV, MATLAB v5/v7.3, MDF4) and the CSV writer, on synthetic files and the real data sets."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

from feedtune.errors import DataError, UsageError
from feedtune.io import read_log, write_log_csv
from feedtune.log import Log

FIXTURES = Path(__file__).parent / "fixtures"


def _write(tmp_path: Path, name: str, text: str) -> Path:
    p = tmp_path / name
    p.write_text(text)
    return p


# ---------------------------------------------------------------------------------------------------- CSV
def test_csv_round_trip_is_exact(tmp_path):
    rng = np.random.default_rng(1)
    t = np.cumsum(rng.uniform(0.5e-3, 1.5e-3, 400))
    log = Log(t, {"x1": rng.normal(size=400) * 1e-3, "u": rng.normal(size=400), "flag": np.arange(400.0)},
              {"x1": "rad", "u": "V"}, {"source": "bench, run 3"})
    write_log_csv(log, tmp_path / "run.csv")
    lines = (tmp_path / "run.csv").read_text().splitlines()
    assert lines[1] == "# source: bench, run 3" and lines[2] == "t [s],x1 [rad],u [V],flag"
    back = read_log(tmp_path / "run.csv")
    np.testing.assert_array_equal(back.t, t)
    assert list(back.signals) == ["x1", "u", "flag"]
    for k in log.signals:
        np.testing.assert_array_equal(back[k], log[k])
    assert back.units == {"x1": "rad", "u": "V", "flag": ""}
    assert back.meta["origin"] == "bench, run 3"
    with pytest.raises(UsageError, match=r"run\.csv exists; pass force=True to overwrite") as err:
        write_log_csv(log, tmp_path / "run.csv")
    assert err.value.parameter == "force"


def test_csv_units_from_metadata_and_time_in_ms(tmp_path):
    text = "# unit: u = N\n# rig: test bench\ntime [ms];x2 (m);u\n0;0.0;1\n2;0.5;2\n4;1.0;3\n"
    log = read_log(_write(tmp_path, "semi.csv", text))
    np.testing.assert_array_equal(log.t, [0.0, 0.002, 0.004])
    assert log.units == {"x2": "m", "u": "N"} and log.meta["rig"] == "test bench"
    assert log.fs == pytest.approx(500.0)


def test_csv_mapping_scale_units_and_fs(tmp_path):
    text = "pos,cmd\n0.0,1.0\n0.1,2.0\n0.2,4.0\n0.3,8.0\n"
    p = _write(tmp_path, "nt.csv", text)
    with pytest.raises(DataError, match=r"nt\.csv: no time column .*pass fs= \(sample rate in Hz\)") as err:
        read_log(p)
    assert err.value.parameters == ("fs", "time")
    log = read_log(p, fs=100.0, mapping={"x2": "pos", "u": "cmd"}, scale={"u": 35.15}, units={"u": "N"})
    np.testing.assert_array_equal(log.t, np.arange(4) / 100.0)
    np.testing.assert_array_equal(log["u"], np.array([1.0, 2.0, 4.0, 8.0]) * 35.15)
    assert list(log.signals) == ["x2", "u"] and log.units == {"x2": "", "u": "N"}


def test_csv_semicolons_with_decimal_commas(tmp_path):
    log = read_log(_write(tmp_path, "de.csv", "t;x\n0;1,5\n0,001;-2,25\n"))
    np.testing.assert_array_equal(log.t, [0.0, 0.001])
    np.testing.assert_array_equal(log["x"], [1.5, -2.25])


def test_csv_columns_by_header_text_or_position(tmp_path):
    p = _write(tmp_path, "h.csv", "t [s],x2 [m],u [V]\n0,1,5\n0.001,2,6\n")
    log = read_log(p, time="t [s]", mapping={"pos": "col1"})
    assert list(log.signals) == ["pos", "u"] and log.units == {"pos": "m", "u": "V"}
    np.testing.assert_array_equal(log["pos"], [1.0, 2.0])


def test_csv_vendor_preamble_with_skip_rows():
    p = FIXTURES / "vendor_daq_preamble.csv"
    preamble = r"vendor_daq_preamble\.csv: line 2, column 'Timestamp': 'Interval' is not a number; pass skip"
    with pytest.raises(DataError, match=preamble):
        read_log(p)
    log = read_log(p, skip_rows=4, time="col0", mapping={"force": "col1", "input": "col3"},
                   scale={"force": -200})
    np.testing.assert_array_equal(log.t, np.arange(5) * 0.0005)
    np.testing.assert_array_equal(log["force"], [25.0, 100.0, -50.0, -150.0, -200.0])
    np.testing.assert_array_equal(log["input"], [-3.25, -3.5, 1.5, 2.0, 2.5])
    assert set(log.signals) == {"force", "input", "col2"}


@pytest.mark.parametrize(
    ("text", "kwargs", "error", "fragment"),
    [
        ("t,x\n0,1\n1,2\n", {"mapping": {"y": "z"}}, DataError, "no column 'z'"),
        ("t,x\n0,1\n1,abc\n", {}, DataError, "line 3, column 'x': 'abc' is not a number"),
        ("t,x\n0,1\n0,2\n", {}, DataError, "time column 't' is not strictly increasing"),
        ("t,x\n0,1\n1,2\n", {"scale": {"y": 2.0}}, DataError, "scale: no signal 'y'"),
        ("t,x\n0,1\n1,2\n", {"fs": -5.0}, UsageError, "fs must be a sample rate in (0, 1e+07] Hz"),
        ("t,x\n0,1\n1,2\n", {"fs": 5.0, "time": "t"}, UsageError, "give either time= (a time column)"),
        ("t,x\n0,1\n1,2\n", {"units": {"q": "m"}}, DataError, "units: no signal 'q'"),
        ("t,x\n0,1\n", {}, DataError, "at least 2 samples"),
    ],
)
def test_csv_bad_input(tmp_path, text, kwargs, error, fragment):
    p = _write(tmp_path, "bad_log.csv", text)
    with pytest.raises(error) as err:
        read_log(p, **kwargs)
    assert fragment in str(err.value)
    if error is DataError:
        assert "bad_log.csv" in str(err.value)


def test_unknown_log_extension(tmp_path):
    with pytest.raises(DataError, match=r"run\.xls: unknown log file type '\.xls'; accepted: \.csv"):
        read_log(tmp_path / "run.xls")


# ---------------------------------------------------------------------------------------------------- MAT
def test_mat_v5_vectors_scalars_and_matrix_columns(tmp_path):
    import scipy.io

    n = 50
    t_us = (np.arange(n) * 400).astype(np.int32)
    data = np.column_stack([np.arange(n) * 1e-3, np.arange(n) ** 2.0, -np.arange(n) * 1.0])
    scipy.io.savemat(tmp_path / "m.mat", {"time": t_us, "iq": np.linspace(0, 1, n), "gain": 35.15,
                                          "count": np.uint16(7), "note": "bench", "ref": np.ones(10),
                                          "data": data})
    log = read_log(tmp_path / "m.mat", scale={"time": 1e-6})
    assert log.n == n and log.fs == pytest.approx(2500.0)
    assert list(log.signals) == ["iq"]  # ref has another length, data is a matrix
    assert log.meta["gain"] == 35.15 and log.meta["count"] == 7 and log.meta["note"] == "bench"
    log2 = read_log(tmp_path / "m.mat", time="data[0]", mapping={"v": "data[1]", "w": "data[2]"})
    np.testing.assert_array_equal(log2.t, np.arange(n) * 1e-3)
    np.testing.assert_array_equal(log2["v"], np.arange(n) ** 2.0)
    with pytest.raises(DataError, match=r"m\.mat: data\[5\]: variable 'data' has shape 50x3, no column 5"):
        read_log(tmp_path / "m.mat", time="data[0]", mapping={"v": "data[5]"})
    with pytest.raises(DataError, match=r"m\.mat: variable 'data' is a 50x3 matrix; pick a column"):
        read_log(tmp_path / "m.mat", mapping={"v": "data"}, scale={"time": 1e-6})
    with pytest.raises(DataError, match=r"m\.mat: no variable 'qm'; numeric variables: time 1x50, iq 1x50"):
        read_log(tmp_path / "m.mat", mapping={"x": "qm"})


def test_time_column_by_its_mapped_name(tmp_path):
    import scipy.io

    n = 40
    data = np.column_stack([0.5 + np.arange(n) * 1e-3, np.arange(n) * 2.0])
    scipy.io.savemat(tmp_path / "hsm.mat", {"data": data})
    for kwargs in ({"time": "t"}, {}):  # named with time=, or found as the mapped name t
        log = read_log(tmp_path / "hsm.mat", mapping={"t": "data[0]", "x": "data[1]"}, **kwargs)
        np.testing.assert_array_equal(log.t, data[:, 0])
        assert list(log.signals) == ["x"]
    ms = read_log(tmp_path / "hsm.mat", mapping={"clock": "data[0]", "x": "data[1]"}, time="clock",
                  scale={"clock": 0.5})
    np.testing.assert_allclose(ms.t, data[:, 0] * 0.5)
    with pytest.raises(DataError, match=r"hsm\.mat: no time column"):
        read_log(tmp_path / "hsm.mat", mapping={"x": "data[1]"})


def test_mat_v73_log(tmp_path):
    from test_io_frf import write_mat73

    t = np.arange(20) / 1000.0
    write_mat73(tmp_path / "v73.mat", {"t": t, "qm": np.sin(t), "vir": np.cos(t), "gtau": np.array([[35.0]]),
                                       "unit_note": "V"})
    log = read_log(tmp_path / "v73.mat")
    np.testing.assert_array_equal(log.t, t)
    np.testing.assert_array_equal(log["qm"], np.sin(t))
    assert log.meta["gtau"] == 35.0 and log.meta["unit_note"] == "V" and log.meta["format"] == "mat v7.3"


# ---------------------------------------------------------------------------------------------------- MDF
def test_mdf_without_asammdf_says_which_extra(tmp_path, monkeypatch):
    p = tmp_path / "run.mf4"
    p.write_bytes(b"MDF     4.10    ")
    monkeypatch.setitem(sys.modules, "asammdf", None)
    extra = r"reading MDF4 needs the optional extra: pip install 'feedtune\[mdf\]'"
    with pytest.raises(DataError, match=extra):
        read_log(p)


def test_mdf_round_trip_with_two_rates(tmp_path):
    asammdf = pytest.importorskip("asammdf")
    t_fast = np.arange(200) / 1000.0
    t_slow = np.arange(100) / 500.0
    mdf = asammdf.MDF(version="4.10")
    mdf.append([asammdf.Signal(np.sin(t_fast), t_fast, name="x1", unit="rad"),
                asammdf.Signal(3.0 * t_fast, t_fast, name="cmd", unit="V")])
    mdf.append([asammdf.Signal(2.0 * t_slow, t_slow, name="slow", unit="m")])
    mdf.save(tmp_path / "run.mf4")
    mdf.close()
    log = read_log(tmp_path / "run.mf4", mapping={"u": "cmd", "z": "slow"}, scale={"u": 2.0})
    np.testing.assert_array_equal(log.t, t_fast)
    np.testing.assert_allclose(log["u"], 6.0 * t_fast, rtol=1e-15)
    np.testing.assert_allclose(log["z"], np.interp(t_fast, t_slow, 2.0 * t_slow), rtol=1e-15)
    assert log.units == {"u": "V", "z": "m"}
    all_channels = read_log(tmp_path / "run.mf4", fs=250.0)
    np.testing.assert_allclose(np.diff(all_channels.t), 0.004, rtol=1e-9)
    np.testing.assert_allclose(all_channels["slow"], 2.0 * all_channels.t, rtol=1e-12)
    with pytest.raises(DataError, match=r"run\.mf4: no channel 'nope'"):
        read_log(tmp_path / "run.mf4", mapping={"a": "nope"})


# ---------------------------------------------------------------------------------------------- real data
def test_real_emps(real_data_dir):
    log = read_log(real_data_dir / "EMPS" / "DATA_EMPS.mat")
    assert log.n == 24841 and log.fs == pytest.approx(1000.0, rel=1e-9) and log.is_uniform()
    assert {"qm", "qg", "vir"} <= set(log.signals)
    assert log.meta["gtau"] == pytest.approx(35.15065, rel=1e-6)
    assert log.meta["kp"] == pytest.approx(160.18) and log.meta["kv"] == pytest.approx(243.45)
    assert np.abs(log["vir"]).max() <= 10.0 + 1e-9  # +-10 V saturation (README)


def test_real_fdi_tools_multisine(real_data_dir):
    log = read_log(real_data_dir / "twomass_motor_bench_FdiTools" / "MultisineTypeA.mat",
                   scale={"time": 1e-6}, units={"iq_adx": "A", "theta_mx": "rad"})
    assert log.n == 50000 and log.fs == pytest.approx(2500.0, rel=1e-9) and log.is_uniform()
    assert {"iq_adx", "theta_mx", "theta_my", "omega_max"} <= set(log.signals)
    assert "ref" not in log.signals and log.meta["nrofs"] == 2500
    assert "ms" in log.meta["skipped_variables"]


def test_real_hsm150_matrix_columns(real_data_dir):
    log = read_log(real_data_dir / "HSM150_motor_steps" / "idf_neg_0.045_1.mat", time="data[0]",
                   mapping={"theta": "data[2]", "omega": "data[3]", "torque_cmd": "data[4]"})
    assert log.n == 20000 and log.fs == pytest.approx(1000.0, rel=1e-6)
    assert log.meta["Tvz"] == pytest.approx(1e-3)
    tau = log["torque_cmd"]
    # README: torque step from -0.03 to -0.045 N m at t = 10 s
    assert np.median(tau[log.t < 9.9]) == pytest.approx(-0.03, abs=1e-9)
    assert np.median(tau[log.t > 10.1]) == pytest.approx(-0.045, abs=1e-9)


def test_real_rack_pinion_daq(real_data_dir):
    log = read_log(real_data_dir / "rack_pinion_friction_Mnich" / "a3NI.csv", skip_rows=4, time="col0",
                   mapping={"force_v": "col1", "input_v": "col3"}, units={"force_v": "V", "input_v": "V"})
    assert log.dt == pytest.approx(0.5e-3, rel=1e-9) and log.is_uniform()
    assert log.t[0] == 0.0 and log.t[-1] == pytest.approx(0.5385)
    assert log.n == 1078
