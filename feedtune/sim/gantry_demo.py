"""The gantry job in one call, on the twin: measure, identify, design, test, compare (thesis chapter 4).

:func:`run_gantry_demo` follows §4.3-4.5 on :class:`~feedtune.sim.gantry_twin.GantryTwin`:

1. 2x2 FRFs at three table positions (:func:`~feedtune.sim.gantry_experiments.measure_gantry_frf`) and mass
   runs there plus an x-axis run, all under the built-in holding controllers;
2. the mass distribution and ``m_x`` (:mod:`feedtune.identify.mass`), then the gantry model of eq. 4.16 with
   the side masses imposed (:func:`~feedtune.identify.gantry.fit_gantry`; the span ``L`` is known);
3. the x axis by loop shaping (130 Hz, 35 deg, the notches and low-pass of §4.4.1), the MIMO law of eq. 4.30
   (60 Hz, 40 deg, +590 % damping, the filter pack of §4.4.2) and independent PIDs tuned to the MIMO design's
   peak sensitivity on the measured FRF, each checked on the measured FRF (DesignError when unstable);
4. the gains files exported and read back as the runtimes run them (``GantryRuntime``/``AxisRuntime``), and
   with both gantry controllers: the 57 N rope snap, tracking at 1 mm/s and 200 mm/s, and circle and diamond
   contours;
5. a comparison table (crossover, Ms, rope-snap peak and settling, tracking and contour errors).

Nothing is written; :meth:`GantryDemoResult.texts` holds every file (``feedtune.sim.demo.write_texts``
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
DEMO_ENVELOPE_M = 5e-3
"""Following-error envelope of the demo's twin [m]: the PID baseline tuned to the MIMO design's Ms is soft
(about 4 Hz), and the 57 N rope snap moves it by about 1 mm, more than the twin's default 0.5 mm trip."""
CONTROLLERS = ("mimo", "pid")
LABELS = {"mimo": "MIMO", "pid": "PID"}


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

    def to_dict(self) -> dict:
        """JSON-ready: comparison rows, identification, designs, twin parameters, file names."""
        return {"comparison": self.rows, "identified": self.identified, "designs": self.designs, "twin": self.twin,
                "files": sorted(self.texts),
                "units": {"max_um": "um", "rms_um": "um", "peak_um": "um", "settling_time_s": "s",
                          "crossover_hz": "Hz", "ms": "-"}}

    def table(self) -> str:
        """The comparison as text: MIMO against independent PIDs, and the improvement."""
        head = f"{'test':34s} {'MIMO':>14s} {'PID':>14s} {'change':>8s}"
        lines = ["Gantry: MIMO (eq. 4.30) against independent PIDs on the twin (design figures on the FRF "
                 "measured at x = 0)", head]
        for row in self.rows:
            a, b = row["mimo"], row["pid"]
            for key, label, unit in (("crossover_hz", "CoM crossover", "Hz"), ("ms", "Ms = max sigma_max(S)", ""),
                                     ("peak_um", "peak", "um"), ("settling_time_s", "5 % settling", "s"),
                                     ("max_um", "max", "um"), ("rms_um", "RMS", "um")):
                if key not in a:
                    continue
                name = f"{row['test']} {label}".strip()
                lines.append(f"{name:34s} {_cell(a[key], unit):>14s} {_cell(b[key], unit):>14s} "
                             f"{_change(a[key], b[key]):>8s}")
        return "\n".join(lines)


def _cell(v, unit: str) -> str:
    if v is None:
        return "not settled" if unit == "s" else "-"
    return f"{v:.4g} {unit}".strip()


def _change(a, b) -> str:
    if a is None or b is None or not b:
        return ""
    return f"{100.0 * (a / b - 1.0):+.0f} %"


# ------------------------------------------------------------------------------------------ steps
def _texts_of(result, name: str, log: bool = True) -> dict:
    from ..io.frf_csv import frf_to_csv_text
    from ..io.log_csv import log_to_csv_text

    if result.tripped:
        raise DesignError(f"{result.kind} run ({name}): {result.run.trip_message}")
    out = {f"{name}.csv": log_to_csv_text(result.log)} if log else {}
    if result.frf is not None:
        out[f"{name}_frf.csv"] = frf_to_csv_text(result.frf)
    return out


def _measure(twin, xs, seed, engine, texts, keep_raw):
    from .gantry_experiments import measure_gantry_frf, run_axis_mass, run_mass

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
    return frfs, mass_logs, res.log


def _identify(twin, xs, frfs, mass_logs, axis_log, texts):
    from ..identify.gantry import fit_gantry
    from ..identify.mass import fit_axis_mass, fit_mass_distribution
    from ..io import dumps_json, dumps_toml, model_document
    from .gantry_experiments import mass_document

    mass = fit_mass_distribution(mass_logs, xs, acc_ref="ay_ref")
    m_x = fit_axis_mass(axis_log, u="ux", acc_ref="a_ref")
    fit = fit_gantry(frfs, xs, L=twin.model.L, mass_distribution=mass, m_x=m_x)
    mdoc = mass_document(mass, m_x)
    texts["mass.toml"], texts["mass.json"] = dumps_toml(mdoc), dumps_json(mdoc)
    doc = model_document(fit.model, fit=fit.to_dict())
    texts["model.toml"], texts["model.json"] = dumps_toml(doc), dumps_json(doc)
    return fit, mass, m_x


