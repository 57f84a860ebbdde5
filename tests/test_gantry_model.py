"""T-gantry yaw model (thesis eq. 4.1-4.4, 4.16) against the thesis' numbers and closed forms."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from feedtune.errors import DataError, UsageError
from feedtune.io.gantry_model import gantry_model_from_doc, gantry_model_to_doc
from feedtune.models.gantry import THESIS_GANTRY, GantryModel

T = THESIS_GANTRY
XS = (-0.15, 0.0, 0.15)


def _arms_by_hand(x: float) -> tuple[float, float]:
    """a1, a2 from alpha1 = a2 / L (eq. 4.22) with the THESIS_GANTRY line alpha1 = 0.5 - m_x x / (m L)."""
    alpha1 = 0.5 - 0.6977 / (2.722 * 1.484) * x
    return (1 - alpha1) * 1.484, alpha1 * 1.484


def test_thesis_yaw_mode_at_x0_is_94_3_hz_with_3_4_percent_damping():
    mode = T.yaw_mode(0.0)
    assert round(mode.freq_hz, 1) == 94.3
    assert round(100 * mode.zeta, 1) == 3.4
    # the same mode from the eigenvalues of the 4-state model in encoder coordinates
    eig = T.at(0.0).yaw_mode()
    assert eig.freq_hz == pytest.approx(mode.freq_hz, rel=1e-10)
    assert eig.zeta == pytest.approx(mode.zeta, rel=1e-10)


def test_yaw_mode_shift_over_table_travel_by_hand():
    # J(0.15) = 0.4342 + 0.6977 * (0.1655 + 0.15)^2 = 0.503648...; f = sqrt(k/J) / (2 pi)
    J = 0.4342 + 0.6977 * 0.3155**2
    assert T.inertia(0.15) == pytest.approx(J, rel=1e-12)
    assert T.yaw_mode(0.15).freq_hz == pytest.approx(math.sqrt(159.2e3 / J) / (2 * math.pi), rel=1e-12)
    # thesis: "the vibration modes were observed to shift in frequency by less than +-6 %"
    f0 = T.yaw_mode(0.0).freq_hz
    for x in XS:
        assert abs(T.yaw_mode(x).freq_hz / f0 - 1) < 0.06


@pytest.mark.parametrize("x", XS)
def test_matrices_equal_transformed_cog_model(x):
    a1, a2 = _arms_by_hand(x)
    J, m, c, k = 0.4342 + 0.6977 * (0.1655 + x) ** 2, 2.722, 18.17, 159.2e3
    Fq = np.array([[1.0, 1.0], [-a1, a2]])
    Tm = np.array([[1.0, -a1], [1.0, a2]])
    Fi, Ti = np.linalg.inv(Fq), np.linalg.inv(Tm)
    at = T.at(x)
    np.testing.assert_allclose(at.M, Fi @ np.diag([m, J]) @ Ti, rtol=1e-12)
    np.testing.assert_allclose(at.C, Fi @ np.diag([0.0, c]) @ Ti, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(at.K, Fi @ np.diag([0.0, k]) @ Ti, rtol=1e-12, atol=1e-6)
    np.testing.assert_allclose(at.M, at.M.T, rtol=0, atol=1e-15)
    assert np.all(np.linalg.eigvalsh(at.M) > 0)


@pytest.mark.parametrize("x", XS)
def test_physical_parameters_invert_eq_4_3(x):
    p = T.at(x).physical()
    a1, a2 = _arms_by_hand(x)
    assert p.m == pytest.approx(2.722, rel=1e-12)
    assert p.J == pytest.approx(0.4342 + 0.6977 * (0.1655 + x) ** 2, rel=1e-10)
    assert (p.a1, p.a2) == pytest.approx((a1, a2), rel=1e-12)
    assert p.alpha1 + p.alpha2 == pytest.approx(1.0, abs=1e-14)
    assert (p.c, p.k) == pytest.approx((18.17, 159.2e3), rel=1e-10)


def test_frequency_response_matches_eq_4_4():
    f = np.linspace(1.0, 500.0, 700)
    x = 0.15
    a1, a2 = _arms_by_hand(x)
    J, m = 0.4342 + 0.6977 * (0.1655 + x) ** 2, 2.722
    s = 2j * np.pi * f
    rigid = 1 / (m * s**2)
    yaw = 1 / (J * s**2 + 18.17 * s + 159.2e3)
    expected = np.array([[rigid + a1**2 * yaw, rigid - a1 * a2 * yaw],
                         [rigid - a2 * a1 * yaw, rigid + a2**2 * yaw]])
    got = T.frequency_response(f, x)
    assert got.shape == (2, 2, f.size)
    np.testing.assert_allclose(got, expected, rtol=1e-10)


def test_state_space_matches_python_control():
    control = pytest.importorskip("control")
    x = -0.15
    A, B, C = T.state_space(x)
    f = np.array([20.0, 90.0, 96.4, 150.0, 400.0])
    sys = control.ss(A, B, C, np.zeros((2, 2)))
    ref = np.asarray(sys(2j * np.pi * f))  # (2, 2, n)
    np.testing.assert_allclose(T.frequency_response(f, x), ref, rtol=1e-9)


def test_model_frf_value_type():
    f = np.array([50.0, 100.0])
    frf = T.frf(f, 0.0, quantity="acceleration")
    assert frf.outputs == ("y1", "y2") and frf.inputs == ("u1", "u2") and frf.output_unit == "m"
    np.testing.assert_allclose(frf.response, -((2 * np.pi * f) ** 2) * T.frequency_response(f, 0.0))


def test_doc_round_trip_and_json():
    doc = gantry_model_to_doc(T)
    assert doc["schema"] == "feedtune.model/1" and doc["kind"] == "gantry"
    assert doc["params"]["J0"] == {"value": 0.4342, "unit": "V*m*s^2"}
    back = gantry_model_from_doc(json.loads(json.dumps(doc)))
    assert back == T
    json.dumps(T.to_dict(), allow_nan=False)
    json.dumps(T.at(0.1).to_dict(), allow_nan=False)


@pytest.mark.parametrize("mutate, match", [
    (lambda d: d.update(kind="ballscrew"), "kind"),
    (lambda d: d["params"].pop("k"), r"params\.k .*missing"),
    (lambda d: d["params"]["k"].update(unit="N*m"), "unit"),
    (lambda d: d["params"]["c"].update(value="big"), "number"),
    (lambda d: d["params"].update(zeta={"value": 1.0, "unit": "-"}), "unknown"),
    (lambda d: d["params"]["J0"].update(value=-1.0), "J0"),
])
def test_bad_doc_is_data_error(mutate, match):
    doc = json.loads(json.dumps(gantry_model_to_doc(T)))
    mutate(doc)
    with pytest.raises(DataError, match=match) as info:
        gantry_model_from_doc(doc, "gantry.toml")
    assert str(info.value).startswith("gantry.toml: ") and "\n" not in str(info.value)


def test_bad_inputs():
    with pytest.raises(DataError, match="> 0 Hz"):
        T.frequency_response([0.0, 10.0], 0.0)
    with pytest.raises(UsageError, match="outside the actuator span"):
        T.alpha(5.0)
    with pytest.raises(UsageError, match="position"):
        T.at("left")
    with pytest.raises(DataError, match="k must be > 0"):
        GantryModel(m=1.0, L=1.0, J0=0.1, d=0.0, m_x=0.1, c=1.0, k=0.0)
