"""``feedtune design loopshape`` and ``feedtune tune loopshape``: a rigid axis by loop shaping (thesis eq. 4.17-4.20).

Double-lead-and-integral loop shaping of an axis from a mass, a model (a gantry model's ``m_x``, a rigid-body model's
mass) or a measured SISO FRF; without ``--crossover-hz`` the highest crossover under the limits
(:func:`feedtune.tune.loopshape.tune_loopshape`). The command is registered on the ``design`` group in
:mod:`feedtune.cli.main`; :func:`tune_axis` is ``feedtune tune loopshape`` (the registry of structures names it).
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
from .design_gantry_cmd import (
    FS_OPTION,
    LEAD_OPTION,
    LPF_OPTION,
    LPF_ZETA_OPTION,
    PREFILTER_HZ_OPTION,
    _deliver_and_report,
    _loop_filters,
    _print_tuning,
)
from .frf_options import (
    FRF_CHANNEL_OPTION,
    FRF_INPUT_UNIT_OPTION,
    FRF_MAP_OPTION,
    FRF_SCALE_OPTION,
    FRF_SKIP_ROWS_OPTION,
)
from .help_text import LPF_ORDERS, choice
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
from .sampling_options import FS_OVERRIDE_OPTION, target_sampling


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
    if friction_band is not None and friction is None:
        raise UsageError("--friction-band needs --friction")
    friction_model = _load_friction(friction)
    if friction_model is not None:  # refuse a unit mismatch before designing (with_friction checks it again)
        unit = plant.input_unit if isinstance(plant, Frf) else _command_unit_of(plant)
        friction_feedforward(friction_model, command_unit=unit, lead_m_per_rad=None, v_band=friction_band,
                             where=str(friction), command_where=str(plant_file))
    policy = limits_from_options(limits, ms_max, pm_min, gm_min, dm_min, gm_low_min)
    measured = read_optional_frf(frf, quantity, options=frf_options)
    rate = target_sampling(fs, delay_samples, [(plant_file, plant if isinstance(plant, Frf) else None),
                                               (frf, measured)], default_fs=controller("loopshape").default_fs_hz,
                         override=fs_override)
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


# ------------------------------------------------------------------------------------------ tune loopshape
def tune_axis(entry, request) -> None:
    """``feedtune tune loopshape``: tune an axis by loop shaping on every FRF, certify, write, print (``request``:
    :class:`~feedtune.cli.tune_cmd.TuneRequest`; its MODEL is a model file or a measured SISO FRF)."""
    from ..io import load_model
    from ..io.document import ensure_document_writable
    from ..machines.certificate import FrfSource
    from ..structures import resolve
    from ..workflows.deliver import deliver
    from .common import fmt
    from .frf_options import read_optional_frf
    from .limits_options import OPTION_NAMES
    from .tune_cmd import _filter_choice, _frfs, _report_tuned, print_tuned

    r = request
    choice = _filter_choice(r.filters, r.pack.notches, r.pack.lpf_hz)
    if r.out is not None:
        ensure_document_writable(r.out, r.force)
    is_model = r.plant_file.suffix.lower() in (".toml", ".json")
    plant = load_model(r.plant_file) if is_model else read_optional_frf(r.plant_file, r.quantity,
                                                                           options=r.frf_options)
    frfs = _frfs(r.frf, r.quantity, r.frf_options)
    plant_frf = [] if is_model else [FrfSource.from_file(r.plant_file, plant)]
    rate = target_sampling(r.fs, r.delay_samples, [(s.name, s.frf) for s in plant_frf + frfs],
                           default_fs=entry.default_fs_hz, override=r.fs_override)
    rate.report(r.as_json, f"tune {entry.command}")
    design = resolve(entry.tuner)(plant, limits=r.policy, filters=r.pack, fs=rate.fs_hz,
                                  delay_samples=rate.delay_samples, frf=[s.frf for s in frfs] or None,
                                  filter_choice=choice, objective=r.objective)
    delivery = deliver(design, plant_frf + [s for s in frfs if s.name != str(r.plant_file)], r.policy,
                       where="tuned design")
    tuning = design.tuning
    result = {"kind": entry.gains_kind, "controller": entry.name, "design": design.design_dict(),
              "filters": design.filters.to_dict(), "certificate": delivery.certificate.to_dict(OPTION_NAMES),
              **rate.to_json()}
    if _report_tuned("loop-shaping design", delivery, result, r.out, r.force, r.as_json):
        return
    shape = (f"crossover {fmt(tuning['crossover_hz'], 'Hz')}, PM target {fmt(tuning['pm_target_deg'], 'deg')}, "
             f"integral lag {fmt(tuning['pi_lag_deg'], 'deg')}, {tuning['lead_stages']} lead stage(s)")
    print_tuned(entry.title, shape, {}, {}, tuning, result["filters"], tuning.get("filters", {"choice": choice}),
                result["certificate"], r.out)
