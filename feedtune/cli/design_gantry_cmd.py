"""``feedtune design loopshape|gantry|pid``: the x axis and the gantry of thesis chapter 4.

* ``loopshape``: double-lead-and-integral loop shaping of an axis (eq. 4.17-4.20) from a mass, a gantry model
  (its ``m_x``) or a measured SISO FRF; without ``--crossover-hz`` the highest crossover under the limits
  (:func:`feedtune.tune.loopshape.tune_loopshape`).
* ``gantry``: the MIMO law of eq. 4.30 (sensor/actuator averaging, lead, active damping, actuator-level
  integral) with feedforward and pre-filters scheduled in the table position.
* ``gantry`` and ``pid`` take ``--friction F.toml [--friction-band V]``: the Stribeck friction feedforward of the
  gantry's travel (command unit, m/s), split ``alpha1 : alpha2`` between the drives like the inertia feedforward.
* ``pid``: the independent-PID baseline tuned for the highest crossover under the limits
  (:func:`feedtune.tune.pid.tune_gantry_pid`), with ``--match`` to the Ms of a MIMO gains file and its filters;
  ``--filters own|identical`` says whether the tuner may choose its own notches and low-pass.

The commands are registered on the ``design`` group in :mod:`feedtune.cli.main`.
"""

from __future__ import annotations

from pathlib import Path

import typer

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

DEFAULT_FS = 15000.0
"""Sample rate [Hz] of ``design loopshape|gantry|pid`` without ``--fs`` and without a rate recorded in an FRF."""
FS_OPTION = fs_option("15000 Hz")
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
    from ..errors import DataError
    from ..io import load_model
    from ..models.gantry import GantryModel

    model = load_model(path)
    if not isinstance(model, GantryModel):
        raise DataError(f"{path}: a gantry model is needed (kind = \"gantry\"), got a {type(model).__name__}")
    return model


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


