"""The gantry job in one call, on the twin: measure, identify, design, test, compare (thesis chapter 4).

:func:`run_gantry_demo` follows §4.3-4.5 on :class:`~feedtune.machines.gantry.twin.GantryTwin`:

1. 2x2 FRFs at three table positions (:func:`~feedtune.machines.gantry.experiments.measure_gantry_frf`) and mass
   runs there plus an x-axis run, all under the built-in holding controllers;
2. the mass distribution and ``m_x`` (:mod:`feedtune.identify.mass`), then the gantry model of eq. 4.16 with
   the side masses imposed (:func:`~feedtune.identify.gantry.fit_gantry`; the span ``L`` is known);
3. every controller tuned for the highest first crossover under the same limits (default: textbook) on the measured
   FRFs: the x axis by loop shaping (:func:`feedtune.tune.loopshape.tune_loopshape`, on the x FRF measured at
   x = 0, with the notches and low-pass of section 4.4.1), the MIMO law of eq. 4.30
   (:func:`feedtune.tune.gantry.tune_gantry_mimo`, with the filter pack of section 4.4.2) and the independent PIDs
   (:func:`feedtune.tune.pid.tune_gantry_pid`) twice: with the MIMO design's notches and low-pass (the thesis'
   rule, and the MIMO tuner's: filters fixed, gains searched) and choosing their own filters; the gantry
   controllers on the FRFs of all three positions (each at its position: the limits on every one; tuned at x = 0
   alone, the MIMO law was unstable at x = 0.3 m), each then delivered with its certificate on every FRF it was
   tuned on (:func:`feedtune.workflows.deliver.deliver`; the FRFs from memory, identified by their arrays) and its
   figures shown at x = 0;
4. the gains files exported and read back as the runtimes run them (``GantryRuntime``/``AxisRuntime``), and
   with the three gantry controllers, on the twin with its own trip limits: the 57 N rope snap, tracking at 1 mm/s and
   200 mm/s, and circle and diamond contours (a run that trips is reported as tripped);
5. a comparison table (crossover, Ms, rope-snap peak and settling, tracking and contour errors) with the limits,
   the rules and, against each PID, the better controller per figure.

Nothing is written; :meth:`GantryDemoResult.texts` holds every file (``feedtune.workflows.ballscrew_demo.write_texts``
writes them all or none).
"""

from __future__ import annotations

from dataclasses import dataclass, field

from ..errors import DesignError

DEMO_XS = (-0.3, 0.0, 0.3)
"""Table positions of the FRF and mass runs [m]."""
AXIS_DESIGN = {"crossover_hz": 130.0, "pm_deg": 35.0, "notches": ((186.0, 0.6, 0.7), (332.0, 0.3, 0.7),
                                                                  (404.0, 0.2, 0.7)), "lpf_hz": 1200.0}
"""x-axis loop shaping of §4.4.1: crossover [Hz], phase margin [deg], notches (Hz, zeta_N, zeta_D), low-pass [Hz]."""
MIMO_DESIGN = {"crossover_hz": 60.0, "pm_deg": 40.0, "damping_increase": 5.9,
               "notches": ((110.0, 0.5, 0.7), (320.0, 0.2, 0.9), (400.0, 0.15, 1.0), (940.0, 0.6, 0.75)),
               "lpf_hz": 450.0, "lead": (154.0, 70.0)}
"""Gantry MIMO design of §4.4.2: CoM crossover [Hz], PM [deg], damping increase [-], filter pack h(s)."""
CONTROLLERS = ("mimo", "pid", "pid_own")
"""The gantry controllers compared: MIMO, independent PIDs with the MIMO design's notches and low-pass (the thesis'
rule: the same filters, the same search over the gains), independent PIDs that choose their own filters."""
LABELS = {"mimo": "MIMO", "pid": "PID (same filters)", "pid_own": "PID (own filters)"}


