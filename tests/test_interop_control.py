"""feedtune <-> python-control: FRFs, models and controllers, held to python-control's own evaluation.

The references are python-control's objects evaluated by python-control (``sys(s)``, series connections, sampling),
not copies of feedtune's formulas; feedtune's side is the analysis that ``feedtune analyze`` reports.
"""

from __future__ import annotations

import numpy as np
import pytest

ct = pytest.importorskip("control")

from feedtune import DataError, UsageError  # noqa: E402
from feedtune.analysis.ballscrew import analyze_ballscrew, zoh_plant  # noqa: E402
from feedtune.control.filters import THESIS_FILTER_PACK  # noqa: E402
from feedtune.design.mcppc import design_mcppc  # noqa: E402
from feedtune.frf import Frf  # noqa: E402
from feedtune.interop_control import (  # noqa: E402
    ballscrew_from_control,
    from_control,
    gantry_from_control,
    law_to_control,
    to_control,
    zpk_from_control,
    zpk_sections,
    zpk_to_control,
)
from feedtune.io import read_frf  # noqa: E402
from feedtune.lti import Zpk  # noqa: E402
from feedtune.models import THESIS_GANTRY, THESIS_TABLE_3_1, BallScrewModel, RigidBodyModel  # noqa: E402

MODEL = THESIS_TABLE_3_1
TOL = 1e-12


def _rel(a, b) -> float:
    return float(np.max(np.abs(np.asarray(a) - np.asarray(b)) / np.abs(np.asarray(b))))


@pytest.fixture(scope="module")
def case():
    """The thesis model, an MC-PPC law and the example FRF, analysed as ``feedtune analyze`` does."""
    from pathlib import Path

    frf = read_frf(Path(__file__).resolve().parents[1] / "examples" / "ballscrew_frf.csv")
    law = design_mcppc(MODEL, beta=4, pole_hz=50, zeta=0.7, filters=THESIS_FILTER_PACK).law()
    return frf, law, analyze_ballscrew(law, MODEL, frf)


# ------------------------------------------------------------------------------------------ FRFs
def test_frf_round_trip_is_exact(case):
    frf = case[0]
    frd = frf.to_control()
    assert isinstance(frd, ct.FrequencyResponseData)
    assert frd.output_labels == ["x1", "x2"] and frd.input_labels == ["u"]
    np.testing.assert_array_equal(frd.omega, 2 * np.pi * frf.freq_hz)
    back = Frf.from_control(frd)
    np.testing.assert_array_equal(back.response, frf.response)
    np.testing.assert_allclose(back.freq_hz, frf.freq_hz, rtol=1e-15)
    assert back.channels == frf.channels


def test_an_lti_system_becomes_an_frf_on_a_grid():
    sys = MODEL.to_control()
    f = np.logspace(0, 3, 50)
    frf = from_control(sys, "frf", freq_hz=f, input_unit="V", output_unit="rad")
    assert frf.channels == ["x1/u", "x1/d1", "x1/d2", "x2/u", "x2/d1", "x2/d2"]
    g = MODEL.frequency_response(f)
    assert _rel(frf.channel("x1/u"), g["G11"]) < TOL and _rel(frf.channel("x2/d2"), g["G23"]) < TOL
    with pytest.raises(UsageError, match="freq_hz is needed"):
        from_control(sys, "frf")


# ------------------------------------------------------------------------------------------ models
@pytest.mark.parametrize("form", ["ss", "tf"])
@pytest.mark.parametrize("model", [MODEL, BallScrewModel(1.0, 2.0, 0.1, 0.0, 1e4, 0.5),
                                   BallScrewModel(1e-3, 1e-3, 0.0, 0.0, 100.0, 0.0)])
