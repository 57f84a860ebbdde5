"""FRFs and sampling: removing the ZOH and the computational delay, the metadata record, the CLI and the warning."""

from __future__ import annotations

import json

import numpy as np
import pytest
from cli_run import run

from feedtune.analysis.ballscrew import analyze_ballscrew
from feedtune.control.filters import THESIS_FILTER_PACK
from feedtune.design.mcppc import design_mcppc
from feedtune.errors import DataError, UsageError
from feedtune.frf import Frf
from feedtune.frf_sampling import (
    double_counting_warning,
    mark_sampling_kept,
    remove_sampling,
    sampling_response,
    sampling_state,
)
from feedtune.machines.ballscrew.twin import BallScrewTwin, TwinParams
from feedtune.models import THESIS_TABLE_3_1 as MODEL

FS = 20000.0
WARNING = "counts them twice"


def _frf(f, h, meta=None) -> Frf:
    return Frf(f, np.asarray(h)[None, None, :], ("x",), ("u",), meta=meta or {"source": "test"})


# ------------------------------------------------------------------------------------------ library
def test_integrator_with_zoh_and_delay_gives_the_closed_form_continuous_response():
    # exact ZOH discretization of 1/s is T/(z - 1) (python-control c2d gives the same), times z^-1 for the delay.
    # Divided by ZOH * delay it is (1/(j w)) * ((wT/2) / sin(wT/2))^2: the aliasing factor, real, 1 + (wT)^2/12.
    control = pytest.importorskip("control")
    T = 1 / FS
    f = np.linspace(1.0, FS / 2, 500)
    z = np.exp(2j * np.pi * f * T)
    sysd = control.c2d(control.tf([1], [1, 0]), T, "zoh")
    sampled = np.asarray(sysd(z)).reshape(-1) / z
    got = remove_sampling(_frf(f, sampled), FS, 1).channel("x/u")
    half = np.pi * f * T
    expected = 1 / (2j * np.pi * f) * (half / np.sin(half)) ** 2
    assert np.max(np.abs(got / expected - 1)) < 1e-10
    assert abs(got[0] * 2j * np.pi * f[0] - 1) < 1e-8  # 1 Hz: the integrator itself


def test_twin_sampled_response_becomes_its_continuous_plant():
    twin = BallScrewTwin()
    f = np.geomspace(1, 2000, 300)
    cont = twin.frequency_response(f, sampled=False)
    frf = remove_sampling(twin.frf(f, sampled=True), twin.fs, twin.params.delay_samples)
    for out in ("x1", "x2"):
        ratio = frf.channel(f"{out}/u") / cont[out]
        assert np.max(np.abs(ratio[f < 200] - 1)) < 1e-6  # only aliasing is left: 6e-8 measured
        assert np.max(np.abs(ratio - 1)) < 2e-3  # 7e-4 at 2 kHz (x1) measured
    raw = twin.frf(f, sampled=True).channel("x2/u") / cont["x2"]
    i = int(np.argmin(np.abs(f - 160)))
    # without removal: ZOH half sample + 1 sample of delay = 360 f 1.5 / fs deg of extra lag
    assert np.degrees(np.angle(raw[i])) == pytest.approx(-360 * f[i] * 1.5 / FS, abs=1e-3)


def test_discrete_case_on_the_removed_frf_equals_the_continuous_plant_and_double_counting_shows():
    twin = BallScrewTwin()
    law = design_mcppc(MODEL, filters=THESIS_FILTER_PACK).law()
    f = np.linspace(5, 3000, 1500)
    truth = analyze_ballscrew(law, MODEL, twin.frf(f, sampled=False)).cases["discrete"].metrics
    removed = analyze_ballscrew(law, MODEL, remove_sampling(twin.frf(f, sampled=True), FS, 1)).cases["discrete"]
    twice = analyze_ballscrew(law, MODEL, twin.frf(f, sampled=True)).cases["discrete"].metrics
    assert removed.metrics.ms == pytest.approx(truth.ms, rel=1e-4)
    assert removed.metrics.phase_margin_deg == pytest.approx(truth.phase_margin_deg, abs=0.01)
    assert twice.ms > truth.ms * 1.2  # the doubled ZOH and delay cost margin: 3.71 against 2.93 measured


