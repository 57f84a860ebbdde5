"""``feedtune design gantry|pid`` and ``feedtune tune gantry|pid``: the gantry of thesis chapter 4.

* ``gantry``: the MIMO law of eq. 4.30 (sensor/actuator averaging, lead, active damping, actuator-level
  integral) with feedforward and pre-filters scheduled in the table position.
* ``gantry`` and ``pid`` take ``--friction F.toml [--friction-band V]``: the Stribeck friction feedforward of the
  gantry's travel (command unit, m/s), split ``alpha1 : alpha2`` between the drives like the inertia feedforward.
* ``pid``: the independent-PID baseline tuned for the highest crossover under the limits
  (:func:`feedtune.tune.pid.tune_gantry_pid`), with ``--match`` to the Ms of a MIMO gains file and its filters;
  ``--filters own|identical`` says whether the tuner may choose its own notches and low-pass.

The commands are registered on the ``design`` group in :mod:`feedtune.cli.main`; :func:`tune_gantry` is ``feedtune
tune gantry|pid`` (the registry of structures names it). The loop-shaping filter options and the delivery of a
design are shared with ``design loopshape`` (:mod:`feedtune.cli.design_loopshape_cmd`).
"""

from __future__ import annotations

from pathlib import Path

import typer

from ..structures import controller
from .common import FORCE_OPTION, JSON_OPTION
from .design_cmd import (
    ALLOW_OPTION,
    DELAY_OPTION,
    FRICTION_BAND_OPTION,
    FRICTION_OPTION,
    NOTCH_OPTION,
    OUT_OPTION,
    QUANTITY_OPTION,
)
from .envelope import cli_text
from .frf_options import (
    FRF_CHANNEL_OPTION,
    FRF_INPUT_UNIT_OPTION,
    FRF_MAP_OPTION,
    FRF_SCALE_OPTION,
    FRF_SKIP_ROWS_OPTION,
)
from .help_text import FILTER_CHOICES, LPF_ORDERS, choice
from .limits_options import (
    DM_MIN_OPTION,
    GM_LOW_MIN_OPTION,
    GM_MIN_OPTION,
    LIMITS_OPTION,
    MS_MAX_OPTION,
    PM_MIN_OPTION,
    limits_from_options,
)
from .progress_display import QUIET_OPTION, show_progress
from .sampling_options import FS_OVERRIDE_OPTION, fs_option, target_sampling

DEFAULT_FS = controller("mimo").default_fs_hz
"""Sample rate [Hz] of ``design gantry|pid`` without ``--fs`` and without a rate recorded in an FRF (the
registry's)."""
FS_OPTION = fs_option(f"{DEFAULT_FS:g} Hz")
LPF_OPTION = typer.Option(None, "--lpf", metavar="HZ", help="Low-pass frequency [Hz] of the filter pack.")
LEAD_OPTION = typer.Option(
    None, "--lead", metavar="HZ,DEG",
    help="Extra lead stage HZ,DEG in the filter pack (repeatable), e.g. --lead 154,70.",
)
LPF_ZETA_OPTION = typer.Option(0.7, "--lpf-zeta", metavar="ZETA", help="Damping of a 2nd-order low-pass [-].")
PREFILTER_HZ_OPTION = typer.Option(
    80.0, "--prefilter-hz", metavar="HZ",
    help="Pre-filter low-pass frequency [Hz] (eq. 4.20).",
)
X_OPTION = typer.Option(0.0, "--design-x", metavar="M", help="Table position [m] the design is made at (averaging, "
                                                              "damping gain, the PIDs' mass scaling).")
X_MIN_OPTION = typer.Option(-0.3, "--x-min", metavar="M", help="First table position [m] of the schedule tables.")
X_MAX_OPTION = typer.Option(0.3, "--x-max", metavar="M", help="Last table position [m] of the schedule tables.")
X_POINTS_OPTION = typer.Option(13, "--x-points", metavar="N", help="Number of rows of the schedule tables.")
PRE1_OPTION = typer.Option(
    None, "--prefilter1", metavar="VEL,ACC,JERK,SNAP",
    help="Left-side pre-filter gains VEL,ACC,JERK,SNAP [s, s^2, s^3, s^4] (eq. 4.32).",
)
PRE2_OPTION = typer.Option(
    None, "--prefilter2", metavar="VEL,ACC,JERK,SNAP",
    help="Right-side pre-filter gains VEL,ACC,JERK,SNAP.",
)
GANTRY_FRF_OPTION = typer.Option(
    None, "--frf", metavar="FRF",
    help="Measured 2x2 position FRF (y1/u1, y1/u2, y2/u1, y2/u2) for the measured and discrete cases.",
)

