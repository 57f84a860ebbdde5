"""The library as a notebook uses it: one import, short reprs, attribute access, DataFrames, ``.plot()`` and
python-control, on the example FRF (issue 15)."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import matplotlib
import numpy as np
import pytest

matplotlib.use("Agg")

import feedtune
from feedtune import (
    THESIS_FILTER_PACK,
    DataError,
    DesignError,
    UsageError,
    analyze_ballscrew,
    design_mcppc,
    design_ppi,
    fit_ballscrew,
    read_frf,
)
from feedtune.display import number
from feedtune.errors import cli_message

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


@pytest.fixture(scope="module")
def flow():
    frf = read_frf(EXAMPLES / "ballscrew_frf.csv")
    fit = fit_ballscrew([frf])
    design = design_mcppc(fit.model, beta=4, pole_hz=50, zeta=0.7, filters=THESIS_FILTER_PACK)
    law = design.law()
    return {"frf": frf, "model": fit.model, "design": design, "law": law,
            "analysis": analyze_ballscrew(law, fit.model, frf)}


# ------------------------------------------------------------------------------------------ the public API
def test_the_public_api_is_importable_from_the_package_and_listed():
    for name in ("read_frf", "read_log", "fit_ballscrew", "design_mcppc", "design_ppi", "analyze_ballscrew",
                 "tune_mcppc", "tune_ppi", "analyze_gantry", "to_control", "from_control", "BallScrewModel"):
        assert name in feedtune.__all__ and name in dir(feedtune) and callable(getattr(feedtune, name)), name
    assert feedtune.design_mcppc is design_mcppc
    with pytest.raises(AttributeError, match="no attribute 'nope'"):
        feedtune.nope  # noqa: B018


def test_import_feedtune_stays_light():
    code = ("import sys, json, feedtune; print(json.dumps([m for m in ('feedtune.design.mcppc', 'feedtune.analysis',"
            " 'matplotlib', 'pandas', 'scipy', 'control') if m in sys.modules]))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert json.loads(out) == []


# ------------------------------------------------------------------------------------------ reprs
def test_reprs_are_short_and_carry_the_key_numbers(flow):
    frf, model, law, analysis = flow["frf"], flow["model"], flow["law"], flow["analysis"]
    text = repr(frf)
    assert "x1/u x2/u" in text and "2x1" in text and "1500 lines" in text and "1-2000 Hz" in text and "rad/V" in text
    text = repr(model)
    assert f"k={number(model.k)} V/rad" in text and f"mode {number(model.modes()[0].freq_hz)} Hz" in text
    text = repr(law)
    assert f"Kx1={number(law.gains['Kx1'])} U/rad" in text and "fs=20000 Hz" in text
    text = repr(analysis)
    for name, case in analysis.cases.items():
        assert name in text and number(case.ms) in text and number(case.metrics.phase_margin_deg) in text
    for obj in (frf, model, law, analysis, analysis.discrete, feedtune.THESIS_GANTRY, feedtune.THESIS_GANTRY.at(0.1)):
        assert "array(" not in repr(obj) and len(repr(obj)) < 700, repr(obj)
    assert "<table>" in frf._repr_html_() and "<table>" in analysis._repr_html_()


def test_fit_and_design_reprs_are_one_line_with_units(flow):
    """The identification result and the designs: the numbers an engineer checks first, each with its unit."""
    from feedtune.design.ppi import design_ppi

    fit = fit_ballscrew([flow["frf"]])
    text = repr(fit)
    lo, hi = fit.band_hz
    assert text.startswith("BallScrewFit(BallScrewModel(") and f"band {number(lo)}-{number(hi)} Hz" in text
    assert f"x1/u {number(100 * fit.fit['x1/u']['nrmse'])} %" in text and "warning" in text
    design = flow["design"]
    text = repr(design)
    assert text.startswith("McppcDesign(beta=4, pole_hz=50 Hz, zeta=0.7, ")
    assert f"Kx1={number(design.gains['Kx1'])} V/rad" in text and f"Ki2={number(design.gains['Ki2'])} V/(rad s)" in text
    assert "notches 420, 1080 Hz, low-pass 2000 Hz (order 1)" in text and "fs=20000 Hz" in text
    ppi = design_ppi(fit.model, Kpx=150.0, Kpv=0.5, Kiv=40.0, filters=THESIS_FILTER_PACK)
    text = repr(ppi)
    assert "Kpx=150 1/s" in text and "Kpv=0.5 V/(rad/s)" in text and "Kiv=40 V/rad" in text
    for obj in (fit, design, ppi):
        assert "\n" not in repr(obj) and "array(" not in repr(obj) and len(repr(obj)) < 500, repr(obj)


# ------------------------------------------------------------------------------------------ figures by attribute
def test_metrics_by_attribute_equal_to_dict(flow):
    analysis = flow["analysis"]
    d = analysis.to_dict()
    assert analysis.discrete.ms == d["discrete"]["ms"]
    assert analysis.cases["discrete"].gain_margin_db == d["discrete"]["gain_margin_db"]
    assert analysis.ideal.disturbance_min_real_rad_per_V == d["ideal"]["disturbance_min_real_rad_per_V"]
    assert analysis.discrete is analysis.cases["discrete"]
    assert "discrete" in dir(analysis) and "gain_margin_db" in dir(analysis.discrete)
    with pytest.raises(AttributeError, match="cases: ideal, ideal_discrete, measured, discrete"):
        analysis.nope  # noqa: B018
    with pytest.raises(AttributeError, match="no attribute or figure 'nope'"):
        analysis.discrete.nope  # noqa: B018


def test_dataframes(flow):
    frf, analysis = flow["frf"], flow["analysis"]
    df = analysis.to_dataframe()
    assert list(df.index) == ["ideal", "ideal_discrete", "measured", "discrete"]
    assert df.loc["discrete", "ms"] == analysis.discrete.ms and bool(df.loc["ideal", "stable"])
    fd = frf.to_dataframe()
    np.testing.assert_array_equal(fd.index.to_numpy(), frf.freq_hz)
    np.testing.assert_array_equal(fd["x2/u"].to_numpy(), frf.channel("x2/u"))
    assert fd.attrs["units"]["x2/u"] == "rad/V" and "coherence x1/u" in fd
    log = feedtune.point_to_point(0.02, v_max=0.2, a_max=9.81, j_max=500, fs=20000).to_log()
    ld = log.to_dataframe()
    np.testing.assert_array_equal(ld["v_ref"].to_numpy(), log["v_ref"])
    assert ld.index.name == "t" and ld.attrs["units"]["a_ref"] == "m/s^2"


# ------------------------------------------------------------------------------------------ figures
def _labels(fig) -> list[str]:
    return [ax.get_ylabel() for ax in fig.axes]


def test_plots_return_figures_with_units(flow):
    from matplotlib.figure import Figure

    frf, model, law, analysis = flow["frf"], flow["model"], flow["law"], flow["analysis"]
    figures = {
        "frf": frf.plot(),
        "model": model.plot(frf=frf),
        "law": law.plot(),
        "case": analysis.discrete.plot("nyquist"),
        **{kind: analysis.plot(kind) for kind in ("loop", "nyquist", "sensitivity", "tracking", "disturbance")},
    }
    for name, fig in figures.items():
        assert isinstance(fig, Figure), name
        assert all("[" in label and "]" in label for label in _labels(fig) if label), (name, _labels(fig))
    assert "|x1/u| [dB re 1 rad/V]" in _labels(figures["frf"]) and "|S| [dB]" in _labels(figures["sensitivity"])
    assert len(figures["loop"].axes[0].lines) >= 4  # one curve per case (and the crossover marks)
    figures["frf"].savefig(Path("/dev/null"), format="png")
    with pytest.raises(UsageError, match="kind must be one of"):
        analysis.plot("bode")
    with pytest.raises(DataError, match="no channel 'x3/u'"):
        frf.plot(["x3/u"])


def test_other_value_types_plot(flow):
    from feedtune.io.gains import gains_document
    from feedtune.machines.ballscrew.experiments import run_ropesnap

    gantry = feedtune.THESIS_GANTRY
    assert "sigma(S) [dB]" in _labels(feedtune.analyze_gantry(
        feedtune.design_gantry_mimo(gantry, crossover_hz=60, pm_deg=40, damping_increase=5.9).law, gantry,
        x=0.0).plot("sensitivity"))
    assert "|y2/u1| [dB re 1 m/V]" in _labels(gantry.plot(x=0.1))
    friction = feedtune.StribeckFriction(dc_pos=20.0, ds_pos=30.0, dc_neg=-18.0, ds_neg=-25.0, omega_pos=0.01)
    assert _labels(friction.plot()) == ["friction / disturbance [N]"]
    rigid = feedtune.RigidBodyModel(mass=95.0, viscous=200.0, coulomb_pos=20.0)
    assert _labels(rigid.plot()) == ["friction / disturbance [N]"]
    trajectory = feedtune.point_to_point(0.02, v_max=0.2, a_max=9.81, j_max=500, fs=20000)
    assert _labels(trajectory.plot())[:2] == ["x_ref [m]", "v_ref [m/s]"]
    runtime = feedtune.load_runtime(gains_document(flow["design"]))
    run = run_ropesnap(feedtune.get_machine("ballscrew").twin(), runtime, engine="python")
    assert repr(run).startswith("ExperimentResult('ropesnap', 22001 samples") and "peak_um=" in repr(run)
    assert _labels(run.plot()) == ["x2 [rad]", "u [V]", "d2 [V]"]


# ------------------------------------------------------------------------------------------ errors
def test_errors_are_value_errors_that_speak_of_parameters(flow):
    for cls in (DataError, UsageError, DesignError):
        assert issubclass(cls, ValueError)
    with pytest.raises(ValueError, match=r"^beta must be >= 1") as err:
        design_mcppc(flow["model"], beta=0.5, pole_hz=50, zeta=0.7)
    assert err.value.parameter == "beta" and "--" not in str(err.value)
    assert cli_message(err.value).startswith("--beta must be >= 1")
    with pytest.raises(UsageError, match="Kpv must be > 0") as err:
        design_ppi(flow["model"], Kpx=1.0, Kpv=0.0, Kiv=0.0)
    assert cli_message(err.value) == "--kpv must be > 0"
    bad = feedtune.FilterPack(lpf_hz=12000.0)
    with pytest.raises(UsageError, match="lpf_hz 12000 Hz is at or above the Nyquist frequency 10000 Hz") as err:
        design_mcppc(flow["model"], beta=4, pole_hz=50, zeta=0.7, filters=bad)
    assert cli_message(err.value).startswith("--lpf 12000 Hz")


def test_the_command_line_still_names_the_flags(tmp_path, capsys, monkeypatch):
    from cli_run import run

    from feedtune.io import save_model

    save_model(tmp_path / "m.toml", feedtune.THESIS_TABLE_3_1)
    for args, words in ((["--beta", "0.5"], "feedtune: error: --beta must be >= 1"),
                        (["--zeta", "1.5"], "feedtune: error: --zeta must be between 0 and 1"),
                        (["--lpf", "12000"], "feedtune: error: --lpf 12000 Hz is at or above the Nyquist")):
        code, _, err = run(["design", "ppc", tmp_path / "m.toml", *args], capsys, monkeypatch)
        assert code == 2 and words in err and err.count("\n") == 1, (args, err)


# ------------------------------------------------------------------------------------------ python-control
def test_round_trip_through_python_control(flow):
    ct = pytest.importorskip("control")
    frf, model, law, analysis = flow["frf"], flow["model"], flow["law"], flow["analysis"]
    back = feedtune.from_control(frf.to_control())
    np.testing.assert_array_equal(back.response, frf.response)
    np.testing.assert_allclose(back.freq_hz, frf.freq_hz, rtol=1e-15, atol=0)
    again = feedtune.BallScrewModel.from_control(model.to_control())
    for name, value in model.params().items():
        assert getattr(again, name) == pytest.approx(value, rel=1e-12, abs=1e-12 * model.k)
    # the loop as python-control builds and evaluates it, against feedtune's analysis; transfer functions (its
    # state-space solve near this model's double integrator is 1.2e-12 off exact rational arithmetic at 0.5 Hz)
    loop = law.to_control() * model.to_control("tf")[:, 0]
    ideal = analysis.ideal
    got = loop(2j * np.pi * ideal.freq_hz)
    assert np.max(np.abs(got - ideal.L) / np.abs(ideal.L)) < 1e-12
    measured = ct.series(frf.to_control(), law.to_control())
    keep = frf.freq_hz > 0
    h = np.asarray(measured.frdata if hasattr(measured, "frdata") else measured.fresp)[0, 0]
    L_lines = analysis.measured.L[:int(keep.sum())]  # the case continues above the FRF's lines
    assert np.max(np.abs(h[keep] - L_lines) / np.abs(L_lines)) < 1e-12
