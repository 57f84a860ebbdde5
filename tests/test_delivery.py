"""One delivery exit and one certificate that travels with the gains (issue 23 items 4 and 6, issue 24 item 4).

Checked against what is not the code under test: the describing function of a saturation in closed form, a type-3
loop whose phase crossover and gain there are known in closed form (and its stability from the Routh criterion),
SHA-256 of the files computed here with hashlib, and a synthetic x axis (mass plus a 150 Hz amplifier) whose
loop-shaping design passes on its FRF but not on the pure-mass model (the situation of the gantry demo's x axis,
whose model lacks the 360 Hz amplifier).
"""

from __future__ import annotations

import copy
import hashlib
import math
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
from cli_run import run

from feedtune.analysis.limits import (
    PROFILES,
    Limits,
    describing_function_saturation,
    saturation_overdrive,
    split_gain_margins,
)
from feedtune.errors import DesignError
from feedtune.frf import Frf

EXAMPLE_FRF = str(Path(__file__).resolve().parents[1] / "examples" / "ballscrew_frf.csv")
THESIS_PACK = ["--notch", "420,0.55,0.7", "--notch", "1080,0.05,0.7", "--lpf", "2000"]


@pytest.fixture
def cli(capsys, monkeypatch):
    """``feedtune ARGS`` in-process: ``exit_code`` and ``output`` (stdout and stderr)."""
    def invoke(*args):
        code, out, err = run(args, capsys, monkeypatch)
        return SimpleNamespace(exit_code=code, output=out + err)

    return invoke


# ------------------------------------------------------------------------------------------ item 6
def _n(a: float) -> float:
    """The describing function of a unit saturation, written out here (Gelb and Vander Velde, table 2.3-1)."""
    return 2.0 / math.pi * (math.asin(1.0 / a) + math.sqrt(1.0 - 1.0 / a**2) / a)


@pytest.mark.parametrize("margin_db", [0.5, 3.0, 6.0, 12.0, 17.0, 30.0])
def test_saturation_headroom_is_where_the_describing_function_falls_to_the_margin(margin_db):
    a = saturation_overdrive(margin_db)
    assert a > 1
    assert _n(a) == pytest.approx(10 ** (-margin_db / 20), rel=1e-10)
    assert describing_function_saturation(a) == pytest.approx(_n(a), rel=1e-13)


def test_saturation_headroom_at_known_points():
    assert saturation_overdrive(-20 * math.log10(1 / 3 + math.sqrt(3) / (2 * math.pi))) == pytest.approx(2.0, 1e-9)
    g = 10 ** (-60 / 20)  # large overdrive: N(a) -> 4/(pi a)
    assert saturation_overdrive(60.0) == pytest.approx(4 / (math.pi * g), rel=1e-5)
    assert saturation_overdrive(0.0) == 1.0
    assert describing_function_saturation(0.5) == 1.0  # below the limit the saturation is linear


def _type3_metrics(gm_low_db: float):
    """``L(s) = K (1 + s/w1)^2 / s^3``: the phase is -270 + 2 atan(w/w1) deg, so the only phase crossover is at
    ``w1`` with ``|L| = 2 K / w1^3``; K sets the gain-reduction margin there."""
    from feedtune.analysis.loop import analyze_loop

    w1 = 2 * np.pi * 30.0
    K = 10 ** (gm_low_db / 20) * w1**3 / 2

    def loop(f):
        s = 2j * np.pi * np.asarray(f, float)
        return K * (1 + s / w1) ** 2 / s**3

    f = np.geomspace(0.01, 1e4, 4000)
    return analyze_loop(f, loop(f), evaluate=loop, integrators=3), K, w1


