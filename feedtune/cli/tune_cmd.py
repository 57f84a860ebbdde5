"""``feedtune tune``: the highest-bandwidth controller that meets the limits on every measured FRF, with a certificate.

``feedtune tune mcppc|ppi MODEL --frf F1 --frf F2 ...``: MC-PPC (beta, pole frequency, zeta) or P-PI (Kpx, Kpv,
Kiv) tuned for the highest first crossover guaranteed on every FRF (:func:`feedtune.tune.mcppc.tune_mcppc`,
:func:`feedtune.tune.ppi.tune_ppi`); ``gantry|pid MODEL --frf F1 --frf F2 ...``: the gantry MIMO law or the
independent PIDs, each FRF checked at its table position (:func:`feedtune.tune.gantry.tune_gantry_mimo`,
:func:`feedtune.tune.pid.tune_gantry_pid`); ``loopshape``: an x axis. Each design is then certified on each FRF by
the analysis ``feedtune analyze`` runs (:func:`feedtune.machines.certificate.certify`). The certificate is printed,
in ``--json`` and in the gains file (``[certificate]``).
"""

from __future__ import annotations

from pathlib import Path

import typer

from .common import FORCE_OPTION, JSON_OPTION, fmt
from .delivery import print_certificate
from .design_cmd import DELAY_OPTION, LPF_OPTION, NOTCH_OPTION, QUANTITY_OPTION, _load_model
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
    OPTION_NAMES,
    PM_MIN_OPTION,
    limits_from_options,
)
from .progress_display import QUIET_OPTION, show_progress
from .sampling_options import FS_OVERRIDE_OPTION, target_sampling

FRFS_OPTION = typer.Option(
    None, "--frf", metavar="FRF",
    help="Measured FRF (x1/u, x2/u), repeatable: one per table position or load. The limits must hold on every one.",
)
OUT_OPTION = typer.Option(
    None, "--out", "-o", metavar="FILE",
    help="Gains file to write (.toml or .json), with the certificate.",
)
FS_OPTION = typer.Option(
    None, "--fs", metavar="HZ",
    help="Sample rate of the target [Hz] (default: the rate the FRF files record, sampling_fs_hz, else 20000 for "
         "mcppc and ppi, 15000 for gantry, pid and loopshape).",
)
DEFAULT_FS = {"mcppc": 20000.0, "ppi": 20000.0, "gantry": 15000.0, "pid": 15000.0, "loopshape": 15000.0}
X_OPTION = typer.Option(
    None, "--x", metavar="M",
    help="gantry, pid: table position [m] of each --frf, in order (repeatable; default: the position recorded in each "
         "FRF file, x_m).",
)
DESIGN_X_OPTION = typer.Option(
    0.0, "--design-x", metavar="M",
    help="gantry, pid: table position [m] the design is made at (averaging, damping gain, the PIDs' mass scaling).",
)
LPF_ORDER_OPTION = typer.Option(
    None, "--lpf-order", **choice(LPF_ORDERS),
    help="Low-pass order, 1 or 2 (default 2 for gantry and pid, else 1).",
)
LEAD_OPTION = typer.Option(
    None, "--lead", metavar="HZ,DEG",
    help="gantry, pid, loopshape: extra lead stage HZ,DEG in the filter pack (repeatable), e.g. --lead 154,70.",
)
OBJECTIVE_OPTION = typer.Option(
    None, "--objective", metavar="OBJECTIVE",
    help="What the tuner maximises at the edge of the limits: stiffness (the integral gain: Ki2, ki, K; the default), "
         "bandwidth (the first crossover, ties by the integral gain) or pareto (the front of both, printed; the "
         "stiffness winner chosen).",
)
COMPLIANCE_MAX_OPTION = typer.Option(
    None, "--compliance-max", metavar="RAD_PER_U", min=0.0,
    help="mcppc, ppi: cap on the axial-mode compliance, minus the most negative real part of x2/d2 in the ideal case "
         "[rad per command unit] (the 'd2->x2 most negative real part' of 'feedtune analyze'), under any objective.",
)
FILTERS_OPTION = typer.Option(
    None, "--filters", **choice(FILTER_CHOICES),
    help="own: the tuner places notches and a low-pass where they raise the guaranteed crossover (--notch/--lpf "
         "are candidates, and the pack they form as a whole; --lead stages are kept); identical: the pack as "
         "given. Default: identical with --notch or --lpf, else own.")


def _filter_choice(choice: str | None, notch, lpf) -> str:
    from ..errors import UsageError

    if choice is None:
        return "identical" if notch or lpf is not None else "own"
    if choice not in ("own", "identical"):
        raise UsageError(f"--filters must be own or identical, got {choice!r}")
    return choice


