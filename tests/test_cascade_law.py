"""The drive cascade's law, written once (machines/cascade/law.py), held to itself in every place it runs: the twin's
compiled closed loop against the same loop interpreted, the runtime's per-sample step and its vectorised replay (a
second implementation: numpy over the position samples, a cumulative sum, sosfilt) against the twin's recorded
commands, the C header in double (1e-9 of the peak command) and in float (FLOAT_ERROR_BOUND) -- with the position loop
at an eighth of the speed loop's rate and on the load encoder of a two-mass axis. The executed law is also held to
the transfer functions the analysis uses (steady-state sine responses) and its filters to scipy's prewarped bilinear
transform."""

from __future__ import annotations

import shutil
import subprocess

import numpy as np
import pytest
from c_compile import WARNINGS, compile_c, sanitizer_flags

from feedtune.control.cascade import CascadeLaw, drive_filter_sos
from feedtune.control.drive_tuning import Pt1Filter, Pt2Filter, SecondOrderFilter
from feedtune.design.cascade import design_cascade
from feedtune.export.c_common import FLOAT_ERROR_BOUND
from feedtune.export.c_header import c_header
from feedtune.machines import load_runtime
from feedtune.machines.cascade.twin import CascadeTwin
from feedtune.models import THESIS_TABLE_3_1
from feedtune.models.rigid import RigidBodyModel
from feedtune.workflows.deliver import deliver

GCC = shutil.which("gcc")
needs_gcc = pytest.mark.skipif(GCC is None, reason="gcc not installed")
FILTERS = (SecondOrderFilter(420.0, 0.05, 420.0, 0.5), SecondOrderFilter(900.0, 0.2, 1200.0, 0.4),
           Pt2Filter(2000.0, 0.7), Pt1Filter(5e-5), Pt2Filter(300.0, 0.5, enabled=False))
FS = 8000.0


def _doc(plant, encoder: str = "motor", **gains) -> dict:
    values = {"kp": 0.8, "tn_s": 0.012, "kv": 60.0, "fs": FS, "position_ratio": 8, "delay_samples": 1,
              "filters": FILTERS, "position_encoder": encoder, **gains}
    return deliver(design_cascade(plant, **values)).document


TWO_MASS = THESIS_TABLE_3_1  # V, rad: x1 motor, x2 load (the table's screw angle)
RIGID = RigidBodyModel(mass=1.2e-4, viscous=7.03e-5, command_unit="N*m", position_unit="rad")
DOCS = {
    "two-mass, motor encoder": (TWO_MASS, _doc(TWO_MASS, kp=0.8)),
    "two-mass, load encoder": (TWO_MASS, _doc(TWO_MASS, "load", kp=0.8, kv=40.0)),
    "rigid rotary, N m": (RIGID, _doc(RIGID, kp=0.05, tn_s=0.01, kv=80.0)),
}


def _setpoint(n: int, amp: float = 0.2) -> np.ndarray:
    """A smooth move, a hold, a move back and a small step (the position loop and both feedforwards busy)."""
    t = np.arange(n) / FS
    r = amp * 0.5 * (1 - np.cos(np.pi * np.clip(t / 0.1, 0, 1)))
    back = amp * 0.5 * (1 - np.cos(np.pi * np.clip((t - 0.2) / 0.08, 0, 1)))
    return r - back + 1e-3 * (t > 0.35)


def _run(name: str, engine: str):
    model, doc = DOCS[name]
    twin = CascadeTwin(_plant(doc), FS, 1)
    n = 3600
    d = np.where(np.arange(n) > 2000, 0.02 if model is RIGID else 0.3, 0.0)  # a load step
    return twin.simulate(load_runtime(doc), _setpoint(n), disturbance=d, engine=engine), doc


def _plant(doc):
    from feedtune.io.cascade_gains import cascade_from_document

    return cascade_from_document(doc)[1]