def test_a_gain_reduction_margin_is_judged_by_its_own_limit():
    m, K, w1 = _type3_metrics(4.0)
    # Routh on s^3 + (K/w1^2) s^2 + (2K/w1) s + K: stable iff 2K/w1^3 > 1, i.e. |L| > 1 at the phase crossover
    assert m.stable == (2 * K / w1**3 > 1) is True
    assert m.gain_margins_db == pytest.approx([-4.0], abs=1e-6)
    assert m.phase_crossovers_hz == pytest.approx([30.0], rel=1e-6)
    up, down = split_gain_margins(m.gain_margins)
    assert up is None and down[0] == pytest.approx(4.0, abs=1e-6)
    textbook = PROFILES["textbook"]
    items = {i.name: i for i in textbook.check(m, "ideal")}
    assert items["gm_low_db"].value == pytest.approx(4.0, abs=1e-6) and not items["gm_low_db"].ok
    assert items["gm_db"].value is None and items["gm_db"].ok  # no gain-increase margin to judge
    names = {"gm_low_db": "--gm-low-min"}
    from feedtune.analysis.limits import LimitCheck

    (text,) = [v for v in LimitCheck(textbook, list(items.values())).violations_named(names) if "reduction" in v]
    assert "gain-reduction margin 4 dB at 30 Hz is below --gm-low-min 6 dB" in text
    assert f"{saturation_overdrive(items['gm_low_db'].value):.3g} x" in text
    assert all(i.ok for i in textbook.override(gm_low_min_db=3.0).check(m, "ideal") if i.name.startswith("gm"))
    assert not [i for i in PROFILES["thesis"].check(m, "ideal") if i.name.startswith("gm")]  # the thesis: none


def test_the_two_gain_margins_are_set_apart():
    m = SimpleNamespace(stable=True, ms=1.5, ms_freq_hz=10.0, phase_margin_deg=50.0, phase_margins=[],
                        gain_margins=[{"freq_hz": 30.0, "gm_db": -17.0}, {"freq_hz": 400.0, "gm_db": 5.0}],
                        disk_margin=1.0, disk_margin_freq_hz=1.0)
    before = Limits(2.5, 30.0, 6.0, None, "old")  # not given: one |GM| limit both ways, as before
    assert before.gm_low_min_db == 6.0
    items = {i.name: i for i in before.check(m, "c")}
    assert items["gm_db"].value == 5.0 and not items["gm_db"].ok
    assert items["gm_low_db"].value == 17.0 and items["gm_low_db"].ok  # -17 dB is not a gain-increase margin
    stricter = PROFILES["textbook"].override(gm_low_min_db=20.0, gm_min_db=3.0)
    items = {i.name: i for i in stricter.check(m, "c")}
    assert items["gm_db"].ok and not items["gm_low_db"].ok
    assert Limits.from_dict(stricter.to_dict()) == stricter
    assert Limits.from_dict({k: v for k, v in before.to_dict().items() if k != "gm_low_min_db"}) == before


def test_gm_low_min_option(cli, tmp_path):
    bad = cli("analyze", tmp_path / "x.toml", "--gm-low-min", "-1")
    assert bad.exit_code == 2 and "--gm-low-min must be a number >= 0 dB" in bad.output


# ------------------------------------------------------------------------------------------ item 4: the file
@pytest.fixture(scope="module")
def delivered():
    """MC-PPC (thesis settings) on the example model, delivered with its certificate on the example FRF."""
    from feedtune import THESIS_FILTER_PACK, design_mcppc, fit_ballscrew, read_frf
    from feedtune.machines.certificate import FrfSource
    from feedtune.workflows.deliver import deliver

    frf = read_frf(EXAMPLE_FRF)
    model = fit_ballscrew([frf]).model
    design = design_mcppc(model, beta=4, pole_hz=50, zeta=0.7, filters=THESIS_FILTER_PACK)
    return deliver(design, [FrfSource.from_file(EXAMPLE_FRF, frf, "ballscrew_frf.csv")]), frf


