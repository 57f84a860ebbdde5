"""What the demos' speed work rests on (issue 11), each against something that is not the code under test:

* ``analyze_mimo(figures="limits")`` gives exactly the figures of the full analysis that the limits policy and the
  tuners' acceptance read (the full analysis is the reference);
* every cheap necessary condition a tuner now skips candidates with never refuses a candidate the real check
  accepts (the real check, by brute force over a grid of candidates);
* the coarse-to-fine :func:`~feedtune.tune.search.highest_feasible` finds the winner and edge of the plain search
  (a plain top-down scan and bisection of every shape, written here) on synthetic problems, with fewer checks;
* :func:`~feedtune.tune.search.feasibility_edge` on a known edge with the new early exits and jumps;
* the worker processes of :mod:`feedtune.parallel` return what the serial run returns, and an error there
  is raised in the caller;
* the gantry twin's compiled loop for the holding controllers gives the same samples, bit for bit, as the same
  controllers stepped from Python.
"""

from __future__ import annotations

import math
import os

import numpy as np
import pytest

from feedtune.analysis.limits import DEFAULT_LIMITS

FS = 15000.0


# ------------------------------------------------------------------------------------------- fixtures
@pytest.fixture(scope="module")
def gantry_cases():
    """The gantry twin's model FRFs at three positions (2-1000 Hz, 400 lines), and their plant cases."""
    from feedtune.analysis.gantry import gantry_plant_cases
    from feedtune.frf import Frf
    from feedtune.models.gantry import THESIS_GANTRY as MODEL

    f = np.geomspace(2.0, 1000.0, 400)
    out = []
    for x in (-0.3, 0.0, 0.3):
        g = MODEL.frequency_response(f, x)
        frf = Frf(f, g, ("y1", "y2"), ("u1", "u2"), "position", None, "V", "m", {"source": f"model x={x}"})
        out.append((x, frf, gantry_plant_cases(MODEL, x, FS, 1, frf)))
    return MODEL, out


# ------------------------------------------------------------------------------------------- limits figures
def test_limits_figures_equal_those_of_the_full_analysis(gantry_cases):
    from feedtune.analysis.gantry import analyze_gantry_case
    from feedtune.control.filters import FilterPack, Notch
    from feedtune.control.gantry import PidLaw
    from feedtune.design.gantry_pid import pid_gains

    model, cases = gantry_cases
    pack = FilterPack([Notch(110, 0.5, 0.7)], 450.0, 2, 0.7)
    rng = np.random.default_rng(3)
    keys = ("crossovers_hz", "phase_margins_deg", "phase_margin_deg", "gain_margin_db", "gain_margins_db",
            "phase_crossovers_hz", "ms", "ms_freq_hz", "disk_margin", "disk_margin_freq_hz", "band_top_loop_gain",
            "stable", "nyquist_reliable", "warnings")
    for _ in range(6):
        bw, zeta, rho = float(np.exp(rng.uniform(np.log(2), np.log(200)))), rng.uniform(0.3, 1), rng.uniform(0.5, 10)
        law = PidLaw(**pid_gains(model, 0.0, bw, zeta, rho), filters=pack, fs=FS, delay_samples=1)
        x, _, pcs = cases[int(rng.integers(3))]
        for name, pc in pcs.items():
            full = analyze_gantry_case(law, pc, model.alpha(x)).metrics
            lim = analyze_gantry_case(law, pc, model.alpha(x), figures="limits").metrics
            for k in keys:
                assert repr(getattr(lim, k)) == repr(getattr(full, k)), (name, k)
            assert DEFAULT_LIMITS.check(lim, name) == DEFAULT_LIMITS.check(full, name)
    no_disk = analyze_gantry_case(law, pc, model.alpha(x), figures="limits", disk_margin=False).metrics
    assert no_disk.disk_margin == math.inf and no_disk.ms == full.ms
    with pytest.raises(ValueError, match="figures"):
        analyze_gantry_case(law, pc, model.alpha(x), figures="some")


# ------------------------------------------------------------------------------------------- cheap conditions
def test_the_cheap_conditions_never_refuse_a_passing_candidate(gantry_cases):
    """Brute force over a grid of bandwidths per shape: every bandwidth the real check passes is admissible."""
    from feedtune.tune import pid as pid_tuner

    model, cases = gantry_cases
    problem = pid_tuner._problem(model, 0.0, FS, 1, [frf for _, frf, _ in cases], [x for x, _, _ in cases],
                         pid_tuner.default_grid(FS), DEFAULT_LIMITS)
    search = pid_tuner._Search(problem, pid_tuner.FilterPack(), pid_tuner.ZETA_BOUNDS, pid_tuner.RHO_BOUNDS,
                               np.geomspace(0.2, 375, 24))
    passed = 0
    for zeta, rho in ((0.36, 10.0), (1.0, 0.5)):
        cheap = search.admissible(zeta, rho)
        bws = np.geomspace(50.0, 300.0, 14)
        ok = cheap(bws)
        for bw, admitted in zip(bws, ok, strict=True):
            if search.check(float(bw), zeta, rho).ok:
                passed += 1
                assert admitted, (zeta, rho, bw)
    assert passed >= 3  # the brute force met passing candidates


