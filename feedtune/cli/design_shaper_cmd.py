"""``feedtune design shaper``: an input shaper from the identified modes, robust over FRFs; compared on the twin.

Three sources of modes, one per run:

* ``GAINS`` (with ``--frf`` files): the lightly damped modes of the gains file's tracking responses on its model and
  on each FRF (:func:`feedtune.workflows.shaper.design_shaper`), the shaper chosen by the residual vibration vs
  smoothing trade-off (:func:`feedtune.design.shaper_choice.choose_shaper`) at the file's sample rate; ``--out``
  writes the gains file with a ``[shaper]`` that the runtime, the twin and the C header execute. ``--twin`` runs a
  move per candidate on the twin (and on the twin of the file's model) and prints the ringing, the added delay and
  the tracking errors (:func:`feedtune.workflows.shaper_twin.compare_on_twin`).
* ``--psd FILE``: a Klipper resonance file, fitted as Klipper fits it (:mod:`feedtune.design.input_shaper`);
  ``--out`` writes a shaper document for ``feedtune export klipper|marlin``.
* ``--mode HZ,ZETA`` (repeatable): modes given by hand; ``--fs`` judges the sampled taps of that rate.
"""

from __future__ import annotations

from pathlib import Path

import typer

from .common import FORCE_OPTION, JSON_OPTION
from .frf_options import (
    FRF_CHANNEL_OPTION,
    FRF_INPUT_UNIT_OPTION,
    FRF_MAP_OPTION,
    FRF_SCALE_OPTION,
    FRF_SKIP_ROWS_OPTION,
)
from .help_text import SHAPER_AXES, SHAPER_TYPES, choice
from .progress_display import QUIET_OPTION, show_progress

PSD_COLUMNS = ("xyz", "x", "y", "z")


def _mode(text: str) -> tuple[float, float]:
    from ..errors import UsageError

    parts = text.split(",")
    try:
        f, z = (float(p) for p in parts)
    except ValueError:
        raise UsageError(f"--mode expects HZ,ZETA (e.g. 116.5,0.05), got {text!r}") from None
    return f, z


def _move(text: str | None):
    from ..errors import UsageError
    from ..workflows.shaper_twin import Move

    if text is None:
        return None  # the gains kind's default (workflows.shaper_twin.default_move)
    try:
        d, v, a, j = (float(p) for p in text.split(","))
    except ValueError:
        raise UsageError(f"--move expects DISTANCE,V_MAX,A_MAX,J_MAX [m, m/s, m/s^2, m/s^3], got {text!r}") from None
    if not all(x > 0 for x in (d, v, a, j)):
        raise UsageError(f"--move expects four numbers > 0, got {text!r}")
    return Move(d, v, a, j)


def _print_choice(choice, title: str) -> None:
    typer.echo(title)
    typer.echo(f"  {'type':9s} {'freq':>10s} {'worst vib':>10s} {'smoothing':>11s} {'duration':>9s} {'lag':>9s}"
               "   vibration at each mode")
    for c in choice.candidates:
        mark = "*" if c is choice.chosen else " "
        vib = " ".join(f"{100 * v:.1f}%" for v in c.vibrations)
        typer.echo(f"{mark} {c.kind:9s} {c.shaper.freq_hz:7.2f} Hz {100 * c.worst_vibration:9.1f}% "
                   f"{c.smoothing_m * 1e6:8.3g} um {c.duration_s * 1e3:6.3g} ms {c.time_shift_s * 1e3:6.3g} ms   {vib}")
    verdict = "within" if choice.meets_target else "NOT within"
    typer.echo(f"  chosen: {choice.chosen.kind} at {choice.chosen.shaper.freq_hz:.2f} Hz, design damping "
               f"{choice.design_damping:.3g}: the least smoothing (at {choice.accel:g} m/s^2) {verdict} "
               f"{100 * choice.max_vibration:g} % residual vibration at every mode and between them"
               + (f" (taps at {choice.fs:g} Hz)" if choice.fs else ""))


def _print_twin(rows, title: str) -> None:
    typer.echo(title)
    typer.echo(f"  {'candidate':22s} {'ringing':>10s} {'ratio':>8s} {'duration':>9s} {'lag':>8s} "
               f"{'max error':>10s} {'servo error':>11s}")
    for r in rows:
        if r.tripped:
            typer.echo(f"  {r.label:22s} tripped: {r.tripped}")
            continue
        typer.echo(f"  {r.label:22s} {r.ringing_m * 1e9:7.3g} nm {100 * r.ratio:7.2f}% {r.duration_s * 1e3:6.3g} ms "
                   f"{r.lag_s * 1e3:5.3g} ms {r.max_error_m * 1e6:7.4g} um {r.max_servo_error_m * 1e6:8.4g} um")


