"""``feedtune analyze``: frequency-domain analysis of a gains file, and time-domain metrics of logs.

* ``feedtune analyze GAINS.toml [--frf F]`` (or ``feedtune analyze gains GAINS.toml``): loop, margins, Ms,
  Nyquist stability, disturbance and tracking of a design, by the machine of its ``kind``
  (:func:`feedtune.machines.analyze_gains`).
* ``feedtune analyze track LOG``: maximum and RMS tracking error (whole run, constant-velocity and
  acceleration parts) and the error spectrum peaks.
* ``feedtune analyze ropesnap LOG``: peak displacement, 5 % settling time and the amplitude spectral density
  of a rope-snap (released step force) test.

``analyze`` is a command group whose first argument may also be a gains file: :class:`AnalyzeGroup` routes
an unknown first token that is an existing file (or ends in ``.toml``/``.json``) to the ``gains`` command.
"""

from __future__ import annotations

from pathlib import Path

import typer
from typer.core import TyperGroup

from .common import JSON_OPTION, fmt, fmt_angle, fmt_length
from .design_cmd import QUANTITY_OPTION
from .envelope import emit
from .frf_options import (
    FRF_CHANNEL_OPTION,
    FRF_INPUT_UNIT_OPTION,
    FRF_MAP_OPTION,
    FRF_SCALE_OPTION,
    FRF_SKIP_ROWS_OPTION,
)
from .limits_options import (
    DM_MIN_OPTION,
    GM_LOW_MIN_OPTION,
    GM_MIN_OPTION,
    LIMITS_OPTION,
    MS_MAX_OPTION,
    PM_MIN_OPTION,
    limits_from_options,
)
from .log_options import FS_OPTION, MAP_OPTION, SCALE_OPTION, SKIP_ROWS_OPTION, TIME_OPTION, UNIT_OPTION
from .progress_display import QUIET_OPTION, show_progress
from .sampling_options import FS_OVERRIDE_OPTION

GAINS_COMMAND = "gains"
GAINS_SUFFIXES = (".toml", ".json")

#: Units of the ``metrics`` entries printed by ``analyze track|ropesnap --json`` (keys also carry them).
TRACK_UNITS = {"max_m": "m", "rms_m": "m", "duration_s": "s", "freq_hz": "Hz", "amplitude_m": "m"}
ROPESNAP_UNITS = {"t_release_s": "s", "baseline_m": "m", "peak_m": "m", "peak_abs_m": "m", "peak_time_s": "s",
                  "final_m": "m", "settle_band_m": "m", "settling_time_s": "s", "freq_hz": "Hz",
                  "asd_m_per_rthz": "m/sqrt(Hz)"}


class AnalyzeGroup(TyperGroup):
    """Command group that treats ``analyze FILE ...`` as ``analyze gains FILE ...``."""

    default_command = GAINS_COMMAND
    """The command a first argument that is a gains file runs."""

    def parse_args(self, ctx, args: list[str]) -> list[str]:
        """Insert the ``gains`` command before a first argument that is a gains file, not a command."""
        if args and args[0] not in self.commands and not args[0].startswith("-"):
            first = Path(args[0])
            if first.is_file() or first.suffix.lower() in GAINS_SUFFIXES:
                args = [GAINS_COMMAND, *args]
        return super().parse_args(ctx, args)


app = typer.Typer(
    cls=AnalyzeGroup,
    rich_markup_mode="rich",
    no_args_is_help=True,
    help="Analyze a gains file, or a tracking or rope-snap log.\n\n'feedtune analyze GAINS [--frf FRF]' is short for "
         "'feedtune analyze gains GAINS [--frf FRF]'.",
)


