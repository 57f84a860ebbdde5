"""Tracking, rope-snap and contour metrics against closed-form and hand-computed values."""

from __future__ import annotations

import json

import numpy as np
import pytest
from scipy.special import lambertw

from feedtune.analysis.metrics import (
    amplitude_spectrum,
    contour_error,
    ropesnap_metrics,
    tracking_metrics,
)
from feedtune.errors import DataError, UsageError


# ---------------------------------------------------------------------------------------------- tracking
def _trapezoid_run():
    """3 s at 1 kHz: accelerate 1 s, cruise 1 s, decelerate 1 s; error built from known pieces."""
    t = np.arange(3000) * 1e-3
    acc = np.where(t < 1.0, 0.5, np.where(t < 2.0, 0.0, -0.5))
    vel = np.cumsum(acc) * 1e-3
    err = np.where(t < 1.0, 3e-6, np.where(t < 2.0, 1e-6 * np.sin(2 * np.pi * 50 * t), -3e-6))
    return t, err, vel, acc


def test_tracking_parts_by_hand():
    t, err, vel, acc = _trapezoid_run()
    m = tracking_metrics(t, err, vel=vel, acc=acc)
    # acceleration parts: constant +-3 um over 2000 samples
    assert m.acceleration.n_samples == 2000
    assert m.acceleration.max_abs == pytest.approx(3e-6, rel=1e-12)
    assert m.acceleration.rms == pytest.approx(3e-6, rel=1e-12)
    # cruise: 1 um sine, 50 whole cycles sampled at its crests -> max 1 um, RMS 1/sqrt(2) um
    assert m.constant_velocity.n_samples == 1000
    assert m.constant_velocity.max_abs == pytest.approx(1e-6, rel=1e-9)
    assert m.constant_velocity.rms == pytest.approx(1e-6 / np.sqrt(2), rel=1e-9)
    # whole run: sqrt((2000 * 9 + 1000 * 0.5) / 3000) um
    assert m.overall.max_abs == pytest.approx(3e-6, rel=1e-12)
    assert m.overall.rms == pytest.approx(np.sqrt(18500 / 3000) * 1e-6, rel=1e-9)
    d = m.to_dict()
    json.dumps(d)
    assert d["constant_velocity"]["max_m"] == pytest.approx(1e-6, rel=1e-9)
    assert d["overall"]["duration_s"] == pytest.approx(3.0)


def test_tracking_velocity_only_derives_acceleration():
    t, err, vel, _ = _trapezoid_run()
    m = tracking_metrics(t, err, vel=vel, spectrum=False)
    # np.gradient blurs the two acceleration edges by one sample each at most
    assert abs(m.constant_velocity.n_samples - 1000) <= 2
    assert m.constant_velocity.max_abs == pytest.approx(1e-6, rel=1e-9)
    assert m.freq_hz is None and m.peaks == ()


def test_tracking_spectrum_amplitudes():
    t = np.arange(4000) * 5e-4  # 2 s at 2 kHz, 0.5 Hz lines
    err = 2e-6 * np.sin(2 * np.pi * 37 * t) + 0.5e-6 * np.cos(2 * np.pi * 120 * t) + 4e-6
    m = tracking_metrics(t, err)
    assert [p.freq_hz for p in m.peaks] == [37.0, 120.0]
    assert m.peaks[0].level == pytest.approx(2e-6, rel=1e-9)
    assert m.peaks[1].level == pytest.approx(0.5e-6, rel=1e-9)
    f, a = amplitude_spectrum(err, 5e-4)
    assert f[1] == pytest.approx(0.5) and a[0] < 1e-18  # mean removed


# --------------------------------------------------------------------------------------------- rope snap
def _pulse_log(noise: float = 0.0, seed: int = 0):
    """Baseline 20 um until 0.5 s, then x = x0 + A (tau/T) exp(1 - tau/T): peak A at tau = T."""
    fs, T, A, x0, t_rel = 2000.0, 0.1, -4e-6, 20e-6, 0.5
    t = np.arange(int(7.0 * fs)) / fs
    tau = np.clip(t - t_rel, 0.0, None)
    x = x0 + A * (tau / T) * np.exp(1 - tau / T)
    x = x + noise * np.random.default_rng(seed).standard_normal(t.size)
    return t, x, dict(fs=fs, T=T, A=A, x0=x0, t_rel=t_rel)