def _frfs(paths: list[Path] | None, quantity: str | None, frf_options=None) -> list:
    """The ``--frf`` files as certification sources (:class:`~feedtune.machines.certificate.FrfSource`)."""
    from .delivery import read_sources

    return read_sources(list(paths or []), quantity, frf_options)


def print_filters(pack: dict, record: dict) -> None:
    """The filter pack and, for the tuner's own choice, what each kept filter addresses."""
    parts = [f"notch {fmt(n['freq_hz'], 'Hz')} (zeta_z {n['zeta_z']:.3g}, zeta_p {n['zeta_p']:.3g})"
             for n in pack["notches"]]
    if pack.get("lpf_hz") is not None:
        parts.append(f"low-pass {fmt(pack['lpf_hz'], 'Hz')} (order {pack['lpf_order']})")
    typer.echo(f"filters ({record.get('choice', 'identical')}): {', '.join(parts) or 'none'}")
    for line in record.get("chosen", []):
        typer.echo(f"  {line}")
    if record.get("choice") == "own" and not record.get("chosen"):
        typer.echo(f"  {record.get('why', '')}")


def objective_options(objective: str | None, compliance_max: float | None, structure: str):
    """The objective of ``--objective`` / ``--compliance-max`` (checked before any work)."""
    from ..errors import UsageError
    from ..tune.search import OBJECTIVES, Objective

    if objective is not None and objective not in OBJECTIVES:
        raise UsageError(f"--objective must be one of {', '.join(OBJECTIVES)}, got {objective!r}")
    if compliance_max is not None and structure not in ("mcppc", "ppi"):
        raise UsageError(f"--compliance-max caps the ball screw's axial-mode compliance; {structure} has none")
    return Objective.of(objective, compliance_max)


def print_objective(tuning: dict) -> None:
    """The objective used, the winner's integral gain, the Pareto front when asked for, and the warnings (a winner
    on a search bound)."""
    g = tuning.get("integral_gain")
    if tuning.get("objective_rule"):
        typer.echo(f"objective: {tuning['objective_rule']}")
    if g:
        xo = tuning.get("first_crossover_hz")
        typer.echo(f"  winner: {g['name']} {g['value']:.5g} {g['unit']}, first crossover {fmt(xo, 'Hz')}"
                   + ("" if tuning.get("axial_compliance_rad_per_V") is None else
                      f", axial-mode compliance {tuning['axial_compliance_rad_per_V']:.4g} rad/V"))
    front = tuning.get("pareto_front")
    if front:
        typer.echo(f"  Pareto front ({len(front)} designs; first crossover against {g['name']} [{g['unit']}]):")
        for p in front:
            shape = ", ".join(f"{k} {v:.4g}" for k, v in p["shape"].items())
            mark = "  <- chosen" if abs(p["integral_gain"] - g["value"]) <= 1e-9 * abs(g["value"]) else ""
            typer.echo(f"    {fmt(p['first_crossover_hz'], 'Hz'):>12s}  {p['integral_gain']:12.5g}  ({shape}){mark}")
    for w in tuning.get("warnings", []):
        typer.echo(f"  warning: {cli_text(w)}")


def _report_tuned(title: str, delivery, result: dict, out: Path | None, force: bool, as_json: bool) -> bool:
    """Refuse a tuned design that fails its certificate (the gains file as written), write it, print the JSON; True
    when the JSON was printed (nothing else to print)."""
    from .delivery import write_delivery

    write_delivery(delivery, out, force, None, f"tuned {title}")
    if out is not None:
        result["out"] = str(out)
    if as_json:
        from .envelope import design_result, emit

        doc = delivery.document
        if "gains" not in result:  # the x axis: the gains as the file holds them
            result = {**result, "gains": {k: v["value"] for k, v in doc["gains"].items()},
                      "gain_units": {k: v["unit"] for k, v in doc["gains"].items()}}
        emit(design_result(result, doc.get("kind")), check=delivery.check_dict(OPTION_NAMES))
        return True
    return False


