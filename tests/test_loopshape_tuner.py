"""The x-axis loop-shaping tuner (feedtune.tune.loopshape) against an independent brute force and hand-set designs.

Independent references:

* a brute force written here over a grid of phase-margin targets, integral lags and numbers of lead stages, each
  with a top-down scan of the crossover (ratio 1.25 from ``fs/8``) and a plain bisection to 0.2 %, every design
  judged by the analysis it is judged by (``analyze_axis_case`` on the checked case, ``Limits.check``) and the
  tuner's stated acceptance rule for band-limited FRFs re-implemented here;
* the thesis' design (130 Hz, PM 35 deg, thesis §4.4.1), which meets the textbook limits;
* a measured-like FRF built here: the double integrator with a lightly damped mode in series (the gantry twin has no
  x-axis FRF: its table is a rigid mass, so its x FRF is the double integrator itself).

Tolerance: the tuner's first crossover is at least 97 % of the brute force's best (``BRUTE_TOL``).
"""

from __future__ import annotations

import json
import math
import sys

import numpy as np
import pytest

from feedtune.analysis.gantry import analyze_axis, analyze_axis_case, axis_plant_cases
from feedtune.analysis.limits import DEFAULT_LIMITS, check_cases
from feedtune.control.filters import FilterPack, Notch
from feedtune.design.loopshape import axis_plant, design_loopshape
from feedtune.errors import DesignError, UsageError
from feedtune.frf import Frf
from feedtune.tune.loopshape import PI_LAG_BOUNDS, PM_BOUNDS, STAGES, tune_loopshape

FS = 15000.0
M_X = 0.6977  # thesis x-axis mass [V/(m/s^2)]
AXIS_FILTERS = FilterPack([Notch(186, 0.6, 0.7), Notch(332, 0.3, 0.7), Notch(404, 0.2, 0.7)], 1200.0)
BRUTE_TOL = 0.03
POLICY = DEFAULT_LIMITS


def mode_frf(freq_hz: float = 600.0, zeta: float = 0.02) -> Frf:
    """``1/(m_x s^2)`` with a lightly damped mode in series, 1 Hz lines to 2 kHz [m/V]."""
    f = np.arange(1.0, 2001.0)
    s, w = 2j * np.pi * f, 2 * np.pi * freq_hz
    g = 1 / (M_X * s * s) * w * w / (s * s + 2 * zeta * w * s + w * w)
    return Frf(f, g[None, None, :], ("x",), ("u",), "position", meta={"source": "double integrator with a mode"})


def brute_force(plant, filters, policy, *, pms=None, lags=None, stages=STAGES) -> dict:
    """Best first crossover [Hz] over a grid of shapes, each at its largest passing crossover."""
    ap = axis_plant(plant)
    cases = axis_plant_cases(design_loopshape(ap, crossover_hz=10.0, pm_deg=45.0, filters=filters, fs=FS))
    name = "discrete" if cases.get("discrete") is not None else "ideal_discrete"
    pc = cases[name]
    pms = np.linspace(policy.pm_min_deg + 0.01, PM_BOUNDS[1], 5) if pms is None else pms
    lags = np.geomspace(*PI_LAG_BOUNDS, 4) if lags is None else lags
    scan = FS / 8 / 1.25 ** np.arange(0, 40)
    scan = scan[scan >= 1.0]

    def passes(xo, pm, lag, n):
        try:
            d = design_loopshape(ap, crossover_hz=xo, pm_deg=pm, pi_lag_deg=lag, filters=filters, fs=FS, stages=n)
        except (DesignError, UsageError):
            return False, math.nan
        m = analyze_axis_case(d, pc, responses=False).metrics
        ok = all(i.ok for i in policy.check(m, name))
        ok = ok and not any("not close to an integer" in w for w in m.warnings)
        top = pc.freq_hz[-1:]
        if top[0] < 0.999 * FS / 2:
            ok = ok and abs((pc.plant(top) * pc.hold(top) * d.controller_discrete().freqresp(top))[0]) <= \
                1 - 1 / policy.ms_max
        return ok, (m.crossovers_hz[0] if ok else math.nan)

    best = {"crossover_hz": 0.0}
    for n in stages:
        for pm in pms:
            for lag in lags:
                hi = None
                for xo in scan:
                    ok, x = passes(xo, pm, lag, n)
                    if ok:
                        lo, xlo = xo, x
                        break
                    hi = xo
                else:
                    continue
                while hi is not None and hi / lo > 1.002:
                    mid = math.sqrt(lo * hi)
                    ok, x = passes(mid, pm, lag, n)
                    if ok:
                        lo, xlo = mid, x
                    else:
                        hi = mid
                if xlo > best["crossover_hz"]:
                    best = {"crossover_hz": xlo, "pm_deg": pm, "pi_lag_deg": lag, "stages": n}
    return best


_TUNED: dict = {}


def _tuned(plant, filters, objective="bandwidth"):  # the brute force's objective unless told
    key = (id(plant) if isinstance(plant, Frf) else plant, repr(filters), objective)
    if key not in _TUNED:
        d = tune_loopshape(plant, limits=POLICY, filters=filters, fs=FS, objective=objective)
        _TUNED[key] = (d, d.tuning["crossover_hz"])
    return _TUNED[key]


