"""Tuning over several FRFs (issue 12): a ball-screw family whose axial mode moves with the table mass.

The family is built from Table 3.1 with the table mass m2 at 0.7, 1.0 and 1.3 times its value. The verdicts are
recomputed independently with python-control: each member's state space discretized with a zero-order hold
(``control.c2d``), the controller's discrete transfer functions and one sample of delay assembled as a state-space
loop, stability from the closed-loop eigenvalues and the peak sensitivity and phase margins on a dense grid.
"""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest
from test_cli import run

from feedtune.io import save_model, write_frf
from feedtune.models import THESIS_TABLE_3_1 as MODEL
from feedtune.tune.mcppc import tune_mcppc

control = pytest.importorskip("control")

SCALES = (0.7, 1.0, 1.3)
MEMBERS = [replace(MODEL, m2=MODEL.m2 * s) for s in SCALES]
F = np.logspace(0, np.log10(9000.0), 2000)
FAMILY = [m.frf(F) for m in MEMBERS]
MS_MAX, PM_MIN = 2.5, 30.0  # the textbook profile the tuner uses by default


def _loop(law, model, extra=None):
    """The sampled loop broken at the plant input as a python-control state space (ZOH plant, law, delay);
    ``extra`` is a continuous transfer function in front of the plant (an unmodelled mode)."""
    T = 1 / law.fs
    A, B, C = model.state_space()
    plant = control.ss(A, B[:, :1], C, np.zeros((2, 1)))
    if extra is not None:
        plant = control.series(control.ss(extra), plant)
    plant = control.c2d(plant, T, "zoh")
    parts = [control.ss(control.tf(*k.to_tf(), T)) for k in (law.K1d(), law.K2d())]
    add = control.ss(np.zeros((0, 0)), np.zeros((0, 2)), np.zeros((1, 0)), np.array([[1.0, 1.0]]), T)
    loop = control.series(plant, control.append(*parts), add)
    for _ in range(int(law.delay_samples)):
        loop = control.series(loop, control.ss([[0.0]], [[1.0]], [[1.0]], [[0.0]], T))
    return loop


def independent_figures(law, model, extra=None) -> tuple[bool, float, float, float]:
    """(stable by the closed-loop eigenvalues, max |S|, the first crossover [Hz] and the smallest |PM| [deg]) on
    60,000 log-spaced points."""
    loop = _loop(law, model, extra)
    stable = bool(np.all(np.abs(control.feedback(loop, 1).poles()) < 1))
    f = np.logspace(-1, np.log10(0.9999 * law.fs / 2), 60_000)
    L = np.asarray(loop.frequency_response(2 * np.pi * f).complex).ravel()
    ms = float(np.max(1 / np.abs(1 + L)))
    cross = np.flatnonzero(np.diff(np.sign(np.abs(L) - 1)))
    pm = 180.0 - np.abs(np.degrees(np.angle(L[cross])))  # distance of the phase from -180 deg
    return stable, ms, float(f[cross[0]]), float(pm.min())


def _independent(law, model, extra=None) -> tuple[bool, float, float]:
    """(stable by the closed-loop eigenvalues, max |S| and the smallest |PM| [deg])."""
    stable, ms, _, pm = independent_figures(law, model, extra)
    return stable, ms, pm


@pytest.fixture(scope="module")
def designs():
    return tune_mcppc(MODEL, frf=FAMILY[1]), tune_mcppc(MODEL, frf=FAMILY)


@pytest.mark.slow
def test_the_design_tuned_on_every_frf_meets_the_limits_on_each_by_an_independent_computation(designs):
    _, robust = designs
    for model in MEMBERS:
        stable, ms, pm = _independent(robust.law(), model)
        assert stable, model.m2
        assert ms <= MS_MAX * 1.002, model.m2
        assert pm >= PM_MIN - 0.05, model.m2
    assert robust.tuning["frfs"] == 3