def _tune_ballscrew(structure: str, model_file: Path, frf: list[Path] | None, pack, filters: str | None,
                    fs: float | None, delay_samples: int | None, quantity: str | None, policy, out: Path | None,
                    force: bool, as_json: bool, fs_override: bool = False, frf_options=None, objective=None) -> None:
    """Tune a ball-screw structure on every FRF, certify the gains file as written, write it, print the result."""
    from ..control.ballscrew_law import all_gain_units
    from ..io.document import ensure_document_writable
    from ..tune.mcppc import tune_mcppc
    from ..tune.ppi import tune_ppi
    from ..workflows.deliver import deliver

    choice = _filter_choice(filters, pack.notches, pack.lpf_hz)
    if out is not None:
        ensure_document_writable(out, force)  # refused before the search, not after it
    model = _load_model(model_file)
    frfs = _frfs(frf, quantity, frf_options)
    rate = target_sampling(fs, delay_samples, [(s.name, s.frf) for s in frfs], default_fs=DEFAULT_FS[structure],
                           override=fs_override)
    rate.report(as_json, f"tune {structure}")
    fs, delay_samples = rate.fs_hz, rate.delay_samples
    tuner = {"mcppc": tune_mcppc, "ppi": tune_ppi}[structure]
    design = tuner(model, limits=policy, filters=pack, fs=fs, delay_samples=delay_samples,
                   frf=[s.frf for s in frfs] or None, filter_choice=choice, objective=objective)
    delivery = deliver(design, frfs, policy, where="tuned design")
    gains = {**design.gains, **getattr(design, "ppi_gains", {})}
    units = all_gain_units(model.input_unit)
    result = {"kind": "ballscrew", "controller": design.kind, "gains": gains, "gain_units": units,
              "filters": design.filters.to_dict(), "filter_choice": design.tuning.get("filters", {"choice": choice}),
              "design": design.design_dict(), "certificate": delivery.certificate.to_dict(OPTION_NAMES),
              **rate.to_json()}
    if _report_tuned(TITLES[structure], delivery, result, out, force, as_json):
        return
    typer.echo(f"{TITLES[structure]} tuned: " + ", ".join(f"{k} {fmt(v, units.get(k, ''))}"
                                                          for k, v in gains.items()))
    print_objective(design.tuning)
    print_filters(result["filters"], result["filter_choice"])
    print_certificate(result["certificate"])
    if out is not None:
        typer.echo(f"wrote {out}")


def _tune_axis(plant_file: Path, frf: list[Path] | None, pack, filters: str | None, fs: float | None,
               delay_samples: int | None, quantity: str | None, policy, out: Path | None, force: bool, as_json: bool,
               fs_override: bool = False, frf_options=None, objective=None) -> None:
    """Tune an x axis by loop shaping on every FRF, certify, write, print."""
    from ..io import load_model
    from ..io.document import ensure_document_writable
    from ..machines.certificate import FrfSource
    from ..tune.loopshape import tune_loopshape
    from ..workflows.deliver import deliver
    from .frf_options import read_optional_frf

    choice = _filter_choice(filters, pack.notches, pack.lpf_hz)
    if out is not None:
        ensure_document_writable(out, force)
    if plant_file.suffix.lower() in (".toml", ".json"):
        plant = load_model(plant_file)
    else:
        plant = read_optional_frf(plant_file, quantity, options=frf_options)
    frfs = _frfs(frf, quantity, frf_options)
    plant_frf = [] if plant_file.suffix.lower() in (".toml", ".json") else [FrfSource.from_file(plant_file, plant)]
    rate = target_sampling(fs, delay_samples, [(s.name, s.frf) for s in plant_frf + frfs],
                           default_fs=DEFAULT_FS["loopshape"], override=fs_override)
    rate.report(as_json, "tune loopshape")
    fs, delay_samples = rate.fs_hz, rate.delay_samples
    design = tune_loopshape(plant, limits=policy, filters=pack, fs=fs, delay_samples=delay_samples,
                            frf=[s.frf for s in frfs] or None, filter_choice=choice, objective=objective)
    delivery = deliver(design, plant_frf + [s for s in frfs if s.name != str(plant_file)], policy,
                       where="tuned design")
    tuning = design.tuning
    result = {"kind": "axis", "controller": "loopshape", "design": design.design_dict(),
              "filters": design.filters.to_dict(), "certificate": delivery.certificate.to_dict(OPTION_NAMES),
              **rate.to_json()}
    if _report_tuned("loop-shaping design", delivery, result, out, force, as_json):
        return
    typer.echo(f"x-axis loop shaping tuned: crossover {fmt(tuning['crossover_hz'], 'Hz')}, PM target "
               f"{fmt(tuning['pm_target_deg'], 'deg')}, integral lag {fmt(tuning['pi_lag_deg'], 'deg')}, "
               f"{tuning['lead_stages']} lead stage(s)")
    print_objective(tuning)
    print_filters(result["filters"], tuning.get("filters", {"choice": choice}))
    print_certificate(result["certificate"])
    if out is not None:
        typer.echo(f"wrote {out}")