# ------------------------------------------------------------------------------------------ loopshape
def loopshape(
    plant_file: Path = typer.Argument(
        ..., metavar="PLANT",
        help="Model file (.toml/.json: a gantry model's m_x) or a measured SISO FRF (.csv/.mat/.uff).",
    ),
    crossover_hz: float = typer.Option(
        None, "--crossover-hz", metavar="HZ",
        help="Crossover frequency [Hz] (thesis: 130); without it the tuner finds the highest crossover under the "
             "limits.",
    ),
    pm_deg: float = typer.Option(
        None, "--pm-deg", metavar="DEG",
        help="Phase margin at the crossover [deg] (thesis: 35); needed with --crossover-hz, fixes the target when "
             "tuning.",
    ),
    pi_lag_deg: float = typer.Option(
        None, "--pi-lag-deg", metavar="DEG",
        help="Phase lag of the integral action at the crossover [deg] (default 10; searched when tuning unless given).",
    ),
    max_stage_deg: float = typer.Option(
        70.0, "--max-stage-deg", metavar="DEG",
        help="Largest phase of one lead stage [deg] (the tuner searches 1-3 stages instead).",
    ),
    mass: float = typer.Option(
        None, "--mass", metavar="MASS",
        help="Axis mass [V/(m/s^2)] (instead of the model's m_x or the FRF estimate).",
    ),
    channel: str = typer.Option(
        None, "--channel", metavar="OUT/IN",
        help="FRF channel OUT/IN when the FRF has several.",
    ),
    notch: list[str] = NOTCH_OPTION,
    lpf: float = LPF_OPTION,
    lpf_order: int = typer.Option(1, "--lpf-order", **choice(LPF_ORDERS), help="Low-pass order, 1 or 2."),
    lpf_zeta: float = LPF_ZETA_OPTION,
    lead: list[str] = LEAD_OPTION,
    prefilter: str = typer.Option(
        None, "--prefilter", metavar="VEL,ACC,JERK,SNAP",
        help="Pre-filter gains VEL,ACC,JERK,SNAP [s, s^2, s^3, s^4] (eq. 4.20).",
    ),
    prefilter_hz: float = PREFILTER_HZ_OPTION,
    friction: Path = FRICTION_OPTION,
    friction_band: float = FRICTION_BAND_OPTION,
    fs: float = FS_OPTION,
    delay_samples: int = DELAY_OPTION,
    fs_override: bool = FS_OVERRIDE_OPTION,
    frf: Path = typer.Option(
        None, "--frf", metavar="FRF",
        help="Measured SISO FRF for the measured and discrete cases.",
    ),
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
    """Design x-axis loop shaping, given or tuned under the limits.

    Double-lead and integral loop shaping of an axis (thesis eq. 4.17-4.20), designed or tuned; optionally with
    the Stribeck friction feedforward of an identified friction model (--friction, levels in the axis' command unit,
    velocities in m/s)."""
    show_progress(quiet)
    from ..control.friction import friction_feedforward
    from ..control.prefilter import PrefilterGains
    from ..design.loopshape import _command_unit_of, axis_plant, design_loopshape
    from ..errors import DataError, UsageError
    from ..frf import Frf
    from ..tune.loopshape import tune_loopshape
    from .design_cmd import _load_friction
    from .frf_options import FrfReadOptions, read_optional_frf

    frf_options = FrfReadOptions.from_cli(frf_map, frf_skip_rows, frf_scale, frf_channel, frf_input_unit)
    if plant_file.suffix.lower() in (".toml", ".json"):
        from ..io import load_model

        plant = load_model(plant_file)
        try:
            axis_plant(plant, mass=mass)  # a model of the wrong kind, named with its file before any work
        except DataError as exc:
            raise DataError(f"{plant_file}: {exc}") from None
    else:
        plant = read_optional_frf(plant_file, quantity, options=frf_options)
    friction_model = _load_friction(friction)
    if friction_model is not None:  # refuse a unit mismatch before designing (with_friction checks it again)
        unit = plant.input_unit if isinstance(plant, Frf) else _command_unit_of(plant)
        friction_feedforward(friction_model, command_unit=unit, lead_m_per_rad=None, v_band=friction_band,
                             where=str(friction), command_where=str(plant_file))
    policy = limits_from_options(limits, ms_max, pm_min, gm_min, dm_min, gm_low_min)
    measured = read_optional_frf(frf, quantity, options=frf_options)
    rate = target_sampling(fs, delay_samples, [(plant_file, plant if isinstance(plant, Frf) else None),
                                               (frf, measured)], default_fs=DEFAULT_FS, override=fs_override)
    rate.report(as_json, "design loopshape")
    fs, delay_samples = rate.fs_hz, rate.delay_samples
    filters = _loop_filters(notch, lpf, lpf_order, lpf_zeta, lead)
    common = dict(filters=filters, fs=fs, delay_samples=delay_samples, prefilter=PrefilterGains.parse(prefilter),
                  prefilter_hz=prefilter_hz, mass=mass, channel=channel)
    if crossover_hz is not None:
        if pm_deg is None:
            raise UsageError("--crossover-hz needs --pm-deg (or give neither to tune the crossover)")
        design = design_loopshape(plant, crossover_hz=crossover_hz, pm_deg=pm_deg,
                                  pi_lag_deg=10.0 if pi_lag_deg is None else pi_lag_deg, max_stage_deg=max_stage_deg,
                                  **common)
    else:
        design = tune_loopshape(plant, limits=policy, frf=measured,
                                pm_bounds=None if pm_deg is None else (pm_deg, pm_deg),
                                pi_lag_bounds=None if pi_lag_deg is None else (pi_lag_deg, pi_lag_deg), **common)
        if not as_json:
            _print_tuning(design.tuning)
    if friction_model is not None:
        design = design.with_friction(friction_model, v_band=friction_band, where=str(friction),
                                      plant_where=str(plant_file))
    sources = _axis_sources([(plant_file, plant if isinstance(plant, Frf) else None), (frf, measured)], channel)
    _deliver_and_report(design, sources, limits=policy, targets=(design.crossover_hz, design.pm_deg), out=out,
                        force=force, allow_unstable=allow_unstable, as_json=as_json, sampling=rate,
                        extra={"lead_stages": [s.to_dict() for s in design.lead_stages]})


def _axis_sources(frfs, channel: str | None) -> list:
    """The x axis' FRFs as certification sources (each file once): the plant FRF it was designed on and ``--frf``;
    with ``--channel`` an FRF of several channels is narrowed to that one (named ``FILE [CHANNEL]``)."""
    from ..frf import Frf
    from ..machines.certificate import FrfSource

    out, seen = [], set()
    for path, frf in frfs:
        if frf is None or str(path) in seen:
            continue
        seen.add(str(path))
        name = str(path)
        if channel is not None and len(frf.channels) > 1:
            coh = frf.channel_coherence(channel)
            frf = Frf.from_channels(frf.freq_hz, {channel: frf.channel(channel)},
                                    coherence=None if coh is None else {channel: coh}, quantity=frf.quantity,
                                    input_unit=frf.input_unit, output_unit=frf.output_unit, meta=frf.meta)
            name = f"{path} [{channel}]"
        out.append(FrfSource.from_file(path, frf, name))
    return out


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
