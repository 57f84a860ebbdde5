"""``feedtune warmup``: compile the kernels ahead (:mod:`feedtune.workflows.warmup`)."""

from __future__ import annotations

import typer

from .common import JSON_OPTION
from .progress_display import QUIET_OPTION, show_progress


def warmup(
    again: bool = typer.Option(False, "--again", help="Compile even when the kernels are built already."),
    as_json: bool = JSON_OPTION,
    quiet: bool = QUIET_OPTION,
) -> None:
    """Compile feedtune's kernels ahead, once per install.

    Run it after pip install, or in a container's build: the twins' closed loops, the gains files' laws, the CSV
    writer and the Kalman filter are compiled on the machine's cores and kept in the kernel cache. Without it, the
    demos do this first, as the step 'compiling kernels (first run only)', and the other commands compile a kernel
    the first time they use it."""
    show_progress(quiet)
    from ..workflows.warmup import compile_kernels, kernels_ready, stamp_path

    done = kernels_ready() and not again
    seconds = {} if done else compile_kernels()
    folder = str(stamp_path().parent)
    if as_json:
        from .envelope import emit

        emit({"compiled": not done, "kernels_s": seconds, "cache_folder": folder, "units": {"kernels_s": "s"}})
        return
    if done:
        typer.echo(f"the kernels are built already (in {folder}); --again compiles them again")
        return
    typer.echo(f"compiled {len(seconds)} kernels into {folder}: "
               + ", ".join(f"{k} {v:.1f} s" for k, v in seconds.items()))
