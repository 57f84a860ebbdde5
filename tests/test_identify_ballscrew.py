"""Tests of the ball-screw 2-mass FRF fit against independent values.

Truth FRFs are built here from the state-space form of eq. 3.1 typed in by hand (not from the model module),
thesis numbers come from the thesis text (Table 3.1: mode 130 Hz, 2.7 % damping, real pole 0.07 Hz), and
the real-data check compares with resonance and anti-resonance frequencies read off the raw measurement.
"""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest

from feedtune.errors import DataError, UsageError, cli_message
from feedtune.frf import Frf
from feedtune.identify.ballscrew import fit_ballscrew
from feedtune.models.ballscrew import THESIS_TABLE_3_1

TABLE_3_1 = {"m1": 1.858e-3, "m2": 0.379e-3, "b1": 1.020e-3, "b2": 0.0, "k": 210.02, "c": 0.014}
FREQ = np.geomspace(1.0, 1000.0, 2000)


# ----------------------------------------------------------------------------------------- helpers
def state_space_frf(p: dict, freq_hz: np.ndarray) -> np.ndarray:
    """u -> (x1, x2) position response [rad/V], shape (2, 1, n), from the matrices of eq. 3.3."""
    m1, m2, b1, b2, k, c = (p[n] for n in ("m1", "m2", "b1", "b2", "k", "c"))
    A = np.array([[0, 0, 1, 0], [0, 0, 0, 1],
                  [-k / m1, k / m1, -(c + b1) / m1, c / m1],
                  [k / m2, -k / m2, c / m2, -(c + b2) / m2]])
    B = np.array([0.0, 0.0, 1 / m1, 0.0])
    s = 2j * np.pi * freq_hz
    x = np.linalg.solve(s[:, None, None] * np.eye(4) - A, np.broadcast_to(B, (s.size, 4))[..., None])
    return np.moveaxis(x[:, :2, :], 0, -1)


def second_order_pair(freq_hz, fn, zeta_zero, zeta_pole):
    """Unit-DC-gain resonance factor (s^2 + 2 zz wn s + wn^2) / (s^2 + 2 zp wn s + wn^2)."""
    s, wn = 2j * np.pi * freq_hz, 2 * np.pi * fn
    return (s**2 + 2 * zeta_zero * wn * s + wn**2) / (s**2 + 2 * zeta_pole * wn * s + wn**2)


def complex_noise(shape, level, seed):
    """Independent circular complex noise of rms ``level`` per point."""
    rng = np.random.default_rng(seed)
    return level * (rng.standard_normal(shape) + 1j * rng.standard_normal(shape)) / np.sqrt(2)


def realistic_response(seed: int = 1) -> np.ndarray:
    """Table 3.1 with torsional modes at 440 and 1100 Hz, a 450 Hz current loop and 2 % complex noise."""
    h = state_space_frf(TABLE_3_1, FREQ)
    extra = (second_order_pair(FREQ, 440, 0.03, 0.01) * second_order_pair(FREQ, 1100, 0.03, 0.01)
             / (1 + 2j * np.pi * FREQ / (2 * np.pi * 450)))
    return h * extra * (1 + complex_noise(h.shape, 0.02, seed))


def make_frf(h, quantity="position", **kw) -> Frf:
    jw = 2j * np.pi * FREQ
    order = {"position": 0, "velocity": 1, "acceleration": 2}[quantity]
    return Frf(FREQ, h * jw**order, ("x1", "x2"), ("u",), quantity, **kw)


def rel_errors(params: dict, truth: dict) -> dict:
    return {n: abs(params[n] - truth[n]) / truth[n] for n in truth if truth[n] != 0}


@pytest.fixture(scope="module")
def realistic_fit():
    return fit_ballscrew([make_frf(realistic_response())])


# ----------------------------------------------------------------------------------------- thesis values
def test_table_3_1_mode_damping_and_real_pole_match_thesis_text():
    modes = THESIS_TABLE_3_1.modes()
    assert len(modes) == 1
    assert modes[0].freq_hz == pytest.approx(130, abs=0.5)
    assert modes[0].zeta == pytest.approx(0.027, abs=0.0005)
    assert THESIS_TABLE_3_1.real_pole_hz() == pytest.approx(0.07, abs=0.005)


