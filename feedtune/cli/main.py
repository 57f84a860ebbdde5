"""The ``feedtune`` command line: a thin layer over the library.

Every command parses options, calls library functions, writes files and prints a summary, or one JSON
object with ``--json``. Errors are one line on stderr with exit code 2 (usage) or 1 (data, design).
Library imports happen inside the commands so ``feedtune --help`` stays fast.
"""

from __future__ import annotations

import os
import sys

import typer

from . import (
    analyze_cmd,
    demo_cmd,
    design_cmd,
    design_gantry_cmd,
    design_shaper_cmd,
    export_cmd,
    export_targets_cmd,
    fleet_cmd,
    frf_cmd,
    help_text,
    identify_cmd,
    identify_gantry_cmd,
    identify_resonances_cmd,
    log_cmd,
    prefilter_cmd,
    report_cmd,
    simulate_cmd,
    simulate_gantry_cmd,
    trajectory_cmd,
    tune_cmd,
)

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
design_cmd.app.command("loopshape")(design_gantry_cmd.loopshape)
design_cmd.app.command("gantry")(design_gantry_cmd.gantry)
design_cmd.app.command("pid")(design_gantry_cmd.pid)
design_cmd.app.command("shaper")(design_shaper_cmd.shaper)
export_cmd.app.command("klipper")(export_targets_cmd.klipper)
export_cmd.app.command("marlin")(export_targets_cmd.marlin)
export_cmd.app.command("linuxcnc")(export_targets_cmd.linuxcnc)
simulate_cmd.app.add_typer(simulate_gantry_cmd.app, name="gantry")

app.add_typer(identify_cmd.app, name="identify")
app.add_typer(frf_cmd.app, name="frf")
app.add_typer(design_cmd.app, name="design")
app.command("tune")(tune_cmd.tune)
app.command("prefilter")(prefilter_cmd.prefilter)
app.add_typer(analyze_cmd.app, name="analyze")
app.add_typer(export_cmd.app, name="export")
app.command("report")(report_cmd.report)
app.add_typer(simulate_cmd.app, name="simulate")
app.command("trajectory")(trajectory_cmd.trajectory)
app.command("demo")(demo_cmd.demo)
app.add_typer(log_cmd.app, name="log")
app.add_typer(fleet_cmd.app, name="fleet")
help_text.prepare_help(app)


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


BLAS_THREAD_VARIABLES = ("OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "BLIS_NUM_THREADS", "VECLIB_MAXIMUM_THREADS")
"""Set to 1 before numpy loads unless the user set them: feedtune's matrices are tiny (:mod:`feedtune.blas`)."""


class _Signalled(BaseException):
    """SIGINT or SIGTERM, turned into an exception that the command-line framework does not swallow (typer turns
    KeyboardInterrupt into a silent exit 130), so that ``finally`` blocks remove temporary files."""

    def __init__(self, signum: int):
        super().__init__(signum)
        self.signum = signum


_RECEIVED: list[int] = []
"""Signals received in this run: a library that swallows the exception (numba compiling inside a ctypes callback)
fails later with an error of its own, which is then reported as the interruption it is."""


def _on_signal(signum, frame):
    _RECEIVED.append(signum)
    raise _Signalled(signum)


def _exit_signalled(signum: int):
    import signal

    interrupted = signum == signal.SIGINT
    typer.echo(f"feedtune: {'interrupted' if interrupted else 'terminated'}", err=True)
    sys.exit(130 if interrupted else 143)


def _quiet_stdout() -> None:
    """After a broken pipe: send what is left of stdout to /dev/null so the exit is quiet."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
    except (OSError, ValueError):
        pass


def main() -> None:
    """Entry point of the ``feedtune`` console script.

    Exit codes (docs/conventions.md): 0 success, 1 data or design error, 2 usage error, 130 interrupted (SIGINT,
    "feedtune: interrupted"), 143 terminated (SIGTERM), 141 when stdout is closed early (a pipe into ``head``:
    quiet). Temporary files of unfinished outputs are removed on SIGINT and SIGTERM.
    """
    import signal

    for name in BLAS_THREAD_VARIABLES:
        os.environ.setdefault(name, "1")
    os.environ.setdefault("FEEDTUNE_JOBS", "auto")  # independent steps side by side (feedtune.parallel)
    _RECEIVED.clear()
    handlers = {sig: signal.getsignal(sig) for sig in (signal.SIGTERM, signal.SIGINT)}
    signal.signal(signal.SIGTERM, _on_signal)
    signal.signal(signal.SIGINT, _on_signal)
    if hasattr(signal, "SIGPIPE"):  # a closed stdout (a pipe into head) ends the process quietly, as for cat
        handlers[signal.SIGPIPE] = signal.getsignal(signal.SIGPIPE)
        signal.signal(signal.SIGPIPE, signal.SIG_DFL)
    try:
        _run()
    finally:  # main() called in-process (tests, notebooks) leaves the caller's signal handling as it was
        for sig, handler in handlers.items():
            signal.signal(sig, handler)


def _run() -> None:
    """Run the command line and turn its outcome into an exit code (:func:`main`)."""

    from ..errors import FeedtuneError, cli_message

    try:
        code = app(standalone_mode=False, **_invocation())
    except FeedtuneError as exc:
        if _RECEIVED:
            _exit_signalled(_RECEIVED[0])
        typer.echo(f"feedtune: error: {cli_message(exc)}", err=True)  # parameters named by their options
        sys.exit(exc.exit_code)
    except (KeyboardInterrupt, typer.Abort):
        typer.echo("feedtune: interrupted", err=True)
        sys.exit(130)
    except _Signalled as sig:
        _exit_signalled(sig.signum)
    except BrokenPipeError:
        _quiet_stdout()
        sys.exit(141)
    except Exception as exc:  # the parser's usage errors (click's, or typer's copy of click), or a bug
        if _RECEIVED:  # the signal's exception was swallowed and this is what followed
            _exit_signalled(_RECEIVED[0])
        if hasattr(exc, "show") and isinstance(getattr(exc, "exit_code", None), int):
            exc.show()
            sys.exit(exc.exit_code)
        if os.environ.get("FEEDTUNE_DEBUG"):
            raise
        typer.echo(
            f"feedtune: internal error: {type(exc).__name__}: {exc} (set FEEDTUNE_DEBUG=1 for a traceback)", err=True
        )
        sys.exit(1)
    try:
        sys.stdout.flush()
    except BrokenPipeError:
        _quiet_stdout()
        sys.exit(141)
    sys.exit(code if isinstance(code, int) else 0)


if __name__ == "__main__":
    main()
