"""feedtune report: sections for the inputs given, figures present, numbers equal to the --json commands,
self-contained HTML, partial inputs, bad inputs, no recomputation, and the demo's report."""

from __future__ import annotations

import base64
import html
import io
import json
import re

import numpy as np
import pytest
from typer.testing import CliRunner

from feedtune.analysis.limits import DEFAULT_LIMITS
from feedtune.cli.main import app
from feedtune.errors import DataError, UsageError, cli_message
from feedtune.io import dumps_toml, model_document, write_log_csv
from feedtune.log import Log
from feedtune.report.build import build_report
from feedtune.report.content import Alert, FigureBlock, Paragraph, Table
from feedtune.report.figures import envelope, log_envelope
from feedtune.report.sections import ReportLimits
from feedtune.report.time_domain import saturation
from feedtune.workflows.ballscrew_demo import run_demo
from feedtune.workflows.files import write_texts

runner = CliRunner()

DATA_RE = re.compile(r'<script type="application/json" id="feedtune-report-data">(.*?)</script>', re.S)
CELL_RE = re.compile(r"<td class=\"num\"(?: data-key='([^']*)')? data-value='([^']*)'>(.*?)</td>", re.S)
DISPLAY_SCALE = {"µm": 1e6, "ms": 1e3}


# ------------------------------------------------------------------------------------------ fixtures
@pytest.fixture(scope="module")
def demo_result():
    return run_demo(seed=1, speeds=(0.2, 0.5), include_cut=True)


@pytest.fixture(scope="module")
def demo_dir(demo_result, tmp_path_factory):
    out = tmp_path_factory.mktemp("demo") / "demo_out"
    write_texts(demo_result.texts, out_dir=out)
    return out


@pytest.fixture(scope="module")
def report(demo_dir):
    return build_report([demo_dir])


def cli(*args):
    return runner.invoke(app, [str(a) for a in args])


def cli_json(*args) -> dict:
    res = cli(*args, "--json")
    assert res.exit_code == 0, res.output
    return json.loads(res.output)


PEAK_LOCATIONS = ("ms_freq_hz", "disk_margin_freq_hz", "disturbance_peak_freq_hz", "disturbance_min_real_freq_hz")
"""Keys that give where a curve has its maximum or minimum [Hz]. The value at a smooth extremum moves with the square
of a shift of its place, so the place is fixed by the curve only to about the square root of the rounding: two
analyses that differ in the last bits (below) put a flat Ms peak 1e-11 apart (seen once in CI); compared to
:data:`PEAK_REL`, every value itself to 1e-12."""
PEAK_REL = 1e-7


def assert_same_numbers(got, expected, path="", rel=1e-12):
    """``got == expected`` with floats equal to ``rel`` (two analyses of the same files in one process may differ in
    the last bits: LAPACK's results depend on the memory alignment of a recomputed discretization), the places of
    extrema (:data:`PEAK_LOCATIONS`) to :data:`PEAK_REL`; every key, length, string, bool and None exactly."""
    if isinstance(expected, dict):
        assert isinstance(got, dict) and set(got) == set(expected), (path, sorted(set(got) ^ set(expected)))
        for k in expected:
            assert_same_numbers(got[k], expected[k], f"{path}/{k}", max(rel, PEAK_REL) if k in PEAK_LOCATIONS else rel)
    elif isinstance(expected, list):
        assert isinstance(got, list) and len(got) == len(expected), path
        for i, (g, e) in enumerate(zip(got, expected, strict=True)):
            assert_same_numbers(g, e, f"{path}[{i}]", rel)
    elif isinstance(expected, float) and not isinstance(expected, bool):
        assert isinstance(got, (int, float)) and got == pytest.approx(expected, rel=rel, abs=1e-300), (path, got)
    else:
        assert got == expected, (path, got, expected)


def embedded_data(text: str) -> dict:
    m = DATA_RE.search(text)
    assert m is not None
    return json.loads(m.group(1))


def lookup(data, key):
    for k in key:
        data = data[k]
    return data


NUMBERS_RE = re.compile(r"^([-+0-9.eE]+(?:, [-+0-9.eE]+)*)\s*(.*)$")


def shown_numbers(text: str) -> tuple[list[float], str]:
    """Numbers and unit of a table cell text such as '1.992 µm', '7.25e+04 V/(rad s)' or '94.08, 124.3 Hz'."""
    m = NUMBERS_RE.match(text)
    assert m is not None, text
    return [float(x) for x in m.group(1).split(", ")], m.group(2)


def section_keys(rep) -> set[str]:
    return {s.key for top in rep.sections for s in top.walk()}


