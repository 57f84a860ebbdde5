"""The report of drive-cascade gains files (issue 24 item 2, docs/cascade.md): both loops (speed L_v, position L_p) in
Bode, Nyquist and |S| figures for every design on every FRF and on the model, tables whose numbers are those of
``feedtune analyze --json`` on the same files, the headline per design; and a one-channel FRF's certificate saying
what it assumes above the band once.

References: ``feedtune analyze GAINS [--frf F] --json`` (the command the report must agree with, one formatter: the
analysis' dictionaries, shown by the report's one cell formatter), and the speed loop's first crossover on the model
found by a root search on the loop written out here (PI, the speed as ``s x``, a rigid body and the first-order
current loop the design assumes), not by the package's analysis.
"""

from __future__ import annotations

import json
import math
from io import BytesIO

import numpy as np
import pytest
from report_checks import BROWSER, MIN_PIXELS, axes_mask, colour_pixels
from scipy.optimize import brentq
from test_report import assert_same_numbers, lookup
from typer.testing import CliRunner

from feedtune.cli.main import app
from feedtune.io import dumps_toml, model_document
from feedtune.models.rigid import RigidBodyModel
from feedtune.report.build import build_report
from feedtune.report.content import Cell, Table

runner = CliRunner()
RIGID = RigidBodyModel(mass=1.2e-4, viscous=7.0e-5, command_unit="N*m", position_unit="rad")
"""A servo motor like HSM150 (docs/cascade.md): inertia [N m/(rad/s^2)], viscous friction [N m/(rad/s)]."""
DESIGNS = {"fast.toml": ("--kp", "0.2", "--tn", "0.007", "--kv", "500"),
           "slow.toml": ("--kp", "0.08", "--tn", "0.012", "--kv", "150", "--filter", "pt2:1500,0.7")}
"""Two cascades of one axis: a stiff one and a soft one with a PT2 current-setpoint filter."""
CURRENT_LOOP_HZ = 1000.0
"""The current loop a cascade on a model alone assumes (docs/cascade.md)."""
LOOP_FIGURES = [f"cascade-{loop}-{kind}" for loop in ("speed", "position")
                for kind in ("loop", "nyquist", "sensitivity")]
TITLES = {"loop": "Bode", "nyquist": "Nyquist", "sensitivity": "sensitivity |S|"}
LOOPS = {"speed": "Speed loop L_v", "position": "Position loop L_p"}


def cli(*args):
    return runner.invoke(app, [str(a) for a in args])


def analyze_json(*args) -> dict:
    res = cli("analyze", *args, "--json")
    assert res.exit_code == 0, res.output
    return json.loads(res.output)


@pytest.fixture(scope="module")
def axis(tmp_path_factory):
    folder = tmp_path_factory.mktemp("cascade")
    (folder / "axis.toml").write_text(dumps_toml(model_document(RIGID)))
    for name, values in DESIGNS.items():
        res = cli("design", "cascade", folder / "axis.toml", *values, "--out", folder / name)
        assert res.exit_code == 0, res.output
    return folder


@pytest.fixture(scope="module")
def report(axis):
    return build_report([axis / "axis.toml", *(axis / n for n in DESIGNS)], render=False)


def test_cascade_report_draws_both_loops_of_both_designs(report):
    figs = {f.name: f for f in report.figures()}
    assert set(LOOP_FIGURES) <= set(figs)
    assert {f"design-controller-{n}" for n in DESIGNS} <= set(figs)
    designs = {f"drive cascade ({n.removesuffix('.toml')})" for n in DESIGNS}
    for name in LOOP_FIGURES:
        block = figs[name]
        loop, kind = name.split("-")[1:]
        assert block.source.keywords["title"] == f"{LOOPS[loop]}: {TITLES[kind]}"
        curves = block.source.args[0]
        # every design on the model (dashed), one colour each; the figure names both as the designs it compares
        assert {c.label for c in curves} == {f"{d}, model" for d in designs}
        assert len({c.color for c in curves}) == 2 and {c.style for c in curves} == {"--"}
        assert {label for label, _ in block.shows} == designs
    # both drawn and visible: each design's colour inside the axes of every loop figure
    from PIL import Image

    from feedtune.report.figures import figure_png

    for name in ("cascade-speed-loop", "cascade-position-sensitivity"):
        fig = figs[name].figure
        rgb = np.asarray(Image.open(BytesIO(figure_png(fig))).convert("RGB"))
        mask = axes_mask(fig, rgb.shape[:2])
        for label, color in figs[name].shows:
            assert colour_pixels(rgb, mask, color) >= MIN_PIXELS, (name, label)