def test_the_certificate_names_its_frf_by_the_files_digest_and_ties_itself_to_the_gains(delivered, tmp_path):
    from feedtune.io import read_document
    from feedtune.io.gains import with_prefilter
    from feedtune.io.gains_certificate import read_certificate

    delivery, _ = delivered
    sec = delivery.document["certificate"]
    with open(EXAMPLE_FRF, "rb") as fh:
        assert sec["frfs"][0]["sha256"] == hashlib.sha256(fh.read()).hexdigest()
    assert sec["frfs"][0]["identity"] == "file" and sec["frfs"][0]["frf"] == "ballscrew_frf.csv"
    assert sec["ok"] is delivery.ok
    assert sec["limits"] == {k: v for k, v in PROFILES["textbook"].to_dict().items() if v is not None}
    delivery.write(tmp_path / "g.toml", allow_failed=True)
    for name in ("g.toml", "g.json"):  # the TOML and its JSON twin carry the same digests
        doc = read_document(tmp_path / name)
        assert doc["certificate"] == read_document(tmp_path / "g.toml")["certificate"]
        assert read_certificate(doc, name).status == "valid"
    doc = read_document(tmp_path / "g.toml")
    # the pre-filter acts outside the loop: adding it keeps the certificate
    assert read_certificate(with_prefilter(doc, gains={"K_vel": 1e-3}, lpf_hz=80.0), "pf").status == "valid"
    edited = copy.deepcopy(doc)
    edited["gains"]["Kx1"]["value"] *= 1.001
    stale = read_certificate(edited, "edited.toml")
    assert stale.status == "edited" and stale.changed == ("gains",)
    assert "gains changed since they were certified on ballscrew_frf.csv (sha256 " in stale.problem()
    old = copy.deepcopy(doc)
    del old["certificate"]["gains_sha256"]
    assert read_certificate(old, "old.toml").status == "undigested"


def test_a_stored_certificate_judged_under_other_limits_is_the_certificate_made_anew(delivered, tmp_path):
    from feedtune.io import read_document
    from feedtune.io.document import strip_none
    from feedtune.machines.certificate import Certificate, FrfSource, certify

    delivery, frf = delivered
    delivery.write(tmp_path / "g.toml", allow_failed=True)
    doc = read_document(tmp_path / "g.toml")
    body = {k: v for k, v in doc.items() if k != "certificate"}
    for limits in (PROFILES["thesis"], PROFILES["textbook"].override(ms_max=2.0, gm_low_min_db=20.0)):
        stored = Certificate.from_section(doc["certificate"], limits)
        fresh = certify(body, "g", [FrfSource.from_file(EXAMPLE_FRF, frf, "ballscrew_frf.csv")], limits)
        assert strip_none(stored.to_dict()) == strip_none(fresh.to_dict())  # TOML keeps no null entries
        assert stored.violations() == fresh.violations()
    assert not Certificate.from_section(doc["certificate"], PROFILES["textbook"].override(ms_max=1.2)).ok


def test_deliver_refuses_an_unknown_design_and_a_failed_write(delivered, tmp_path):
    from feedtune.errors import UsageError
    from feedtune.workflows.deliver import deliver

    with pytest.raises(UsageError, match="not a design feedtune delivers"):
        deliver(object())
    delivery, _ = delivered
    failed = type(delivery)(delivery.design, delivery.structure, delivery.document, delivery.certificate,
                            ("crossover 1 Hz differs from the requested 2 Hz",))
    with pytest.raises(DesignError, match="allow_failed=True"):
        failed.write(tmp_path / "x.toml")
    assert not (tmp_path / "x.toml").exists()