# ------------------------------------------------------------------------------------------ full report
@pytest.mark.slow
def test_demo_report_has_every_section_with_content(report):
    keys = section_keys(report)
    assert [s.key for s in report.sections] == ["summary", "identification", "design", "time", "inputs"]
    assert {"model-model.toml", "design-ballscrew", "time-tracking", "time-ropesnap"} <= keys
    for top in report.sections:
        for s in top.walk():
            assert not s.is_empty(), s.key
    names = {f.name for f in report.figures()}
    assert {"frf-frf.csv", "design-poles", "design-loop", "design-nyquist", "design-sensitivity",
            "design-disturbance", "design-tracking"} <= names
    assert sum(n.startswith("time-track-") for n in names) == 2  # 200 and 500 mm/s
    assert sum(n.startswith("time-cut-") for n in names) == 1
    assert sum(n.startswith("time-ropesnap") for n in names) == 1
    titles = [t.title for t in report.tables()]
    for needle in ("Identified parameters", "Modes", "Fit quality", "Gains of MC-PPC", "Gains of P-PI",
                   "Stability, margins", "Closed-loop poles", "Table 3.2", "Rope snap", "Files"):
        assert any(needle in t for t in titles), needle


@pytest.mark.slow
def test_every_figure_is_a_non_empty_image(report):
    import matplotlib.image as mpimg

    embedded = re.findall(r'<figure id="fig-([^"]+)"><img [^>]*src="data:image/png;base64,([^"]+)"', report.html)
    assert len(embedded) == len(report.figures())
    for (fig_id, data), f in zip(embedded, report.figures(), strict=True):
        png = base64.b64decode(data)
        assert png[:8] == b"\x89PNG\r\n\x1a\n" and len(png) > 10_000, fig_id
        img = mpimg.imread(io.BytesIO(png), format="png")
        assert img.shape[0] > 200 and img.shape[1] > 500, fig_id
        # drawn content: a good share of pixels differ from the white background
        assert np.mean(np.any(img[..., :3] < 0.9, axis=-1)) > 0.02, fig_id
        axes = [ax for ax in f.figure.axes if ax.get_lines() or ax.collections]
        assert axes and all(ax.get_ylabel() for ax in axes) and any(ax.get_xlabel() for ax in axes), fig_id


@pytest.mark.slow
def test_html_embeds_every_figure_and_opens_without_network(report):
    text = report.html
    assert text.startswith("<!DOCTYPE html>") and len(text) < 10e6
    assert "http://" not in text and "https://" not in text
    assert not re.search(r"<script(?![^>]*type=\"application/json\")", text)  # only the data block
    assert "<link" not in text and "@import" not in text and "url(" not in text
    srcs = re.findall(r'<img [^>]*src="([^"]+)"', text)
    assert len(srcs) == len(report.figures())
    assert all(s.startswith("data:image/png;base64,") for s in srcs)


# ------------------------------------------------------------------------------------------ numbers
@pytest.mark.slow
def test_design_numbers_equal_analyze_json(report, demo_dir):
    for gains in ("mcppc_gains.toml", "ppi_gains.toml"):
        expected = cli_json("analyze", demo_dir / gains, "--frf", demo_dir / "frf.csv")
        expected = {**expected, "kind": expected["controller"],  # the --json envelope's spelling (docs/json.md)
                    "gains": {k: q["value"] for k, q in expected["gains"].items()}}
        got = report.data["design"][gains]
        for key in ("kind", "gains"):
            assert got[key] == expected[key], (gains, key)
        for key in ("closed_loop_poles", "analysis"):
            assert_same_numbers(got[key], expected[key], f"{gains}/{key}")
        assert got["frf"] == "frf.csv"


@pytest.mark.slow
def test_time_domain_numbers_equal_analyze_track_and_ropesnap_json(report, demo_dir):
    tracks = sorted(p.name for p in demo_dir.glob("track_*.csv")) + sorted(p.name for p in demo_dir.glob("cut_*.csv"))
    assert sorted(report.data["tracking"]) == sorted(tracks)
    for name in tracks:
        assert report.data["tracking"][name]["metrics"] == cli_json("analyze", "track", demo_dir / name)["metrics"]
    for name in ("ropesnap_mcppc.csv", "ropesnap_ppi.csv"):
        expected = cli_json("analyze", "ropesnap", demo_dir / name)["metrics"]
        assert report.data["ropesnap"][name]["metrics"] == expected