def shaper(
    gains: Path = typer.Argument(
        None, metavar="[GAINS]",
        help="Gains file whose tracking responses give the modes (with --frf: on each measured FRF too).",
    ),
    frf: list[Path] = typer.Option(
        None, "--frf", metavar="FRF",
        help="Measured FRF (repeatable): the mode as the law sees it there (a family at several loads, a gantry at "
             "several table positions).",
    ),
    psd: Path = typer.Option(
        None, "--psd", metavar="FILE",
        help="Klipper resonances_*.csv / calibration_data_*.csv: the shapers fitted as Klipper fits them.",
    ),
    column: str = typer.Option("xyz", "--column", **choice(PSD_COLUMNS), help="PSD of --psd to fit (as Klipper: xyz)."),
    mode: list[str] = typer.Option(
        None, "--mode", metavar="HZ,ZETA", help="A mode given by hand: frequency [Hz] and damping ratio (repeatable).",
    ),
    fs: float = typer.Option(None, "--fs", metavar="HZ", help="With --mode: the target's sample rate [Hz] whose "
                                                              "sampled taps are judged."),
    shaper_types: list[str] = typer.Option(
        None, "--shaper", **choice(SHAPER_TYPES, "TYPE"),
        help="Shaper types to try (repeatable): zv, mzv, zvd, ei, 2hump_ei, 3hump_ei (default all six; --psd: "
             "Klipper's five).",
    ),
    max_vibration: float = typer.Option(
        0.05, "--max-vibration", metavar="FRACTION",
        help="Largest residual vibration accepted at every mode, as a fraction of the unshaped move's [-].",
    ),
    accel: float = typer.Option(5.0, "--accel", metavar="M/S^2",
                                help="Acceleration the smoothing (corner deviation) is compared at [m/s^2]."),
    axis: str = typer.Option("x", "--axis", **choice(SHAPER_AXES), help="Axis of a shaper document (--psd, --mode)."),
    twin: bool = typer.Option(False, "--twin", help="With GAINS: run a move per candidate on the twin and on the "
                                                    "twin of the file's model; print ringing, delay, errors."),
    move: str = typer.Option(None, "--move", metavar="D,V,A,J",
                             help="The --twin move: distance [m], v, a, jerk limits [m/s, m/s^2, m/s^3] (default "
                                  "0.002,0.05,20,1e6 for a ball screw or axis: its 2.5 ms of acceleration excite the "
                                  "mode; 0.004,0.05,2,1e6 for a gantry, within its drives' 10 V)."),
    x: float = typer.Option(0.0, "--x", metavar="M", help="Table position of a gantry's --twin move [m]."),
    param: list[str] = typer.Option(None, "--param", "-p", metavar="NAME=VALUE",
                                    help="Twin parameter of --twin (repeatable), as feedtune simulate."),
    out: Path = typer.Option(
        None, "--out", "-o", metavar="FILE",
        help="GAINS: the gains file with a [shaper] (.toml+.json); --psd/--mode: a shaper document.",
    ),
    frf_map: list[str] = FRF_MAP_OPTION,
    frf_skip_rows: int = FRF_SKIP_ROWS_OPTION,
    frf_scale: list[str] = FRF_SCALE_OPTION,
    frf_channel: str = FRF_CHANNEL_OPTION,
    frf_input_unit: str = FRF_INPUT_UNIT_OPTION,
    force: bool = FORCE_OPTION,
    as_json: bool = JSON_OPTION,
    quiet: bool = QUIET_OPTION,
) -> None:
    """Choose an input shaper for the identified modes.

    Choose an input shaper (ZV, MZV, ZVD, EI, 2HUMP_EI, 3HUMP_EI) for the modes a gains file's closed loop leaves
    ringing, robust over the FRFs of a mode that moves with load or position: the least smoothing within the
    residual-vibration bound at every mode. --out writes the gains file with the shaper, which the runtime, the twin
    and export c execute; from a Klipper PSD or modes given by hand, a shaper document for export klipper|marlin."""
    show_progress(quiet)
    from ..errors import UsageError
    from ..io import write_document
    from ..io.atomic import ensure_writable
    from .envelope import emit, warn

    sources = [n for n, v in (("GAINS", gains), ("--psd", psd), ("--mode", mode)) if v]
    if len(sources) != 1:
        raise UsageError("design shaper needs exactly one source of modes: GAINS (with --frf), --psd FILE or --mode "
                         f"HZ,ZETA; got {', '.join(sources) or 'none'}")
    if frf and gains is None:
        raise UsageError("--frf needs GAINS: the law whose tracking response on each FRF gives the mode")
    if twin and gains is None:
        raise UsageError("--twin needs GAINS: the law to run on the twin")
    bad = [k for k in (shaper_types or []) if k not in SHAPER_TYPES]
    if bad:
        raise UsageError(f"--shaper {bad[0]}: expected one of {', '.join(SHAPER_TYPES)}")
    if not 0 < max_vibration < 1:
        raise UsageError(f"--max-vibration expects a fraction in (0, 1), got {max_vibration:g}")
    if not accel > 0:
        raise UsageError(f"--accel expects an acceleration > 0 m/s^2, got {accel:g}")
    if fs is not None and mode is None:
        raise UsageError("--fs goes with --mode (a gains file carries its own sample rate)")
    twin_move = _move(move) if twin else None
    if move is not None and not twin:
        raise UsageError("--move goes with --twin")
    if out is not None:
        ensure_writable(out, force)
    result: dict = {}
    if psd is not None:
        new_doc = _from_psd(psd, column, shaper_types, axis, result, as_json)
    elif mode:
        from ..design.shaper_choice import choose_shaper
        from ..io.shaper_file import shaper_document

        modes = [_mode(m) for m in mode]
        choice_ = choose_shaper([m[0] for m in modes], [m[1] for m in modes], kinds=shaper_types or SHAPER_TYPES,
                                max_vibration=max_vibration, fs=fs, accel=accel)
        result.update(choice_.to_dict())
        new_doc = shaper_document(choice_.chosen.shaper, axis, {"modes": result["modes"],
                                                               "max_vibration": max_vibration})
        if not as_json:
            _print_choice(choice_, f"input shapers for {len(modes)} mode(s) given by hand:")
        if not choice_.meets_target:
            warn(f"no shaper type keeps every mode within {100 * max_vibration:g} % residual vibration; the least "
                 "vibration was chosen")
    else:
        new_doc = _from_gains(gains, frf, shaper_types, max_vibration, accel, twin, twin_move, x, param, result,
                              as_json, (frf_map, frf_skip_rows, frf_scale, frf_channel, frf_input_unit))
    if out is not None:
        write_document(out, new_doc, force=force)
        result["out"] = str(out)
    if as_json:
        emit(result)
    elif out is not None:
        typer.echo(f"wrote {out}")