@pytest.mark.parametrize("name", list(DOCS))
def test_compiled_twin_loop_runtime_and_replay_agree_sample_by_sample(name):
    compiled, doc = _run(name, "numba")
    python, _ = _run(name, "python")
    peak = np.max(np.abs(compiled.u))
    assert peak > 0 and np.max(np.abs(compiled.x1 - compiled.r)) < 0.2  # it moves and follows
    assert np.max(np.abs(compiled.u - python.u)) <= 1e-12 * peak
    assert np.max(np.abs(compiled.x1 - python.x1)) <= 1e-12 * np.max(np.abs(compiled.x1))
    rt = load_runtime(doc)
    stepped = np.array([rt.step(r, a, b) for r, a, b in zip(compiled.r, compiled.x1, compiled.x2, strict=True)])
    assert np.max(np.abs(stepped - compiled.u)) <= 1e-12 * peak
    replayed = rt.replay(compiled.r, compiled.x1, compiled.x2)
    assert np.max(np.abs(replayed - compiled.u)) <= 1e-9 * peak


def test_a_wrong_twin_misses_the_runtime():
    """The comparison can fail: a runtime with another position ratio gives other commands on the same run."""
    run, doc = _run("two-mass, motor encoder", "numba")
    other = dict(doc, position_loop={**doc["position_loop"], "ratio": 4})
    other.pop("certificate", None)
    u = load_runtime(other).replay(run.r, run.x1, run.x2)
    assert np.max(np.abs(u - run.u)) > 1e-3 * np.max(np.abs(run.u))


MAIN = r"""
#include <stdio.h>
#include "gains.h"
int main(void) {
    ft_state s; ft_init(&s);
    double r, x1, x2;
    while (scanf("%lf %lf %lf", &r, &x1, &x2) == 3) printf("%.17g\n", (double)ft_step(&s, (REAL)r, (REAL)x1, (REAL)x2));
    return 0;
}
"""


def _run_c(tmp_path, header: str, inputs: np.ndarray, real: str) -> np.ndarray:
    (tmp_path / "gains.h").write_text(header)
    (tmp_path / "main.c").write_text(f"#define REAL {real}\n" + MAIN)
    exe = tmp_path / f"prog_{real}"
    if real == "double":
        compile_c(GCC, tmp_path / "main.c", exe, opt="-O2")
    else:
        cmd = [GCC, *WARNINGS, "-Wdouble-promotion", "-O2", *sanitizer_flags(GCC), "-o", str(exe),
               str(tmp_path / "main.c"), "-lm"]
        res = subprocess.run(cmd, capture_output=True, text=True, cwd=tmp_path)
        assert res.returncode == 0, res.stderr
    text = "\n".join(" ".join(repr(float(v)) for v in row) for row in inputs) + "\n"
    out = subprocess.run([str(exe)], input=text, check=True, capture_output=True, text=True).stdout
    return np.array([float(v) for v in out.split()])


@needs_gcc
@pytest.mark.parametrize("name", list(DOCS))
def test_c_header_executes_the_law_double_to_1e9_and_float_within_its_bound(tmp_path, name):
    run, doc = _run(name, "numba")
    inputs = np.column_stack([run.r, run.x1, run.x2]).astype(np.float32).astype(float)  # float-representable
    rt = load_runtime(doc)
    u = np.array([rt.step(*row) for row in inputs])
    peak = np.max(np.abs(u))
    double = _run_c(tmp_path, c_header(doc), inputs, "double")
    assert np.max(np.abs(double - u)) <= 1e-9 * peak
    single = _run_c(tmp_path, c_header(doc, precision="float"), inputs, "float")
    err = np.max(np.abs(single - double)) / peak
    assert err <= FLOAT_ERROR_BOUND, f"float header {err:.2e} of the peak command"


