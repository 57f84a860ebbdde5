"""Drift and forecast of a fleet axis (feedtune/fleet/drift.py, forecast.py) against references that are not the code
under test: the false-alarm rate the CUSUM threshold is designed for, counted on simulated unchanged parameters run
through the whole trend function; numpy's weighted polyfit for the trend line and its covariance; the scatter a
simulation put in; the future plant's FRF computed from its own model; a brute-force scan for the failing week."""

from __future__ import annotations

import datetime
from dataclasses import replace

import numpy as np
import pytest

from feedtune.fleet.drift import DriftSettings, cusum_threshold, pooled_scatter, trend
from feedtune.fleet.forecast import DriftLine, ForecastTask, carried_frf, forecast_axis
from feedtune.fleet.simulated import SimulatedAxis, installed_gains
from feedtune.fleet.snapshot import Snapshot
from feedtune.machines.certificate import certify
from feedtune.models import THESIS_TABLE_3_1


def test_an_unchanged_parameter_alarms_as_often_as_the_threshold_is_designed_for():
    """2000 unchanged parameters (levels 1-1000, fit std and scatter varying per measurement) through trend():
    the share that alarms within the design horizon is the designed false-alarm probability (binomial 4 sigma)."""
    settings = DriftSettings(false_alarm=0.05, horizon=20)
    rng = np.random.default_rng(11)
    runs, n = 2000, settings.baseline + settings.horizon
    alarms = 0
    for _ in range(runs):
        level = 10 ** rng.uniform(0, 3)
        s = level * rng.uniform(0.002, 0.01, n)  # fits' std, different per measurement
        tau = 0.01
        y = level + np.sqrt(s**2 + (tau * level) ** 2) * rng.standard_normal(n)
        alarms += trend("k", np.arange(n) * 1.0, y, s, tau, settings).alarm
    p = settings.false_alarm
    assert abs(alarms / runs - p) < 4 * np.sqrt(p * (1 - p) / runs), alarms / runs


def test_the_threshold_grows_with_the_horizon_and_falls_with_the_false_alarm_probability():
    assert cusum_threshold(0.75, 0.0017, 52) > cusum_threshold(0.75, 0.0017, 12) > cusum_threshold(0.75, 0.05, 12)


@pytest.mark.parametrize(("shape", "seed"), [("step", 5), ("step", 6), ("ramp", 5), ("ramp", 6)])
def test_a_change_is_detected_within_three_measurements_and_dated(shape, seed):
    """Noise 1.5 % (0.4 % of it the fit's): a 9 % step after measurement 6 alarms within 3 measurements; a ramp of
    -2 %/week from measurement 6 on alarms at most 3 measurements after the loss passes 10 % (week 11). The change
    is dated within a measurement of where it began, and the trend's slope holds the ramp's."""
    rng = np.random.default_rng(seed)
    n, onset, sigma = 16, 6, 1.5
    t = np.arange(n, dtype=float)
    change = np.where(t > onset, -6 * sigma if shape == "step" else -2.0 * (t - onset), 0.0)
    y = 100 + change + sigma * rng.standard_normal(n)
    tr = trend("k", t, y, np.full(n, 0.4), np.sqrt(sigma**2 - 0.4**2) / 100)
    assert tr.alarm and tr.direction == -1
    assert onset < tr.alarm_index <= (onset + 3 if shape == "step" else onset + 5 + 3)
    assert abs(tr.since - onset) <= 1
    if shape == "ramp":
        assert abs(tr.slope + 2.0) < 3 * tr.slope_std