def test_ropesnap_peak_and_settling_closed_form():
    t, x, p = _pulse_log()
    m = ropesnap_metrics(t, x)
    assert m.release_detected and m.t_release == pytest.approx(p["t_rel"], abs=1e-12)
    assert m.baseline == pytest.approx(p["x0"], rel=1e-12)
    assert m.peak == pytest.approx(p["A"], rel=1e-9)  # signed
    assert m.peak_abs == pytest.approx(abs(p["A"]), rel=1e-9)
    assert m.peak_time == pytest.approx(p["T"], abs=1e-9)
    # |x - x0| = 0.05 |A| after the peak: s exp(1 - s) = 0.05  ->  s = -W_{-1}(-0.05 / e)
    s = -lambertw(-0.05 / np.e, k=-1).real
    assert m.settled
    assert 0 <= m.settling_time - s * p["T"] <= 1 / p["fs"] + 1e-12
    assert m.final == pytest.approx(p["x0"], abs=1e-12)
    d = m.to_dict()
    json.dumps(d)
    assert d["settling_time_s"] == m.settling_time and d["peak_m"] == m.peak


def test_ropesnap_release_detected_in_noise():
    t, x, p = _pulse_log(noise=2e-9)
    m = ropesnap_metrics(t, x)
    assert abs(m.t_release - p["t_rel"]) < 2e-3
    assert m.peak == pytest.approx(p["A"], rel=0.01)
    given = ropesnap_metrics(t, x, t_release=p["t_rel"])
    assert not given.release_detected and given.t_release == p["t_rel"]
    assert given.baseline == pytest.approx(p["x0"], abs=1e-9)


def test_ropesnap_damped_modes_asd_and_settling():
    fs, t_rel = 5000.0, 0.4
    t = np.arange(int(4.4 * fs)) / fs
    tau = np.clip(t - t_rel, 0.0, None)
    zeta = 0.05
    w1, w2 = 2 * np.pi * 43.0, 2 * np.pi * 160.0
    s1, s2 = zeta * w1, zeta * w2
    wd1, wd2 = w1 * np.sqrt(1 - zeta**2), w2 * np.sqrt(1 - zeta**2)
    mode1 = 5e-6 * np.exp(-s1 * tau) * np.sin(wd1 * tau)
    mode2 = 1e-6 * np.exp(-s2 * tau) * np.sin(wd2 * tau)
    m = ropesnap_metrics(t, mode1 + mode2)
    df = m.asd_freq_hz[1]
    # a damped mode's displacement ASD peaks at sqrt(wd^2 - s^2) = w sqrt(1 - 2 zeta^2)
    for peak, w in zip(m.peaks[:2], (w1, w2), strict=True):
        assert abs(peak.freq_hz - w * np.sqrt(1 - 2 * zeta**2) / (2 * np.pi)) <= df
    assert len(m.peaks) >= 2 and m.peaks[0].level > m.peaks[1].level

    # single mode: settling found by brute force on a 50x finer analytic grid (independent of the code)
    single = 5e-6 * np.exp(-s1 * tau) * np.sin(wd1 * tau)
    m1 = ropesnap_metrics(t, single)
    tp = np.arctan(wd1 / s1) / wd1
    assert m1.peak == pytest.approx(5e-6 * np.exp(-s1 * tp) * np.sin(wd1 * tp), rel=1e-3)
    fine = np.arange(0, 4.0, 1 / (50 * fs))
    resp = 5e-6 * np.exp(-s1 * fine) * np.sin(wd1 * fine)
    t_settle = fine[np.flatnonzero(np.abs(resp) >= 0.05 * abs(m1.peak))[-1]]
    assert abs(m1.settling_time - t_settle) <= 1 / fs


