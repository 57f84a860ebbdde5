"""``feedtune frf``: FRFs from excitation logs, and FRF files put together or inspected.

* ``feedtune frf estimate LOG`` (or ``feedtune frf LOG``): frequency response and coherence estimated from an
  excitation log;
* ``feedtune frf merge FILE:OUT/IN ...``: one FRF file from files measured one channel each
  (:func:`feedtune.frf_merge.merge_frfs`);
* ``feedtune frf info FRF``: lines, band, channels, units and coherence of an FRF file (and the drive's own speed
  controllers of an auto-servo-tuning XML export).

``frf`` is a command group whose first argument may also be a log: :class:`FrfGroup` routes an unknown first token
to ``estimate``.

``--remove-sampling DELAY_SAMPLES`` divides out the zero-order hold and the computational delay (sample rate from
the log) when the log's input is the controller's computed command and its outputs the controller's encoder
readings, so the FRF file is the continuous plant the analysis and the fits expect
(:func:`feedtune.frf_sampling.remove_sampling`). Without it the FRF is written as estimated and its metadata say
``sampling: not_removed``.
"""

from __future__ import annotations

from pathlib import Path

import typer
from typer.core import TyperGroup

from .common import FORCE_OPTION, JSON_OPTION, fmt, fmt_band, parse_float_pair
from .envelope import cli_text, emit
from .frf_options import (
    FRF_CHANNEL_OPTION,
    FRF_INPUT_UNIT_OPTION,
    FRF_MAP_OPTION,
    FRF_SCALE_OPTION,
    FRF_SKIP_ROWS_OPTION,
)
from .help_text import FRF_METHODS, QUANTITIES, choice
from .log_options import FS_OPTION, MAP_OPTION, SCALE_OPTION, SKIP_ROWS_OPTION, TIME_OPTION, UNIT_OPTION
from .progress_display import QUIET_OPTION, show_progress

ESTIMATE_COMMAND = "estimate"


class FrfGroup(TyperGroup):
    """Command group that treats ``frf LOG ...`` as ``frf estimate LOG ...``."""

    default_command = ESTIMATE_COMMAND
    """The command a first argument that is not a command runs."""

    def parse_args(self, ctx, args: list[str]) -> list[str]:
        """Insert the ``estimate`` command before a first argument that is not a command."""
        if args and args[0] not in self.commands and not args[0].startswith("-"):
            args = [ESTIMATE_COMMAND, *args]
        return super().parse_args(ctx, args)


app = typer.Typer(
    cls=FrfGroup,
    rich_markup_mode="rich",
    no_args_is_help=True,
    help="Estimate FRFs from logs; merge and inspect FRF files.\n\n'feedtune frf LOG ...' is short for "
         "'feedtune frf estimate LOG ...'.",
)

#: Coherence level counted in the summary ("lines with coherence >= 0.9").
GOOD_COHERENCE = 0.9

#: Metadata keys of the sampling record (reported under "sampling", not "estimate").
SAMPLING_KEYS = ("sampling", "sampling_fs_hz", "sampling_delay_samples")


def split_names(text: str, option: str) -> list[str]:
    """``"x1,x2"`` -> ``["x1", "x2"]``; UsageError for an empty list or an empty name."""
    from ..errors import UsageError

    names = [n.strip() for n in text.split(",")]
    if not names or any(not n for n in names):
        raise UsageError(f"{option} expects comma-separated signal names such as x1,x2, got {text!r}")
    return names


def coherence_stats(coherence) -> dict | None:
    """Minimum, median, mean [-] and the number of lines with coherence >= 0.9 of one channel."""
    import numpy as np

    if coherence is None:
        return None
    c = np.asarray(coherence, dtype=float)
    return {"min": float(c.min()), "median": float(np.median(c)), "mean": float(c.mean()),
            "lines_above_0_9": int(np.count_nonzero(c >= GOOD_COHERENCE))}