# ----------------------------------------------------------------------------------------- recovery
def test_noise_free_table_3_1_recovered_within_1_percent_with_automatic_band():
    result = fit_ballscrew([make_frf(state_space_frf(TABLE_3_1, FREQ))])
    params = result.model.params()
    errors = rel_errors(params, TABLE_3_1)
    assert max(errors.values()) < 0.01, errors
    assert params["b2"] < 0.01 * TABLE_3_1["b1"]
    lo, hi = result.band_hz
    assert lo == pytest.approx(13.0, rel=0.05)            # a tenth of the 130 Hz mode
    assert 1.7 * 130 <= hi <= 2.05 * 130
    assert result.modes[0].freq_hz == pytest.approx(130, abs=0.5)
    assert result.modes[0].zeta == pytest.approx(0.027, abs=0.0005)
    assert all(q["nrmse"] < 1e-6 for q in result.fit.values())


def test_a_channel_counting_the_other_way_is_named_with_its_phase_and_the_fix():
    frf = make_frf(state_space_frf(TABLE_3_1, FREQ))
    flipped = replace(frf, response=frf.response * np.array([1.0, -1.0])[:, None, None])
    with pytest.raises(DataError, match=r"channel x2/u: its phase below the first axial mode is \+0 deg .*"
                                        r"scale=x2/u=-1 when reading the FRF") as err:
        fit_ballscrew([flipped])
    assert err.value.parameter == "read_frf.scale" and "flip it with --frf-scale x2/u=-1" in cli_message(err.value)


def test_realistic_data_within_5_percent_and_b1_flagged(realistic_fit):
    errors = rel_errors(realistic_fit.model.params(), TABLE_3_1)
    assert max(errors[n] for n in ("m1", "m2", "k", "c")) < 0.05, errors
    lo, hi = realistic_fit.band_hz
    assert lo == pytest.approx(13.0, rel=0.05)
    assert 1.7 * 130 <= hi < 440 / 1.5 + 1                 # below the first torsional mode
    assert any(w.startswith("b1") and "poorly determined" in w for w in realistic_fit.warnings)
    assert not any("poor fit" in w for w in realistic_fit.warnings)
    # the fitted equivalent delay stands in for the 450 Hz current loop: ~1 / (2 pi 450 Hz) = 354 us
    assert realistic_fit.delay_s == pytest.approx(1 / (2 * np.pi * 450), rel=0.25)


def test_position_velocity_and_acceleration_frfs_give_the_same_parameters(realistic_fit):
    h = realistic_response()
    for quantity in ("velocity", "acceleration"):
        other = fit_ballscrew([make_frf(h, quantity)]).model.params()
        for name, value in realistic_fit.model.params().items():
            assert other[name] == pytest.approx(value, rel=1e-6, abs=1e-12), (quantity, name)


def test_two_files_one_channel_each_in_other_units_match_the_combined_fit(realistic_fit):
    h = realistic_response()
    lead = 0.02 / (2 * np.pi)
    jw = 2j * np.pi * FREQ
    motor = Frf(FREQ, h[:1] * jw, ("x1",), ("u",), "velocity", output_unit="rad", meta={"source": "m.csv"})
    table = Frf(FREQ, h[1:] * jw**2 * lead * 1e3, ("x2",), ("u",), "acceleration", output_unit="mm",
                meta={"source": "t.csv"})
    result = fit_ballscrew([motor, table], lead_m_per_rad=lead)
    for name, value in realistic_fit.model.params().items():
        assert result.model.params()[name] == pytest.approx(value, rel=1e-6, abs=1e-12), name
    assert result.model.lead_m_per_rad == lead


def test_channel_in_several_files_is_fitted_from_all_of_them():
    h = state_space_frf(TABLE_3_1, FREQ)
    low, high = FREQ <= 100, FREQ > 100
    parts = [Frf(FREQ[m], h[..., m], ("x1", "x2"), ("u",)) for m in (low, high)]
    result = fit_ballscrew(parts)
    assert result.fit["x1/u"]["n_points"] == np.count_nonzero((FREQ >= result.band_hz[0])
                                                              & (FREQ <= result.band_hz[1]))
    assert max(rel_errors(result.model.params(), TABLE_3_1).values()) < 0.01


def test_motor_side_channel_alone_identifies_all_parameters():
    h = state_space_frf(TABLE_3_1, FREQ)[:1]
    result = fit_ballscrew([Frf(FREQ, h, ("x1",), ("u",))], channels=["x1/u"])
    assert max(rel_errors(result.model.params(), TABLE_3_1).values()) < 0.01
    assert list(result.fit) == ["x1/u"]