def _from_psd(psd: Path, column: str, kinds, axis: str, result: dict, as_json: bool) -> dict:
    """Klipper's fit of a PSD file: every type's frequency and figures, the recommended one as a shaper document."""
    from ..design.input_shaper import AUTOTUNE_TYPES, fit_shapers, normalize_psd, recommended_shaper
    from ..errors import UsageError
    from ..io.psd_csv import read_psd_csv, shaper_column
    from ..io.shaper_file import shaper_document

    if column not in PSD_COLUMNS:
        raise UsageError(f"--column expects one of {', '.join(PSD_COLUMNS)}, got {column!r}")
    spectrum = read_psd_csv(psd)
    p = spectrum.get(column)
    p = p if spectrum.normalized else normalize_psd(spectrum.freq_hz, p)
    fits = fit_shapers(spectrum.freq_hz, p, tuple(kinds) if kinds else AUTOTUNE_TYPES)
    best = recommended_shaper(fits)
    files = {shaper_column(name)[0]: shaper_column(name)[1] for name in spectrum.shaper_columns}
    rows = [{"kind": f.kind, "freq_hz": f.freq_hz, "vibrations": f.vibrations, "smoothing_m": f.smoothing_m,
             "max_accel": f.max_accel, "file_freq_hz": files.get(f.kind)} for f in fits]
    result.update({"source": str(psd), "column": column, "shapers": rows, "chosen": best.kind,
                   "units": {"freq_hz": "Hz", "file_freq_hz": "Hz", "vibrations": "-", "smoothing_m": "m",
                             "max_accel": "m/s^2"}})
    if not as_json:
        typer.echo(f"input shapers fitted to psd_{column} of {psd} as Klipper fits them:")
        for r in rows:
            mark = "*" if r["kind"] == best.kind else " "
            ref = f"   Klipper's file: {r['file_freq_hz']:.1f} Hz" if r["file_freq_hz"] else ""
            typer.echo(f"{mark} {r['kind']:9s} {r['freq_hz']:6.1f} Hz  vibrations {100 * r['vibrations']:5.1f} %  "
                       f"smoothing {r['smoothing_m'] * 1e3:.3g} mm  max accel {r['max_accel'] * 1e3:.0f} mm/s^2{ref}")
        typer.echo(f"  chosen: {best.kind} (Klipper's rule: a lower score by 20 %, or by 5 % with 10 % less smoothing)")
    return shaper_document(best.shaper, axis, {"rule": "Klipper's fit to a PSD (feedtune.design.input_shaper)",
                                               "source": str(psd), "column": column,
                                               "vibrations": best.vibrations, "smoothing_m": best.smoothing_m})


