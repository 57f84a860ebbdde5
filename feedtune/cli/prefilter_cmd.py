"""``feedtune prefilter LOG``: least-squares trajectory pre-filter from one tracking run (thesis §3.2.4).

Fits ``K_vel .. K_snap`` (eq. 3.17-3.19) to the tracking error of the log and, with ``--gains`` and
``--out``, writes a copy of the gains file with a ``[prefilter]`` section that the runtime, the C header and
``feedtune simulate`` execute.
"""

from __future__ import annotations

from pathlib import Path

import typer

from .common import FORCE_OPTION, JSON_OPTION, fmt
from .envelope import emit, quantities
from .log_options import FS_OPTION, MAP_OPTION, SCALE_OPTION, SKIP_ROWS_OPTION, TIME_OPTION, UNIT_OPTION
from .progress_display import QUIET_OPTION, show_progress


def prefilter(
    log_file: Path = typer.Argument(
        ..., metavar="LOG",
        help="Tracking log (CSV, MATLAB, MDF4) with x_ref [m] and e2 or x2.",
    ),
    gains: Path = typer.Option(
        None, "--gains", "-g", metavar="GAINS",
        help="Gains file the run used (lead, sample rate; --out copy).",
    ),
    out: Path = typer.Option(
        None, "--out", "-o", metavar="FILE",
        help="Gains file to write: --gains plus [prefilter] (.toml+.json).",
    ),
    lpf_hz: float = typer.Option(
        80.0, "--lpf-hz", metavar="HZ",
        help="Pole frequency of the low-pass G in eq. 3.19 [Hz].",
    ),
    orders: str = typer.Option("vel,acc,jerk,snap", "--orders", metavar="TERMS", help="Terms to fit, comma separated."),
    reference: str = typer.Option(
        "x_ref", "--reference", metavar="COLUMN",
        help="Reference position signal [m] (v_ref.. used too).",
    ),
    error: str = typer.Option(
        None, "--error", metavar="COLUMN",
        help="Tracking error signal reference - measured [m] (default e2).",
    ),
    position: str = typer.Option(
        None, "--position", metavar="COLUMN",
        help="Measured table position, when there is no error signal (default x2_table, x2).",
    ),
    refine: bool = typer.Option(
        False, "--refine", help="The run already used the pre-filter of --gains: add the new gains to its gains."
    ),
    map_: list[str] = MAP_OPTION,
    fs: float = FS_OPTION,
    time: str = TIME_OPTION,
    scale: list[str] = SCALE_OPTION,
    unit: list[str] = UNIT_OPTION,
    skip_rows: int = SKIP_ROWS_OPTION,
    force: bool = FORCE_OPTION,
    as_json: bool = JSON_OPTION,
    quiet: bool = QUIET_OPTION,
) -> None:
    """Fit the trajectory pre-filter to one tracking run.

    Fit the least-squares trajectory pre-filter to one tracking run and add it to a gains file (eq. 3.16-3.20)."""
    show_progress(quiet)
    from ..design.prefilter import fit_prefilter
    from ..errors import UsageError
    from ..io import read_document, write_document
    from .log_options import read_log_with_options

    if out is not None and gains is None:
        raise UsageError("--out needs --gains: the gains file to which the [prefilter] section is added")
    if refine and gains is None:
        raise UsageError("--refine needs --gains with the pre-filter the run used")
    if out is not None and gains is not None and _same_file(out, gains) and not force:
        raise UsageError(f"--out {out} is the --gains file; pass --force to overwrite it")
    doc = read_document(gains) if gains is not None else None
    lead = _lead(doc, str(gains)) if doc is not None else None
    log = read_log_with_options(log_file, map_, fs, time, scale, unit, skip_rows)
    fit = fit_prefilter(log, lpf_hz=lpf_hz, orders=orders, reference=reference, error=error, position=position,
                        lead_m_per_rad=lead)
    result = {"log": str(log_file), **fit.to_dict()}
    if doc is not None:
        new_doc, note = _updated(doc, fit, str(gains), refine)
        result["written_gains"] = new_doc["prefilter"]["gains"]
        if note:
            result["note"] = note
        if out is not None:
            write_document(out, new_doc, force=force)
            result["out"] = str(out)
    if as_json:  # the fitted gains [s, s^2, s^3, s^4] with their standard deviations (null: not fitted)
        emit({**result, "gains": quantities(result["gains"], result["units"], result["std"])})
    else:
        _summary(result, fit)


