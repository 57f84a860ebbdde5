"""Constrained FRF identification of the gantry (eq. 4.5-4.16) and the mass-distribution fits.

Synthetic measurements are built from THESIS_GANTRY (eq. 4.16), the ground truth the fits must recover.
"""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest

from feedtune.errors import DataError, IllConditionedError, UsageError
from feedtune.frf import Frf
from feedtune.identify.gantry import (
    fit_gantry,
    fit_gantry_frf,
    gantry_constraints,
    gantry_regressor,
)
from feedtune.identify.mass import fit_axis_mass, fit_mass_distribution
from feedtune.log import Log
from feedtune.models.gantry import THESIS_GANTRY, GantryModelAtX

T = THESIS_GANTRY
XS = (-0.15, 0.0, 0.15)
FREQ = np.arange(5.0, 400.0, 0.25)


def _noisy_frf(x: float, rng: np.random.Generator, level: float = 0.02, model=T) -> Frf:
    G = model.frequency_response(FREQ, x)
    noise = level * (rng.standard_normal(G.shape) + 1j * rng.standard_normal(G.shape)) / np.sqrt(2)
    return Frf(FREQ, G * (1 + noise), ("y1", "y2"), ("u1", "u2"), output_unit="m")


@pytest.fixture(scope="module")
def noisy_frfs() -> list[Frf]:
    rng = np.random.default_rng(20240611)
    return [_noisy_frf(x, rng) for x in XS]


def _theta_true(x: float) -> np.ndarray:
    at = T.at(x)
    return np.concatenate([[m[0, 0], m[0, 1], m[1, 1]] for m in (at.M, at.C, at.K)])


# ------------------------------------------------------------------------ regressor and constraints
@pytest.mark.parametrize("x", XS)
def test_rebuilt_regressor_and_constraints_hold_for_the_true_model(x):
    G = T.frequency_response(FREQ, x)
    Phi, Y = gantry_regressor(FREQ, G)
    assert Phi.shape == (8 * FREQ.size, 9)
    theta = _theta_true(x)
    np.testing.assert_allclose(Phi @ theta, Y, atol=1e-9)
    Lc, xi = gantry_constraints(T.side_masses(x))
    np.testing.assert_allclose(Lc @ theta, xi, atol=1e-9 * np.abs(theta).max())
    assert np.linalg.matrix_rank(Lc) == Lc.shape[0] == 6


def test_noise_free_fit_without_mass_constraint_is_exact():
    fit = fit_gantry_frf(T.frf(FREQ, 0.15), x=0.15, L=T.L)
    p = fit.physical
    assert (p.m, p.J, p.alpha1, p.c, p.k) == pytest.approx(
        (2.722, T.inertia(0.15), T.alpha(0.15)[0], 18.17, 159.2e3), rel=1e-9)


# ----------------------------------------------------------------------------- noisy fits at each x
@pytest.mark.parametrize("i", range(3))
def test_constrained_fit_recovers_truth_within_3_percent(noisy_frfs, i):
    x = XS[i]
    fit = fit_gantry_frf(noisy_frfs[i], x=x, L=T.L, mass_distribution=T.side_masses(x))
    p = fit.physical
    assert p.J == pytest.approx(T.inertia(x), rel=0.03)
    assert p.c == pytest.approx(18.17, rel=0.03)
    assert p.k == pytest.approx(159.2e3, rel=0.03)
    assert p.m == pytest.approx(2.722, rel=0.03)
    assert p.alpha1 == pytest.approx(T.alpha(x)[0], rel=0.03)
    np.testing.assert_allclose(fit.M, T.at(x).M, rtol=0.03)
    truth = T.yaw_mode(x)
    assert fit.yaw_mode.freq_hz == pytest.approx(truth.freq_hz, rel=0.03)
    assert fit.yaw_mode.zeta == pytest.approx(truth.zeta, rel=0.03)
    assert fit.constraint_residual < 1e-9
    assert fit.kkt_condition < 1e6
    # default band: 0.6 f_yaw .. 1.6 f_yaw (no further resonance in this FRF)
    assert fit.band_hz[0] == pytest.approx(0.6 * truth.freq_hz, rel=0.02)
    assert fit.band_hz[1] == pytest.approx(1.6 * truth.freq_hz, rel=0.02)
    # the 2 % noise is what remains
    assert all(0.015 < e < 0.025 for e in fit.fit_error.values())
    json.dumps(fit.to_dict(), allow_nan=False)


def test_kkt_and_cvxpy_solutions_agree(noisy_frfs):
    kw = dict(x=0.0, L=T.L, mass_distribution=T.side_masses(0.0))
    plain = fit_gantry_frf(noisy_frfs[1], **kw)
    bounded = fit_gantry_frf(noisy_frfs[1], bounds=True, **kw)
    assert bounded.kkt_cvxpy_agreement < 1e-4
    for name, value in plain.theta.items():
        assert bounded.theta[name] == pytest.approx(value, rel=1e-4)
    assert bounded.constraint_residual < 1e-9


