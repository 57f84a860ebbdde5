"""The ``feedtune`` command line: a thin layer over the library.

Every command parses options, calls library functions, writes files and prints a summary, or one JSON
object with ``--json``. Errors are one line on stderr with exit code 2 (usage) or 1 (data, design).
Library imports happen inside the commands so ``feedtune --help`` stays fast.
"""

from __future__ import annotations

import os
import re
import sys

import typer

from . import (
    analyze_cmd,
    cascade_cmd,
    demo_cmd,
    design_cmd,
    design_gantry_cmd,
    design_loopshape_cmd,
    design_shaper_cmd,
    drive_cmd,
    explore_cmd,
    export_cmd,
    export_targets_cmd,
    fleet_cmd,
    frf_cmd,
    guard,
    help_text,
    identify_cmd,
    identify_gantry_cmd,
    identify_resonances_cmd,
    log_cmd,
    prefilter_cmd,
    project_cmd,
    report_cmd,
    simulate_cmd,
    simulate_gantry_cmd,
    trajectory_cmd,
    tune_cmd,
    warmup_cmd,
)
from .start import RECEIVED, Signalled, exit_signalled, install_handlers, restore_handlers

app = typer.Typer(
    rich_markup_mode="rich",
    name="feedtune",
    help="Identify and tune precision feed drives: ball-screw drives and linear-motor gantries.",
    epilog="Start with [bold]feedtune demo --out demo_out[/bold] (the main job on the ball-screw twin, no input "
           "files); every command's --help ends with an example that runs from the repository root.",
    no_args_is_help=True,
    add_completion=True,
    pretty_exceptions_enable=False,
    context_settings={"help_option_names": ["-h", "--help"]},
)


def _print_version(value: bool) -> None:
    if value:
        from .. import __version__

        typer.echo(f"feedtune {__version__}")
        raise typer.Exit()


@app.callback()
def _root(
    version: bool = typer.Option(False, "--version", callback=_print_version, is_eager=True,
                                 help="Print the version and exit."),
) -> None:
    """Identify and tune precision feed drives: ball-screw drives and linear-motor gantries."""


# gantry commands join the machine-independent groups
identify_cmd.app.command("gantry")(identify_gantry_cmd.gantry)
identify_cmd.app.command("mass")(identify_gantry_cmd.mass)
identify_cmd.app.command("resonances")(identify_resonances_cmd.resonances)
design_cmd.app.command("loopshape")(design_loopshape_cmd.loopshape)
design_cmd.app.command("gantry")(design_gantry_cmd.gantry)
design_cmd.app.command("pid")(design_gantry_cmd.pid)
design_cmd.app.command("cascade")(cascade_cmd.design)
design_cmd.app.command("shaper")(design_shaper_cmd.shaper)
export_cmd.app.command("klipper")(export_targets_cmd.klipper)
export_cmd.app.command("marlin")(export_targets_cmd.marlin)
export_cmd.app.command("linuxcnc")(export_targets_cmd.linuxcnc)
export_cmd.app.command("drive")(drive_cmd.export_drive)
simulate_cmd.app.add_typer(simulate_gantry_cmd.app, name="gantry")

app.add_typer(identify_cmd.app, name="identify")
app.add_typer(frf_cmd.app, name="frf")
app.add_typer(design_cmd.app, name="design")
app.command("tune")(tune_cmd.tune)
app.command("prefilter")(prefilter_cmd.prefilter)
app.add_typer(analyze_cmd.app, name="analyze")
app.add_typer(export_cmd.app, name="export")
app.add_typer(drive_cmd.import_app, name="import")
app.command("report")(report_cmd.report)
app.command("explore")(explore_cmd.explore)
app.add_typer(simulate_cmd.app, name="simulate")
app.command("trajectory")(trajectory_cmd.trajectory)
app.command("demo")(demo_cmd.demo)
app.command("warmup")(warmup_cmd.warmup)
app.add_typer(log_cmd.app, name="log")
app.add_typer(fleet_cmd.app, name="fleet")
app.add_typer(project_cmd.app, name="project")
help_text.prepare_help(app)
guard.install(app)  # finite numbers, writable outputs: checked before any command's own code


