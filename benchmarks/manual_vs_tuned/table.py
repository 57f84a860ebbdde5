"""Manual vs tuned, tabulated from the files ``ballscrew.sh`` / ``gantry.sh`` wrote in the current folder.

``python table.py ballscrew|gantry FRF1,FRF2,... DESIGN1,DESIGN2,... LIMITS``: for each design (``DESIGN.toml``) the
worst over the FRFs of ``feedtune analyze DESIGN.toml --frf F --json --limits LIMITS`` (first crossover, Ms, the
smallest |PM|, the verdict; a gantry FRF is analysed at the table position it records) and the twin runs
``rs_DESIGN.json`` (rope snap: peak, 5 % settling) and ``tr_DESIGN.json`` (tracking: max, RMS), as a Markdown table.
"""

from __future__ import annotations

import json
import subprocess
import sys


def worst(design: str, frfs: list[str], limits: str) -> tuple[float, float, float, bool]:
    xo, ms, pm, ok = [], [], [], True
    for f in frfs:
        r = subprocess.run(["feedtune", "analyze", f"{design}.toml", "--frf", f, "--json", "--limits", limits],
                           capture_output=True, text=True, check=True)
        d = json.loads(r.stdout)
        a = d["analysis"]["discrete"]
        xo.append(a["crossovers_hz"][0])
        ms.append(a["ms"])
        pm.append(abs(a["phase_margin_deg"]))
        ok = ok and d["check"]["ok"]
    return min(xo), max(ms), min(pm), ok


def main(kind: str, frfs: list[str], designs: list[str], limits: str) -> None:
    if kind == "gantry":
        print("| design | CoM first crossover (worst) [Hz] | Ms (worst) | PM (worst) [deg] | verdict "
              "| rope-snap peak [um] | settling [ms] | tracking max y1/y2 [um] | tracking RMS y1/y2 [um] |")
    else:
        print("| design | first crossover (worst) [Hz] | Ms (worst) | PM (worst) [deg] | verdict | rope-snap peak [um] "
              "| settling [ms] | tracking max [um] | tracking RMS [um] |")
    print("|---|---|---|---|---|---|---|---|---|")
    for g in designs:
        xo, ms, pm, ok = worst(g, frfs, limits)
        with open(f"rs_{g}.json") as fh:
            rs = json.load(fh)
        with open(f"tr_{g}.json") as fh:
            tr = json.load(fh)
        if kind == "gantry":
            t = tr["tracking"]
            track = (f"{1e6 * t['y1']['overall']['max_m']:.3f} / {1e6 * t['y2']['overall']['max_m']:.3f} | "
                     f"{1e6 * t['y1']['overall']['rms_m']:.3f} / {1e6 * t['y2']['overall']['rms_m']:.3f}")
        else:
            track = f"{tr['max_um']:.3f} | {tr['rms_um']:.3f}"
        print(f"| {g} | {xo:.1f} | {ms:.2f} | {pm:.1f} | {'meets' if ok else 'FAILS'} | {rs['peak_um']:.2f} | "
              f"{1e3 * rs['settling_time_s']:.1f} | {track} |")


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2].split(","), sys.argv[3].split(","), sys.argv[4])