def test_without_delay_term_noise_free_data_are_still_recovered(clean_frf):
    result = fit_ballscrew([clean_frf], fit_delay=False)
    assert max(rel_errors(result.model.params(), TABLE_3_1).values()) < 0.01
    assert result.delay_s == 0.0 and result.delay_std_s == 0.0


def test_different_input_units_are_a_data_error(clean_frf):
    other = Frf(FREQ, clean_frf.response, ("x1", "x2"), ("u",), input_unit="A")
    with pytest.raises(DataError, match="input units"):
        fit_ballscrew([clean_frf, other])


def test_reported_std_matches_scatter_over_noise_realisations():
    truth = {**TABLE_3_1, "b2": 0.3e-3}                       # no parameter at its bound
    freq = np.geomspace(0.5, 260, 300)
    h = state_space_frf(truth, freq) * np.exp(-2j * np.pi * freq * 1e-4)
    estimates, stds = [], []
    for seed in range(30):
        noisy = h * (1 + complex_noise(h.shape, 0.02, seed))
        result = fit_ballscrew([Frf(freq, noisy, ("x1", "x2"), ("u",))], band_hz=(0.4, 300))
        estimates.append([result.model.params()[n] for n in truth])
        stds.append([result.std[n] for n in truth])
    ratio = np.std(estimates, axis=0, ddof=1) / np.mean(stds, axis=0)
    assert np.all((ratio > 0.6) & (ratio < 1.6)), dict(zip(truth, ratio.round(2), strict=True))


# ----------------------------------------------------------------------------------------- warnings, output
def test_poor_fit_and_low_coherence_are_reported():
    h = realistic_response()
    coherence = np.full(h.shape, 0.5)
    result = fit_ballscrew([make_frf(h, coherence=coherence)], poor_fit_threshold=0.01)
    assert any(w.startswith("poor fit of x1/u") for w in result.warnings)
    assert any(w.startswith("low coherence in x2/u") for w in result.warnings)


def test_to_dict_is_json_ready_with_units():
    h = state_space_frf(TABLE_3_1, FREQ)
    result = fit_ballscrew([make_frf(h, input_unit="A")])
    d = json.loads(json.dumps(result.to_dict()))
    assert d["kind"] == "ballscrew"
    assert set(d["params"]) == set(TABLE_3_1) == set(d["std"])
    assert d["units"]["m1"] == "A/(rad/s^2)" and d["units"]["k"] == "A/rad"
    assert d["modes"][0]["freq_hz"] == pytest.approx(130, abs=0.5)
    assert d["real_pole_hz"] == pytest.approx(0.07, abs=0.005)
    assert len(d["band_hz"]) == 2 and set(d["fit"]) == {"x1/u", "x2/u"}
    assert set(d["fit"]["x1/u"]) == {"nrmse", "mag_rms_db", "phase_rms_deg", "n_points"}


# ----------------------------------------------------------------------------------------- bad input
@pytest.fixture(scope="module")
def clean_frf():
    return make_frf(state_space_frf(TABLE_3_1, FREQ))


def test_band_without_the_mode_is_a_data_error(clean_frf):
    with pytest.raises(DataError, match=r"band_hz 1-50 Hz must contain the first axial mode") as info:
        fit_ballscrew([clean_frf], band_hz=(1, 50))
    detected = float(str(info.value).split(" at ")[1].split(" Hz")[0])
    assert detected == pytest.approx(130, rel=0.01)


def test_too_few_points_in_band_is_a_data_error(clean_frf):
    with pytest.raises(DataError, match="points"):
        fit_ballscrew([clean_frf], band_hz=(129.9, 130.1))


def test_missing_channels_are_data_errors(clean_frf):
    table_only = Frf(FREQ, clean_frf.response[1:], ("x2",), ("u",))
    with pytest.raises(DataError, match="x1/u"):
        fit_ballscrew([table_only])
    with pytest.raises(DataError, match="enc/u"):
        fit_ballscrew([clean_frf], channels=["enc/u", "x2/u"])
    with pytest.raises(DataError, match="cannot separate"):
        fit_ballscrew([clean_frf], channels=["x2/u"])