@pytest.mark.slow
def test_the_design_tuned_on_the_middle_frf_alone_violates_the_limits_on_another(designs):
    middle, robust = designs
    verdicts = [_independent(middle.law(), m) for m in MEMBERS]
    assert verdicts[1][0] and verdicts[1][1] <= MS_MAX * 1.002 and verdicts[1][2] >= PM_MIN - 0.05
    broken = [not s or ms > MS_MAX * 1.002 or pm < PM_MIN - 0.05 for s, ms, pm in verdicts]
    assert broken[0] or broken[2]
    # the price of robustness: a lower guaranteed crossover than the nominal design's
    assert robust.tuning["first_crossover_hz"] < middle.tuning["first_crossover_hz"]


# ------------------------------------------------------------------ filter placement
MODE_HZ, MODE_ZETA, MODE_GAIN = 703.3, 0.005, 0.5  # between two lines of F; the resonance lifts |G| 1.5x below it


def _mode_tf():
    w = 2 * np.pi * MODE_HZ
    return control.tf([1, 2 * MODE_ZETA * w, (1 + MODE_GAIN) * w * w], [1, 2 * MODE_ZETA * w, w * w])


def _with_mode(frf):
    from feedtune.frf import Frf

    m = np.asarray(_mode_tf()(2j * np.pi * F)).ravel()
    return Frf(F, frf.response * m, frf.outputs, frf.inputs, "position", None, "V", "rad", {"source": "mode"})


@pytest.mark.slow
def test_a_lightly_damped_mode_between_lines_gets_a_notch_there_and_the_design_meets_the_limits():
    assert not np.any(np.isclose(F, MODE_HZ, rtol=1e-3))
    d = tune_mcppc(MODEL, frf=_with_mode(FAMILY[1]), filter_choice="own")
    notches = [n.freq_hz for n in d.filters.notches]
    assert any(abs(f / MODE_HZ - 1) < 0.05 for f in notches), notches
    stable, ms, pm = _independent(d.law(), MODEL, _mode_tf())
    assert stable and ms <= MS_MAX * 1.01 and pm >= PM_MIN - 0.3
    assert d.tuning["filters"]["chosen"] and d.tuning["filters"]["choice"] == "own"


def test_without_the_mode_no_notch_is_added():
    d = tune_mcppc(MODEL, frf=FAMILY[1], filter_choice="own")
    assert d.filters.notches == () and d.filters.lpf_hz is None
    assert d.tuning["filters"]["chosen"] == [] and "no notch" in d.tuning["filters"]["why"]


