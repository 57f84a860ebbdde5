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

from dataclasses import dataclass, field
from pathlib import Path

import typer

from ..structures import controllers
from . import cascade_cmd
from .common import FORCE_OPTION, JSON_OPTION, fmt
from .delivery import print_certificate
from .design_cmd import DELAY_OPTION, LPF_OPTION, NOTCH_OPTION, QUANTITY_OPTION
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
from .sampling_options import FS_OVERRIDE_OPTION

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


def objective_options(objective: str | None, compliance_max: float | None, plants, name: str):
    """The objective of ``--objective`` / ``--compliance-max`` (checked before any work) for the structure or
    machine ``name`` whose plant structures are ``plants``."""
    from ..errors import UsageError
    from ..tune.search import OBJECTIVES, Objective

    if objective is not None and objective not in OBJECTIVES:
        raise UsageError(f"--objective must be one of {', '.join(OBJECTIVES)}, got {objective!r}")
    if compliance_max is not None and not any(p.axial_mode for p in plants):
        raise UsageError(f"--compliance-max caps the ball screw's axial-mode compliance; {name} has none")
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


@dataclass(frozen=True)
class TuneRequest:
    """What ``feedtune tune`` was asked, options checked: the input of a structure's tuning command
    (:attr:`feedtune.structures.ControllerStructure.tune_command`, ``tune_command(entry, request)``).

    Attributes
    ----------
    plant_file : Path
        MODEL: a model file (or, where the structure takes one, a measured FRF).
    frf : list of Path
        The ``--frf`` files.
    xs : list of float
        ``--x``: the table position of each FRF [m] (structures whose plants are measured at positions).
    design_x : float
        ``--design-x`` [m].
    pack : FilterPack
        The filter pack of the options (candidates with ``--filters own``).
    filters : str or None
        ``--filters`` as given.
    fs : float or None
        ``--fs`` [Hz].
    delay_samples : int or None
        ``--delay-samples``.
    quantity : str or None
        ``--quantity`` of the FRF files.
    policy : Limits
        The limits.
    out : Path or None
        ``--out``.
    force, as_json, fs_override : bool
        ``--force``, ``--json``, ``--fs-override``.
    frf_options : FrfReadOptions
        How the FRF files are read.
    objective : Objective
        What the tuner maximises.
    options : dict
        The structure's own options (:attr:`feedtune.structures.ControllerStructure.options`) by name, as given
        (None when not given).
    """

    plant_file: Path
    frf: list
    xs: list
    design_x: float
    pack: object
    filters: str | None
    fs: float | None
    delay_samples: int | None
    quantity: str | None
    policy: object
    out: Path | None
    force: bool
    as_json: bool
    fs_override: bool
    frf_options: object
    objective: object
    options: dict = field(default_factory=dict)


def print_tuned(title: str, shape: str | None, gains: dict, units: dict, tuning: dict, filters: dict, record: dict,
                certificate: dict, out: Path | None) -> None:
    """What ``feedtune tune`` prints of a tuned design: its gains (or its shape alone when ``gains`` is empty), the
    objective, the filters, the certificate and the file written."""
    head = f"{title} tuned" + (f" ({shape})" if shape and gains else f": {shape}" if shape else "")
    typer.echo(head + (": " + ", ".join(f"{k} {fmt(v, units.get(k, ''))}" for k, v in gains.items()) if gains else ""))
    print_objective(tuning)
    print_filters(filters, record)
    print_certificate(certificate)
    if out is not None:
        typer.echo(f"wrote {out}")


TITLES = {c.command: c.title for c in controllers()}
"""The structures ``feedtune tune`` tunes (their command names) and their titles (:mod:`feedtune.structures`; the
``gantry`` structure is the MIMO law)."""


def tune(
    structure: str = typer.Argument(
        ..., **choice(TITLES, "STRUCTURE"),
        help="mcppc (MC-PPC: beta, pole frequency, zeta), ppi (P-PI cascade: Kpx, Kpv, Kiv), gantry (MIMO law: CoM "
             "crossover, PM target, damping), pid (independent PIDs: bandwidth, zeta, rho), loopshape (x axis: "
             "crossover, PM target, lag, lead stages) or cascade (a drive's speed PI with its current-setpoint "
             "filters, then Kv with feedforward).",
    ),
    model_file: Path = typer.Argument(
        ..., metavar="MODEL",
        help="mcppc, ppi: ball-screw model file ('feedtune identify ballscrew'); gantry, pid: gantry model file "
             "('feedtune identify gantry'); loopshape: a model file (a gantry model's m_x, a rigid-body model's mass) "
             "or a measured SISO FRF; cascade: a rigid-body or two-mass model, or the axis' measured FRF (current "
             "setpoint in, motor speed or position out).",
    ),
    frf: list[Path] = FRFS_OPTION,
    x: list[float] = X_OPTION,
    design_x: float = DESIGN_X_OPTION,
    notch: list[str] = NOTCH_OPTION,
    lpf: float = LPF_OPTION,
    lpf_order: int = LPF_ORDER_OPTION,
    lead: list[str] = LEAD_OPTION,
    filters: str = FILTERS_OPTION,
    drive_filter: list[str] = cascade_cmd.FILTER_OPTION,
    position_fs: float = cascade_cmd.POSITION_FS_OPTION,
    current_loop_hz: float = cascade_cmd.CURRENT_LOOP_OPTION,
    position_encoder: str = cascade_cmd.TUNE_ENCODER_OPTION,
    match_margins: Path = cascade_cmd.MATCH_OPTION,
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
    from ..structures import controller_by_command, plant, resolve
    from .design_gantry_cmd import _loop_filters
    from .frf_options import FrfReadOptions

    entry = controller_by_command(structure)
    plants = tuple(plant(p) for p in entry.plants)
    policy = limits_from_options(limits, ms_max, pm_min, gm_min, dm_min, gm_low_min)
    goal = objective_options(objective or entry.objective or None, compliance_max, plants, structure)
    frf_options = FrfReadOptions.from_cli(frf_map, frf_skip_rows, frf_scale, frf_channel, frf_input_unit)
    if x and not any(p.positions for p in plants):
        raise UsageError(f"--x gives gantry FRF positions; {structure} has none")
    if lead and not entry.lead_stages:
        raise UsageError(f"--lead: the {entry.title} filter pack holds notches and a low-pass only")
    own = {"--filter": drive_filter or None, "--position-fs": position_fs, "--current-loop-hz": current_loop_hz,
           "--position-encoder": position_encoder, "--match-margins": match_margins}
    foreign = next((k for k, v in own.items() if v is not None and k not in entry.options), None)
    if foreign is not None:
        takes = ", ".join(c.command for c in controllers() if foreign in c.options)
        raise UsageError(f"{foreign} is an option of tune {takes}; {structure} has none")
    order = entry.lpf_order if lpf_order is None else lpf_order
    if order not in (1, 2):
        raise UsageError(f"--lpf-order must be 1 or 2, got {order}")
    request = TuneRequest(model_file, list(frf or []), list(x or []), design_x,
                          _loop_filters(notch, lpf, order, 0.7, lead), filters, fs, delay_samples, quantity, policy,
                          out, force, as_json, fs_override, frf_options, goal,
                          {k: v for k, v in own.items() if k in entry.options})
    resolve(entry.tune_command)(entry, request)
