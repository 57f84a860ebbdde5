"""The interactive page (``feedtune explore``, :mod:`feedtune.report.explore`) against the library.

The page stores the analysed loop without its filter pack and re-evaluates it in the browser as the gain, a notch or
the low-pass pole move. Held to what is not the page's own code: the loop it stores times the library's matched
filter pack is the loop ``analyze_gains`` analysed; in headless Chromium, for a set of moved filters and gains on two
designs (MC-PPC with the thesis pack; P-PI with a 2nd-order low-pass and a lead stage inside the pack), the page's
Ms, margins, disk margin, first crossover, stability and verdict are those the library computes for the gains file
the page downloads (read back from JSON, schema-checked, analysed on the same FRF), and the filter sections it
writes respond as the library's pole-zero matching of the filters it names. A moved notch slider updates Ms within
1 s.
"""

from __future__ import annotations

import html
import json
import re
from pathlib import Path

import numpy as np
import pytest
from cli_run import run
from report_checks import BROWSER, run_browser

from feedtune.analysis.limits import DEFAULT_LIMITS, split_gain_margins
from feedtune.control.discretize import matched
from feedtune.control.filters import THESIS_FILTER_PACK, FilterPack, LeadStage, Notch
from feedtune.design.mcppc import design_mcppc
from feedtune.design.ppi import design_ppi
from feedtune.errors import UsageError
from feedtune.io import read_document, read_frf, write_document
from feedtune.io.gains import gains_document
from feedtune.machines import analyze_gains
from feedtune.models import THESIS_TABLE_3_1
from feedtune.report.explore import explore_data, explore_html

needs_browser = pytest.mark.skipif(BROWSER is None, reason="no Chromium on the PATH (Debian: apt-get install chromium)")

SETTINGS = [
    {},
    {"gain_db": 3.0},
    {"gain_db": -4.0},
    {"gain_db": -10.0},
    {"gain_db": 12.0},  # unstable
    {"notch": [0, {"freq_hz": 600.0}]},
    {"notch": [0, {"freq_hz": 300.0, "zeta_z": 0.2, "zeta_p": 0.5}]},
    {"lpf_hz": 1200.0},
    {"gain_db": 2.0, "notch": [0, {"freq_hz": 500.0}], "lpf_hz": 3000.0},
]
"""Moves applied on the page, each from the design as analysed: overall gain [dB], one notch's frequency [Hz] and
dampings [-], the low-pass pole [Hz]."""
MS_REL, PM_DEG, GM_DB, F_REL, DM_REL = 0.01, 0.5, 0.1, 0.005, 0.01
"""How close the page's figures are to the library's: Ms and disk margin within 1 %, phase margin 0.5 deg, gain
margins 0.1 dB, first crossover 0.5 % (the page reads them on its fixed dense grid, the library refines its grid)."""

PROBE = r"""<script>
window.addEventListener('load', () => {
  const E = window.feedtuneExplore, start = JSON.parse(JSON.stringify(E.params)), out = {runs: []};
  for (const s of SETTINGS) {
    const p = E.params;
    p.gain_db = s.gain_db || 0; p.lpf_hz = s.lpf_hz || start.lpf_hz;
    p.notches.forEach((n, k) => Object.assign(n, start.notches[k]));
    if (s.notch) Object.assign(p.notches[s.notch[0]], s.notch[1]);
    E.update();
    out.runs.push({metrics: E.last.metrics, ok: E.last.verdict.ok, doc: E.gainsDocument()});
  }
  Object.assign(E.params, {gain_db: 0, lpf_hz: start.lpf_hz});
  E.params.notches.forEach((n, k) => Object.assign(n, start.notches[k]));
  E.update();
  const before = document.getElementById('ms').textContent, slider = document.getElementById('notch-1-freq');
  const t0 = performance.now();
  slider.value = String(+slider.value + 150);
  slider.dispatchEvent(new Event('input'));
  out.slider = {before: before, after: document.getElementById('ms').textContent, ms: performance.now() - t0,
                notch_hz: E.params.notches[0].freq_hz};
  const pre = document.createElement('pre'); pre.id = 'feedtune-probe'; pre.textContent = JSON.stringify(out);
  document.body.appendChild(pre);
});
</script>"""


@pytest.fixture(scope="module")
def frf(examples_dir):
    return read_frf(examples_dir / "ballscrew_frf.csv")