DEPRECATED_OPTIONS = {
    ("simulate", "gantry", "frf"): {"--keep-delay": "--keep-sampling"},
    ("simulate", "gantry", "axis-frf"): {"--keep-delay": "--keep-sampling"},
    ("design", "gantry"): {"--x": "--design-x"},
    ("design", "pid"): {"--x": "--design-x"},
}
"""Old spellings still accepted, per command, with a warning on stderr; the help shows only the new one. One idea, one
spelling: ``--keep-sampling`` keeps the ZOH and the computational delay in a simulated FRF (as ``simulate frf``;
``frf --remove-sampling`` is its counterpart for logs), ``--design-x`` is the table position a gantry design is made
at (as ``tune``, where ``--x`` gives the FRFs' positions)."""


def renamed_options(args: list[str]) -> list[str]:
    """``args`` with the deprecated option spellings of :data:`DEPRECATED_OPTIONS` replaced (``--x 0.1`` and
    ``--x=0.1``), each announced once on stderr; arguments after ``--`` are left alone."""
    path = []
    for a in args:
        if a.startswith("-"):
            break
        path.append(a)
    renames = next((r for command, r in DEPRECATED_OPTIONS.items() if tuple(path[:len(command)]) == command), None)
    if not renames:
        return list(args)
    out: list[str] = []
    for i, a in enumerate(args):
        if a == "--":
            return out + list(args[i:])
        name, eq, value = a.partition("=")
        if name in renames:
            typer.echo(f"feedtune: warning: {name} is deprecated; use {renames[name]}", err=True)
            a = renames[name] + eq + value
        out.append(a)
    return out


def _invocation() -> dict:
    """Keyword arguments of the command line's run beyond the defaults: the arguments when a deprecated spelling was
    renamed (:func:`renamed_options`), and the program name ``feedtune`` under ``python -m feedtune`` (usage lines,
    the completion variable ``_FEEDTUNE_COMPLETE``)."""
    extra: dict = {}
    args = renamed_options(sys.argv[1:])
    if args != sys.argv[1:]:
        extra["args"] = args
    if getattr(sys.modules.get("__main__"), "__package__", None) == "feedtune":
        extra["prog_name"] = "feedtune"
    return extra


def main() -> None:
    """Run the command line in this process (tests, notebooks; the console script starts at
    :func:`feedtune.cli.start.main`, which installs the handlers before importing this module).

    Exit codes (docs/conventions.md): 0 success, 1 data or design error, 2 usage error, 130 interrupted (SIGINT,
    "feedtune: interrupted"), 143 terminated (SIGTERM), 141 when stdout is closed early (a pipe into ``head``:
    quiet). Temporary files of unfinished outputs are removed on SIGINT and SIGTERM. The caller's signal handlers
    are put back at the end.
    """
    handlers = install_handlers()
    try:
        run()
    finally:  # main() called in-process (tests, notebooks) leaves the caller's signal handling as it was
        restore_handlers(handlers)


def run() -> None:
    """Run the command line and turn its outcome into an exit code and at most one line on stderr (:func:`main`):
    feedtune's errors, the parser's usage errors (:func:`usage_message`) and the errors of the machine (memory, file
    system, nesting, overflow: :func:`environment_message`) each as one ``feedtune: error: ...`` line; anything
    else is a bug, reported as an internal error."""
    from ..errors import FeedtuneError, cli_message

    args = _invocation()
    try:
        args = _with_project(args)
        with _cli_warnings():
            code = _command()(standalone_mode=False, **args)
    except FeedtuneError as exc:
        if RECEIVED:
            exit_signalled(RECEIVED[0])
        text = command_spelling(cli_message(exc, getattr(exc, "options", None)), args.get("args", sys.argv[1:]))
        _error_line(text)  # parameters named by their options
        sys.exit(exc.exit_code)
    except (KeyboardInterrupt, typer.Abort):
        _say("feedtune: interrupted")
        sys.exit(130)
    except Signalled as sig:
        exit_signalled(sig.signum)
    except BrokenPipeError:
        _quiet_stdout()
        sys.exit(141)
    except Exception as exc:  # the parser's usage errors (click's, or typer's copy of click), or a bug
        if RECEIVED:  # the signal's exception was swallowed and this is what followed
            exit_signalled(RECEIVED[0])
        if _is_parser_error(exc):
            if type(exc).__name__ == "NoArgsIsHelpError":  # 'feedtune design': the group's help is the answer
                exc.show()
            else:
                _error_line(usage_message(exc, args.get("args", sys.argv[1:])))
            sys.exit(exc.exit_code)
        if os.environ.get("FEEDTUNE_DEBUG"):
            raise
        text = environment_message(exc)
        if text is not None:
            _error_line(text)
            sys.exit(1)
        _say(f"feedtune: internal error: {type(exc).__name__}: {' '.join(str(exc).split())[:300]} (set "
             "FEEDTUNE_DEBUG=1 for a traceback)")
        sys.exit(1)
    try:
        sys.stdout.flush()
    except BrokenPipeError:
        _quiet_stdout()
        sys.exit(141)
    sys.exit(code if isinstance(code, int) else 0)