def _same_file(a: Path, b: Path) -> bool:
    return a.resolve() == b.resolve()


def _lead(doc: dict, where: str) -> float | None:
    """The screw lead [m/rad] of a gains file's ``[model]``, None when absent."""
    from ..io.gains import check_gains_header, value

    check_gains_header(doc, where)
    model = doc.get("model")
    if not isinstance(model, dict) or "lead_m_per_rad" not in model:
        return None
    return value(model["lead_m_per_rad"], f"{where}: model.lead_m_per_rad", "m/rad")


def _updated(doc: dict, fit, where: str, refine: bool) -> tuple[dict, str]:
    """The gains document with the new ``[prefilter]`` and a note on what happened to an existing one."""
    import math

    from ..errors import UsageError
    from ..io.gains import read_prefilter_gains, with_prefilter

    old = read_prefilter_gains(doc, where)
    if not refine:
        new = with_prefilter(doc, fit, where=where)
        note = "" if old is None else (f"replaced the pre-filter of {where} (the run must not have used it; "
                                       "pass --refine if it did)")
        return new, note
    if old is None:
        raise UsageError(f"--refine: {where} has no [prefilter] to refine")
    old_gains, old_lpf = old
    if not math.isclose(old_lpf, fit.lpf_hz, rel_tol=1e-9):
        raise UsageError(f"--refine: {where} has lpf_hz = {old_lpf:g} Hz; fit with --lpf-hz {old_lpf:g}")
    with_prefilter(doc, fit, where=where)  # checks the sample rate
    total = {k: old_gains[k] + fit.gains[k] for k in fit.gains}
    new = with_prefilter(doc, gains=total, lpf_hz=fit.lpf_hz, where=where)
    return new, f"added the fitted gains to the pre-filter of {where} (--refine)"


def _summary(result: dict, fit) -> None:
    from ..control.prefilter import GAIN_UNITS

    length = fit.length_unit or ""
    factor, shown = (1e6, "um") if length == "m" else (1.0, length)
    typer.echo(f"Trajectory pre-filter (eq. 3.17-3.20) from {result['log']}: {fit.n_samples} samples at "
               f"{fmt(fit.fs, 'Hz', 6)}, low-pass G at {fmt(fit.lpf_hz, 'Hz')}")
    for name, unit in GAIN_UNITS.items():
        std = fit.std.get(name)
        extra = f"  (std {fmt(std, unit, 2)}; from {fit.sources.get(_order(name), '-')})" if std is not None else \
            "  (not fitted)"
        typer.echo(f"  {name:7s} = {fmt(fit.gains[name], unit)}{extra}")
    typer.echo(f"  tracking error RMS {fmt(fit.error_rms * factor, shown)}; correlated with the reference "
               f"derivatives {fmt(fit.fitted_rms * factor, shown)}")
    typer.echo(f"  achievable RMS with the pre-filter {fmt(fit.residual_rms * factor, shown)} "
               f"(predicted reduction {100 * fit.predicted_reduction:.1f} %); condition number "
               f"{fmt(fit.condition_number, '', 3)}")
    if result.get("note"):
        typer.echo(f"note: {result['note']}")
    if "out" in result:
        typer.echo(f"wrote {result['out']}")


def _order(gain_name: str) -> str:
    return gain_name.split("_", 1)[1]