def test_cascade_report_numbers_are_analyze_json(report, axis):
    data = report.data["design"]
    for name in DESIGNS:
        expected = analyze_json(axis / name)
        assert_same_numbers(data[name]["analysis"], expected["analysis"])
        assert_same_numbers(data[name]["on"]["model"], expected["analysis"])
        assert data[name]["check"]["ok"] == expected["check"]["ok"]
        assert_same_numbers(data[name]["verdict"]["certificate"]["worst"], expected["verdict"]["certificate"]["worst"])
        assert data[name]["gains"] == {k: v["value"] for k, v in expected["gains"].items()}
    # every number in the cascade section's tables is the value at its key in the data, shown in its unit
    section = report.section("design-cascade")
    cells = [c for b in section.blocks if isinstance(b, Table) for row in b.rows for c in row
             if isinstance(c, Cell) and c.key is not None]
    keys = {tuple(c.key[:4]) for c in cells}
    assert {("design", n, "on", "model") for n in DESIGNS} <= keys
    assert {("design", n, "analysis", case) for n in DESIGNS for case in ("ideal", "position_ideal_discrete")} <= keys
    for c in cells:
        got = lookup(report.data, c.key)
        assert got == pytest.approx(c.value, rel=1e-12) if c.value is not None else got is None, c.key
    # the certificate table has both loops of each design, with the limit that binds
    cert = [b for b in section.blocks if isinstance(b, Table) and b.title.startswith("Certificate of")]
    assert len(cert) == 2
    for t in cert:
        assert [(r[0].text, r[1].text) for r in t.rows] == [("model", "speed"), ("model", "position")]
        assert all(r[-2].text.startswith(("Ms ", "PM ", "GM ")) and r[-1].text == "ok" for r in t.rows)
    # the headline per design: verdict, guaranteed bandwidth and the binding limit of analyze's verdict
    head = next(b for b in report.section("summary").blocks if isinstance(b, Table))
    for row, name in zip(head.rows, DESIGNS, strict=True):
        worst = analyze_json(axis / name)["verdict"]["certificate"]["worst"]
        assert row[1].text == "PASS" and row[2].value == pytest.approx(worst["first_crossover_hz"], rel=1e-12)
        assert row[3].text.endswith(f"on {worst['active_limit']['frf']}")


def test_a_file_without_a_model_is_drawn_on_its_frf_and_refused_with_the_reason_without_one(axis, tmp_path):
    """A drive's parameter set read by ``import drive`` holds no [model]: the report analyses it on the FRF among its
    inputs that fits (the rigid body written out here as an FRF in rad/(N*m)), and without one it stops with one
    line naming the file and what to give."""
    from feedtune.errors import DataError
    from feedtune.frf import Frf
    from feedtune.io import read_document, write_document
    from feedtune.io.frf_read import write_frf

    doc = {k: v for k, v in read_document(axis / "fast.toml").items() if k not in ("model", "certificate")}
    write_document(tmp_path / "drive.toml", doc)
    f = np.geomspace(1.0, 2000.0, 800)
    s = 2j * np.pi * f
    rigid = 1 / (s * (RIGID.mass * s + RIGID.viscous))
    write_frf(Frf(f, rigid[None, None], ("x1",), ("u",), "position", input_unit="N*m", output_unit="rad"),
              tmp_path / "rigid.csv")
    rep = build_report([tmp_path / "drive.toml", tmp_path / "rigid.csv"], render=False)
    assert list(rep.data["design"]["drive.toml"]["on"]) == ["rigid.csv"]
    with pytest.raises(DataError, match=r"drive\.toml: the gains file holds no plant model .* give the FRF"):
        build_report([tmp_path / "drive.toml"], render=False)