def test_metadata_records_the_removal_and_survives_a_csv_round_trip(tmp_path):
    from feedtune.io import read_frf, write_frf

    f = np.linspace(1, 1000, 50)
    coh = np.full((1, 1, 50), 0.99)
    frf = Frf(f, np.ones((1, 1, 50), complex), ("x",), ("u",), coherence=coh, meta={"source": "t", "method": "h1"})
    assert sampling_state(frf) == "not_removed"  # estimated from a log, no record: assumed kept
    out = remove_sampling(frf, 8000, 0.5)
    assert (out.meta["sampling"], out.meta["sampling_fs_hz"], out.meta["sampling_delay_samples"]) == (
        "removed", "8000", "0.5")
    np.testing.assert_array_equal(out.coherence, coh)
    np.testing.assert_allclose(out.channel("x/u"), 1 / sampling_response(f, 8000, 0.5), rtol=1e-15)
    write_frf(out, tmp_path / "r.csv")
    back = read_frf(tmp_path / "r.csv")
    assert sampling_state(back) == "removed" and back.meta["sampling_delay_samples"] == "0.5"
    assert double_counting_warning(back) is None
    with pytest.raises(DataError, match="already removed"):
        remove_sampling(back, 8000, 0.5)
    kept = mark_sampling_kept(frf, 8000)
    write_frf(kept, tmp_path / "k.csv")
    msg = double_counting_warning(read_frf(tmp_path / "k.csv"), "k.csv")
    assert msg.startswith("k.csv was estimated from a sampled log at 8000 Hz") and WARNING in msg


def test_sampling_state_of_other_files():
    f = np.array([1.0, 2.0])
    assert sampling_state(_frf(f, [1, 1])) == "unknown"  # signal analyser, model: no warning
    assert double_counting_warning(_frf(f, [1, 1])) is None
    assert sampling_state(_frf(f, [1, 1], {"delay_removed_s": "7.5e-05"})) == "removed"  # gantry twin record
    assert sampling_state(_frf(f, [1, 1], {"method": "periodic", "sampling": "removed"})) == "removed"


@pytest.mark.parametrize("fs, delay, err, match", [
    (0, 1, UsageError, "fs must be > 0"),
    ("fast", 1, UsageError, "fs must be a number"),
    (FS, -1, UsageError, "delay_samples must be a number of samples in 0 .. 100"),
    (FS, float("nan"), UsageError, "delay_samples"),
    (100, 1, DataError, "above the Nyquist frequency 50 Hz"),
])
def test_bad_parameters(fs, delay, err, match):
    with pytest.raises(err, match=match):
        remove_sampling(_frf(np.array([10.0, 60.0]), [1, 1]), fs, delay)


# ------------------------------------------------------------------------------------------ command line
@pytest.fixture(scope="module")
def twin_files(tmp_path_factory):
    """An excitation log of the ideal twin, a model file and an MC-PPC gains file."""
    from feedtune.io import save_model, write_document, write_log_csv
    from feedtune.io.gains import gains_document
    from feedtune.machines.ballscrew.experiments import measure_frf

    d = tmp_path_factory.mktemp("sampling")
    write_log_csv(measure_frf(BallScrewTwin(TwinParams.ideal()), periods=3).log, d / "log.csv")
    save_model(d / "model.toml", MODEL)
    write_document(d / "gains.toml", gains_document(design_mcppc(MODEL, filters=THESIS_FILTER_PACK)))
    return d


FRF_ARGS = ["--input", "u", "--output", "x1,x2", "--reference", "r", "--method", "periodic", "--band", "2", "2000"]