@dataclass(frozen=True)
class GantryDemoResult:
    """Everything the gantry demo computed.

    Attributes
    ----------
    rows : list of dict
        One per test: ``{"test", "mimo": {...}, "pid": {...}}`` with ``max_um``/``rms_um`` (tracking,
        contour), ``peak_um``/``settling_time_s`` (rope snap), or design figures (``crossover_hz``, ``ms``).
    identified : dict
        ``{"gantry": GantryFit.to_dict(), "mass": MassFit.to_dict(), "m_x": float}``.
    designs : dict
        Per controller (``mimo``, ``pid``, ``axis``): design figures on the measured FRF.
    texts : dict
        File name -> text (CSV logs and FRFs, model, mass and gains TOML/JSON, summary JSON).
    twin : dict
        The twin's parameters.
    """

    rows: list
    identified: dict
    designs: dict
    texts: dict = field(repr=False)
    twin: dict = field(repr=False, default_factory=dict)
    limits: dict = field(default_factory=dict)

    def to_dict(self) -> dict:
        """JSON-ready: limits, comparison rows (with the better controller per figure), identification, designs
        with their rules, twin parameters, file names."""
        return {"limits": self.limits, "comparison": self.rows, "identified": self.identified,
                "designs": self.designs, "twin": self.twin, "files": sorted(self.texts),
                "units": {"max_um": "um", "rms_um": "um", "peak_um": "um", "settling_time_s": "s",
                          "crossover_hz": "Hz", "ms": "-"}}

    def summary(self) -> str:
        """What the demo prints: the comparison (:meth:`table`)."""
        return self.table()

    def table(self) -> str:
        """The comparison as text: the limits and rules, the three controllers and the verdict against each PID."""
        from ..analysis.comparison import verdict_line

        objectives = sorted({d["objective"] for d in self.designs.values() if d.get("objective")})
        lines = [f"Limits: {self.limits.get('profile')}; every controller tuned for the {' / '.join(objectives) or '-'}"
                 " objective under them (discrete case): the gantry ones on the FRFs of every table position "
                 "measured, the x axis on its FRF; figures at x = 0:"]
        for name in (*CONTROLLERS, "axis"):
            d = self.designs.get(name)
            if d:
                xo = "-" if d.get("crossover_hz") is None else f"{d['crossover_hz']:.4g} Hz"
                g = d.get("integral_gain")
                gain = "" if not g else f", {g['name']} {g['value']:.4g} {g['unit']}"
                lines.append(f"  {d['label']}: first crossover {xo}{gain}, Ms {d['ms']:.3g}; {d['rule']}"
                             + (f"; filters chosen: {d['filters']}" if d.get("filters") else ""))
                lines += [f"    warning: {w}" for w in d.get("warnings") or []]
        head = f"{'test':34s}" + "".join(f" {LABELS[c]:>19s}" for c in CONTROLLERS)
        lines += ["", "Gantry: MIMO (eq. 4.30) against independent PIDs on the twin", head]
        for row in self.rows:
            for key, label, unit in (("crossover_hz", "CoM crossover", "Hz"), ("ms", "Ms = max sigma_max(S)", ""),
                                     ("peak_um", "peak", "um"), ("settling_time_s", "5 % settling", "s"),
                                     ("max_um", "max", "um"), ("rms_um", "RMS", "um")):
                if not any(key in row[c] for c in CONTROLLERS):
                    continue
                name = f"{row['test']} {label}".strip()
                lines.append(f"{name:34s}" + "".join(f" {_cell(row[c].get(key), unit, row[c]):>19s}"
                                                      for c in CONTROLLERS))
        tests = [r for r in self.rows if not r["test"].startswith("design")]
        lines += [""] + [verdict_line(tests, ("mimo", "MIMO"), (c, LABELS[c])) for c in CONTROLLERS[1:]]
        return "\n".join(lines)


def _cell(v, unit: str, figures: dict | None = None) -> str:
    if figures is not None and figures.get("tripped"):
        return "tripped"
    if v is None:
        return "not settled" if unit == "s" else "-"
    return f"{v:.4g} {unit}".strip()