def test_speed_loop_crossover_on_the_model_is_the_written_out_loop(report):
    """The report's first crossover of L_v (model, continuous controller) is where the loop written out here,
    ``Kp (1 + 1/(Tn s)) s G(s) / (1 + s/wc)`` with ``G = 1/(s (J s + B))``, has ``|L| = 1``."""
    for name, values in DESIGNS.items():
        opts = dict(zip(values[::2], values[1::2], strict=True))
        kp, tn = float(opts["--kp"]), float(opts["--tn"])
        filt = opts.get("--filter")

        def mag(f, kp=kp, tn=tn, filt=filt):
            s = 2j * math.pi * f
            lag = 1 + s / (2 * math.pi * CURRENT_LOOP_HZ)
            loop = kp * (1 + 1 / (tn * s)) / (RIGID.mass * s + RIGID.viscous) / lag
            if filt:
                hz, d = (float(x) for x in filt.split(":")[1].split(","))
                w = 2 * math.pi * hz
                loop *= w * w / (s * s + 2 * d * w * s + w * w)
            return abs(loop) - 1.0

        expected = brentq(mag, 1.0, 3000.0, xtol=1e-9)
        got = report.data["design"][name]["analysis"]["ideal"]["first_crossover_hz"]
        assert got == pytest.approx(expected, rel=2e-3), name


# ------------------------------------------------------------------------------------------ on measured FRFs
@pytest.mark.slow
def test_drive_tuning_and_feedtune_tuning_on_the_vendor_frf_in_one_report(examples_dir, tmp_path):
    """The drive's own tuning (an auto-servo-tuning export's controller, with a position gain) and feedtune's tuning
    of the same speed-loop FRF: both designs in every loop figure, on the FRF (solid) and on the model (dashed), each
    visible; the tables' numbers those of ``feedtune analyze GAINS --frf XML --json``; the command writes it."""
    from PIL import Image

    from feedtune.report.figures import figure_png

    xml = examples_dir / "vendor" / "auto_servo_tuning.xml"
    for args in (("design", "cascade", xml, "--drive-tuning", xml, "--kv", 150, "--out", tmp_path / "drive.toml"),
                 ("tune", "cascade", xml, "--out", tmp_path / "feedtune.toml")):
        res = cli(*args)
        assert res.exit_code == 0, res.output
    gains = [tmp_path / "drive.toml", tmp_path / "feedtune.toml"]
    rep = build_report([*gains, xml])
    figs = {f.name: f for f in rep.figures()}
    labels = {"drive cascade (drive)", "drive cascade (feedtune)"}
    for name in LOOP_FIGURES:
        curves = figs[name].source.args[0]
        assert {(c.label, c.style) for c in curves} == {(f"{d} on {xml.name}", "-") for d in labels} | {
            (f"{d}, model", "--") for d in labels}, name
        fig = figs[name].figure
        rgb = np.asarray(Image.open(BytesIO(figure_png(fig))).convert("RGB"))
        mask = axes_mask(fig, rgb.shape[:2])
        assert {label for label, _ in figs[name].shows} == labels
        for label, color in figs[name].shows:
            assert colour_pixels(rgb, mask, color) >= MIN_PIXELS, (name, label)
    for g in gains:
        expected = analyze_json(g, "--frf", xml)
        got = rep.data["design"][g.name]
        assert_same_numbers(got["on"][xml.name], expected["analysis"])
        # the same worst case; its FRF named as the report shows it (the command names it as typed)
        assert_same_numbers(json.loads(json.dumps(got["verdict"]["certificate"]["worst"])),
                            json.loads(json.dumps(expected["verdict"]["certificate"]["worst"]).replace(str(xml),
                                                                                                       xml.name)))
        assert got["frfs"] == [xml.name] and got["verdict"]["basis"] == "frfs"
    cert = [b for b in rep.section("design-cascade").blocks if isinstance(b, Table) and b.title.startswith("Certif")]
    assert [[(r[0].text, r[1].text) for r in t.rows] for t in cert] == [[
        (xml.name, "speed"), (xml.name, "position"), ("model", "speed"), ("model", "position")]] * 2
    res = cli("report", *gains, xml, "--out", tmp_path / "rep.html")
    assert res.exit_code == 0, res.output
    assert f"report with {len(rep.figures())} figures" in res.output and len(rep.figures()) >= 9
    if BROWSER is not None:  # as a reader sees it: every table fits at 1280 px, no cell overflows, no page scroll
        from test_report_browser import DESKTOP, probe

        seen = probe(tmp_path / "rep.html", DESKTOP, tmp_path)
        assert len(seen["imgs"]) == len(rep.figures()) and seen["cells"] == []
        assert seen["page_scroll_width"] <= seen["vw"]
        assert all(t["box_scroll_width"] <= t["box_client_width"] + 1 for t in seen["tables"]), seen["tables"]


