"""The gantry/axis runtime executes a gains file exactly as docs/gantry_gains.md describes."""

from __future__ import annotations

import copy

import numpy as np
import pytest
from scipy.signal import freqz_zpk, lfilter, sosfilt

from feedtune.control.filters import FilterPack, LeadStage, Notch
from feedtune.control.prefilter import PrefilterGains
from feedtune.design.gantry_mimo import design_gantry_mimo
from feedtune.design.gantry_pid import design_gantry_pid
from feedtune.design.loopshape import design_loopshape
from feedtune.design.mcppc import design_mcppc
from feedtune.errors import DataError, UsageError
from feedtune.io import write_document
from feedtune.io.gains import gains_document
from feedtune.io.gantry_gains import axis_gains_document, gantry_gains_document
from feedtune.machines import load_runtime
from feedtune.machines.ballscrew.runtime import GainsRuntime
from feedtune.machines.gantry.runtime import AxisRuntime, GantryRuntime
from feedtune.models import THESIS_TABLE_3_1
from feedtune.models.gantry import THESIS_GANTRY as MODEL
from feedtune.tune.pid import tune_gantry_pid

FS = 15000.0
H = FilterPack([Notch(110, 0.5, 0.7), Notch(320, 0.2, 0.9), Notch(400, 0.15, 1.0), Notch(940, 0.6, 0.75)],
                450.0, 2, 0.7, [LeadStage(154, 70)])
PRE1, PRE2 = PrefilterGains(2e-3, 1e-5, 1e-8, 0.0), PrefilterGains(-1e-3, 2e-5, 0.0, 1e-10)
MIMO = design_gantry_mimo(MODEL, filters=H, prefilter1=PRE1, prefilter2=PRE2)
PID = tune_gantry_pid(MODEL, ms_max=1.8, filters=H)
AXIS = design_loopshape(0.6977, crossover_hz=130, pm_deg=35, filters=FilterPack([Notch(186, 0.6, 0.7)], 1200.0),
                        prefilter=PrefilterGains(1e-3, 1e-6, 0, 0))


def _signals(n=4000, seed=2):
    rng = np.random.default_rng(seed)
    r = np.cumsum(rng.standard_normal(n)) * 1e-5
    y1 = np.cumsum(rng.standard_normal(n)) * 1e-6
    y2 = np.cumsum(rng.standard_normal(n)) * 1e-6
    r[:5] = y1[0] = y2[0] = 0.0
    return r, y1, y2


def _step_all(rt, p, y1, y2, x):
    rt.reset()
    return np.array([rt.step(a, b, c, d) for a, b, c, d in zip(p, y1, y2, x, strict=True)])


# ------------------------------------------------------------------------ runtime vs the designed law
def test_mimo_feedback_equals_the_designed_transfer_functions():
    # independent: eq. 4.30 evaluated with scipy from the design object (not the file), alpha at x = 0
    rt = GantryRuntime.from_document(gantry_gains_document(MIMO))
    _, y1, y2 = _signals()
    n = y1.size
    u = _step_all(rt, np.zeros(n), y1, y2, np.zeros(n))
    law = MIMO.law
    a1, a2 = law.alpha
    e1, e2 = -y1, -y2
    ebar = sosfilt(law.lead_discrete().to_sos(), a1 * e1 + a2 * e2)
    dd = law.beta * FS * lfilter([1.0, -1.0], [1.0], e1 - e2)
    i1, i2 = (law.ki * lfilter([1 / FS], [1.0, -1.0], e) for e in (e1, e2))
    h = law.filter_pack_discrete().to_sos()
    assert np.allclose(u[:, 0], sosfilt(h, a1 * (ebar + dd + i1)), rtol=1e-9, atol=1e-9 * np.abs(u).max())
    assert np.allclose(u[:, 1], sosfilt(h, a2 * (ebar - dd + i2)), rtol=1e-9, atol=1e-9 * np.abs(u).max())


@pytest.mark.parametrize("design", [MIMO, PID], ids=["mimo", "pid"])
@pytest.mark.parametrize("freq_hz", [20.0, 94.0, 400.0])
def test_runtime_frequency_response_equals_the_analysis_controller(design, freq_hz):
    # steady state of u for e1 = cos(w k T), e2 = 0 (fitted with a constant for the integrators) equals the
    # first column of K(e^{jwT}) that the frequency-domain analysis uses
    rt = GantryRuntime.from_document(gantry_gains_document(design))
    n = int(0.6 * FS)
    k = np.arange(n)
    e1 = np.cos(2 * np.pi * freq_hz * k / FS)
    u1, u2 = rt.replay(np.zeros(n), -e1, np.zeros(n), 0.0)
    tail = k > n - int(0.15 * FS)
    X = np.column_stack([np.cos(2 * np.pi * freq_hz * k[tail] / FS), -np.sin(2 * np.pi * freq_hz * k[tail] / FS),
                         np.ones(tail.sum())])
    K = design.law.response_discrete(np.array([freq_hz]))[:, 0, 0]
    for u, expected in ((u1, K[0]), (u2, K[1])):
        c = np.linalg.lstsq(X, u[tail], rcond=None)[0]
        assert complex(c[0], c[1]) == pytest.approx(expected, rel=1e-6, abs=1e-9 * abs(K).max())


