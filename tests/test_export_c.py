"""The exported C header executes the gains document: compile it and compare with scipy's sosfilt."""

import shutil
import subprocess

import numpy as np
import pytest
from c_compile import compile_c

from feedtune.control.filters import THESIS_FILTER_PACK
from feedtune.design.mcppc import design_mcppc
from feedtune.design.ppi import design_ppi
from feedtune.export.c_header import c_header
from feedtune.io.gains import gains_document, law_from_document, with_friction_feedforward, with_prefilter
from feedtune.models import THESIS_TABLE_3_1 as MODEL
from feedtune.models.friction import FrictionLaw

MAIN_C = r"""
#include <stdio.h>
#include "gains.h"
int main(void) {
    ft_state s; ft_init(&s);
    double r, x1, x2;
    while (scanf("%lf %lf %lf", &r, &x1, &x2) == 3) printf("%.17g\n", ft_step(&s, r, x1, x2));
    return 0;
}
"""


def _reference_output(doc, r_preview, x1, x2, friction=None, band=None):
    """The law of docs/gains.md evaluated with vector operations (sosfilt and cumulative sums).

    With a ``[prefilter]`` the paths run on ``r + sosfilt(prefilter_sos, r)``; ``friction`` (a FrictionLaw in V and
    rad/s) adds its smoothed force of the backward-difference velocity of that, its viscous term less the ``b1 + b2``
    the feedforward ``U_ff = ... + (b1 + b2) s`` already carries (the model's viscous friction fed forward once).
    """
    from scipy.signal import sosfilt

    fs = doc["sampling"]["fs_hz"]["value"]
    g = {k: v["value"] for k, v in doc["gains"].items()}
    ref = doc["reference"]
    if "prefilter" in doc:
        r_preview = r_preview + sosfilt(np.array(doc["prefilter"]["prefilter_sos"]), r_preview)
    x1r = sosfilt(np.array(ref["rotary_sos"]), r_preview)
    x2r = sosfilt(np.array(ref["table_sos"]), r_preview)
    uff = sosfilt(np.array(ref["feedforward_sos"]), r_preview)
    if friction is not None:
        b = MODEL.b1 + MODEL.b2
        fed = FrictionLaw(friction.dc_pos, friction.ds_pos, friction.dc_neg, friction.ds_neg, friction.omega_pos,
                          friction.omega_neg, command_unit="V", velocity_unit="rad/s",
                          viscous_pos=friction.viscous_pos - b, viscous_neg=friction.viscous_negative - b)
        uff = uff + fed.smoothed(np.diff(r_preview, prepend=r_preview[0]) * fs, band)
    e1, e2 = x1r - x1, x2r - x2
    de1 = np.diff(e1, prepend=e1[0]) * fs
    de2 = np.diff(e2, prepend=e2[0]) * fs
    ie2 = np.cumsum(e2) / fs
    ufb = g["Kx1"] * e1 + g["Kx2"] * e2 + g["Kv1"] * de1 + g["Kv2"] * de2 + g["Ki2"] * ie2
    return sosfilt(np.array(doc["filters"]["filter_pack_sos"]), ufb) + uff


FRICTION = FrictionLaw(dc_pos=0.1, ds_pos=0.16, dc_neg=-0.09, ds_neg=-0.15, omega_pos=0.8, omega_neg=0.6,
                       command_unit="V", velocity_unit="rad/s", viscous_pos=0.004, viscous_neg=0.0006)
"""With viscous friction on both sides of the model's b1 + b2 = 0.00102 V/(rad/s): the feedforward adds +0.003 and
-0.0004 V/(rad/s) (at the test's 9 rad/s: 0.027 V, -0.004 V)."""
PF_GAINS = {"K_vel": 1e-4, "K_acc": -2e-6, "K_jerk": 3e-9, "K_snap": -4e-12}


def _extras(design):
    """Gains document with a pre-filter and friction feedforward (band 0.05 rad/s)."""
    doc = with_prefilter(gains_document(design), gains=PF_GAINS, lpf_hz=80.0)
    return with_friction_feedforward(doc, FRICTION, v_band=0.05)