def _positioned_frfs(paths: list[Path] | None, xs: list[float] | None, quantity: str | None, frf_options=None):
    """Gantry FRFs as certification sources, each carrying its table position (``--x`` or its own ``x_m``)."""
    from dataclasses import replace

    from ..tune.gantry_cases import frf_positions

    frfs = _frfs(paths, quantity, frf_options)
    if xs and not frfs:
        from ..errors import UsageError

        raise UsageError("--x gives the table position of each --frf; without --frf use --design-x")
    positions = frf_positions([s.frf for s in frfs], xs or None, 0.0)
    return [replace(s, name=f"{s.name} (x = {x:g} m)", frf=replace(s.frf, meta={**s.frf.meta, "x_m": repr(float(x))}))
            for s, x in zip(frfs, positions, strict=True)]


def _tune_gantry(structure: str, model_file: Path, frf: list[Path] | None, xs: list[float] | None, design_x: float,
                 filters_pack, filters: str | None, fs: float | None, delay_samples: int | None, quantity: str | None,
                 policy, out: Path | None, force: bool, as_json: bool, fs_override: bool = False,
                 frf_options=None, objective=None) -> None:
    """Tune the gantry MIMO law or the PID pair on every FRF at its position, certify, write, print."""
    from ..io.document import ensure_document_writable
    from ..tune.gantry import tune_gantry_mimo
    from ..tune.pid import tune_gantry_pid
    from ..workflows.deliver import deliver
    from .design_gantry_cmd import _gantry_model

    if out is not None:
        ensure_document_writable(out, force)
    model = _gantry_model(model_file)
    frfs = _positioned_frfs(frf, xs, quantity, frf_options)
    rate = target_sampling(fs, delay_samples, [(s.name, s.frf) for s in frfs], default_fs=DEFAULT_FS[structure],
                           override=fs_override)
    rate.report(as_json, f"tune {structure}")
    fs, delay_samples = rate.fs_hz, rate.delay_samples
    common = {"limits": policy, "filters": filters_pack, "fs": fs, "delay_samples": delay_samples, "x": design_x,
              "frf": [s.frf for s in frfs] or None, "objective": objective}
    choice = _filter_choice(filters, filters_pack.notches, filters_pack.lpf_hz)
    tuner = tune_gantry_mimo if structure == "gantry" else tune_gantry_pid
    design = tuner(model, filter_choice=choice, **common)
    tuning = design.tuning
    record = tuning.get("filters", {"choice": choice})
    delivery = deliver(design, frfs, policy, where="tuned design")
    doc = delivery.document
    gains = {k: v["value"] for k, v in doc["gains"].items()}
    units = {k: v["unit"] for k, v in doc["gains"].items()}
    if design.controller == "mimo":
        gains["lead_gain"], units["lead_gain"] = design.law.lead_gain, f"{model.input_unit}/m"
    result = {"kind": "gantry", "controller": design.controller, "design_x_m": design.x, "gains": gains,
              "gain_units": units, "filters": design.law.filters.to_dict(), "filter_choice": record,
              "design": design.design_dict(), "certificate": delivery.certificate.to_dict(OPTION_NAMES),
              **rate.to_json()}
    if _report_tuned(TITLES[structure], delivery, result, out, force, as_json):
        return
    shape = (f"CoM crossover target {fmt(design.crossover_hz, 'Hz')}, PM target {fmt(design.pm_deg, 'deg')}, "
             f"damping increase {design.damping_increase:g}" if structure == "gantry" else
             f"bandwidth {fmt(tuning['bandwidth_hz'], 'Hz')}, zeta {tuning['zeta']:.3g}, rho {tuning['rho']:.3g}")
    typer.echo(f"{TITLES[structure]} tuned ({shape}): "
               + ", ".join(f"{k} {fmt(v, units.get(k, ''))}" for k, v in gains.items()))
    print_objective(tuning)
    print_filters(result["filters"], record)
    print_certificate(result["certificate"])
    if out is not None:
        typer.echo(f"wrote {out}")


TITLES = {"mcppc": "MC-PPC", "ppi": "P-PI", "gantry": "MIMO", "pid": "PID", "loopshape": "x-axis loop shaping"}
"""The structures ``feedtune tune`` tunes and their names (:data:`feedtune.control.names.CONTROLLER_NAMES`; the
``gantry`` structure is the MIMO law)."""