def test_ropesnap_never_settles():
    t = np.arange(20000) * 1e-4
    x = np.where(t < 0.3, 0.0, 1e-6 * np.sin(2 * np.pi * 20 * (t - 0.3)))
    m = ropesnap_metrics(t, x)
    assert m.settling_time is None and not m.settled
    assert m.to_dict()["settling_time_s"] is None


# -------------------------------------------------------------------------------------------- contouring
def test_contour_error_diamond_by_hand():
    xr = np.array([1.0, 0.0, -1.0, 0.0, 1.0])  # counter-clockwise diamond, side sqrt(2)
    yr = np.array([0.0, 1.0, 0.0, -1.0, 0.0])
    d = 1e-6
    n = np.array([[1, 1], [-1, 1], [-1, -1], [1, -1]]) / np.sqrt(2)  # outward normals
    mid = np.array([[0.5, 0.5], [-0.5, 0.5], [-0.5, -0.5], [0.5, -0.5]])
    pts = np.vstack([mid + d * n, mid - 2 * d * n, [[1.0 + 3e-6, 0.0]]])  # outside, inside, past a corner
    c = contour_error(xr, yr, pts[:, 0], pts[:, 1], chunk_elements=3)
    # outside of a counter-clockwise path is to the right: negative
    np.testing.assert_allclose(c.distance, [-d] * 4 + [2 * d] * 4 + [-3e-6], rtol=1e-6, atol=1e-15)
    np.testing.assert_array_equal(c.segment[:8], [0, 1, 2, 3] * 2)
    assert c.max_abs == pytest.approx(3e-6, rel=1e-6)
    assert c.rms == pytest.approx(np.sqrt((4 + 16 + 9) / 9) * 1e-6, rel=1e-6)
    big = contour_error(xr, yr, pts[:, 0], pts[:, 1])
    np.testing.assert_allclose(big.distance, c.distance, rtol=0, atol=1e-18)


def test_contour_error_circle():
    r0, n_ref = 0.1, 3600
    a = np.linspace(0, 2 * np.pi, n_ref + 1)
    th = np.linspace(0, 2 * np.pi, 1000, endpoint=False) + 1e-3
    delta = 2e-6 * np.sin(3 * th)
    c = contour_error(r0 * np.cos(a), r0 * np.sin(a), (r0 + delta) * np.cos(th), (r0 + delta) * np.sin(th))
    chord_sag = r0 * (1 - np.cos(np.pi / n_ref))  # polyline lies at most this far inside the circle
    np.testing.assert_allclose(-c.distance, delta, atol=chord_sag + 1e-12)
    assert c.to_dict()["max_m"] == pytest.approx(2e-6, abs=chord_sag + 1e-9)


# ---------------------------------------------------------------------------------------------- bad input
def test_metric_input_errors():
    t = np.arange(100) * 1e-3
    with pytest.raises(DataError, match="error: has 99 samples, expected 100"):
        tracking_metrics(t, np.zeros(99))
    with pytest.raises(DataError, match="strictly increasing"):
        tracking_metrics(t[::-1], np.zeros(100))
    tt = t.copy()
    tt[50:] += 0.5e-3
    with pytest.raises(DataError, match="uniformly sampled"):
        tracking_metrics(tt, np.ones(100))
    with pytest.raises(UsageError, match="v_tol"):
        tracking_metrics(t, np.zeros(100), vel=np.ones(100), v_tol=2.0)
    with pytest.raises(DataError, match="never departs"):
        ropesnap_metrics(t, np.ones(100))
    with pytest.raises(UsageError, match="settle_fraction"):
        ropesnap_metrics(t, np.r_[np.zeros(50), np.ones(50)], settle_fraction=0.0)
    with pytest.raises(UsageError, match="t_release"):
        ropesnap_metrics(t, np.r_[np.zeros(50), np.ones(50)], t_release=5.0)
    with pytest.raises(DataError, match="NaN"):
        contour_error([0, 1], [0, 0], [0.5, np.nan], [0.0, 0.0])
    with pytest.raises(DataError, match="coincide"):
        contour_error([1, 1], [2, 2], [0.5], [0.0])