def test_frf_command_removes_sampling_when_asked(twin_files, tmp_path, capsys, monkeypatch):
    from feedtune.io import read_frf

    twin = BallScrewTwin(TwinParams.ideal())
    for extra, sampled in (([], True), (["--remove-sampling", "1"], False)):
        path = tmp_path / f"frf_{sampled}.csv"
        code, out, err = run(["frf", twin_files / "log.csv", *FRF_ARGS, *extra, "--out", path, "--json"],
                             capsys, monkeypatch)
        assert code == 0, err
        res = json.loads(out)
        assert res["sampling"] == {"removed": not sampled, "fs_hz": FS, "delay_samples": None if sampled else 1.0}
        frf = read_frf(path)
        assert sampling_state(frf) == ("not_removed" if sampled else "removed")
        band = (frf.freq_hz >= 200) & (frf.freq_hz <= 500) & (frf.channel_coherence("x1/u") > 0.999)
        assert band.sum() > 100
        h = frf.channel("x1/u")[band]
        match = twin.frequency_response(frf.freq_hz[band], sampled=sampled)["x1"]
        other = twin.frequency_response(frf.freq_hz[band], sampled=not sampled)["x1"]
        assert np.max(np.abs(h / match - 1)) < 0.015
        assert np.min(np.abs(h / other - 1)) > 0.08  # 5.4 deg of ZOH + delay at 200 Hz
    code, out, err = run(["frf", twin_files / "log.csv", *FRF_ARGS, "--remove-sampling", "1"], capsys, monkeypatch)
    assert code == 0 and "ZOH and computational delay (1 sample(s) at 20000 Hz) removed" in out
    code, _, err = run(["frf", twin_files / "log.csv", *FRF_ARGS, "--remove-sampling", "-2"], capsys, monkeypatch)
    assert code == 2 and err.strip().splitlines() == [
        "feedtune: error: --remove-sampling expects the computational delay in samples (0 .. 100, e.g. 1), got -2"]


def test_analyze_and_design_warn_about_a_frf_with_sampling_kept(twin_files, tmp_path, capsys, monkeypatch):
    kept, removed = tmp_path / "kept.csv", tmp_path / "removed.csv"
    for path, extra in ((kept, []), (removed, ["--remove-sampling", "1"])):
        code, _, err = run(["frf", twin_files / "log.csv", *FRF_ARGS, *extra, "--out", path], capsys, monkeypatch)
        assert code == 0, err
    gains, model = twin_files / "gains.toml", twin_files / "model.toml"
    ppi = ["design", "ppi", model, "--kpx", "60", "--kpv", "0.8", "--kiv", "100", "--allow-unstable", "--json"]
    for args in (["analyze", gains, "--json"], ppi):
        code, out, err = run([*args, "--frf", kept], capsys, monkeypatch)
        assert code == 0, err
        json.loads(out)  # stdout stays one JSON object
        lines = [ln for ln in err.splitlines() if WARNING in ln]
        assert lines == [f"feedtune: warning: {kept} was estimated from a sampled log at 20000 Hz without removing "
                         "the ZOH and the computational delay; if its input is the controller's command, the discrete "
                         "case counts them twice (feedtune frf --remove-sampling DELAY_SAMPLES)"]
        code, out, err = run([*args, "--frf", removed], capsys, monkeypatch)
        assert code == 0 and WARNING not in err


def test_simulate_frf_removes_sampling_unless_kept(tmp_path, capsys, monkeypatch):
    from feedtune.io import read_frf

    base = ["simulate", "frf", "--ideal", "--excitation", "prbs", "--periods", "2", "--json"]
    for extra, state in (([], "removed"), (["--keep-sampling"], "not_removed")):
        out_path = tmp_path / f"{state}.csv"
        code, out, err = run([*base, *extra, "--out", out_path], capsys, monkeypatch)
        assert code == 0, err
        assert json.loads(out)["sampling_removed"] is (state == "removed")
        assert sampling_state(read_frf(tmp_path / f"{state}_frf.csv")) == state