@pytest.mark.slow
def test_visible_tables_show_the_embedded_numbers(report):
    data = embedded_data(report.html)
    assert data == json.loads(json.dumps(report.data))
    cells = CELL_RE.findall(report.html)
    keyed = [c for c in cells if c[0]]
    assert len(keyed) > 100
    for key_text, value_text, shown in keyed:
        key = json.loads(html.unescape(key_text))
        value = json.loads(html.unescape(value_text))
        assert lookup(data, key) == value, key
        numbers, unit = shown_numbers(html.unescape(shown))
        values = value if isinstance(value, list) else [value]
        if isinstance(values[0], bool):
            continue
        scale = DISPLAY_SCALE.get(unit, 1.0)
        assert len(numbers) == len(values), (key, shown)
        for n, v in zip(numbers, values, strict=True):
            assert n == pytest.approx(v * scale, rel=6e-4, abs=1e-300), (key, shown, v)


@pytest.mark.slow
def test_comparison_is_table_3_2_with_reductions_from_the_logs(report, demo_result):
    rows = report.data["comparison"]["tracking"]["rows"]
    assert report.data["comparison"]["tracking"]["baseline"] == "P-PI"
    assert [r["run"] for r in rows] == ["tracking, peak speed 200 mm/s", "tracking, peak speed 500 mm/s",
                                        "cut, peak speed 200 mm/s"]
    assert [r["cut"] for r in rows] == [False, False, True]
    demo_rows = [r for r in demo_result.rows if "max_um" in r["mcppc"]]  # computed by the twin experiments
    for row, demo_row in zip(rows, demo_rows, strict=True):
        mc, pp = row["runs"]["MC-PPC"], row["runs"]["P-PI"]
        assert mc["max_m"] * 1e6 == pytest.approx(demo_row["mcppc"]["max_um"], rel=1e-9)
        assert pp["rms_m"] * 1e6 == pytest.approx(demo_row["ppi"]["rms_um"], rel=1e-9)
        red = row["reduction_pct"]["MC-PPC"]
        assert red["max"] == pytest.approx(100 * (1 - mc["max_m"] / pp["max_m"]))
        assert red["rms"] == pytest.approx(100 * (1 - mc["rms_m"] / pp["rms_m"]))
    snap = report.data["comparison"]["ropesnap"]["rope snap 0.5 V"]["MC-PPC"]
    rope = next(r for r in demo_result.rows if r["test"] == "0.5 V")
    assert snap["peak"] == pytest.approx(100 * (1 - rope["mcppc"]["peak_um"] / rope["ppi"]["peak_um"]), rel=1e-6)
    assert snap["settling_time"] == pytest.approx(
        100 * (1 - rope["mcppc"]["settling_time_s"] / rope["ppi"]["settling_time_s"]), rel=1e-6)
    summary = report.section("summary")
    assert any(isinstance(b, Paragraph) and "Against P-PI, MC-PPC reduces" in b.text for b in summary.blocks)


@pytest.mark.slow
def test_summary_flags_ms_above_the_limit(demo_dir):
    # the demo's gains file carries its certificate on the twin's FRF: the verdict (analyze's and the report's)
    # rests on it, its stored figures judged under the limits asked for
    verdict = cli_json("analyze", demo_dir / "ppi_gains.toml")["verdict"]
    assert verdict["basis"] == "certificate"
    ms = verdict["certificate"]["worst"]["ms"]
    assert ms > 1.5
    low = build_report([demo_dir / "ppi_gains.toml"], limits=ReportLimits(DEFAULT_LIMITS.override(ms_max=1.5)),
                       render=False)
    assert any(f"Ms = {ms:.3g}" in w and "exceeds the limit 1.5" in w for w in low.warnings)
    high = build_report([demo_dir / "ppi_gains.toml"], limits=ReportLimits(DEFAULT_LIMITS.override(ms_max=10.0)),
                        render=False)
    assert not any("Ms =" in w for w in high.warnings)


# ------------------------------------------------------------------------------------------ partial inputs
@pytest.mark.parametrize(
    ("files", "expected"),
    [
        (("model.toml", "frf.csv"), ["summary", "identification", "inputs"]),
        (("mcppc_gains.toml",), ["summary", "design", "inputs"]),
        (("track_200mm_s_mcppc.csv", "ropesnap_ppi.csv"), ["summary", "time", "inputs"]),
    ],
)
@pytest.mark.slow
def test_partial_inputs_give_a_partial_report_without_empty_sections(demo_dir, files, expected):
    rep = build_report([demo_dir / f for f in files], render=False)
    assert [s.key for s in rep.sections] == expected
    for top in rep.sections:
        for s in top.walk():
            assert s.blocks or any(not x.is_empty() for x in s.subsections), s.key
    if "design" in expected:
        assert rep.data["design"]["mcppc_gains.toml"]["analysis"] == \
            cli_json("analyze", demo_dir / "mcppc_gains.toml")["analysis"]
        assert rep.data["design"]["mcppc_gains.toml"]["frf"] is None
    if "time" in expected:
        assert set(rep.data["tracking"]) == {"track_200mm_s_mcppc.csv"}
        assert set(rep.data["ropesnap"]) == {"ropesnap_ppi.csv"}