def test_ballscrew_model_round_trip(model, form):
    sys = model.to_control(form)
    assert isinstance(sys, ct.StateSpace if form == "ss" else ct.TransferFunction)
    f = model.modes()[0].freq_hz * np.logspace(-2, 1.5, 200)  # far above the mode |G| ~ 1/f^2 ends in rounding
    s = 2j * np.pi * f
    g = model.frequency_response(f)
    assert _rel(sys(s)[0, 0], g["G11"]) < TOL and _rel(sys(s)[1, 2], g["G23"]) < TOL  # python-control evaluates
    back = BallScrewModel.from_control(sys)
    for name, value in model.params().items():
        assert getattr(back, name) == pytest.approx(value, rel=TOL, abs=TOL * max(model.params().values()))


def test_a_system_that_is_not_a_ball_screw_is_named():
    with pytest.raises(DataError, match="not a 2-mass ball-screw model"):
        ballscrew_from_control(ct.tf([[[1.0]], [[2.0]]], [[[1.0, 3.0, 2.0]], [[1.0, 1.0]]]))
    with pytest.raises(DataError, match="outputs x1, x2"):
        ballscrew_from_control(ct.tf([1.0], [1.0, 1.0]))


def test_gantry_model_round_trip():
    at = THESIS_GANTRY.at(0.1)
    sys = THESIS_GANTRY.to_control(0.1)
    f = np.logspace(0, 3, 100)
    h = np.stack([sys(2j * np.pi * fk) for fk in f], axis=-1)
    assert _rel(h, at.frequency_response(f)) < TOL
    back = gantry_from_control(sys, L=at.L, x=0.1)
    for name in ("M", "C", "K"):
        want = getattr(at, name)
        np.testing.assert_allclose(getattr(back, name), want, rtol=0, atol=TOL * np.abs(want).max())


def test_rigid_body_linear_part():
    m = RigidBodyModel(mass=95.0, viscous=200.0, coulomb_pos=20.0)
    sys = m.to_control()
    s = 2j * np.pi * np.array([0.5, 5.0, 50.0])
    assert _rel(sys(s), 1.0 / (m.mass * s**2 + m.viscous * s)) < TOL


# ------------------------------------------------------------------------------------------ controllers and loops
def test_continuous_loop_agrees_with_the_analysis(case):
    """``L = [K1 K2] [G11; G21]`` as python-control's series connection, evaluated by python-control, against
    the ``ideal`` case of the analysis, in both realizations."""
    _, law, analysis = case
    ideal = analysis.ideal
    s = 2j * np.pi * ideal.freq_hz
    for form in ("ss", "tf"):
        loop = law.to_control(form=form) * MODEL.to_control(form)[:, 0]
        assert loop.ninputs == 1 and loop.noutputs == 1
        assert _rel(loop(s), ideal.L) < TOL, form


def test_measured_loop_agrees_with_the_analysis(case):
    """The law times the FRF as python-control's FrequencyResponseData, against the ``measured`` case on the
    FRF's lines."""
    frf, law, analysis = case
    loop = law.to_control() * frf.to_control()
    measured = analysis.measured
    got = from_control(loop, "frf", outputs=["u"], inputs=["u"]).channel("u/u")
    keep = frf.freq_hz > 0
    n = int(keep.sum())  # the case continues above the FRF's lines (feedtune.analysis.band_edge)
    np.testing.assert_array_equal(frf.freq_hz[keep], measured.freq_hz[:n])
    assert _rel(got[keep], measured.L[:n]) < TOL


def test_discrete_law_with_its_delay(case):
    """``[K1d K2d] z^-d`` (dt = 1/fs) evaluated by python-control against feedtune's own discrete paths."""
    _, law, analysis = case
    f = analysis.ideal_discrete.freq_hz[:-1]  # below fs/2, where the low-pass' zero at z = -1 sits
    z = np.exp(2j * np.pi * f / law.fs)
    want = np.stack([law.K1d().freqresp(f), law.K2d().freqresp(f)]) * z ** -law.delay_samples
    sections = law.to_control(discrete=True, form="ss")
    assert sections.dt == pytest.approx(1 / law.fs) and sections.input_labels == ["e1", "e2"]
    got = sections(z)[0]
    # near z = 1 a rounding of a pole by eps moves the response by eps / |z - 1|: 1.4e-12 at 0.5 Hz, 20 kHz
    assert _rel(got[:, f >= 1], want[:, f >= 1]) < TOL and _rel(got, want) < 2 * TOL
    polynomial = law.to_control(discrete=True)  # polynomials in z: accurate to ~1e-8 near z = 1 only
    assert isinstance(polynomial, ct.TransferFunction) and _rel(polynomial(z)[0], want) < 1e-6


