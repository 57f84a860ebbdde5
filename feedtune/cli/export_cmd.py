"""``feedtune export``: gains files in target formats."""

from __future__ import annotations

from pathlib import Path

import typer

from ..export.c_common import float_bound_text
from .common import FORCE_OPTION, JSON_OPTION
from .design_cmd import QUANTITY_OPTION
from .frf_options import (
    FRF_CHANNEL_OPTION,
    FRF_INPUT_UNIT_OPTION,
    FRF_MAP_OPTION,
    FRF_SCALE_OPTION,
    FRF_SKIP_ROWS_OPTION,
)
from .help_text import ANTI_WINDUP, choice
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

app = typer.Typer(rich_markup_mode="rich", help="Export gains files for real-time targets.", no_args_is_help=True)


def scale_factor_option(text: str | None) -> float | None:
    """``--scale-out``: a number or a ratio ``A/B`` (``1/35.15065``), finite and non-zero; UsageError otherwise."""
    import math

    from ..errors import UsageError

    if text is None:
        return None
    num, sep, den = str(text).partition("/")
    try:
        value = float(num) / float(den) if sep else float(num)
    except (ValueError, ZeroDivisionError):
        raise UsageError(f"--scale-out expects a number or a ratio A/B (e.g. 1/35.15065), got {text!r}") from None
    if not math.isfinite(value) or value == 0:
        raise UsageError(f"--scale-out expects a finite non-zero factor, got {text!r}")
    return value


def checked_for_export(doc: dict, gains_file: Path, sources, policy, allow_unstable: bool, as_json: bool,
                       command: str):
    """``(verdict, warning)``: the gains file's verdict (certified anew on ``sources``, by its certificate, or on its
    model), printed; DesignError when it fails and not ``allow_unstable``; ``warning`` is the line the exported file
    carries (None for a certified pass)."""
    from ..errors import DesignError
    from ..machines.certificate import UNCERTIFIED_HINT, gains_verdict
    from .envelope import warn

    verdict = gains_verdict(doc, str(gains_file), sources, policy)
    for note in verdict.notes:
        if note == verdict.stored.problem():
            warn(note)
        elif not as_json:
            typer.echo(f"note: {note}")
    hint = "" if verdict.certified else f"; to certify it: {UNCERTIFIED_HINT.format(command=command)}"
    basis = verdict.basis_text()
    warning = None
    if not verdict.ok:
        msg = "; ".join(verdict.certificate.violations(OPTION_NAMES))
        if not allow_unstable:
            raise DesignError(f"{gains_file}: {msg} ({basis}); not exported (use --allow-unstable to export it "
                              f"anyway{hint})")
        warning = f"this design fails the limits check ({policy.describe()}; {basis}): {msg}"
        warn(f"{msg} (exported because of --allow-unstable)")
    elif not verdict.certified:
        warning = (f"this design is not certified on a measured FRF: it passes the limits ({policy.describe()}) on "
                   "its design model alone")
        warn(f"{gains_file}: exported on the design model's check alone, not certified on a measured FRF{hint}")
    return verdict, warning