def _with_project(invocation: dict) -> dict:
    """The run's keyword arguments with a project file's arguments filled in (:func:`feedtune.cli.project_args.
    expand`) and, for the documents the command writes, the command line as run and the project file (the root
    context's ``obj``: :func:`feedtune.cli.guard.run_record`)."""
    from .project_args import command_text, expand

    given = invocation.get("args", sys.argv[1:])
    args, project = expand(list(given), _command())
    out = {**invocation, "obj": {"command": command_text(args), "project": project}}
    if args != list(given):
        out["args"] = args
    return out


_COMMANDS: list = []


def _command():
    """The click command of :data:`app`, built once per process (typer builds it anew on every call of ``app``, 40 ms:
    the cost of every in-process run, such as the bad-input corpus's hundreds)."""
    if not _COMMANDS:
        from typer.main import get_command

        _COMMANDS.append(get_command(app))
    return _COMMANDS[0]


def _say(line: str) -> None:
    typer.echo(line, err=True)


def _error_line(text: str) -> None:
    """``feedtune: error: TEXT`` on one line (a message's line breaks become spaces)."""
    _say(f"feedtune: error: {' '.join(str(text).split())}")


GENERIC_PARAMETERS = frozenset({"out", "force", "as_json", "quiet", "time", "map_", "scale", "unit", "x", "input_",
                                "output", "error", "position", "reference", "band", "channel", "mass", "method"})
"""Parameters whose names are ordinary words: :func:`command_spelling` leaves them to the library's own mapping
(``parameter=``), never to a guess."""


def command_spelling(text: str, args: list[str]) -> str:
    """``text`` with the running command's own parameter names replaced by its options: a name with an underscore
    (``v_max``, ``t_release``) wherever it stands as a word, any other name (``cycles``, ``nperseg``) where it begins
    the message or is written ``name=``. A library error names the parameter of the function the command called; the
    command line calls it with the option of that name (``--v-max``, ``--cycles``): the user reads what they typed.
    """
    options = _command_options(args)
    for name, option in sorted(options.items(), key=lambda kv: -len(kv[0])):
        if name in GENERIC_PARAMETERS:
            continue
        word = re.escape(name)
        if "_" in name:
            text = re.sub(rf"(?<![\w.\-/\\]){word}(?![\w\-/\\])", option, text)
        else:
            text = re.sub(rf"^{word}(?=[\s:\[=])", option, text)
            text = re.sub(rf"(?<![\w.\-/\\]){word}=", option + " ", text)
    return text


def _command_options(args: list[str]) -> dict[str, str]:
    """``{parameter: --option}`` of the leaf command ``args`` name (empty when it is not found)."""
    try:
        cmd = _command()
    except Exception:  # pragma: no cover - the command tree cannot be built: no mapping
        return {}
    for token in args:
        subs = getattr(cmd, "commands", None)
        if not subs:
            break
        if token in subs:
            cmd = subs[token]
        elif not token.startswith("-") and getattr(cmd, "default_command", None) in subs:  # analyze GAINS, frf LOG
            cmd = subs[cmd.default_command]
        else:
            break
    out = {}
    for p in getattr(cmd, "params", []):
        longs = [o for o in (getattr(p, "opts", None) or []) if o.startswith("--")]
        if longs and p.name:
            out[p.name] = longs[0]
    return out


def _is_parser_error(exc: BaseException) -> bool:
    """Whether ``exc`` is the parser's (click's, or typer's copy of click): it carries an int exit code and shows
    itself."""
    return hasattr(exc, "show") and isinstance(getattr(exc, "exit_code", None), int) and hasattr(exc, "format_message")


