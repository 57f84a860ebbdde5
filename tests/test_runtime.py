"""The per-sample runtime executes a gains file exactly as docs/gains.md describes."""

from __future__ import annotations

import copy

import numpy as np
import pytest
from scipy.signal import sosfilt

from feedtune.control.filters import THESIS_FILTER_PACK
from feedtune.design.mcppc import design_mcppc
from feedtune.design.ppi import design_ppi
from feedtune.errors import DataError
from feedtune.io import write_document
from feedtune.io.gains import gains_document
from feedtune.machines.ballscrew.runtime import GainsRuntime
from feedtune.models import THESIS_TABLE_3_1 as MODEL

DESIGNS = {
    "mcppc": design_mcppc(MODEL, filters=THESIS_FILTER_PACK),
    "ppi": design_ppi(MODEL, Kpx=60.0, Kpv=0.8, Kiv=100.0, filters=THESIS_FILTER_PACK),
}


def _inputs(n: int = 1500, seed: int = 3):
    """A previewed reference and encoder readings that all start at 0 (so the first error is 0)."""
    rng = np.random.default_rng(seed)
    p = np.cumsum(rng.standard_normal(n)) * 1e-3
    x1 = np.cumsum(rng.standard_normal(n)) * 1e-4
    x2 = np.cumsum(rng.standard_normal(n)) * 1e-4
    p[:5] = x1[0] = x2[0] = 0.0
    return p, x1, x2


def _step_all(rt: GainsRuntime, p, x1, x2) -> np.ndarray:
    rt.reset()
    return np.array([rt.step(a, b, c) for a, b, c in zip(p, x1, x2, strict=True)])


@pytest.mark.parametrize("kind", list(DESIGNS))
def test_step_equals_the_discrete_transfer_functions_of_the_law(kind):
    # independent: u = Uff(z) p + K1d(z) (R1(z) p - x1) + K2d(z) (T(z) p - x2), built from the design's
    # continuous law (not from the file) and filtered as whole transfer functions
    design = DESIGNS[kind]
    law = design.law()
    paths = law.reference_paths()
    p, x1, x2 = _inputs()

    def filt(z, x):
        return sosfilt(z.to_sos(), x)

    expected = (filt(paths["feedforward"].discrete, p) + filt(law.K1d(), filt(paths["rotary"].discrete, p) - x1)
                + filt(law.K2d(), filt(paths["table"].discrete, p) - x2))
    got = _step_all(GainsRuntime.from_document(gains_document(design)), p, x1, x2)
    assert np.max(np.abs(got - expected)) <= 1e-8 * np.max(np.abs(expected))


def test_first_sample_has_no_derivative_kick():
    # a constant error -c from the first sample: de = 0 throughout, ie2 = -c (k + 1) / fs (hand-derived)
    design = DESIGNS["mcppc"]
    rt = GainsRuntime.from_document(gains_document(design))
    g, fs, c, n = design.gains, design.fs, 2e-4, 400
    got = _step_all(rt, np.zeros(n), np.full(n, c), np.full(n, c))
    ufb = -(g["Kx1"] + g["Kx2"]) * c - g["Ki2"] * c * np.arange(1, n + 1) / fs
    expected = sosfilt(design.law().filter_pack_discrete().to_sos(), ufb)
    assert np.allclose(got, expected, rtol=1e-9, atol=1e-12)


def test_replay_equals_stepping():
    rt = GainsRuntime.from_document(gains_document(DESIGNS["mcppc"]))
    p, x1, x2 = _inputs(800)
    x_ref = np.r_[np.zeros(rt.preview_samples), p][: p.size]  # so that previewed(x_ref) == p up to the end
    stepped = _step_all(rt, rt.previewed(x_ref), x1, x2)
    assert np.allclose(rt.replay(x_ref, x1, x2), stepped, rtol=1e-10, atol=1e-12)


@pytest.mark.parametrize("ext", ["toml", "json"])
def test_file_round_trip_and_only_the_law_is_read(tmp_path, ext):
    doc = gains_document(DESIGNS["ppi"])
    path = tmp_path / f"gains.{ext}"
    write_document(path, doc)
    p, x1, x2 = _inputs(300)
    ref = _step_all(GainsRuntime.from_document(doc), p, x1, x2)
    assert np.array_equal(_step_all(GainsRuntime.from_file(path), p, x1, x2), ref)
    stripped = copy.deepcopy(doc)
    for key in ("model", "design", "ppi_gains", "law"):
        stripped.pop(key, None)
    stripped["reference"] = {k: v for k, v in doc["reference"].items() if k.endswith("_sos")}
    stripped["filters"] = {"filter_pack_sos": doc["filters"]["filter_pack_sos"]}
    assert np.array_equal(_step_all(GainsRuntime.from_document(stripped), p, x1, x2), ref)


def _broken(edit):
    doc = copy.deepcopy(gains_document(DESIGNS["mcppc"]))
    edit(doc)
    return doc


