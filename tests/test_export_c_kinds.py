"""``feedtune export c`` for every gains kind: the header compiles with ``gcc -Wall -Wextra -Werror -std=c99`` and
executes the same law as the Python runtime sample by sample; the output limit and the anti-windup behave as their
closed forms say; failed designs and bad options are refused."""

from __future__ import annotations

import shutil

import numpy as np
import pytest
from c_compile import DRIVERS, run_header
from test_cli import run

from feedtune.control.filters import FilterPack, LeadStage, Notch
from feedtune.control.prefilter import PrefilterGains
from feedtune.design.gantry_mimo import design_gantry_mimo
from feedtune.design.gantry_pid import design_gantry_pid
from feedtune.design.loopshape import design_loopshape
from feedtune.design.mcppc import design_mcppc
from feedtune.errors import DataError, UsageError
from feedtune.export.c_header import c_header
from feedtune.io import write_document
from feedtune.io.gains import gains_document
from feedtune.io.gantry_gains import axis_gains_document, gantry_gains_document
from feedtune.machines import load_runtime
from feedtune.models import THESIS_TABLE_3_1
from feedtune.models.friction import FrictionLaw
from feedtune.models.gantry import THESIS_GANTRY

GCC = shutil.which("gcc")
needs_gcc = pytest.mark.skipif(GCC is None, reason="gcc not installed")

H = FilterPack([Notch(110, 0.5, 0.7), Notch(320, 0.2, 0.9), Notch(940, 0.6, 0.75)], 450.0, 2, 0.7,
               [LeadStage(154, 70)])
PRE1, PRE2 = PrefilterGains(2e-3, 1e-5, 1e-8, 0.0), PrefilterGains(-1e-3, 2e-5, 0.0, 1e-10)
X_GRID = np.linspace(-0.3, 0.3, 5)
MIMO = gantry_gains_document(design_gantry_mimo(THESIS_GANTRY, filters=H, prefilter1=PRE1, prefilter2=PRE2,
                                                x_grid=X_GRID))
PID = gantry_gains_document(design_gantry_pid(THESIS_GANTRY, kp=(4e3, 3e3), kd=(60.0, 50.0), ki=(4e4, 3e4),
                                              filters=FilterPack([Notch(320, 0.2, 0.9)], 900.0), x_grid=X_GRID))
AXIS = axis_gains_document(design_loopshape(0.6977, crossover_hz=130, pm_deg=35,
                                            filters=FilterPack([Notch(186, 0.6, 0.7)], 1200.0),
                                            prefilter=PrefilterGains(1e-3, 1e-6, 0, 0)))
AXIS_FRICTION_MODEL = FrictionLaw(0.05, 0.09, -0.06, -0.1, 2e-3, 3e-3, command_unit="V", velocity_unit="m/s",
                                  viscous_pos=0.4, viscous_neg=0.55)
"""An asymmetric friction of the x axis [V, m/s] with viscous friction [V/(m/s)], fed forward with a 2e-4 m/s band."""
AXIS_FRICTION = axis_gains_document(design_loopshape(0.6977, crossover_hz=130, pm_deg=35,
                                                     filters=FilterPack([Notch(186, 0.6, 0.7)], 1200.0),
                                                     prefilter=PrefilterGains(1e-3, 1e-6, 0, 0),
                                                     friction=AXIS_FRICTION_MODEL, friction_band=2e-4))
GANTRY_FRICTION_MODEL = FrictionLaw(0.3, 0.5, -0.35, -0.55, 2e-3, 3e-3, command_unit="V", velocity_unit="m/s",
                                    viscous_pos=1.2, viscous_neg=0.9)
"""An asymmetric friction of the gantry's travel [V, m/s] with viscous friction [V/(m/s)], fed forward with a 2e-4 m/s
band."""
MIMO_FRICTION = gantry_gains_document(design_gantry_mimo(THESIS_GANTRY, filters=H, prefilter1=PRE1, prefilter2=PRE2,
                                                         x_grid=X_GRID).with_friction(GANTRY_FRICTION_MODEL,
                                                                                      v_band=2e-4))
PID_FRICTION = gantry_gains_document(design_gantry_pid(THESIS_GANTRY, kp=(4e3, 3e3), kd=(60.0, 50.0), ki=(4e4, 3e4),
                                                       filters=FilterPack([Notch(320, 0.2, 0.9)], 900.0),
                                                       x_grid=X_GRID).with_friction(GANTRY_FRICTION_MODEL,
                                                                                    v_band=2e-4))
BALLSCREW = gains_document(design_mcppc(THESIS_TABLE_3_1, filters=FilterPack([Notch(420.0, 0.55, 0.7)], 2000.0)))

GANTRY_MAIN, AXIS_MAIN, BALLSCREW_MAIN = DRIVERS["gantry"], DRIVERS["axis"], DRIVERS["ballscrew"]


def _run_c(tmp_path, header: str, main_c: str, inputs: np.ndarray) -> np.ndarray:
    return run_header(GCC, tmp_path, header, main_c, inputs, opt="-O2")


