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
    GM_MIN_OPTION,
    LIMITS_OPTION,
    MS_MAX_OPTION,
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


def _frfs(paths: list[Path] | None, quantity: str | None, frf_options=None) -> list[tuple[str, object]]:
    from .frf_options import read_optional_frf

    return [(str(p), read_optional_frf(p, quantity, options=frf_options)) for p in paths or []]


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


def print_certificate(cert: dict) -> None:
    """One line per FRF and the worst case, with the active limit."""
    typer.echo(f"certificate ({cert['limits']['profile']} limits; discrete case, every FRF):")
    for c in cert["frfs"]:
        first = c["crossovers_hz"][0] if c["crossovers_hz"] else None
        verdict = "ok" if c["ok"] else "FAILS: " + "; ".join(c["violations"])
        typer.echo(f"  {c['frf']}: first crossover {fmt(first, 'Hz')}, Ms {c['ms']:.3g} at {fmt(c['ms_freq_hz'], 'Hz')}"
                   f", PM {fmt(c['pm_deg'], 'deg')}, GM {fmt(c['gm_db'], 'dB')}, DM {c['disk_margin']:.3g}, "
                   f"{'stable' if c['stable'] else 'UNSTABLE'}: {verdict}")
    w = cert["worst"]
    act = w["active_limit"]
    active = "none" if act is None else f"{act['name']} = {act['value']:.4g} (limit {act['limit']:g}) on {act['frf']}"
    typer.echo(f"  worst: first crossover {fmt(w['first_crossover_hz'], 'Hz')} ({w['first_crossover_hz_frf']}), "
               f"Ms {w['ms']:.3g} ({w['ms_frf']}); active limit: {active}")


def _write_certified(title: str, doc: dict, cert, result: dict, out: Path | None, force: bool,
                     as_json: bool) -> bool:
    """Refuse a design that fails its certificate (the gains file as written), write it, print the JSON; True when
    the JSON was printed (nothing else to print)."""
    from ..errors import DesignError
    from ..io import write_document

    if not cert.ok:  # the tuner re-checks its winner on every FRF; this is the gains file as written
        raise DesignError(f"the tuned {title} fails its certificate: "
                          + "; ".join(v for c in cert.frfs for v in c.check.violations))
    if out is not None:
        write_document(out, doc, force=force)
        result["out"] = str(out)
    if as_json:
        from .envelope import design_result, emit

        if "gains" not in result:  # the x axis: the gains as the file holds them
            result = {**result, "gains": {k: v["value"] for k, v in doc["gains"].items()},
                      "gain_units": {k: v["unit"] for k, v in doc["gains"].items()}}
        emit(design_result(result, doc.get("kind")), check=certificate_check(cert))
        return True
    return False


def certificate_check(cert) -> dict:
    """The ``check`` of ``tune --json``: the certificate's verdict in the layout of ``design``'s check. ``violations``
    and ``items`` of every FRF, each named by its FRF; ``active`` the limit closest to binding over all FRFs."""
    from .limits_options import OPTION_NAMES

    worst = cert.worst()
    active = worst.get("active_limit")
    return {"checked_case": cert.frfs[0].checked_case if cert.frfs else None, "ok": cert.ok,
            "limits": cert.limits.to_dict(),
            "violations": [f"{c.name}: {v}" for c in cert.frfs for v in c.check.violations_named(OPTION_NAMES)],
            "items": [{**i.to_dict(), "frf": c.name} for c in cert.frfs for i in c.check.items],
            "active": None if active is None else active["name"]}


