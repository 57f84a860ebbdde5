"""Friction feedforward of the gantry laws (``design gantry|pid --friction``): the ``[friction_feedforward]`` of a
gantry gains file is Stribeck eq. 2.1 with its viscous term (:meth:`FrictionLaw.force`, evaluated here independently) of
the previewed gantry reference's backward-difference velocity [m/s] outside the band and the straight line through zero
inside it, split between the drives as the inertia feedforward splits a rigid acceleration: ``u_i += alpha_i(x) d`` with
``alpha_i m`` the row sums of ``M(x)`` (computed here from the model, clamped at the schedule's ends); its units must be
the gantry model's (command unit, m/s); the command line writes it and ``export c`` exports it.

The runtime, the compiled twin loop and the C header (double and float) are checked against each other for MIMO and
PID designs with friction feedforward in tests/test_gantry_law_consistency.py, tests/test_export_c_kinds.py and
tests/test_export_c_float.py.
"""

from __future__ import annotations

import copy

import numpy as np
import pytest
from test_cli import run

from feedtune.control.filters import FilterPack, LeadStage, Notch
from feedtune.design.gantry_mimo import design_gantry_mimo
from feedtune.design.gantry_pid import design_gantry_pid
from feedtune.errors import DataError, UsageError
from feedtune.io import read_document, save_model
from feedtune.io.gantry_gains import gantry_gains_document
from feedtune.machines import load_runtime
from feedtune.machines.gantry.runtime import GantryRuntime
from feedtune.models.friction import FrictionLaw, StribeckFriction
from feedtune.models.gantry import THESIS_GANTRY
from feedtune.sim.engine import numba_available
from feedtune.sim.trajectory import multi_segment

needs_numba = pytest.mark.skipif(not numba_available(), reason="numba not installed")

FRICTION = FrictionLaw(0.3, 0.5, -0.35, -0.55, 0.01, 0.02, command_unit="V", velocity_unit="m/s", viscous_pos=1.2,
                       viscous_neg=0.9)
"""An asymmetric friction of the moving gantry (both drives together) in the twin's command unit [V] and m/s."""
BAND = 1e-3
"""Linear band of the feedforward [m/s]."""
X_GRID = np.linspace(-0.3, 0.3, 7)
H = FilterPack([Notch(110, 0.5, 0.7), Notch(320, 0.2, 0.9)], 450.0, 2, 0.7, [LeadStage(154.0, 70.0)])
MIMO = design_gantry_mimo(THESIS_GANTRY, filters=H, x_grid=X_GRID)
PID = design_gantry_pid(THESIS_GANTRY, kp=(6e3, 5e3), kd=(40.0, 35.0), ki=(3e4, 2.5e4),
                        filters=FilterPack([], 900.0), x_grid=X_GRID)


def _move(fs: float, dwell: float = 0.05) -> np.ndarray:
    """A y move out and back (0 -> 0.05 -> 0 m, 0.3 m/s) with dwells: starts, stops and both directions [m]."""
    tr = multi_segment([0.0, 0.05, 0.0], v_max=0.3, a_max=3.0, j_max=100.0, fs=fs, dwell=dwell)
    return np.r_[np.full(int(dwell * fs), tr.pos[0]), tr.pos, np.full(int(dwell * fs), tr.pos[-1])]