@pytest.mark.parametrize("structure", ["mcppc", pytest.param("ppi", marks=pytest.mark.slow)])
def test_tune_cli_certifies_every_frf_and_analyze_agrees(structure, tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    save_model("model.toml", MODEL)
    names = []
    for s, frf in zip(SCALES, FAMILY, strict=True):
        names.append(f"m2x{s}.csv")
        write_frf(frf, names[-1])
    args = ["tune", structure, "model.toml", *[a for n in names for a in ("--frf", n)], "--out", "g.toml"]
    code, out, err = run([*args, "--json"], capsys, monkeypatch)
    assert code == 0, err
    res = json.loads(out)
    assert res["controller"] == structure
    cert = res["certificate"]
    assert [c["frf"] for c in cert["frfs"]] == names and all(c["ok"] for c in cert["frfs"])
    worst = cert["worst"]
    assert worst["first_crossover_hz"] == min(c["crossovers_hz"][0] for c in cert["frfs"])
    assert worst["ms"] == max(c["ms"] for c in cert["frfs"]) <= MS_MAX
    assert worst["active_limit"]["frf"] in names
    for name, c in zip(names, cert["frfs"], strict=True):
        code, out, err = run(["analyze", "g.toml", "--frf", name, "--json", "--check"], capsys, monkeypatch)
        assert code == 0, err
        d = json.loads(out)["analysis"]["discrete"]
        assert d["ms"] == pytest.approx(c["ms"], rel=1e-9) and d["crossovers_hz"][0] == pytest.approx(
            c["crossovers_hz"][0], rel=1e-9)
    assert "[certificate]" in (tmp_path / "g.toml").read_text()
    # the report recomputes the certificate from the files: one row per FRF, the same figures
    code, _, err = run(["report", "model.toml", "g.toml", *names, "--out", "r.html"], capsys, monkeypatch)
    assert code == 0, err
    from test_report import embedded_data

    html = (tmp_path / "r.html").read_text()
    again = embedded_data(html)["design"]["g.toml"]["certificate"]
    assert "Certificate of" in html
    assert [c["frf"] for c in again["frfs"]] == names
    assert [c["ms"] for c in again["frfs"]] == pytest.approx([c["ms"] for c in cert["frfs"]], rel=1e-9)
    code, _, err = run(args, capsys, monkeypatch)  # no overwrite without --force (a usage error)
    assert code == 2 and "--force" in err and err.count("\n") == 1
    (tmp_path / "g.toml").unlink()  # the JSON twin alone is refused too, before the search (not after it)
    code, _, err = run(args, capsys, monkeypatch)
    assert code == 2 and "g.json exists" in err and not (tmp_path / "g.toml").exists()


# ------------------------------------------------------------------ the x axis (loop shaping) over several FRFs
AXIS_MASS = 0.6977  # V/(m/s^2), the thesis x axis
F_AXIS = np.logspace(0, np.log10(7000.0), 1500)


def _axis_tf(m):
    s = control.tf("s")
    w1, w2 = 2 * np.pi * 400.0, 2 * np.pi * 380.0
    return (s**2 + 2 * 0.02 * w1 * s + w1**2) / (s**2 + 2 * 0.01 * w2 * s + w2**2) / (m * s**2)


def _axis_frf(m):
    from feedtune.frf import Frf

    h = np.asarray(_axis_tf(m)(2j * np.pi * F_AXIS)).ravel()
    return Frf(F_AXIS, h[None, None, :], ("x",), ("u",), "position", None, "V", "m", {"source": f"m{m:g}"})


def _axis_independent(design, m):
    """(stable, max |S|, smallest |PM| [deg]) of the exact sampled loop: ``control.c2d`` of the axis, the
    controller's discrete sections, one sample of delay."""
    T = 1 / design.fs
    plant = control.c2d(control.ss(_axis_tf(m)), T, "zoh")
    loop = control.series(plant, control.ss(control.tf(*design.controller_discrete().to_tf(), T)),
                          control.ss([[0.0]], [[1.0]], [[1.0]], [[0.0]], T))
    stable = bool(np.all(np.abs(control.feedback(loop, 1).poles()) < 1))
    f = np.logspace(-1, np.log10(0.9999 * design.fs / 2), 60_000)
    L = np.asarray(loop.frequency_response(2 * np.pi * f).complex).ravel()
    cross = np.flatnonzero(np.diff(np.sign(np.abs(L) - 1)))
    return stable, float(np.max(1 / np.abs(1 + L))), float(np.min(180.0 - np.abs(np.degrees(np.angle(L[cross])))))


@pytest.mark.slow
def test_loopshape_tuned_on_every_frf_meets_the_limits_where_the_middle_one_does_not():
    """An axis whose mass is 0.7/1.0/1.3 times the thesis' with a resonance pair near 400 Hz. The FRFs are the
    continuous responses (no aliasing); the independent check is the exact ZOH discretization, which differs from
    the FRF's hold-and-delay case by up to 2 % in Ms for this double integrator at 15 kHz (hence the tolerance)."""
    from feedtune.tune.loopshape import tune_loopshape

    scales = (0.7, 1.0, 1.3)
    family = [_axis_frf(AXIS_MASS * s) for s in scales]
    robust = tune_loopshape(AXIS_MASS, frf=family)
    middle = tune_loopshape(AXIS_MASS, frf=family[1])
    assert robust.tuning["frfs"] == 3
    for s in scales:
        stable, ms, pm = _axis_independent(robust, AXIS_MASS * s)
        assert stable and ms <= MS_MAX * 1.02 and pm >= PM_MIN - 0.5, s
    worst = [_axis_independent(middle, AXIS_MASS * s) for s in scales]
    assert any(not st or ms > MS_MAX * 1.2 or pm < PM_MIN - 5 for st, ms, pm in worst)  # 0.7x: Ms 4.9, PM 18 deg
    assert robust.tuning["first_crossover_hz"] < middle.tuning["first_crossover_hz"]


@pytest.mark.slow
def test_tune_loopshape_cli_certifies_every_frf_and_the_design_exports(tmp_path, capsys, monkeypatch):
    from feedtune.models.gantry import THESIS_GANTRY

    monkeypatch.chdir(tmp_path)
    save_model("gantry.toml", THESIS_GANTRY)
    names = []
    for s in (0.7, 1.0, 1.3):
        names.append(f"x{s}.csv")
        write_frf(_axis_frf(AXIS_MASS * s), names[-1])
    frf_args = [a for n in names for a in ("--frf", n)]
    code, out, err = run(["tune", "loopshape", "gantry.toml", *frf_args, "--out", "axis.toml", "--json"], capsys,
                         monkeypatch)
    assert code == 0, err
    cert = json.loads(out)["certificate"]
    assert cert["worst"]["ok"] and [c["frf"] for c in cert["frfs"]] == names
    for name, c in zip(names, cert["frfs"], strict=True):
        code, out, err = run(["analyze", "axis.toml", "--frf", name, "--json", "--check"], capsys, monkeypatch)
        assert code == 0, err
        assert json.loads(out)["analysis"]["discrete"]["ms"] == pytest.approx(c["ms"], rel=1e-9)
    code, _, err = run(["export", "c", "axis.toml", "--u-max", "10"], capsys, monkeypatch)
    assert code == 0, err
    code, _, err = run(["tune", "loopshape", "gantry.toml", "--filters", "mine"], capsys, monkeypatch)
    assert code == 2 and "--filters" in err


@pytest.mark.slow
def test_loopshape_own_filters_notch_a_lightly_damped_mode_and_meet_the_limits_independently():
    """An axis with a lightly damped series mode at 242 Hz (between two lines): the tuner's own pack holds a notch
    within 5 % of it, raises the crossover over the design without filters, and the exact sampled loop meets the
    limits."""
    from feedtune.frf import Frf
    from feedtune.tune.loopshape import tune_loopshape

    s = control.tf("s")
    w = 2 * np.pi * 242.0
    tf = w * w / (s * s + 2 * 0.02 * w * s + w * w) / (AXIS_MASS * s**2)
    h = np.asarray(tf(2j * np.pi * F_AXIS)).ravel()
    assert not np.any(np.isclose(F_AXIS, 242.0, rtol=1e-3))
    frf = Frf(F_AXIS, h[None, None, :], ("x",), ("u",), "position", None, "V", "m", {"source": "mode"})
    bare = tune_loopshape(AXIS_MASS, frf=frf, objective="bandwidth")  # a notch raises the crossover (2 %)
    own = tune_loopshape(AXIS_MASS, frf=frf, filter_choice="own", objective="bandwidth")
    assert any(abs(n.freq_hz / 242.0 - 1) < 0.05 for n in own.filters.notches), own.filters
    assert own.tuning["first_crossover_hz"] > bare.tuning["first_crossover_hz"] * 1.02
    T = 1 / own.fs
    loop = control.series(control.c2d(control.ss(tf), T, "zoh"),
                          control.ss(control.tf(*own.controller_discrete().to_tf(), T)),
                          control.ss([[0.0]], [[1.0]], [[1.0]], [[0.0]], T))
    assert np.all(np.abs(control.feedback(loop, 1).poles()) < 1)
    f = np.logspace(-1, np.log10(0.9999 * own.fs / 2), 60_000)
    L = np.asarray(loop.frequency_response(2 * np.pi * f).complex).ravel()
    assert float(np.max(1 / np.abs(1 + L))) <= MS_MAX * 1.02