@app.command("c")
def export_c(
    gains_file: Path = typer.Argument(
        ..., metavar="GAINS",
        help="Gains file (.toml or .json) from 'feedtune design' or 'tune': ball screw, gantry (MIMO or PID) or x "
             "axis.",
    ),
    out: Path = typer.Option(
        None, "--out", "-o", metavar="FILE",
        help="Header to write (default: GAINS with suffix .h).",
    ),
    prefix: str = typer.Option("ft", "--prefix", metavar="NAME", help="Prefix of the C identifiers."),
    u_max: float = typer.Option(
        None, "--u-max", metavar="U",
        help="Output limit in the command unit of the file: every command is clamped to +-U_MAX. Default: no limit "
             "(said in the header).",
    ),
    scale_out: str = typer.Option(
        None, "--scale-out", metavar="FACTOR",
        help="Multiply every command by FACTOR [drive unit per command unit of the file], a number or a ratio A/B, "
             "so that the header outputs the drive's unit, e.g. 1/35.15065 for a design in N on a drive taking V at "
             "35.15 N/V; --u-max is then in the drive's unit.",
    ),
    out_unit: str = typer.Option(
        None, "--out-unit", metavar="UNIT", help="The drive's unit of the scaled command (with --scale-out), e.g. V.",
    ),
    anti_windup: str = typer.Option("none", "--anti-windup", **choice(ANTI_WINDUP),
                                    help="clamp: an integrator stops integrating while its command sits at --u-max "
                                         "and the error drives it further (conditional integration)."),
    single: bool = typer.Option(False, "--float", help="Single precision: float states, coefficients and "
                                                        "arithmetic (no double operation), the filters rewritten in "
                                                        "difference form so that, fed the same inputs, the commands "
                                                        f"stay within {float_bound_text()} x the peak command of the "
                                                        "double header (docs/export.md). Default: double."),
    limits: str = LIMITS_OPTION,
    ms_max: float = MS_MAX_OPTION,
    pm_min: float = PM_MIN_OPTION,
    gm_min: float = GM_MIN_OPTION,
    gm_low_min: float = GM_LOW_MIN_OPTION,
    dm_min: float = DM_MIN_OPTION,
    frf: list[Path] = typer.Option(
        None, "--frf", metavar="FRF",
        help="Measured FRF to certify the gains on before exporting (repeatable; gantry FRFs at their recorded "
             "positions); compared with the file's certificate by digest. Without --frf: the file's certificate "
             "while it holds for its gains, else the design model (the header then says it is uncertified).",
    ),
    quantity: str = QUANTITY_OPTION,
    frf_map: list[str] = FRF_MAP_OPTION,
    frf_skip_rows: int = FRF_SKIP_ROWS_OPTION,
    frf_scale: list[str] = FRF_SCALE_OPTION,
    frf_channel: str = FRF_CHANNEL_OPTION,
    frf_input_unit: str = FRF_INPUT_UNIT_OPTION,
    allow_unstable: bool = typer.Option(False, "--allow-unstable", help="Export a design that fails the limits "
                                                                        "check (the header then says so)."),
    force: bool = FORCE_OPTION,
    as_json: bool = JSON_OPTION,
    quiet: bool = QUIET_OPTION,
) -> None:
    """Write a C header that runs a gains file sample by sample.

    Write a self-contained C header that runs the controller sample by sample.

    The design is checked first: certified anew on the --frf files, else by the file's own certificate while it holds
    for its gains (its figures judged under the limits asked for), else on the design model alone (then the header
    and a warning say it is not certified). A design that fails is not exported unless --allow-unstable."""
    show_progress(quiet)
    from ..export.c_header import c_header
    from ..io import atomic_write_text, read_document
    from ..io.atomic import ensure_writable
    from .delivery import read_sources
    from .frf_options import FrfReadOptions

    policy = limits_from_options(limits, ms_max, pm_min, gm_min, dm_min, gm_low_min)
    frf_options = FrfReadOptions.from_cli(frf_map, frf_skip_rows, frf_scale, frf_channel, frf_input_unit)
    precision = "float" if single else "double"
    target = out or gains_file.with_suffix(".h")
    ensure_writable(target, force)
    doc = read_document(gains_file)
    scaling = {"scale_out": scale_factor_option(scale_out), "out_unit": out_unit}
    c_header(doc, prefix=prefix, where=str(gains_file), u_max=u_max, anti_windup=anti_windup,
             precision=precision, **scaling)  # options, document
    sources = read_sources(list(frf or []), quantity, frf_options)
    verdict, warning = checked_for_export(doc, gains_file, sources, policy, allow_unstable, as_json, "export c")
    text = c_header(doc, prefix=prefix, where=str(gains_file), u_max=u_max, anti_windup=anti_windup, warning=warning,
                    precision=precision, **scaling)
    atomic_write_text(target, text, force=force)
    if as_json:
        from .envelope import emit

        emit({"gains_kind": doc.get("kind"), "out": str(target), "prefix": prefix,
              "bytes": len(text.encode()), "u_max": u_max, "anti_windup": anti_windup, "precision": precision,
              **scaling,
              "check": verdict.certificate.check_dict(OPTION_NAMES), "verdict": verdict.to_dict(OPTION_NAMES)})
    else:
        typer.echo(f"verdict on {verdict.basis_text()}: {'passes' if verdict.ok else 'FAILS'} ({policy.describe()})")
        typer.echo(f"wrote {target}")