def _filters(spec: dict):
    from ..design.filters import Notch
    from ..design.loopshape import LeadStage, LoopFilters

    leads = [LeadStage(*spec["lead"])] if spec.get("lead") else []
    order = 2 if spec.get("lead") else 1
    return LoopFilters([Notch(*n) for n in spec["notches"]], spec["lpf_hz"], order, 0.7, leads)


def _figures(analysis: dict) -> dict:
    """Design figures: the measured-FRF (discrete) case, and the Nyquist verdicts of both checked cases."""
    c = analysis["discrete"]
    return {"case": "discrete (measured FRF at x = 0, discrete controller, ZOH, delay)",
            "crossover_hz": c["crossovers_hz"][0] if c["crossovers_hz"] else None, "ms": c["ms"],
            "ms_freq_hz": c["ms_freq_hz"], "phase_margin_deg": c["phase_margin_deg"],
            "stable_model": analysis["ideal_discrete"]["stable"], "stable_measured": c["stable"]}


def _design(twin, fit, m_x, frf0, texts):
    """Axis, MIMO and PID designs on the identified model; figures on the measured FRF at x = 0; runtimes.

    The PIDs are tuned on the measured FRF to the MIMO design's peak sensitivity there (discrete case). A design
    that is unstable in any analysed case raises DesignError (the measured-FRF Nyquist count continues the
    loop below the FRF's band with the model, so it does not depend on the lowest measured line).
    """
    from ..analysis.gantry import analyze_gantry
    from ..analysis.limits import Limits, check_cases
    from ..design.gantry_gains import axis_gains_document, gantry_gains_document
    from ..design.gantry_mimo import design_gantry_mimo
    from ..design.loopshape import design_loopshape
    from ..io import dumps_json, dumps_toml
    from ..io.document import loads_document
    from ..tune.pid import tune_gantry_pid
    from .gantry_runtime import load_runtime

    p = twin.params
    model = fit.model
    axis = design_loopshape(m_x, crossover_hz=AXIS_DESIGN["crossover_hz"], pm_deg=AXIS_DESIGN["pm_deg"],
                            filters=_filters(AXIS_DESIGN), fs=p.fs, delay_samples=p.delay_samples)
    h = _filters(MIMO_DESIGN)
    mimo = design_gantry_mimo(model, crossover_hz=MIMO_DESIGN["crossover_hz"], pm_deg=MIMO_DESIGN["pm_deg"],
                              damping_increase=MIMO_DESIGN["damping_increase"], filters=h, fs=p.fs,
                              delay_samples=p.delay_samples)
    an_mimo = analyze_gantry(mimo.law, model, frf=frf0).to_dict()
    pid_filters = type(h)(h.notches, h.lpf_hz, h.lpf_order, h.lpf_zeta, ())  # the same notches and low-pass
    stability_only = Limits(None, None, None, None, "stability only")
    pid = tune_gantry_pid(model, limits=stability_only, ms_max=an_mimo["discrete"]["ms"], filters=pid_filters,
                          fs=p.fs, delay_samples=p.delay_samples, frf=frf0)
    an_pid = analyze_gantry(pid.law, model, frf=frf0).to_dict()
    designs, runtimes = {}, {}
    for name, design, an in (("mimo", mimo, an_mimo), ("pid", pid, an_pid)):
        full = analyze_gantry(design.law, model, frf=frf0)
        violations = check_cases(stability_only, {k: None if c is None else c.metrics for k, c in full.cases.items()},
                                 ["discrete"]).violations
        if violations:
            raise DesignError(f"the {LABELS[name]} design on the identified model: {'; '.join(violations)}")
        doc = gantry_gains_document(design, an)
        texts[f"{name}_gains.toml"], texts[f"{name}_gains.json"] = dumps_toml(doc), dumps_json(doc)
        runtimes[name] = load_runtime(loads_document(texts[f"{name}_gains.toml"], "toml", f"{name}_gains.toml"),
                                       f"{name}_gains.toml")
        designs[name] = _figures(an)
    doc = axis_gains_document(axis)
    texts["axis_gains.toml"], texts["axis_gains.json"] = dumps_toml(doc), dumps_json(doc)
    runtimes["axis"] = load_runtime(loads_document(texts["axis_gains.toml"], "toml", "axis_gains.toml"),
                                    "axis_gains.toml")
    designs["axis"] = {"crossover_hz": AXIS_DESIGN["crossover_hz"], "pm_deg": AXIS_DESIGN["pm_deg"], "m_x": m_x}
    return designs, runtimes