def frf_summary(frf, log_path: Path) -> dict:
    """JSON-ready summary of an estimated FRF: lines, band, resolution, coherence per channel, method."""
    channels = {ch: {"coherence": coherence_stats(frf.channel_coherence(ch))} for ch in frf.channels}
    meta = dict(frf.meta)
    return {
        "log": str(log_path),
        "method": meta.get("method"),
        "estimator": meta.get("estimator"),
        "lines": int(frf.freq_hz.size),
        "band_hz": [float(frf.freq_hz[0]), float(frf.freq_hz[-1])],
        "quantity": frf.quantity,
        "channels": channels,
        "unit": f"{frf.output_unit or '-'}/{frf.input_unit or '-'}",
        "estimate": {k: v for k, v in meta.items() if k not in ("source", "method", "estimator", "warning",
                                                                 *SAMPLING_KEYS)},
        "warnings": [meta["warning"]] if meta.get("warning") else [],
        "sampling": sampling_record(meta),
        "units": {"band_hz": "Hz", "coherence": "-", "frf": f"{frf.output_unit or '-'}/{frf.input_unit or '-'}",
                  "fs_hz": "Hz", "delay_samples": "samples"},
    }


def sampling_record(meta) -> dict:
    """The sampling record of an estimate's metadata: removed (bool), fs_hz [Hz], delay_samples [samples]."""
    from ..frf_sampling import REMOVED, SAMPLING_DELAY_KEY, SAMPLING_FS_KEY, SAMPLING_KEY

    fs, delay = meta.get(SAMPLING_FS_KEY), meta.get(SAMPLING_DELAY_KEY)
    return {"removed": meta.get(SAMPLING_KEY) == REMOVED, "fs_hz": None if fs is None else float(fs),
            "delay_samples": None if delay is None else float(delay)}


def _check_delay_samples(delay_samples: float | None) -> None:
    """UsageError naming --remove-sampling for a negative or non-finite delay."""
    import math

    from ..errors import UsageError
    from ..frf_sampling import MAX_DELAY_SAMPLES

    if delay_samples is not None and not (math.isfinite(delay_samples) and 0 <= delay_samples <= MAX_DELAY_SAMPLES):
        raise UsageError(f"--remove-sampling expects the computational delay in samples (0 .. {MAX_DELAY_SAMPLES}, "
                         f"e.g. 1), got {delay_samples:g}")


def _check_frf_out(out: Path) -> None:
    """UsageError naming --out unless ``out`` names a format feedtune writes FRFs in (.csv, .txt, .mat, .uff)."""
    from ..errors import UsageError
    from ..io.frf_read import frf_format

    try:
        frf_format(out, writing=True)
    except UsageError as exc:
        raise UsageError(f"--out {exc}") from None


def _print_summary(result: dict) -> None:
    est = result["estimate"]
    lo, hi = result["band_hz"]
    typer.echo(f"FRF from {result['log']}: {result['estimator']} ({result['method']})")
    typer.echo(f"  {result['lines']} lines, {fmt_band(lo, hi)}, unit {result['unit']} "
               f"({result['quantity']})")
    if "period_samples" in est:
        typer.echo(f"  period {est['period_samples']} samples ({fmt(est['period_s'], 's')}, "
                   f"{est['period_detection']}); "
                   f"{est['periods_averaged']} of {est['periods_total']} periods averaged, "
                   f"{est['excited_lines']} excited lines")
    elif "nperseg" in est:
        typer.echo(f"  {est['segments']} segments of {est['nperseg']} samples, overlap {fmt(est['overlap'])}, "
                   f"resolution {fmt(est['resolution_hz'], 'Hz')}")
    smp = result["sampling"]
    if smp["removed"]:
        typer.echo(f"  ZOH and computational delay ({smp['delay_samples']:g} sample(s) at {smp['fs_hz']:g} Hz) "
                   "removed: continuous plant")
    else:
        typer.echo(f"  sampled at {smp['fs_hz']:g} Hz; ZOH and computational delay not removed "
                   "(use --remove-sampling DELAY_SAMPLES when the input is the controller's command)")
    for ch, info in result["channels"].items():
        c = info["coherence"]
        if c is None:
            continue
        typer.echo(f"  {ch}: coherence min {c['min']:.3f}, median {c['median']:.3f}, mean {c['mean']:.3f}; "
                   f"{c['lines_above_0_9']} of {result['lines']} lines >= {GOOD_COHERENCE}")
    for w in result.get("warnings", []):
        typer.echo(f"  warning: {cli_text(w)}")
    if "out" in result:
        typer.echo(f"wrote {result['out']}")