def test_rigid_body_without_resonance_is_a_data_error():
    s = 2j * np.pi * FREQ
    rigid = (1 / (s * (2e-3 * s + 1e-3)))[None, None, :].repeat(2, axis=0)
    with pytest.raises(DataError, match="no resonance"):
        fit_ballscrew([Frf(FREQ, rigid, ("x1", "x2"), ("u",))])


@pytest.mark.parametrize("kwargs, pattern", [
    ({"band_hz": (200, 100)}, "band_hz"),
    ({"band_hz": "wide"}, "band_hz"),
    ({"poor_fit_threshold": 0}, "poor_fit_threshold"),
    ({"lead_m_per_rad": -1.0}, "lead_m_per_rad"),
    ({"channels": ["x1-u"]}, "OUT/IN"),
])
def test_bad_parameters_are_usage_errors(clean_frf, kwargs, pattern):
    with pytest.raises(UsageError, match=pattern):
        fit_ballscrew([clean_frf], **kwargs)


def test_metres_without_lead_is_a_usage_error():
    h = state_space_frf(TABLE_3_1, FREQ)
    frf = Frf(FREQ, h, ("x1", "x2"), ("u",), output_unit="m")
    with pytest.raises(UsageError, match="lead_m_per_rad"):
        fit_ballscrew([frf])


# ----------------------------------------------------------------------------------------- real data
def bench_frf(real_data_dir) -> Frf:
    """FRF of the FdiTools two-mass bench: period-averaged spectra of periods 2..20, lines 11..250 Hz."""
    from scipy.io import loadmat

    d = loadmat(real_data_dir / "twomass_motor_bench_FdiTools" / "MultisineTypeA.mat", squeeze_me=True)
    n = 2500
    spectra = {name: np.fft.rfft(np.asarray(x, float)[n:20 * n].reshape(19, n), axis=1).mean(axis=0)
               for name, x in (("u", d["iq_adx"]), ("x1", d["theta_mx"]), ("x2", -d["theta_my"]))}
    lines = np.arange(11, 251)                               # df = 2500 Hz / 2500 = 1 Hz
    return Frf.from_channels(lines.astype(float), {f"{o}/u": spectra[o][lines] / spectra["u"][lines]
                                                   for o in ("x1", "x2")}, input_unit="A")


def test_real_two_mass_bench_mode_and_anti_resonance_match_the_measurement(real_data_dir):
    frf = bench_frf(real_data_dir)
    accel = frf.as_quantity("acceleration")
    f = frf.freq_hz
    peak_hz = f[np.argmax(np.abs(accel.channel("x2/u")))]
    below = f < peak_hz
    dip_hz = f[below][np.argmin(np.abs(accel.channel("x1/u"))[below])]
    result = fit_ballscrew([frf])
    model = result.model
    assert result.modes[0].freq_hz == pytest.approx(peak_hz, abs=1.5)
    assert np.sqrt(model.k / model.m2) / (2 * np.pi) == pytest.approx(dip_hz, abs=1.5)
    assert all(q["mag_rms_db"] < 1.0 and q["phase_rms_deg"] < 6.0 for q in result.fit.values()), result.fit
    motor_only = fit_ballscrew([frf], channels=["x1/u"]).model.params()
    for name in ("m1", "m2", "k"):
        assert motor_only[name] == pytest.approx(model.params()[name], rel=0.02), name


def test_outlier_lines_are_named_and_a_clean_frf_has_none(examples_dir):
    """Five lines of the example FRF inside the fit band multiplied by 10 (a glitch): each is named; the clean
    FRF gives no such warning."""
    from dataclasses import replace

    from feedtune.io import read_frf

    frf = read_frf(examples_dir / "ballscrew_frf.csv")
    clean = fit_ballscrew([frf])
    assert not any("stand out" in w for w in clean.warnings)
    lo, hi = clean.band_hz
    inside = np.flatnonzero((frf.freq_hz > lo) & (frf.freq_hz < hi))
    idx = inside[np.linspace(5, inside.size - 5, 5).astype(int)]
    h = frf.response.copy()
    h[:, :, idx] *= 10
    bad = fit_ballscrew([replace(frf, response=h)])
    lines = [w for w in bad.warnings if "stand out" in w]
    assert len(lines) == 2 and all("5 line(s)" in w for w in lines), lines
    for f in frf.freq_hz[idx]:
        assert all(f"{f:.4g}" in w for w in lines)
