"""``feedtune design cascade`` and ``feedtune tune cascade``: the drive cascade of a one-encoder axis (docs/cascade.md).

* ``design cascade MODEL|FRF --kp --tn [--kv] [--filter KIND:VALUES]...``: given values; ``--drive-tuning XML``
  takes them from the controller of an auto-servo-tuning export (the drive's own tuning as a cascade gains file,
  certified on the FRF given: the export's own, when it is the plant);
* ``tune cascade MODEL|FRF [--frf FRF]...``: the speed loop (PI and its current-setpoint filters) and then ``Kv``
  under the limits on every FRF (:func:`feedtune.tune.cascade.tune_cascade`); ``--match-margins GAINS`` sets the
  limits to the margins another cascade (a drive's own tuning) has on the first FRF and prints both side by side.

Every design goes through the one delivery exit (:func:`feedtune.workflows.deliver.deliver`).
"""

from __future__ import annotations

from pathlib import Path

import typer

from ..structures import controller
from .common import FORCE_OPTION, JSON_OPTION, fmt
from .design_cmd import ALLOW_OPTION, DELAY_OPTION, OUT_OPTION, QUANTITY_OPTION
from .frf_options import (
    FRF_CHANNEL_OPTION,
    FRF_INPUT_UNIT_OPTION,
    FRF_MAP_OPTION,
    FRF_SCALE_OPTION,
    FRF_SKIP_ROWS_OPTION,
)
from .help_text import choice
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

DEFAULT_POSITION_RATIO = 8
"""Speed-loop samples per position-loop sample without ``--position-fs`` (1 ms at 125 us)."""
MODEL_SUFFIXES = (".toml", ".json")

FILTER_OPTION = typer.Option(
    None, "--filter", metavar="KIND:VALUES",
    help="cascade: current-setpoint filter in the drive's terms, repeatable, in order: pt1:T (time constant "
         "[s]), pt2:HZ,D, notch:HZ,DZ,DP (a general second-order filter with equal frequencies) or "
         "so:FZ,DZ,FP,DP (numerator and denominator frequency [Hz] and damping).")
POSITION_FS_OPTION = typer.Option(
    None, "--position-fs", metavar="HZ",
    help="cascade: position-loop rate [Hz]; fs must be a whole multiple of it (default fs / 8: 1 kHz at 8 kHz).")
CURRENT_LOOP_OPTION = typer.Option(
    None, "--current-loop-hz", metavar="HZ",
    help="cascade: the drive's current-loop bandwidth [Hz] (a first-order lag) behind a model; default: none "
         "beside a measured FRF (it holds the current loop), 1000 Hz assumed for a model alone (the design then "
         "says so).")
ENCODER_OPTION = typer.Option(
    "motor", "--position-encoder", **choice(("motor", "load")),
    help="The encoder the position loop closes on: motor, or load (a two-encoder FRF with x2, or a two-mass model).")
TUNE_ENCODER_OPTION = typer.Option(
    None, "--position-encoder", **choice(("motor", "load")),
    help="cascade: the encoder the position loop closes on: motor (default), or load (a two-encoder FRF with x2, or "
         "a two-mass model).")
KV_FF_OPTION = typer.Option(1.0, "--kv-ff", metavar="FACTOR", help="Velocity feedforward factor [-] (1: all of it).")
INERTIA_FF_OPTION = typer.Option(
    None, "--inertia-ff", metavar="J",
    help="Acceleration feedforward [command unit/(position unit/s^2)] (default: the plant's inertia; 0: none).")
MATCH_OPTION = typer.Option(
    None, "--match-margins", metavar="GAINS",
    help="cascade: a cascade gains file (e.g. the drive's own tuning, 'design cascade --drive-tuning'): the limits "
         "become its speed loop's margins on the first FRF (Ms, the smallest |PM|, the gain-increase margin), and "
         "both are printed side by side.")


def position_ratio(fs: float, position_fs: float | None) -> int:
    """``fs / position_fs`` as a whole number (default :data:`DEFAULT_POSITION_RATIO`); UsageError otherwise."""
    from ..errors import UsageError

    if position_fs is None:
        return DEFAULT_POSITION_RATIO
    if not position_fs > 0:
        raise UsageError(f"--position-fs must be a rate > 0 Hz, got {position_fs!r}")
    n = round(fs / position_fs)
    if n < 1 or abs(n * position_fs - fs) > 1e-9 * fs:
        raise UsageError(f"--position-fs {position_fs:g} Hz: the speed loop's {fs:g} Hz must be a whole multiple of "
                         "the position loop's rate")
    return int(n)