def _gantry_inputs(n=3000, seed=4):
    rng = np.random.default_rng(seed)
    r = np.cumsum(rng.standard_normal(n)) * 1e-5
    y1 = r + rng.standard_normal(n) * 2e-6
    y2 = r + rng.standard_normal(n) * 2e-6
    x = 0.4 * np.sin(np.linspace(0, 3 * np.pi, n))  # crosses every schedule segment and both clamped ends
    x[100] = X_GRID[2]  # exactly on a grid point
    return np.column_stack([r, y1, y2, x])


def _gantry_friction_inputs(n=3000, seed=7, fs=15000.0):
    """A gantry reference whose velocity swings through zero, +-8 mm/s at 10 Hz with 1e-4 m/s of noise: it crosses
    the friction band of MIMO_FRICTION and PID_FRICTION (2e-4 m/s) and their Stribeck region (2e-3, 3e-3 m/s) in both
    directions; encoders 2e-6 m off it; the table across the schedule as in _gantry_inputs."""
    rng = np.random.default_rng(seed)
    v = 8e-3 * np.sin(2 * np.pi * 10.0 * np.arange(n) / fs) + 1e-4 * rng.standard_normal(n)
    r = np.cumsum(v) / fs
    x = 0.4 * np.sin(np.linspace(0, 3 * np.pi, n))
    return np.column_stack([r, r + rng.standard_normal(n) * 2e-6, r + rng.standard_normal(n) * 2e-6, x])


# ------------------------------------------------------------------ the header executes the runtime's law
@needs_gcc
@pytest.mark.parametrize(("doc", "make_inputs"), [(MIMO, _gantry_inputs), (PID, _gantry_inputs),
                                                  (MIMO_FRICTION, _gantry_inputs), (PID_FRICTION, _gantry_inputs),
                                                  (MIMO_FRICTION, _gantry_friction_inputs),
                                                  (PID_FRICTION, _gantry_friction_inputs)],
                         ids=["mimo", "pid", "mimo+friction", "pid+friction", "mimo+friction-slow",
                              "pid+friction-slow"])
def test_gantry_header_matches_the_runtime_sample_by_sample(tmp_path, doc, make_inputs):
    inputs = make_inputs()
    got = _run_c(tmp_path, c_header(doc), GANTRY_MAIN, inputs)
    rt = load_runtime(doc)
    rt.reset()
    ref = np.array([rt.step(*row) for row in inputs])
    scale = np.max(np.abs(ref), axis=0)
    assert np.max(np.abs(got - ref) / scale) < 1e-9


def _axis_inputs(n=3000, seed=5):
    """A random-walk reference (steps of 1e-5 m) and an encoder 1e-6 m off it."""
    rng = np.random.default_rng(seed)
    r = np.cumsum(rng.standard_normal(n)) * 1e-5
    return np.column_stack([r, r + rng.standard_normal(n) * 1e-6])


def _axis_friction_inputs(n=3000, seed=6, fs=15000.0):
    """A reference whose velocity swings through zero, +-8 mm/s at 10 Hz with 1e-4 m/s of noise: it crosses the
    friction band of AXIS_FRICTION (2e-4 m/s) and its Stribeck region (2e-3, 3e-3 m/s) in both directions; an
    encoder 1e-6 m off it."""
    rng = np.random.default_rng(seed)
    v = 8e-3 * np.sin(2 * np.pi * 10.0 * np.arange(n) / fs) + 1e-4 * rng.standard_normal(n)
    r = np.cumsum(v) / fs
    return np.column_stack([r, r + rng.standard_normal(n) * 1e-6])


@needs_gcc
@pytest.mark.parametrize(("doc", "make_inputs"), [(AXIS, _axis_inputs), (AXIS_FRICTION, _axis_inputs),
                                                  (AXIS_FRICTION, _axis_friction_inputs)],
                         ids=["axis", "axis+friction", "axis+friction-slow"])
def test_axis_header_matches_the_runtime_sample_by_sample(tmp_path, doc, make_inputs):
    inputs = make_inputs()
    got = _run_c(tmp_path, c_header(doc), AXIS_MAIN, inputs)[:, 0]
    rt = load_runtime(doc)
    rt.reset()
    ref = np.array([rt.step(*row) for row in inputs])
    assert np.max(np.abs(got - ref)) / np.max(np.abs(ref)) < 1e-9


