"""``feedtune design``: controllers from models."""

from __future__ import annotations

from pathlib import Path

import typer

from ..structures import controller
from .common import FORCE_OPTION, JSON_OPTION
from .frf_options import (
    FRF_CHANNEL_OPTION,
    FRF_INPUT_UNIT_OPTION,
    FRF_MAP_OPTION,
    FRF_SCALE_OPTION,
    FRF_SKIP_ROWS_OPTION,
)
from .help_text import QUANTITIES, choice
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
from .sampling_options import DELAY_OPTION, FS_OVERRIDE_OPTION, fs_option, target_sampling

app = typer.Typer(
    rich_markup_mode="rich",
    help="Design controllers: MC-PPC, P-PI, MIMO, PID, loop shaping.\n\nFrom identified models: MC-PPC and P-PI "
         "for a ball screw, MIMO and PID for a gantry, loop shaping for an x axis.",
    no_args_is_help=True,
)

NOTCH_HELP = "Notch HZ,ZETA_Z,ZETA_P (repeatable), e.g. --notch 420,0.55,0.7 --notch 1080,0.05,0.7."
NOTCH_OPTION = typer.Option(None, "--notch", metavar="HZ,ZETA_Z,ZETA_P", help=NOTCH_HELP)
LPF_OPTION = typer.Option(None, "--lpf", metavar="HZ", help="First-order low-pass pole frequency [Hz] (eq. 3.10).")
DEFAULT_FS = controller("mcppc").default_fs_hz
"""Sample rate [Hz] of ``design ppc|ppi`` without ``--fs`` and without a rate recorded in the FRF (the registry's)."""
FS_OPTION = fs_option(f"{DEFAULT_FS:g} Hz")
QUANTITY_OPTION = typer.Option(
    None, "--quantity", **choice(QUANTITIES, "QUANTITY"),
    help="Quantity of the --frf file (position, velocity or acceleration) if not in its metadata.",
)
OUT_OPTION = typer.Option(None, "--out", "-o", metavar="FILE", help="Gains file to write (.toml with a .json twin).")
ALLOW_OPTION = typer.Option(False, "--allow-unstable", help="Write the gains even if limits are violated.")
FRICTION_OPTION = typer.Option(
    None, "--friction", metavar="FILE",
    help="Friction model file ('feedtune identify friction') to feed forward (eq. 2.1).",
)
FRICTION_BAND_OPTION = typer.Option(
    None, "--friction-band", metavar="SPEED",
    help="Linear band around zero velocity of the friction feedforward, in the friction model's velocity unit (m/s or "
         "rad/s); default 0.1 x its smaller Stribeck velocity.",
)


def _filters(notch, lpf):
    from ..control.filters import FilterPack, Notch

    return FilterPack([Notch.parse(n) for n in notch or []], lpf)


def _load_friction(path: Path | None):
    """The StribeckFriction of a friction model file, or None."""
    from ..errors import DataError
    from ..io import load_model
    from ..models.friction import StribeckFriction

    if path is None:
        return None
    model = load_model(path)
    if not isinstance(model, StribeckFriction):
        raise DataError(f"{path}: --friction expects a friction model file (kind 'friction'), got a "
                        f"{type(model).__name__}")
    return model


def _ballscrew_friction(path: Path | None, band: float | None, model, model_file: Path):
    """The friction model of ``--friction`` (None without), its units and ``--friction-band`` checked against the
    ball-screw model before any design work (the gains file repeats the check with the law's own viscous term)."""
    from ..control.friction import friction_feedforward

    friction = _load_friction(path)
    if friction is not None:
        friction_feedforward(friction, command_unit=model.input_unit, lead_m_per_rad=model.lead_m_per_rad,
                             v_band=band, where=str(path), command_where=str(model_file))
    return friction


def _check_out(out: Path | None, force: bool) -> None:
    """Refuse an existing ``--out`` (without ``--force``) before any design work."""
    if out is not None:
        from ..io.document import ensure_document_writable

        ensure_document_writable(out, force)


def _finish(design, *, frf_path, frf, limits, out, force, allow_unstable, as_json, friction=None,
            friction_band=None, sampling=None):
    """Deliver the design (:func:`feedtune.workflows.deliver.deliver`: gains document, its check on the FRF or the
    model, the certificate in the file when on an FRF), write it unless it fails, print the result (``friction``:
    the friction model read by :func:`_load_friction`, ``sampling``: the
    :class:`~feedtune.cli.sampling_options.TargetSampling` recorded in the ``--json`` result)."""
    from ..machines.certificate import FrfSource
    from ..workflows.deliver import deliver
    from .delivery import finish_design

    sources = [] if frf is None else [FrfSource.from_file(frf_path, frf)]
    delivery = deliver(design, sources, limits, friction=friction, friction_band=friction_band,
                       where="the design")
    result = {**delivery.result, "design": design.design_dict(), **({} if sampling is None else sampling.to_json())}
    if design.kind != "ppi":
        result["placed_poles"] = [[float(p.real), float(p.imag)] for p in design.poles]
    finish_design(delivery, result, out=out, force=force, allow_unstable=allow_unstable, as_json=as_json)