@pytest.mark.slow
def test_one_channel_certificate_says_what_it_assumes_once(real_data_dir, tmp_path):
    """The two-mass bench's motor side alone (ends at 250 Hz, the loop there not small): the certificate's line on
    what the figures assume above the FRF names the channel once (it was printed twice: the cascade's plant holds
    x1/u as the motor side and as the position loop's side), as the report's verdict line does."""
    frf = tmp_path / "tm_x1.csv"
    res = cli("frf", real_data_dir / "twomass_motor_bench_FdiTools" / "MultisineTypeA.mat", "--map", "u=iq_refx",
              "--map", "x1=theta_mx", "--scale", "time=1e-6", "--unit", "u=A", "--unit", "x1=rad", "-y", "x1",
              "--method", "periodic", "--period-samples", 2500, "--out", frf)
    assert res.exit_code == 0, res.output
    res = cli("design", "cascade", frf, "--kp", 6, "--tn", 0.0185, "--kv", 70, "--filter", "so:83.7,0.0667,83.7,0.334",
              "--filter", "so:222.5,0.1186,222.5,0.2685", "--filter", "so:127.5,0.1186,127.5,0.334",
              "--out", tmp_path / "given.toml")
    assert res.exit_code == 0, res.output
    lines = [ln for ln in res.output.splitlines() if "assumes" in ln]
    assert len(lines) == 1 and lines[0].count("x1/u above 250 Hz") == 1, lines
    rep = build_report([tmp_path / "given.toml", frf], render=False)
    verdict = next(b.text for b in rep.section("design-cascade").blocks if type(b).__name__ == "Verdict")
    assert verdict.count("x1/u above 250 Hz") == 1, verdict


@pytest.mark.slow
@pytest.mark.parametrize("which, unit", [("HSM150", "N*m"), ("ODrive", "V")])
def test_real_rigid_axis_report_in_its_units(which, unit, real_data_dir, tmp_path, capsys, monkeypatch):
    """docs/cascade.md "Real rigid axes end to end" then ``feedtune report GAINS MODEL``: both loops drawn (it drew
    the identification alone), the gains in the data's units, the headline the certificate's."""
    from cli_run import run
    from test_tune_cascade import _hsm_model, _odrive_model

    model = (_hsm_model if which == "HSM150" else _odrive_model)(real_data_dir, tmp_path, capsys, monkeypatch)
    gains = tmp_path / "gains.toml"
    code, _, err = run(["tune", "cascade", model, "--out", gains], capsys, monkeypatch)
    assert code == 0, err
    code, out, err = run(["report", gains, model, "--out", tmp_path / "rep.html"], capsys, monkeypatch)
    assert code == 0, err
    rep = build_report([gains, model], render=False)
    assert set(LOOP_FIGURES) <= {f.name for f in rep.figures()} and f"report with {len(rep.figures())} figures" in out
    section = rep.section("design-cascade")
    shown = {c.unit for b in section.blocks if isinstance(b, Table) for row in b.rows for c in row
             if isinstance(c, Cell)}
    assert {f"{unit}/(rad/s)", f"{unit}/(rad/s^2)", "1/s"} <= shown
    worst = analyze_json(gains)["verdict"]["certificate"]["worst"]
    head = next(b for b in rep.section("summary").blocks if isinstance(b, Table))
    assert head.rows[0][1].text == "PASS"
    assert head.rows[0][2].value == pytest.approx(worst["first_crossover_hz"], rel=1e-12)