@pytest.mark.slow
def test_partial_report_command_writes_html_without_empty_sections(demo_dir, tmp_path):
    out = tmp_path / "r.html"
    res = cli("report", demo_dir / "model.toml", demo_dir / "frf.csv", "--out", out, "--title", "Axis X", "--json")
    assert res.exit_code == 0, res.output
    info = json.loads(res.output)
    assert info["sections"] == ["Summary", "Identification", "Inputs"] and info["figures"] == 1
    text = out.read_text(encoding="utf-8")
    assert "<title>Axis X</title>" in text
    assert not re.search(r"<h[234]>[^<]*</h[234]>\s*</section>", text)  # no heading without content
    assert info["sizes_bytes"] == [out.stat().st_size]


# ------------------------------------------------------------------------------------------ bad input
@pytest.mark.slow
def test_unrecognised_file_is_a_one_line_error_and_writes_nothing(demo_dir, tmp_path):
    junk = tmp_path / "notes.txt"
    junk.write_text("these are my notes\nnot a table at all\n")
    out = tmp_path / "r.html"
    res = cli("report", demo_dir / "model.toml", junk, "--out", out)
    assert isinstance(res.exception, DataError) and str(junk) in str(res.exception)
    assert "\n" not in str(res.exception)
    other = tmp_path / "image.png"
    other.write_bytes(b"\x89PNG")
    res = cli("report", other, "--out", out)
    assert isinstance(res.exception, DataError) and "not a file feedtune reports on" in str(res.exception)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["image.png", "notes.txt"]


@pytest.mark.slow
def test_existing_output_needs_force_and_is_left_untouched(demo_dir, tmp_path):
    out = tmp_path / "r.html"
    out.write_text("mine")
    res = cli("report", demo_dir / "model.toml", "--out", out, "--pdf")
    assert isinstance(res.exception, UsageError) and "pass --force" in cli_message(res.exception)
    assert out.read_text() == "mine" and sorted(p.name for p in tmp_path.iterdir()) == ["r.html"]
    res = cli("report", demo_dir / "model.toml", "--out", out, "--pdf", "--force")
    assert res.exit_code == 0, res.output
    assert out.read_text(encoding="utf-8").startswith("<!DOCTYPE html>")
    assert (tmp_path / "r.pdf").read_bytes()[:5] == b"%PDF-"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["r.html", "r.pdf"]  # no temporary files left


@pytest.mark.slow
def test_folder_members_that_cannot_be_read_are_skipped_with_a_warning_or_refused_when_strict(demo_dir, tmp_path):
    folder = tmp_path / "in"
    folder.mkdir()
    (folder / "model.toml").write_text((demo_dir / "model.toml").read_text())
    (folder / "broken.csv").write_text("t,x\n0,1\n0,2\n")  # time not increasing
    (folder / "readme.md").write_text("ignored: not a data file")
    rep = build_report([folder], render=False)
    assert any("broken.csv" in w and "left out" in w for w in rep.warnings)
    assert any(s["file"].endswith("broken.csv") for s in rep.data["inputs"]["skipped"])
    with pytest.raises(DataError, match=r"broken\.csv"):
        build_report([folder], strict=True)


def test_a_log_without_metadata_needs_its_kind(tmp_path):
    t = np.arange(2000) / 1000.0
    x = np.where(t >= 0.5, 1e-5 * np.exp(-(t - 0.5) * 20) * np.cos(2 * np.pi * 40 * (t - 0.5)), 0.0)
    write_log_csv(Log(t, {"x": x, "u": 0.1 * np.ones_like(t)}, {"x": "m", "u": "V"}), tmp_path / "snap.csv")
    with pytest.raises(DataError, match=r"pass log_kinds=snap\.csv=KIND") as err:
        build_report([tmp_path / "snap.csv"])
    assert err.value.parameter == "log_kinds"
    assert "pass --log-kind snap.csv=KIND" in cli_message(err.value)
    rep = build_report([tmp_path / "snap.csv"], log_kinds={"snap.csv": "ropesnap"}, render=False)
    m = rep.data["ropesnap"]["snap.csv"]["metrics"]
    assert m["peak_abs_m"] == pytest.approx(1e-5, rel=1e-9)  # the decaying cosine starts at its peak
    assert m["t_release_s"] == pytest.approx(0.499)  # detected: the last quiet sample
    with pytest.raises(UsageError, match="no such file"):
        build_report([tmp_path / "snap.csv"], log_kinds={"other.csv": "track"})


