"""Friction feedforward of the loop-shaped x axis (``design loopshape --friction``): the ``[friction_feedforward]`` of
an axis gains file is Stribeck eq. 2.1 with its viscous term (:meth:`FrictionLaw.force`, evaluated here independently)
of the previewed reference's backward-difference velocity [m/s] outside the band and the straight line through zero
inside it; its units must be the axis' (command unit, m/s); the command line writes it; and on the gantry twin's x axis
with friction the closed loop tracks better with it than without.

The runtime, the compiled twin loop and the C header (double and float) are checked against each other for an axis
with friction feedforward in tests/test_gantry_law_consistency.py, tests/test_export_c_kinds.py and
tests/test_export_c_float.py.
"""

from __future__ import annotations

import numpy as np
import pytest
from test_cli import run

from feedtune.control.filters import FilterPack, Notch
from feedtune.control.friction import reference_velocity
from feedtune.design.loopshape import design_loopshape
from feedtune.errors import DataError, UsageError
from feedtune.io import read_document, save_model
from feedtune.io.gantry_gains import axis_gains_document
from feedtune.machines import load_runtime
from feedtune.machines.gantry.experiments import HoldingController
from feedtune.machines.gantry.runtime import AxisRuntime
from feedtune.machines.gantry.twin import GantryTwin, GantryTwinParams
from feedtune.models.friction import FrictionLaw, StribeckFriction
from feedtune.models.gantry import THESIS_GANTRY
from feedtune.models.rigid import RigidBodyModel
from feedtune.sim.engine import numba_available
from feedtune.sim.trajectory import multi_segment

needs_numba = pytest.mark.skipif(not numba_available(), reason="numba not installed")

FRICTION = FrictionLaw(0.2, 0.35, -0.25, -0.4, 0.01, 0.02, command_unit="V", velocity_unit="m/s", viscous_pos=0.8,
                       viscous_neg=1.1)
"""An asymmetric friction of the x axis in the twin's command unit [V] and m/s, with viscous friction [V/(m/s)] (at the
move's 0.3 m/s the viscous term, 0.24-0.33 V, is as large as the Coulomb level)."""
BAND = 1e-3
"""Linear band of the feedforward [m/s]."""
FILTERS = FilterPack([Notch(186, 0.6, 0.7), Notch(332, 0.3, 0.7), Notch(404, 0.2, 0.7)], 1200.0)
DESIGN = design_loopshape(THESIS_GANTRY.m_x, crossover_hz=130.0, pm_deg=35.0, filters=FILTERS)


def _move(fs: float, dwell: float = 0.1) -> np.ndarray:
    """An x move out and back (-0.1 -> 0.05 -> -0.1 m, 0.3 m/s) with dwells: starts, stops and both directions."""
    tr = multi_segment([-0.1, 0.05, -0.1], v_max=0.3, a_max=3.0, j_max=100.0, fs=fs, dwell=dwell)
    return np.r_[np.full(int(dwell * fs), tr.pos[0]), tr.pos, np.full(int(dwell * fs), tr.pos[-1])]


# ------------------------------------------------------------------ the feedforward term, evaluated independently
@needs_numba
def test_the_feedforward_term_is_the_stribeck_force_of_the_reference_velocity():
    """The command with friction feedforward minus the command without, for the same readings, is d(v_r): eq. 2.1 and
    its viscous term (FrictionLaw.force) outside +-v_band and d(+-v_band) |v_r| / v_band inside, with v_r the backward
    difference of the previewed reference (0 on the first sample). Checked on the runtime's per-sample step (the
    compiled law) and on its vectorised replay."""
    plain = load_runtime(axis_gains_document(DESIGN))
    ff = load_runtime(axis_gains_document(DESIGN.with_friction(FRICTION, v_band=BAND)))
    assert ff.friction is not None and ff.friction.velocity_unit == "m/s" and plain.friction is None
    x_ref = _move(plain.fs)
    rng = np.random.default_rng(3)
    x = x_ref + 1e-6 * rng.standard_normal(x_ref.size)
    r = plain.previewed(x_ref)
    per_sample = []
    for rt in (plain, ff):
        rt.reset()
        per_sample.append(np.array([rt.step(a, b) for a, b in zip(r, x, strict=True)]))
    extra = per_sample[1] - per_sample[0]
    replayed = ff.replay(x_ref, x) - plain.replay(x_ref, x)
    v = np.r_[0.0, np.diff(r)] * plain.fs  # m/s, written out rather than reference_velocity
    outside = np.abs(v) >= BAND
    inside = ~outside
    edge = np.where(v[inside] >= 0, FRICTION.force(BAND), FRICTION.force(-BAND))
    expected = np.zeros(v.size)
    expected[outside] = FRICTION.force(v[outside])
    expected[inside] = edge * np.abs(v[inside]) / BAND
    for got in (extra, replayed):
        assert np.allclose(got, expected, rtol=1e-9, atol=1e-10)
    # the move covers both directions, the Stribeck region, the band (not only at rest) and the rest
    assert np.any(v > 0.2) and np.any(v < -0.2) and np.any((np.abs(v) > BAND) & (np.abs(v) < 0.02))
    assert np.any(inside & (v != 0)) and np.any(v == 0)
    # the band is continuous at its edges: the line meets the curve
    assert FRICTION.smoothed([BAND * (1 - 1e-12)], BAND)[0] == pytest.approx(FRICTION.force(BAND), rel=1e-9)
    assert np.array_equal(reference_velocity(r, plain.fs), v)