def test_bounds_clip_non_physical_negative_damping():
    neg = T.at(0.0)
    model = GantryModelAtX(x=0.0, M=neg.M, C=-neg.C, K=neg.K, L=T.L)  # c = -18.17: unstable, non-physical
    frf = model.frf(FREQ)
    kw = dict(x=0.0, L=T.L, mass_distribution=T.side_masses(0.0), band_hz=(60.0, 150.0))
    with pytest.raises(IllConditionedError, match="not physical"):
        fit_gantry_frf(frf, **kw)
    bounded = fit_gantry_frf(frf, bounds=True, **kw)
    assert abs(bounded.physical.c) < 1e-6 * 18.17
    assert bounded.kkt_cvxpy_agreement > 0.5


# --------------------------------------------------------------------------------- across positions
def test_fit_gantry_recovers_eq_4_16_within_5_percent(noisy_frfs):
    fit = fit_gantry(noisy_frfs, XS, L=T.L, mass_distribution=T)
    m = fit.model
    for name, truth in (("J0", 0.4342), ("d", 0.1655), ("m_x", 0.6977), ("c", 18.17), ("k", 159.2e3),
                        ("m", 2.722)):
        assert getattr(m, name) == pytest.approx(truth, rel=0.05), name
    assert m.dalpha1_dx == pytest.approx(T.dalpha1_dx, rel=1e-9)
    assert round(m.yaw_mode(0.0).freq_hz) == 94
    assert [d["x"] for d in fit.yaw_modes()] == list(XS)
    json.dumps(fit.to_dict(), allow_nan=False)


def test_fit_gantry_with_known_table_mass(noisy_frfs):
    fit = fit_gantry(noisy_frfs, XS, L=T.L, mass_distribution=[T.side_masses(x) for x in XS], m_x=0.6977)
    assert fit.m_x_given and fit.model.m_x == 0.6977
    assert fit.model.J0 == pytest.approx(0.4342, rel=0.01)
    assert fit.model.d == pytest.approx(0.1655, rel=0.05)


def test_default_band_stops_below_unmodelled_modes():
    """Machine-like FRF: pitch 216 Hz, 320 Hz, bending 382 Hz (thesis §4.3.3), acceleration in mm/s^2."""
    rng = np.random.default_rng(7)
    f = np.arange(2.0, 600.0, 0.5)
    s = 2j * np.pi * f
    G = T.frequency_response(f, 0.0)
    for fn, zeta, shape, gain in ((216, 0.02, [1, 1], 0.3), (320, 0.015, [1, -0.3], 0.4),
                                  (382, 0.01, [1, -1], 0.5)):
        w = 2 * np.pi * fn
        G = G + gain / T.m * np.outer(shape, shape)[:, :, None] / (s**2 + 2 * zeta * w * s + w**2)
    G = G * (1 + 0.02 * (rng.standard_normal(G.shape) + 1j * rng.standard_normal(G.shape)) / np.sqrt(2))
    acc_mm = Frf(f, 1e3 * G * s**2, ("y1", "y2"), ("u1", "u2"), "acceleration", output_unit="mm")
    fit = fit_gantry_frf(acc_mm, x=0.0, L=T.L, mass_distribution=T.side_masses(0.0))
    assert fit.band_hz[0] == pytest.approx(0.6 * 94.3, rel=0.02)
    assert fit.band_hz[1] < 150.0  # sqrt(94 * 216) = 143 Hz
    assert fit.physical.J == pytest.approx(T.inertia(0.0), rel=0.03)
    assert fit.physical.k == pytest.approx(159.2e3, rel=0.03)
    assert fit.physical.c == pytest.approx(18.17, rel=0.05)


# --------------------------------------------------------------------------------------- bad input
def test_wrong_channels(noisy_frfs):
    f = noisy_frfs[0]
    renamed = Frf(f.freq_hz, f.response, ("x1", "x2"), ("u1", "u2"), output_unit="m")
    with pytest.raises(DataError, match="no channel 'y1/u1'"):
        fit_gantry_frf(renamed, x=0.0, L=T.L)
    siso = Frf(f.freq_hz, f.response[:1, :1], ("y1",), ("u1",), output_unit="m")
    with pytest.raises(DataError, match="no channel 'y1/u2'"):
        fit_gantry_frf(siso, x=0.0, L=T.L)
    rad = Frf(f.freq_hz, f.response, ("y1", "y2"), ("u1", "u2"), output_unit="rad")
    with pytest.raises(DataError, match="lengths"):
        fit_gantry_frf(rad, x=0.0, L=T.L)


def test_fewer_than_three_positions(noisy_frfs):
    with pytest.raises(UsageError, match=">= 3 distinct"):
        fit_gantry(noisy_frfs[:2], XS[:2], L=T.L)
    with pytest.raises(UsageError, match=">= 3 distinct"):
        fit_gantry(noisy_frfs, (0.0, 0.0, 0.15), L=T.L)
    with pytest.raises(UsageError, match="one position per FRF"):
        fit_gantry(noisy_frfs, XS[:2], L=T.L)


@pytest.mark.parametrize("band", [(10.0, 50.0), (110.0, 200.0)])
def test_band_without_yaw_mode(noisy_frfs, band):
    with pytest.raises(DataError, match="does not contain the yaw mode"):
        fit_gantry_frf(noisy_frfs[1], x=0.0, L=T.L, band_hz=band)