# ------------------------------------------------------------------------------------------ no recomputation
@pytest.mark.slow
def test_report_does_not_identify_or_design_again(demo_dir, monkeypatch):
    import feedtune.design.mcppc
    import feedtune.design.prefilter
    import feedtune.identify.ballscrew
    import feedtune.tune.ppi

    def refuse(*args, **kwargs):
        raise AssertionError("the report recomputed a result stored in its input files")

    monkeypatch.setattr(feedtune.identify.ballscrew, "fit_ballscrew", refuse)
    monkeypatch.setattr(feedtune.design.mcppc, "design_mcppc", refuse)
    monkeypatch.setattr(feedtune.tune.ppi, "tune_ppi", refuse)
    monkeypatch.setattr(feedtune.design.prefilter, "fit_prefilter", refuse)
    rep = build_report([demo_dir], render=False)
    fit = rep.data["identification"]["model.toml"]["fit"]
    stored = json.loads((demo_dir / "model.json").read_text())["fit"]
    assert fit["std"] == stored["std"] and fit["fit"] == stored["fit"]


# ------------------------------------------------------------------------------------------ other inputs
def test_friction_gantry_and_contour_inputs(tmp_path):
    from feedtune.models.friction import StribeckFriction
    from feedtune.models.gantry import THESIS_GANTRY

    friction = StribeckFriction(dc_pos=0.10, ds_pos=0.16, dc_neg=-0.09, ds_neg=-0.15, omega_pos=0.8,
                                command_unit="V", velocity_unit="rad/s")
    (tmp_path / "friction.toml").write_text(dumps_toml(model_document(friction)))
    (tmp_path / "gantry.toml").write_text(dumps_toml(model_document(THESIS_GANTRY)))
    rng = np.random.default_rng(0)
    v = np.linspace(-8, 8, 4001)
    d = friction.force(v) + 0.002 * rng.standard_normal(v.size)
    t = np.arange(v.size) * 1e-3
    write_log_csv(Log(t, {"v_hat": v, "d_hat": d}, {"v_hat": "rad/s", "d_hat": "V"}), tmp_path / "kalman.csv")
    # circle of radius R followed at R + 5 um: the contour error is 5 um everywhere (chord sag 1e-8 m)
    th = np.linspace(0, 2 * np.pi, 2001)
    R, dr = 0.01, 5e-6
    sig = {"x_ref": R * np.cos(th), "y_ref": R * np.sin(th), "x": (R + dr) * np.cos(th), "y": (R + dr) * np.sin(th)}
    write_log_csv(Log(th / 10, sig, dict.fromkeys(sig, "m")), tmp_path / "circle.csv")
    rep = build_report([tmp_path], render=False)
    keys = section_keys(rep)
    assert {"friction", "model-gantry.toml", "time-contour"} <= keys
    contour = rep.data["contour"]["circle.csv"]["metrics"]
    assert contour["max_m"] == pytest.approx(dr, abs=3e-8) and contour["rms_m"] == pytest.approx(dr, abs=3e-8)
    params = rep.data["identification"]["friction.toml"]["params"]
    assert params["ds_pos"]["value"] == 0.16 and params["omega_pos"]["value"] == 0.8
    assert rep.data["identification"]["gantry.toml"]["params"]["k"]["value"] == THESIS_GANTRY.k
    figs = {f.name for f in rep.figures()}
    assert {"friction", "gantry-mass-gantry.toml", "contour-circle"} <= figs
    gantry_fig = next(f for f in rep.figures() if f.name == "gantry-mass-gantry.toml").figure
    yaw = gantry_fig.axes[2].get_lines()[0]
    x0 = np.argmin(np.abs(yaw.get_xdata()))
    assert yaw.get_ydata()[x0] == pytest.approx(94.3, abs=0.05)  # thesis: yaw mode 94.3 Hz at x = 0


def test_saturated_and_tripped_runs_are_warned(tmp_path):
    t = np.arange(4000) / 2000.0
    x_ref = 0.01 * np.sin(2 * np.pi * t)
    u = np.clip(20 * np.sin(2 * np.pi * 3 * t), -10, 10)
    log = Log(t, {"x_ref": x_ref, "x2_table": x_ref * 0.999, "u": u}, {"x_ref": "m", "x2_table": "m", "u": "V"},
              {"trip": "following-error trip at 1.9 s"})
    write_log_csv(log, tmp_path / "run.csv")
    rep = build_report([tmp_path / "run.csv"], log_kinds={"run.csv": "track"}, render=False)
    assert any("tripped" in w for w in rep.warnings)
    sat = [w for w in rep.warnings if "saturation" in w]
    assert sat and "±10 V" in sat[0]
    assert any(isinstance(b, Alert) and "saturation" in b.text for b in rep.section("summary").blocks)