def _judged(design, frf=None) -> float:
    full = analyze_axis(design, frf)
    checked = "discrete" if full.cases.get("discrete") is not None else "ideal_discrete"
    verdict = check_cases(POLICY, {k: None if c is None else c.metrics for k, c in full.cases.items()}, [checked])
    assert verdict.ok, verdict.violations
    return full.cases[checked].metrics.crossovers_hz[0]


# -------------------------------------------------------------------------------------------- the tests
@pytest.mark.slow
def test_quick_brute_force_on_the_double_integrator():
    d, xo = _tuned(M_X, AXIS_FILTERS)
    assert _judged(d) == pytest.approx(xo, rel=1e-9)
    bf = brute_force(M_X, AXIS_FILTERS, POLICY, pms=[30.01, 50.0], lags=[5.0, 20.0], stages=(2, 3))
    assert xo >= (1 - BRUTE_TOL) * bf["crossover_hz"], (xo, bf)


@pytest.mark.slow
@pytest.mark.parametrize("plant", ["double integrator", "double integrator, no filters", "FRF with a mode"])
def test_dense_brute_force(plant):
    filters = FilterPack() if "no filters" in plant else AXIS_FILTERS
    p = mode_frf() if "FRF" in plant else M_X
    _, xo = _tuned(p, filters)
    bf = brute_force(p, filters, POLICY)
    assert xo >= (1 - BRUTE_TOL) * bf["crossover_hz"], (xo, bf)


def test_never_below_the_thesis_design():
    thesis = design_loopshape(M_X, crossover_hz=130.0, pm_deg=35.0, filters=AXIS_FILTERS, fs=FS)
    _, xo = _tuned(M_X, AXIS_FILTERS)
    assert xo >= _judged(thesis) == pytest.approx(130.0, abs=0.5)


@pytest.mark.slow
def test_measured_frf_with_a_mode_is_checked_on_the_discrete_case():
    frf = mode_frf()
    d, xo = _tuned(frf, AXIS_FILTERS)
    t = d.tuning
    # checked to the Nyquist frequency of fs = 15 kHz: above the FRF's last line (2 kHz) on its continuation
    assert t["checked_case"] == "discrete" and t["checked_to_hz"] == pytest.approx(7500.0, rel=1e-3)
    assert _judged(d) == pytest.approx(xo, rel=1e-9)
    # the loop at the FRF's last line is small enough for the limit to hold above the band (if it rolls off)
    top = np.array([2000.0])
    pc = axis_plant_cases(d)["discrete"]
    assert abs((pc.plant(top) * pc.hold(top) * d.controller_discrete().freqresp(top))[0]) <= 1 - 1 / POLICY.ms_max


@pytest.mark.slow
def test_tuning_record_and_bounds():
    d, _ = _tuned(M_X, AXIS_FILTERS)
    t = d.tuning
    for key in ("method", "objective", "limits", "active_limit", "checked_case", "search", "warnings"):
        assert key in t
    assert t["pm_target_deg"] == pytest.approx(POLICY.pm_min_deg + 0.01)
    assert any("pi_lag_deg = 5 (lower bound)" in w for w in t["warnings"])
    assert d.design_dict()["tuning"] == t
    with pytest.raises(UsageError, match="phase-margin target"):
        tune_loopshape(M_X, pm_bounds=(20.0, 25.0))
    with pytest.raises(DesignError, match="no loop-shaping design"):
        tune_loopshape(M_X, ms_max=1.01, filters=AXIS_FILTERS)


def test_cli_loopshape_tunes_without_a_crossover(tmp_path, capsys, monkeypatch):
    from feedtune.cli.main import main
    from feedtune.io import read_document, save_model
    from feedtune.models.gantry import THESIS_GANTRY

    model_file = tmp_path / "gantry.toml"
    save_model(model_file, THESIS_GANTRY)

    def run(args):
        monkeypatch.setattr(sys, "argv", ["feedtune", *map(str, args)])
        try:
            main()
            code = 0
        except SystemExit as exc:
            code = exc.code if isinstance(exc.code, int) else 1
        out, err = capsys.readouterr()
        return code, out, err

    filt = ["--notch", "186,0.6,0.7", "--notch", "332,0.3,0.7", "--notch", "404,0.2,0.7", "--lpf", "1200"]
    out_file = tmp_path / "axis.toml"
    code, out, err = run(["design", "loopshape", model_file, *filt, "--out", out_file, "--json"])
    assert code == 0, err
    res = json.loads(out)
    assert res["check"]["ok"]
    assert res["analysis"]["ideal_discrete"]["crossovers_hz"][0] == pytest.approx(_tuned(M_X, AXIS_FILTERS,
                                                                                          "stiffness")[1],
                                                                                   rel=1e-6)
    assert read_document(out_file)["design"]["tuning"]["checked_case"] == "ideal_discrete"
    code, _, err = run(["design", "loopshape", model_file, "--crossover-hz", "130"])
    assert code == 2 and "--pm-deg" in err