def test_the_gains_file_section_and_law_text():
    doc = axis_gains_document(DESIGN.with_friction(FRICTION))
    sec = doc["friction_feedforward"]
    assert sec["model"] == "stribeck" and sec["dc_pos"] == {"value": 0.2, "unit": "V"}
    assert sec["omega_neg"] == {"value": 0.02, "unit": "m/s"}
    assert sec["v_band"] == {"value": pytest.approx(1e-3), "unit": "m/s"}  # default: 0.1 x the smaller Omega
    assert "friction(v_r)" in doc["law"]["execution"] and "previewed reference" in sec["velocity"]
    assert "friction" not in axis_gains_document(DESIGN)["law"]["execution"]
    # a section in rad/s is not an axis' (the runtime reads m/s)
    bad = {**doc, "friction_feedforward": {**sec, "v_band": {"value": 1e-3, "unit": "rad/s"}}}
    with pytest.raises(DataError, match=r"friction_feedforward\.v_band"):
        AxisRuntime.from_document(bad)
    assert DESIGN.with_friction(FRICTION).with_friction(None).friction is None


def test_units_must_be_the_axis_units():
    newton = StribeckFriction(20.0, 25.0, -20.0, -25.0, 0.01, command_unit="N", velocity_unit="m/s")
    with pytest.raises(DataError, match=r"friction levels are in 'N' but .*command is in 'V'"):
        DESIGN.with_friction(newton)
    rotary = StribeckFriction(0.2, 0.3, -0.2, -0.3, 0.5, command_unit="V", velocity_unit="rad/s")
    with pytest.raises(DataError, match="velocities are in 'rad/s' but the linear axis"):
        design_loopshape(THESIS_GANTRY.m_x, crossover_hz=130.0, pm_deg=35.0, friction=rotary)
    with pytest.raises(UsageError, match="band must be > 0"):
        DESIGN.with_friction(FRICTION, v_band=0.0)
    # an EMPS-like axis commanded in N takes a friction model in N
    emps = design_loopshape(RigidBodyModel(mass=95.0, command_unit="N"), crossover_hz=20.0, pm_deg=40.0, fs=1000.0,
                            friction=newton)
    assert emps.friction.command_unit == "N"
    assert axis_gains_document(emps)["friction_feedforward"]["ds_pos"]["unit"] == "N"


# ------------------------------------------------------------------ the command line
def test_cli_design_loopshape_with_friction(tmp_path, capsys, monkeypatch):
    save_model(tmp_path / "gantry.toml", THESIS_GANTRY)
    save_model(tmp_path / "friction.toml", FRICTION)
    args = ["design", "loopshape", tmp_path / "gantry.toml", "--crossover-hz", "130", "--pm-deg", "35", "--notch",
            "186,0.6,0.7", "--lpf", "1200", "--friction", tmp_path / "friction.toml", "--friction-band", "0.002",
            "--out", tmp_path / "x.toml", "--allow-unstable"]
    code, out, err = run(args, capsys, monkeypatch)
    assert code == 0, err
    assert "friction feedforward (eq. 2.1)" in out and "m/s" in out
    doc = read_document(tmp_path / "x.toml")
    assert doc["friction_feedforward"]["v_band"] == {"value": 0.002, "unit": "m/s"}
    assert doc["friction_feedforward"]["viscous_neg"] == {"value": 1.1, "unit": "V/(m/s)"}
    rt = load_runtime(doc)
    assert rt.friction.friction.ds_neg == -0.4 and rt.friction.viscous == (0.8, 1.1)
    code, _, err = run(["export", "c", tmp_path / "x.toml"], capsys, monkeypatch)
    assert code == 0, err
    assert "FT_FR_V_BAND = 0.002; /* m/s */" in (tmp_path / "x.h").read_text()
    assert "FT_FR_FV_NEG = 1.1; /* V/(m/s) */" in (tmp_path / "x.h").read_text()
    # a friction model in N for an axis commanded in V: one line naming both files
    save_model(tmp_path / "newton.toml", StribeckFriction(20.0, 25.0, -20.0, -25.0, 0.01, command_unit="N",
                                                          velocity_unit="m/s"))
    args[args.index(tmp_path / "friction.toml")] = tmp_path / "newton.toml"
    code, _, err = run([*args, "--force"], capsys, monkeypatch)
    assert code != 0 and err.count("\n") == 1
    assert "newton.toml" in err and "gantry.toml" in err and "'N'" in err and "'V'" in err
    code, _, err = run(["design", "loopshape", tmp_path / "gantry.toml", "--crossover-hz", "130", "--pm-deg", "35",
                        "--friction-band", "0.001"], capsys, monkeypatch)
    assert code != 0 and "--friction-band needs --friction" in err