def test_saturation_needs_consecutive_samples_at_the_largest_magnitude():
    u = np.r_[np.zeros(5), np.full(12, -10.0), np.zeros(3), np.full(3, 10.0)]
    assert saturation(u, 10) == (10.0, 12)
    assert saturation(u, 13) is None
    assert saturation(np.sin(np.linspace(0, 20, 1000)), 3) is None  # a smooth peak touches its maximum once


def test_plot_decimation_keeps_extremes():
    x = np.arange(100_000, dtype=float)
    y = np.sin(x / 5000.0)
    y[33_333] = 7.0
    y[66_666] = -7.0
    xe, ye = envelope(x, y, 500)
    assert xe.size == 1000 and ye.max() == 7.0 and ye.min() == -7.0 and np.all(np.diff(xe) >= 0)
    f = np.linspace(0, 10_000, 50_001)
    a = np.full_like(f, 1e-3)
    a[12_345] = 1.0
    fe, ae = log_envelope(f, a, 300)
    assert fe.size <= 300 and ae.max() == 1.0 and fe[np.argmax(ae)] == f[12_345] and fe.min() > 0


# ------------------------------------------------------------------------------------------ demo command
@pytest.mark.slow
def test_demo_command_ends_with_the_report(demo_result, tmp_path, monkeypatch, report):
    import feedtune.report.html
    import feedtune.workflows.ballscrew_demo

    monkeypatch.setattr(feedtune.workflows.ballscrew_demo, "run_demo", lambda **kwargs: demo_result)
    # the figures' rendering is checked on the module's report; a stand-in PNG keeps this test fast
    monkeypatch.setattr(feedtune.report.html, "figure_png", lambda fig: b"\x89PNG\r\n\x1a\n")
    out = tmp_path / "demo_out"
    res = cli("demo", "--out", out)
    assert res.exit_code == 0, res.output
    path = out / "report.html"
    assert f"report: {path}" in res.output
    data = embedded_data(path.read_text(encoding="utf-8"))
    assert_same_numbers(data["design"], json.loads(json.dumps(report.data["design"])))
    assert data["tracking"] == json.loads(json.dumps(report.data["tracking"]))


@pytest.mark.slow
def test_tables_and_blocks_are_well_formed(report):
    for top in report.sections:
        for s in top.walk():
            for b in s.blocks:
                assert isinstance(b, (Table, FigureBlock, Paragraph, Alert))
                if isinstance(b, Table):
                    assert all(len(row) == len(b.columns) for row in b.rows), b.title


# ------------------------------------------------------------------------------------------ gantry
def test_gantry_and_axis_gains_are_analysed_as_the_analyze_command_does(tmp_path):
    from feedtune.models.gantry import THESIS_GANTRY

    (tmp_path / "gantry.toml").write_text(dumps_toml(model_document(THESIS_GANTRY)))
    for args in (("design", "gantry", tmp_path / "gantry.toml", "--lpf", 450, "--out", tmp_path / "mimo.toml"),
                 ("design", "loopshape", tmp_path / "gantry.toml", "--crossover-hz", 130, "--pm-deg", 35,
                  "--out", tmp_path / "axis.toml")):
        res = cli(*args)
        assert res.exit_code == 0, res.output
    rep = build_report([tmp_path / "gantry.toml", tmp_path / "mimo.toml", tmp_path / "axis.toml"], render=False)
    for name in ("mimo.toml", "axis.toml"):
        envelope = cli_json("analyze", tmp_path / name)  # the results inside the --json envelope (docs/json.md)
        expected = {k: v for k, v in envelope.items()
                    if k not in ("kind", "feedtune_version", "inputs", "warnings", "gains_kind")}
        expected.update(kind=envelope["gains_kind"], gains={k: q["value"] for k, q in envelope["gains"].items()})
        got = rep.data["design"][name]
        assert {k: got[k] for k in expected} == expected, name
    assert {"design-gantry", "design-axis", "model-gantry.toml"} <= section_keys(rep)
    figs = {f.name for f in rep.figures()}
    assert {"gantry-sv-loop", "gantry-nyquist", "gantry-sv-sensitivity", "gantry-sv-disturbance",
            "axis-loop", "axis-nyquist", "axis-sensitivity"} <= figs
    summary = next(t for t in rep.section("summary").blocks if isinstance(t, Table))
    assert [row[0].text for row in summary.rows] == ["MIMO", "x-axis loop shaping"]


