"""The proposals' tuners (MC-PPC, gantry MIMO) against independent dense brute-force searches under the same limits.

The brute force evaluates every design of a dense grid with the full check (``check_design`` / ``check_analysis``:
stability in every case, the limits in the checked case) and keeps the highest first crossover; the tuner must reach
it within the resolution of the grid (and never stay below a feasible grid point by more than 2 %).
"""

from __future__ import annotations

import numpy as np
import pytest

from feedtune.analysis.check import check_design
from feedtune.analysis.limits import PROFILES
from feedtune.control.filters import THESIS_FILTER_PACK
from feedtune.design.mcppc import design_mcppc
from feedtune.errors import FeedtuneError
from feedtune.io import read_frf
from feedtune.models import THESIS_TABLE_3_1
from feedtune.tune.mcppc import tune_mcppc

LIMITS = PROFILES["textbook"]


@pytest.fixture(scope="module")
def example_frf(examples_dir):
    return read_frf(examples_dir / "ballscrew_frf.csv")


def _brute_mcppc(model, frf, betas, zetas, poles):
    best = 0.0
    for b in betas:
        for z in zetas:
            for p in poles:
                try:
                    d = design_mcppc(model, beta=b, pole_hz=p, zeta=z, filters=THESIS_FILTER_PACK)
                except FeedtuneError:
                    continue
                c = check_design(d, frf=frf, limits=LIMITS)
                m = c.analysis.cases[c.worst_case].metrics
                if c.ok and m.crossovers_hz:
                    best = max(best, m.crossovers_hz[0])
    return best


@pytest.mark.slow
def test_tuned_mcppc_reaches_the_best_of_a_dense_brute_force_search(example_frf):
    tuned = tune_mcppc(THESIS_TABLE_3_1, limits=LIMITS, filters=THESIS_FILTER_PACK, frf=example_frf,
                       betas=(1.0, 4.0), zetas=(0.7,))
    check = check_design(tuned, frf=example_frf, limits=LIMITS)
    assert check.ok
    got = check.analysis.cases["discrete"].metrics.crossovers_hz[0]
    assert got == pytest.approx(tuned.tuning["first_crossover_hz"], rel=1e-9)
    brute = _brute_mcppc(THESIS_TABLE_3_1, example_frf, (1.0, 4.0), (0.7,), np.geomspace(20.0, 200.0, 40))
    assert brute > 0
    assert got >= brute * (1 - 0.02)
    assert tuned.tuning["rule"].startswith("MC-PPC tuned by feedtune.tune.mcppc")
    assert tuned.tuning["active_limit"]["name"] in ("ms", "pm_deg", "gm_db")


@pytest.mark.slow
def test_thesis_mcppc_does_not_beat_the_tuned_one_under_the_same_limits(example_frf):
    """On the twin's example FRF the thesis' manual MC-PPC (beta 4, 50 Hz, zeta 0.7) crosses over near 100 Hz but
    its loop crosses again near 160 Hz with 21 deg of phase margin: it fails the thesis' own PM limit. The tuned one
    meets it with a higher first crossover and a lower Ms."""
    thesis = design_mcppc(THESIS_TABLE_3_1, beta=4, pole_hz=50, zeta=0.7, filters=THESIS_FILTER_PACK)
    tuned = tune_mcppc(THESIS_TABLE_3_1, limits=PROFILES["thesis"], filters=THESIS_FILTER_PACK, frf=example_frf)
    c = check_design(thesis, frf=example_frf, limits=PROFILES["thesis"])
    t = check_design(tuned, frf=example_frf, limits=PROFILES["thesis"])
    manual, best = c.analysis.cases["discrete"].metrics, t.analysis.cases["discrete"].metrics
    assert not c.ok and any("phase margin" in v for v in c.violations)
    assert t.ok
    assert manual.crossovers_hz[0] == pytest.approx(100.0, abs=3.0)
    assert best.crossovers_hz[0] >= manual.crossovers_hz[0]
    assert best.ms <= manual.ms


@pytest.mark.slow
def test_tuned_mcppc_reaches_the_manual_crossover_at_the_manual_ms_by_an_independent_computation():
    """Better than hand tuning, recomputed with python-control (the sampled loop of the Table 3.1 model, the
    controller's discrete transfer functions, one sample of delay): tuned at the thesis' PM limit and at the Ms of the
    thesis' manual design, the MC-PPC crosses over at least as high as the manual one, with no higher Ms."""
    pytest.importorskip("control")
    from test_tune_robust import FAMILY, MODEL, independent_figures

    thesis = design_mcppc(MODEL, beta=4, pole_hz=50, zeta=0.7, filters=THESIS_FILTER_PACK)
    c = check_design(thesis, frf=FAMILY[1], limits=PROFILES["thesis"])
    assert c.ok, c.violations
    limits = PROFILES["thesis"].override(ms_max=c.analysis.cases["discrete"].metrics.ms)
    tuned = tune_mcppc(MODEL, limits=limits, filters=THESIS_FILTER_PACK, frf=FAMILY[1])
    m_stable, m_ms, m_xo, _ = independent_figures(thesis.law(), MODEL)
    t_stable, t_ms, t_xo, t_pm = independent_figures(tuned.law(), MODEL)
    assert m_stable and t_stable
    assert m_xo == pytest.approx(100.0, abs=3.0)
    assert t_xo >= m_xo
    assert t_ms <= m_ms * 1.002
    assert t_pm >= 30.0 - 0.05