def test_feedforward_of_a_parabola_is_the_side_mass_times_the_acceleration():
    # y_r = a t^2 / 2 tracked perfectly (y_i = y_r[k]): no error, u_i = (m_i1 + m_i2)(x) a (eq. 4.31, 4.3)
    rt = GantryRuntime.from_document(gantry_gains_document(design_gantry_mimo(MODEL, filters=H)))
    # (starts at rest: the runtime only ever sees y_r[k+P], so the reference must be 0 for the first P samples;
    # the last P samples see the held end of the finite reference)
    a, n, x, k0 = 2.0, 300, 0.1, 5
    yr = 0.5 * a * (np.maximum(np.arange(n) - k0, 0) / FS) ** 2
    u = _step_all(rt, rt.previewed(yr), yr, yr, np.full(n, x))
    m1, m2 = MODEL.side_masses(x)
    steady = slice(k0, n - 2)
    assert np.allclose(u[steady, 0], m1 * a, rtol=1e-9) and np.allclose(u[steady, 1], m2 * a, rtol=1e-9)
    assert np.all(u[: k0 - 1] == 0.0)


def test_prefilter_offsets_each_side_by_its_velocity_gain():
    # ramp y_r = v t, encoders on the raw reference, P-only PID (h(0) = 1): u_i -> kp_i k_vel_i v (eq. 4.32)
    d = design_gantry_pid(MODEL, kp=(1000.0, 2000.0), kd=0.0, ki=0.0, filters=H,
                          prefilter1=PrefilterGains(2e-3), prefilter2=PrefilterGains(-1e-3))
    rt = GantryRuntime.from_document(gantry_gains_document(d))
    v, n = 0.2, 6000
    yr = v * np.arange(n) / FS
    u1, u2 = rt.replay(yr, yr, yr, 0.0)
    assert u1[-10] == pytest.approx(1000.0 * 2e-3 * v, rel=1e-6)  # (the last P samples see the held end)
    assert u2[-10] == pytest.approx(2000.0 * -1e-3 * v, rel=1e-6)


@pytest.mark.parametrize("design", [MIMO, PID], ids=["mimo", "pid"])
def test_step_equals_replay_with_a_moving_table(design):
    rt = GantryRuntime.from_document(gantry_gains_document(design))
    r, y1, y2 = _signals(3000)
    x = np.linspace(-0.35, 0.33, r.size)  # crosses the whole table and both clamped ends
    stepped = _step_all(rt, rt.previewed(r), y1, y2, x)
    u1, u2 = rt.replay(r, y1, y2, x)
    scale = np.abs(stepped).max()
    assert np.allclose(stepped[:, 0], u1, rtol=1e-10, atol=1e-12 * scale)
    assert np.allclose(stepped[:, 1], u2, rtol=1e-10, atol=1e-12 * scale)


def test_schedule_interpolates_linearly_and_clamps():
    rt = GantryRuntime.from_document(gantry_gains_document(MIMO))
    for x in (-0.123, 0.0, 0.271):
        row = rt.schedule_at(x)
        assert row[:2] == pytest.approx(MODEL.alpha(x), rel=1e-12)  # alpha is linear in x: exact
        assert row[2] == pytest.approx(np.interp(x, MIMO.schedule.x, MIMO.schedule.m11), rel=1e-12)
        assert row[2] == pytest.approx(MODEL.at(x).M[0, 0], rel=1e-3)  # M(x) is quadratic in x: close
    assert rt.schedule_at(-5.0) == pytest.approx(rt.schedule_at(-0.3))
    assert rt.schedule_at(5.0) == pytest.approx(rt.schedule_at(0.3))
    with pytest.raises(UsageError):
        rt.schedule_at(float("nan"))