@app.command(ESTIMATE_COMMAND)
def estimate(
    log_file: Path = typer.Argument(..., metavar="LOG", help="Excitation log (.csv, .mat, .mf4)."),
    input_: str = typer.Option(
        "u", "--input", "-i", metavar="COLUMN",
        help="Plant input signal (command) [V, A or N].",
    ),
    output: str = typer.Option(
        ..., "--output", "-y", metavar="COLUMNS",
        help="Output signals, comma-separated, e.g. x1,x2.",
    ),
    reference: str = typer.Option(
        None, "--reference", "-r", metavar="COLUMN",
        help="Excitation injected into a closed loop: indirect estimate G = S_ry/S_ru.",
    ),
    method: str = typer.Option(
        "h1", "--method", **choice(FRF_METHODS),
        help="h1 (Welch) or periodic (multisine, per-line averaging).",
    ),
    period_samples: int = typer.Option(
        None, "--period-samples", metavar="N", help="Period of a periodic excitation [samples] (default: detected)."
    ),
    transient_periods: int = typer.Option(
        1, "--transient-periods", metavar="N",
        help="Leading periods dropped (periodic).",
    ),
    nperseg: int = typer.Option(None, "--nperseg", metavar="N", help="Welch segment length [samples] (h1)."),
    overlap: float = typer.Option(
        0.5, "--overlap", metavar="FRACTION",
        help="Welch overlap as a fraction of --nperseg (h1).",
    ),
    band: tuple[float, float] = typer.Option(None, "--band", metavar="LO HI", help="Keep LO HI [Hz]."),
    quantity: str = typer.Option(
        "position", "--quantity", **choice(QUANTITIES, "QUANTITY"),
        help="What the outputs measure: position, velocity, acceleration.",
    ),
    map_: list[str] = MAP_OPTION,
    fs: float = FS_OPTION,
    time: str = TIME_OPTION,
    scale: list[str] = SCALE_OPTION,
    unit: list[str] = UNIT_OPTION,
    skip_rows: int = SKIP_ROWS_OPTION,
    remove_sampling: float = typer.Option(
        None, "--remove-sampling", metavar="DELAY_SAMPLES",
        help="Divide out the zero-order hold and a computational delay of DELAY_SAMPLES samples (sample rate from "
        "the log). Use it when the input is the controller's computed command and the outputs its encoder "
        "readings, so the FRF is the continuous plant the analysis expects.",
    ),
    out: Path = typer.Option(None, "--out", "-o", metavar="FILE", help="FRF file to write (.csv, .mat or .uff)."),
    force: bool = FORCE_OPTION,
    as_json: bool = JSON_OPTION,
    quiet: bool = QUIET_OPTION,
) -> None:
    """Estimate FRFs and their coherence from an excitation log.

    Estimate the FRF input -> outputs and its coherence from a log (Welch H1, periodic, or indirect).

    With --remove-sampling the ZOH and the computational delay of a controller's own log are removed.
    """
    show_progress(quiet)
    from ..errors import UsageError
    from ..frf_sampling import mark_sampling_kept
    from ..frf_sampling import remove_sampling as remove_zoh_and_delay
    from ..identify.frf_estimate import estimate_frf
    from ..io import ensure_writable, write_frf
    from .frf_options import quantity_option
    from .log_options import read_log_with_options

    outputs = split_names(output, "--output")
    freq_range = parse_float_pair(band, "--band")
    quantity = quantity_option(quantity)
    _check_delay_samples(remove_sampling)
    if out is not None:
        _check_frf_out(out)
        ensure_writable(out, force)
    if period_samples is not None and period_samples < 2:
        raise UsageError(f"--period-samples expects the excitation period in samples (>= 2), got {period_samples}")
    log = read_log_with_options(log_file, map_, fs, time, scale, unit, skip_rows)
    estimate = estimate_frf(log, input=input_, outputs=outputs, reference=reference, method=method,
                            period_samples=period_samples, transient_periods=transient_periods, nperseg=nperseg,
                            overlap=overlap, freq_range=freq_range, quantity=quantity)
    if remove_sampling is None:
        estimate = mark_sampling_kept(estimate, log.fs)
    else:
        estimate = remove_zoh_and_delay(estimate, log.fs, remove_sampling)
    result = frf_summary(estimate, log_file)
    if out is not None:
        write_frf(estimate, out, force=force)
        result["out"] = str(out)
    if as_json:
        emit(result)
    else:
        _print_summary(result)