# ------------------------------------------------------------------------------------------ gains file
@app.command(GAINS_COMMAND)
def analyze(
    gains_file: Path = typer.Argument(..., metavar="GAINS", help="Gains file (.toml or .json) from 'feedtune design'."),
    frf: list[Path] = typer.Option(
        None, "--frf", metavar="FRF",
        help="Measured FRF (ball screw x1/u, x2/u; gantry 2x2 at its recorded position; x axis SISO), repeatable: the "
             "analysis is printed on the first, the design certified anew on every one (and compared with the "
             "file's certificate by digest). Without --frf the verdict is the file's certificate while it holds for "
             "its gains, else the design model's.",
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
    strict: bool = typer.Option(False, "--check", help="Exit 1 when the design does not meet the limits."),
    fs_override: bool = FS_OVERRIDE_OPTION,
    as_json: bool = JSON_OPTION,
    quiet: bool = QUIET_OPTION,
) -> None:
    """Margins, stability and limits verdict of a gains file.

    Loop, every crossover and margin, Ms, disk margin, |S|<1 bands, Nyquist stability, disturbance and tracking
    of a design, and its verdict under the limits."""
    show_progress(quiet)
    from ..io import read_document
    from ..machines import analyze_gains
    from ..machines.certificate import gains_verdict
    from .delivery import read_sources
    from .frf_options import FrfReadOptions
    from .limits_options import finish_analysis
    from .sampling_options import gains_sampling

    policy = limits_from_options(limits, ms_max, pm_min, gm_min, dm_min, gm_low_min)
    frf_options = FrfReadOptions.from_cli(frf_map, frf_skip_rows, frf_scale, frf_channel, frf_input_unit)
    doc = read_document(gains_file)
    sources = read_sources(list(frf or []), quantity, frf_options)
    measured = sources[0].frf if sources else None
    rate = gains_sampling(doc, str(gains_file), [(s.name, s.frf) for s in sources] or [(None, None)],
                          override=fs_override)
    if rate is not None:
        rate.report(as_json)
    done = analyze_gains(doc, str(gains_file), measured)
    verdict = gains_verdict(doc, str(gains_file), sources, policy, known=[(measured, done.analysis)])
    record = rate.to_json() if rate is not None and measured is not None else {}  # checked against an FRF
    finish_analysis({**done.result, **record}, verdict, as_json, strict, gains_kind=doc.get("kind"))


# ------------------------------------------------------------------------------------------ logs
def log_result(log_path: Path, kind: str, metrics) -> dict:
    """The results of ``analyze track|ropesnap``: log, kind, metrics (no spectrum), units (``--json`` prints them in
    the envelope, whose ``kind`` is ``analyze.track`` or ``analyze.ropesnap``)."""
    units = TRACK_UNITS if kind == "track" else ROPESNAP_UNITS
    unit = getattr(metrics, "unit", "m")  # a rotary axis' tracking log: rad in the keys that end in _m
    return {"log": str(log_path), "kind": kind, "metrics": metrics.to_dict(include_spectrum=False),
            "units": {k: (unit if v == "m" else v) for k, v in units.items()}}


def _um(x: float | None) -> str:
    """A displacement [m] in um (or mm, m where um would need a power of ten)."""
    return fmt_length(x)


def _print_track(result: dict) -> None:
    m = result["metrics"]
    _um = fmt_angle if result["units"]["max_m"] == "rad" else fmt_length
    typer.echo(f"Tracking error of {result['log']}:")
    for label, key in (("whole run", "overall"), ("constant velocity", "constant_velocity"),
                       ("acceleration", "acceleration")):
        part = m[key]
        if part is None:
            typer.echo(f"  {label:18s} -")
            continue
        typer.echo(f"  {label:18s} max {_um(part['max_m'])}, RMS {_um(part['rms_m'])} "
                   f"over {fmt(part['duration_s'], 's')}")
    for p in m["peaks"]:
        typer.echo(f"  spectrum peak {fmt(p['freq_hz'], 'Hz')}: {_um(p['amplitude_m'])}")


def _print_ropesnap(result: dict) -> None:
    m = result["metrics"]
    how = "detected" if m["release_detected"] else "given"
    typer.echo(f"Rope snap of {result['log']} (release at {fmt(m['t_release_s'], 's')}, {how}):")
    typer.echo(f"  peak displacement {_um(m['peak_m'])} at {fmt(m['peak_time_s'], 's')} after the release")
    settle = fmt(m["settling_time_s"], "s") if m["settled"] else "not settled within the log"
    typer.echo(f"  5 % settling time {settle} (band {_um(m['settle_band_m'])} around {_um(m['final_m'])})")
    for p in m["asd_peaks"]:
        typer.echo(f"  ASD peak {fmt(p['freq_hz'], 'Hz')}: {fmt(p['asd_m_per_rthz'] * 1e6, 'um/sqrt(Hz)')}")


@app.command("track")
def track(
    log_file: Path = typer.Argument(
        ..., metavar="LOG",
        help="Tracking log (.csv, .mat, .mf4), e.g. from 'feedtune simulate track'.",
    ),
    error: str = typer.Option(
        None, "--error", metavar="COLUMN",
        help="Tracking-error column [m, or rad for a rotary axis] (default e2 when present).",
    ),
    reference: str = typer.Option(
        None, "--reference", metavar="COLUMN",
        help="Commanded position column [m or rad] (default x_ref).",
    ),
    position: str = typer.Option(
        None, "--position", metavar="COLUMN",
        help="Measured position column [m or rad] (default x2_table).",
    ),
    map_: list[str] = MAP_OPTION,
    fs: float = FS_OPTION,
    time: str = TIME_OPTION,
    scale: list[str] = SCALE_OPTION,
    unit: list[str] = UNIT_OPTION,
    skip_rows: int = SKIP_ROWS_OPTION,
    as_json: bool = JSON_OPTION,
    quiet: bool = QUIET_OPTION,
) -> None:
    """Tracking error of a log per motion phase, and its spectrum.

    Max and RMS tracking error (whole run, constant velocity, acceleration) and error spectrum peaks."""
    show_progress(quiet)
    from ..analysis.log_analysis import analyze_tracking_log
    from .log_options import read_log_with_options

    log = read_log_with_options(log_file, map_, fs, time, scale, unit, skip_rows)
    metrics = analyze_tracking_log(log, error=error, reference=reference, position=position, angular=True)
    result = log_result(log_file, "track", metrics)
    if as_json:
        emit(result)
    else:
        _print_track(result)


@app.command("ropesnap")
def ropesnap(
    log_file: Path = typer.Argument(
        ..., metavar="LOG",
        help="Rope-snap log (.csv, .mat, .mf4), e.g. 'feedtune simulate ropesnap'.",
    ),
    position: str = typer.Option(
        None, "--position", metavar="COLUMN",
        help="Table displacement column [m] (default x2_table).",
    ),
    t_release: float = typer.Option(
        None, "--t-release", metavar="S",
        help="Release instant [s] (default: the log's t_release_s metadata, else detected).",
    ),
    map_: list[str] = MAP_OPTION,
    fs: float = FS_OPTION,
    time: str = TIME_OPTION,
    scale: list[str] = SCALE_OPTION,
    unit: list[str] = UNIT_OPTION,
    skip_rows: int = SKIP_ROWS_OPTION,
    as_json: bool = JSON_OPTION,
    quiet: bool = QUIET_OPTION,
) -> None:
    """Peak, settling time and spectrum of a rope-snap log.

    Peak displacement, 5 % settling time and amplitude spectral density after a rope snap."""
    show_progress(quiet)
    from ..analysis.log_analysis import analyze_ropesnap_log
    from .log_options import read_log_with_options

    log = read_log_with_options(log_file, map_, fs, time, scale, unit, skip_rows)
    metrics = analyze_ropesnap_log(log, position=position, t_release=t_release)
    result = log_result(log_file, "ropesnap", metrics)
    if as_json:
        emit(result)
    else:
        _print_ropesnap(result)