def _split(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``alpha_1, alpha_2`` at table positions ``x`` [m] from the model: the row sums of ``M(x)`` over their total
    (eq. 4.3), at ``x`` clamped to the schedule's ends (the schedule is clamped)."""
    xc = np.clip(x, X_GRID[0], X_GRID[-1])
    rows = np.array([THESIS_GANTRY.at(v).M.sum(axis=1) for v in xc])
    total = rows.sum(axis=1)
    return rows[:, 0] / total, rows[:, 1] / total


def _expected_friction(v: np.ndarray) -> np.ndarray:
    """``d(v)`` [V]: eq. 2.1 outside +-BAND, ``d(+-BAND) |v| / BAND`` inside."""
    out = np.zeros(v.size)
    outside = np.abs(v) >= BAND
    out[outside] = FRICTION.force(v[outside])
    inside = ~outside
    out[inside] = np.where(v[inside] >= 0, FRICTION.force(BAND), FRICTION.force(-BAND)) * np.abs(v[inside]) / BAND
    return out


# ------------------------------------------------------------------ the feedforward term, evaluated independently
@needs_numba
@pytest.mark.parametrize("design", [MIMO, PID], ids=["mimo", "pid"])
def test_the_feedforward_term_is_the_split_stribeck_force_of_the_reference_velocity(design):
    """The commands with friction feedforward minus the commands without, for the same readings, are
    ``alpha_i(x) d(v_r)``: eq. 2.1 and its viscous term (FrictionLaw.force) outside +-v_band, d(+-v_band) |v_r| /
    v_band inside, with v_r the backward difference of the previewed reference (0 on the first sample) and alpha_i the
    model's row-sum split of M(x). Checked on the per-sample step (the compiled law) and on the vectorised replay,
    with the table moving across the schedule and past both clamped ends."""
    plain = load_runtime(gantry_gains_document(design))
    ff = load_runtime(gantry_gains_document(design.with_friction(FRICTION, v_band=BAND)))
    assert isinstance(ff, GantryRuntime) and ff.friction is not None and plain.friction is None
    y_ref = _move(plain.fs)
    n = y_ref.size
    rng = np.random.default_rng(3)
    y1 = y_ref + 1e-6 * rng.standard_normal(n)
    y2 = y_ref + 1e-6 * rng.standard_normal(n)
    x = 0.4 * np.sin(np.linspace(0.0, 3 * np.pi, n))
    r = plain.previewed(y_ref)
    per_sample = []
    for rt in (plain, ff):
        rt.reset()
        per_sample.append(np.array([rt.step(a, b, c, d) for a, b, c, d in zip(r, y1, y2, x, strict=True)]))
    extra = per_sample[1] - per_sample[0]
    replayed = np.column_stack(ff.replay(y_ref, y1, y2, x)) - np.column_stack(plain.replay(y_ref, y1, y2, x))
    v = np.r_[0.0, np.diff(r)] * plain.fs  # m/s, written out rather than reference_velocity
    d = _expected_friction(v)
    a1, a2 = _split(x)
    expected = np.column_stack([a1 * d, a2 * d])
    for got in (extra, replayed):
        assert np.allclose(got, expected, rtol=1e-9, atol=1e-10)
    # the two shares add up to the friction force, unequally away from the centre
    assert np.allclose(extra.sum(axis=1), d, rtol=1e-9, atol=1e-10)
    assert np.max(np.abs(a1 - a2)) > 0.05
    # the move covers both directions, the Stribeck region, the band (not only at rest) and the rest
    assert np.any(v > 0.2) and np.any(v < -0.2) and np.any((np.abs(v) > BAND) & (np.abs(v) < 0.02))
    assert np.any((np.abs(v) < BAND) & (v != 0)) and np.any(v == 0)
    assert np.array_equal(ff.friction_feedforward(y_ref), ff.friction.command(v))


def test_the_gains_file_section_and_law_text():
    for design in (MIMO, PID):
        doc = gantry_gains_document(design.with_friction(FRICTION))
        sec = doc["friction_feedforward"]
        assert sec["model"] == "stribeck" and sec["ds_neg"] == {"value": -0.55, "unit": "V"}
        assert sec["omega_pos"] == {"value": 0.01, "unit": "m/s"}
        assert sec["v_band"] == {"value": pytest.approx(1e-3), "unit": "m/s"}  # default: 0.1 x the smaller Omega
        assert "alpha1 d" in doc["law"]["execution"] and "friction(v_r)" in doc["law"]["execution"]
        assert "alpha1(x) d" in sec["velocity"] and "previewed gantry reference" in sec["velocity"]
        assert "friction" not in gantry_gains_document(design)["law"]["execution"]
        assert "friction_feedforward" not in gantry_gains_document(design)
        assert load_runtime(doc).to_dict()["friction_feedforward"]["units"]["v_band"] == "m/s"
        # a section in rad/s is not the gantry's (the runtime reads m/s)
        bad = {**doc, "friction_feedforward": {**sec, "omega_pos": {"value": 0.01, "unit": "rad/s"}}}
        with pytest.raises(DataError, match=r"friction_feedforward\.omega_pos"):
            GantryRuntime.from_document(bad)
    assert MIMO.with_friction(FRICTION).with_friction(None).friction is None
    assert PID.with_friction(FRICTION).with_friction(None).friction is None


def test_a_schedule_whose_alpha_is_not_the_mass_split_is_refused_with_friction():
    """The friction is split alpha1 : alpha2; a file whose alpha does not split a force as M(x) does is refused (with
    friction only: without it the PID file's alpha is information)."""
    doc = gantry_gains_document(PID.with_friction(FRICTION))
    bad = copy.deepcopy(doc)
    bad["schedule"]["alpha1"] = [0.5] * len(bad["schedule"]["alpha1"])
    with pytest.raises(DataError, match="alpha1, alpha2 are not the row sums of M"):
        load_runtime(bad)
    del bad["friction_feedforward"]
    load_runtime(bad)


def test_units_must_be_the_gantry_units():
    newton = StribeckFriction(20.0, 25.0, -20.0, -25.0, 0.01, command_unit="N", velocity_unit="m/s")
    with pytest.raises(DataError, match=r"friction levels are in 'N' but .*command is in 'V'"):
        MIMO.with_friction(newton)
    with pytest.raises(DataError, match=r"friction levels are in 'N' but .*command is in 'V'"):
        PID.with_friction(newton)
    rotary = StribeckFriction(0.2, 0.3, -0.2, -0.3, 0.5, command_unit="V", velocity_unit="rad/s")
    with pytest.raises(DataError, match="velocities are in 'rad/s' but the linear axis"):
        MIMO.with_friction(rotary)
    with pytest.raises(UsageError, match="band must be > 0"):
        PID.with_friction(FRICTION, v_band=0.0)


# ------------------------------------------------------------------ the command line
@pytest.mark.parametrize("command", ["gantry", "pid"])
def test_cli_design_gantry_and_pid_with_friction(tmp_path, capsys, monkeypatch, command):
    save_model(tmp_path / "gantry.toml", THESIS_GANTRY)
    save_model(tmp_path / "friction.toml", FRICTION)
    own = (["--kp", "6000,5000", "--kd", "40,35", "--ki", "30000,25000", "--lpf", "900"] if command == "pid"
           else ["--notch", "110,0.5,0.7", "--lpf", "450", "--lead", "154,70"])
    args = ["design", command, tmp_path / "gantry.toml", *own, "--friction", tmp_path / "friction.toml",
            "--friction-band", "0.002", "--out", tmp_path / "g.toml", "--allow-unstable"]
    code, out, err = run(args, capsys, monkeypatch)
    assert code == 0, err
    assert "friction feedforward (eq. 2.1)" in out and "m/s" in out
    doc = read_document(tmp_path / "g.toml")
    assert doc["controller"] == ("pid" if command == "pid" else "mimo")
    assert doc["friction_feedforward"]["v_band"] == {"value": 0.002, "unit": "m/s"}
    rt = load_runtime(doc)
    assert rt.friction.friction.ds_neg == -0.55 and rt.friction.v_band == 0.002
    code, _, err = run(["export", "c", tmp_path / "g.toml", "--allow-unstable"], capsys, monkeypatch)
    assert code == 0, err
    header = (tmp_path / "g.h").read_text()
    assert "FT_FR_V_BAND = 0.002; /* m/s */" in header and "sr[0] * fr" in header and "sr[1] * fr" in header
    code, _, err = run(["export", "c", tmp_path / "g.toml", "--allow-unstable", "--float", "--out",
                        tmp_path / "gf.h"], capsys, monkeypatch)
    assert code == 0, err
    assert "FT_FR_V_BAND = 0.002f;" in (tmp_path / "gf.h").read_text()
    # JSON carries the section
    code, out, err = run([*args[:-3], "--allow-unstable", "--json"], capsys, monkeypatch)
    assert code == 0, err
    assert '"friction_feedforward"' in out
    # a friction model in N for a gantry commanded in V: one line naming both files, nothing written
    save_model(tmp_path / "newton.toml", StribeckFriction(20.0, 25.0, -20.0, -25.0, 0.01, command_unit="N",
                                                          velocity_unit="m/s"))
    bad = list(args)
    bad[bad.index(tmp_path / "friction.toml")] = tmp_path / "newton.toml"
    bad[bad.index(tmp_path / "g.toml")] = tmp_path / "n.toml"
    code, _, err = run(bad, capsys, monkeypatch)
    assert code != 0 and err.count("\n") == 1
    assert "newton.toml" in err and "gantry.toml" in err and "'N'" in err and "'V'" in err
    assert not (tmp_path / "n.toml").exists()
    code, _, err = run(["design", command, tmp_path / "gantry.toml", *own, "--friction-band", "0.001"], capsys,
                       monkeypatch)
    assert code != 0 and "--friction-band needs --friction" in err
