"""The joint friction fit on valid closed-loop logs made with the thesis' own law (eq. 2.1): sine, chirp and trapezoid
motions, 0.1 um encoder, command noise (issue 25's acceptance), and a Gaussian-shaped Stribeck curve.

The logs come from a direct simulation of eq. 2.1 under a PID loop (:mod:`friction_sim`), not from the fitting
code; the truth is the simulated axis. Before the masked parallel decimation the joint fit (then followed by a law fit
to the Kalman estimate) refused "sine 1 Hz, heavy" (too few rows after its 14 Hz filter) and missed ds by up to 15 %
and Omega by up to 33 % on "chirp 0.2-2 Hz", "sine 0.5 Hz" and "sine, dip"; the issue's own logs were refused as
"mirrored or sign-inverted".
"""

from __future__ import annotations

import json

import numpy as np
import pytest
from friction_sim import Axis, chirp, simulate, sine, trapezoid

from feedtune.identify.friction import identify_friction
from feedtune.identify.friction_joint import fit_joint_friction

LIGHT = Axis()  # 20 kg, Stribeck peak: ds above dc both ways, Omega 10 mm/s
HEAVY = Axis(mass=95.0, viscous=200.0, dc_pos=20.0, ds_pos=30.0, dc_neg=-18.0, ds_neg=-27.0, omega=0.02)  # EMPS-like
DIP = Axis(ds_pos=8.0, ds_neg=-7.0)  # the static level below the Coulomb level (EMPS, rack and pinion)
DIP_SLOW = Axis(ds_pos=8.0, ds_neg=-7.0, omega=0.015)

CASES = {  # name: (axis, reference, PID bandwidth [Hz])
    "sine 0.5 Hz": (LIGHT, sine(0.05, 0.5, 12.0), 15.0),
    "sine 1 Hz, heavy": (HEAVY, sine(0.03, 1.0, 10.0), 30.0),
    "chirp 0.2-2 Hz": (LIGHT, chirp(0.1, 0.2, 2.0, 20.0), 30.0),
    "chirp 0.1-1.5 Hz, heavy": (HEAVY, chirp(0.15, 0.1, 1.5, 20.0), 15.0),
    "trapezoids": (LIGHT, trapezoid((0.004, 0.01, 0.02, 0.04, 0.08), 0.1, 0.3), 15.0),
    "trapezoids, heavy": (HEAVY, trapezoid((0.005, 0.01, 0.02, 0.05, 0.1, 0.15), 0.3, 0.2), 30.0),
    "sine, dip": (DIP, sine(0.05, 0.5, 12.0), 30.0),
    "trapezoids, dip": (DIP_SLOW, trapezoid((0.004, 0.01, 0.02, 0.04, 0.08), 0.1, 0.3), 15.0),
}
FAST = ("sine 1 Hz, heavy", "chirp 0.2-2 Hz")


def _log(name: str, seed: int = 1):
    axis, reference, bandwidth = CASES[name]
    # 0.1 um encoder (the loop runs on it), command measured with noise of 2 % of the Coulomb level
    return axis, simulate(axis, reference, quant=1e-7, noise_u=0.02 * axis.dc_pos, bandwidth_hz=bandwidth, seed=seed)


def _check(axis: Axis, joint) -> dict[str, float]:
    d = joint.law_fit.directions
    errors = {"mass": joint.mass / axis.mass - 1.0}
    for key, dc, ds in (("pos", axis.dc_pos, axis.ds_pos), ("neg", axis.dc_neg, axis.ds_neg)):
        errors[f"dc_{key}"] = d[key].dc / dc - 1.0
        errors[f"ds_{key}"] = d[key].ds / ds - 1.0
        errors[f"omega_{key}"] = d[key].omega / axis.omega - 1.0
        errors[f"viscous_{key}"] = d[key].viscous / axis.viscous - 1.0
    assert abs(errors["mass"]) < 0.01, errors  # issue 25: mass within 1 %
    assert max(abs(errors[k]) for k in errors if k.startswith(("dc", "ds"))) < 0.03, errors  # dc, ds within 3 %
    assert max(abs(errors[k]) for k in errors if k.startswith("omega")) < 0.10, errors  # Omega within 10 %
    return errors


@pytest.mark.parametrize("name", FAST)
def test_joint_fit_recovers_eq_2_1_on_closed_loop_logs(name):
    axis, log = _log(name)
    result = identify_friction(log, position="x", command="u")
    _check(axis, result.joint_fit)
    f = result.friction  # the joint law with its viscous terms is the model
    assert f.law == "stribeck" and f.viscous_pos == result.joint_fit.law_fit.directions["pos"].viscous
    assert not any("mirrored" in w or "law mismatch" in w or "on its bound" in w for w in result.warnings)
    json.dumps(result.to_dict(), allow_nan=False)


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(CASES))
def test_every_valid_log_is_accepted_and_recovered(name):
    """All 8: measured max errors 1.2 % (dc, ds), 2.6 % (Omega), 0.1 % (mass)."""
    axis, log = _log(name)
    joint = fit_joint_friction(log, position="x", command="u")
    _check(axis, joint)
    dips = [w for w in joint.warnings if w.startswith("dip, not a Stribeck peak")]
    assert bool(dips) == (axis.ds_pos < axis.dc_pos)  # flagged exactly when the static level lies below


