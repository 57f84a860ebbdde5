"""One gantry law (issue 11): the compiled twin loop, the Python loop and the runtime replayed on a recorded run give
the same commands sample by sample, for the MIMO law (with its pre-filter and the schedule across the table's
travel), the independent PIDs and the x axis, each with and without its Stribeck friction feedforward.

The laws themselves are checked against independent descriptions elsewhere: the runtime against the designed transfer
functions with scipy (tests/test_gantry_runtime.py) and the C header against the runtime (tests/test_export_c_kinds.py).
"""

from __future__ import annotations

import numpy as np
import pytest

from feedtune.control.filters import FilterPack, LeadStage, Notch
from feedtune.control.prefilter import PrefilterGains
from feedtune.design.gantry_mimo import design_gantry_mimo
from feedtune.design.gantry_pid import design_gantry_pid
from feedtune.design.loopshape import design_loopshape
from feedtune.io.gantry_gains import axis_gains_document, gantry_gains_document
from feedtune.machines import load_runtime
from feedtune.machines.gantry.twin import GantryTwin, GantryTwinParams
from feedtune.models.friction import FrictionLaw
from feedtune.models.gantry import THESIS_GANTRY
from feedtune.sim.engine import numba_available
from feedtune.sim.trajectory import multi_segment

H = FilterPack([Notch(110, 0.5, 0.7), Notch(320, 0.2, 0.9), Notch(400, 0.15, 1.0), Notch(940, 0.6, 0.75)], 450.0, 2,
               0.7, [LeadStage(154.0, 70.0)])
PRE1, PRE2 = PrefilterGains(2e-3, 1e-5, 1e-8, 0.0), PrefilterGains(-1e-3, 2e-5, 0.0, 1e-10)
MIMO_DESIGN = design_gantry_mimo(THESIS_GANTRY, filters=H, prefilter1=PRE1, prefilter2=PRE2)
PID_DESIGN = design_gantry_pid(THESIS_GANTRY, kp=(6e3, 5e3), kd=(40.0, 35.0), ki=(3e4, 2.5e4),
                               filters=FilterPack([], 900.0))
MIMO = load_runtime(gantry_gains_document(MIMO_DESIGN))
PID = load_runtime(gantry_gains_document(PID_DESIGN))
GANTRY_FRICTION_MODEL = FrictionLaw(0.3, 0.5, -0.35, -0.55, 0.01, 0.02, command_unit="V", velocity_unit="m/s",
                                    viscous_pos=1.2, viscous_neg=0.9)
"""An asymmetric friction of the gantry's travel [V, m/s] with viscous friction [V/(m/s)], fed forward with a 1e-3 m/s
band."""
MIMO_FRICTION = load_runtime(gantry_gains_document(MIMO_DESIGN.with_friction(GANTRY_FRICTION_MODEL, v_band=1e-3)))
PID_FRICTION = load_runtime(gantry_gains_document(PID_DESIGN.with_friction(GANTRY_FRICTION_MODEL, v_band=1e-3)))
AXIS_DESIGN = design_loopshape(
    THESIS_GANTRY.m_x, crossover_hz=130.0, pm_deg=35.0,
    filters=FilterPack([Notch(186, 0.6, 0.7), Notch(332, 0.3, 0.7), Notch(404, 0.2, 0.7)], 1200.0),
    prefilter=PrefilterGains(1e-3, 1e-6, 0.0, 0.0))
AXIS = load_runtime(axis_gains_document(AXIS_DESIGN))
AXIS_FRICTION = load_runtime(axis_gains_document(AXIS_DESIGN.with_friction(
    FrictionLaw(0.2, 0.35, -0.25, -0.4, 0.01, 0.02, command_unit="V", velocity_unit="m/s", viscous_pos=0.8,
                viscous_neg=1.1), v_band=1e-3)))
needs_numba = pytest.mark.skipif(not numba_available(), reason="numba not installed")


def _references(fs: float, n: int):
    """A 30 mm y move and an x move from -0.2 to 0.25 m across the schedule's grid."""
    y = multi_segment([0.0, 0.03, 0.0], v_max=0.2, a_max=2.0, j_max=50.0, fs=fs, dwell=0.02).pos
    x = multi_segment([-0.2, 0.25], v_max=0.5, a_max=5.0, j_max=100.0, fs=fs).pos
    return [np.r_[a, np.full(max(0, n - a.size), a[-1])][:n] for a in (y, x)]


@needs_numba
@pytest.mark.parametrize(("gantry", "axis"), [(MIMO, AXIS), (PID, AXIS), (MIMO, AXIS_FRICTION),
                                             (MIMO_FRICTION, AXIS_FRICTION), (PID_FRICTION, AXIS)],
                         ids=["mimo", "pid", "mimo+axis-friction", "mimo-friction+axis-friction", "pid-friction"])
def test_compiled_loop_python_loop_and_replay_give_the_same_commands(gantry, axis):
    # no clamp and no overload trip: the recorded commands are the laws' outputs over the whole run
    twin = GantryTwin(GantryTwinParams(u_max=None, overload_rms=None, envelope_m=0.05))
    n = int(1.2 * twin.fs)
    y, x = _references(twin.fs, n)
    fast = twin.simulate(gantry, axis, y, x_ref=x, engine="numba")
    slow = twin.simulate(gantry, axis, y, x_ref=x, engine="python")
    assert not fast.tripped and not slow.tripped
    assert np.ptp(fast.x) > 0.4  # the schedule is interpolated across most of the table's travel
    for name in ("u1", "u2", "ux", "y1", "y2", "x"):
        a, b = getattr(fast, name), getattr(slow, name)
        assert np.max(np.abs(a - b)) <= 1e-9 * np.max(np.abs(a)), name
    # open-loop replay: the runtime, given the recorded readings, computes the recorded commands
    y0, x0 = fast.y_ref[0], fast.x_ref[0]
    u1, u2 = gantry.replay(fast.y_ref - y0, fast.y1 - y0, fast.y2 - y0, fast.x)
    ux = axis.replay(fast.x_ref - x0, fast.x - x0)
    for got, rec in ((u1, fast.u1), (u2, fast.u2), (ux, fast.ux)):
        assert np.max(np.abs(got - rec)) <= 1e-9 * np.max(np.abs(rec))


@needs_numba
def test_a_trip_happens_at_the_same_sample_in_both_loops():
    unstable = load_runtime(gantry_gains_document(design_gantry_pid(
        THESIS_GANTRY, kp=(2e6, 2e6), kd=(0.0, 0.0), ki=(0.0, 0.0), filters=FilterPack([], 900.0))))
    twin = GantryTwin()
    n = int(0.2 * twin.fs)
    y, x = _references(twin.fs, n)
    fast = twin.simulate(unstable, AXIS, y, x_ref=x, engine="numba")
    slow = twin.simulate(unstable, AXIS, y, x_ref=x, engine="python")
    assert fast.tripped and slow.tripped and fast.t.size == slow.t.size
    assert fast.trip_message == slow.trip_message