# ------------------------------------------------------------------ output limit and anti-windup
@needs_gcc
def test_an_open_loop_ramp_stays_at_the_limit(tmp_path):
    """The issue's case: a reference ramp with the encoders at rest drove u to 7.4e5 V; clamped, u stays at +U_MAX."""
    n = 4000
    ramp = np.linspace(0.0, 50.0, n)  # rad
    inputs = np.column_stack([ramp, np.zeros(n), np.zeros(n)])
    free = _run_c(tmp_path, c_header(BALLSCREW), BALLSCREW_MAIN, inputs)[:, 0]
    assert np.max(np.abs(free)) > 1e4
    clamped = _run_c(tmp_path, c_header(BALLSCREW, u_max=10.0, anti_windup="clamp"), BALLSCREW_MAIN, inputs)[:, 0]
    assert np.max(np.abs(clamped)) <= 10.0
    assert np.all(clamped[n // 10:] == 10.0)


@needs_gcc
@pytest.mark.parametrize("doc", [PID, MIMO], ids=["pid", "mimo"])
def test_anti_windup_holds_the_integrators_and_the_output_leaves_the_limit_at_once(tmp_path, doc):
    """A large error (a 2 mm S-curve with the encoders at rest) saturates both outputs for 1 s, then the error
    turns slightly negative. Without
    anti-windup the integrators wound up during the second and hold the outputs at the limit long after; with clamp
    they stopped integrating at the limit, so after the reversal the outputs stay below it (closed form: the held
    integral is what the first samples added, and a negative error only lowers it)."""
    fs = load_runtime(doc).fs
    n_on, n_off = int(fs), int(0.2 * fs)
    t = np.arange(n_on + n_off) / fs
    ramp = lambda t0: 0.5 - 0.5 * np.cos(np.pi * np.clip((t - t0) / 0.05, 0.0, 1.0))  # noqa: E731 - 50 ms S-curve
    r = 2e-3 * ramp(0.0) - 2.1e-3 * ramp(n_on / fs)  # m: 2 mm, far beyond what u_max can hold, then -0.1 mm
    zeros = np.zeros(r.size)
    inputs = np.column_stack([r, zeros, zeros, zeros])
    u_max = 5.0
    wound = _run_c(tmp_path, c_header(doc, u_max=u_max), GANTRY_MAIN, inputs)
    held = _run_c(tmp_path, c_header(doc, u_max=u_max, anti_windup="clamp"), GANTRY_MAIN, inputs)
    for u in (wound, held):
        assert np.max(np.abs(u)) <= u_max
        assert np.all(u[n_on // 2:n_on] == u_max)  # saturated while the error is positive
    after = slice(n_on + int(0.1 * fs), n_on + n_off)  # after the second S-curve and its transient
    assert np.mean(wound[after] == u_max) > 0.9
    assert np.all(held[after] < u_max)


def test_options_are_checked():
    with pytest.raises(UsageError, match="anti_windup=clamp needs u_max") as err:
        c_header(PID, anti_windup="clamp")
    assert err.value.parameters == ("anti_windup", "u_max")
    with pytest.raises(UsageError, match=r"u_max must be a positive number, got -1\.0") as err:
        c_header(PID, u_max=-1.0)
    assert err.value.parameter == "u_max"
    with pytest.raises(UsageError, match="anti_windup=clamp is not available for an axis") as err:
        c_header(AXIS, u_max=5.0, anti_windup="clamp")
    assert err.value.parameter == "anti_windup"
    with pytest.raises(UsageError, match="prefix '9x' is not a valid C identifier") as err:
        c_header(PID, prefix="9x")
    assert err.value.parameter == "prefix"


def test_export_refuses_what_the_runtime_refuses():
    bad = {**MIMO, "controller": "lqr"}
    with pytest.raises(DataError, match="controller: expected one of 'mimo', 'pid', got 'lqr'"):
        c_header(bad)
    with pytest.raises(DataError, match="kind 'spindle' unknown"):
        c_header({**MIMO, "kind": "spindle"})


# ------------------------------------------------------------------ the command
def test_cli_exports_every_kind_and_refuses_a_design_outside_the_limits(tmp_path, capsys, monkeypatch):
    for name, doc in (("mimo", MIMO), ("axis", AXIS)):
        write_document(tmp_path / f"{name}.toml", doc)
        code, _, err = run(["export", "c", tmp_path / f"{name}.toml", "--u-max", "10", "--limits", "thesis"], capsys,
                           monkeypatch)
        assert code == 0, err
        assert "#define FT_U_MAX 10.0" in (tmp_path / f"{name}.h").read_text()
    # the hand-set PIDs are not checked against any limit at design time: --ms-max 1.05 cannot hold
    write_document(tmp_path / "pid.toml", PID)
    code, _, err = run(["export", "c", tmp_path / "pid.toml", "--ms-max", "1.05"], capsys, monkeypatch)
    assert code == 1 and "--allow-unstable" in err and err.count("\n") == 1 and not (tmp_path / "pid.h").exists()
    code, _, err = run(["export", "c", tmp_path / "pid.toml", "--ms-max", "1.05", "--allow-unstable"], capsys,
                       monkeypatch)
    assert code == 0 and "warning" in err
    assert "WARNING: this design fails the limits check" in (tmp_path / "pid.h").read_text()
    code, _, err = run(["export", "c", tmp_path / "pid.toml"], capsys, monkeypatch)
    assert code == 2 and "--force" in err  # no overwrite