# ------------------------------------------------------------------------------------------ helpers
def _loop_filters(notch, lpf, lpf_order, lpf_zeta, lead):
    from ..control.filters import FilterPack, LeadStage, Notch

    return FilterPack([Notch.parse(n) for n in notch or []], lpf, lpf_order, lpf_zeta,
                       [LeadStage.parse(s) for s in lead or []])


def _gantry_model(path: Path):
    """The gantry model of a model file; DataError (a file of the wrong kind, exit 1) otherwise."""
    from ..io import load_model

    return load_model(path, plants=("gantry",))


def _x_grid(model, x_min: float, x_max: float, x_points: int):
    from ..design.gantry_mimo import default_x_grid

    return default_x_grid(model, x_min, x_max, x_points)


def _gantry_friction_model(friction: Path | None, friction_band: float | None, model, model_file: Path):
    """The friction model of ``--friction`` (None without), its units checked against the gantry model's before
    designing: UsageError for ``--friction-band`` alone, DataError naming both files for a unit mismatch."""
    from ..design.gantry_mimo import gantry_friction
    from ..errors import UsageError
    from .design_cmd import _load_friction

    if friction_band is not None and friction is None:
        raise UsageError("--friction-band needs --friction")
    friction_model = _load_friction(friction)
    if friction_model is not None:
        gantry_friction(model, friction_model, v_band=friction_band, where=str(friction), model_where=str(model_file))
    return friction_model


def _with_friction(design, friction_model, friction: Path | None, friction_band: float | None, model_file: Path):
    """``design`` with the friction feedforward of ``friction_model`` (unchanged without one)."""
    if friction_model is None:
        return design
    return design.with_friction(friction_model, v_band=friction_band, where=str(friction),
                                model_where=str(model_file))


def _deliver_and_report(design, sources, *, limits, targets, out, force, allow_unstable, as_json, sampling=None,
                        extra: dict | None = None, extra_gains: dict | None = None) -> None:
    """Deliver the design (:func:`feedtune.workflows.deliver.deliver`: gains document, its check on every FRF or on
    the model, the certificate in the file when on FRFs, the design targets), write it unless it fails, print the
    result; DesignError (exit 1) when it fails without ``--allow-unstable``."""
    from ..workflows.deliver import deliver
    from .delivery import finish_design

    delivery = deliver(design, sources, limits, targets=targets, where="the design")
    doc = delivery.document
    gains = {**doc["gains"], **(extra_gains or {})}
    result = {**delivery.result, "gains": {k: v["value"] for k, v in gains.items()},
              "gain_units": {k: v["unit"] for k, v in gains.items()}, "design": doc["design"], **(extra or {}),
              **({} if sampling is None else sampling.to_json())}
    finish_design(delivery, result, out=out, force=force, allow_unstable=allow_unstable, as_json=as_json)


def read_sources_of(path: Path | None, frf) -> list:
    """The FRF read from ``--frf`` as a certification source (none without one)."""
    from ..machines.certificate import FrfSource

    return [] if frf is None else [FrfSource.from_file(path, frf)]


def _gantry_finish(design, sources, *, limits, targets, out, force, allow_unstable, as_json, sampling=None) -> None:
    """Deliver a gantry design; the result also holds the design position and, for MIMO, the lead gain."""
    lead = ({"lead_gain": {"value": design.law.lead_gain, "unit": f"{design.model.input_unit}/m"}}
            if design.controller == "mimo" else {})
    _deliver_and_report(design, sources, limits=limits, targets=targets, out=out, force=force,
                        allow_unstable=allow_unstable, as_json=as_json, sampling=sampling, extra={"x_m": design.x},
                        extra_gains=lead)