# ------------------------------------------------------------------------------------------ steps
def _texts_of(result, name: str, log: bool = True, allow_trip: bool = False) -> dict:
    from ..io.frf_csv import frf_to_csv_text
    from ..io.log_csv import log_to_csv_text

    if result.tripped and not allow_trip:
        raise DesignError(f"{result.kind} run ({name}): {result.run.trip_message}")
    out = {f"{name}.csv": log_to_csv_text(result.log)} if log else {}
    if result.frf is not None:
        out[f"{name}_frf.csv"] = frf_to_csv_text(result.frf)
    return out


def _measure(twin, xs, seed, engine, texts, keep_raw):
    from ..machines.gantry.experiments import measure_axis_frf, measure_gantry_frf, run_axis_mass, run_mass

    frfs = []
    for x in xs:
        res = measure_gantry_frf(twin, x, seed=seed, engine=engine)
        texts.update(_texts_of(res, f"frf_x{x:g}", log=keep_raw))
        frfs.append(res.frf)
    mass_logs = []
    for x in xs:
        res = run_mass(twin, x, seed=seed, engine=engine)
        texts.update(_texts_of(res, f"mass_x{x:g}", log=keep_raw))
        mass_logs.append(res.log)
    res = run_axis_mass(twin, x_start=min(xs), seed=seed, engine=engine)
    texts.update(_texts_of(res, "mass_axis", log=keep_raw))
    axis = measure_axis_frf(twin, 0.0, seed=seed, engine=engine)
    texts.update(_texts_of(axis, "frf_axis", log=keep_raw))
    return frfs, mass_logs, res.log, axis.frf


def _identify(twin, xs, frfs, mass_logs, axis_log, texts):
    from ..identify.gantry import fit_gantry
    from ..identify.mass import fit_axis_mass, fit_mass_distribution
    from ..io import dumps_json, dumps_toml, model_document
    from ..io.mass_file import mass_document

    mass = fit_mass_distribution(mass_logs, xs, acc_ref="ay_ref")
    m_x = fit_axis_mass(axis_log, u="ux", acc_ref="a_ref")
    fit = fit_gantry(frfs, xs, L=twin.model.L, mass_distribution=mass, m_x=m_x)
    mdoc = mass_document(mass, m_x)
    texts["mass.toml"], texts["mass.json"] = dumps_toml(mdoc), dumps_json(mdoc)
    doc = model_document(fit.model, fit=fit.to_dict())
    texts["model.toml"], texts["model.json"] = dumps_toml(doc), dumps_json(doc)
    return fit, mass, m_x


def _filters(spec: dict):
    from ..control.filters import FilterPack, LeadStage, Notch

    leads = [LeadStage(*spec["lead"])] if spec.get("lead") else []
    order = 2 if spec.get("lead") else 1
    return FilterPack([Notch(*n) for n in spec["notches"]], spec["lpf_hz"], order, 0.7, leads)


def _figures(label: str, design, check, checked: str, analysis: dict) -> dict:
    """What the demo prints and stores of a design: its rule and the checked case's figures."""
    c = analysis[checked]
    tuning = design.tuning if hasattr(design, "tuning") else design.extra.get("tuning", {})
    filters = (tuning.get("filters") or {}).get("chosen") if isinstance(tuning.get("filters"), dict) else None
    return {"label": label, "case": f"{checked} (measured FRF at x = 0, discrete controller, ZOH, delay)",
            "crossover_hz": c["crossovers_hz"][0] if c["crossovers_hz"] else None, "ms": c["ms"],
            "ms_freq_hz": c["ms_freq_hz"], "phase_margin_deg": c["phase_margin_deg"],
            "gain_margin_db": c["gain_margin_db"], "rule": tuning.get("rule", tuning.get("method", "given")),
            "active_limit": (tuning.get("active_limit") or {}).get("name")
            if isinstance(tuning.get("active_limit"), dict) else tuning.get("active_limit"),
            "filters": None if filters is None else (", ".join(str(f) for f in filters) or "none"),
            "check_ok": check.ok, "stable_model": analysis["ideal_discrete"]["stable"],
            "stable_measured": analysis[checked]["stable"], "objective": tuning.get("objective"),
            "integral_gain": tuning.get("integral_gain"), "warnings": list(tuning.get("warnings", []))}


