"""An interactive look at a ball-screw design on its measured FRF: one self-contained HTML page (no server, no
network) where the reader moves the gain, a notch (frequency and depth) or the low-pass pole of the filter pack and
sees the Bode plot, the Nyquist plot, ``|S|`` and the verdict follow, and downloads the gains file the page shows.

The page is a thin layer over the library. :func:`explore_data` runs the analysis ``feedtune analyze GAINS --frf F``
runs (:func:`feedtune.machines.analyze_gains`, discrete case: the FRF, the discrete controller, ZOH and computational
delay) and stores the loop without its filter pack, ``L0 = L / Fd``, on the analysis' grid made denser (log magnitude
and unwrapped phase interpolated in log frequency, as the analysis interpolates an FRF; ``L0`` holds no filter, so
its sharp features are the plant's, which the analysis' grid resolves). The page's script (``explore_page.js``)
evaluates ``L = k L0 Fd(f; notches, low-pass)`` with the filter pack discretized by pole-zero matching exactly as
:func:`feedtune.control.discretize.matched` does (each root ``s -> exp(s T)``, the low-pass's excess zeros at
``z = -1``, unit gain at 0 Hz), written as the second-order sections the gains file stores. From ``L`` it reads Ms
(the largest ``|1/(1 + L)|`` on the grid), every crossover with its phase margin and every phase crossover with its
gain margin (linear interpolation in log frequency), and stability as the analysed design's: the winding of
``1 + L`` over the grid unchanged. What it does not re-derive (possible crossings within the FRF's scatter, the
refinement of the grid around a moved notch, the ``band_top`` limit) the certificate does: the downloaded file
carries no certificate; ``feedtune analyze FILE --frf F`` certifies it. tests/test_explore.py holds the page's
numbers to the library's on a grid of filter settings.
"""

from __future__ import annotations

import json
import os
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from .. import progress
from ..errors import UsageError

DENSE_POINTS = 3000
"""Log-spaced frequencies added to the analysis' grid for the page (a moved notch lands between them, not between
the analysis' refined points)."""
EXPLORE_KINDS = ("ballscrew",)
"""Gains files the page covers: the SISO loop ``L = K1 G11 + K2 G21`` whose filter pack multiplies both paths."""


def explore_data(doc: Mapping, gains_name: str, frf, frf_name: str, limits=None) -> dict:
    """What the page holds: the loop without its filter pack on a dense grid, the filter pack, the limits, the
    analysed figures and the gains document.

    Parameters
    ----------
    doc : Mapping
        A ball-screw gains document.
    gains_name, frf_name : str
        Their names (shown, and the downloaded file's name).
    frf : Frf
        The measured FRF with ``x1/u`` and ``x2/u``.
    limits : Limits, optional
        The policy the verdict uses (default ``textbook``).

    Raises
    ------
    UsageError
        A gains file of another kind.
    """
    from ..analysis.limits import DEFAULT_LIMITS
    from ..control.discretize import matched
    from ..control.filters import FilterPack
    from ..lti import Zpk
    from ..machines import analyze_gains

    policy = limits or DEFAULT_LIMITS
    if doc.get("kind") not in EXPLORE_KINDS:
        raise UsageError(f"{gains_name}: the interactive page covers ball-screw gains files (kind 'ballscrew'), "
                         f"not {doc.get('kind')!r}")
    progress.step(f"explore: analysing {gains_name} on {frf_name}")
    done = analyze_gains(doc, gains_name, frf)
    case = done.analysis.cases.get("discrete")
    if case is None:
        raise UsageError(f"{frf_name}: the FRF needs the channels x1/u and x2/u for the discrete case")
    law = done.law
    pack = FilterPack.from_dict(doc["filters"].get("continuous", {}))
    fs = float(law.fs)
    f = np.asarray(case.freq_hz, float)
    F = law.filter_pack_discrete().freqresp(f)
    keep = (np.abs(F) > 1e-9) & (f < 0.999 * fs / 2) & (f > 0)
    f, L0 = f[keep], case.L[keep] / F[keep]
    dense = np.union1d(f, np.logspace(np.log10(f[0]), np.log10(f[-1]), DENSE_POINTS))
    mag = np.interp(np.log(dense), np.log(f), np.log(np.abs(L0)))
    phase = np.interp(np.log(dense), np.log(f), np.unwrap(np.angle(L0)))
    L0d = np.exp(mag + 1j * phase)
    leads = Zpk.constant(1.0)
    for stage in pack.leads:
        leads = leads * stage.zpk()
    fixed = matched(leads, fs).tf.to_sos().tolist() if pack.leads else []
    m = case.metrics
    return {
        "gains_name": gains_name, "frf_name": frf_name, "fs_hz": fs, "kind": doc.get("kind"),
        "controller": doc.get("controller"), "freq_hz": dense.tolist(), "L0_re": L0d.real.tolist(),
        "L0_im": L0d.imag.tolist(), "filters": {k: v for k, v in pack.to_dict().items() if k != "leads"},
        "fixed_sos": fixed, "limits": {**policy.to_dict(), "name": policy.name},
        "reference": {"ms": float(m.ms), "ms_freq_hz": float(m.ms_freq_hz),
                      "stable": bool(m.stable) and bool(getattr(m, "nyquist_reliable", True)),
                      "crossovers_hz": [float(x) for x in m.crossovers_hz]},
        "document": json.loads(json.dumps({k: v for k, v in doc.items() if k != "certificate"}, default=float)),
    }


