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
    export_cmd,
    frf_cmd,
    identify_cmd,
    identify_gantry_cmd,
    prefilter_cmd,
    report_cmd,
    simulate_cmd,
    simulate_gantry_cmd,
    trajectory_cmd,
    tune_cmd,
)

app = typer.Typer(
    rich_markup_mode=None,
    name="feedtune",
    help="Identify and tune precision feed drives: ball-screw drives and linear-motor gantries.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
    context_settings={"help_option_names": ["-h", "--help"]},
)
# gantry commands join the machine-independent groups
identify_cmd.app.command("gantry")(identify_gantry_cmd.gantry)
identify_cmd.app.command("mass")(identify_gantry_cmd.mass)
design_cmd.app.command("loopshape")(design_gantry_cmd.loopshape)
design_cmd.app.command("gantry")(design_gantry_cmd.gantry)
design_cmd.app.command("pid")(design_gantry_cmd.pid)
simulate_cmd.app.add_typer(simulate_gantry_cmd.app, name="gantry")

app.add_typer(identify_cmd.app, name="identify")
app.command("frf")(frf_cmd.frf)
app.add_typer(design_cmd.app, name="design")
app.command("tune")(tune_cmd.tune)
app.command("prefilter")(prefilter_cmd.prefilter)
app.add_typer(analyze_cmd.app, name="analyze")
app.add_typer(export_cmd.app, name="export")
app.command("report")(report_cmd.report)
app.add_typer(simulate_cmd.app, name="simulate")
app.command("trajectory")(trajectory_cmd.trajectory)
app.command("demo")(demo_cmd.demo)


BLAS_THREAD_VARIABLES = ("OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "BLIS_NUM_THREADS", "VECLIB_MAXIMUM_THREADS")
"""Set to 1 before numpy loads unless the user set them: feedtune's matrices are tiny (:mod:`feedtune.blas`)."""


def main() -> None:
    """Entry point of the ``feedtune`` console script."""
    from ..errors import FeedtuneError

    for name in BLAS_THREAD_VARIABLES:
        os.environ.setdefault(name, "1")

    try:
        app()
    except FeedtuneError as exc:
        typer.echo(f"feedtune: error: {exc}", err=True)
        sys.exit(exc.exit_code)
    except KeyboardInterrupt:
        typer.echo("feedtune: interrupted", err=True)
        sys.exit(130)
    except Exception as exc:  # a bug: one line unless asked for the traceback
        if os.environ.get("FEEDTUNE_DEBUG"):
            raise
        typer.echo(
            f"feedtune: internal error: {type(exc).__name__}: {exc} (set FEEDTUNE_DEBUG=1 for a traceback)", err=True
        )
        sys.exit(1)


if __name__ == "__main__":
    main()
