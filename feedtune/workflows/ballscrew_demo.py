"""The main job in one command, on the twin: measure, identify, design, test, compare (thesis §3.4, Table 3.2).

:func:`run_demo` measures the FRF of the ball-screw twin under a weak stabilising controller, identifies the
2-mass model from it, tunes MC-PPC and P-PI with the thesis's filter pack under the same limits on the measured FRF
for the same objective (:class:`feedtune.tune.search.Objective`, default ``stiffness``: the highest integral gain
``Ki2``), delivers both gains files with their certificate on the measured FRF
(:func:`feedtune.workflows.deliver.deliver`; the FRF from memory, identified by its arrays) and runs every test
through :class:`~feedtune.machines.ballscrew.runtime.GainsRuntime` reading the exported text only: rope snap and
tracking at 200, 500 and 1000 mm/s with both controllers, plus the slotting cut at 200 mm/s. Then it
identifies the trajectory pre-filter (§3.2.4) from the MC-PPC tracking run at 500 mm/s, exports
``mcppc_prefilter_gains.toml`` and tracks the three speeds again with it ("MC-PPC+PF"). The result
holds the comparison table and the text of every file; :func:`write_texts` writes them all or none.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from ..analysis.comparison import better_per_figure, reduction_pct, verdict_line
from ..analysis.limits import DEFAULT_LIMITS, Limits
from ..errors import DesignError
from .files import experiment_texts, plain_json

SPEEDS_M_PER_S = (0.2, 0.5, 1.0)
"""Tracking speeds of Table 3.2 [m/s]."""
DEMO_MOVE = {"distance": 0.25, "a_max": 9.81, "j_max": 1000.0, "dwell_before": 0.05, "dwell_after": 0.2}
"""The demo's point-to-point move: 250 mm at 1 g (the thesis ran 200, 500 and 1000 mm/s at 1 g) with 1000 m/s^3
jerk, and dwells [m, m/s^2, m/s^3, s, s]; long enough to cruise at 1000 mm/s."""
CONTROLLERS = ("mcppc", "ppi")
LABELS = {"mcppc": "MC-PPC", "ppi": "P-PI", "mcppc_prefilter": "MC-PPC+PF"}
PREFILTER_SPEED = 0.5
"""Speed of the MC-PPC tracking run the pre-filter is identified from [m/s] (the nearest demo speed)."""


@dataclass(frozen=True)
class DemoResult:
    """Everything the demo computed.

    Attributes
    ----------
    rows : list of dict
        One per test: ``{"test", "mcppc": {...}, "ppi": {...}}`` with ``max_um``, ``rms_um`` (tracking,
        cut) or ``peak_um``, ``settling_time_s`` (rope snap).
    identified : dict
        The fit (:meth:`~feedtune.identify.ballscrew.BallScrewFit.to_dict`).
    designs : dict
        Per controller: gains and the discrete-case peak sensitivity ``ms``.
    texts : dict
        File name -> file text (CSV logs, FRF, model and gains TOML/JSON, summary JSON).
    twin : dict
        The twin's parameters.
    prefilter : dict
        The pre-filter fit (:meth:`~feedtune.design.prefilter.PrefilterFit.to_dict`) and the speed of the
        run it came from; tracking rows then also hold ``"mcppc_prefilter"`` figures.
    """

    rows: list
    identified: dict
    designs: dict
    texts: dict = field(repr=False)
    twin: dict = field(repr=False, default_factory=dict)
    prefilter: dict = field(default_factory=dict)
    limits: dict = field(default_factory=dict)

    def to_dict(self) -> dict:
        """JSON-ready: limits, comparison rows (with the better controller per figure), identified model, designs
        with their tuning rules, pre-filter, twin parameters, file names."""
        return {"limits": self.limits, "comparison": self.rows, "identified": self.identified,
                "designs": self.designs, "prefilter": self.prefilter, "twin": self.twin, "files": sorted(self.texts),
                "units": {"max_um": "um", "rms_um": "um", "peak_um": "um", "settling_time_s": "s",
                          "speed": "mm/s"}}

    def summary(self) -> str:
        """What the demo prints: the identified model, both tuned designs with the limits and the rule, and the
        comparison (:meth:`table`)."""
        from ..display import at_lower_bound, quantity
        from ..models.ballscrew import LOWER_BOUNDS

        ident = self.identified
        std = ident.get("std") or {}

        def param(k, v):  # the fit's damping parameters are bounded below by 0: a value on 0 is printed as 0
            at_bound = at_lower_bound(v, std.get(k), LOWER_BOUNDS.get(k))
            return f"{k} = {quantity(0.0 if at_bound else v, ident['units'].get(k, ''))}" + (
                " (at its lower bound)" if at_bound else "")

        lines = ["Identified from the measured FRF: " + ", ".join(param(k, v) for k, v in ident["params"].items())]
        lim = self.limits
        rules = {d["tuning"].get("objective_rule") for d in self.designs.values() if d.get("tuning")}
        lines.append("Both controllers tuned under the same limits ("
                     + Limits.from_dict(lim).describe()
                     + ") on the measured FRF (discrete case), with the thesis' filter pack, by the same objective, "
                     + "; ".join(sorted(r for r in rules if r)))
        labels = {"mcppc": "MC-PPC", "ppi": "P-PI"}
        for name, d in self.designs.items():
            if name not in labels:
                continue
            params = d.get("design") or d.get("ppi_gains") or {}
            chosen = ", ".join(f"{k} = {v:.4g}" for k, v in params.items())
            crossovers = ", ".join(f"{x:.1f}" for x in d["crossovers_hz"])
            pm = "-" if d["phase_margin_deg"] is None else f"{d['phase_margin_deg']:.3g} deg"
            gm = "-" if d["gain_margin_db"] is None else f"{d['gain_margin_db']:.3g} dB"
            lines.append(f"{labels[name]} ({chosen}): crossovers {crossovers} Hz, Ms {d['ms']:.3g}, PM {pm}, GM {gm}, "
                         f"Ki2 {d['gains']['Ki2']:.4g} V/(rad s); limit reached: {d['active_limit']}")
            lines += [f"  warning: {w}" for w in d["tuning"].get("warnings", [])]
        return "\n".join(lines) + "\n\n" + self.table()

    def table(self) -> str:
        """The comparison as text, laid out like Table 3.2 (plus MC-PPC with the pre-filter when run), with the
        limits and the rule both controllers were tuned by, and which one is better in each figure."""
        pf = any("mcppc_prefilter" in row for row in self.rows)
        head = (f"{'test':22s} {'MC-PPC max':>10s} {'RMS':>7s} {'P-PI max':>10s} {'RMS':>7s} "
                f"{'max -%':>7s} {'RMS -%':>7s}" + (f" {'MC-PPC+PF max':>13s} {'RMS':>7s}" if pf else ""))
        lines = ["Tracking error of the table [um] (Table 3.2; -%: MC-PPC's reduction against P-PI, negative: "
                 "P-PI better)", head]
        for row in self.rows:
            if "max_um" not in row["mcppc"]:
                continue
            a, b = row["mcppc"], row["ppi"]
            c = row.get("mcppc_prefilter")
            extra = "" if not pf else f" {c['max_um']:13.3f} {c['rms_um']:7.3f}" if c else f" {'-':>13s} {'-':>7s}"
            lines.append(f"{row['test']:22s} {a['max_um']:10.3f} {a['rms_um']:7.3f} {b['max_um']:10.3f} "
                         f"{b['rms_um']:7.3f} {reduction_pct(a['max_um'], b['max_um']):7.1f} "
                         f"{reduction_pct(a['rms_um'], b['rms_um']):7.1f}{extra}")
        if self.prefilter:
            g, u = self.prefilter["gains"], self.prefilter["units"]
            lines += ["", f"MC-PPC+PF: pre-filter identified from the MC-PPC run at "
                          f"{self.prefilter['speed_mm_s']:g} mm/s (eq. 3.17-3.20, {self.prefilter['lpf_hz']:g} Hz): "
                      + ", ".join(f"{k} = {v:.4g} {u[k]}" for k, v in g.items())]
        for row in self.rows:
            if "peak_um" in row["mcppc"]:
                a, b = row["mcppc"], row["ppi"]
                lines += ["", f"Rope snap ({row['test']}): peak [um], 5 % settling time [s]",
                          f"  MC-PPC {a['peak_um']:8.3f} um  {_fmt_s(a['settling_time_s'])}",
                          f"  P-PI   {b['peak_um']:8.3f} um  {_fmt_s(b['settling_time_s'])}"]
        lines += ["", verdict_line(self.rows)]
        return "\n".join(lines)


def _fmt_s(x) -> str:
    return "not settled" if x is None else f"{x:.4f} s"


# ------------------------------------------------------------------------------------------ demo
def run_demo(*, seed: int = 0, speeds=SPEEDS_M_PER_S, params=None, engine: str = "auto",
             rope_force: float = 0.5, include_cut: bool = True, limits: Limits | None = None,
             objective=None) -> DemoResult:
    """Run the whole job on the twin (see the module docstring); nothing is written.

    Parameters
    ----------
    seed : int
        Seed of the excitation phases and of the measurement noise.
    speeds : sequence of float
        Tracking speeds [m/s].
    params : TwinParams, optional
        The twin (default: the thesis's drive with every unmodeled effect).
    engine : str
        Simulation engine.
    rope_force : float
        Rope force [V].
    include_cut : bool
        Also run the slotting cut at the first speed.
    limits : Limits, optional
        The limits both controllers are tuned under (default: textbook).
    objective : str or Objective, optional
        What both tuners maximise (:class:`feedtune.tune.search.Objective`, default ``stiffness``), with its
        compliance cap if any.

    Returns
    -------
    DemoResult

    Raises
    ------
    DesignError
        No design meets the limits on the measured FRF (with the default twin and limits this does not happen).
    """
    from .. import progress
    from ..control.filters import THESIS_FILTER_PACK
    from ..identify.ballscrew import fit_ballscrew
    from ..io import dumps_json, dumps_toml, model_document
    from ..machines.ballscrew.experiments import measure_frf
    from ..machines.ballscrew.twin import BallScrewTwin, TwinParams
    from ..machines.certificate import FrfSource
    from ..parallel import plan, run_groups
    from ..tune.mcppc import tune_mcppc
    from ..tune.ppi import tune_ppi
    from ..tune.search import Objective
    from .deliver import deliver

    Objective.of(objective)  # a bad objective is refused before the twin runs
    twin = BallScrewTwin(params or TwinParams())
    p = twin.params
    progress.step("measuring the FRF on the twin")
    frf_res = measure_frf(twin, seed=seed, engine=engine)
    if frf_res.tripped:
        raise DesignError(f"FRF measurement stopped: {frf_res.run.trip_message}")
    frf = frf_res.frf
    progress.step("identifying the 2-mass model")
    fit = fit_ballscrew(frf)
    texts = experiment_texts(frf_res, "frf_measurement.csv", "frf.csv")
    model_doc = model_document(fit.model, fit=fit.to_dict())
    texts["model.toml"], texts["model.json"] = dumps_toml(model_doc), dumps_json(model_doc)

    policy = limits or DEFAULT_LIMITS
    common = {"limits": policy, "filters": THESIS_FILTER_PACK, "frf": frf, "fs": p.fs,
              "delay_samples": p.delay_samples, "objective": Objective.of(objective)}
    designs, runtimes = {}, {}
    progress.step("tuning MC-PPC and P-PI under the same limits")
    tuned = run_groups(plan([("mcppc", lambda: tune_mcppc(fit.model, **common), 1.0),
                             ("ppi", lambda: tune_ppi(fit.model, **common), 0.6)]))  # side by side on the cores
    measured = FrfSource.from_memory("frf.csv", frf)  # the twin's FRF, written as frf.csv
    for name in CONTROLLERS:
        design = tuned[name]
        delivery = deliver(design, [measured], policy, where=f"{name}_gains.toml")
        if not delivery.ok:  # the tuners return only designs that pass; this is the exported file's own certificate
            raise DesignError(f"{LABELS[name]} design on the identified model: {'; '.join(delivery.violations())}")
        texts.update(delivery.texts(f"{name}_gains"))
        runtimes[name] = _runtime_from_text(texts[f"{name}_gains.toml"], f"{name}_gains.toml")
        designs[name] = _design_figures(design, delivery.certificate.frfs[0])
    runs: dict = {}
    progress.step("rope snap, tracking and cutting on the twin")
    rows = _tests(twin, runtimes, speeds, seed, engine, rope_force, include_cut, texts, runs)
    progress.step("pre-filter runs")
    prefilter = _prefilter_tests(twin, texts, speeds, seed, engine, rows, runs)
    for row in rows:
        row["better"] = {k: w for t, k, w in better_per_figure([row])}
    result = DemoResult(rows, fit.to_dict(), designs, texts, p.to_dict(), prefilter, policy.to_dict())
    texts["summary.json"] = dumps_json(plain_json({k: v for k, v in result.to_dict().items() if k != "files"}))
    return result


def _design_figures(design, checked) -> dict:
    """What the demo prints and stores of a design: gains, tuning rule and the certified case's figures (``checked``:
    the :class:`~feedtune.machines.certificate.FrfCertificate` on the measured FRF)."""
    m = checked.metrics
    active = checked.check.active()
    out = {"gains": dict(design.gains), "tuning": design.tuning, "checked_case": checked.checked_case,
           "ms": m.ms, "crossovers_hz": list(m.crossovers_hz), "phase_margin_deg": m.phase_margin_deg,
           "gain_margin_db": m.gain_margin_db, "disk_margin": m.disk_margin,
           "rejection_bands_hz": m.rejection_bands_hz, "active_limit": None if active is None else active.name,
           "rule": design.tuning.get("rule", design.tuning.get("method"))}
    if design.kind == "ppi":
        out["ppi_gains"] = dict(design.ppi_gains)
    else:
        out["design"] = {"beta": design.beta, "pole_hz": design.pole_hz, "zeta": design.zeta}
    return out


def _runtime_from_text(text: str, name: str):
    """The runtime built from exactly the exported TOML text."""
    from ..io.document import loads_document
    from ..machines.ballscrew.runtime import GainsRuntime

    return GainsRuntime.from_document(loads_document(text, "toml", name), name)


def _tests(twin, runtimes, speeds, seed, engine, rope_force, include_cut, texts, runs=None) -> list:
    """Rope snap, tracking at each speed and the cut with every runtime; ``runs`` (optional) receives the tracking
    results as ``{(controller, speed): ExperimentResult}``."""
    from ..machines.ballscrew.experiments import SlotCut, run_cut, run_ropesnap, run_tracking
    from ..sim.trajectory import point_to_point

    rows = []
    row = {"test": f"{rope_force:g} V"}
    for name, rt in runtimes.items():
        res = run_ropesnap(twin, rt, force=rope_force, seed=seed, engine=engine)
        texts[f"ropesnap_{name}.csv"] = _log_text(res)
        row[name] = _figures(res, ("peak_um", "settling_time_s"))
    rows.append(row)
    for v in speeds:
        tr = point_to_point(DEMO_MOVE["distance"], v_max=v, a_max=DEMO_MOVE["a_max"], j_max=DEMO_MOVE["j_max"],
                            fs=twin.fs, dwell_before=DEMO_MOVE["dwell_before"], dwell_after=DEMO_MOVE["dwell_after"])
        row = {"test": f"track {v * 1e3:g} mm/s", "speed": v * 1e3}
        for name, rt in runtimes.items():
            res = run_tracking(twin, rt, tr, seed=seed, engine=engine)
            texts[f"track_{v * 1e3:g}mm_s_{name}.csv"] = _log_text(res)
            row[name] = _figures(res, ("max_um", "rms_um"))
            if runs is not None:
                runs[(name, v)] = res
        rows.append(row)
    if include_cut:
        v = speeds[0]
        cut = SlotCut()
        dist = cut.start_m + cut.length_m + 0.03
        tr = point_to_point(dist, v_max=v, a_max=DEMO_MOVE["a_max"], j_max=DEMO_MOVE["j_max"], fs=twin.fs,
                            dwell_before=DEMO_MOVE["dwell_before"], dwell_after=DEMO_MOVE["dwell_after"])
        row = {"test": f"cut {v * 1e3:g} mm/s*", "speed": v * 1e3}
        for name, rt in runtimes.items():
            res = run_cut(twin, rt, tr, cut, seed=seed, engine=engine)
            texts[f"cut_{v * 1e3:g}mm_s_{name}.csv"] = _log_text(res)
            row[name] = _figures(res, ("max_um", "rms_um"))
        rows.append(row)
    return rows


def _prefilter_tests(twin, texts, speeds, seed, engine, rows, runs=None) -> dict:
    """Identify the pre-filter from one MC-PPC run, export it, rerun the tracking speeds with it.

    Adds ``"mcppc_prefilter"`` figures to the tracking rows and the files ``mcppc_prefilter_gains.toml/.json``
    and ``track_*_mcppc_prefilter.csv`` to ``texts``; returns the fit with the identification speed. The MC-PPC
    run at that speed is taken from ``runs`` (:func:`_tests`) when it is there: the same gains file, move, seed
    and engine give the same run.
    """
    from ..design.prefilter import fit_prefilter
    from ..io import dumps_json, dumps_toml
    from ..io.document import loads_document
    from ..io.gains import with_prefilter
    from ..machines.ballscrew.experiments import run_tracking

    speed = min(speeds, key=lambda v: abs(v - PREFILTER_SPEED))
    ident = (runs or {}).get(("mcppc", speed))
    if ident is None:
        mcppc = _runtime_from_text(texts["mcppc_gains.toml"], "mcppc_gains.toml")
        ident = run_tracking(twin, mcppc, _demo_move(speed, twin.fs), seed=seed, engine=engine)
        _log_text(ident)  # stops on a tripped run
    fit = fit_prefilter(ident.log)
    doc = with_prefilter(loads_document(texts["mcppc_gains.toml"], "toml", "mcppc_gains.toml"), fit,
                         where="mcppc_gains.toml")
    name = "mcppc_prefilter_gains"
    texts[f"{name}.toml"], texts[f"{name}.json"] = dumps_toml(doc), dumps_json(doc)
    runtime = _runtime_from_text(texts[f"{name}.toml"], f"{name}.toml")
    for v in speeds:
        res = run_tracking(twin, runtime, _demo_move(v, twin.fs), seed=seed, engine=engine)
        texts[f"track_{v * 1e3:g}mm_s_mcppc_prefilter.csv"] = _log_text(res)
        row = next(r for r in rows if r["test"] == f"track {v * 1e3:g} mm/s")
        row["mcppc_prefilter"] = _figures(res, ("max_um", "rms_um"))
    return {**fit.to_dict(), "speed_mm_s": speed * 1e3, "gains_file": f"{name}.toml"}


def _demo_move(v: float, fs: float):
    """The demo's point-to-point move at ``v`` [m/s]."""
    from ..sim.trajectory import point_to_point

    return point_to_point(DEMO_MOVE["distance"], v_max=v, a_max=DEMO_MOVE["a_max"], j_max=DEMO_MOVE["j_max"],
                          fs=fs, dwell_before=DEMO_MOVE["dwell_before"], dwell_after=DEMO_MOVE["dwell_after"])


def _log_text(res) -> str:
    from ..io.log_csv import log_to_csv_text

    if res.tripped:
        raise DesignError(f"{res.kind} with {res.summary.get('controller')}: {res.run.trip_message}")
    return log_to_csv_text(res.log)


def _figures(res, keys) -> dict:
    return {k: res.summary.get(k) for k in keys}


def machine_demo(*, seed, engine, limits, keep_raw, objective) -> DemoResult:
    """The ball-screw machine's demo as ``feedtune demo ballscrew`` runs it
    (:func:`feedtune.workflows.run_machine_demo`; ``keep_raw`` is the gantry's)."""
    return run_demo(seed=seed, engine=engine, limits=limits, objective=objective)