def test_a_dip_is_flagged_as_such():
    axis, log = DIP, simulate(DIP, sine(0.05, 0.5, 12.0), quant=1e-7, noise_u=0.24, bandwidth_hz=30.0, seed=2)
    joint = fit_joint_friction(log, position="x", command="u")
    _check(axis, joint)
    assert joint.shapes == {"pos": "dip", "neg": "dip"} and joint.to_dict()["shape"] == {"pos": "dip", "neg": "dip"}
    assert any(w.startswith("dip, not a Stribeck peak (v > 0: ds = 8.0") for w in joint.warnings)


def test_gaussian_stribeck_log_is_accepted_with_a_stated_law_mismatch_or_fitted_by_other_laws():
    """ds 3 N, Omega 0.02 m/s, Gaussian decay exp(-(v/Omega)^2), 1 kHz, 0.1 um encoder (issue 25): the stribeck law is
    accepted (before: refused, ds_pos = -0.667 N) with the mismatch named; the hump law is accepted too; the lugre
    law, whose shape it is, recovers it."""
    axis = Axis(mass=2.0, viscous=10.0, dc_pos=2.0, ds_pos=3.0, dc_neg=-2.0, ds_neg=-3.0, omega=0.02, gaussian=True)
    log = simulate(axis, chirp(0.1, 0.2, 2.0, 20.0), quant=1e-7, noise_u=0.02, bandwidth_hz=30.0, seed=1)
    stribeck = fit_joint_friction(log, position="x", command="u")
    assert stribeck.law_fit.model.sign_problems() == []
    [mismatch] = [w for w in stribeck.warnings if w.startswith("law mismatch")]
    assert "the lugre law fits these samples" in mismatch and "law='lugre'" in mismatch
    assert stribeck.law_rms["lugre"] < 0.5 * stribeck.law_rms["stribeck"]
    hump = fit_joint_friction(log, position="x", command="u", law="hump")
    assert hump.law_fit.model.sign_problems() == [] and hump.mass == pytest.approx(2.0, rel=0.01)
    lugre = fit_joint_friction(log, position="x", command="u", law="lugre")
    d = lugre.law_fit.directions
    assert (d["pos"].dc, d["pos"].ds, d["pos"].omega) == pytest.approx((2.0, 3.0, 0.02), rel=0.01)
    assert (d["neg"].dc, d["neg"].ds, d["neg"].viscous) == pytest.approx((-2.0, -3.0, 10.0), rel=0.01)
    assert not any(w.startswith("law mismatch") for w in lugre.warnings)


def test_poor_identifiability_is_reported_not_blamed_on_the_sign():
    """Only the samples far above Omega (min_speed 5 Omega: the Stribeck term is below 1 % of its step there): the
    static level is not in the data. The fit is accepted, the levels keep their signs, and the warnings say what is
    not identified."""
    axis = LIGHT
    log = simulate(axis, trapezoid((0.06, 0.08, 0.1, 0.12), 0.5, 0.3), quant=1e-7, noise_u=0.24, seed=3)
    joint = fit_joint_friction(log, position="x", command="u", min_speed=0.05)
    assert joint.law_fit.model.sign_problems() == []
    said = " ".join(joint.warnings)
    assert "mirrored" not in said
    assert "static level (" in said and "is not distinguishable from the Coulomb level" in said, said
    assert "vs for v > 0 ended on its bound" in said
    for d, dc in zip(joint.law_fit.directions.values(), (axis.dc_pos, axis.dc_neg), strict=True):
        assert d.dc == pytest.approx(dc, rel=0.03)  # the sliding level is what the data hold


def test_coulomb_viscous_law_on_a_log_without_stribeck_effect():
    axis = Axis(ds_pos=12.0, ds_neg=-10.0)  # ds = dc: no Stribeck effect
    log = simulate(axis, chirp(0.1, 0.2, 2.0, 20.0), quant=1e-7, noise_u=0.24, bandwidth_hz=30.0, seed=4)
    joint = fit_joint_friction(log, position="x", command="u", law="coulomb-viscous")
    d = joint.law_fit.directions
    assert (d["pos"].dc, d["neg"].dc) == pytest.approx((12.0, -10.0), rel=0.01)
    assert (d["pos"].viscous, d["neg"].viscous, joint.mass) == pytest.approx((60.0, 60.0, 20.0), rel=0.01)
    assert np.isnan(d["pos"].omega) and joint.law_fit.model.law == "coulomb-viscous"
    assert not any(w.startswith("law mismatch") for w in joint.warnings)  # no law fits clearly better
