"""``feedtune export klipper|marlin|linuxcnc``: input shapers for printer firmwares, and a gains file as a LinuxCNC
HAL component (docs/drive_export.md)."""

from __future__ import annotations

from pathlib import Path

import typer

from .common import FORCE_OPTION, JSON_OPTION
from .help_text import ANTI_WINDUP, choice
from .limits_options import LIMITS_OPTION, OPTION_NAMES, limits_from_options
from .progress_display import QUIET_OPTION, show_progress

SHAPER_FILES = typer.Argument(
    ..., metavar="SHAPER...",
    help="Shaper documents (design shaper --psd/--mode --out) or gains files with a [shaper], one per axis.",
)
AXIS_OPTION = typer.Option(
    None, "--axis", metavar="AXIS",
    help="Axis of each file, in order (repeatable; default the axis a shaper document records, x for a gains file).",
)


def _shapers(files: list[Path], axes: list[str] | None) -> list[tuple[object, str]]:
    from ..errors import UsageError
    from ..io import read_document
    from ..io.shaper_file import read_shaper

    if axes and len(axes) != len(files):
        raise UsageError(f"--axis: give one per file ({len(files)}), got {len(axes)}")
    out = []
    for i, path in enumerate(files):
        shaper, axis = read_shaper(read_document(path), str(path))
        out.append((shaper, axes[i] if axes else (axis or "x")))
    return out


def _write_text(target: str, files: list[Path], axes, out: Path | None, force: bool, as_json: bool) -> None:
    from ..export.printer import TARGETS
    from ..io import atomic_write_text

    shapers = _shapers(files, axes)
    text = TARGETS[target](shapers, [str(p) for p in files])
    if out is not None:
        atomic_write_text(out, text, force=force)
    if as_json:
        from .envelope import emit

        emit({"target": target, "out": None if out is None else str(out), "text": text,
              "shapers": [{"axis": a, "type": s.kind, "freq_hz": s.freq_hz, "damping": s.damping} for s, a in shapers],
              "units": {"freq_hz": "Hz", "damping": "-"}})
    else:
        typer.echo(text, nl=False) if out is None else typer.echo(f"wrote {out}")


def klipper(
    files: list[Path] = SHAPER_FILES,
    axis: list[str] = AXIS_OPTION,
    out: Path = typer.Option(None, "--out", "-o", metavar="FILE", help="File to write (default: print the section)."),
    force: bool = FORCE_OPTION,
    as_json: bool = JSON_OPTION,
    quiet: bool = QUIET_OPTION,
) -> None:
    """Write Klipper's [input_shaper] section.

    Write Klipper's [input_shaper] section (shaper_type_x, shaper_freq_x [Hz], damping_ratio_x [-]; y likewise) for
    the shapers of the files, one per axis: Klipper rebuilds each shaper from these three numbers."""
    show_progress(quiet)
    _write_text("klipper", files, axis, out, force, as_json)


def marlin(
    files: list[Path] = SHAPER_FILES,
    axis: list[str] = AXIS_OPTION,
    out: Path = typer.Option(None, "--out", "-o", metavar="FILE", help="File to write (default: print the G-code)."),
    force: bool = FORCE_OPTION,
    as_json: bool = JSON_OPTION,
    quiet: bool = QUIET_OPTION,
) -> None:
    """Write Marlin's M593 (ZV) or M493 (ZVD) G-code.

    Write the G-code that sets Marlin's input shaper: M593 X F<Hz> D<zeta> for ZV; M493 S11 A<Hz> for ZVD by fixed-time
    motion (no damping ratio there); other types are refused, M493 numbering them differently between versions."""
    show_progress(quiet)
    _write_text("marlin", files, axis, out, force, as_json)


def linuxcnc(
    gains_file: Path = typer.Argument(..., metavar="GAINS", help="Gains file of any kind (ball screw, gantry, axis)."),
    out: Path = typer.Option(None, "--out", "-o", metavar="FILE",
                             help="Component source to write (default: NAME.c beside GAINS)."),
    name: str = typer.Option("feedtune", "--name", metavar="NAME",
                             help="Component name: module, pin and function prefix (NAME.0.u)."),
    u_max: float = typer.Option(None, "--u-max", metavar="U", help="Output limit in the command unit (as export c)."),
    scale_out: str = typer.Option(None, "--scale-out", metavar="FACTOR",
                                  help="Drive unit per command unit of the file, a number or A/B (as export c)."),
    out_unit: str = typer.Option(None, "--out-unit", metavar="UNIT", help="The drive's unit with --scale-out."),
    anti_windup: str = typer.Option("none", "--anti-windup", **choice(ANTI_WINDUP),
                                    help="clamp: conditional integration at --u-max (as export c)."),
    frf: list[Path] = typer.Option(None, "--frf", metavar="FRF",
                                   help="Measured FRF to certify the gains on first (repeatable; as export c)."),
    limits: str = LIMITS_OPTION,
    allow_unstable: bool = typer.Option(False, "--allow-unstable",
                                        help="Export a design that fails the limits check (the source says so)."),
    force: bool = FORCE_OPTION,
    as_json: bool = JSON_OPTION,
    quiet: bool = QUIET_OPTION,
) -> None:
    """Write a LinuxCNC HAL component that runs the gains file.

    Write the C source of a LinuxCNC realtime HAL component (halcompile --install NAME.c) that runs the gains file's
    law (its export c header, [shaper] included) on the servo thread, with pins in the file's units, an enable pin
    that starts the law from the reference as origin, and a rate-fault pin when the thread's period is not 1/fs. The
    design is checked as export c checks it."""
    show_progress(quiet)
    from ..export.linuxcnc import hal_component, pin_list
    from ..io import atomic_write_text, read_document
    from ..io.atomic import ensure_writable
    from .delivery import read_sources
    from .export_cmd import checked_for_export, scale_factor_option

    policy = limits_from_options(limits, None, None, None, None, None)
    target = out or gains_file.with_name(f"{name}.c")
    ensure_writable(target, force)
    doc = read_document(gains_file)
    options = {"u_max": u_max, "anti_windup": anti_windup, "scale_out": scale_factor_option(scale_out),
               "out_unit": out_unit}
    hal_component(doc, name=name, where=str(gains_file), **options)  # options and document first
    verdict, warning = checked_for_export(doc, gains_file, read_sources(list(frf or [])), policy, allow_unstable,
                                          as_json, "export linuxcnc")
    text = hal_component(doc, name=name, where=str(gains_file), warning=warning, **options)
    atomic_write_text(target, text, force=force)
    pins = pin_list(doc, name)
    if as_json:
        from .envelope import emit

        emit({"gains_kind": doc.get("kind"), "out": str(target), "name": name, "bytes": len(text.encode()),
              "pins": [{"pin": p, "type": t, "note": n} for p, t, n in pins], "u_max": u_max,
              "anti_windup": anti_windup, "verdict": verdict.to_dict(OPTION_NAMES)})
    else:
        typer.echo(f"verdict on {verdict.basis_text()}: {'passes' if verdict.ok else 'FAILS'} ({policy.describe()})")
        typer.echo(f"pins of {name}.0 (function {name}.0.update):")
        for p, t, n in pins:
            typer.echo(f"  {p:28s} {t:10s} {n}")
        typer.echo(f"wrote {target}")
