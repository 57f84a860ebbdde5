"""What the report claims from its inputs: spectrum peaks only above the noise floor, the margin to saturation,
the tracking bandwidth only where the data supports it, zoom windows on the reference's acceleration phases, the
wording of a report without designs, and the work split of the figure drawing."""

from __future__ import annotations

import numpy as np
import pytest

from feedtune.analysis.metrics import tracking_metrics
from feedtune.log import Log
from feedtune.report.build import build_report
from feedtune.report.content import Paragraph
from feedtune.report.html import render_pngs
from feedtune.report.sections import ReportLimits
from feedtune.report.time_domain import (
    PEAK_FLOOR_RATIO,
    acceleration_phases,
    command_peaks,
    significant_peak,
    tracking_windows,
)
from feedtune.report.trust import bandwidth_entry, trusted_top_hz


def _spectrum(tone_amplitude: float, tone_hz: float = 125.0, seed: int = 0):
    """Metrics of 1 s at 4 kHz of white noise (RMS 1e-8 m) plus a tone on a frequency line."""
    rng = np.random.default_rng(seed)
    t = np.arange(4000) / 4000.0
    e = 1e-8 * rng.standard_normal(t.size) + tone_amplitude * np.sin(2 * np.pi * tone_hz * t)
    return tracking_metrics(t, e)


def test_a_tone_above_the_noise_floor_is_a_peak_and_noise_alone_is_not():
    m = _spectrum(1e-6)
    sp = significant_peak(m.freq_hz, m.amplitude, m.peaks)
    assert sp["index"] is not None and sp["freq_hz"] == pytest.approx(125.0, abs=sp["resolution_hz"])
    assert sp["level"] == pytest.approx(1e-6, rel=0.02)  # amplitude-correct Hann spectrum of a line tone
    assert sp["resolution_hz"] == pytest.approx(1.0, rel=1e-3)  # 1 / T for T = 1 s
    # the noise floor: the median amplitude of white noise, sigma sqrt(pi/2)... times the window's noise gain; the
    # ratio is far above the 20 dB criterion for a 1 um tone in 10 nm noise
    assert sp["ratio"] > 10 * PEAK_FLOOR_RATIO
    for seed in range(5):  # the largest of thousands of noise lines stays below 10 x their median
        noise = _spectrum(0.0, seed=seed)
        assert significant_peak(noise.freq_hz, noise.amplitude, noise.peaks)["index"] is None
    weak = _spectrum(2e-9)  # a tone at the noise level is not reported
    assert significant_peak(weak.freq_hz, weak.amplitude, weak.peaks)["index"] is None


def test_peaks_within_four_lines_of_zero_are_not_reported():
    m = _spectrum(1e-6, tone_hz=3.0)  # 3 lines above 0 Hz: the run's slow motion, not a spectral line
    assert significant_peak(m.freq_hz, m.amplitude, m.peaks)["index"] is None
    m = _spectrum(1e-6, tone_hz=5.0)
    assert significant_peak(m.freq_hz, m.amplitude, m.peaks)["freq_hz"] == pytest.approx(5.0)


def _log(u, meta=None):
    t = np.arange(u.size) / 1000.0
    return Log(t, {"u": u, "x_ref": np.zeros_like(t)}, {"u": "A", "x_ref": "m"}, meta or {})


def test_peak_command_and_margin_to_saturation_with_the_unit_of_u():
    u = np.zeros(100)
    u[40] = -7.5
    p = command_peaks(_log(u, {"u_max": "9"}), ReportLimits())["u"]
    assert p["peak_abs"] == 7.5 and p["t_peak_s"] == pytest.approx(0.04) and p["unit"] == "A"
    assert p["saturation"] == 9.0 and p["margin"] == pytest.approx(1.5) and p["margin_pct"] == pytest.approx(100 / 6)
    assert p["saturation_source"] == "log metadata"
    assert command_peaks(_log(u), ReportLimits(u_max=8.0))["u"]["margin"] == pytest.approx(0.5)
    twin = command_peaks(_log(u, {"origin": "twin track run"}), ReportLimits())["u"]
    assert twin["saturation"] == 10.0 and twin["saturation_source"] == "ballscrew twin default"  # TwinParams.u_max
    unknown = command_peaks(_log(u), ReportLimits())["u"]
    assert unknown["saturation"] is None and unknown["margin"] is None


def test_tracking_bandwidth_is_shown_only_inside_the_supported_band():
    support = {"measured": 396.0, "model": 260.0}  # trusted FRF band, model fit band [Hz]
    assert bandwidth_entry(120.0, "discrete", support)["shown"]
    assert not bandwidth_entry(4534.0, "ideal_discrete", support)["shown"]  # beyond the fit band
    assert not bandwidth_entry(None, "ideal", support)["shown"]  # never leaves 0 +- 3 dB on the grid
    assert not bandwidth_entry(120.0, "ideal", {"measured": 396.0, "model": None})["shown"]  # no fit band known
    f = np.arange(1.0, 11.0)
    coh = np.array([1, 1, 0.3, 1, 1, 1, 0.2, 0.1, 0.1, 0.4])
    assert trusted_top_hz(f, coh, 0.5) == 6.0  # a single low line does not end the band; three in a row do