def test_bad_parameters(noisy_frfs):
    with pytest.raises(UsageError, match="band_hz"):
        fit_gantry_frf(noisy_frfs[1], x=0.0, L=T.L, band_hz=(150.0, 60.0))
    with pytest.raises(UsageError, match="mass_distribution"):
        fit_gantry_frf(noisy_frfs[1], x=0.0, L=T.L, mass_distribution=(1.0, -1.0))
    with pytest.raises(DataError, match="only 4 frequencies"):
        fit_gantry_frf(noisy_frfs[1], x=0.0, L=T.L, band_hz=(94.0, 94.9))
    with pytest.raises(UsageError, match="span L"):
        fit_gantry_frf(noisy_frfs[1], x=0.0, L=0.0)


# ------------------------------------------------------------------------------- mass from logs
def _tracking_log(m1: float, m2: float, rng: np.random.Generator, viscous: float = 0.0) -> Log:
    t = np.arange(0.0, 2.0, 1e-3)
    acc = 3.0 * np.sin(2 * np.pi * 2.0 * t) + 1.5 * np.sin(2 * np.pi * 7.0 * t + 0.4)
    vel = -3.0 / (2 * np.pi * 2.0) * np.cos(2 * np.pi * 2.0 * t) \
        - 1.5 / (2 * np.pi * 7.0) * np.cos(2 * np.pi * 7.0 * t + 0.4)
    noise = 0.02 * rng.standard_normal((2, t.size))
    u1 = m1 * acc + viscous * vel + 0.05 + noise[0]
    u2 = m2 * acc + viscous * vel - 0.03 + noise[1]
    return Log(t, {"u1": u1, "u2": u2, "a_ref": acc, "v_ref": vel},
               {"u1": "V", "u2": "V", "a_ref": "m/s^2", "v_ref": "m/s"})


def _alpha1_truth(x: float) -> float:
    return 0.56 - 0.17 * x


@pytest.mark.parametrize("viscous", [0.0, 0.8])
def test_mass_distribution_recovered_within_1_percent(viscous):
    rng = np.random.default_rng(11)
    logs = [_tracking_log(2.722 * _alpha1_truth(x), 2.722 * (1 - _alpha1_truth(x)), rng, viscous) for x in XS]
    fit = fit_mass_distribution(logs, XS, vel_ref="v_ref" if viscous else None)
    assert fit.m == pytest.approx(2.722, rel=0.01)
    for x in (-0.2, 0.0, 0.1, 0.2):
        assert fit.alpha(x)[0] == pytest.approx(_alpha1_truth(x), rel=0.01)
    assert fit.dalpha1_dx == pytest.approx(-0.17, rel=0.05)
    if viscous:
        assert fit.positions[0].viscous1 == pytest.approx(0.8, rel=0.05)
    json.dumps(fit.to_dict(), allow_nan=False)


def test_mass_fit_feeds_gantry_fit(noisy_frfs):
    rng = np.random.default_rng(5)
    logs = [_tracking_log(*T.side_masses(x), rng) for x in XS]
    masses = fit_mass_distribution(logs, XS)
    fit = fit_gantry(noisy_frfs, XS, L=T.L, mass_distribution=masses)
    assert fit.model.m == pytest.approx(2.722, rel=0.01)
    assert fit.model.k == pytest.approx(159.2e3, rel=0.03)


def test_axis_mass():
    rng = np.random.default_rng(3)
    log = _tracking_log(0.6977, 0.0, rng)
    log = Log(log.t, {"u": log["u1"], "a_ref": log["a_ref"]}, {"u": "V", "a_ref": "m/s^2"})
    assert fit_axis_mass(log) == pytest.approx(0.6977, rel=0.01)
    mm = Log(log.t, {"u": log["u"], "a": 1e3 * log["a_ref"]}, {"u": "V", "a": "mm/s^2"})
    assert fit_axis_mass(mm, acc_ref="a") == pytest.approx(0.6977, rel=0.01)


def test_mass_fit_bad_logs():
    rng = np.random.default_rng(1)
    log = _tracking_log(1.0, 1.0, rng)
    still = log.with_signals({"a_ref": np.zeros(log.n)})
    with pytest.raises(IllConditionedError, match="a_ref"):
        fit_axis_mass(still, u="u1")
    with pytest.raises(IllConditionedError, match="ill-conditioned"):
        collinear = log.with_signals({"v_ref": 2 * log["a_ref"]})
        fit_mass_distribution([log, collinear], (0.0, 0.1), vel_ref="v_ref")
    with pytest.raises(DataError, match="no signal 'acc'"):
        fit_mass_distribution([log, log], (0.0, 0.1), acc_ref="acc")
    with pytest.raises(UsageError, match=">= 2 distinct"):
        fit_mass_distribution([log, log], (0.0, 0.0))
    with pytest.raises(DataError, match="unit"):
        fit_axis_mass(dataclasses.replace(log, units={**log.units, "a_ref": "rad/s^2"}), u="u1")