def tune(
    structure: str = typer.Argument(
        ..., **choice(TITLES, "STRUCTURE"),
        help="mcppc (MC-PPC: beta, pole frequency, zeta), ppi (P-PI cascade: Kpx, Kpv, Kiv), gantry (MIMO law: CoM "
             "crossover, PM target, damping), pid (independent PIDs: bandwidth, zeta, rho) or loopshape (x axis: "
             "crossover, PM target, lag, lead stages).",
    ),
    model_file: Path = typer.Argument(
        ..., metavar="MODEL",
        help="mcppc, ppi: ball-screw model file ('feedtune identify ballscrew'); gantry, pid: gantry model file "
             "('feedtune identify gantry'); loopshape: a model file (a gantry model's m_x, a rigid-body model's mass) "
             "or a measured SISO FRF.",
    ),
    frf: list[Path] = FRFS_OPTION,
    x: list[float] = X_OPTION,
    design_x: float = DESIGN_X_OPTION,
    notch: list[str] = NOTCH_OPTION,
    lpf: float = LPF_OPTION,
    lpf_order: int = LPF_ORDER_OPTION,
    lead: list[str] = LEAD_OPTION,
    filters: str = FILTERS_OPTION,
    objective: str = OBJECTIVE_OPTION,
    compliance_max: float = COMPLIANCE_MAX_OPTION,
    fs: float = FS_OPTION,
    delay_samples: int = DELAY_OPTION,
    fs_override: bool = FS_OVERRIDE_OPTION,
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
    as_json: bool = JSON_OPTION,
    quiet: bool = QUIET_OPTION,
) -> None:
    """Tune for every measured FRF under the limits, and certify it.

    Tune a controller for the objective (default stiffness: the highest integral gain; bandwidth: the highest first
    crossover; pareto: both, the front printed) among those that meet the limits on every measured FRF, and certify it.

    mcppc tunes beta, the pole frequency and zeta of eq. 3.5-3.13; ppi tunes Kpx, Kpv and Kiv (Figure 3.9) by the
    rule of 'feedtune design ppi'; with --filters own also the notches and low-pass. gantry tunes the MIMO law of
    eq. 4.30 (CoM crossover, phase-margin target, active damping, integral gain), pid the independent PIDs (with
    --filters own, both also the notches and low-pass of h(s)); each gantry FRF is checked at its table position.
    loopshape tunes an x axis (eq. 4.17-4.18), with --filters own also its notches and low-pass. Without --frf, on the
    model in the ideal discrete case.

    On a gantry measured at two positions: feedtune tune gantry gantry_model.toml --frf frf_x-0.3.csv --frf
    frf_x0.3.csv --notch 110,0.5,0.7 --lpf 450 --lead 154,70 -o mimo_gains.toml"""
    show_progress(quiet)
    from ..errors import UsageError
    from .design_gantry_cmd import _loop_filters
    from .frf_options import FrfReadOptions

    if structure not in TITLES:
        raise UsageError(f"STRUCTURE must be one of {', '.join(TITLES)}, got {structure!r}")
    policy = limits_from_options(limits, ms_max, pm_min, gm_min, dm_min, gm_low_min)
    goal = objective_options(objective, compliance_max, structure)
    frf_options = FrfReadOptions.from_cli(frf_map, frf_skip_rows, frf_scale, frf_channel, frf_input_unit)
    gantry = structure in ("gantry", "pid")
    if x and not gantry:
        raise UsageError(f"--x gives gantry FRF positions; {structure} has none")
    if lead and structure in ("mcppc", "ppi"):
        raise UsageError(f"--lead: the {TITLES[structure]} filter pack holds notches and a low-pass only")
    order = (2 if gantry else 1) if lpf_order is None else lpf_order
    if order not in (1, 2):
        raise UsageError(f"--lpf-order must be 1 or 2, got {order}")
    if gantry:
        pack = _loop_filters(notch, lpf, order, 0.7, lead)
        _tune_gantry(structure, model_file, frf, x, design_x, pack, filters, fs, delay_samples, quantity, policy, out,
                     force, as_json, fs_override=fs_override, frf_options=frf_options, objective=goal)
        return
    if structure == "loopshape":
        _tune_axis(model_file, frf, _loop_filters(notch, lpf, order, 0.7, lead), filters, fs, delay_samples,
                   quantity, policy, out, force, as_json, fs_override=fs_override, frf_options=frf_options,
                   objective=goal)
        return
    _tune_ballscrew(structure, model_file, frf, _loop_filters(notch, lpf, order, 0.7, None), filters, fs,
                    delay_samples, quantity, policy, out, force, as_json, fs_override=fs_override,
                    frf_options=frf_options, objective=goal)
