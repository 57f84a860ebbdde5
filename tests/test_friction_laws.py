"""Friction laws (stribeck, hump, lugre, coulomb-viscous), the steady-state plateau method, sign checks and the joint
fit."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from test_identify_friction import MASS, TRUTH, VISCOUS, _simulate

from feedtune.errors import DataError, IllConditionedError, UsageError
from feedtune.identify.friction import identify_friction
from feedtune.identify.friction_curve import (
    PlateauSettings,
    find_plateaus,
    fit_friction_law,
    identify_friction_curve,
)
from feedtune.log import Log
from feedtune.models.friction import LAWS, SHAPED_LAWS, FrictionLaw, StribeckFriction, law_shape

PARAMS = ("dc_pos", "ds_pos", "dc_neg", "ds_neg", "omega_pos", "omega_negative", "viscous_pos", "viscous_negative")
SPEEDS = np.geomspace(0.001, 0.2, 14)  # m/s: plateaus from well below to far above vs


def _truth(law: str) -> FrictionLaw:
    if law == "coulomb-viscous":
        return FrictionLaw.coulomb_viscous(12.0, -10.0, 40.0, 50.0)
    return FrictionLaw(dc_pos=12.0, ds_pos=20.0, dc_neg=-10.0, ds_neg=-17.0, omega_pos=0.01, omega_neg=0.015,
                       law=law, viscous_pos=40.0, viscous_neg=50.0)


def _params(law: str) -> tuple[str, ...]:
    """The parameters a law has (the coulomb-viscous law: no ds, no omega)."""
    return PARAMS if law in SHAPED_LAWS else ("dc_pos", "dc_neg", "viscous_pos", "viscous_negative")


def _plateau_log(truth, *, speeds=SPEEDS, both: bool = True, mass: float = 20.0, fs: float = 1000.0,
                 acc: float = 0.5, hold: float = 0.5, noise: float = 0.05, seed: int = 0) -> Log:
    """Trapezoidal velocity moves (ramp ``acc`` [m/s^2], plateau ``hold`` [s], 0.1 s rest) to every speed, each
    way; command ``F = law(v) + m a + noise``; position quantised to 0.5 um with 0.1 um noise."""
    tb, vb = [0.0], [0.0]
    for v in speeds:
        for sign in (1.0, -1.0) if both else (1.0,):
            ramp, t0 = v / acc, tb[-1]
            tb += [t0 + ramp, t0 + ramp + hold, t0 + 2 * ramp + hold, t0 + 2 * ramp + hold + 0.1]
            vb += [sign * v, sign * v, 0.0, 0.0]
    t = np.arange(0.0, tb[-1] + 0.2, 1.0 / fs)
    v = np.interp(t, tb, vb)
    a = np.gradient(v, 1.0 / fs)
    x = np.concatenate([[0.0], np.cumsum((v[1:] + v[:-1]) / 2.0) / fs])
    rng = np.random.default_rng(seed)
    u = truth.force(v) + mass * a + rng.normal(0.0, noise, t.size)
    x = np.round((x + rng.normal(0.0, 0.1e-6, t.size)) / 0.5e-6) * 0.5e-6
    return Log(t, {"x": x, "u": u}, {"x": "m", "u": "N"}, {"source": "plateau simulation"})


def _rel_errors(model, truth, names=PARAMS) -> dict[str, float]:
    return {n: getattr(model, n) / getattr(truth, n) - 1.0 for n in names}


# ------------------------------------------------------------------------------------------ the laws
def test_laws_by_hand():
    v = np.array([0.02, 0.0, -0.03, 0.005])
    cv = _truth("coulomb-viscous")
    assert cv.force(v) == pytest.approx([12.0 + 40.0 * 0.02, 0.0, -10.0 - 50.0 * 0.03, 12.0 + 40.0 * 0.005], rel=1e-14)
    assert cv.to_dict()["formula"] == "F = sign(v) Fc + Fv v" and "ds_pos" not in cv.to_dict()
    with pytest.raises(DataError, match="coulomb-viscous friction law has no static level"):
        FrictionLaw(12.0, 20.0, -10.0, -10.0, omega_pos=0.01, law="coulomb-viscous")
    for law in SHAPED_LAWS:
        f = _truth(law)
        pos = [12.0 + 8.0 * {"stribeck": math.exp(-x), "hump": x * math.exp(1 - x), "lugre": math.exp(-x * x)}[law]
               for x in (0.02 / 0.01, 0.005 / 0.01)]
        neg = -10.0 - 7.0 * {"stribeck": math.exp(-2.0), "hump": 2.0 * math.exp(-1.0), "lugre": math.exp(-4.0)}[law]
        expected = [pos[0] + 40.0 * 0.02, 0.0, neg + 50.0 * -0.03, pos[1] + 40.0 * 0.005]
        assert f.force(v) == pytest.approx(expected, rel=1e-12), law
    # the author's hump law F = Fv v + Fc + v (Fmax - Fc) e / vs exp(-v / vs): its peak Fmax (+ Fv vs) at v = vs
    hump = _truth("hump")
    vv = np.linspace(0.001, 0.1, 7)
    author = 40.0 * vv + 12.0 + vv * (20.0 - 12.0) * math.e / 0.01 * np.exp(-vv / 0.01)
    assert hump.force(vv) == pytest.approx(author, rel=1e-12)
    assert hump.force(-vv) == pytest.approx(-10.0 - 7.0 * law_shape("hump", vv / 0.015) - 50.0 * vv, rel=1e-12)
    # the stribeck law without viscous friction is eq. 2.1 itself
    plain = FrictionLaw(12.0, 20.0, -10.0, -17.0, omega_pos=0.008)
    assert plain.force(vv) == pytest.approx(TRUTH.force(vv), rel=1e-14)
    assert plain.without_viscous() == TRUTH and type(plain.without_viscous()) is StribeckFriction
    d = hump.to_dict()
    json.dumps(d, allow_nan=False)
    assert d["model"] == "hump" and d["units"]["viscous_pos"] == "N/(m/s)" and d["units"]["omega_neg"] == "m/s"
    with pytest.raises(UsageError, match="friction law must be one of stribeck, hump, lugre, coulomb-viscous"):
        FrictionLaw(1.0, 2.0, -1.0, -2.0, omega_pos=0.1, law="dahl")
    assert _truth("stribeck").shapes() == {"pos": "peak", "neg": "peak"}
    assert FrictionLaw(12.0, 8.0, -10.0, -7.0, omega_pos=0.01).shapes() == {"pos": "dip", "neg": "dip"}


def test_sign_problems_name_the_parameter():
    assert TRUTH.sign_problems() == [] and _truth("lugre").sign_problems() == []
    bad = FrictionLaw(12.0, -108.0, 3.0, -17.0, omega_pos=0.01, law="hump", viscous_neg=-1.0)
    names = [n for n, _ in bad.sign_problems()]
    assert names == ["ds_pos", "dc_neg", "viscous_neg"]
    assert "ds_pos = -108 N must be >= 0" in bad.sign_problems()[0][1]


# ------------------------------------------------------------------------------- steady-state method
@pytest.mark.parametrize("law", LAWS)
def test_each_law_recovered_from_a_plateau_log(law):
    truth = _truth(law)
    result = identify_friction_curve(_plateau_log(truth), position="x", command="u", law=law)
    assert len(result.plateaus) == 2 * SPEEDS.size
    errors = _rel_errors(result.friction, truth, _params(law))
    assert max(abs(e) for e in errors.values()) < 0.02, errors  # measured: < 0.1 %
    for d in result.fit.directions.values():
        assert all(np.isfinite(s) and s > 0 for s in d.std.values())
        assert not d.omega_at_bound
    assert result.warnings == ()
    out = result.to_dict()
    json.dumps(out, allow_nan=False)
    assert out["method"] == "steady-state" and out["law"] == law and len(out["points"]) == 2 * SPEEDS.size
    assert len(out["curve"]["pos"]["velocity"]) == len(out["curve"]["neg"]["force"]) == 100
    assert out["curve"]["neg"]["velocity"][0] < 0 and out["units"]["force"] == "N"
    # the points: mean command on each plateau = the law at the plateau's speed
    v = np.array([p["velocity"] for p in out["points"]])
    f = np.array([p["force"] for p in out["points"]])
    assert np.max(np.abs(f - truth.force(v))) < 0.05  # N


def test_plateau_rule_and_settings():
    t = np.arange(3000) / 1000.0
    v = np.where(t < 1.0, 0.01, np.where(t < 2.0, 0.0102, -0.02))  # a 2 % step cuts; standstill is no plateau
    v[(t > 2.4) & (t < 2.5)] = 0.0
    a = np.zeros_like(t)
    a[(t > 0.999) & (t < 1.001)] = 1.0  # the 2 % step accelerates: two physical plateaus
    u = 5.0 * np.sign(v)
    plateaus, used = find_plateaus(t, v, a, u, settings=PlateauSettings(vel_tol=0.01, min_duration=0.2))
    assert [round(p.velocity, 4) for p in plateaus] == [0.01, 0.0102, -0.02, -0.02]
    first = plateaus[0]  # 0 .. 1 s, cut where the 40-sample mean leaves the 1 % band, 10 % trimmed at each end
    assert 780 <= first.n <= 800 and first.t_start == pytest.approx(0.1, abs=0.003)
    assert used == {"acc_tol": 0.0, "min_speed": pytest.approx(0.002 * 0.02)}  # |a| is 0 in 99 % of the samples
    # without the acceleration the 2 % step is a drift: one physical plateau (its pieces merged); the stop at
    # 2.4-2.5 s still separates the two runs at -0.02 m/s
    merged, _ = find_plateaus(t, v, np.zeros_like(t), u, settings=PlateauSettings(vel_tol=0.01, min_duration=0.2))
    assert [round(p.velocity, 4) for p in merged] == [pytest.approx(0.0101, abs=1e-4), -0.02, -0.02]
    assert merged[0].t_start == pytest.approx(0.1, abs=0.003) and merged[0].t_end > 1.7
    with pytest.raises(UsageError, match="vel_tol"):
        PlateauSettings(vel_tol=0.0)
    with pytest.raises(UsageError, match="trim"):
        PlateauSettings(trim=0.5)


def test_one_direction_log_fits_that_direction_only():
    truth = _truth("hump")
    result = identify_friction_curve(_plateau_log(truth, both=False), position="x", command="u", law="hump")
    assert set(result.fit.directions) == {"pos"} and result.friction is None
    assert any("no points with v < 0" in w for w in result.warnings)
    assert any("one direction only" in w for w in result.warnings)
    pos = result.fit.directions["pos"]
    assert pos.dc == pytest.approx(12.0, rel=0.02) and pos.ds == pytest.approx(20.0, rel=0.02)
    assert pos.omega == pytest.approx(0.01, rel=0.02) and pos.viscous == pytest.approx(40.0, rel=0.02)
    out = result.to_dict()
    json.dumps(out, allow_nan=False)
    assert out["friction"] is None and list(out["curve"]) == ["pos"]


def test_too_few_plateaus():
    log = _plateau_log(_truth("stribeck"), speeds=SPEEDS[[2, 6, 10]])
    with pytest.raises(IllConditionedError, match="fewer than 5 points"):
        identify_friction_curve(log, position="x", command="u")
    few = identify_friction_curve(_plateau_log(_truth("stribeck"), speeds=SPEEDS[::2]), position="x", command="u")
    assert any("only 7 points with v > 0" in w for w in few.warnings)


# ---------------------------------------------------------------------------------------- wrong signs
def test_mirrored_data_are_refused_with_the_parameter_named(closed_loop):
    log = _plateau_log(_truth("hump"))
    mirrored = Log(log.t, {"x": log["x"], "u": -log["u"]}, dict(log.units))
    with pytest.raises(DataError, match=r"steady-state hump fit: both Coulomb levels oppose the motion \(dc_pos = "
                                        r"-12 \+/- .* N, dc_neg = 10 .*mirrored or sign-inverted"):
        identify_friction_curve(mirrored, position="x", command="u", law="hump")
    sim, _ = closed_loop
    flipped = Log(sim.t, {"x": sim["x"], "u": -sim["u"]}, dict(sim.units))
    with pytest.raises(DataError, match=r"Stribeck fit: both Coulomb levels oppose the motion.*sign-inverted"):
        identify_friction(flipped, position="x", command="u", mass=MASS, viscous=VISCOUS)
    with pytest.raises(DataError, match=r"joint friction fit: mass = -\d.* < 0 .*sign-inverted"):
        identify_friction(flipped, position="x", command="u", joint=True)


def test_an_offset_larger_than_the_friction_is_named_not_called_mirrored():
    """A vertical axis: gravity 30 N against a Coulomb level of 11 N; both levels come out positive."""
    log = _plateau_log(_truth("stribeck"))
    lifted = Log(log.t, {"x": log["x"], "u": log["u"] + 30.0}, dict(log.units))
    with pytest.raises(DataError, match=r"both Coulomb levels have the same sign .*: an offset of 3\d.* N against a "
                                        r"Coulomb level of 1\d.* N; a constant force \(gravity") as info:
        identify_friction_curve(lifted, position="x", command="u")
    assert "mirrored" not in str(info.value)


def test_a_negative_viscous_term_is_held_at_zero_and_named():
    v = np.concatenate([SPEEDS, -SPEEDS])
    falling = FrictionLaw(12.0, 12.0, -10.0, -10.0, omega_pos=0.01).force(v) - 20.0 * v  # friction falls with speed
    fit = fit_friction_law(v, falling + np.random.default_rng(1).normal(0.0, 0.05, v.size), law="stribeck")
    assert fit.directions["pos"].viscous == 0.0 and "viscous_pos" in fit.on_bound
    assert fit.on_bound["viscous_pos"]["unconstrained"] < -10.0 and np.isnan(fit.directions["pos"].std["viscous"])
    assert any(w.startswith("viscous_pos ended on its bound 0 (unconstrained -") and "does not describe" in w
               for w in fit.warnings), fit.warnings
    flat = StribeckFriction(12.0, 20.0, -10.0, -17.0, omega_pos=0.01).force(v)  # no viscous friction at all
    noisy = flat + np.random.default_rng(2).normal(0.0, 0.05, v.size)
    fit = fit_friction_law(v, noisy - 0.3 * v, law="stribeck")  # Fv slightly below 0, within its noise
    assert all(d.viscous >= 0.0 for d in fit.directions.values())
    assert any("the data do not identify it; it is held at 0" in w for w in fit.warnings)


def test_load_model_refuses_a_wrong_sign_file(tmp_path):
    from feedtune.io import load_model, save_model

    path = tmp_path / "friction.toml"
    save_model(path, StribeckFriction(12.0, 20.0, -10.0, -17.0, omega_pos=0.01), fit={"log": "run.csv"})
    text = path.read_text()
    path.write_text(text.replace("ds_pos = { value = 20.0,", "ds_pos = { value = -108.0,"))
    with pytest.raises(DataError) as info:
        load_model(path)
    message = str(info.value)
    assert message.startswith(f"{path}: params.ds_pos: must be >= 0, got -108") and "\n" not in message
    path.write_text(text.replace("dc_neg = { value = -10.0,", "dc_neg = { value = 10.0,"))
    with pytest.raises(DataError, match=r"params\.dc_neg: must be <= 0, got 10"):
        load_model(path)
    law = tmp_path / "hump.toml"
    save_model(law, _truth("hump"))
    law.write_text(law.read_text().replace("viscous_neg = { value = 50.0,", "viscous_neg = { value = -5.0,"))
    with pytest.raises(DataError, match=r"hump\.toml: params\.viscous_neg: must be >= 0, got -5\.0"):
        load_model(law)
    law.write_text(law.read_text().replace("viscous_neg = { value = -5.0,", "viscous_neg = { value = 5.0,")
                   .replace("ds_pos = { value = 20.0,", "ds_pos = { value = -20.0,"))
    with pytest.raises(DataError, match=r"hump\.toml: params\.ds_pos: must be >= 0, got -20"):
        load_model(law)


def test_friction_law_files_round_trip_and_eq_2_1_files_load_as_before(tmp_path):
    from feedtune.io import load_model, save_model

    for law in LAWS:
        path = tmp_path / f"{law}.toml"
        save_model(path, _truth(law), fit={"log": "run.csv"})
        assert load_model(path) == _truth(law) and load_model(path.with_suffix(".json")) == _truth(law)
        assert f'model = "{law}"' in path.read_text() and "viscous_neg" in path.read_text()
    assert "omega_pos" not in (tmp_path / "coulomb-viscous.toml").read_text()
    eq21 = tmp_path / "eq21.toml"
    save_model(eq21, TRUTH)
    assert "viscous" not in eq21.read_text()
    assert type(load_model(eq21)) is StribeckFriction and load_model(eq21) == TRUTH
    eq21.write_text(eq21.read_text().replace('model = "stribeck"', 'model = "dahl"'))
    with pytest.raises(DataError, match="model = 'dahl'; known friction laws: stribeck, hump, lugre, coulomb-viscous"):
        load_model(eq21)


def test_feedforward_takes_the_law_with_its_viscous_term_and_refuses_hump_and_lugre():
    from feedtune.control.friction import friction_feedforward

    lead = 0.01 / (2 * math.pi)
    ff = friction_feedforward(_truth("stribeck"), command_unit="N", lead_m_per_rad=lead)
    assert isinstance(ff.friction, FrictionLaw) and ff.friction.dc_pos == 12.0
    assert ff.friction.omega_pos == pytest.approx(0.01 / lead)
    assert ff.viscous == pytest.approx((40.0 * lead, 50.0 * lead))  # N/(m/s) -> N/(rad/s) of screw rotation
    v = np.array([-0.2, -0.03, 0.05, 0.2]) / lead  # rad/s, outside the band
    assert ff.command(v) == pytest.approx(_truth("stribeck").force(v * lead), rel=1e-12)
    # a design whose linear feedforward carries b = 0.03 N/(rad/s) gets the rest: the viscous friction fed once
    rest = friction_feedforward(_truth("stribeck"), command_unit="N", lead_m_per_rad=lead, linear_viscous=0.03)
    assert rest.viscous == pytest.approx((40.0 * lead - 0.03, 50.0 * lead - 0.03))
    assert rest.section()["viscous_pos"]["unit"] == "N/(rad/s)"
    assert rest.source["viscous_in_linear_feedforward"] == {"value": 0.03, "unit": "N/(rad/s)"}
    # eq. 2.1 alone (no viscous term identified with it) adds none, whatever the design carries
    plain = friction_feedforward(TRUTH, command_unit="N", lead_m_per_rad=lead, linear_viscous=0.03)
    assert plain.viscous == (0.0, 0.0) and type(plain.friction) is StribeckFriction
    # the coulomb-viscous law: Fc + Fv v, its band a tenth of Fc / Fv (12 N / 40 N/(m/s) = 0.3 m/s)
    cv = friction_feedforward(_truth("coulomb-viscous"), command_unit="N", lead_m_per_rad=None)
    assert cv.v_band == pytest.approx(0.1 * min(12.0 / 40.0, 10.0 / 50.0))
    assert cv.command(np.array([0.5, -0.5])) == pytest.approx([12.0 + 20.0, -10.0 - 25.0])
    assert "ds_pos" not in cv.section() and cv.section()["model"] == "coulomb-viscous"
    with pytest.raises(DataError, match="'lugre' friction law cannot be fed forward"):
        friction_feedforward(_truth("lugre"), command_unit="N", lead_m_per_rad=lead)


# ------------------------------------------------------------------------------------ joint fit (sim)
@pytest.fixture(scope="module")
def closed_loop():
    return _simulate(TRUTH)


def test_joint_fit_recovers_the_closed_loop_truth(closed_loop):
    log, _ = closed_loop
    result = identify_friction(log, position="x", command="u", joint=True)
    errors = _rel_errors(result.friction, TRUTH, PARAMS[:6])
    errors["mass"] = result.mass / MASS - 1.0
    errors["viscous"] = result.viscous / VISCOUS - 1.0
    assert max(abs(e) for e in errors.values()) < 0.05, errors  # measured: <= 0.5 %
    joint = result.joint_fit
    assert joint is not None and result.rigid_fit is None
    assert joint.mass == pytest.approx(MASS, rel=0.05) and 0.0 < joint.law_fit.mass_std < 0.05 * MASS
    assert result.friction.viscous_pos == joint.law_fit.directions["pos"].viscous  # the joint law is the model
    for d, (dc, ds) in zip(joint.law_fit.directions.values(), ((12.0, 20.0), (-10.0, -17.0)), strict=True):
        assert d.dc == pytest.approx(dc, rel=0.05) and d.ds == pytest.approx(ds, rel=0.05)
        assert d.omega == pytest.approx(0.008, rel=0.05) and d.viscous == pytest.approx(VISCOUS, rel=0.05)
    out = result.to_dict()
    json.dumps(out, allow_nan=False)
    assert out["joint_fit"]["units"]["mass"] == "N/(m/s^2)" and out["law"] == "stribeck"


def test_steady_state_on_the_closed_loop_simulation(closed_loop):
    """The closed-loop log (PID, quantised position) dwells 0.3 s at 5 speeds each way: 10 plateaus."""
    log, _ = closed_loop
    result = identify_friction_curve(log, position="x", command="u")
    assert len(result.plateaus) == 10 and any("only 5 points" in w for w in result.warnings)
    pos, neg = result.fit.directions["pos"], result.fit.directions["neg"]
    got = (pos.dc, pos.ds, neg.dc, neg.ds, pos.omega, neg.omega, pos.viscous, neg.viscous)
    truth = (12.0, 20.0, -10.0, -17.0, 0.008, 0.008, VISCOUS, VISCOUS)
    assert got == pytest.approx(truth, rel=0.02)  # measured: <= 0.6 %


def test_kalman_path_with_another_law(closed_loop):
    log, _ = closed_loop
    result = identify_friction(log, position="x", command="u", mass=MASS, viscous=VISCOUS, law="lugre")
    f = result.friction
    assert isinstance(f, FrictionLaw) and f.law == "lugre" and f.viscous_pos == 0.0
    assert f.sign_problems() == [] and f.dc_pos == pytest.approx(12.0, rel=0.1)
    json.dumps(result.to_dict(), allow_nan=False)
    cv = identify_friction(log, position="x", command="u", mass=MASS, viscous=VISCOUS, law="coulomb-viscous")
    assert cv.friction.law == "coulomb-viscous" and cv.friction.viscous_pos == 0.0  # the viscous is the model's
    assert "ds_pos" not in cv.to_dict()["friction"]["friction"]
    json.dumps(cv.to_dict(), allow_nan=False)


# ----------------------------------------------------------------------------------------------- CLI
def test_cli_steady_state(tmp_path, capsys, monkeypatch):
    from test_cli_logs import _one_line_error, run, run_json

    from feedtune.io import load_model, write_log_csv

    truth = _truth("hump")
    path, out = tmp_path / "plateaus.csv", tmp_path / "friction.toml"
    write_log_csv(_plateau_log(truth), path)
    result = run_json(["identify", "friction", path, "--steady-state", "--law", "hump", "--out", out], capsys,
                      monkeypatch)
    assert result["method"] == "steady-state" and len(result["points"]) == 2 * SPEEDS.size
    model = load_model(out)
    assert isinstance(model, FrictionLaw) and model.law == "hump"
    assert max(abs(e) for e in _rel_errors(model, truth).values()) < 0.02
    code, _, err = run(["identify", "friction", path, "--steady-state", "--mass", "3"], capsys, monkeypatch)
    _one_line_error(code, err, 2, "--mass is not used by --steady-state")
    code, _, err = run(["identify", "friction", path, "--plateau-vel-tol", "0.1"], capsys, monkeypatch)
    _one_line_error(code, err, 2, "--plateau-vel-tol needs --steady-state")
    code, _, err = run(["identify", "friction", path, "--steady-state", "--law", "dahl"], capsys, monkeypatch)
    _one_line_error(code, err, 2, "friction --law must be one of stribeck, hump, lugre, coulomb-viscous")
    mirrored = tmp_path / "mirrored.csv"
    log = _plateau_log(truth)
    write_log_csv(Log(log.t, {"x": log["x"], "u": -log["u"]}, dict(log.units)), mirrored)
    code, _, err = run(["identify", "friction", mirrored, "--steady-state", "--out", tmp_path / "m.toml"], capsys,
                       monkeypatch)
    _one_line_error(code, err, 1, "steady-state stribeck fit: both Coulomb levels oppose the motion (dc_pos = -1")
    assert not (tmp_path / "m.toml").exists()
    one_way = tmp_path / "one_way.csv"
    write_log_csv(_plateau_log(truth, both=False), one_way)
    code, _, err = run(["identify", "friction", one_way, "--steady-state", "--out", tmp_path / "o.toml"], capsys,
                       monkeypatch)
    _one_line_error(code, err, 1, "only v > 0 has plateaus")


# ------------------------------------------------------------------------------ real data: rack & pinion
def test_rack_pinion_hump_law(real_data_dir):
    """K. Mnich's constant-direction run: force = -200 N/V (V - mean of the first 10 samples), speed = -rpm 20e-3/60
    m/s (README); both resampled to the servo trace, low-passed at 30 Hz as the author's scripts do, then the hump
    law with a mass term fitted to the ramp samples above 0.01 m/s (there are no plateaus: the carriage accelerates
    to 0.65 m/s and brakes)."""
    from scipy import signal

    root = real_data_dir / "rack_pinion_friction_Mnich"
    if not (root / "a3NI.csv").is_file():
        pytest.skip("rack_pinion_friction_Mnich not present")
    ni = np.genfromtxt(root / "a3NI.csv", delimiter=",", skip_header=4, encoding="utf-8-sig")
    mr = np.genfromtxt(root / "a3MR.csv", delimiter=",", skip_header=5)
    ni = ni[np.isfinite(ni[:, 0]) & np.isfinite(ni[:, 1])]
    t_ni, force = ni[:, 0] + 0.004, -200.0 * (ni[:, 1] - ni[:10, 1].mean())  # README: NI shifted by +4 ms
    t, speed = mr[:, 0] / 1000.0, -mr[:, 1] * 20e-3 / 60.0
    b, a = signal.butter(2, 30.0, fs=1.0 / np.median(np.diff(t)))
    v = signal.filtfilt(b, a, speed)
    f = signal.filtfilt(b, a, np.interp(t, t_ni, force))
    acc = np.gradient(v, t)
    use = (t <= t_ni[-1]) & (v > 0.01)
    fit = fit_friction_law(v[use], f[use], law="hump", acceleration=acc[use])
    assert set(fit.directions) == {"pos"}  # one direction: fitted alone
    d = fit.directions["pos"]
    assert d.dc > 0 and d.ds > 0 and d.omega > 0 and d.viscous >= 0  # measured 27.6 N, 15.0 N, 0.067 m/s, 23.5
    assert fit.mass == pytest.approx(24.7, rel=0.1)  # the author's reduced mass: 24.7 kg (measured 25.3)
    # measured RMS 3.4 N (4.2 %) of a 100 N peak force; the author's published coefficients (Fc 10 N,
    # Fv 67.4 N/(m/s), Fmax 29.6 N, vs 0.0135 m/s, m 24.7 kg) leave 6.5 N (8.1 %) on the same samples
    assert fit.rms_error < 5.0 and fit.relative_error_pct < 6.0


def test_joint_fit_of_a_one_way_run_gives_the_mass_and_that_direction(tmp_path, capsys, monkeypatch):
    import sys

    from feedtune.cli.main import main
    from feedtune.identify.friction import OneDirectionError, fit_joint_friction
    from feedtune.io import write_log_csv

    truth = _truth("hump")
    log = _plateau_log(truth, both=False, mass=25.0, noise=0.02)
    with pytest.raises(OneDirectionError, match="both directions"):
        fit_joint_friction(log, position="x", command="u", law="hump")
    fit = fit_joint_friction(log, position="x", command="u", law="hump", one_direction=True)
    assert fit.mass == pytest.approx(25.0, rel=0.02)
    assert set(fit.law_fit.directions) == {"pos"} and any("one way only" in w for w in fit.warnings)
    d = fit.law_fit.directions["pos"]
    assert d.dc == pytest.approx(truth.dc_pos, rel=0.05) and d.viscous == pytest.approx(40.0, rel=0.1)
    # the command line falls back to it (no model file: it would need both directions)
    write_log_csv(log, tmp_path / "oneway.csv")
    for extra, code in (([], 0), (["--out", str(tmp_path / "f.toml")], 1)):
        monkeypatch.setattr(sys, "argv", ["feedtune", "identify", "friction", str(tmp_path / "oneway.csv"),
                                          "--position", "x", "--input", "u", "--law", "hump", *extra])
        try:
            main()
            got = 0
        except SystemExit as exc:
            got = exc.code
        out, err = capsys.readouterr()
        assert got == code, err
        if code == 0:  # the fallback's warning names the option
            said = out + err
            assert "one way only" in said and "above --min-speed" in said and "min_speed" not in said, said
    assert "one way only" in err or "one way only" in out