# ------------------------------------------------------------------------------------------ the command line
def _axis_frf(path):
    """x axis: 0.6977 V/(m/s^2) behind a 150 Hz, zeta 0.7 amplifier, 2-2000 Hz (the pure-mass model lacks it)."""
    from feedtune.io import write_frf

    f = np.geomspace(2.0, 2000.0, 600)
    s = 2j * np.pi * f
    wa = 2 * np.pi * 150.0
    h = 1 / (0.6977 * s**2) * wa**2 / (s**2 + 1.4 * wa * s + wa**2)
    write_frf(Frf.from_channels(f, {"x/u": h}, input_unit="V", output_unit="m", meta={"source": "axis"}), path)
    return path


AXIS_DESIGN = ["--pi-lag-deg", "5", "--max-stage-deg", "60", "--fs", "15000"]


def _design_axis(cli, tmp_path, crossover_hz: str = "200", pm_deg: str = "42", out: str = "axis.toml", *more):
    """``design loopshape`` on the synthetic axis FRF (written once), certified on it; returns the FRF's path. At
    200 Hz / 42 deg the design passes on the FRF and fails on the pure-mass model; at 180 Hz / 40 deg it fails on
    the FRF (Ms 2.68)."""
    frf = tmp_path / "axis_frf.csv"
    if not frf.exists():
        _axis_frf(frf)
    res = cli("design", "loopshape", frf, "--crossover-hz", crossover_hz, "--pm-deg", pm_deg, *AXIS_DESIGN,
              "--out", tmp_path / out, *more)
    assert res.exit_code == 0, res.output
    return frf


def test_export_honours_the_files_certificate_and_says_what_would_certify_an_uncertified_one(cli, tmp_path):
    from feedtune.io import read_document, write_document

    frf = _design_axis(cli, tmp_path)
    doc = read_document(tmp_path / "axis.toml")
    assert doc["certificate"]["ok"] and doc["certificate"]["frfs"][0]["frf"] == str(frf)
    # certified on its FRF: exported without --allow-unstable, and the command says on what
    res = cli("export", "c", tmp_path / "axis.toml")
    assert res.exit_code == 0, res.output
    assert "verdict on the file's certificate: certified on" in res.output and "axis_frf.csv (sha256 " in res.output
    # the same gains without the certificate: the model alone (no 150 Hz amplifier) refuses them, and says how to
    # certify them
    del doc["certificate"]
    write_document(tmp_path / "bare.toml", doc)
    res = cli("export", "c", tmp_path / "bare.toml")
    assert res.exit_code == 1
    assert "peak sensitivity Ms" in res.output and "ideal_discrete case" in res.output
    assert "tune or design with --frf, or pass --frf to export c" in res.output
    # --frf certifies them now (and the header is written)
    res = cli("export", "c", tmp_path / "bare.toml", "--frf", frf, "--force")
    assert res.exit_code == 0, res.output
    assert "a certificate made now on" in res.output
    # analyze without --frf gives the file's certificate, not the model's contradicting check
    res = cli("analyze", tmp_path / "axis.toml", "--check")
    assert res.exit_code == 0, res.output
    assert "the verdict rests on the file's certificate" in res.output


def test_an_edited_gain_voids_the_certificate_and_a_failed_certificate_is_refused_with_its_limit(cli, tmp_path):
    from feedtune.io import read_document, write_document

    _design_axis(cli, tmp_path)
    doc = read_document(tmp_path / "axis.toml")
    doc["gains"]["K"]["value"] *= 1.01
    write_document(tmp_path / "edited.toml", doc)
    res = cli("export", "c", tmp_path / "edited.toml")
    assert res.exit_code == 1
    assert "the gains were edited after they were certified (gains changed since" in res.output
    # a design whose certificate fails, written anyway: refused by export, naming the failing limit
    _design_axis(cli, tmp_path, "180", "40", "bad.toml", "--allow-unstable")
    assert read_document(tmp_path / "bad.toml")["certificate"]["ok"] is False
    res = cli("export", "c", tmp_path / "bad.toml")
    assert res.exit_code == 1
    assert "peak sensitivity Ms = 2.68" in res.output and "exceeds --ms-max 2.5 (discrete case)" in res.output
    assert "the file's certificate: certified on" in res.output