def _tune_ballscrew(structure: str, model_file: Path, frf: list[Path] | None, pack, filters: str | None,
                    fs: float | None, delay_samples: int | None, quantity: str | None, policy, out: Path | None,
                    force: bool, as_json: bool, fs_override: bool = False, frf_options=None) -> None:
    """Tune a ball-screw structure on every FRF, certify the gains file as written, write it, print the result."""
    from ..control.ballscrew_law import all_gain_units
    from ..io.atomic import ensure_writable
    from ..io.document import strip_none
    from ..io.gains import gains_document
    from ..machines.certificate import certify
    from ..tune.mcppc import tune_mcppc
    from ..tune.ppi import tune_ppi

    choice = _filter_choice(filters, pack.notches, pack.lpf_hz)
    if out is not None:
        ensure_writable(out, force)  # refused before the search, not after it
    model = _load_model(model_file)
    frfs = _frfs(frf, quantity, frf_options)
    rate = target_sampling(fs, delay_samples, frfs, default_fs=DEFAULT_FS[structure], override=fs_override)
    rate.report(as_json, f"tune {structure}")
    fs, delay_samples = rate.fs_hz, rate.delay_samples
    tuner = {"mcppc": tune_mcppc, "ppi": tune_ppi}[structure]
    design = tuner(model, limits=policy, filters=pack, fs=fs, delay_samples=delay_samples,
                   frf=[f for _, f in frfs] or None, filter_choice=choice)
    doc = gains_document(design)
    cert = certify(doc, "tuned design", frfs or [("model", None)], policy)
    doc["certificate"] = strip_none(cert.to_dict())
    gains = {**design.gains, **getattr(design, "ppi_gains", {})}
    units = all_gain_units(model.input_unit)
    result = {"kind": "ballscrew", "controller": design.kind, "gains": gains, "gain_units": units,
              "filters": design.filters.to_dict(), "filter_choice": design.tuning.get("filters", {"choice": choice}),
              "design": design.design_dict(), "certificate": cert.to_dict(), **rate.to_json()}
    if _write_certified(TITLES[structure], doc, cert, result, out, force, as_json):
        return
    typer.echo(f"{TITLES[structure]} tuned: " + ", ".join(f"{k} {fmt(v, units.get(k, ''))}"
                                                          for k, v in gains.items()))
    print_filters(result["filters"], result["filter_choice"])
    print_certificate(result["certificate"])
    if out is not None:
        typer.echo(f"wrote {out}")


def _tune_axis(plant_file: Path, frf: list[Path] | None, pack, filters: str | None, fs: float | None,
               delay_samples: int | None, quantity: str | None, policy, out: Path | None, force: bool, as_json: bool,
               fs_override: bool = False, frf_options=None) -> None:
    """Tune an x axis by loop shaping on every FRF, certify, write, print."""
    from ..io import load_model
    from ..io.atomic import ensure_writable
    from ..io.document import strip_none
    from ..io.gantry_gains import axis_gains_document
    from ..machines.certificate import certify
    from ..tune.loopshape import tune_loopshape
    from .frf_options import read_optional_frf

    choice = _filter_choice(filters, pack.notches, pack.lpf_hz)
    if out is not None:
        ensure_writable(out, force)
    if plant_file.suffix.lower() in (".toml", ".json"):
        plant = load_model(plant_file)
    else:
        plant = read_optional_frf(plant_file, quantity, options=frf_options)
    frfs = _frfs(frf, quantity, frf_options)
    plant_frf = [] if plant_file.suffix.lower() in (".toml", ".json") else [(str(plant_file), plant)]
    rate = target_sampling(fs, delay_samples, plant_frf + frfs, default_fs=DEFAULT_FS["loopshape"],
                           override=fs_override)
    rate.report(as_json, "tune loopshape")
    fs, delay_samples = rate.fs_hz, rate.delay_samples
    design = tune_loopshape(plant, limits=policy, filters=pack, fs=fs, delay_samples=delay_samples,
                            frf=[f for _, f in frfs] or None, filter_choice=choice)
    doc = axis_gains_document(design)
    cert = certify(doc, "tuned design", frfs or [("model", None)], policy)
    doc["certificate"] = strip_none(cert.to_dict())
    tuning = design.tuning
    result = {"kind": "axis", "controller": "loopshape", "design": design.design_dict(),
              "filters": design.filters.to_dict(), "certificate": cert.to_dict(), **rate.to_json()}
    if _write_certified("loop-shaping design", doc, cert, result, out, force, as_json):
        return
    typer.echo(f"x-axis loop shaping tuned: crossover {fmt(tuning['crossover_hz'], 'Hz')}, PM target "
               f"{fmt(tuning['pm_target_deg'], 'deg')}, integral lag {fmt(tuning['pi_lag_deg'], 'deg')}, "
               f"{tuning['lead_stages']} lead stage(s)")
    print_filters(result["filters"], tuning.get("filters", {"choice": choice}))
    print_certificate(result["certificate"])
    if out is not None:
        typer.echo(f"wrote {out}")


def _positioned_frfs(paths: list[Path] | None, xs: list[float] | None, quantity: str | None, frf_options=None):
    """``[(name, Frf)]`` of gantry FRFs, each carrying its table position (``--x`` or its own ``x_m``)."""
    from dataclasses import replace

    from ..tune.gantry_cases import frf_positions

    frfs = _frfs(paths, quantity, frf_options)
    if xs and not frfs:
        from ..errors import UsageError

        raise UsageError("--x gives the table position of each --frf; without --frf use --design-x")
    positions = frf_positions([f for _, f in frfs], xs or None, 0.0)
    return [(f"{name} (x = {x:g} m)", replace(f, meta={**f.meta, "x_m": repr(float(x))}))
            for (name, f), x in zip(frfs, positions, strict=True)]