def test_gantry_runs_use_each_side_and_the_table_displacement(tmp_path):
    fs = 5000.0
    t = np.arange(int(0.6 * fs)) / fs
    y_ref = 0.01 * (1 - np.cos(np.pi * t / 0.6)) / 2
    e1 = 1e-6 * np.sin(2 * np.pi * 20 * t)
    e2 = 3e-6 * np.sin(2 * np.pi * 30 * t)  # side 2 has the larger error
    sig = {"y_ref": y_ref, "y1": y_ref - e1, "y2": y_ref - e2, "x": np.zeros_like(t), "u1": 0.1 * np.sin(t),
           "u2": 0.1 * np.cos(t), "e1": e1, "e2": e2}
    write_log_csv(Log(t, sig, dict.fromkeys(sig, "m") | {"u1": "V", "u2": "V"},
                      {"experiment": "track", "controller": "mimo"}), tmp_path / "track.csv")
    snap = np.where(t >= 0.2, 5e-6 * np.exp(-(t - 0.2) * 30) * np.cos(2 * np.pi * 25 * (t - 0.2)), 0.0)
    sig = {"y_table": snap, "y1": snap, "y2": snap, "u1": np.zeros_like(t), "u2": np.zeros_like(t)}
    write_log_csv(Log(t, sig, dict.fromkeys(sig, "m") | {"u1": "V", "u2": "V"},
                      {"experiment": "ropesnap", "controller": "pid", "t_release_s": 0.2}), tmp_path / "snap.csv")
    rep = build_report([tmp_path], render=False)
    entry = rep.data["tracking"]["track.csv"]
    assert entry["options"] == {"error": "e2", "reference": "y_ref"}
    for side in ("e1", "e2"):
        expected = cli_json("analyze", "track", tmp_path / "track.csv", "--error", side, "--reference", "y_ref")
        assert entry["sides"][side] == expected["metrics"]
    assert entry["metrics"] == entry["sides"]["e2"]
    assert entry["metrics"]["overall"]["max_m"] == pytest.approx(3e-6, rel=1e-3)
    snap_entry = rep.data["ropesnap"]["snap.csv"]
    assert snap_entry["options"] == {"position": "y_table"}
    expected = cli_json("analyze", "ropesnap", tmp_path / "snap.csv", "--position", "y_table")["metrics"]
    assert snap_entry["metrics"] == expected and expected["peak_abs_m"] == pytest.approx(5e-6, rel=1e-9)


def test_summary_counts_the_figures_as_the_demos_do():
    from feedtune.report.summary import comparison_sentences

    own = "PID (pid_own_gains)"
    data = {"comparison": {"tracking": {"rows": [{"run": "tracking, peak speed 200 mm/s", "runs": {
        "MIMO": {"max_m": 2e-6, "rms_m": 1e-6}, own: {"max_m": 1e-6, "rms_m": 0.999e-6}}}]}},
        "ropesnap": {"a.csv": {"controller": "MIMO", "run": "rope snap 57 N",
                               "metrics": {"peak_abs_m": 5e-6, "settling_time_s": 0.05, "settled": True}},
                     "b.csv": {"controller": own, "run": "rope snap 57 N",
                               "metrics": {"peak_abs_m": 4e-6, "settling_time_s": None, "settled": False}}},
        "contour": {"c.csv": {"controller": "MIMO", "run": "circle", "metrics": {"max_m": 1e-6, "rms_m": 1e-6}},
                    "d.csv": {"controller": own, "run": "circle", "metrics": {"max_m": 2e-6, "rms_m": 1.5e-6}}}}
    # by hand: max 2 > 1 um (PID), RMS within 0.5 % (tie), rope-snap peak 5 > 4 um (PID), settling: only MIMO settles
    # (MIMO), contour max and RMS (MIMO): the rule of feedtune demo's table (feedtune.analysis.comparison)
    assert comparison_sentences(data) == [
        f"MIMO is better in 3 of 6 figures, {own} in 2, 1 tie(s) within 0.5 % or both missing; {own} is better in: "
        "track 200 mm/s max, rope snap 57 N peak."]
    data["comparison"]["tracking"]["rows"][0]["runs"][own]["max_m"] = 3e-6
    assert comparison_sentences(data)[0].startswith(f"MIMO is better in 4 of 6 figures, {own} in 1")