def _from_gains(gains: Path, frf, kinds, max_vibration: float, accel: float, twin: bool, twin_move, x: float,
                param, result: dict, as_json: bool, frf_args) -> dict:
    """The shaper of a gains file's modes (and the twin comparison); the gains document with its ``[shaper]``."""
    from ..io import read_document
    from ..io.shaper_file import with_shaper
    from ..workflows.shaper import design_shaper
    from .envelope import warn
    from .frf_options import FrfReadOptions, read_optional_frf
    from .twin_options import parse_params

    where = str(gains)
    doc = read_document(gains)
    options = FrfReadOptions.from_cli(*frf_args)
    frfs = [(str(p), read_optional_frf(p, None, options=options)) for p in (frf or [])]
    design = design_shaper(doc, where, frfs, kinds=kinds or None, max_vibration=max_vibration, accel=accel)
    result.update(design.to_dict())
    if not as_json:
        typer.echo(f"modes of the tracking response of {where} (fitted pole pair at each lightly damped peak):")
        for m in design.modes:
            typer.echo(f"  {m.freq_hz:8.2f} Hz, damping {m.damping:.4f}, |T| {m.peak:.3g} at {m.peak_freq_hz:.1f} Hz"
                       f"  ({m.source})")
        for m, v in zip(design.other_modes, design.other_vibrations, strict=True):
            typer.echo(f"  other: {m.freq_hz:.2f} Hz, damping {m.damping:.4f}, |T| {m.peak:.3g} ({m.source}): the "
                       f"chosen shaper leaves {100 * v:.0f} % of its vibration")
        _print_choice(design.choice, "input shapers for these modes:")
    if not design.choice.meets_target:
        warn(f"{where}: no shaper type keeps every mode within {100 * max_vibration:g} % residual vibration; the "
             "least vibration was chosen")
    if twin:
        from ..workflows.shaper_twin import compare_on_twin, default_move, shaper_candidates

        twin_move = twin_move or default_move(doc.get("kind"))
        overrides = parse_params(param)
        cands = shaper_candidates(design.choice)
        f_mode = design.model_mode.freq_hz
        tables = {}
        for label, model in (("twin", False), ("model", True)):
            rows = compare_on_twin(doc, where, cands, f_mode, move=twin_move, model=model, overrides=overrides, x=x,
                                   chosen=design.choice.chosen.kind)
            tables[label] = [r.to_dict() for r in rows]
            if not as_json:
                title = ("on the twin" if label == "twin" else "on the twin of the file's design model (identified "
                         "model alone" + ("" if design.model_mode.source == "model" else
                                          f"; it has no mode near {f_mode:.1f} Hz, found on the FRFs only") + ")")
                _print_twin(rows, f"{title}: ringing at {f_mode:.1f} Hz after the move (band-passed RMS of the "
                                  "load), added delay, largest error against the commanded and the shaped "
                                  "reference:")
        result["twin"] = {**tables, "move": twin_move.__dict__, "freq_hz": f_mode, "x_m": x,
                          "units": {"ringing_m": "m", "ratio": "-", "duration_s": "s", "lag_s": "s",
                                   "max_error_m": "m", "max_servo_error_m": "m", "freq_hz": "Hz", "x_m": "m"}}
    return with_shaper(doc, design.shaper, choice=design.record(), where=where)