def read_plant(path: Path, quantity, frf_options):
    """``(plant, FrfSource or None)``: a model file, or an FRF file read as a certification source."""
    from ..errors import DataError
    from ..io import load_model
    from ..models.ballscrew import BallScrewModel
    from ..models.rigid import RigidBodyModel
    from .delivery import read_sources

    if path.suffix.lower() in MODEL_SUFFIXES:
        model = load_model(path)
        if not isinstance(model, (RigidBodyModel, BallScrewModel)):
            raise DataError(f"{path}: a cascade needs a rigid-body model ('identify rigid') or a two-mass model "
                            f"('identify ballscrew'), got a {type(model).__name__}")
        return model, None
    source = read_sources([path], quantity, frf_options)[0]
    return source.frf, source


def drive_filters(specs, notch=None, lpf=None, lpf_order: int = 2) -> tuple:
    """The current-setpoint filters of ``--filter`` (and ``--notch``/``--lpf``), in order."""
    from ..control.cascade import pack_filters, parse_filter
    from ..control.filters import FilterPack, Notch

    out = [parse_filter(s) for s in specs or []]
    if notch or lpf is not None:
        out += list(pack_filters(FilterPack([Notch.parse(n) for n in notch or []], lpf, lpf_order)))
    return tuple(out)


def _drive_tuning(path: Path, which: str):
    from ..errors import UsageError
    from ..io.servo_tuning_xml import read_drive_speed_tuning

    tuning = read_drive_speed_tuning(path)
    ctrl = tuning.tuned if which == "tuned" else tuning.original
    if which not in ("tuned", "original"):
        raise UsageError(f"--drive-controller must be tuned or original, got {which!r}")
    if ctrl is None:
        raise UsageError(f"{path}: the export holds no tuned controller; use --drive-controller original")
    return tuning, ctrl