@pytest.mark.parametrize(
    ("design", "extras"),
    [
        (design_mcppc(MODEL, filters=THESIS_FILTER_PACK), False),
        (design_ppi(MODEL, Kpx=60.0, Kpv=0.8, Kiv=100.0, filters=THESIS_FILTER_PACK), False),
        (design_mcppc(MODEL, filters=THESIS_FILTER_PACK), True),
    ],
    ids=["mcppc", "ppi", "mcppc+prefilter+friction"],
)
def test_c_header_matches_vectorised_law(tmp_path, design, extras):
    cc = shutil.which("cc") or shutil.which("gcc")
    if cc is None:
        pytest.skip("no C compiler")
    doc = _extras(design) if extras else gains_document(design)
    (tmp_path / "gains.h").write_text(c_header(doc))
    (tmp_path / "main.c").write_text(MAIN_C)
    exe = tmp_path / "run"
    compile_c(cc, tmp_path / "main.c", exe)
    rng = np.random.default_rng(1)
    n = 4000
    t = np.arange(n) / 20000.0
    r = 0.5 * (1 - np.cos(2 * np.pi * 3 * t))  # both signs of velocity, through 0 at t = 1/6 s
    x1 = r + 1e-4 * rng.standard_normal(n)
    x2 = r + 1e-4 * rng.standard_normal(n)
    text = "\n".join(f"{a:.17g} {b:.17g} {c:.17g}" for a, b, c in zip(r, x1, x2, strict=True))
    out = subprocess.run([str(exe)], input=text, capture_output=True, text=True, check=True).stdout
    u_c = np.array(out.split(), float)
    u_ref = _reference_output(doc, r, x1, x2, FRICTION if extras else None, 0.05)
    assert np.allclose(u_c, u_ref, rtol=1e-9, atol=1e-9 * np.max(np.abs(u_ref)))
    if extras:  # the extras really act: without them the command differs
        plain = _reference_output(gains_document(design), r, x1, x2)
        assert np.max(np.abs(u_c - plain)) > 0.05


def test_gains_document_rebuilds_the_same_law():
    d = design_mcppc(MODEL, filters=THESIS_FILTER_PACK)
    law, model, kind = law_from_document(gains_document(d))
    assert kind == "mcppc" and model == MODEL
    f = np.logspace(0, 3, 50)
    assert np.allclose(law.K2().freqresp(f), d.law().K2().freqresp(f))


def test_discrete_reference_paths_realise_the_previewed_filters():
    # the SOS in the document, fed x_r[k+P], equal the matched filters: compare with an independent
    # frequency response of G_r at low frequency (where matching is accurate)
    from feedtune.lti import sos_freqresp

    d = design_mcppc(MODEL)
    doc = gains_document(d)
    P = doc["sampling"]["preview_samples"]
    f = np.array([1.0, 10.0, 50.0])
    fs = 20000.0
    rot = sos_freqresp(np.array(doc["reference"]["rotary_sos"]), f, fs) * np.exp(2j * np.pi * f * P / fs)
    s = 2j * np.pi * f
    g_r = (MODEL.m2 * s**2 + (MODEL.b2 + MODEL.c) * s + MODEL.k) / (MODEL.c * s + MODEL.k)  # eq. 3.12
    # matched improper filters lead by half a sample per excess zero (G_r has one): closed form e^{jwT/2}
    assert np.allclose(rot, g_r * np.exp(1j * np.pi * f / fs), rtol=2e-3)
    table = sos_freqresp(np.array(doc["reference"]["table_sos"]), f, fs) * np.exp(2j * np.pi * f * P / fs)
    assert np.allclose(table, 1.0)


@pytest.mark.parametrize("design", [design_mcppc(MODEL, filters=THESIS_FILTER_PACK),
                                    design_ppi(MODEL, Kpx=60.0, Kpv=0.8, Kiv=100.0, filters=THESIS_FILTER_PACK)],
                         ids=["mcppc", "ppi"])
def test_ball_screw_friction_feedforward_feeds_the_viscous_friction_once(design):
    """Both designs' feedforward carries ``b1 + b2`` (``U_ff'(0)``: G_ff of eq. 3.13 and (m1+m2) s^2 + (b1+b2) s of
    the P-PI): the friction section adds the model's viscous coefficients less that."""
    sec = with_friction_feedforward(gains_document(design), FRICTION, v_band=0.05)["friction_feedforward"]
    b = MODEL.b1 + MODEL.b2
    assert sec["viscous_pos"]["value"] == pytest.approx(FRICTION.viscous_pos - b, rel=1e-9)
    assert sec["viscous_neg"]["value"] == pytest.approx(FRICTION.viscous_negative - b, rel=1e-9)
    assert sec["source"]["viscous_in_linear_feedforward"] == {"value": pytest.approx(b, rel=1e-9), "unit": "V/(rad/s)"}