def designs():
    """Two gains documents: MC-PPC with the thesis filter pack, P-PI with a 2nd-order low-pass and a lead stage."""
    mcppc = design_mcppc(THESIS_TABLE_3_1, filters=THESIS_FILTER_PACK)
    pack = FilterPack([Notch(420.0, 0.55, 0.7), Notch(1080.0, 0.05, 0.7)], 1800.0, lpf_order=2, lpf_zeta=0.6,
                      leads=[LeadStage(400.0, 15.0)])
    ppi = design_ppi(THESIS_TABLE_3_1, Kpx=75.7, Kpv=1.45, Kiv=274.0, filters=pack)
    return {"mcppc": gains_document(mcppc), "ppi": gains_document(ppi)}


def test_the_page_holds_the_analysed_loop_without_its_filter_pack(frf):
    for name, doc in designs().items():
        data = explore_data(doc, f"{name}.toml", frf, "ballscrew_frf.csv")
        case = analyze_gains(doc, name, frf).analysis.cases["discrete"]
        f = np.asarray(data["freq_hz"])
        L0 = np.asarray(data["L0_re"]) + 1j * np.asarray(data["L0_im"])
        pack = FilterPack.from_dict(doc["filters"]["continuous"])
        L = L0 * matched(pack.zpk(), data["fs_hz"]).tf.freqresp(f)
        inside = (case.freq_hz > 0) & (case.freq_hz < 0.999 * data["fs_hz"] / 2)
        at = np.searchsorted(f, case.freq_hz[inside])
        assert np.allclose(f[at], case.freq_hz[inside], rtol=1e-12)
        assert np.allclose(L[at], case.L[inside], rtol=1e-9), name
        assert data["reference"]["ms"] == pytest.approx(case.metrics.ms)
        assert len(f) >= 3000 and np.all(np.diff(f) > 0)


def test_the_page_is_one_self_contained_file(frf):
    doc = designs()["mcppc"]
    page = explore_html(explore_data(doc, "a</script>.toml", frf, "f.csv"))
    assert not re.search(r"""(src|href)\s*=\s*["']?(https?:|//)""", page)
    block = re.search(r'<script type="application/json" id="feedtune-explore-data">(.*?)</script>', page, re.S)
    data = json.loads(block.group(1))
    assert data["gains_name"] == "a</script>.toml" and "certificate" not in data["document"]


def test_other_gains_kinds_and_bad_outputs_get_one_line(frf, tmp_path, examples_dir, capsys, monkeypatch):
    with pytest.raises(UsageError, match="ball-screw gains files"):
        explore_data({"kind": "gantry"}, "mimo.toml", frf, "f.csv")
    gains = tmp_path / "mcppc.toml"
    write_document(gains, designs()["mcppc"])
    args = ["explore", str(gains), "--frf", str(examples_dir / "ballscrew_frf.csv"), "-q"]
    code, _, err = run([*args, "--out", tmp_path / "page.txt"], capsys, monkeypatch)
    assert code == 2 and "give a name ending in .html" in err and len(err.strip().splitlines()) == 1
    (tmp_path / "page.html").write_text("mine")
    code, _, err = run([*args, "--out", tmp_path / "page.html"], capsys, monkeypatch)
    assert code == 2 and "--force" in err and (tmp_path / "page.html").read_text() == "mine"
    code, out, _ = run([*args, "--out", tmp_path / "page.html", "--force"], capsys, monkeypatch)
    assert code == 0 and "wrote" in out and "feedtune-explore-data" in (tmp_path / "page.html").read_text()


def browse(page: Path, tmp: Path) -> dict:
    """Run :data:`PROBE` with :data:`SETTINGS` in headless Chromium on ``page`` and return what it recorded."""
    probe = PROBE.replace("SETTINGS", json.dumps(SETTINGS))
    text = page.read_text(encoding="utf-8").replace("</body>", probe + "</body>")
    probed = tmp / f"probe_{page.name}"
    probed.write_text(text, encoding="utf-8")
    res = run_browser(["--window-size=1280,900", "--dump-dom", probed.as_uri()], tmp / "profile")
    m = re.search(r'<pre id="feedtune-probe">(.*?)</pre>', res.stdout, re.S)
    assert m is not None, f"the probe did not run (exit {res.returncode}): {res.stderr[-2000:]}"
    return json.loads(html.unescape(m.group(1)))