def design(
    plant_file: Path = typer.Argument(
        ..., metavar="MODEL|FRF",
        help="Rigid-body or two-mass model file ('identify rigid', 'identify ballscrew'), or the measured FRF of the "
             "axis (current or torque setpoint in; motor speed or position out, or both encoders); an "
             "auto-servo-tuning XML export is such an FRF.",
    ),
    kp: float = typer.Option(None, "--kp", metavar="GAIN",
                             help="Speed-loop gain Kp [command unit/(position unit/s)]."),
    tn: float = typer.Option(None, "--tn", metavar="S",
                             help="Speed-loop integral time Tn [s] (0: no integral action)."),
    kv: float = typer.Option(0.0, "--kv", metavar="1/S",
                             help="Position-loop gain Kv [1/s] (0: the position loop open)."),
    filter_: list[str] = FILTER_OPTION,
    drive_tuning: Path = typer.Option(
        None, "--drive-tuning", metavar="XML",
        help="Take Kp, Tn, the current-setpoint filters and the speed-loop sample time from a controller of an "
             "auto-servo-tuning export (the drive's own tuning as a cascade gains file).",
    ),
    drive_controller: str = typer.Option("tuned", "--drive-controller", **choice(("tuned", "original")),
                                         help="Which controller of --drive-tuning: tuned (the tool's) or original."),
    fs: float = typer.Option(None, "--fs", metavar="HZ",
                             help="Speed-loop rate [Hz] (default: --drive-tuning's, the rate the FRF records, else "
                                  "8000)."),
    delay_samples: int = DELAY_OPTION,
    fs_override: bool = FS_OVERRIDE_OPTION,
    position_fs: float = POSITION_FS_OPTION,
    kv_ff: float = KV_FF_OPTION,
    inertia_ff: float = INERTIA_FF_OPTION,
    position_encoder: str = ENCODER_OPTION,
    current_loop_hz: float = CURRENT_LOOP_OPTION,
    frf: Path = typer.Option(None, "--frf", metavar="FRF",
                             help="Measured FRF beside a model: the design is checked and certified on it."),
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
    """Design the drive cascade with given values.

    Speed PI (Kp, Tn) with current-setpoint filters (PT1, PT2, general second-order), position gain Kv with velocity
    and acceleration feedforward, the position loop at its own rate (docs/cascade.md). With --drive-tuning the values
    are a drive's own (an auto-servo-tuning export's controller), certified on the FRF given."""
    show_progress(quiet)
    import math

    from ..design.cascade import design_cascade
    from ..errors import UsageError
    from ..workflows.deliver import deliver
    from .delivery import finish_design, read_sources
    from .frf_options import FrfReadOptions
    from .sampling_options import target_sampling

    policy = limits_from_options(limits, ms_max, pm_min, gm_min, dm_min, gm_low_min)
    frf_options = FrfReadOptions.from_cli(frf_map, frf_skip_rows, frf_scale, frf_channel, frf_input_unit)
    if out is not None:
        from ..io.document import ensure_document_writable

        ensure_document_writable(out, force)
    filters = drive_filters(filter_)
    record = None
    if drive_tuning is not None:
        if kp is not None or tn is not None or filters:
            raise UsageError("--drive-tuning gives Kp, Tn and the filters; do not give --kp, --tn or --filter too")
        export, ctrl = _drive_tuning(drive_tuning, drive_controller)
        kp, tn, filters = ctrl.kp, ctrl.tn_s, ctrl.filters
        fs = fs if fs is not None else export.fs_hz
        record = {"drive_tuning": str(drive_tuning), "controller": drive_controller, **ctrl.to_dict()}
    elif kp is None or tn is None:
        raise UsageError("give --kp and --tn (or --drive-tuning), or tune them: feedtune tune cascade")
    plant, plant_source = read_plant(plant_file, quantity, frf_options)
    sources = [plant_source] if plant_source is not None else read_sources([frf] if frf else [], quantity,
                                                                           frf_options)
    rate = target_sampling(fs, delay_samples, [(s.name, s.frf) for s in sources],
                           default_fs=controller("cascade").default_fs_hz,
                           override=fs_override)
    rate.report(as_json, "design cascade")
    ratio = position_ratio(rate.fs_hz, position_fs)
    design_ = design_cascade(plant, kp=kp, tn_s=math.inf if tn == 0 else tn, filters=filters, kv=kv, fs=rate.fs_hz,
                             position_ratio=ratio, delay_samples=rate.delay_samples, kv_ff=kv_ff,
                             inertia_ff=inertia_ff, position_encoder=position_encoder,
                             frf=None if plant_source is not None or not sources else sources[0].frf,
                             current_loop_hz=current_loop_hz, tuning=record)
    delivery = deliver(design_, sources, policy, where="the design")
    result = {**delivery.result, "design": design_.design_dict(), **rate.to_json()}
    finish_design(delivery, result, out=out, force=force, allow_unstable=allow_unstable, as_json=as_json)
    if not as_json:
        typer.echo(f"rests on {design_.source.rests_on}")


def tune_command(entry, request) -> None:
    """``feedtune tune cascade`` (:attr:`feedtune.structures.ControllerStructure.tune_command`; ``request``: a
    :class:`~feedtune.cli.tune_cmd.TuneRequest`): the current-setpoint filters are those of ``--filter``, then
    the ``--notch``/``--lpf`` pack's."""
    from ..control.cascade import pack_filters
    from .tune_cmd import _filter_choice

    r, o = request, request.options
    given = drive_filters(o.get("--filter")) + pack_filters(r.pack)
    tune(entry.title, r.plant_file, r.frf, filters=given,
         filter_choice=_filter_choice(r.filters, given, None),
         fs=r.fs, delay_samples=r.delay_samples, fs_override=r.fs_override, position_fs=o.get("--position-fs"),
         current_loop_hz=o.get("--current-loop-hz"), position_encoder=o.get("--position-encoder") or "motor",
         match_margins=o.get("--match-margins"), quantity=r.quantity, frf_options=r.frf_options, policy=r.policy,
         objective=r.objective, out=r.out, force=r.force, as_json=r.as_json)


def tune(structure_title: str, plant_file: Path, frf: list[Path] | None, *, filters: tuple, filter_choice: str,
         fs: float | None, delay_samples: int | None, fs_override: bool, position_fs: float | None,
         current_loop_hz: float | None, position_encoder: str, match_margins: Path | None, quantity, frf_options,
         policy, objective, out: Path | None, force: bool, as_json: bool) -> None:
    """``feedtune tune cascade``: tune, certify on every FRF, write, print (module docstring)."""
    from ..io.document import ensure_document_writable
    from ..tune.cascade import tune_cascade
    from ..workflows.deliver import deliver
    from .delivery import print_certificate, read_sources, write_delivery
    from .sampling_options import target_sampling
    from .tune_cmd import print_objective

    if out is not None:
        ensure_document_writable(out, force)
    plant, plant_source = read_plant(plant_file, quantity, frf_options)
    extra = [s for s in read_sources(list(frf or []), quantity, frf_options) if s.name != str(plant_file)]
    sources = ([plant_source] if plant_source is not None else []) + extra
    rate = target_sampling(fs, delay_samples, [(s.name, s.frf) for s in sources],
                           default_fs=controller("cascade").default_fs_hz,
                           override=fs_override)
    rate.report(as_json, "tune cascade")
    ratio = position_ratio(rate.fs_hz, position_fs)
    reference = None
    if match_margins is not None:
        policy, reference = _matched_limits(match_margins, sources, policy)
    design_ = tune_cascade(plant, frf=[s.frf for s in extra] or None, limits=policy, filters=filters,
                           filter_choice=filter_choice, fs=rate.fs_hz, position_ratio=ratio,
                           delay_samples=rate.delay_samples, position_encoder=position_encoder,
                           current_loop_hz=current_loop_hz, objective=objective)
    delivery = deliver(design_, sources, policy, where="tuned design")
    result = {**delivery.result, "design": design_.design_dict(), "certificate": delivery.certificate.to_dict(
        OPTION_NAMES), **rate.to_json()}
    if reference is not None:
        from ..analysis.cascade import compare_speed_loops

        result["comparison"] = compare_speed_loops({reference[0]: reference[1], "feedtune": delivery.analysis})
    write_delivery(delivery, out, force, None, f"tuned {structure_title}")
    if out is not None:
        result["out"] = str(out)
    if as_json:
        from .envelope import design_result, emit

        emit(design_result(result, "cascade"), check=delivery.check_dict(OPTION_NAMES))
        return
    tuning = design_.tuning
    law = design_.law
    sp, pos = tuning["speed_loop"], tuning["position_loop"]
    typer.echo(f"drive cascade tuned ({rate.fs_hz:g} Hz speed loop, {law.fp:g} Hz position loop):")
    typer.echo(f"  speed loop: Kp {fmt(law.kp, law.gain_units()['Kp'])}, Tn {fmt(law.tn_s * 1e3, 'ms')}; first "
               f"crossover {fmt(sp['first_crossover_hz'], 'Hz')}, Ms {sp['ms']:.3g}, PM {fmt(sp['pm_deg'], 'deg')}, "
               f"GM {fmt(sp['gm_db'], 'dB')}")
    typer.echo(f"  current-setpoint filters ({tuning['filters'].get('choice')}): "
               + (", ".join(sp["filters"]) or "none"))
    for line in tuning["filters"].get("chosen", []):
        typer.echo(f"    {line}")
    if pos is not None:
        typer.echo(f"  position loop: Kv {fmt(law.kv, '1/s')} ({law.position_encoder} encoder); first crossover "
                   f"{fmt(pos['first_crossover_hz'], 'Hz')}, Ms {pos['ms']:.3g}, PM {fmt(pos['pm_deg'], 'deg')}, "
                   f"GM {fmt(pos['gm_db'], 'dB')}")
    typer.echo(f"  feedforward: velocity x{law.kv_ff:g}, acceleration J_ff "
               f"{fmt(law.inertia_ff, law.gain_units()['J_ff'])}")
    typer.echo(f"  rests on {tuning['rests_on']}")
    print_objective(tuning)
    print_certificate(result["certificate"])
    if reference is not None:
        print_comparison(result["comparison"])
    if out is not None:
        typer.echo(f"wrote {out}")


def _matched_limits(path: Path, sources: list, base):
    """``(limits, (name, analysis))``: the margins of another cascade gains file on the first FRF."""
    from ..analysis.cascade import margins_of, speed_loop_figures
    from ..errors import UsageError
    from ..io import read_document
    from ..machines import analyze_gains

    if not sources:
        raise UsageError("--match-margins compares on a measured FRF: give the FRF (as the plant or with --frf)")
    doc = read_document(path)
    done = analyze_gains(doc, str(path), sources[0].frf)
    if doc.get("kind") != "cascade":
        raise UsageError(f"--match-margins {path}: a cascade gains file is needed, got kind {doc.get('kind')!r}")
    figures = speed_loop_figures(done.analysis.cases.get("discrete"))
    if not figures.get("stable"):
        raise UsageError(f"--match-margins {path}: its speed loop is not stable on {sources[0].name}")
    return margins_of(figures, base, str(path)), (str(path), done.analysis)


def print_comparison(comparison: dict) -> None:
    """The speed loops side by side on one FRF (:func:`feedtune.analysis.cascade.compare_speed_loops`)."""
    typer.echo(f"speed loops compared ({comparison['case']} case):")
    typer.echo(f"  {'design':38s} {'first crossover':>16s} {'Ms':>6s} {'min |PM|':>9s} {'GM':>8s}")
    for r in comparison["rows"]:
        ratio = "" if r.get("crossover_ratio") is None else (
            f"  x{r['crossover_ratio']:.3g}, margins {'no worse' if r['margins_no_worse'] else 'WORSE'}")
        typer.echo(f"  {r['name'][:38]:38s} {fmt(r['first_crossover_hz'], 'Hz'):>16s} {r['ms']:6.3g} "
                   f"{fmt(r['pm_deg'], 'deg'):>9s} {fmt(r['gm_db'], 'dB'):>8s}{ratio}")