def test_discrete_loop_agrees_with_the_analysis(case):
    """python-control's ZOH-sampled model and the discrete law with its delay, each evaluated by python-control,
    against the ``ideal_discrete`` case. The worst point (5e-12) is next to the antiresonance of ``x1/u``, where
    a zero amplifies rounding in every evaluation; python-control's series connection of the two (23 states solved
    at once, near the double pole at z = 1) is itself only good to about 3e-11 at 0.5 Hz."""
    _, law, analysis = case
    c = analysis.ideal_discrete
    keep = c.freq_hz < law.fs / 2
    z = np.exp(2j * np.pi * c.freq_hz[keep] / law.fs)
    plant = ct.sample_system(MODEL.to_control(), 1 / law.fs, method="zoh")[:, 0]
    law_ss = law.to_control(discrete=True, form="ss")
    product = np.einsum("ijn,jkn->ikn", law_ss(z, squeeze=False), plant(z, squeeze=False))[0, 0]
    assert _rel(product, c.L[keep]) < 5 * TOL
    assert _rel((law_ss * plant)(z), c.L[keep]) < 1e-10


def test_zoh_model_agrees_with_python_control():
    """feedtune's exact ZOH model against python-control's sampling of the same continuous model, across the band;
    both agree with exact rational arithmetic on the same (Ad, Bd) to 5e-12 or better (worst next to zeros)."""
    fs = 20000.0
    f = np.logspace(np.log10(0.5), np.log10(0.9999 * fs / 2), 2000)
    ours = zoh_plant(MODEL, fs, f)
    theirs = ct.sample_system(MODEL.to_control(), 1 / fs, method="zoh")(np.exp(2j * np.pi * f / fs))
    assert _rel(ours["G11"], theirs[0, 0]) < 1e-11 and _rel(ours["G21"], theirs[1, 0]) < 1e-11


def test_zpk_round_trip_and_sections():
    z = Zpk([-1.0, -5 + 50j, -5 - 50j], [-2.0, -3 + 4j, -3 - 4j, -100.0], 5.0)
    s = 2j * np.pi * np.logspace(-1, 3, 60)
    for form in ("tf", "ss"):
        sys = zpk_to_control(z, form)
        assert _rel(sys(s), z.evaluate(s)) < TOL
    back = zpk_from_control(zpk_to_control(z))
    np.testing.assert_allclose(np.sort_complex(back.poles), np.sort_complex(z.poles), rtol=1e-12)
    assert back.gain == pytest.approx(5.0, rel=1e-15)
    for num, den in zpk_sections(z):
        assert len(num) <= len(den) <= 3
    zd = Zpk([0.5], [0.9, 0.2], 2.0, 1e-3)
    assert zpk_from_control(zpk_to_control(zd)).dt == 1e-3
    with pytest.raises(UsageError, match="improper"):
        zpk_to_control(Zpk([-1.0, -2.0], [-3.0], 1.0), "ss")


def test_dispatch_and_bad_input(case):
    _, law, _ = case
    assert isinstance(to_control(law), ct.TransferFunction)
    assert to_control(MODEL).nstates == 4
    with pytest.raises(UsageError, match="no python-control form"):
        to_control(object())
    with pytest.raises(UsageError, match="form must be one of ss, tf"):
        law_to_control(law, form="zpk")
    with pytest.raises(UsageError, match="delay needs discrete=True"):
        law_to_control(law, delay=True)
    with pytest.raises(UsageError, match="kind must be one of"):
        from_control(ct.tf([1.0], [1.0, 1.0]), "nope")
    with pytest.raises(UsageError, match="unspecified sample time"):
        zpk_from_control(ct.tf([1.0], [1.0, -0.5], True))
    assert isinstance(from_control(ct.tf([1.0], [1.0, 1.0])), Zpk)