def _tune_gantry(structure: str, model_file: Path, frf: list[Path] | None, xs: list[float] | None, design_x: float,
                 filters_pack, filters: str | None, fs: float | None, delay_samples: int | None, quantity: str | None,
                 policy, out: Path | None, force: bool, as_json: bool, fs_override: bool = False,
                 frf_options=None) -> None:
    """Tune the gantry MIMO law or the PID pair on every FRF at its position, certify, write, print."""
    from ..io.atomic import ensure_writable
    from ..io.document import strip_none
    from ..io.gantry_gains import gantry_gains_document
    from ..machines.certificate import certify
    from ..tune.gantry import tune_gantry_mimo
    from ..tune.pid import tune_gantry_pid
    from .design_gantry_cmd import _gantry_model

    if out is not None:
        ensure_writable(out, force)
    model = _gantry_model(model_file)
    frfs = _positioned_frfs(frf, xs, quantity, frf_options)
    rate = target_sampling(fs, delay_samples, frfs, default_fs=DEFAULT_FS[structure], override=fs_override)
    rate.report(as_json, f"tune {structure}")
    fs, delay_samples = rate.fs_hz, rate.delay_samples
    common = {"limits": policy, "filters": filters_pack, "fs": fs, "delay_samples": delay_samples, "x": design_x,
              "frf": [f for _, f in frfs] or None}
    choice = _filter_choice(filters, filters_pack.notches, filters_pack.lpf_hz)
    tuner = tune_gantry_mimo if structure == "gantry" else tune_gantry_pid
    design = tuner(model, filter_choice=choice, **common)
    tuning = design.tuning
    record = tuning.get("filters", {"choice": choice})
    doc = gantry_gains_document(design)
    cert = certify(doc, "tuned design", frfs or [("model", None)], policy)
    doc["certificate"] = strip_none(cert.to_dict())
    gains = {k: v["value"] for k, v in doc["gains"].items()}
    units = {k: v["unit"] for k, v in doc["gains"].items()}
    if design.controller == "mimo":
        gains["lead_gain"], units["lead_gain"] = design.law.lead_gain, f"{model.input_unit}/m"
    result = {"kind": "gantry", "controller": design.controller, "design_x_m": design.x, "gains": gains,
              "gain_units": units, "filters": design.law.filters.to_dict(), "filter_choice": record,
              "design": design.design_dict(), "certificate": cert.to_dict(), **rate.to_json()}
    if _write_certified(TITLES[structure], doc, cert, result, out, force, as_json):
        return
    shape = (f"CoM crossover target {fmt(design.crossover_hz, 'Hz')}, PM target {fmt(design.pm_deg, 'deg')}, "
             f"damping increase {design.damping_increase:g}" if structure == "gantry" else
             f"bandwidth {fmt(tuning['bandwidth_hz'], 'Hz')}, zeta {tuning['zeta']:.3g}, rho {tuning['rho']:.3g}")
    typer.echo(f"{TITLES[structure]} tuned ({shape}): "
               + ", ".join(f"{k} {fmt(v, units.get(k, ''))}" for k, v in gains.items()))
    print_filters(result["filters"], record)
    print_certificate(result["certificate"])
    for w in tuning.get("warnings", []):
        typer.echo(f"  warning: {cli_text(w)}")
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
    dm_min: float = DM_MIN_OPTION,
    out: Path = OUT_OPTION,
    force: bool = FORCE_OPTION,
    as_json: bool = JSON_OPTION,
    quiet: bool = QUIET_OPTION,
) -> None:
    """Tune for every measured FRF under the limits, and certify it.

    Tune a controller for the highest first crossover that meets the limits on every measured FRF, and certify it.

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
    policy = limits_from_options(limits, ms_max, pm_min, gm_min, dm_min)
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
                     force, as_json, fs_override=fs_override, frf_options=frf_options)
        return
    if structure == "loopshape":
        _tune_axis(model_file, frf, _loop_filters(notch, lpf, order, 0.7, lead), filters, fs, delay_samples,
                   quantity, policy, out, force, as_json, fs_override=fs_override, frf_options=frf_options)
        return
    _tune_ballscrew(structure, model_file, frf, _loop_filters(notch, lpf, order, 0.7, None), filters, fs,
                    delay_samples, quantity, policy, out, force, as_json, fs_override=fs_override,
                    frf_options=frf_options)