def _load_model(path: Path):
    """The two-mass model of a model file; DataError for a model of another plant structure."""
    from ..io import load_model

    return load_model(path, plants=("two_mass",))


@app.command("ppc")
def ppc(
    model_file: Path = typer.Argument(
        ..., metavar="MODEL",
        help="Ball-screw model file from 'feedtune identify ballscrew'.",
    ),
    beta: float = typer.Option(
        None, "--beta", metavar="BETA",
        help="Multiplier of the axial mode's decay rate (eq. 3.7), >= 1 (thesis: 4). Without --beta, --pole-hz and "
             "--zeta the three are tuned under the limits.",
    ),
    pole_hz: float = typer.Option(
        None, "--pole-hz", metavar="HZ",
        help="Rigid-body closed-loop pole frequency [Hz] (eq. 3.8; thesis: 50).",
    ),
    zeta: float = typer.Option(
        None, "--zeta", metavar="ZETA",
        help="Damping of the rigid-body pole pair [-] (thesis: 0.7).",
    ),
    notch: list[str] = NOTCH_OPTION,
    lpf: float = LPF_OPTION,
    fs: float = FS_OPTION,
    delay_samples: int = DELAY_OPTION,
    fs_override: bool = FS_OVERRIDE_OPTION,
    frf: Path = typer.Option(
        None, "--frf", metavar="FRF",
        help="Measured FRF for the measured and discrete analysis cases.",
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
    friction: Path = FRICTION_OPTION,
    friction_band: float = FRICTION_BAND_OPTION,
    force: bool = FORCE_OPTION,
    allow_unstable: bool = ALLOW_OPTION,
    as_json: bool = JSON_OPTION,
    quiet: bool = QUIET_OPTION,
) -> None:
    """Design MC-PPC, given or tuned under the limits.

    Mode-compensating pole-placement control (MC-PPC, eq. 3.5-3.13): given, or tuned for the highest first
    crossover under the limits."""
    show_progress(quiet)
    from ..design.mcppc import design_mcppc
    from ..tune.mcppc import tune_mcppc
    from .frf_options import FrfReadOptions, read_optional_frf

    policy = limits_from_options(limits, ms_max, pm_min, gm_min, dm_min, gm_low_min)
    frf_options = FrfReadOptions.from_cli(frf_map, frf_skip_rows, frf_scale, frf_channel, frf_input_unit)
    model = _load_model(model_file)
    filters = _filters(notch, lpf)
    _check_out(out, force)
    friction_model = _ballscrew_friction(friction, friction_band, model, model_file)  # named before any work
    measured = read_optional_frf(frf, quantity, options=frf_options)
    rate = target_sampling(fs, delay_samples, [(frf, measured)], default_fs=DEFAULT_FS, override=fs_override)
    rate.report(as_json, "design ppc")
    fs, delay_samples = rate.fs_hz, rate.delay_samples
    if beta is None and pole_hz is None and zeta is None:
        design = tune_mcppc(model, limits=policy, filters=filters, fs=fs, delay_samples=delay_samples,
                            frf=measured)
    else:
        design = design_mcppc(model, beta=4.0 if beta is None else beta, pole_hz=50.0 if pole_hz is None else pole_hz,
                              zeta=0.7 if zeta is None else zeta, filters=filters, fs=fs,
                              delay_samples=delay_samples)
    _finish(design, frf_path=frf, frf=measured, limits=policy, out=out, force=force, allow_unstable=allow_unstable,
            as_json=as_json, friction=friction_model, friction_band=friction_band, sampling=rate)


@app.command("ppi")
def ppi(
    model_file: Path = typer.Argument(
        ..., metavar="MODEL",
        help="Ball-screw model file from 'feedtune identify ballscrew'.",
    ),
    limits: str = LIMITS_OPTION,
    ms_max: float = MS_MAX_OPTION,
    pm_min: float = PM_MIN_OPTION,
    gm_min: float = GM_MIN_OPTION,
    gm_low_min: float = GM_LOW_MIN_OPTION,
    dm_min: float = DM_MIN_OPTION,
    kpx: float = typer.Option(
        None, "--kpx", metavar="1/S",
        help="Position-loop gain [1/s] (give all three to skip tuning).",
    ),
    kpv: float = typer.Option(
        None, "--kpv", metavar="GAIN",
        help="Velocity-loop proportional gain [command unit/(rad/s)].",
    ),
    kiv: float = typer.Option(None, "--kiv", metavar="GAIN", help="Velocity-loop integral gain [command unit/rad]."),
    notch: list[str] = NOTCH_OPTION,
    lpf: float = LPF_OPTION,
    fs: float = FS_OPTION,
    delay_samples: int = DELAY_OPTION,
    fs_override: bool = FS_OVERRIDE_OPTION,
    frf: Path = typer.Option(
        None, "--frf", metavar="FRF",
        help="Measured FRF: tuning and checking use the discrete case on it.",
    ),
    quantity: str = QUANTITY_OPTION,
    frf_map: list[str] = FRF_MAP_OPTION,
    frf_skip_rows: int = FRF_SKIP_ROWS_OPTION,
    frf_scale: list[str] = FRF_SCALE_OPTION,
    frf_channel: str = FRF_CHANNEL_OPTION,
    frf_input_unit: str = FRF_INPUT_UNIT_OPTION,
    out: Path = OUT_OPTION,
    friction: Path = FRICTION_OPTION,
    friction_band: float = FRICTION_BAND_OPTION,
    force: bool = FORCE_OPTION,
    allow_unstable: bool = ALLOW_OPTION,
    as_json: bool = JSON_OPTION,
    quiet: bool = QUIET_OPTION,
) -> None:
    """Design the P-PI cascade, given or tuned under the limits.

    P-PI position-velocity cascade with velocity and acceleration feedforward (Figure 3.9)."""
    show_progress(quiet)
    from ..design.ppi import design_ppi
    from ..errors import UsageError
    from ..tune.ppi import tune_ppi
    from .frf_options import FrfReadOptions, read_optional_frf

    policy = limits_from_options(limits, ms_max, pm_min, gm_min, dm_min, gm_low_min)
    frf_options = FrfReadOptions.from_cli(frf_map, frf_skip_rows, frf_scale, frf_channel, frf_input_unit)
    model = _load_model(model_file)
    filters = _filters(notch, lpf)
    _check_out(out, force)
    given = [g is not None for g in (kpx, kpv, kiv)]
    if any(given) and not all(given):
        raise UsageError("give all of --kpx, --kpv and --kiv, or none of them to tune them under the limits")
    friction_model = _ballscrew_friction(friction, friction_band, model, model_file)  # named before any work
    measured = read_optional_frf(frf, quantity, options=frf_options)
    rate = target_sampling(fs, delay_samples, [(frf, measured)], default_fs=DEFAULT_FS, override=fs_override)
    rate.report(as_json, "design ppi")
    fs, delay_samples = rate.fs_hz, rate.delay_samples
    if all(given):
        design = design_ppi(model, Kpx=kpx, Kpv=kpv, Kiv=kiv, filters=filters, fs=fs, delay_samples=delay_samples)
    else:
        design = tune_ppi(
            model,
            limits=policy,
            filters=filters,
            fs=fs,
            delay_samples=delay_samples,
            frf=measured,
        )
    _finish(design, frf_path=frf, frf=measured, limits=policy, out=out, force=force, allow_unstable=allow_unstable,
            as_json=as_json, friction=friction_model, friction_band=friction_band, sampling=rate)


# ------------------------------------------------------------------------------------------ tune mcppc|ppi
def tune_two_mass(entry, request) -> None:
    """``feedtune tune mcppc|ppi``: tune the structure ``entry`` on every FRF, certify the gains file as written,
    write it, print the result (``request``: :class:`~feedtune.cli.tune_cmd.TuneRequest`)."""
    from ..control.ballscrew_law import all_gain_units
    from ..io.document import ensure_document_writable
    from ..structures import resolve
    from ..workflows.deliver import deliver
    from .limits_options import OPTION_NAMES
    from .tune_cmd import _filter_choice, _frfs, _report_tuned, print_tuned

    r = request
    choice = _filter_choice(r.filters, r.pack.notches, r.pack.lpf_hz)
    if r.out is not None:
        ensure_document_writable(r.out, r.force)  # refused before the search, not after it
    model = _load_model(r.plant_file)
    frfs = _frfs(r.frf, r.quantity, r.frf_options)
    rate = target_sampling(r.fs, r.delay_samples, [(s.name, s.frf) for s in frfs], default_fs=entry.default_fs_hz,
                           override=r.fs_override)
    rate.report(r.as_json, f"tune {entry.command}")
    design = resolve(entry.tuner)(model, limits=r.policy, filters=r.pack, fs=rate.fs_hz,
                                  delay_samples=rate.delay_samples, frf=[s.frf for s in frfs] or None,
                                  filter_choice=choice, objective=r.objective)
    delivery = deliver(design, frfs, r.policy, where="tuned design")
    gains = {**design.gains, **getattr(design, "ppi_gains", {})}
    units = all_gain_units(model.input_unit)
    result = {"kind": entry.gains_kind, "controller": design.kind, "gains": gains, "gain_units": units,
              "filters": design.filters.to_dict(), "filter_choice": design.tuning.get("filters", {"choice": choice}),
              "design": design.design_dict(), "certificate": delivery.certificate.to_dict(OPTION_NAMES),
              **rate.to_json()}
    if _report_tuned(entry.title, delivery, result, r.out, r.force, r.as_json):
        return
    print_tuned(entry.title, None, gains, units, design.tuning, result["filters"], result["filter_choice"],
                result["certificate"], r.out)