def test_mcppc_cheap_condition_never_refuses_a_passing_candidate():
    from feedtune.analysis.ballscrew import analyze_case, feedback_paths, loop_function, plant_cases
    from feedtune.control.filters import THESIS_FILTER_PACK
    from feedtune.design.mcppc import design_mcppc
    from feedtune.models import THESIS_TABLE_3_1 as MODEL

    f = np.geomspace(1.0, 9000.0, 800)
    pc = plant_cases(MODEL, 20000.0, 1, MODEL.frf(f))["discrete"]
    passed = 0
    for pole in np.geomspace(20.0, 200.0, 12):
        law = design_mcppc(MODEL, beta=2.0, pole_hz=float(pole), zeta=0.7, filters=THESIS_FILTER_PACK).law()
        m = analyze_case(law, pc, responses=False).metrics
        grid_ms = float(np.max(np.abs(1 / (1 + loop_function(feedback_paths(law, True), pc)(pc.freq_hz)))))
        assert grid_ms <= m.ms * (1 + 1e-12)  # the analysis' Ms is the peak over a contour holding every line
        passed += all(i.ok for i in DEFAULT_LIMITS.check(m, "discrete"))
    assert passed >= 2


# ------------------------------------------------------------------------------------------- highest_feasible
def _plain(check, shapes, lo, hi, tie, secondary):
    """The plain search of every shape (top-down scan of 16 scales, bisection to 0.2 %) and the tie rule."""
    from feedtune.tune.search import COARSE_POINTS

    scan = np.geomspace(lo, hi, COARSE_POINTS)
    bests = []
    n = 0
    for sh in shapes:
        above = None
        for s in scan[::-1]:
            n += 1
            c = check(sh, float(s))
            if c is not None and c.passed:
                lo_s, lo_c = float(s), c
                break
            above = float(s)
        else:
            continue
        hi_s = above
        while hi_s is not None and hi_s / lo_s > 1 + 2e-3:
            m = math.sqrt(lo_s * hi_s)
            n += 1
            c = check(sh, m)
            if c is not None and c.passed:
                lo_s, lo_c = m, c
            else:
                hi_s = m
        bests.append(lo_c)
    top = max(c.objective for c in bests)
    tied = [c for c in bests if c.objective >= (1 - tie) * top]
    return max(tied, key=secondary), n


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_coarse_to_fine_finds_the_plain_search_winner(seed):
    from feedtune.tune.search import Candidate, SearchRecord, highest_feasible

    rng = np.random.default_rng(seed)
    shapes = [{"k": float(k)} for k in range(12)]
    edge = {k: float(np.exp(rng.uniform(np.log(8), np.log(300)))) for k in range(12)}
    ratio = {k: float(rng.uniform(0.8, 1.3)) for k in range(12)}  # crossover per unit scale, growing with it
    gain = {k: float(rng.uniform(0, 1)) for k in range(12)}

    def check(shape, scale):
        k = int(shape["k"])
        xo = ratio[k] * scale
        return Candidate(shape, scale, None, None, xo, passed=scale <= edge[k])

    def secondary(c):
        return gain[int(c.shape["k"])]

    rec = SearchRecord()
    best = highest_feasible(check, shapes, 5.0, 500.0, rec, secondary=secondary)
    ref, n_plain = _plain(check, shapes, 5.0, 500.0, 0.02, secondary)
    assert best.shape == ref.shape and best.bandwidth == ref.bandwidth and best.objective == ref.objective
    assert rec.evaluations < n_plain
    assert len(rec.per_shape) + len(rec.skipped) == 12


def test_a_refused_winner_gets_the_next_of_the_complete_ranking():
    from feedtune.tune.search import Candidate, SearchRecord, highest_feasible

    edges = [100.0, 60.0, 20.0]

    def check(shape, scale):
        return Candidate(shape, scale, None, None, scale, passed=scale <= edges[int(shape["k"])])

    rec = SearchRecord()
    best = highest_feasible(check, [{"k": 0.0}, {"k": 1.0}, {"k": 2.0}], 5.0, 500.0, rec,
                            accept=lambda c: c.shape["k"] == 1.0)
    assert best.shape == {"k": 1.0} and abs(best.bandwidth / 60.0 - 1) < 2e-3
    assert "failed the full verification" in rec.warnings[0]