TUNING_COST = {"mimo": 0.7, "pid": 0.55, "pid_own": 0.7, "axis": 2.3}
"""Time of each tuner on the twin [s] (measured on a 2-core machine; what matters is their ratios, by which they are
shared out over the cores: on two, the x axis against the three others)."""


def _tune(twin, fit, frfs, axis_frf, policy, objective=None) -> dict:
    """The four tuners under ``policy``: MIMO and both PIDs on the identified model and every 2x2 FRF (``frfs``,
    each at its recorded position), the x axis on its FRF. They are independent: they run side by side on the
    machine's cores (:mod:`feedtune.parallel`; the results are those of running them one by one)."""
    from ..parallel import plan, run_groups
    from ..tune.gantry import tune_gantry_mimo
    from ..tune.loopshape import tune_loopshape
    from ..tune.pid import tune_gantry_pid

    p = twin.params
    model = fit.model
    common = {"limits": policy, "fs": p.fs, "delay_samples": p.delay_samples, "objective": objective}
    h = _filters(MIMO_DESIGN)
    pid_identical_filters = type(h)(h.notches, h.lpf_hz, h.lpf_order, h.lpf_zeta, ())  # the thesis' rule
    jobs = {
        "mimo": lambda: tune_gantry_mimo(model, filters=h, frf=frfs, **common),
        "pid": lambda: tune_gantry_pid(model, filters=pid_identical_filters, filter_choice="identical", frf=frfs,
                                       **common),
        "pid_own": lambda: tune_gantry_pid(model, filter_choice="own", frf=frfs, **common),
        "axis": lambda: tune_loopshape(axis_frf, filters=_filters(AXIS_DESIGN), **common),
    }
    return run_groups(plan([(name, fn, TUNING_COST[name]) for name, fn in jobs.items()]))


def _design(twin, fit, frfs, xs, axis_frf, texts, policy, objective=None):
    """Axis, MIMO and PID designs tuned under ``policy`` for ``objective`` (:func:`_tune`), each delivered with its
    certificate on every FRF it was tuned on (:func:`feedtune.workflows.deliver.deliver`; the gantry ones at every
    table position, the x axis on its FRF; DesignError when a tuned design fails it), exported and read back as
    runtimes; the figures shown are those at x = 0."""
    from ..io.document import loads_document
    from ..machines import load_runtime
    from ..machines.certificate import FrfSource
    from .deliver import deliver

    tuned = _tune(twin, fit, frfs, axis_frf, policy, objective)
    sources = [FrfSource.from_memory(f"frf_x{x:g}_frf.csv", f) for x, f in zip(xs, frfs, strict=True)]
    at0 = sources[list(xs).index(0.0)].name
    designs, runtimes = {}, {}
    for name, label, on in [*((n, LABELS[n], sources) for n in CONTROLLERS),
                            ("axis", "x axis (loop shaping)", [FrfSource.from_memory("frf_axis_frf.csv", axis_frf)])]:
        delivery = deliver(tuned[name], on, policy, where=f"{name}_gains.toml")
        if not delivery.ok:
            raise DesignError(f"the tuned {label} design fails its certificate: {'; '.join(delivery.violations())}")
        checked = next((c for c in delivery.certificate.frfs if c.name == at0), delivery.certificate.frfs[0])
        designs[name] = _figures(label, tuned[name], checked.check, checked.checked_case, checked.result["analysis"])
        texts.update(delivery.texts(f"{name}_gains"))
        runtimes[name] = load_runtime(loads_document(texts[f"{name}_gains.toml"], "toml", f"{name}_gains.toml"),
                                      f"{name}_gains.toml")
    return designs, runtimes


