"""``feedtune export drive`` and ``feedtune import drive``: a cascade gains file as a drive's parameter set,
re-certified as the drive runs it, and a drive's parameter file read back (docs/drive_export.md)."""

from __future__ import annotations

from pathlib import Path

import typer

from .common import FORCE_OPTION, JSON_OPTION
from .help_text import choice
from .limits_options import LIMITS_OPTION, OPTION_NAMES, limits_from_options
from .progress_display import QUIET_OPTION, show_progress

TARGET_NAMES = ("sinamics", "odrive", "linuxcnc-pid", "ax8000", "yaskawa")
EXTENSIONS = {"sinamics": ".sinamics.txt", "odrive": ".odrive.py", "linuxcnc-pid": ".pid.ini",
              "ax8000": ".ax8000.xml", "yaskawa": ".yaskawa.txt"}
"""The default file beside GAINS per target (ODrive with --odrive-json: .odrive.json)."""

import_app = typer.Typer(rich_markup_mode="rich", help="Read drives' parameter files into gains files.",
                         no_args_is_help=True)

TARGET_ARGUMENT = typer.Argument(..., **choice(TARGET_NAMES), help="The drive or controller.")
TORQUE_CONSTANT_OPTION = typer.Option(None, "--torque-constant", metavar="NM_PER_A",
                                      help="Motor torque constant Kt [N*m/A]: gains in A into the drive's torque "
                                           "parameters (SINAMICS, ODrive, AX8000).")
LEAD_OPTION = typer.Option(None, "--lead", metavar="M",
                           help="Lead [m per motor revolution]: gains per m (and N) into the motor's rad (and N*m).")
FS_OPTION = typer.Option(None, "--fs", metavar="HZ",
                         help="The target's speed-loop rate [Hz] (default: ODrive 8000, LinuxCNC's servo thread "
                              "1000, SINAMICS and AX8000 the file's).")
POSITION_FS_OPTION = typer.Option(None, "--position-fs", metavar="HZ",
                                  help="SINAMICS, AX8000: the position loop's rate [Hz] (default: the file's).")
INERTIA_OPTION = typer.Option(None, "--inertia", metavar="KG_M2",
                              help="Yaskawa: the motor-side inertia J_M (1 + Pn103/100) [kg*m^2] the speed loop gain "
                                   "in Hz refers to.")
MACHINE_UNIT_OPTION = typer.Option(None, "--machine-unit", **choice(("mm", "m", "inch", "deg", "rad", "turn")),
                                   help="LinuxCNC: the joint's machine unit (default mm for gains per m, deg per "
                                        "rad).")


def _options(torque_constant, lead, fs, position_fs, u_max=None, machine_unit=None, command_unit=None,
             axis="AX1", encoder_bandwidth=None, inertia=None):
    from ..export.drives import DriveOptions

    return DriveOptions(torque_constant, lead, fs, position_fs, u_max, machine_unit, command_unit, axis,
                        encoder_bandwidth, inertia)


def _check_target(target: str) -> None:
    from ..errors import UsageError

    if target not in TARGET_NAMES:
        raise UsageError(f"TARGET {target!r}: expected one of {', '.join(TARGET_NAMES)}")