# ------------------------------------------------------------------------------------------ gantry
def gantry(
    model_file: Path = typer.Argument(..., metavar="MODEL", help="Gantry model file from 'feedtune identify gantry'."),
    crossover_hz: float = typer.Option(
        60.0, "--crossover-hz", metavar="HZ",
        help="CoM-loop crossover [Hz] (thesis: 60).",
    ),
    pm_deg: float = typer.Option(40.0, "--pm-deg", metavar="DEG", help="CoM-loop phase margin [deg] (thesis: 40)."),
    damping_increase: float = typer.Option(
        5.9, "--damping-increase", metavar="FACTOR",
        help="Increase of the torsional damping by active damping [-] (5.9 = +590 %).",
    ),
    ki: float = typer.Option(None, "--ki", metavar="GAIN", help="Actuator-level integral gain [V/(m s)]; default "
                                                "K_D wc tan(--integral-lag-deg)."),
    integral_lag_deg: float = typer.Option(
        10.0, "--integral-lag-deg", metavar="DEG",
        help="Sets the default --ki [deg].",
    ),
    notch: list[str] = NOTCH_OPTION,
    lpf: float = LPF_OPTION,
    lpf_order: int = typer.Option(2, "--lpf-order", **choice(LPF_ORDERS), help="Low-pass order, 1 or 2."),
    lpf_zeta: float = LPF_ZETA_OPTION,
    lead: list[str] = LEAD_OPTION,
    x: float = X_OPTION,
    x_min: float = X_MIN_OPTION,
    x_max: float = X_MAX_OPTION,
    x_points: int = X_POINTS_OPTION,
    prefilter1: str = PRE1_OPTION,
    prefilter2: str = PRE2_OPTION,
    prefilter_hz: float = PREFILTER_HZ_OPTION,
    friction: Path = FRICTION_OPTION,
    friction_band: float = FRICTION_BAND_OPTION,
    fs: float = FS_OPTION,
    delay_samples: int = DELAY_OPTION,
    fs_override: bool = FS_OVERRIDE_OPTION,
    frf: Path = GANTRY_FRF_OPTION,
    quantity: str = QUANTITY_OPTION,
    frf_map: list[str] = FRF_MAP_OPTION,
    frf_skip_rows: int = FRF_SKIP_ROWS_OPTION,
    frf_scale: list[str] = FRF_SCALE_OPTION,
    frf_channel: str = FRF_CHANNEL_OPTION,
    frf_input_unit: str = FRF_INPUT_UNIT_OPTION,
    limits: str = LIMITS_OPTION,
    ms_max: float = MS_MAX_OPTION,
    pm_min: float = PM_MIN_OPTION,
    gm_min: float = GM_MIN_OPTION,
    gm_low_min: float = GM_LOW_MIN_OPTION,
    dm_min: float = DM_MIN_OPTION,
    out: Path = OUT_OPTION,
    force: bool = FORCE_OPTION,
    allow_unstable: bool = ALLOW_OPTION,
    as_json: bool = JSON_OPTION,
    quiet: bool = QUIET_OPTION,
) -> None:
    """Design the gantry MIMO law.

    Gantry MIMO control: averaging, lead, active damping, actuator-level integral (eq. 4.22-4.33); optionally with
    the Stribeck friction feedforward of the gantry's travel (--friction, levels in the model's command unit,
    velocities in m/s), split alpha1 : alpha2 between the drives."""
    show_progress(quiet)
    from ..control.prefilter import PrefilterGains
    from ..design.gantry_mimo import design_gantry_mimo
    from .frf_options import FrfReadOptions, read_optional_frf

    policy = limits_from_options(limits, ms_max, pm_min, gm_min, dm_min, gm_low_min)
    frf_options = FrfReadOptions.from_cli(frf_map, frf_skip_rows, frf_scale, frf_channel, frf_input_unit)
    model = _gantry_model(model_file)
    friction_model = _gantry_friction_model(friction, friction_band, model, model_file)
    measured = read_optional_frf(frf, quantity, options=frf_options)
    rate = target_sampling(fs, delay_samples, [(frf, measured)], default_fs=DEFAULT_FS, override=fs_override)
    rate.report(as_json, "design gantry")
    fs, delay_samples = rate.fs_hz, rate.delay_samples
    design = design_gantry_mimo(
        model, crossover_hz=crossover_hz, pm_deg=pm_deg, damping_increase=damping_increase, ki=ki,
        integral_lag_deg=integral_lag_deg, filters=_loop_filters(notch, lpf, lpf_order, lpf_zeta, lead), fs=fs,
        delay_samples=delay_samples, x=x, x_grid=_x_grid(model, x_min, x_max, x_points),
        prefilter1=PrefilterGains.parse(prefilter1, "--prefilter1"),
        prefilter2=PrefilterGains.parse(prefilter2, "--prefilter2"), prefilter_hz=prefilter_hz)
    design = _with_friction(design, friction_model, friction, friction_band, model_file)
    _gantry_finish(design, read_sources_of(frf, measured), limits=policy, targets=(crossover_hz, pm_deg), out=out,
                   force=force, allow_unstable=allow_unstable, as_json=as_json, sampling=rate)