ERROR_FIGURES = {"max_um": lambda s: s["max_um"], "rms_um": lambda s: s["rms_um"]}


def _run_figures(res, figures: dict) -> dict:
    """The run's figures, or ``{"tripped": message}`` (figures None) when the twin's safety limits stopped it."""
    if res.tripped:
        return {**{k: None for k in figures}, "tripped": res.run.trip_message}
    return {k: get(res.summary) for k, get in figures.items()}


TEST_COST = {"ropesnap": 0.2, "track_1mm_s": 1.0, "track_200mm_s": 0.3, "contour_circle": 1.1, "contour_diamond": 1.6}
"""Relative time of each twin test (simulation and log text), by which the tests are shared out over the cores."""


def _tests(twin, runtimes, seed, engine, tracking, contour_feature, shapes, texts) -> list:
    """Rope snap, tracking and contour runs of every controller; each run's log text into ``texts``. The runs are
    independent (each seeded with ``seed``, the runtimes reset at its start): they run side by side on the
    machine's cores (:mod:`feedtune.parallel`), and the rows and texts are those of running them one by one."""
    from ..machines.gantry.experiments import run_contour, run_gantry_ropesnap, run_gantry_tracking, tracking_trajectory
    from ..parallel import plan, run_groups
    from ..sim.contour import thesis_path

    axis = runtimes["axis"]
    peak = {"peak_um": lambda s: abs(s["peak_um"]), "settling_time_s": lambda s: s["settling_time_s"]}
    tests = [("rope snap 57 N", "ropesnap", "ropesnap", peak,
              lambda name: run_gantry_ropesnap(twin, runtimes[name], axis, seed=seed, engine=engine))]
    for test in tracking:
        tr = tracking_trajectory(test, twin.fs)
        tests.append((f"track {test.replace('_', '/')}", f"track_{test}", f"track_{test}", ERROR_FIGURES,
                      lambda name, tr=tr: run_gantry_tracking(twin, runtimes[name], tr, axis, seed=seed,
                                                              engine=engine)))
    for shape in shapes:
        path = thesis_path(shape, contour_feature, fs=twin.fs, start=(0.1 if contour_feature == "200mm" else 0.0,
                                                                       0.0))
        tests.append((f"{shape} {contour_feature}", f"contour_{shape}", f"contour_{shape}_{contour_feature}",
                      ERROR_FIGURES,
                      lambda name, path=path: run_contour(twin, runtimes[name], axis, path, seed=seed, engine=engine)))

    def job(k: int, name: str):
        _, _, prefix, figures, run = tests[k]
        res = run(name)
        return _texts_of(res, f"{prefix}_{name}", allow_trip=True), _run_figures(res, figures)

    jobs = [(f"{k}:{name}", (lambda k=k, name=name: job(k, name)), TEST_COST.get(tests[k][1], 1.0))
            for k in range(len(tests)) for name in CONTROLLERS]
    done = run_groups(plan(jobs))
    rows = []
    for k, (label, *_rest) in enumerate(tests):
        row = {"test": label}
        for name in CONTROLLERS:
            run_texts, row[name] = done[f"{k}:{name}"]
            texts.update(run_texts)
        rows.append(row)
    return rows