# ------------------------------------------------------------------ closed loop on the twin's x axis with friction
class _TableFriction:
    """The x-axis controller with Stribeck friction acting on the twin's table: the twin's x axis has no friction of
    its own, so the friction force (in the drive's command unit) of the velocity measured by backward difference of
    the encoder is subtracted from the command the drive applies (a one-sample-late velocity; the command the
    controller computes is unchanged)."""

    def __init__(self, axis, friction: StribeckFriction, band: float) -> None:
        self.axis, self.friction, self.band = axis, friction, band
        self.fs, self.preview_samples = axis.fs, axis.preview_samples
        self.reset()

    def reset(self) -> None:
        self.axis.reset()
        self.x_prev = None

    def check_target(self, fs: float, where: str | None = None) -> None:
        self.axis.check_target(fs, where)

    def step(self, x_ref_preview: float, x: float) -> float:
        v = 0.0 if self.x_prev is None else (x - self.x_prev) * self.fs
        self.x_prev = x
        return self.axis.step(x_ref_preview, x) - float(self.friction.smoothed(v, self.band))


@needs_numba
def test_friction_feedforward_tracks_better_on_the_twin_with_friction():
    """The x axis tracks an out-and-back move on the gantry twin (noise-free encoders) whose table has the friction
    FRICTION: with the feedforward of that model the RMS tracking error is several times smaller than without; on
    the twin without friction the feedforward would only add error."""
    twin = GantryTwin(GantryTwinParams(noise_m=0.0, u_max=None, overload_rms=None, envelope_m=0.05))
    x_ref = _move(twin.fs)
    gantry = HoldingController.for_twin(twin)  # holds y at rest
    plain = load_runtime(axis_gains_document(DESIGN))
    ff = load_runtime(axis_gains_document(DESIGN.with_friction(FRICTION, v_band=BAND)))

    def rms(axis) -> float:
        run_ = twin.simulate(gantry, axis, np.zeros(x_ref.size), x_ref=x_ref)
        assert not run_.tripped, run_.trip_message
        return float(np.sqrt(np.mean((run_.x_ref - run_.x) ** 2)))

    without, with_ff = rms(_TableFriction(plain, FRICTION, BAND)), rms(_TableFriction(ff, FRICTION, BAND))
    assert with_ff < without / 3, (with_ff, without)
    assert rms(ff) > rms(plain)


# ------------------------------------------------------------------ EMPS: the viscous feedforward at speed
def test_emps_friction_feedforward_at_speed_matches_the_published_model(real_data_dir):
    """EMPS (nonlinearbenchmark.org): ``identify friction`` (the joint fit: the law with its viscous term), an axis
    design fed forward with it, and the runtime's feedforward at the reference's peak speed (0.125 m/s) against the
    published asymmetric IDIM-LS friction ``Fc+- + Fv+- v`` (EMPS_Description.pdf, README): within 1 % both ways. The
    viscous term alone is about 24 N there (203.5 N/(m/s) x 0.125 m/s = 25.4 N published), more than the 20.4 N
    Coulomb level; before, the feedforward had no viscous term and missed it."""
    from scipy.io import loadmat

    from feedtune.identify.friction import identify_friction
    from feedtune.log import Log

    d = loadmat(real_data_dir / "EMPS" / "DATA_EMPS.mat")
    t = d["t"].ravel()
    log = Log(t, {"qm": d["qm"].ravel(), "vir": d["vir"].ravel()}, {"qm": "m", "vir": "V"})
    friction = identify_friction(log, position="qm", command="vir", command_scale=35.15065).friction
    assert friction.command_unit == "N" and friction.viscous_pos > 0 and friction.viscous_negative > 0
    design = design_loopshape(RigidBodyModel(mass=95.11, command_unit="N"), crossover_hz=30.0, pm_deg=35.0, fs=1000.0,
                              friction=friction)
    rt = load_runtime(axis_gains_document(design))
    v = float(np.max(np.abs(np.gradient(d["qg"].ravel(), t))))  # the reference's peak speed [m/s]
    assert v == pytest.approx(0.1247, abs=1e-3)
    published = (20.1440 + 166.7061 * v, -(20.6277 + 240.4236 * v))  # N at +v, -v
    fed = rt.friction.command(np.array([v, -v]))
    assert fed == pytest.approx(published, rel=0.01)
    viscous = np.mean(np.array(rt.friction.viscous) * v)  # the viscous term at speed, mean of both ways
    assert viscous == pytest.approx(203.5034 * v, rel=0.1) and viscous > 20.3935