# ------------------------------------------------------------------------------------------ axis
def test_axis_runtime_equals_scipy_evaluation_of_the_designed_controller():
    rt = AxisRuntime.from_document(axis_gains_document(AXIS))
    c = AXIS.controller_discrete()
    n = int(0.4 * FS)
    k = np.arange(n)
    for f0 in (30.0, 130.0):
        e = np.cos(2 * np.pi * f0 * k / FS)
        u = rt.replay(np.zeros(n), -e)
        tail = k > n - 1500
        X = np.column_stack([np.cos(2 * np.pi * f0 * k[tail] / FS), -np.sin(2 * np.pi * f0 * k[tail] / FS),
                             np.ones(tail.sum())])
        coef = np.linalg.lstsq(X, u[tail], rcond=None)[0]
        _, expected = freqz_zpk(c.zeros, c.poles, c.gain, worN=[f0], fs=FS)
        assert complex(coef[0], coef[1]) == pytest.approx(expected[0], rel=1e-6)
    # feedforward: m_x a for a parabola tracked perfectly (the pre-filter offset is zero on a parabola's
    # steady state only for k_vel = 0, so use a design without pre-filter)
    rt0 = AxisRuntime.from_document(axis_gains_document(design_loopshape(0.6977, crossover_hz=130, pm_deg=35)))
    xr = 0.5 * 3.0 * (np.maximum(np.arange(200) - 5, 0) / FS) ** 2
    p = rt0.previewed(xr)
    rt0.reset()
    u = np.array([rt0.step(a, b) for a, b in zip(p, xr, strict=True)])
    assert np.allclose(u[5:-2], 0.6977 * 3.0, rtol=1e-9)
    r, y1, _ = _signals(2000)
    rt.reset()
    stepped = np.array([rt.step(a, b) for a, b in zip(rt.previewed(r), y1, strict=True)])
    assert np.allclose(stepped, rt.replay(r, y1), rtol=1e-10, atol=1e-12 * np.abs(stepped).max())


# ------------------------------------------------------------------------------------- files and errors
@pytest.mark.parametrize("ext", ["toml", "json"])
def test_file_round_trip(tmp_path, ext):
    doc = gantry_gains_document(MIMO)
    path = tmp_path / f"mimo.{ext}"
    write_document(path, doc)
    from_file = load_runtime(path)
    assert isinstance(from_file, GantryRuntime) and from_file.source == str(path)
    r, y1, y2 = _signals(500)
    x = np.linspace(-0.1, 0.1, r.size)
    a = from_file.replay(r, y1, y2, x)
    b = GantryRuntime.from_document(doc).replay(r, y1, y2, x)
    assert np.array_equal(a[0], b[0]) and np.array_equal(a[1], b[1])
    axis = tmp_path / f"axis.{ext}"
    write_document(axis, axis_gains_document(AXIS))
    assert isinstance(load_runtime(axis), AxisRuntime)
    d = from_file.to_dict()
    assert d["controller"] == "mimo" and d["units"]["beta"] == "V/(m/s)" and d["preview_samples"] == 2


def test_dispatch_on_kind():
    assert isinstance(load_runtime(gains_document(design_mcppc(THESIS_TABLE_3_1))), GainsRuntime)
    assert isinstance(load_runtime(gantry_gains_document(PID)), GantryRuntime)
    assert isinstance(load_runtime(axis_gains_document(AXIS)), AxisRuntime)


def _broken(mutate):
    doc = copy.deepcopy(gantry_gains_document(MIMO))
    mutate(doc)
    return doc


@pytest.mark.parametrize("mutate, words", [
    (lambda d: d.update(kind="lathe"), "kind 'lathe'"),
    (lambda d: d.update(schema="feedtune.gains/2"), "comes from a newer feedtune"),
    (lambda d: d.update(controller="lqr"), "controller: expected one of 'mimo', 'pid', got 'lqr'"),
    (lambda d: d.pop("schedule"), "schedule is missing"),
    (lambda d: d["filters"].pop("lead_sos"), "filters.lead_sos"),
    (lambda d: d["reference"].pop("acceleration_sos"), "reference.acceleration_sos"),
    (lambda d: d["gains"].pop("beta"), "gains.beta"),
    (lambda d: d["gains"].update(beta={"value": 1.0, "unit": "N"}), "gains.beta"),
    (lambda d: d["schedule"].update(x=list(reversed(d["schedule"]["x"]))), "strictly increasing"),
    (lambda d: d["schedule"].update(alpha1=[0.5]), "schedule.alpha1"),
    (lambda d: d["sampling"].update(delay_samples=-1), "delay_samples"),
    (lambda d: d["filters"].update(filter_pack_sos=[[1, 2, 3]]), "filters.filter_pack_sos[0]: expected at least 6"),
])
def test_bad_files_give_one_line_errors(mutate, words):
    with pytest.raises(DataError) as info:
        load_runtime(_broken(mutate), "g.toml")
    msg = str(info.value)
    assert words in msg and "g.toml" in msg and "\n" not in msg


def test_wrong_target_rate():
    rt = GantryRuntime.from_document(gantry_gains_document(MIMO), "mimo.toml")
    rt.check_target(15000.0)
    with pytest.raises(DataError, match=r"15000 Hz.*20000"):
        rt.check_target(20000.0)
    with pytest.raises(DataError, match="design again with fs=8000") as err:
        AxisRuntime.from_document(axis_gains_document(AXIS)).check_target(8000.0)
    assert err.value.parameter == "fs"