def explore_html(data: Mapping) -> str:
    """The self-contained page (inline CSS and script, the data as a JSON block; nothing loaded from anywhere)."""
    import html

    script = (Path(__file__).with_name("explore_page.js")).read_text(encoding="utf-8")
    payload = json.dumps(data, allow_nan=False, separators=(",", ":")).replace("<", "\\u003c")
    title = f"feedtune explore: {data['gains_name']} on {data['frf_name']}"
    ref = data["reference"]
    return f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>{html.escape(title)}</title>
<style>
body {{ font: 14px/1.45 system-ui, sans-serif; margin: 16px auto; max-width: 1180px; color: #1b1f24; }}
#controls label {{ display: grid; grid-template-columns: 190px 1fr 110px; gap: 8px; align-items: center; }}
#figures {{ display: grid; grid-template-columns: 1fr 1fr; gap: 12px; }}
canvas {{ border: 1px solid #d0d7de; max-width: 100%; }}
table {{ border-collapse: collapse; }} td, th {{ border: 1px solid #d0d7de; padding: 2px 8px; text-align: left; }}
#verdict.pass {{ border-left: 4px solid #1a7f37; padding-left: 8px; font-weight: 600; }}
#verdict.fail {{ border-left: 4px solid #9a4d00; background: #fff4e5; padding-left: 8px; font-weight: 600; }}
.note {{ color: #57606a; font-size: 0.9em; }}
</style></head><body>
<h1>{html.escape(title)}</h1>
<p class="note">The loop of the gains file on the measured FRF (discrete controller, ZOH and computational delay) as
<code>feedtune analyze {html.escape(data['gains_name'])} --frf {html.escape(data['frf_name'])}</code> computes it:
Ms {ref['ms']:.4g} at {ref['ms_freq_hz']:.4g} Hz as analysed. Move the gain, a notch or the low-pass pole: the loop is
re-evaluated here (grey: as analysed). The download is the gains file shown, without a certificate: certify it with
<code>feedtune analyze FILE --frf {html.escape(data['frf_name'])}</code> (possible crossings within the FRF's scatter
and the grid refinement around a moved notch are the analysis' work).</p>
<div id="controls"></div>
<p><button id="download">Download the gains file shown (JSON)</button> <span class="note">updated in
<span id="elapsed">-</span></span></p>
<p id="verdict"></p>
<table><tr><th>Ms</th><th>at</th><th>PM (worst)</th><th>GM</th><th>gain-reduction GM</th><th>disk margin</th>
<th>first crossover</th></tr>
<tr><td id="ms"></td><td id="ms-at"></td><td id="pm"></td><td id="gm"></td><td id="gm-low"></td><td id="dm"></td>
<td id="bw"></td></tr>
</table>
<div id="figures"><canvas id="bode" width="560" height="370"></canvas><canvas id="nyquist" width="420" height="370">
</canvas><canvas id="sens" width="560" height="260"></canvas></div>
<script type="application/json" id="feedtune-explore-data">{payload}</script>
<script>
{script}
</script>
</body></html>
"""


def write_explore_page(doc: Mapping, gains_name: str, frf, frf_name: str, out: str | os.PathLike[str], *,
                       limits=None, force: bool = False) -> Path:
    """Write the page (:func:`explore_data`, :func:`explore_html`) to ``out`` atomically; refuses an existing file
    without ``force`` (UsageError)."""
    from ..io import atomic_outputs

    text = explore_html(explore_data(doc, gains_name, frf, frf_name, limits))
    with atomic_outputs([Path(out)], force=force) as temps:
        temps[0].write_text(text, encoding="utf-8")
    return Path(out)