# ------------------------------------------------------------------------------------------ merge
def frf_file_summary(frf) -> dict:
    """JSON-ready description of an FRF: lines, band [Hz], quantity, unit, channels with coherence statistics, the
    file format and the merge record."""
    import numpy as np

    from ..display import frf_unit

    unit = frf_unit(frf)

    def coherence(ch):
        c = frf.channel_coherence(ch)
        return coherence_stats(c) if c is not None and bool(np.isfinite(c).all()) else None

    channels = {ch: {"coherence": coherence(ch)} for ch in frf.channels}
    return {"source": frf.source, "format": frf.meta.get("format"), "lines": int(frf.freq_hz.size),
            "band_hz": [float(frf.freq_hz[0]), float(frf.freq_hz[-1])], "quantity": frf.quantity, "unit": unit,
            "input_unit": frf.input_unit, "output_unit": frf.output_unit, "channels": channels,
            "merge": frf.meta.get("merge"), "sampling": sampling_record(frf.meta),
            "units": {"band_hz": "Hz", "coherence": "-", "frf": unit}}


def _print_frf_file(result: dict, title: str) -> None:
    lo, hi = result["band_hz"]
    typer.echo(f"{title}: {', '.join(result['channels'])}")
    typer.echo(f"  {result['lines']} lines, {fmt_band(lo, hi)}, unit {result['unit']} ({result['quantity']})")
    if result.get("merge"):
        typer.echo(f"  {result['merge']}")
    for ch, info in result["channels"].items():
        c = info["coherence"]
        if c is not None:
            typer.echo(f"  {ch}: coherence min {c['min']:.3f}, median {c['median']:.3f}, mean {c['mean']:.3f}; "
                       f"{c['lines_above_0_9']} of {result['lines']} lines >= {GOOD_COHERENCE}")


@app.command("merge")
def merge(
    pieces: list[str] = typer.Argument(
        ..., metavar="FILE:OUT/IN",
        help="FRF files, one channel each, as FILE:OUT/IN[,scale=FACTOR][,in=UNIT][,out=UNIT][,quantity=Q], e.g. "
             "motor.csv:x1/u table.csv:x2/u,scale=-1.",
    ),
    out: Path = typer.Option(..., "--out", "-o", metavar="FILE", help="Merged FRF file to write (.csv, .mat or .uff)."),
    quantity: str = typer.Option(
        None, "--quantity", **choice(QUANTITIES, "QUANTITY"),
        help="What the files' outputs measure where they do not say it (a piece's quantity= overrides).",
    ),
    frf_map: list[str] = FRF_MAP_OPTION,
    frf_skip_rows: int = FRF_SKIP_ROWS_OPTION,
    frf_scale: list[str] = FRF_SCALE_OPTION,
    frf_input_unit: str = FRF_INPUT_UNIT_OPTION,
    force: bool = FORCE_OPTION,
    as_json: bool = JSON_OPTION,
    quiet: bool = QUIET_OPTION,
) -> None:
    """Merge FRF files measured one channel each into one FRF file.

    Merge single-channel FRF files (one per encoder, as a drive's analyser writes them) into one FRF on their
    common lines. Each file names its channel; two files of one channel, different grids or input units are
    refused."""
    show_progress(quiet)
    from ..io import ensure_writable, write_frf
    from .frf_options import FrfReadOptions, check_pieces_named, parse_frf_argument, read_frf_pieces

    _check_frf_out(out)
    ensure_writable(out, force)
    options = FrfReadOptions.from_cli(frf_map, frf_skip_rows, frf_scale, None, frf_input_unit)
    parsed = [p for text in pieces for p in parse_frf_argument(text)]
    check_pieces_named(parsed, " ".join(pieces))
    merged = read_frf_pieces(parsed, quantity, options=options)
    write_frf(merged, out, force=force)
    result = {**frf_file_summary(merged), "files": [str(p.path) for p in parsed], "out": str(out)}
    if as_json:
        emit(result)
        return
    _print_frf_file(result, f"merged {len(parsed)} files")
    typer.echo(f"wrote {out}")