# ------------------------------------------------------------------------------------------- feasibility_edge
def test_feasibility_edge_jumps_to_the_cheap_edge_and_exits_early():
    from feedtune.tune.search import Probe, feasibility_edge

    scan = np.geomspace(0.2, 400.0, 24)
    n = {"checks": 0}

    def check(s):  # passes up to 7.3, crossover = 2 x scale
        n["checks"] += 1
        return Probe(s, s <= 7.3, 2 * s, (7.3 - s) / 7.3)

    # the cheap condition admits what passes (Ms binds): one real check just below its edge brackets the edge
    e = feasibility_edge(check, scan, start=2.0, admissible=lambda s: np.asarray(s) <= 7.3)
    assert 7.3 / 1.002 <= e.best.scale <= 7.3 and e.checks == 1
    # a start not admitted is not checked: the first check is below the cheap edge
    n["checks"] = 0
    e = feasibility_edge(check, scan, start=9.0, beat=13.0, admissible=lambda s: np.asarray(s) <= 7.3)
    assert e.best is not None and e.best.crossover_hz > 13.0 and n["checks"] == 1
    # a failing scale with a crossover below 'beat' ends the search, and says by how much
    e = feasibility_edge(check, scan, start=7.4, beat=14.9)
    assert e.pruned and e.best is None and e.bound_hz <= 14.9 and e.checks <= 2


# ------------------------------------------------------------------------------------------- workers
def test_workers_return_what_the_serial_run_returns(monkeypatch):
    from feedtune.parallel import plan, run_groups

    jobs = [(f"j{i}", (lambda i=i: {"i": i, "pid": os.getpid(), "a": np.arange(i + 3)}), float(i)) for i in range(4)]
    monkeypatch.setenv("FEEDTUNE_JOBS", "auto")
    got = run_groups(plan(jobs, processes=2))
    monkeypatch.setenv("FEEDTUNE_JOBS", "1")
    serial = run_groups(plan(jobs))
    for name, _, _ in jobs:
        assert got[name]["i"] == serial[name]["i"] and np.array_equal(got[name]["a"], serial[name]["a"])
    assert all(serial[n]["pid"] == os.getpid() for n in serial)


def test_library_callers_run_serially_unless_they_ask(monkeypatch):
    from feedtune.parallel import run_groups, usable_cores

    monkeypatch.delenv("FEEDTUNE_JOBS", raising=False)
    assert usable_cores() == 1
    got = run_groups([[("a", os.getpid)], [("b", os.getpid)]])
    assert got == {"a": os.getpid(), "b": os.getpid()}


def test_an_error_in_a_worker_is_raised_in_the_caller(monkeypatch):
    from feedtune.errors import DesignError
    from feedtune.parallel import run_groups, usable_cores

    monkeypatch.setenv("FEEDTUNE_JOBS", "auto")

    def fail():
        raise DesignError("no design in the worker")

    if usable_cores() < 2:
        pytest.skip("one core: no workers")
    with pytest.raises(DesignError, match="no design in the worker"):
        run_groups([[("a", lambda: 1)], [("b", fail)]])


def test_plan_shares_the_cost_out():
    from feedtune.parallel import plan

    groups = plan([("axis", None, 3.4), ("mimo", None, 1.4), ("pid", None, 1.0), ("own", None, 1.1)], processes=2)
    assert sorted(sorted(n for n, _ in g) for g in groups) == [["axis"], ["mimo", "own", "pid"]]


# ------------------------------------------------------------------------------------------- holding loop
def test_compiled_holding_loop_equals_the_python_stepped_controllers():
    pytest.importorskip("numba")
    from feedtune.machines.gantry import experiments
    from feedtune.machines.gantry.twin import GantryTwin

    class Holding(experiments.HoldingController):  # another type: stepped from Python around the compiled plant step
        pass

    class AxisHolding(experiments.AxisHoldingController):
        pass

    twin = GantryTwin(None)
    a = experiments.run_mass(twin, 0.3, seed=2)
    b = experiments.run_mass(twin, 0.3, seed=2, controller=Holding.for_twin(twin), axis=AxisHolding.for_twin(twin))
    assert set(a.log.signals) == set(b.log.signals)
    for k in a.log.signals:
        assert np.array_equal(a.log[k], b.log[k]), k


# ------------------------------------------------------------------------------------------- designs
def test_matched_stages_in_closed_form_equal_the_matched_transform():
    from feedtune.control.discretize import matched, matched_stages_response
    from feedtune.control.filters import LeadStage
    from feedtune.lti import Zpk

    rng = np.random.default_rng(4)
    f = np.geomspace(1.0, 7400.0, 9)
    for _ in range(100):
        fc = float(np.exp(rng.uniform(np.log(5.0), np.log(3000.0))))
        stages = [LeadStage(fc, float(rng.uniform(-85.0, 85.0))) for _ in range(int(rng.integers(0, 4)))]
        cascade = Zpk.constant(1.0)
        for s in stages:
            cascade = cascade * s.zpk()
        assert np.allclose(matched_stages_response(stages, FS, f), matched(cascade, FS).tf.freqresp(f), rtol=1e-12,
                           atol=0)