# ------------------------------------------------------------------------------------------ what the reader sees
def _frf_coherence(path):
    """Lowest coherence of x1/u and x2/u per line, read from the FRF file with numpy alone."""
    lines = [line for line in path.read_text().splitlines() if line and not line.startswith("#")]
    names = [c.strip() for c in lines[0].split(",")]
    table = np.array([[float(x) for x in line.split(",")] for line in lines[1:]])
    cols = [names.index("x1/u.coh"), names.index("x2/u.coh")]
    return table[:, names.index("freq_hz")], table[:, cols].min(axis=1)


@pytest.mark.slow
def test_curves_drawn_from_the_frf_leave_out_lines_of_low_coherence(report, demo_dir):
    f_line, coh = _frf_coherence(demo_dir / "frf.csv")
    assert (coh < 0.5).any() and (coh >= 0.5).any()
    fig = next(f for f in report.figures() if f.name == "design-loop")
    assert "coherence" in fig.caption and "below 0.5" in fig.caption
    phase_ax = fig.figure.axes[1]
    solid = [ln for ln in phase_ax.get_lines() if ln.get_linestyle() == "-" and len(ln.get_xdata()) > 100
             and ln.get_transform() == phase_ax.transData]  # the curves, not the minor grid
    assert solid  # the measured-FRF cases
    for ln in solid:
        x, y = np.asarray(ln.get_xdata(), float), np.asarray(ln.get_ydata(), float)
        drawn = x[np.isfinite(y)]
        low = np.interp(drawn, f_line, coh) < 0.5
        assert not low.any(), drawn[low][:5]
        assert np.isfinite(y).sum() < y.size  # some lines were left out


@pytest.mark.slow
def test_legends_never_cover_the_axes(report):
    for block in report.figures():
        fig = block.figure
        renderer = fig.canvas.get_renderer()
        boxes = [ax.get_window_extent(renderer) for ax in fig.axes]
        legend_texts = [t for t in fig.texts if t.get_fontsize() < 8]
        assert legend_texts or not any(ax.get_legend_handles_labels()[1] for ax in fig.axes), block.name
        for t in legend_texts:
            bb = t.get_window_extent(renderer)
            assert not any(bb.overlaps(b) for b in boxes), (block.name, t.get_text())
        assert not any(ax.get_legend() for ax in fig.axes), block.name  # no legend box inside an axes


@pytest.mark.slow
def test_every_design_has_a_verdict_line_a_controller_bode_plot_and_a_supported_bandwidth(report):
    summary = [b.text for b in report.section("summary").blocks if isinstance(b, (Paragraph, Alert))]
    for name in ("mcppc_gains.toml", "ppi_gains.toml"):
        line = next(t for t in summary if f"({name})" in t)
        assert ": PASS under textbook: Ms <= 2.5, PM >= 30 deg, GM >= 6 dB" in line and "stable in 4 of 4" in line
    figs = {f.name for f in report.figures()}
    assert {"design-controller-mcppc_gains.toml", "design-controller-ppi_gains.toml"} <= figs
    bode = next(f for f in report.figures() if f.name == "design-controller-mcppc_gains.toml").figure
    assert "V/rad" in bode.axes[0].get_ylabel() and len(bode.axes) == 4
    for name in ("mcppc_gains.toml", "ppi_gains.toml"):
        bw = report.data["design"][name]["tracking_bandwidth"]["cases"]
        assert bw["discrete"]["shown"] and bw["discrete"]["value_hz"] <= bw["discrete"]["supported_to_hz"]
        for entry in bw.values():
            assert not entry["shown"] or entry["value_hz"] <= entry["supported_to_hz"]


@pytest.mark.slow
def test_time_figures_zoom_on_the_events_beside_the_whole_run(report):
    track = next(f for f in report.figures() if f.name.startswith("time-track-"))
    axes = track.figure.axes
    whole, zooms = axes[0], [axes[1]]
    lo, hi = whole.get_xlim()
    for z in zooms:
        z0, z1 = z.get_xlim()
        assert lo <= z0 < z1 <= hi and (z1 - z0) < 0.4 * (hi - lo)
    snap = next(f for f in report.figures() if f.name.startswith("time-ropesnap"))
    z0, z1 = snap.figure.axes[1].get_xlim()
    assert z0 < 0 < z1 < 0.2  # around the release, tens of ms


@pytest.mark.slow
def test_the_pdf_is_compact(report):
    from feedtune.report.pdf import layout_pages

    pages = layout_pages(report)
    assert len(pages) <= 20 < len(report.tables()) + len(report.figures())
    title = " ".join(t.get_text() for t in pages[0].texts)
    assert report.title in title and "Contents" in title and "PASS under" in title