# ------------------------------------------------------------------------------------------ pid
def _pair(text: str | None, name: str):
    from ..errors import UsageError

    if text is None:
        return None
    try:
        vals = [float(v) for v in str(text).split(",")]
    except ValueError:
        raise UsageError(f"{name} expects one number or SIDE1,SIDE2, got {text!r}") from None
    if len(vals) not in (1, 2):
        raise UsageError(f"{name} expects one number or SIDE1,SIDE2, got {text!r}")
    return (vals[0], vals[-1])


def _matched(match: Path, frf):
    """Ms of a gantry gains file in the case the PID is checked in, and its filters without the leads."""
    from ..analysis.gantry import analyze_gantry
    from ..control.filters import FilterPack
    from ..io import read_document
    from ..io.gantry_gains import gantry_law_from_document

    law, model, x, ref = gantry_law_from_document(read_document(match), str(match))
    a = analyze_gantry(law, model, x=x, frf=frf, reference=ref)
    h = law.filters
    return a.cases["discrete" if frf is not None else "ideal_discrete"].metrics.ms, \
        FilterPack(h.notches, h.lpf_hz, h.lpf_order, h.lpf_zeta)


FILTERS_CHOICE_OPTION = typer.Option(
    None, "--filters", **choice(FILTER_CHOICES),
    help="Filters of the tuned PIDs: identical (the filter options, or with --match the matched file's notches and "
         "low-pass: the thesis' rule) or own (the tuner chooses notches and a low-pass where they raise the "
         "crossover; the filter options or the matched ones are candidates). Default: identical with --match, "
         "else own.")


def _print_tuning(tuning: dict) -> None:
    """A few lines on how a tuner chose the design (its ``tuning`` record)."""
    lim = tuning.get("limits", {})
    typer.echo(f"tuned: {tuning['method']}")
    act = tuning.get("active_limit") or {}
    act = act.get("name") if isinstance(act, dict) else act
    typer.echo(f"  limits {lim.get('profile')} in the {tuning['checked_case']} case; active limit: "
               f"{act}; {tuning['search']['checks']} checks in {tuning['search']['seconds']} s")
    filt = tuning.get("filters")
    if filt:
        chosen = filt.get("chosen")
        text = "; ".join(chosen) if chosen else filt.get("why", "")
        typer.echo(f"  filters ({filt['choice']}): {text or 'none'}")
    for w in tuning.get("warnings", []):
        typer.echo(f"  warning: {cli_text(w)}")


