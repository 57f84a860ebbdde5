"""Pole-zero matching and filters against closed forms and the continuous responses."""

import numpy as np
import pytest

from feedtune.control.discretize import backward_difference, backward_euler_integrator, matched
from feedtune.control.filters import THESIS_FILTER_PACK, FilterPack, Notch, lead, lead_gamma, lowpass1, pi_controller
from feedtune.errors import UsageError
from feedtune.lti import Zpk, sos_freqresp

FS = 20000.0


def test_notch_depth_and_unit_dc_gain():
    n = Notch(420.0, 0.55, 0.7).zpk()
    assert abs(n.dc_gain()) == pytest.approx(1.0)
    # at the centre frequency the notch gain is zeta_z / zeta_p (hand-derived)
    assert abs(n.freqresp([420.0])[0]) == pytest.approx(0.55 / 0.7, rel=1e-12)


def test_lead_phase_and_gamma():
    # (1 + sin 63 deg) / (1 - sin 63 deg), computed by hand: 1.8910 / 0.10899 = 17.35
    assert lead_gamma(63.0) == pytest.approx(17.35, rel=1e-3)
    g = lead(130.0, 63.0)
    f = np.logspace(0, 4, 20001)
    ph = np.angle(g.freqresp(f), deg=True)
    assert ph.max() == pytest.approx(63.0, abs=0.01)
    assert f[np.argmax(ph)] == pytest.approx(130.0, rel=1e-3)


def test_matched_maps_poles_and_zeros():
    g = Zpk([-2 * np.pi * 30], [-2 * np.pi * 100, -2 * np.pi * 500], 7.0)
    m = matched(g, FS)
    T = 1 / FS
    assert np.allclose(np.sort(m.tf.poles.real), np.sort(np.exp(g.poles * T).real))
    assert np.any(np.isclose(m.tf.zeros, np.exp(g.zeros[0] * T)))
    assert np.any(np.isclose(m.tf.zeros, -1.0))  # the zero at infinity
    assert m.tf.dc_gain().real == pytest.approx(g.dc_gain().real, rel=1e-12)


@pytest.mark.parametrize(
    "g",
    [
        THESIS_FILTER_PACK.zpk(),
        lead(130.0, 63.0),
        lowpass1(2000.0),
        Notch(1080.0, 0.05, 0.7).zpk(),
    ],
)
def test_matched_response_up_to_fs_over_10(g):
    m = matched(g, FS)
    f = np.logspace(0, np.log10(FS / 10), 400)
    ratio = m.tf.freqresp(f) / g.freqresp(f)
    assert np.max(np.abs(ratio[f <= FS / 50] - 1)) < 0.012
    assert np.max(np.abs(ratio - 1)) < 0.07
    assert m.delay_samples == 0


def test_matched_integrator_pi_keeps_low_frequency_gain():
    kp, ki = 2.0, 300.0
    g = pi_controller(kp, ki)
    m = matched(g, FS)
    assert np.any(np.isclose(m.tf.poles, 1.0))  # integrator s = 0 -> z = 1
    f = np.array([0.01, 0.1, 1.0, 100.0])
    # below the corner the PI is ki / s; the matched version must keep that gain
    assert np.allclose(np.abs(m.tf.freqresp(f[:2])), ki / (2 * np.pi * f[:2]), rtol=1e-4)
    assert np.allclose(m.tf.freqresp(f), g.freqresp(f), rtol=1e-3)


def test_matched_double_integrator_with_excess_poles():
    g = Zpk([-100.0], [0.0, 0.0, -5000.0], 3.0)
    m = matched(g, FS)
    f = np.logspace(-1, np.log10(FS / 20), 200)
    assert np.allclose(m.tf.freqresp(f), g.freqresp(f), rtol=0.02)


def test_improper_gets_delay_and_previewed_response_matches():
    g = Zpk([0.0, -30.0], [-1000.0], 2.0)  # relative degree -1
    m = matched(g, FS)
    assert m.delay_samples == 1
    f = np.logspace(0, 2, 50)
    previewed = m.tf.freqresp(f) * np.exp(2j * np.pi * f / FS)
    # z - 1 = 2j sin(wT/2) e^{jwT/2}: the matched differentiator leads by half a sample (closed form)
    ratio = previewed / g.freqresp(f)
    assert np.allclose(ratio, np.exp(1j * np.pi * f / FS), atol=2e-3)


def test_backward_difference_and_integrator_closed_form():
    f = np.array([5.0, 500.0])
    z = np.exp(2j * np.pi * f / FS)
    assert np.allclose(backward_difference(FS).freqresp(f), (1 - 1 / z) * FS)
    assert np.allclose(backward_euler_integrator(FS).freqresp(f), 1 / FS / (1 - 1 / z))


def test_sos_equals_zpk_including_delays():
    for g in (
        Zpk([0.5], [0.9, 0.0, 0.0], 2.0, 1 / FS),
        Zpk([], [0.0, 0.0, 0.0], 1.0, 1 / FS),
        matched(THESIS_FILTER_PACK.zpk(), FS).tf,
    ):
        f = np.logspace(0, 3.9, 30)
        assert np.allclose(sos_freqresp(g.to_sos(), f, FS), g.freqresp(f), rtol=1e-9)


def test_bad_filter_input():
    with pytest.raises(UsageError, match="notch"):
        Notch.parse("420,0.5")
    with pytest.raises(UsageError, match="Nyquist"):
        FilterPack([Notch(12000.0, 0.1, 0.7)]).check_nyquist(FS)
    with pytest.raises(UsageError, match="Nyquist"):
        matched(lowpass1(15000.0) * Notch(11000.0, 0.1, 0.5).zpk(), FS)
