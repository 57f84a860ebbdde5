"""``feedtune project init``: write a project file (``feedtune.toml``) from the files and options given.

The file (:mod:`feedtune.io.project_file`) names the axis' model, FRFs, gains file and logs once, the limits, and
the options of ``tune``, ``analyze`` and ``report``; those commands then run in its folder without arguments
(:mod:`feedtune.cli.project_args`). The keys given with ``--set`` are checked against the commands' options before
anything is written; an existing project file is replaced only with ``--force``.
"""

from __future__ import annotations

from pathlib import Path

import typer

from .common import FORCE_OPTION, JSON_OPTION
from .help_text import LIMITS_PROFILES, choice
from .limits_options import (
    DM_MIN_OPTION,
    GM_LOW_MIN_OPTION,
    GM_MIN_OPTION,
    MS_MAX_OPTION,
    PM_MIN_OPTION,
    limits_from_options,
)
from .progress_display import QUIET_OPTION, show_progress

app = typer.Typer(rich_markup_mode="rich", no_args_is_help=True,
                  help="Project files: an axis' files and the options of its commands (feedtune.toml).")


def _value(text: str):
    """A ``--set`` value: a TOML value when it reads as one (``2.5``, ``true``, ``["a", "b"]``), else the text."""
    import tomllib

    try:
        return tomllib.loads(f"v = {text}")["v"]
    except tomllib.TOMLDecodeError:
        return text


def parse_sets(items: list[str] | None) -> dict[str, dict]:
    """``{section: {key: value}}`` of ``--set SECTION.KEY=VALUE`` items (UsageError naming the item)."""
    from ..errors import UsageError
    from ..io.project_file import COMMAND_SECTIONS

    out: dict[str, dict] = {}
    for item in items or []:
        name, eq, text = item.partition("=")
        section, dot, key = name.strip().partition(".")
        if not eq or not dot or not key or section not in COMMAND_SECTIONS:
            raise UsageError(f"--set {item}: expected SECTION.KEY=VALUE with SECTION one of "
                             f"{', '.join(COMMAND_SECTIONS)} (e.g. --set tune.filters=own)")
        out.setdefault(section, {})[key.strip()] = _value(text.strip())
    return out


@app.command("init")
def init(
    model: Path = typer.Option(None, "--model", metavar="FILE", help="The axis' model file (tune's MODEL)."),
    frf: list[Path] = typer.Option(
        None, "--frf", metavar="FRF", help="Measured FRF, repeatable (--frf of tune and analyze; report inputs)."),
    gains: Path = typer.Option(
        None, "--gains", metavar="FILE",
        help="The gains file (tune's --out, analyze's GAINS, a report input); it need not exist yet."),
    log: list[Path] = typer.Option(None, "--log", metavar="LOG", help="A log for the report, repeatable."),
    name: str = typer.Option(None, "--name", metavar="TEXT", help="The axis' name."),
    structure: str = typer.Option(
        None, "--structure", metavar="STRUCTURE", help="What 'feedtune tune' tunes: mcppc, ppi, gantry, pid, "
                                                       "loopshape or cascade."),
    limits: str = typer.Option(None, "--limits", **choice(LIMITS_PROFILES),
                               help="The limits profile of every command (textbook or thesis)."),
    ms_max: float = MS_MAX_OPTION,
    pm_min: float = PM_MIN_OPTION,
    gm_min: float = GM_MIN_OPTION,
    gm_low_min: float = GM_LOW_MIN_OPTION,
    dm_min: float = DM_MIN_OPTION,
    set_: list[str] = typer.Option(
        None, "--set", metavar="SECTION.KEY=VALUE",
        help="An option of tune, analyze or report, by its name without dashes (repeatable): --set "
             "tune.filters=own, --set report.out=report.html, --set report.pdf=true."),
    project_out: Path = typer.Option(  # not named out: a folder is allowed, checked here (not by the guard)
        Path("feedtune.toml"), "--out", "-o", metavar="FILE|DIR",
        help="Project file to write (default feedtune.toml here; a folder: its feedtune.toml)."),
    force: bool = FORCE_OPTION,
    as_json: bool = JSON_OPTION,
    quiet: bool = QUIET_OPTION,
) -> None:
    """Write a project file (feedtune.toml) for tune, analyze and report.

    It names the axis' files (model, FRFs, gains file, logs), the limits and the options of each command.

    In the project's folder, 'feedtune tune', 'feedtune analyze' and 'feedtune report' then run without arguments
    (elsewhere: --project PATH), each with the options the file gives and those typed (typed ones win). Paths are
    written relative to the project file."""
    show_progress(quiet)
    from ..errors import UsageError
    from ..io.project_file import PROJECT_FILE, Project, project_document, relative_to, write_project
    from .envelope import _context
    from .project_args import PROJECT_COMMANDS, project_values

    limits_from_options(limits or "textbook", ms_max, pm_min, gm_min, dm_min, gm_low_min)  # checked before writing
    path = project_out / PROJECT_FILE if project_out.is_dir() else project_out
    if path.suffix.lower() != ".toml":
        raise UsageError(f"--out {project_out}: a project file is TOML; give a name ending in .toml")
    from ..io.atomic import ensure_writable

    ensure_writable(path, force)
    for option, files in (("--model", [model] if model else []), ("--frf", frf or []), ("--log", log or [])):
        for f in files:
            if not f.is_file():
                raise UsageError(f"{option} {f}: no such file")
    folder = path.parent
    rel = {"model": relative_to(model, folder) if model else None,
           "frf": [relative_to(f, folder) for f in frf or []], "gains": relative_to(gains, folder) if gains else None,
           "logs": [relative_to(f, folder) for f in log or []]}
    limit_values = {k: v for k, v in (("profile", limits), ("ms_max", ms_max), ("pm_min", pm_min),
                                      ("gm_min", gm_min), ("gm_low_min", gm_low_min), ("dm_min", dm_min))
                    if v is not None}
    sections = parse_sets(set_)
    if structure is not None:
        sections["tune"] = {"structure": structure, **sections.get("tune", {})}
    doc = project_document(name=name, limits=limit_values, commands=sections, **rel)
    root = _context().find_root().command
    project = Project(path.resolve(), name, commands=sections)
    from ..errors import DataError

    for command_path, section in PROJECT_COMMANDS.items():  # every key an option of its command: checked now
        command = root
        for token in command_path:
            command = command.commands[token]
        try:
            project_values(project, section, command)
        except DataError as exc:
            raise UsageError("--set " + str(exc).split(": ", 1)[1]) from None
    written = write_project(path, doc, force=force)
    result = {"project": str(written), "document": doc}
    if as_json:
        from .envelope import emit

        emit(result)
        return
    files = ", ".join(f"{k} {v if isinstance(v, str) else len(v)}" for k, v in rel.items() if v)
    typer.echo(f"wrote {written} ({files or 'no files'}); run 'feedtune tune', 'feedtune analyze' or "
               f"'feedtune report' in {folder if str(folder) != '.' else 'this folder'}, or with --project {written}")