def pid(
    model_file: Path = typer.Argument(..., metavar="MODEL", help="Gantry model file from 'feedtune identify gantry'."),
    limits: str = LIMITS_OPTION,
    ms_max: float = MS_MAX_OPTION,
    pm_min: float = PM_MIN_OPTION,
    gm_min: float = GM_MIN_OPTION,
    gm_low_min: float = GM_LOW_MIN_OPTION,
    dm_min: float = DM_MIN_OPTION,
    match: Path = typer.Option(
        None, "--match", metavar="GAINS",
        help="Gantry gains file (e.g. the MIMO design) whose Ms the PIDs are tuned to; without filter options its "
             "notches and low-pass are used (not its leads).",
    ),
    filter_choice: str = FILTERS_CHOICE_OPTION,
    kp: str = typer.Option(
        None, "--kp", metavar="K[,K2]",
        help="Proportional gain [V/m], one value or SIDE1,SIDE2 (with --kd, --ki: no tuning).",
    ),
    kd: str = typer.Option(None, "--kd", metavar="K[,K2]", help="Derivative gain [V/(m/s)], one value or SIDE1,SIDE2."),
    ki: str = typer.Option(None, "--ki", metavar="K[,K2]", help="Integral gain [V/(m s)], one value or SIDE1,SIDE2."),
    notch: list[str] = NOTCH_OPTION,
    lpf: float = LPF_OPTION,
    lpf_order: int = typer.Option(2, "--lpf-order", **choice(LPF_ORDERS), help="Low-pass order, 1 or 2."),
    lpf_zeta: float = LPF_ZETA_OPTION,
    lead: list[str] = LEAD_OPTION,
    x: float = X_OPTION,
    x_min: float = X_MIN_OPTION,
    x_max: float = X_MAX_OPTION,
    x_points: int = X_POINTS_OPTION,
    prefilter1: str = PRE1_OPTION,
    prefilter2: str = PRE2_OPTION,
    prefilter_hz: float = PREFILTER_HZ_OPTION,
    friction: Path = FRICTION_OPTION,
    friction_band: float = FRICTION_BAND_OPTION,
    fs: float = FS_OPTION,
    delay_samples: int = DELAY_OPTION,
    fs_override: bool = FS_OVERRIDE_OPTION,
    frf: Path = GANTRY_FRF_OPTION,
    quantity: str = QUANTITY_OPTION,
    frf_map: list[str] = FRF_MAP_OPTION,
    frf_skip_rows: int = FRF_SKIP_ROWS_OPTION,
    frf_scale: list[str] = FRF_SCALE_OPTION,
    frf_channel: str = FRF_CHANNEL_OPTION,
    frf_input_unit: str = FRF_INPUT_UNIT_OPTION,
    out: Path = OUT_OPTION,
    force: bool = FORCE_OPTION,
    allow_unstable: bool = ALLOW_OPTION,
    as_json: bool = JSON_OPTION,
    quiet: bool = QUIET_OPTION,
) -> None:
    """Design independent PIDs per gantry side, the MIMO baseline.

    Independent PID per side behind notches and low-pass, tuned for the highest crossover under the limits
    (thesis baseline); optionally with the friction feedforward of the gantry's travel (--friction), split
    alpha1 : alpha2 between the sides like the inertia feedforward."""
    show_progress(quiet)
    from ..control.prefilter import PrefilterGains
    from ..design.gantry_pid import design_gantry_pid
    from ..errors import UsageError
    from ..tune.pid import FILTER_CHOICES, tune_gantry_pid
    from .frf_options import FrfReadOptions, read_optional_frf

    if filter_choice is not None and filter_choice not in FILTER_CHOICES:
        raise UsageError(f"--filters must be own or identical, got {filter_choice!r}")
    policy = limits_from_options(limits, ms_max, pm_min, gm_min, dm_min, gm_low_min)
    frf_options = FrfReadOptions.from_cli(frf_map, frf_skip_rows, frf_scale, frf_channel, frf_input_unit)
    model = _gantry_model(model_file)
    friction_model = _gantry_friction_model(friction, friction_band, model, model_file)
    measured = read_optional_frf(frf, quantity, options=frf_options)
    filters = _loop_filters(notch, lpf, lpf_order, lpf_zeta, lead)
    rate = target_sampling(fs, delay_samples, [(frf, measured)], default_fs=DEFAULT_FS, override=fs_override)
    rate.report(as_json, "design pid")
    fs, delay_samples = rate.fs_hz, rate.delay_samples
    given = [g is not None for g in (kp, kd, ki)]
    if any(given) and not all(given):
        raise UsageError("give all of --kp, --kd and --ki, or none of them to tune them under the limits")
    if match is not None and ms_max is not None:
        raise UsageError("give either --ms-max or --match, not both")
    if match is not None:
        ms_max, matched_filters = _matched(match, measured)
        if not (notch or lpf is not None or lead):
            filters = matched_filters  # the thesis' PIDs: identical notch and low-pass filters
    choice = filter_choice or ("identical" if match is not None else "own")
    common = dict(filters=filters, fs=fs, delay_samples=delay_samples, x=x,
                  x_grid=_x_grid(model, x_min, x_max, x_points),
                  prefilter1=PrefilterGains.parse(prefilter1, "--prefilter1"),
                  prefilter2=PrefilterGains.parse(prefilter2, "--prefilter2"), prefilter_hz=prefilter_hz)
    if all(given):
        design = design_gantry_pid(model, kp=_pair(kp, "--kp"), kd=_pair(kd, "--kd"), ki=_pair(ki, "--ki"), **common)
    else:
        design = tune_gantry_pid(model, limits=policy.override(ms_max=ms_max), frf=measured, filter_choice=choice,
                                 **common)
        if not as_json:
            _print_tuning(design.tuning)
    design = _with_friction(design, friction_model, friction, friction_band, model_file)
    _gantry_finish(design, read_sources_of(frf, measured), limits=policy.override(ms_max=ms_max), targets=None,
                   out=out, force=force,
                   allow_unstable=allow_unstable, as_json=as_json, sampling=rate)  # --match: the MIMO design's Ms