def test_zoom_windows_cover_the_acceleration_phases_of_the_reference():
    fs = 2000.0
    t = np.arange(int(1.2 * fs)) / fs
    a = np.where((t >= 0.1) & (t < 0.2), 5.0, 0.0) - np.where((t >= 0.9) & (t < 1.0), 5.0, 0.0)
    log = Log(t, {"x_ref": np.zeros_like(t), "a_ref": a}, {"x_ref": "m", "a_ref": "m/s^2"}, {})
    phases = acceleration_phases(log)
    assert len(phases) == 2
    assert phases[0] == pytest.approx((0.1, 0.1995), abs=1e-9) and phases[1] == pytest.approx((0.9, 0.9995), abs=1e-9)
    windows = tracking_windows(log)
    assert len(windows) == 2
    for (s, e), w in zip(phases, windows, strict=True):
        assert w.t0 < s and w.t1 > e and w.t1 - w.t0 < 0.25  # around the ~0.1 s phase, not the whole run


def test_a_report_of_an_frf_alone_claims_no_stability(examples_dir):
    rep = build_report([examples_dir / "ballscrew_frf.csv"], render=False)
    text = " ".join(b.text for b in rep.section("summary").blocks if isinstance(b, Paragraph))
    assert "no gains file was given, so no stability or margin is claimed" in text
    assert "stable" not in text.replace("no stability", "") and "every design" not in text
    assert "no poor fit" not in text  # no model was given to judge a fit


def test_the_figures_are_the_same_drawn_in_one_process_or_several(examples_dir, tmp_path, monkeypatch):
    pytest.importorskip("matplotlib")
    import os

    import feedtune.report.html as report_html

    files = [examples_dir / "ballscrew_frf.csv", examples_dir / "ballscrew_track.csv",
             examples_dir / "ballscrew_ropesnap.csv"]
    rep = build_report(files, render=False)
    one = render_pngs(rep, processes=1)
    # every figure drawn exactly once, by whichever process took it: each draw appends "pid name" to a file
    # (appends of one short line are atomic, the forked children inherit the patched function)
    journal = tmp_path / "drawn.txt"
    draw = report_html._draw

    def logged(figure):
        png = draw(figure)
        with open(journal, "a") as fh:
            fh.write(f"{os.getpid()} {figure.name}\n")
        return png

    monkeypatch.setattr(report_html, "_draw", logged)
    monkeypatch.setenv("FEEDTUNE_REPORT_PROCESSES", "2")
    two = render_pngs(build_report(files, render=False))
    assert list(one) == list(two) == [f.name for f in rep.figures()]
    assert all(one[k] == two[k] for k in one)  # byte-identical PNGs
    entries = [line.split(" ", 1) for line in journal.read_text().splitlines()]
    assert sorted(name for _, name in entries) == sorted(one)  # each once, none lost
    # a child that dies (killed, out of memory) leaves its figures to this process
    parent = os.getpid()

    def dying(figure):
        if os.getpid() != parent:
            os._exit(1)
        return draw(figure)

    monkeypatch.setattr(report_html, "_draw", dying)
    three = render_pngs(build_report(files, render=False))
    assert list(three) == list(one) and all(one[k] == three[k] for k in one)


def test_friction_curve_documents_are_listed_under_inputs(tmp_path):
    from feedtune.io import dumps_toml

    q = {"dc": {"value": 1.2, "unit": "N"}, "ds": {"value": 1.6, "unit": "N"}, "omega": {"value": 0.01, "unit": "m/s"},
         "viscous": {"value": 30.0, "unit": "N/(m/s)"}}
    v = [0.01, 0.02, 0.05, 0.1]
    doc = {"schema": "feedtune.friction_curve/1", "kind": "friction_curve", "law": "stribeck", "command_unit": "N",
           "velocity_unit": "m/s", "directions": ["pos"], "source": "run.csv", "method": "steady state",
           "params": {"pos": q},
           "points": {"direction": ["pos"] * 4, "velocity": v, "force": [1.5, 1.8, 2.7, 4.2],
                      "force_std": [0.1] * 4, "n": [100] * 4, "what": "plateau means"},
           "curve": {"pos": {"velocity": v, "force": [1.5, 1.8, 2.7, 4.2]}}}
    (tmp_path / "curve.toml").write_text(dumps_toml(doc))
    rep = build_report([tmp_path / "curve.toml"], render=False)
    files = next(t for t in rep.section("inputs").blocks if t.title == "Files")
    row = next(r for r in files.rows if r[0].text == "curve.toml")
    assert row[1].text == "friction curve (stribeck)"
    assert "v > 0" in row[2].text and "4 measured points" in row[2].text and "run.csv" in row[2].text