def export_drive(
    target: str = TARGET_ARGUMENT,
    gains_file: Path = typer.Argument(..., metavar="GAINS", help="Cascade gains file (tune cascade, design cascade)."),
    frf: list[Path] = typer.Option(None, "--frf", metavar="FRF",
                                   help="Measured FRF to certify both laws on (repeatable; default: the file's "
                                        "model)."),
    out: Path = typer.Option(None, "--out", "-o", metavar="FILE",
                             help="File to write (default: beside GAINS, GAINS.sinamics.txt, .odrive.py, .pid.ini, "
                                  ".ax8000.xml, .yaskawa.txt)."),
    torque_constant: float = TORQUE_CONSTANT_OPTION,
    lead: float = LEAD_OPTION,
    fs: float = FS_OPTION,
    position_fs: float = POSITION_FS_OPTION,
    u_max: float = typer.Option(None, "--u-max", metavar="U",
                                help="LinuxCNC: MAX_OUTPUT, the output limit in the command unit (default 0: none)."),
    machine_unit: str = MACHINE_UNIT_OPTION,
    inertia: float = INERTIA_OPTION,
    axis: str = typer.Option("AX1", "--axis", metavar="NAME", help="SINAMICS: the NC axis of MD32200."),
    encoder_bandwidth: float = typer.Option(None, "--encoder-bandwidth", metavar="RAD_S",
                                            help="ODrive: encoder.config.bandwidth [rad/s] (default: the law's PT2 "
                                                 "with D = 1, else the firmware's 1000)."),
    odrive_json: bool = typer.Option(False, "--odrive-json",
                                     help="ODrive: write the JSON of odrivetool backup-config instead of odrivetool "
                                          "lines."),
    limits: str = LIMITS_OPTION,
    force: bool = FORCE_OPTION,
    as_json: bool = JSON_OPTION,
    quiet: bool = QUIET_OPTION,
) -> None:
    """Write a drive's parameter set, re-certified as the drive runs it.

    Write the cascade gains file as TARGET's parameters (SINAMICS S120 p1460/p1462/p1656-p1676 and MD32200; ODrive
    0.5.x controller.config; LinuxCNC pid [JOINT_n] P, I, D, FF0-FF2; AX8000 CoE startup list 0x3140:01/02,
    0x30C0:01; Yaskawa Sigma-II Pn100-Pn102, Pn401), every conversion in a comment; read the text
    back into the law the target runs (its rates, its rounding, without what it cannot express), certify that law on
    the same FRFs and print max |dL|, dMs and the change of the first crossover against the file's law. Refused
    (exit 1, nothing written) when the target's law fails the limits."""
    show_progress(quiet)
    _check_target(target)
    from ..export.drives import export_drive as run_export
    from ..io import atomic_write_text, read_document
    from ..io.atomic import ensure_writable
    from .delivery import read_sources

    options = _options(torque_constant, lead, fs, position_fs, u_max, machine_unit, None, axis, encoder_bandwidth,
                       inertia)
    policy = limits_from_options(limits, None, None, None, None, None)
    ext = ".odrive.json" if odrive_json and target == "odrive" else EXTENSIONS[target]
    dest = out or gains_file.with_name(gains_file.stem + ext)
    ensure_writable(dest, force)
    doc = read_document(gains_file)
    sources = read_sources(list(frf or []))
    done = run_export(doc, target, options, sources, policy, where=str(gains_file), as_json=odrive_json)
    atomic_write_text(dest, done.written.text, force=force)
    if not done.certificate.on_frfs:
        from .envelope import warn

        warn(f"{gains_file}: the law {target} runs is checked on the file's model alone, not certified on a measured "
             "FRF; pass --frf to certify it")
    if as_json:
        from .envelope import emit

        emit({"target": target, "out": str(dest), "text": done.written.text, **done.to_dict(OPTION_NAMES)})
        return
    for line in done.written.dropped:
        typer.echo(f"not expressed by {target}: {line}")
    for line in done.notes:
        typer.echo(f"note: {line}")
    on = ("the file's model alone (not certified on a measured FRF: give --frf)" if not done.certificate.on_frfs
          else ", ".join(c.name for c in done.certificate_target.frfs))
    typer.echo(f"the law {target} runs, checked on {on} ({policy.describe()}): passes")
    for c in done.changes:
        typer.echo("  " + c.line())
    typer.echo(f"wrote {dest}")


@import_app.command("drive")
def import_drive(
    target: str = TARGET_ARGUMENT,
    file: Path = typer.Argument(..., metavar="FILE", help="The drive's parameter file (as export drive writes it)."),
    out: Path = typer.Option(None, "--out", "-o", metavar="GAINS",
                             help="Gains file to write (.toml with its JSON twin, or .json; default FILE.toml)."),
    torque_constant: float = TORQUE_CONSTANT_OPTION,
    lead: float = LEAD_OPTION,
    command_unit: str = typer.Option(None, "--command-unit", metavar="UNIT",
                                     help="The gains file's command unit: A (with --torque-constant) for SINAMICS and "
                                          "ODrive (default N*m); LinuxCNC: the pid output's unit when the file does "
                                          "not say."),
    fs: float = FS_OPTION,
    position_fs: float = POSITION_FS_OPTION,
    machine_unit: str = MACHINE_UNIT_OPTION,
    inertia: float = INERTIA_OPTION,
    force: bool = FORCE_OPTION,
    as_json: bool = JSON_OPTION,
    quiet: bool = QUIET_OPTION,
) -> None:
    """Read a drive's parameter file into a cascade gains file.

    Read TARGET's parameter file (SINAMICS parameter list, ODrive odrivetool lines or backup-config JSON, LinuxCNC
    INI, AX8000 CoE startup list, Yaskawa parameter list) into the cascade gains file of the law the drive runs, so
    that the drive's tuning is analysed (feedtune analyze GAINS --frf FRF) and compared with feedtune's on the same
    FRF."""
    show_progress(quiet)
    _check_target(target)
    from ..export.drives import import_drive as run_import
    from ..io import write_document
    from ..io._table import read_text
    from ..io.document import ensure_document_writable

    options = _options(torque_constant, lead, fs, position_fs, None, machine_unit, command_unit, inertia=inertia)
    dest = out or file.with_suffix(".toml")
    ensure_document_writable(dest, force)
    text, _ = read_text(file, "drive parameter")
    doc = run_import(text, target, options, where=str(file))
    written = write_document(dest, doc, force=force)
    if as_json:
        from .envelope import emit

        emit({"target": target, "out": [str(p) for p in written], "document": doc})
        return
    from ..io.cascade_gains import cascade_from_document

    law, _, _ = cascade_from_document(doc, str(dest))
    typer.echo(f"{target}: {law!r}")
    for note in doc.get("design", {}).get("notes", []):
        typer.echo(f"note: {note}")
    typer.echo("wrote " + ", ".join(str(p) for p in written))