# ------------------------------------------------------------------------------------------ tune gantry|pid
def _positioned_frfs(paths: list[Path] | None, xs: list[float] | None, quantity: str | None, frf_options=None):
    """Gantry FRFs as certification sources, each carrying its table position (``--x`` or its own ``x_m``)."""
    from dataclasses import replace

    from ..tune.gantry_cases import frf_positions
    from .tune_cmd import _frfs

    frfs = _frfs(paths, quantity, frf_options)
    if xs and not frfs:
        from ..errors import UsageError

        raise UsageError("--x gives the table position of each --frf; without --frf use --design-x")
    positions = frf_positions([s.frf for s in frfs], xs or None, 0.0)
    return [replace(s, name=f"{s.name} (x = {x:g} m)", frf=replace(s.frf, meta={**s.frf.meta, "x_m": repr(float(x))}))
            for s, x in zip(frfs, positions, strict=True)]


def tune_gantry(entry, request) -> None:
    """``feedtune tune gantry|pid``: tune the gantry MIMO law or the PID pair on every FRF at its position, certify,
    write, print (``request``: :class:`~feedtune.cli.tune_cmd.TuneRequest`)."""
    from ..io.document import ensure_document_writable
    from ..structures import resolve
    from ..workflows.deliver import deliver
    from .common import fmt
    from .limits_options import OPTION_NAMES
    from .tune_cmd import _filter_choice, _report_tuned, print_tuned

    r = request
    if r.out is not None:
        ensure_document_writable(r.out, r.force)
    model = _gantry_model(r.plant_file)
    frfs = _positioned_frfs(r.frf, r.xs, r.quantity, r.frf_options)
    rate = target_sampling(r.fs, r.delay_samples, [(s.name, s.frf) for s in frfs], default_fs=entry.default_fs_hz,
                           override=r.fs_override)
    rate.report(r.as_json, f"tune {entry.command}")
    choice = _filter_choice(r.filters, r.pack.notches, r.pack.lpf_hz)
    design = resolve(entry.tuner)(model, filter_choice=choice, limits=r.policy, filters=r.pack, fs=rate.fs_hz,
                                  delay_samples=rate.delay_samples, x=r.design_x, frf=[s.frf for s in frfs] or None,
                                  objective=r.objective)
    tuning = design.tuning
    record = tuning.get("filters", {"choice": choice})
    delivery = deliver(design, frfs, r.policy, where="tuned design")
    doc = delivery.document
    gains = {k: v["value"] for k, v in doc["gains"].items()}
    units = {k: v["unit"] for k, v in doc["gains"].items()}
    mimo = design.controller == "mimo"
    if mimo:
        gains["lead_gain"], units["lead_gain"] = design.law.lead_gain, f"{model.input_unit}/m"
    result = {"kind": entry.gains_kind, "controller": design.controller, "design_x_m": design.x, "gains": gains,
              "gain_units": units, "filters": design.law.filters.to_dict(), "filter_choice": record,
              "design": design.design_dict(), "certificate": delivery.certificate.to_dict(OPTION_NAMES),
              **rate.to_json()}
    if _report_tuned(entry.title, delivery, result, r.out, r.force, r.as_json):
        return
    shape = (f"CoM crossover target {fmt(design.crossover_hz, 'Hz')}, PM target {fmt(design.pm_deg, 'deg')}, "
             f"damping increase {design.damping_increase:g}" if mimo else
             f"bandwidth {fmt(tuning['bandwidth_hz'], 'Hz')}, zeta {tuning['zeta']:.3g}, rho {tuning['rho']:.3g}")
    print_tuned(entry.title, shape, gains, units, tuning, result["filters"], record, result["certificate"], r.out)