# ------------------------------------------------------------------------------------------ info
def _controller_lines(name: str, ctrl: dict) -> list[str]:
    tn = "no integral action" if ctrl["tn_s"] is None else f"Tn {fmt(ctrl['tn_s'] * 1e3, 'ms')}"
    lines = [f"  {name}: Kp {fmt(ctrl['kp'])}, {tn}"]
    for f in ctrl["filters"]:
        off = "" if f["enabled"] else " (disabled)"
        if f["kind"] == "PT1":
            lines.append(f"    PT1 low-pass, T {fmt(f['time_constant_s'] * 1e3, 'ms')}{off}")
        elif f["kind"] == "PT2":
            lines.append(f"    PT2 low-pass, {fmt(f['freq_hz'], 'Hz')}, D {fmt(f['damping'])}{off}")
        else:
            lines.append(f"    second order, numerator {fmt(f['num_freq_hz'], 'Hz')} D {fmt(f['num_damping'])}, "
                         f"denominator {fmt(f['den_freq_hz'], 'Hz')} D {fmt(f['den_damping'])}{off}")
    return lines


@app.command("info")
def info(
    frf_file: str = typer.Argument(
        ..., metavar="FRF",
        help="FRF file (.csv, .mat, .uff, auto-servo-tuning .xml), or FILE:OUT/IN pieces joined with +.",
    ),
    quantity: str = typer.Option(
        None, "--quantity", **choice(QUANTITIES, "QUANTITY"),
        help="What the file's outputs measure where it does not say it.",
    ),
    frf_map: list[str] = FRF_MAP_OPTION,
    frf_skip_rows: int = FRF_SKIP_ROWS_OPTION,
    frf_scale: list[str] = FRF_SCALE_OPTION,
    frf_channel: str = FRF_CHANNEL_OPTION,
    frf_input_unit: str = FRF_INPUT_UNIT_OPTION,
    as_json: bool = JSON_OPTION,
    quiet: bool = QUIET_OPTION,
) -> None:
    """Show an FRF file's lines, band, channels, units and coherence.

    Show what an FRF file holds as feedtune reads it: lines, band, channels, units, coherence. An auto-servo-tuning
    XML export also shows the drive's original and tuned speed controllers (Kp, Tn, current-setpoint filters) and
    its speed-loop sample time."""
    show_progress(quiet)
    from ..io.frf_read import frf_format
    from .frf_options import FrfReadOptions, read_frf_argument

    options = FrfReadOptions.from_cli(frf_map, frf_skip_rows, frf_scale, frf_channel, frf_input_unit)
    frf = read_frf_argument(frf_file, quantity, options=options)
    result = {**frf_file_summary(frf), "units_note": frf.meta.get("units_note")}
    path = Path(frf_file)
    if path.is_file() and frf_format(path) == "xml":
        from ..io.servo_tuning_xml import read_drive_speed_tuning

        result["drive_speed_tuning"] = read_drive_speed_tuning(path).to_dict()
    if as_json:
        emit(result)
        return
    _print_frf_file(result, f"FRF {frf.source}")
    if result["units_note"]:
        typer.echo(f"  note: {result['units_note']}")
    tuning = result.get("drive_speed_tuning")
    if tuning:
        ts = tuning["sample_time_s"]
        typer.echo("drive speed controllers (PI from speed error to current setpoint, then the filters)"
                   + (f"; speed loop sampled every {fmt(ts * 1e6, 'us')} ({fmt(1 / ts, 'Hz')})" if ts else ""))
        for name in ("original", "tuned"):
            if tuning[name] is not None:
                for line in _controller_lines(name, tuning[name]):
                    typer.echo(line)