def run_gantry_demo(seed: int = 0, *, params=None, engine: str = "auto", xs=DEMO_XS,
                    tracking=("1mm_s", "200mm_s"), contour_feature: str = "200mm",
                    shapes=("circle", "diamond"), keep_raw: bool = False, limits=None,
                    objective=None) -> GantryDemoResult:
    """Run the gantry job on the twin (see the module docstring); nothing is written.

    Parameters
    ----------
    seed : int
        Seed of the multisine phases and of the noise.
    params : GantryTwinParams, optional
        The twin (default: the thesis's gantry with every unmodelled effect and its own trip limits).
    engine : str
        Plant step engine (auto, numba, python).
    xs : sequence of float
        Table positions of the FRF and mass runs [m] (at least 3; 0 must be among them: the designs are
        checked on the FRF measured there).
    tracking : sequence of str
        Tracking tests of :data:`~feedtune.machines.gantry.experiments.THESIS_TRACKING`.
    contour_feature : str
        ``"1um"``, ``"1mm"`` or ``"200mm"`` (:data:`~feedtune.sim.contour.THESIS_FEATURES`).
    shapes : sequence of str
        Contours run (circle, diamond).
    keep_raw : bool
        Also keep the excitation logs of the FRF measurements and the mass runs (about 9 MB each as CSV);
        by default only the FRF files, the mass and model files and the closed-loop test logs are kept.
    limits : Limits, optional
        The limits every controller is tuned under (default: textbook).
    objective : str or Objective, optional
        What every tuner maximises (:class:`feedtune.tune.search.Objective`, default ``stiffness``).

    Returns
    -------
    GantryDemoResult

    Raises
    ------
    DesignError
        No design meets the limits on the measured FRFs, or an identification run tripped.
    """
    from ..analysis.comparison import better_per_figure
    from ..analysis.limits import DEFAULT_LIMITS
    from ..errors import UsageError
    from ..io import dumps_json
    from ..machines.gantry.twin import GantryTwin
    from .files import plain_json

    xs = [float(x) for x in xs]
    if 0.0 not in xs or len(set(xs)) < 3:
        raise UsageError(f"the demo needs >= 3 distinct table positions including 0, got {xs}")
    policy = limits or DEFAULT_LIMITS
    from ..tune.gantry_cases import gantry_objective

    objective = gantry_objective(objective)  # refused before the twin runs
    twin = GantryTwin(params)
    texts: dict = {}
    from .. import progress

    progress.step(f"measuring 2x2 FRFs and mass runs at {len(xs)} table positions")
    frfs, mass_logs, axis_log, axis_frf = _measure(twin, xs, seed, engine, texts, keep_raw)
    progress.step("identifying the gantry model (eq. 4.16) and the mass distribution")
    fit, mass, m_x = _identify(twin, xs, frfs, mass_logs, axis_log, texts)
    progress.step("tuning x-axis loop shaping, MIMO and PIDs under the same limits")
    designs, runtimes = _design(twin, fit, frfs, xs, axis_frf, texts, policy, objective)
    rows = [{"test": "design:", **{c: {k: designs[c][k] for k in ("crossover_hz", "ms")} for c in CONTROLLERS}}]
    progress.step("rope snap, tracking and contours on the twin")
    rows += _tests(twin, runtimes, seed, engine, tracking, contour_feature, shapes, texts)
    for row in rows[1:]:
        row["better"] = {c: {k: w for _, k, w in better_per_figure([row], "mimo", c)} for c in CONTROLLERS[1:]}
    identified = {"gantry": fit.to_dict(), "mass": mass.to_dict(), "m_x": m_x,
                  "true": {**twin.model.params()}}
    result = GantryDemoResult(rows, identified, designs, texts, twin.params.to_dict(), policy.to_dict())
    texts["summary.json"] = dumps_json(plain_json({k: v for k, v in result.to_dict().items() if k != "files"}))
    return result


def identified_errors(result: GantryDemoResult) -> dict[str, float]:
    """Relative errors [-] of the identified ``m, J0, d, m_x, c, k`` against the twin's true values."""
    got = result.identified["gantry"]["model"]
    true = result.identified["true"]
    return {k: float(got[k] / true[k] - 1.0) for k in ("m", "J0", "d", "m_x", "c", "k") if true[k]}


def machine_demo(*, seed, engine, limits, keep_raw, objective) -> GantryDemoResult:
    """The gantry machine's demo as ``feedtune demo gantry`` runs it (:func:`feedtune.workflows.run_machine_demo`)."""
    return run_gantry_demo(seed=seed, engine=engine, keep_raw=keep_raw, limits=limits, objective=objective)


__all__ = ["DEMO_XS", "GantryDemoResult", "identified_errors", "machine_demo", "run_gantry_demo"]
