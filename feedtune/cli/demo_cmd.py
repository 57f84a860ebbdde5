"""``feedtune demo``: the main job on the digital twin in one command, with no input files."""

from __future__ import annotations

from pathlib import Path

import typer

from .common import FORCE_OPTION, JSON_OPTION, print_json

MACHINES = ("ballscrew", "gantry")


def demo(
    machine: str = typer.Argument("ballscrew", help="Which twin: ballscrew (thesis ch. 3) or gantry (ch. 4)."),
    out: Path = typer.Option(..., "--out", "-o", help="Folder for every file of the demo (created if missing)."),
    seed: int = typer.Option(0, "--seed", help="Seed of the excitation phases and the measurement noise."),
    engine: str = typer.Option("auto", "--engine", help="Simulation engine: auto, numba or python."),
    keep_raw: bool = typer.Option(False, "--keep-raw", help="gantry: also write the FRF and mass runs' raw logs."),
    force: bool = FORCE_OPTION,
    as_json: bool = JSON_OPTION,
) -> None:
    """The main job on a digital twin, no input files: measure, identify, design, test and compare; end with
    report.html built from the files written.

    ballscrew: FRF, 2-mass model, MC-PPC against P-PI at the same Ms, rope snap, tracking at 200/500/1000 mm/s,
    slotting, pre-filter (Table 3.2). gantry: 2x2 FRFs and mass runs at three table positions, eq. 4.16 model,
    x-axis loop shaping, MIMO against independent PIDs, rope snap, tracking at 1 and 200 mm/s, contours.
    """
    from ..errors import UsageError
    from ..sim.demo import check_out_dir, write_texts

    if machine not in MACHINES:
        raise UsageError(f"unknown machine {machine!r}: expected one of {', '.join(MACHINES)}")
    check_out_dir(out, force)
    if machine == "gantry":
        from ..sim.gantry_demo import run_gantry_demo

        result = run_gantry_demo(seed=seed, engine=engine, keep_raw=keep_raw)
    else:
        from ..sim.demo import run_demo

        result = run_demo(seed=seed, engine=engine)
    written = write_texts(result.texts, force=force, out_dir=out)
    report_path = write_demo_report(out, force, machine)
    if as_json:
        d = result.to_dict()
        d["machine"] = machine
        d["out"] = str(out)
        d["files"] = [str(p) for p in written]
        d["report"] = str(report_path)
        print_json(d)
        return
    if machine == "ballscrew":
        _print_ballscrew_designs(result)
    typer.echo(result.table())
    typer.echo("")
    typer.echo(f"wrote {len(written)} files to {out}")
    typer.echo(f"report: {report_path}")


def _print_ballscrew_designs(result) -> None:
    ident = result.identified
    typer.echo(
        "Identified from the measured FRF: "
        + ", ".join(f"{k} = {v:.4g} {ident['units'].get(k, '')}" for k, v in ident["params"].items())
    )
    labels = {"mcppc": "MC-PPC", "ppi": "P-PI"}
    for name, d in result.designs.items():
        if name not in labels:
            continue
        beta = d.get("design", {}).get("beta")
        prefix = f"beta = {beta:g}, " if beta else ""
        crossovers = ", ".join(f"{x:.1f}" for x in d["crossovers_hz"])
        typer.echo(f"{labels[name]}: {prefix}Ms = {d['ms']:.3g} (discrete case, measured FRF), "
                   f"crossovers {crossovers} Hz")
    typer.echo("")


REPORT_NAME = "report.html"


def write_demo_report(out: Path, force: bool, machine: str = "ballscrew") -> Path:
    """Build the report from every file in the demo folder and write it there as report.html."""
    from ..report.build import build_report, write_report

    path = out / REPORT_NAME
    built = build_report([out], title=f"feedtune demo on the digital twin ({machine})")
    write_report(built, path, force=force)
    return path