def test_the_same_design_on_the_same_frf_writes_the_same_certificate_whichever_command_made_it(cli, tmp_path):
    """tune on one FRF, design with the tuned settings and --frf, and the library's deliver (the demos' path) with
    the FRF from memory: the certificates are equal (the FRF's identity aside: a file's bytes or its arrays; and the
    design record differs, so does its section digest)."""
    from feedtune.io import load_model, read_document, read_frf
    from feedtune.machines.certificate import FrfSource
    from feedtune.workflows.deliver import deliver

    assert cli("identify", "ballscrew", EXAMPLE_FRF, "--out", tmp_path / "model.toml").exit_code == 0
    res = cli("tune", "mcppc", tmp_path / "model.toml", "--frf", EXAMPLE_FRF, *THESIS_PACK,
              "--out", tmp_path / "tuned.toml")
    assert res.exit_code == 0, res.output
    tuned = read_document(tmp_path / "tuned.toml")
    beta, pole, zeta = (tuned["design"][k] for k in ("beta", "pole_hz", "zeta"))
    res = cli("design", "ppc", tmp_path / "model.toml", "--beta", repr(beta), "--pole-hz", repr(pole), "--zeta",
              repr(zeta), *THESIS_PACK, "--frf", EXAMPLE_FRF, "--out", tmp_path / "designed.toml")
    assert res.exit_code == 0, res.output
    designed = read_document(tmp_path / "designed.toml")
    assert designed["gains"] == tuned["gains"]

    def certificate(doc, drop=()):
        c = {k: v for k, v in doc["certificate"].items() if k not in ("gains_sha256", "sections_sha256")}
        c["frfs"] = [{k: v for k, v in e.items() if k not in drop} for e in c["frfs"]]
        return c

    assert certificate(designed) == certificate(tuned)
    assert {k: v for k, v in designed["certificate"]["sections_sha256"].items() if k != "design"} == \
        {k: v for k, v in tuned["certificate"]["sections_sha256"].items() if k != "design"}
    from feedtune import design_mcppc
    from feedtune.control.filters import FilterPack, Notch

    pack = FilterPack([Notch(420, 0.55, 0.7), Notch(1080, 0.05, 0.7)], 2000.0)
    design = design_mcppc(load_model(tmp_path / "model.toml"), beta=beta, pole_hz=pole, zeta=zeta, filters=pack)
    frf = read_frf(EXAMPLE_FRF)
    lib = deliver(design, [FrfSource.from_memory(EXAMPLE_FRF, frf)], date=designed["certificate"]["date"])
    assert lib.document["certificate"]["frfs"][0]["identity"] == "arrays"
    assert lib.document["certificate"]["frfs"][0]["arrays_sha256"] == designed["certificate"]["frfs"][0][
        "arrays_sha256"]
    assert certificate(lib.document, ("sha256", "identity")) == certificate(designed, ("sha256", "identity"))


def test_the_report_takes_the_files_certificate_without_an_frf(cli, tmp_path):
    from feedtune.io import read_document, write_document
    from feedtune.report.build import build_report

    frf = _design_axis(cli, tmp_path)
    doc = read_document(tmp_path / "axis.toml")
    del doc["certificate"]
    write_document(tmp_path / "bare.toml", doc)
    data = build_report([tmp_path / "axis.toml", tmp_path / "bare.toml"], render=False).data["design"]
    assert data["axis.toml"]["verdict"]["basis"] == "certificate" and data["axis.toml"]["check"]["ok"]
    assert data["bare.toml"]["verdict"]["basis"] == "model" and not data["bare.toml"]["check"]["ok"]
    with_frf = build_report([tmp_path / "bare.toml", frf], render=False).data["design"]["bare.toml"]
    assert with_frf["verdict"]["basis"] == "frfs" and with_frf["check"]["ok"]
