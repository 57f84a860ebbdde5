"""Rigid fits that never contradict their loader: physical signs, one direction with standstill samples, one speed.

The logs are exact solutions of ``J w' = u - B w - Fc sign(w) - offset`` under piecewise-constant commands (and a
sticking axis at rest), not the fitting code; the ODrive steps are compared with the authors' own step method.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from feedtune.identify.rigid import fit_rigid
from feedtune.log import Log

J, B, FC, OFFSET = 1.2e-4, 7.0e-5, 0.03, 0.005  # N*m/(rad/s^2), N*m/(rad/s), N*m, N*m


def _steps(levels, t_steps, *, seconds: float = 20.0, fs: float = 1000.0, quant: float = 2 * np.pi / 10000.0,
           noise: float = 2e-4, seed: int = 0, inertia: float = J) -> Log:
    """A motor at rest, then torque steps to ``levels`` at ``t_steps`` [s] (all moving forward): exact first-order
    response per segment (``w_ss = (u - Fc - offset) / B``, ``tau = J / B``), position integrated in closed form and
    quantized to a 10000-count encoder, measured torque with white noise."""
    t = np.arange(round(seconds * fs)) / fs
    u = np.zeros_like(t)
    w = np.zeros_like(t)
    x = np.zeros_like(t)
    tau = inertia / B
    w0, x0 = 0.0, 0.0
    bounds = [*t_steps, seconds]
    for level, t0, t1 in zip(levels, t_steps, bounds[1:], strict=True):
        seg = (t >= t0) & (t < t1)
        s = t[seg] - t0
        w_ss = (level - FC - OFFSET) / B
        w[seg] = w_ss + (w0 - w_ss) * np.exp(-s / tau)
        x[seg] = x0 + w_ss * s + (w0 - w_ss) * tau * (1.0 - np.exp(-s / tau))
        u[seg] = level
        d = t1 - t0
        w0, x0 = w_ss + (w0 - w_ss) * np.exp(-d / tau), x0 + w_ss * d + (w0 - w_ss) * tau * (1.0 - np.exp(-d / tau))
    rng = np.random.default_rng(seed)
    return Log(t, {"x": np.round(x / quant) * quant, "u": u + rng.normal(0.0, noise, t.size)},
               {"x": "rad", "u": "N*m"}, {"source": "step simulation"})


def test_a_forward_step_run_with_standstill_is_one_direction_and_fits_its_constant():
    """Rest for 2 s (sticking: static friction holds the zero command), a step to 0.05 N*m, another to 0.065 N*m:
    before, the filter's ringing around the first step gave a few dq < 0 samples and the standstill samples (sign 0)
    made it a two-way fit whose Coulomb/offset split rested on them."""
    fit = fit_rigid(_steps([0.05, 0.065], [2.0, 11.0]), force="u", position="x")
    assert fit.to_dict()["model"] == "rigid-one-direction"
    assert fit.values["mass"] == pytest.approx(J, rel=0.03)
    assert fit.values["viscous"] == pytest.approx(B, rel=0.01)
    assert fit.values["constant"] == pytest.approx(FC + OFFSET, rel=0.02)
    [note] = [w for w in fit.warnings if "one direction" in w]
    assert "stand still" in note and "the split would rest on the" in note and "standstill samples" in note


def test_one_speed_fits_the_step_methods_linear_model_and_says_so():
    """One step from rest to one speed (time constant 20 ms, as a motor driven in voltage mode): viscous friction and
    the constant are not separable; the fit is ``u = J a + B' v`` with ``B' = u / w_ss = B + (Fc + offset) / w_ss``
    (what a step-response method reports)."""
    level = 0.05
    log = _steps([level], [2.0], seconds=8.0, inertia=0.02 * B)
    fit = fit_rigid(log, force="u", position="x")
    w_ss = (level - FC - OFFSET) / B
    assert fit.to_dict()["model"] == "rigid-one-speed" and set(fit.values) == {"mass", "viscous"}
    assert fit.values["viscous"] == pytest.approx(level / w_ss, rel=0.005)
    assert fit.model.coulomb_pos == 0.0 and fit.model.offset == 0.0
    assert any("hold one speed" in w and "constant taken as 0" in w for w in fit.warnings)


def _sines(coulomb: float, *, noise: float = 0.05, seed: int = 1) -> Log:
    """A two-way sum of sines (inverse dynamics, exact derivatives) with a Coulomb level ``coulomb`` [N]."""
    t = np.arange(20000) / 1000.0
    w = 2 * np.pi * np.array([0.15, 0.4, 1.1])
    amp = np.array([0.08, 0.02, 0.004])
    x = (amp[:, None] * np.sin(w[:, None] * t)).sum(0)
    v = (amp[:, None] * w[:, None] * np.cos(w[:, None] * t)).sum(0)
    a = -(amp[:, None] * w[:, None] ** 2 * np.sin(w[:, None] * t)).sum(0)
    u = 20.0 * a + 50.0 * v + coulomb * np.sign(v) + np.random.default_rng(seed).normal(0.0, noise, t.size)
    return Log(t, {"x": x, "u": u}, {"x": "m", "u": "N"}, {"source": "sines"})


def test_a_negative_coulomb_level_is_held_at_zero_and_the_file_loads(tmp_path, capsys, monkeypatch):
    from cli_run import run

    from feedtune.io import load_model, write_log_csv

    log = _sines(-2.0)  # unphysical on purpose: a fit that follows the data would write coulomb < 0
    for asymmetric, names in ((False, ("coulomb",)), (True, ("coulomb_pos", "coulomb_neg"))):
        fit = fit_rigid(log, force="u", position="x", asymmetric=asymmetric, cutoff_hz=20.0)
        for name in names:
            assert fit.values[name] == 0.0 and fit.to_dict()["std"][name] is None
            assert fit.on_bound[name]["unconstrained"] == pytest.approx(-2.0, rel=0.05)
            assert any(w.startswith(f"{name} came out -") and "more than 3 std below it" in w for w in fit.warnings)
        assert fit.values["mass"] == pytest.approx(20.0, rel=0.02)
        json.dumps(fit.to_dict(), allow_nan=False)
    # the command line writes a model its loader takes (before: exit 0, then "params.coulomb_pos: must be >= 0")
    path, out = tmp_path / "sines.csv", tmp_path / "rigid.toml"
    write_log_csv(log, path)
    code, text, err = run(["identify", "rigid", path, "--lpf-hz", "20", "--asymmetric", "--out", out], capsys,
                          monkeypatch)
    assert code == 0, err
    assert "coulomb_pos  = 0 N  (at its lower bound)" in text
    model = load_model(out)
    assert model.coulomb_pos == 0.0 and model.coulomb_negative == 0.0
    # a physical log is not touched: ordinary least squares as published
    fit = fit_rigid(_sines(3.0), force="u", position="x", cutoff_hz=20.0)
    assert fit.on_bound == {} and fit.values["coulomb"] == pytest.approx(3.0, rel=0.02)


# ------------------------------------------------------------------------------------------ ODrive steps
def _odrive(path) -> Log:
    """An ODrive log read by hand, as the authors' script reads it: ``%`` lines are comments, rows end in ``;``,
    rows with a NaN or a timestep below 1 are dropped; time = timestep / 8000 s, position turns -> rad. The rows
    come at irregular USB intervals: linearly interpolated onto their median interval."""
    rows = [[float(x) for x in line.strip().rstrip(";").split(",")]
            for line in path.read_text().splitlines() if line.strip() and not line.startswith("%")]
    a = np.array(rows)
    a = a[np.all(np.isfinite(a), axis=1) & (a[:, 0] >= 1)]
    t, volts, turns = a[:, 0] / 8000.0, a[:, 1], a[:, 2]
    dt = float(np.median(np.diff(t)))
    grid = t[0] + dt * np.arange(int((t[-1] - t[0]) / dt))
    return Log(grid, {"u": np.interp(grid, t, volts), "x": np.interp(grid, t, turns * 2 * np.pi)},
               {"u": "V", "x": "rad"}, {"source": path.name})


def _authors_step_method(path) -> float:
    """motorDataVisualize.m, section 2: the steady-state velocity is the mean of the logged velocity after
    ``settleTime = 2.02 s``; the 0.25 V step over it is the viscous coefficient [V/(rad/s)] of ``G = b/(s (s + a))``
    (``a / b``)."""
    rows = [[float(x) for x in line.strip().rstrip(";").split(",")]
            for line in path.read_text().splitlines() if line.strip() and not line.startswith("%")]
    a = np.array(rows)
    a = a[np.all(np.isfinite(a), axis=1) & (a[:, 0] >= 1)]
    t, volts, velocity = a[:, 0] / 8000.0, a[:, 1], a[:, 3] * 2 * np.pi
    step = float(volts[t > 2.02].mean() - volts[t < 2.0].mean())
    return step / float(velocity[t > 2.02].mean())


def test_odrive_steps_viscous_coefficient_matches_the_authors_step_method(real_data_dir):
    folder = real_data_dir / "odrive_motor_characterization"
    files = [folder / f"step{k}.csv" for k in (1, 2, 3)]
    if not all(p.is_file() for p in files):
        pytest.skip("odrive_motor_characterization not present")
    reference = np.mean([_authors_step_method(p) for p in files])
    assert reference == pytest.approx(0.0088, rel=0.01)  # README / issue 25: about 0.0088 V/(rad/s)
    fit = fit_rigid([_odrive(p) for p in files], force="u", position="x")
    assert fit.values["viscous"] == pytest.approx(reference, rel=0.02)  # measured: 0.05 %
    assert fit.to_dict()["model"] == "rigid-one-speed" and fit.units["viscous"] == "V/(rad/s)"
    assert not any("clipped" in w for w in fit.warnings)  # a 0 -> 0.25 V step sets its levels, it is no saturation