@pytest.mark.parametrize(
    ("edit", "needle"),
    [
        (lambda d: d.update(kind="gantry"), "machine kind 'gantry'"),
        (lambda d: d.update(schema="feedtune.gains/2"), "comes from a newer feedtune"),
        (lambda d: d.update(schema="something"), "is not of the form 'feedtune.gains/<version>'"),
        (lambda d: d["gains"].pop("Kv1"), "gains.Kv1 is missing"),
        (lambda d: d["gains"].update(Kx1={"value": 1.0, "unit": "V/m"}), "expected 'V/rad'"),
        (lambda d: d["filters"].update(filter_pack_sos=[[1, 0, 0, 0, 0, 0]]), "a0 = 0"),
        (lambda d: d["reference"].update(rotary_sos=[[1, 2, 3]]), "reference.rotary_sos[0]"),
        (lambda d: d["reference"].pop("table_sos"), "reference.table_sos"),
        (lambda d: d["sampling"].update(fs_hz={"value": -1.0, "unit": "Hz"}), "sampling.fs_hz: must be > 0"),
        (lambda d: d["sampling"].update(delay_samples=-1), "delay_samples"),
        (lambda d: d.pop("sampling"), "sampling is missing"),
    ],
)
def test_bad_gains_documents_are_one_line_data_errors(edit, needle):
    with pytest.raises(DataError) as exc:
        GainsRuntime.from_document(_broken(edit), "g.toml")
    msg = str(exc.value)
    assert needle in msg and msg.startswith("g.toml") and "\n" not in msg


def test_sample_rate_mismatch_is_refused():
    rt = GainsRuntime.from_document(gains_document(DESIGNS["mcppc"]), "g.toml")
    rt.check_target(20000.0)
    with pytest.raises(DataError, match=r"designed for fs = 20000 Hz.*10000 Hz"):
        rt.check_target(10000.0)


# ------------------------------------------------------------------------------ pre-filter and friction
PF_GAINS = {"K_vel": 1e-4, "K_acc": -2e-6, "K_jerk": 3e-9, "K_snap": -4e-12}


def _with_extras():
    from feedtune.io.gains import with_friction_feedforward, with_prefilter
    from feedtune.models.friction import StribeckFriction

    fr = StribeckFriction(dc_pos=0.1, ds_pos=0.16, dc_neg=-0.09, ds_neg=-0.15, omega_pos=0.8, omega_neg=0.6,
                          command_unit="V", velocity_unit="rad/s")
    doc = with_prefilter(gains_document(DESIGNS["mcppc"]), gains=PF_GAINS, lpf_hz=80.0)
    return with_friction_feedforward(doc, fr, v_band=0.05), fr


def test_step_with_prefilter_and_friction_equals_the_vectorised_paths():
    # independent: the plain runtime fed the pre-filtered reference (scipy sosfilt of the stored sections)
    # plus StribeckFriction.smoothed of its backward-difference velocity, added to the command
    doc, fr = _with_extras()
    rt = GainsRuntime.from_document(doc)
    plain = GainsRuntime.from_document(gains_document(DESIGNS["mcppc"]))
    p, x1, x2 = _inputs(1200)
    p = np.cumsum(np.abs(p)) * 1e-2 - np.cumsum(np.abs(p[::-1])) * 2e-2  # both signs of velocity, long rests
    p[:5] = 0.0
    xp = p + sosfilt(np.array(doc["prefilter"]["prefilter_sos"]), p)
    v = np.diff(xp, prepend=xp[0]) * rt.fs
    expected = _step_all(plain, xp, x1, x2) + fr.smoothed(v, 0.05)
    got = _step_all(rt, p, x1, x2)
    assert np.max(np.abs(got - expected)) <= 1e-9 * np.max(np.abs(expected))
    x_ref = np.r_[np.zeros(rt.preview_samples), p][: p.size]
    assert np.allclose(rt.replay(x_ref, x1, x2), _step_all(rt, rt.previewed(x_ref), x1, x2), rtol=1e-10,
                       atol=1e-12)


def test_extras_survive_the_file_round_trip_and_are_reported(tmp_path):
    doc, _ = _with_extras()
    path = tmp_path / "g.toml"
    write_document(path, doc)
    p, x1, x2 = _inputs(300)
    assert np.array_equal(_step_all(GainsRuntime.from_file(path), p, x1, x2),
                          _step_all(GainsRuntime.from_document(doc), p, x1, x2))
    d = GainsRuntime.from_file(path).to_dict()
    assert d["prefilter"]["gains"] == PF_GAINS and d["prefilter"]["units"]["K_snap"] == "s^4"
    assert d["friction_feedforward"]["v_band"] == 0.05 and d["friction_feedforward"]["units"]["v_band"] == "rad/s"
    assert "prefilter(x_r[k+P])" in doc["law"]["execution"] and "friction(v_r)" in doc["law"]["execution"]
    plain = GainsRuntime.from_document(gains_document(DESIGNS["mcppc"])).to_dict()
    assert plain["prefilter"] is None and plain["friction_feedforward"] is None


@pytest.mark.parametrize(
    ("edit", "needle"),
    [
        (lambda d: d["prefilter"].pop("prefilter_sos"), "prefilter.prefilter_sos"),
        (lambda d: d["prefilter"].update(prefilter_sos=[[1, 2]]), "prefilter.prefilter_sos[0]"),
        (lambda d: d["friction_feedforward"].pop("omega_pos"), "friction_feedforward.omega_pos: missing"),
        (lambda d: d["friction_feedforward"].update(dc_pos={"value": 1.0, "unit": "N"}), "expected 'V'"),
        (lambda d: d["friction_feedforward"].update(v_band={"value": 0.0, "unit": "rad/s"}), "band must be > 0"),
    ],
)
def test_bad_extra_sections_are_one_line_data_errors(edit, needle):
    doc, _ = _with_extras()
    edit(doc)
    with pytest.raises(DataError) as exc:
        GainsRuntime.from_document(doc, "g.toml")
    msg = str(exc.value)
    assert needle in msg and msg.startswith("g.toml") and "\n" not in msg