def usage_message(exc: BaseException, args: list[str]) -> str:
    """One line for a parser error, naming the option or argument and the value given, and where the help is:
    ``--seed -1: input should be greater than or equal to 0 (see feedtune simulate frf --help)``."""
    text = " ".join(str(exc.format_message()).split()).rstrip(".")
    param = getattr(exc, "param", None)
    opts = [o for o in (getattr(param, "opts", None) or []) if o.startswith("-")]
    name = type(exc).__name__
    if param is not None and name == "MissingParameter":
        what = opts[0] if opts else (getattr(param, "metavar", None) or str(param.name).upper())
        text = f"missing {'option' if opts else 'argument'} {what}"
    elif param is not None and opts:
        value = _given_value(args, opts)
        head = next((o for o in opts if o.startswith("--")), opts[0])
        for o in opts:
            text = text.replace(f"Invalid value for '{o}': ", "").replace(f"Invalid value for '{o}' / ", "")
        text = re.sub(r"^Invalid value for '[^']*': ", "", text)
        shown = "" if value is None else " " + (value if value and " " not in value else repr(value))
        text = f"{head}{shown}: {text[:1].lower()}{text[1:]}"
    elif param is not None:
        metavar = getattr(param, "metavar", None) or str(param.name).upper()
        text = f"{metavar}: {text}"
    else:
        text = text[:1].lower() + text[1:]
    ctx = getattr(exc, "ctx", None)
    path = getattr(ctx, "command_path", None)
    return f"{text} (see {path} --help)" if path else text


def _given_value(args: list[str], opts: list[str]) -> str | None:
    """The value given to an option on the command line (``--seed -1``, ``--seed=-1``), or None."""
    for i, a in enumerate(args):
        if a == "--":
            break
        for o in opts:
            if a == o and i + 1 < len(args):
                return args[i + 1]
            if a.startswith(o + "=") and o.startswith("--"):
                return a[len(o) + 1:]
    return None


def environment_message(exc: BaseException) -> str | None:
    """One line for an error of the machine rather than of feedtune's code: memory exhausted, a file-system error,
    input nested too deeply, an overflow; None for anything else. Readers and commands check sizes, nesting and
    ranges before they get here (:mod:`feedtune.budget`); this is the last line of defence."""
    from ..budget import ENV_VARIABLE

    if isinstance(exc, MemoryError):
        return (f"out of memory ({' '.join(str(exc).split())[:160] or 'MemoryError'}); give smaller inputs or "
                f"options, or lower {ENV_VARIABLE} so that the sizes are checked against it")
    if isinstance(exc, RecursionError):
        return "an input is nested too deeply to be read"
    if isinstance(exc, OverflowError):
        return f"a number is beyond the range of a float ({' '.join(str(exc).split())[:160]})"
    if isinstance(exc, OSError):
        from ..io.atomic import os_error_text

        where = exc.filename if exc.filename is not None else "a file"
        return f"{where}: {os_error_text(exc)}"
    return None


class _cli_warnings:  # noqa: N801 (a context manager used as a statement)
    """Within a run, feedtune's own warnings (:class:`feedtune.errors.FeedtuneWarning`,
    :class:`feedtune._kernel_cache.KernelCacheWarning`) print as one ``feedtune: warning: ...`` line, its notes
    (:class:`feedtune.errors.FeedtuneNote`) as ``feedtune: note: ...``."""

    def __enter__(self):
        import warnings

        from .._kernel_cache import KernelCacheWarning
        from ..errors import FeedtuneNote, FeedtuneWarning

        self._show = warnings.showwarning

        def show(message, category, filename, lineno, file=None, line=None):
            if issubclass(category, FeedtuneNote):
                _say(f"feedtune: note: {' '.join(str(message).split())}")
            elif issubclass(category, (KernelCacheWarning, FeedtuneWarning)):
                _say(f"feedtune: warning: {' '.join(str(message).split())}")
            else:
                self._show(message, category, filename, lineno, file, line)

        warnings.showwarning = show
        return self

    def __exit__(self, *exc):
        import warnings

        warnings.showwarning = self._show
        return False


def _quiet_stdout() -> None:
    """After a broken pipe: send what is left of stdout to /dev/null so the exit is quiet."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
    except (OSError, ValueError):
        pass


if __name__ == "__main__":
    main()