@needs_gcc
def test_c_header_clamps_and_holds_the_integral(tmp_path):
    _, doc = DOCS["rigid rotary, N m"]
    n = 2000
    inputs = np.column_stack([np.full(n, 1.0), np.zeros(n), np.zeros(n)])  # 1 rad away, the axis stuck
    header = c_header(doc, u_max=0.1, anti_windup="clamp")
    u = _run_c(tmp_path, header, inputs, "double")
    assert np.max(np.abs(u)) <= 0.1 and np.all(u[5:] == 0.1)
    free = _run_c(tmp_path, c_header(doc), inputs, "double")
    assert free[-1] > 10 * free[5]  # without the clamp the integral winds up


# ------------------------------------------------------------------ the law against its transfer functions
def _steady_gain(law, f: float, quantity: str) -> complex:
    """The executed law's response to a sine of the motor position (speed loop alone: Kv = 0, no feedforward):
    ``u / x1`` from the last period of a long run, by a single-bin DFT."""
    from feedtune.design.cascade import CascadeDesign, cascade_plant
    from feedtune.io.cascade_gains import cascade_gains_document

    doc = cascade_gains_document(CascadeDesign(law, cascade_plant(RIGID)))
    rt = load_runtime(doc)
    n_per = round(FS / f)
    f = FS / n_per
    k = np.arange(40 * n_per)
    x = np.sin(2 * np.pi * f * k / FS)
    u = rt.replay(np.zeros(k.size), x)
    last = slice(-n_per, None)
    e = np.exp(-2j * np.pi * f * k[last] / FS)
    return complex(np.sum(u[last] * e) / np.sum(x[last] * e))


@pytest.mark.parametrize("f", [3.0, 40.0, 421.0, 1300.0])
def test_executed_speed_loop_is_the_analysed_transfer_function(f):
    """u = -C(z) D(z) x1 with C the PI and filters as executed, D the backward difference: the time-domain law and
    the analysis' discrete responses agree to 1e-9 (a long-tailed integral would not: Tn is short here)."""
    law = CascadeLaw(0.05, 0.004, FILTERS, 0.0, FS, 8, 1, 0.0, 0.0, "motor", "N*m", "rad")
    n_per = round(FS / f)
    fx = FS / n_per
    expected = -law.speed_controller_response([fx], True)[0] * law.speed_measurement([fx], True)[0]
    got = _steady_gain(law, fx, "position")
    assert abs(got - expected) <= 1e-6 * abs(expected)


def test_filters_are_scipys_prewarped_bilinear_transform():
    from scipy.signal import bilinear

    for flt, num, den, f0 in (
        (Pt2Filter(1000.0, 0.7), [1.0], [1.0, 1.4, 1.0], 1000.0),
        (Pt1Filter(1e-4), [1.0], [1.0, 1.0], 1 / (2 * np.pi * 1e-4)),
    ):
        w = 2 * FS * np.tan(np.pi * f0 / FS)  # prewarped corner [rad/s]
        order = len(den) - 1
        b, a = bilinear(num, [c / w ** (order - i) for i, c in enumerate(den)], fs=FS)
        ref = np.r_[np.pad(b, (0, 3 - b.size)), np.pad(a, (0, 3 - a.size))] / a[0]
        assert np.allclose(drive_filter_sos(flt, FS), ref, rtol=1e-12, atol=1e-15)
    notch = drive_filter_sos(SecondOrderFilter(440.0, 0.03, 440.0, 0.3), FS)
    zi = np.exp(-2j * np.pi * 440.0 / FS)
    h = (notch[0] + notch[1] * zi + notch[2] * zi**2) / (1 + notch[4] * zi + notch[5] * zi**2)
    assert abs(abs(h) - 0.1) < 1e-12  # the notch's depth zeta_z / zeta_p exactly at its frequency


def test_filter_at_or_above_nyquist_is_refused():
    from feedtune.errors import UsageError

    with pytest.raises(UsageError, match="Nyquist"):
        CascadeLaw(1.0, 0.01, (Pt2Filter(4000.0, 0.7),), fs=FS)