@pytest.mark.slow
@needs_browser
@pytest.mark.parametrize("name", ["mcppc", "ppi"])
def test_the_page_computes_what_the_library_computes_on_the_file_it_downloads(name, frf, tmp_path, examples_dir,
                                                                              capsys, monkeypatch):
    doc = designs()[name]
    gains = tmp_path / f"{name}.toml"
    write_document(gains, doc)
    page = tmp_path / f"{name}.html"
    args = ["explore", gains, "--frf", examples_dir / "ballscrew_frf.csv", "--out", page, "-q"]
    assert run(args, capsys, monkeypatch)[0] == 0
    got = browse(page, tmp_path)
    worst = {"ms": 0.0, "pm": 0.0, "gm": 0.0, "gm_low": 0.0, "dm": 0.0, "f": 0.0}
    for setting, result in zip(SETTINGS, got["runs"], strict=True):
        file = tmp_path / f"{name}_explored.json"
        file.write_text(json.dumps(result["doc"]), encoding="utf-8")
        edited = read_document(file)
        assert "certificate" not in edited and edited["edited"]["from"] == str(gains)
        case = analyze_gains(edited, str(file), frf).analysis.cases["discrete"]
        shown, m = result["metrics"], case.metrics
        up, down = split_gain_margins(m.gain_margins)
        worst["ms"] = max(worst["ms"], abs(shown["ms"] / m.ms - 1))
        worst["pm"] = max(worst["pm"], abs(shown["pm_deg"] - m.phase_margin_deg))
        worst["gm"] = max(worst["gm"], abs(shown["gm_db"] - up[0]) if up else 0.0)
        worst["gm_low"] = max(worst["gm_low"], abs(shown["gm_low_db"] - down[0]) if down else 0.0)
        worst["dm"] = max(worst["dm"], abs(shown["disk_margin"] / m.disk_margin - 1))
        # each of the page's crossovers is one of the library's, or one of a cluster the library merged into one
        merged = [x for c in m.merged_crossovers if c["of"] == "crossovers" for x in c["freq_hz"]]
        for c in shown["crossovers"]:
            worst["f"] = max(worst["f"], min(abs(c["freq_hz"] / x - 1) for x in [*m.crossovers_hz, *merged]))
        for x in m.crossovers_hz:  # one the page misses is a touch of |L| = 1 (within 1 %) the library counts
            if min(abs(c["freq_hz"] / x - 1) for c in shown["crossovers"]) > F_REL:
                near = np.abs(case.freq_hz / x - 1) < F_REL
                assert np.min(np.abs(np.abs(case.L[near]) - 1)) < 0.01, (setting, x)
        assert (shown["gm_db"] is None) == (up is None) and (shown["gm_low_db"] is None) == (down is None), setting
        assert shown["stable"] == (m.stable and m.nyquist_reliable), setting
        items = [i for i in DEFAULT_LIMITS.check(m, "discrete") if i.name != "band_top"]
        assert result["ok"] == all(i.ok for i in items), (setting, [i.to_dict() for i in items])
        # the sections the file carries are the library's matching of the filters it names
        pack = FilterPack.from_dict(edited["filters"]["continuous"])
        f = np.geomspace(1.0, 9000.0, 400)
        sos = np.asarray(edited["filters"]["filter_pack_sos"])
        z = np.exp(-2j * np.pi * f / doc["sampling"]["fs_hz"]["value"])
        written = np.prod([(r[0] + r[1] * z + r[2] * z * z) / (r[3] + r[4] * z + r[5] * z * z) for r in sos], axis=0)
        assert np.allclose(written, matched(pack.zpk(), 20000.0).tf.freqresp(f), rtol=1e-9, atol=1e-12), setting
    assert worst["ms"] < MS_REL and worst["pm"] < PM_DEG and worst["gm"] < GM_DB and worst["gm_low"] < GM_DB, worst
    assert worst["dm"] < DM_REL and worst["f"] < F_REL, worst
    slider = got["slider"]
    assert slider["ms"] < 1000 and slider["before"] != slider["after"], slider
    assert slider["notch_hz"] > doc["filters"]["continuous"]["notches"][0]["freq_hz"], slider
