"""Evidence for the tuners' default objective (docs/verdicts.md, "How designs are tuned"; issue 23 item 5).

Run by hand: ``python benchmarks/objective_evidence.py [--seed N]``.

* Ball-screw twin (:class:`feedtune.machines.ballscrew.twin.BallScrewTwin`, the demo's): the FRF measured on the
  twin, the 2-mass model identified from it, MC-PPC and P-PI tuned on that FRF with the thesis' filter pack under the
  textbook limits for each objective (and MC-PPC for ``stiffness`` with the axial-mode compliance capped at the
  thesis design's, beta 4, 50 Hz, zeta 0.7), then on the twin, through the exported gains text: the rope snap
  (0.5 V) and tracking at 1 m/s (the demo's move). The rope-snap IAE is computed here from the log, not by feedtune:
  the integral of ``|x2_table - mean before the release|`` over 0.2 s after the release (the response settles to
  5 % within 0.03-0.06 s) and over the whole second logged [um s].
* The same on the twin with the designs tuned on the example family (the examples are built from the twin's
  Table 3.1 drive).
* The example family (examples/ballscrew_frf_m70/_m100/_m130.csv with the model identified from
  examples/ballscrew_frf.csv): ``Ki2`` of MC-PPC for each objective at the same limits.

The gantry twin's comparison is the demo's (``feedtune demo gantry --objective bandwidth|stiffness``).
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]


def ropesnap_iae_um_s(log, t_release: float, after_s: float = 1.0) -> float:
    """``int |x - baseline| dt`` over ``after_s`` after the release [um s] (baseline: mean before the release)."""
    t, x = np.asarray(log.t), np.asarray(log["x2_table"])
    base = float(np.mean(x[t < t_release])) if np.any(t < t_release) else 0.0
    m = (t >= t_release) & (t <= t_release + after_s)
    return float(np.sum(np.abs(x[m] - base)) * (t[1] - t[0]) * 1e6)


def twin_figures(twin, design, seed: int) -> dict:
    """Rope-snap IAE and peak, tracking RMS and max at 1 m/s of a design on the twin (through its gains text)."""
    from feedtune.io import dumps_toml
    from feedtune.io.document import loads_document
    from feedtune.io.gains import gains_document
    from feedtune.machines.ballscrew.experiments import run_ropesnap, run_tracking
    from feedtune.machines.ballscrew.runtime import GainsRuntime
    from feedtune.sim.trajectory import point_to_point
    from feedtune.workflows.ballscrew_demo import DEMO_MOVE

    text = dumps_toml(gains_document(design))
    rt = GainsRuntime.from_document(loads_document(text, "toml", "gains.toml"), "gains.toml")
    snap = run_ropesnap(twin, rt, force=0.5, seed=seed)
    tr = point_to_point(DEMO_MOVE["distance"], v_max=1.0, a_max=DEMO_MOVE["a_max"], j_max=DEMO_MOVE["j_max"],
                        fs=twin.fs, dwell_before=DEMO_MOVE["dwell_before"], dwell_after=DEMO_MOVE["dwell_after"])
    track = run_tracking(twin, rt, tr, seed=seed)
    return {"iae_um_s": ropesnap_iae_um_s(snap.log, 0.6, 0.2), "iae_1s_um_s": ropesnap_iae_um_s(snap.log, 0.6),
            "peak_um": snap.summary["peak_um"],
            "rms_um": track.summary["rms_um"], "max_um": track.summary["max_um"]}


def ballscrew_twin(seed: int) -> list[dict]:
    from feedtune.analysis.limits import DEFAULT_LIMITS
    from feedtune.control.filters import THESIS_FILTER_PACK
    from feedtune.design.mcppc import design_mcppc
    from feedtune.identify.ballscrew import fit_ballscrew
    from feedtune.machines.ballscrew.experiments import measure_frf
    from feedtune.machines.ballscrew.twin import BallScrewTwin, TwinParams
    from feedtune.tune.compliance import AxialCompliance
    from feedtune.tune.mcppc import tune_mcppc
    from feedtune.tune.ppi import tune_ppi

    twin = BallScrewTwin(TwinParams())
    p = twin.params
    frf = measure_frf(twin, seed=seed).frf
    model = fit_ballscrew(frf).model
    common = {"limits": DEFAULT_LIMITS, "filters": THESIS_FILTER_PACK, "frf": frf, "fs": p.fs,
              "delay_samples": p.delay_samples}
    thesis = design_mcppc(model, beta=4.0, pole_hz=50.0, zeta=0.7, filters=THESIS_FILTER_PACK, fs=p.fs,
                          delay_samples=p.delay_samples)
    cap = AxialCompliance(model, p.fs, p.delay_samples)(thesis.law())
    rows = []
    for name, tuner, kw in (("MC-PPC", tune_mcppc, {"objective": "bandwidth"}),
                            ("MC-PPC", tune_mcppc, {"objective": "stiffness"}),
                            ("MC-PPC", tune_mcppc, {"objective": "stiffness", "compliance_max": cap}),
                            ("P-PI", tune_ppi, {"objective": "bandwidth"}),
                            ("P-PI", tune_ppi, {"objective": "stiffness"})):
        t0 = time.perf_counter()
        d = tuner(model, **common, **kw)
        dt = time.perf_counter() - t0
        shape = f"beta {d.beta:g}, zeta {d.zeta:g}" if name == "MC-PPC" else "-"
        rows.append({"controller": name, "objective": kw["objective"] + (" + cap" if "compliance_max" in kw else ""),
                     "shape": shape, "Ki2": d.gains["Ki2"], "first_crossover_hz": d.tuning["first_crossover_hz"],
                     "compliance": AxialCompliance(model, p.fs, p.delay_samples)(d.law()), "tune_s": dt,
                     **twin_figures(twin, d, seed)})
    rows.append({"controller": "thesis MC-PPC", "objective": "-", "shape": "beta 4, zeta 0.7, 50 Hz",
                 "Ki2": thesis.gains["Ki2"], "first_crossover_hz": float("nan"), "compliance": cap, "tune_s": 0.0,
                 **twin_figures(twin, thesis, seed)})
    return rows


def example_family(seed: int) -> list[dict]:
    from feedtune.identify.ballscrew import fit_ballscrew
    from feedtune.io import read_frf
    from feedtune.machines.ballscrew.twin import BallScrewTwin, TwinParams
    from feedtune.tune.mcppc import tune_mcppc

    twin = BallScrewTwin(TwinParams())
    model = fit_ballscrew(read_frf(ROOT / "examples" / "ballscrew_frf.csv")).model
    frfs = [read_frf(ROOT / "examples" / f"ballscrew_frf_m{m}.csv") for m in (70, 100, 130)]
    out = []
    for obj in ("bandwidth", "stiffness"):
        t0 = time.perf_counter()
        d = tune_mcppc(model, frf=frfs, objective=obj)
        out.append({"objective": obj, "beta": d.beta, "zeta": d.zeta, "pole_hz": d.pole_hz, "Ki2": d.gains["Ki2"],
                    "first_crossover_hz": d.tuning["first_crossover_hz"], "tune_s": time.perf_counter() - t0,
                    **twin_figures(twin, d, seed)})
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()
    print(f"ball-screw twin (seed {args.seed}): rope snap 0.5 V, tracking 1 m/s")
    print(f"{'controller':14s} {'objective':17s} {'shape':24s} {'Ki2':>9s} {'f_c1 Hz':>8s} {'compl.':>9s} "
          f"{'IAE.2s':>7s} {'IAE 1s':>7s} {'peak um':>8s} {'RMS um':>7s} {'max um':>7s}")
    for r in ballscrew_twin(args.seed):
        print(f"{r['controller']:14s} {r['objective']:17s} {r['shape']:24s} {r['Ki2']:9.4g} "
              f"{r['first_crossover_hz']:8.4g} {r['compliance']:9.4g} {r['iae_um_s']:7.4g} {r['iae_1s_um_s']:7.4g} "
              f"{r['peak_um']:8.4g} {r['rms_um']:7.4g} {r['max_um']:7.4g}")
    print("\nexample family m70/m100/m130, MC-PPC, textbook limits, then on the twin")
    fam = example_family(args.seed)
    for r in fam:
        print(f"{r['objective']:10s} beta {r['beta']:g} zeta {r['zeta']:.3g} pole {r['pole_hz']:.4g} Hz: Ki2 "
              f"{r['Ki2']:.4g}, first crossover {r['first_crossover_hz']:.4g} Hz ({r['tune_s']:.2f} s); twin: IAE "
              f"{r['iae_um_s']:.4g} (0.2 s) {r['iae_1s_um_s']:.4g} (1 s) um s, peak {r['peak_um']:.4g} um, RMS "
              f"{r['rms_um']:.4g} um at 1 m/s")
    print(f"Ki2 stiffness / bandwidth: {fam[1]['Ki2'] / fam[0]['Ki2']:.3f}")


if __name__ == "__main__":
    main()