def _tests(twin, runtimes, seed, engine, tracking, contour_feature, shapes, texts) -> list:
    from .contour import thesis_path
    from .gantry_experiments import run_contour, run_gantry_ropesnap, run_gantry_tracking, tracking_trajectory

    axis = runtimes["axis"]
    rows = []
    row = {"test": "rope snap 57 N"}
    for name in CONTROLLERS:
        res = run_gantry_ropesnap(twin, runtimes[name], axis, seed=seed, engine=engine)
        texts.update(_texts_of(res, f"ropesnap_{name}"))
        row[name] = {"peak_um": abs(res.summary["peak_um"]), "settling_time_s": res.summary["settling_time_s"]}
    rows.append(row)
    for test in tracking:
        tr = tracking_trajectory(test, twin.fs)
        row = {"test": f"track {test.replace('_', '/')}"}
        for name in CONTROLLERS:
            res = run_gantry_tracking(twin, runtimes[name], tr, axis, seed=seed, engine=engine)
            texts.update(_texts_of(res, f"track_{test}_{name}"))
            row[name] = {"max_um": res.summary["max_um"], "rms_um": res.summary["rms_um"]}
        rows.append(row)
    for shape in shapes:
        path = thesis_path(shape, contour_feature, fs=twin.fs, start=(0.1 if contour_feature == "200mm" else 0.0,
                                                                       0.0))
        row = {"test": f"{shape} {contour_feature}"}
        for name in CONTROLLERS:
            res = run_contour(twin, runtimes[name], axis, path, seed=seed, engine=engine)
            texts.update(_texts_of(res, f"contour_{shape}_{contour_feature}_{name}"))
            row[name] = {"max_um": res.summary["max_um"], "rms_um": res.summary["rms_um"]}
        rows.append(row)
    return rows


def run_gantry_demo(seed: int = 0, *, params=None, engine: str = "auto", xs=DEMO_XS,
                    tracking=("1mm_s", "200mm_s"), contour_feature: str = "200mm",
                    shapes=("circle", "diamond"), keep_raw: bool = False) -> GantryDemoResult:
    """Run the gantry job on the twin (see the module docstring); nothing is written.

    Parameters
    ----------
    seed : int
        Seed of the multisine phases and of the noise.
    params : GantryTwinParams, optional
        The twin (default: the thesis's gantry with every unmodelled effect, and a following-error envelope of
        :data:`DEMO_ENVELOPE_M`).
    engine : str
        Plant step engine (auto, numba, python).
    xs : sequence of float
        Table positions of the FRF and mass runs [m] (at least 3; 0 must be among them: the designs are
        checked on the FRF measured there).
    tracking : sequence of str
        Tracking tests of :data:`~feedtune.sim.gantry_experiments.THESIS_TRACKING`.
    contour_feature : str
        ``"1um"``, ``"1mm"`` or ``"200mm"`` (:data:`~feedtune.sim.contour.THESIS_FEATURES`).
    shapes : sequence of str
        Contours run (circle, diamond).
    keep_raw : bool
        Also keep the excitation logs of the FRF measurements and the mass runs (about 9 MB each as CSV);
        by default only the FRF files, the mass and model files and the closed-loop test logs are kept.

    Returns
    -------
    GantryDemoResult

    Raises
    ------
    DesignError
        A design is unstable on the measured FRF, or a test run tripped.
    """
    from ..errors import UsageError
    from ..io import dumps_json
    from .demo import _plain
    from .gantry_twin import GantryTwin

    xs = [float(x) for x in xs]
    if 0.0 not in xs or len(set(xs)) < 3:
        raise UsageError(f"the demo needs >= 3 distinct table positions including 0, got {xs}")
    if params is None:
        from dataclasses import replace

        from .gantry_twin import GantryTwinParams

        params = replace(GantryTwinParams(), envelope_m=DEMO_ENVELOPE_M)
    twin = GantryTwin(params)
    texts: dict = {}
    frfs, mass_logs, axis_log = _measure(twin, xs, seed, engine, texts, keep_raw)
    fit, mass, m_x = _identify(twin, xs, frfs, mass_logs, axis_log, texts)
    designs, runtimes = _design(twin, fit, m_x, frfs[xs.index(0.0)], texts)
    rows = [{"test": "design:",
             "mimo": {k: designs["mimo"][k] for k in ("crossover_hz", "ms")},
             "pid": {k: designs["pid"][k] for k in ("crossover_hz", "ms")}}]
    rows += _tests(twin, runtimes, seed, engine, tracking, contour_feature, shapes, texts)
    identified = {"gantry": fit.to_dict(), "mass": mass.to_dict(), "m_x": m_x,
                  "true": {**twin.model.params()}}
    result = GantryDemoResult(rows, identified, designs, texts, twin.params.to_dict())
    texts["summary.json"] = dumps_json(_plain({k: v for k, v in result.to_dict().items() if k != "files"}))
    return result


def identified_errors(result: GantryDemoResult) -> dict[str, float]:
    """Relative errors [-] of the identified ``m, J0, d, m_x, c, k`` against the twin's true values."""
    got = result.identified["gantry"]["model"]
    true = result.identified["true"]
    return {k: float(got[k] / true[k] - 1.0) for k in ("m", "J0", "d", "m_x", "c", "k") if true[k]}


__all__ = ["DEMO_XS", "GantryDemoResult", "identified_errors", "run_gantry_demo"]
