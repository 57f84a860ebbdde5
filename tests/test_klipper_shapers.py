"""Input shapers, resonances of a PSD and Klipper's shaper fit.

References that are not the code under test: the published properties of each shaper (zero vibration at its
frequency for ZV, ZVD and MZV; humps of exactly the tolerance for the EI family), a time-domain simulation of an
oscillator driven by the shaped step (scipy's ``lsim``), a bisection of the smoothing for the largest acceleration
(Klipper's own method), PSDs of a known second-order resonance, and the real Klipper files: the shaper frequencies
Klipper wrote into its column names and the vibration it wrote into those columns.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from cli_run import run

from feedtune.control.shapers import SHAPER_TYPES, VIBRATION_TOLERANCE, InputShaper
from feedtune.design.input_shaper import fit_shapers, normalize_psd, recommended_shaper, resonance_notch
from feedtune.errors import DataError
from feedtune.identify.resonances import find_resonances
from feedtune.io import read_frf, read_log
from feedtune.io.psd_csv import read_psd_csv, shaper_column
from feedtune.spectrum import PsdSpectrum

KLIPPER = "klipper_voron24_resonances"
CALIBRATION = "calibration_data_x_20230306_225431.csv"
RESONANCES = "resonances_x_20230306_224517.csv"


# ------------------------------------------------------------------------------------------ the shapers
@pytest.mark.parametrize("kind", SHAPER_TYPES)
def test_impulses_sum_to_one_are_positive_and_start_at_zero(kind):
    s = InputShaper.design(kind, 47.3, 0.08)
    assert s.amplitudes.sum() == pytest.approx(1.0, abs=1e-15) and np.all(s.amplitudes > 0)
    assert s.times_s[0] == 0 and np.all(np.diff(s.times_s) > 0)


@pytest.mark.parametrize("kind", ["zv", "zvd", "mzv"])
@pytest.mark.parametrize("damping", [0.0, 0.1, 0.3])
def test_zero_vibration_shapers_cancel_their_design_mode(kind, damping):
    assert InputShaper.design(kind, 50.0, damping).vibration(50.0, damping) < 1e-14


def test_zvd_is_also_flat_at_its_mode():
    s = InputShaper.design("zvd", 50.0, 0.05)
    slope = (s.vibration(50.0 + 1e-4, 0.05) - s.vibration(50.0 - 1e-4, 0.05)) / 2e-4
    assert abs(slope) < 1e-6


@pytest.mark.parametrize(("kind", "humps"), [("ei", 1), ("2hump_ei", 2), ("3hump_ei", 3)])
def test_ei_shapers_have_humps_of_exactly_the_tolerance(kind, humps):
    """Singhose's EI family (undamped): ``humps`` local maxima of the vibration, each exactly V = 0.05, inside the
    band where it stays below V."""
    from scipy.signal import argrelextrema

    f = np.linspace(20.0, 80.0, 120001)
    v = InputShaper.design(kind, 50.0, 0.0).vibration(f, 0.0)
    peaks = v[argrelextrema(v, np.greater)[0]]
    assert peaks.size == humps and np.allclose(peaks, VIBRATION_TOLERANCE, atol=1e-6)


@pytest.mark.parametrize("kind", SHAPER_TYPES)
@pytest.mark.parametrize("ratio", [0.7, 1.0, 1.3])
def test_residual_vibration_is_what_an_oscillator_driven_by_the_shaped_step_keeps(kind, ratio):
    """An undamped oscillator ``x'' = w^2 (u - x)`` driven by the shaped unit step: after the last impulse it swings
    around 1 with the amplitude V, where the unshaped step leaves 1."""
    from scipy.signal import lsim

    shaper = InputShaper.design(kind, 40.0, 0.0)
    f = 40.0 * ratio
    w = 2 * np.pi * f
    t = np.arange(0.0, shaper.duration_s + 5.0 / f, 2e-6)
    u = sum(a * (t >= ti - 1e-12) for a, ti in zip(shaper.amplitudes, shaper.times_s, strict=True))
    _, x, _ = lsim(([w * w], [1.0, 0.0, w * w]), u, t)
    after = t > shaper.duration_s + 1e-9
    assert np.max(np.abs(x[after] - 1.0)) == pytest.approx(float(shaper.vibration(f, 0.0)), abs=2e-4)


@pytest.mark.parametrize("kind", SHAPER_TYPES)
def test_max_accel_is_where_the_smoothing_reaches_its_target_as_a_bisection_finds_it(kind):
    shaper = InputShaper.design(kind, 55.0)
    target = 0.12e-3
    lo, hi = 1e-3, 1e4
    while hi - lo > 1e-9 * hi:
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if shaper.smoothing(mid) <= target else (lo, mid)
    assert shaper.max_accel(target) == pytest.approx(lo, rel=1e-8)
    assert shaper.smoothing(shaper.max_accel(target)) == pytest.approx(target, rel=1e-12)


# ------------------------------------------------------------------------------------------ resonances of a PSD
def _psd(f, fn, zeta, level=1.0):
    r = f / fn
    return level / ((1 - r * r) ** 2 + (2 * zeta * r) ** 2)


@pytest.mark.parametrize(("fn", "zeta"), [(52.0, 0.06), (80.3, 0.02), (31.7, 0.1)])
def test_a_second_order_peak_on_a_coarse_grid_gives_its_frequency_and_damping(fn, zeta):
    f = np.arange(0.0, 200.0, 1.5)
    found = find_resonances(PsdSpectrum(f, {"x": _psd(f, fn, zeta)}), "x").resonances[0]
    assert found.freq_hz == pytest.approx(fn, rel=1e-6) and found.damping == pytest.approx(zeta, rel=1e-5)
    assert found.half_power_damping == pytest.approx(zeta, rel=0.25)  # the bins are coarse; the fit is not
    noisy = _psd(f, fn, zeta) * np.exp(0.05 * np.random.default_rng(1).standard_normal(f.size))
    found = find_resonances(PsdSpectrum(f, {"x": noisy}), "x").resonances[0]
    assert found.freq_hz == pytest.approx(fn, rel=0.01) and found.damping == pytest.approx(zeta, rel=0.15)


def test_two_peaks_by_height_and_a_slope_is_no_resonance():
    f = np.arange(0.0, 200.0, 1.0)
    p = _psd(f, 50.0, 0.05) + 0.3 * _psd(f, 120.0, 0.03) + 50.0 * np.exp(-f / 3.0) * (f >= 5)
    found = find_resonances(PsdSpectrum(f, {"x": p}), "x").resonances
    assert [round(r.freq_hz) for r in found] == [50, 120]
    with pytest.raises(DataError, match="no peak"):
        find_resonances(PsdSpectrum(f, {"x": np.exp(-f / 30.0)}), "x")


def test_the_notch_cancels_the_resonance():
    notch = resonance_notch(52.0, 0.06)
    resonance = np.sqrt(_psd(np.array([52.0]), 52.0, 0.06))  # |H| of the resonance at its peak: 1 / (2 zeta)
    assert abs(notch.zpk().freqresp([52.0])[0]) == pytest.approx(0.06 / 0.7, rel=1e-9)
    assert abs(notch.zpk().freqresp([52.0])[0]) * resonance[0] == pytest.approx(1 / (2 * 0.7), rel=1e-9)


# ------------------------------------------------------------------------------------------ Klipper's files
def test_a_klipper_file_is_refused_by_frf_and_log_readers_in_one_line(tmp_path, capsys, monkeypatch):
    path = tmp_path / "resonances_x.csv"
    path.write_text("freq,psd_x,psd_y,psd_z,psd_xyz\n5.0,1,2,3,6\n6.5,1,2,3,6\n8.0,1,2,3,6\n")
    for reader, what in ((read_frf, "not an FRF"), (read_log, "not a log")):
        with pytest.raises(DataError, match=what) as err:
            reader(path)
        assert "magnitude only, no phase" in str(err.value) and "find_resonances" in str(err.value)
    code, _, err = run(["identify", "ballscrew", path], capsys, monkeypatch)
    assert code == 1 and "feedtune identify resonances" in err and err.count("\n") == 1


def test_a_file_without_shaper_columns_is_raw_and_normalised_as_klipper_does(tmp_path):
    path = tmp_path / "r.csv"
    path.write_text("# a comment\nfreq,psd_x,psd_y,psd_z,psd_xyz\n0.0,1,1,1,3\n4.4,1,1,1,3\n10.0,2,2,2,6\n")
    raw = read_psd_csv(path)
    assert not raw.normalized and raw.unit == "(mm/s^2)^2/Hz"
    assert normalize_psd(raw.freq_hz, raw.get("xyz")).tolist() == [0.0, 0.0, 6 / 10.1]
    assert shaper_column("2hump_ei(80.6)") == ("2hump_ei", 80.6) and shaper_column("psd_x") is None


@pytest.fixture(scope="module")
def calibration(real_data_dir):
    return read_psd_csv(real_data_dir / KLIPPER / CALIBRATION)


def test_klipper_acceptance_resonance_within_2_percent_of_the_psd_peak(calibration):
    for column in ("xyz", "x"):
        psd = calibration.get(column)
        peak_hz = calibration.freq_hz[np.argmax(psd)]
        top = find_resonances(calibration, column).resonances[0]
        assert abs(top.freq_hz / peak_hz - 1) < 0.02, (column, top, peak_hz)


def test_klipper_acceptance_every_shaper_of_the_file_within_5_percent(calibration):
    """The frequencies Klipper wrote into the column names, found again (to the 0.2 Hz step: exactly), and the
    vibration Klipper wrote into each column, to its three decimals and the 0.1 Hz rounding of its grid."""
    fits = {fit.kind: fit for fit in fit_shapers(calibration.freq_hz, calibration.get("xyz"))}
    assert len(calibration.shaper_columns) == 5
    for name, values in calibration.shaper_columns.items():
        kind, freq = shaper_column(name)
        assert abs(fits[kind].freq_hz / freq - 1) < 0.05, (name, fits[kind])
        assert fits[kind].freq_hz == pytest.approx(freq, abs=0.05), name
        assert np.max(np.abs(fits[kind].values - values)) < 0.002, name
    assert recommended_shaper(list(fits.values())).kind == "zv"
    assert 0 < fits["mzv"].max_accel < fits["zv"].max_accel  # m/s^2: more impulses, more smoothing


def test_the_raw_test_normalised_gives_the_same_shapers(calibration, real_data_dir):
    raw = read_psd_csv(real_data_dir / KLIPPER / RESONANCES)
    assert not raw.normalized and calibration.normalized
    got = [round(fit.freq_hz, 1) for fit in fit_shapers(raw.freq_hz, normalize_psd(raw.freq_hz, raw.get("xyz")))]
    assert got == [shaper_column(n)[1] for n in calibration.shaper_columns]


def test_identify_resonances_prints_the_files_columns_beside(real_data_dir, capsys, monkeypatch):
    path = real_data_dir / KLIPPER / CALIBRATION
    code, out, err = run(["identify", "resonances", path], capsys, monkeypatch)
    assert code == 0, err
    assert "mzv(54.2) (+0.0 %)" in out and "--notch 52.6," in out and "recommended: zv" in out
    code, out, err = run(["identify", "resonances", path, "--json", "--shaper", "zvd", "--column", "z"], capsys,
                         monkeypatch)
    doc = json.loads(out)
    assert [s["kind"] for s in doc["shapers"]] == ["zvd"] and doc["column"] == "z" and "file" not in doc["shapers"][0]
    assert math.isclose(doc["notch"]["zeta_z"], doc["resonances"][0]["damping"])
