"""Lines judged by what they can prove, and the plant continued above them by an identified roll-off (issue 23,
items 2 and 3). References: the known plants the test FRFs are built from, not the code under test."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from feedtune.analysis.band_edge import continue_plant
from feedtune.frf_quality import averages_of, hann_step_correlation, line_trust
from feedtune.models import THESIS_TABLE_3_1
from feedtune.models.rolloff import fit_rolloff, fitted_band


def two_mass(model, f):
    """``[x1/u, x2/u]`` of eq. 3.4 [rad/V], written out (not the package's model code)."""
    m1, m2, b1, b2, k, c = model.m1, model.m2, model.b1, model.b2, model.k, model.c
    s = 2j * np.pi * np.asarray(f, float)
    den = s * (m1 * m2 * s**3 + (m1 * b2 + m2 * b1 + (m1 + m2) * c) * s**2
               + (b1 * b2 + (b1 + b2) * c + (m1 + m2) * k) * s + (b1 + b2) * k)
    return np.stack([(m2 * s**2 + (c + b2) * s + k) / den, (c * s + k) / den])


def torsional(f, f0, zeta_z, zeta_p):
    s = 2j * np.pi * np.asarray(f, float)
    w, wz = 2 * np.pi * f0, 2 * np.pi * f0 * 0.95
    return (s**2 + 2 * zeta_z * wz * s + wz**2) / (s**2 + 2 * zeta_p * w * s + w**2) * (w / wz) ** 2


def current_loop(f, fc=450.0):
    return 1.0 / (1.0 + 2j * np.pi * np.asarray(f, float) / (2 * np.pi * fc))


def test_rolloff_recovers_a_pole_and_a_delay_within_its_stated_error():
    f = np.logspace(np.log10(300), np.log10(2000), 160)
    rng = np.random.default_rng(3)
    truth = 0.9 * np.exp(-2j * np.pi * f * 80e-6) * current_loop(f, 600.0)
    ratio = truth * (1 + 0.01 * (rng.standard_normal(f.size) + 1j * rng.standard_normal(f.size)) / np.sqrt(2))
    r = fit_rolloff(f, ratio, np.full(f.size, 0.01))
    assert r.structure == "pole"
    assert abs(r.params["pole_hz"] - 600.0) < 4 * r.std["pole_hz"] + 1.0
    assert abs(r.delay_s - 80e-6) < 4 * r.std["delay_s"] + 1e-7
    fe = np.array([3000.0, 10000.0])
    exact = 0.9 * np.exp(-2j * np.pi * fe * 80e-6) * current_loop(fe, 600.0)
    assert np.allclose(r.response(fe), exact, rtol=0.05)


def test_continuation_of_the_example_plant_follows_the_true_plant_above_the_band():
    """The m2 x 1.3 example FRF (Table 3.1, torsional modes at 440 and 1100 Hz, 450 Hz current loop, 2 % noise):
    continued from the true 2-mass model, the plant above 2 kHz is within 10 % and 12 deg of the true plant to 10 kHz
    although the fitted octave holds the 1100 Hz mode."""
    model = replace(THESIS_TABLE_3_1, m2=THESIS_TABLE_3_1.m2 * 1.3)
    f = np.logspace(0, np.log10(2000), 800)

    def true_plant(fr):
        return two_mass(model, fr) * torsional(fr, 440, 0.05, 0.02) * torsional(fr, 1100, 0.05, 0.02) * current_loop(fr)

    rng = np.random.default_rng(130)
    e = (rng.standard_normal((2, f.size)) + 1j * rng.standard_normal((2, f.size))) / np.sqrt(2)
    h = true_plant(f) * (1 + 0.02 * e)
    grid, plant, _, edge = continue_plant(f, h, lambda fr: two_mass(model, fr), 20000.0, channels=("x1/u", "x2/u"))
    assert grid[-1] == 10000.0 and edge.extended_to_hz == 10000.0 and edge.noise_from_hz is None
    above = grid > 2500
    ratio = plant[:, above] / true_plant(grid[above])
    assert np.all(np.abs(np.abs(ratio) - 1) < 0.10)
    assert np.all(np.abs(np.degrees(np.angle(ratio))) < 12)
    assert np.array_equal(plant[:, :f.size], h)  # the lines themselves untouched


def _noisy_top(seed: int = 5, f_noise: float = 200.0):
    """A two-channel ball-screw FRF (Table 3.1 and a 450 Hz current loop: smooth above 200 Hz) whose lines above
    ``f_noise`` are noise (coherence < 0.2), and the same FRF without noise."""
    f = np.logspace(0, np.log10(2000), 800)
    clean = two_mass(THESIS_TABLE_3_1, f) * current_loop(f)
    rng = np.random.default_rng(seed)
    e = (rng.standard_normal(clean.shape) + 1j * rng.standard_normal(clean.shape)) / np.sqrt(2)
    top = f > f_noise
    h = clean * (1 + 0.01 * e)
    h[:, top] = clean[:, top] + 3.0 * np.abs(clean[:, top]) * e[:, top]  # SNR 1/9: coherence about 0.1
    coh = np.where(top, 0.1, 0.999)[None, :].repeat(2, axis=0)
    return f, h, clean, coh


def test_noise_at_the_top_is_found_where_it_starts_and_nowhere_in_a_clean_frf():
    f, h, clean, coh = _noisy_top()
    t = line_trust(f, h, coh, averages=10)
    assert t.noise_from_hz == pytest.approx(200.0, rel=0.03) and t.noise_rel_error > 1
    assert line_trust(f, clean).noise_from_hz is None
    grid, plant, _, edge = continue_plant(f, h, lambda fr: two_mass(THESIS_TABLE_3_1, fr), 20000.0, coherence=coh,
                                          averages=10, channels=("x1/u", "x2/u"))
    assert edge.valid_to_hz < 200.0 and edge.noise_from_hz == pytest.approx(200.0, rel=0.03)
    # the noise is replaced by the model and the roll-off fitted below it: close to the noise-free plant
    sel = (grid > 300) & (grid <= 2000)
    ratio = plant[:, sel] / clean[:, np.searchsorted(f, grid[sel])]
    assert np.all(np.abs(np.abs(ratio) - 1) < 0.05) and np.all(np.abs(np.degrees(np.angle(ratio))) < 5)
    assert any("from 200" in a or "from 19" in a for a in edge.assumptions())


def test_averages_from_the_estimators_metadata():
    assert averages_of({"segments": "20", "overlap": "0"}) == 20
    c = hann_step_correlation(0.5)
    assert c == pytest.approx(1 / 6, abs=0.01)  # Hann at 50 % overlap: 0.167 (Welch 1967)
    assert averages_of({"segments": "20", "overlap": "0.5"}) == pytest.approx(20 / (1 + 2 * c**2))
    assert averages_of({"periods_total": "6", "transient_periods": "1"}) == 5
    assert averages_of({}) is None and averages_of({"segments": "x"}) is None


def test_fitted_band_is_the_top_octave():
    f = np.logspace(0, 3, 301)
    sel = fitted_band(f, 1000.0)
    assert f[sel][0] >= 500.0 - 1e-9 and f[sel][-1] == 1000.0


def test_a_channel_held_twice_is_continued_once_and_said_once():
    """A cascade on a one-channel FRF holds the motor channel twice (``[x1/u, xp/u]`` with the position loop on the
    motor encoder): continued as the channel alone, and what it assumes above the band said once (issue 24)."""
    f = np.logspace(0, np.log10(300), 100)
    one = two_mass(THESIS_TABLE_3_1, f)[:1] * current_loop(f)

    def model(fr):
        return two_mass(THESIS_TABLE_3_1, fr)[:1]

    alone = continue_plant(f, one, model, 8000.0, channels=("x1/u",))
    twice = continue_plant(f, np.vstack([one, one]), lambda fr: np.vstack([model(fr), model(fr)]), 8000.0,
                           channels=("x1/u", "x1/u"))
    assert np.array_equal(twice[0], alone[0]) and np.array_equal(twice[1], np.vstack([alone[1], alone[1]]))
    assert len(alone[3].assumptions()) == 1 and twice[3].assumptions() == alone[3].assumptions()
    assert [c["channel"] for c in twice[3].to_dict()["channels"]] == ["x1/u"]


def test_roughness_reads_the_scatter_of_the_lines_not_the_curvature_of_the_plant():
    """noise_db on a linear 2 Hz grid: a noise-free mass line at 2-6 Hz (whose second difference read 3 dB of
    "scatter") and a 2 % mode read nothing; complex white scatter of known size reads that size (closed form:
    20 log10(1 + e / sqrt 2) for a relative error e, half of it in magnitude); the coherence floor of n averages is
    the H1 error of Bendat and Piersol eq. 9.90."""
    import numpy as np

    from feedtune.analysis.resolution import LineNoise
    from feedtune.frf_quality import noise_db

    f = np.arange(2.0, 1002.0, 2.0)
    s, wn = 2j * np.pi * f, 2 * np.pi * 300.0
    g = 1 / (0.7 * s * s) * wn * wn / (s * s + 2 * 0.02 * wn * s + wn * wn)
    assert noise_db(f, g[None]).max() < 0.01
    assert noise_db(f, g[None])[:3].max() < 1e-3
    e = 0.02
    rng = np.random.default_rng(3)
    noisy = g * (1 + e * (rng.standard_normal(f.size) + 1j * rng.standard_normal(f.size)) / np.sqrt(2))
    assert np.median(noise_db(f, noisy[None])) == pytest.approx(20 * np.log10(1 + e / np.sqrt(2)), rel=0.15)
    coh = np.full(f.size, 0.99)
    n = 3.0
    floor = 20 * np.log10(1 + np.sqrt(0.01 / (2 * n * 0.99)))
    assert np.asarray(LineNoise(f, g[None], coh[None], averages=n)) == pytest.approx(floor, rel=1e-12)
    assert np.asarray(LineNoise(f, g[None], coh[None])) == pytest.approx(  # one average when not recorded
        20 * np.log10(1 + np.sqrt(0.01 / (2 * 0.99))), rel=1e-12)