def test_the_trend_line_and_its_covariance_are_numpys_weighted_fit():
    rng = np.random.default_rng(3)
    t = np.sort(rng.uniform(0, 20, 12))
    s = rng.uniform(0.5, 2.0, 12)
    y = 50 - 0.8 * t + s * rng.standard_normal(12)
    tr = trend("k", t, y, s, 0.0, DriftSettings(baseline=11))  # no alarm possible: the line over every point
    coef, cov = np.polyfit(t - t[-1], y, 1, w=1 / s, cov="unscaled")
    chi2 = np.sum(((y - np.polyval(coef, t - t[-1])) / s) ** 2) / (t.size - 2)
    cov = cov * max(chi2, 1.0)
    assert tr.slope == pytest.approx(coef[0], rel=1e-10) and tr.level == pytest.approx(coef[1], rel=1e-12)
    assert tr.slope_std == pytest.approx(np.sqrt(cov[0, 0]), rel=1e-9)
    assert tr.level_std == pytest.approx(np.sqrt(cov[1, 1]), rel=1e-9)
    assert tr.cov == pytest.approx(cov[0, 1], rel=1e-9)
    mid, sd = tr.at(-5.0)
    assert mid == pytest.approx(np.polyval(coef, -5.0), rel=1e-10)
    assert sd == pytest.approx(np.sqrt(cov[1, 1] + 25 * cov[0, 0] - 10 * cov[0, 1]), rel=1e-9)


def test_the_pooled_scatter_is_the_simulated_one_with_a_few_drifting_axes():
    rng = np.random.default_rng(8)
    tau, series = 0.015, []
    for i in range(150):
        level = rng.uniform(150, 250)
        t = np.arange(12.0)
        s = np.full(12, 0.004 * level)
        y = level * (1 + tau * rng.standard_normal(12)) + s * rng.standard_normal(12)
        if i % 10 == 0:  # every tenth axis drifts from week 4 on
            y = y * (1 - 0.02 * np.maximum(t - 4, 0))
        series.append((t, y, s))
    est, n = pooled_scatter(series)
    assert n == 150 * 12 and est == pytest.approx(tau, rel=0.12)


# ------------------------------------------------------------------------------------------ the forecast plant
AXIS = SimulatedAxis("M", "X", THESIS_TABLE_3_1, (440.0, 1100.0), 450.0, 0.1, "stiffness", 0.0, 7)


def test_the_carried_frf_is_the_future_plants_own_frf():
    """Measured FRF (torsional modes, current loop) carried from k to 0.8 k: the FRF computed from the model at 0.8 k
    with the same unmodelled dynamics."""
    now, later = AXIS.model, replace(AXIS.model, k=0.8 * AXIS.model.k)
    carried = carried_frf(AXIS.true_frf(0, now), now, later)
    np.testing.assert_allclose(carried.response, AXIS.true_frf(0, later).response, rtol=1e-11, atol=0)


def test_the_forecast_week_is_the_first_failing_week_of_a_brute_force_scan(tmp_path):
    """Noise-free plant, stiffness on an exact line of -2 %/week: the forecast (grid + bisection) against a scan of
    the certificate every 0.05 weeks; the interval holds it and shrinks to it as the line's uncertainty vanishes."""
    from feedtune.io import write_document, write_frf

    doc, _ = installed_gains(AXIS)
    write_document(tmp_path / "gains.toml", doc, json_twin=False)
    write_frf(AXIS.true_frf(0.0), tmp_path / "frf.csv")
    k0 = AXIS.model.k
    fit = {**AXIS.model.params(), "lead_m_per_rad": AXIS.model.lead_m_per_rad, "input_unit": "V"}
    axis = Snapshot("M/X", "key", datetime.datetime(2025, 1, 6), str(tmp_path / "gains.toml"), "gains.toml", None,
                    (str(tmp_path / "frf.csv"),), ("frf.csv",), {}, fit)

    def task(level_std, slope_std):
        return ForecastTask(axis, (DriftLine("k", k0, -0.02 * k0, level_std, slope_std, 0.0),), 40.0)

    def fails(week):
        return not certify(doc, "g", [("f", AXIS.true_frf(week))]).ok

    exact = forecast_axis(task(0.0, 0.0))
    whole = next(w for w in np.arange(1.0, 40.0) if fails(w))  # every week, then every 0.05 week before it
    scan = next(w for w in np.arange(whole - 1.0, whole + 0.01, 0.05) if fails(w))
    assert exact.weeks == pytest.approx(scan, abs=0.06)
    assert exact.early == pytest.approx(exact.weeks, abs=0.06) and exact.late == pytest.approx(exact.weeks, abs=0.06)
    wide = forecast_axis(task(0.01 * k0, 0.002 * k0))
    assert wide.early < exact.weeks < wide.late
    assert wide.weeks == pytest.approx(exact.weeks, abs=0.06)

