"""``feedtune demo``: the main job on the digital twin in one command, with no input files."""

from __future__ import annotations

import os
from pathlib import Path

import typer

from ..machines.registry import machines
from .common import FORCE_OPTION, JSON_OPTION
from .envelope import warn
from .help_text import ENGINES, choice
from .limits_options import (
    DM_MIN_OPTION,
    GM_LOW_MIN_OPTION,
    GM_MIN_OPTION,
    LIMITS_OPTION,
    MS_MAX_OPTION,
    PM_MIN_OPTION,
    limits_from_options,
)
from .progress_display import QUIET_OPTION, show_progress

DEMOS = tuple(m.name for m in machines() if m.demo is not None)
"""``demo MACHINE``: the registered machines that have a demo (:mod:`feedtune.machines.registry`)."""


def demo(
    machine: str = typer.Argument(
        "ballscrew", **choice(DEMOS),
        help="Which twin: ballscrew (thesis ch. 3) or gantry (ch. 4).",
    ),
    out: Path = typer.Option(
        ..., "--out", "-o", metavar="DIR",
        help="Folder for every file of the demo (created if missing).",
    ),
    seed: int = typer.Option(
        0, "--seed", min=0, metavar="N",
        help="Seed of the excitation phases and the measurement noise.",
    ),
    engine: str = typer.Option("auto", "--engine", **choice(ENGINES), help="Simulation engine: auto, numba or python."),
    keep_raw: bool = typer.Option(False, "--keep-raw", help="gantry: also write the FRF and mass runs' raw logs."),
    objective: str = typer.Option(
        None, "--objective", metavar="OBJECTIVE",
        help="What every tuner maximises: stiffness (the integral gain; the default), bandwidth (the first crossover) "
             "or pareto (the front of both recorded; the stiffness winner chosen).",
    ),
    compliance_max: float = typer.Option(
        None, "--compliance-max", metavar="RAD_PER_V", min=0.0,
        help="ballscrew: cap on the axial-mode compliance (minus the most negative real part of x2/d2, ideal case) "
             "[rad/V] of both tuned controllers.",
    ),
    limits: str = LIMITS_OPTION,
    ms_max: float = MS_MAX_OPTION,
    pm_min: float = PM_MIN_OPTION,
    gm_min: float = GM_MIN_OPTION,
    gm_low_min: float = GM_LOW_MIN_OPTION,
    dm_min: float = DM_MIN_OPTION,
    force: bool = FORCE_OPTION,
    as_json: bool = JSON_OPTION,
    quiet: bool = QUIET_OPTION,
) -> None:
    """Run the main job on a digital twin, with no input files.

    Measure, identify, design, test and compare on the twin; end with report.html built from the files written.

    ballscrew: FRF, 2-mass model, MC-PPC against P-PI, both tuned by the same rule under the same limits, rope
    snap, tracking at 200/500/1000 mm/s, slotting, pre-filter (Table 3.2). gantry: 2x2 FRFs and mass runs at three
    table positions, eq. 4.16 model, x-axis loop shaping, MIMO against independent PIDs tuned under the same limits,
    rope snap, tracking at 1 and 200 mm/s, contours.
    """
    show_progress(quiet)
    from ..io.atomic import staged_folder
    from ..machines import get_machine
    from ..structures import plant
    from ..workflows import run_machine_demo
    from ..workflows.files import check_out_dir, write_texts
    from .tune_cmd import objective_options

    entry = get_machine(machine)
    policy = limits_from_options(limits, ms_max, pm_min, gm_min, dm_min, gm_low_min)
    goal = objective_options(objective, compliance_max, (plant(entry.plant),), machine)
    check_out_dir(out, force)
    from ..sim.engine import choose_engine
    from ..workflows.warmup import MACHINE_KERNELS, ensure_kernels

    behind = None
    if choose_engine(engine) == "numba":  # a first run compiles them as a step of its own (the CSV writer behind)
        behind = ensure_kernels(MACHINE_KERNELS.get(machine, ()), background=True)
    from .. import progress

    try:
        result = run_machine_demo(machine, seed=seed, engine=engine, limits=policy, keep_raw=keep_raw,
                                  objective=goal)
        with staged_folder(out, force) as stage:  # the folder appears whole, the report in it, or not at all
            progress.step("writing the files")
            staged = write_texts(result.texts, force=True, out_dir=stage)
            write_demo_report(stage, True, machine, policy)
    except BaseException:
        if behind is not None:
            behind.cancel()
        raise
    if behind is not None:
        for line in behind.wait()[1]:
            warn(line)
    progress.done()
    written = [out / p.name for p in staged]
    report_path = out / REPORT_NAME
    if as_json:
        d = result.to_dict()
        d["machine"] = machine
        d["out"] = str(out)
        d["files"] = [str(p) for p in written]
        d["report"] = str(report_path)
        from .envelope import emit

        emit(d)
        return
    typer.echo(result.summary())
    typer.echo("")
    typer.echo(f"wrote {len(written)} files to {out}")
    typer.echo(f"report: {report_path}")


REPORT_NAME = "report.html"


def write_demo_report(out: Path, force: bool, machine: str = "ballscrew", limits=None) -> Path:
    """Build the report from every file in the demo folder (under the demo's limits) and write it there as
    report.html. The files are named relative to that folder (where the report sits), so the report reads the same
    wherever the folder is moved, and a staging folder's name never shows."""
    from ..report.build import build_report, write_report
    from ..report.sections import ReportLimits

    path = Path(out).resolve() / REPORT_NAME
    here = Path.cwd()
    os.chdir(out)
    try:
        built = build_report(["."], title=f"feedtune demo on the digital twin ({machine})",
                             limits=ReportLimits() if limits is None else ReportLimits(limits))
    finally:
        os.chdir(here)
    write_report(built, path, force=force)
    return path
