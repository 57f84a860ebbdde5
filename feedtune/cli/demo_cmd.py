"""``feedtune demo``: the main job on the digital twin in one command, with no input files."""

from __future__ import annotations

from pathlib import Path

import typer

from .common import FORCE_OPTION, JSON_OPTION, print_json


def demo(
    out: Path = typer.Option(..., "--out", "-o", help="Folder for every file of the demo (created if missing)."),
    seed: int = typer.Option(0, "--seed", help="Seed of the excitation phases and the measurement noise."),
    engine: str = typer.Option("auto", "--engine", help="Simulation engine: auto, numba or python."),
    force: bool = FORCE_OPTION,
    as_json: bool = JSON_OPTION,
) -> None:
    """Measure the twin's FRF, identify, design MC-PPC and P-PI, run rope snap and tracking, compare (Table 3.2)."""
    from ..sim.demo import check_out_dir, run_demo, write_texts

    check_out_dir(out, force)
    result = run_demo(seed=seed, engine=engine)
    written = write_texts(result.texts, force=force, out_dir=out)
    if as_json:
        d = result.to_dict()
        d["out"] = str(out)
        d["files"] = [str(p) for p in written]
        print_json(d)
        return
    ident = result.identified
    typer.echo(
        "Identified from the measured FRF: "
        + ", ".join(f"{k} = {v:.4g} {ident['units'].get(k, '')}" for k, v in ident["params"].items())
    )
    for name, d in result.designs.items():
        label = "MC-PPC" if name == "mcppc" else "P-PI"
        typer.echo(
            f"{label}: Ms = {d['ms']:.3g} (discrete case, measured FRF), crossovers "
            + ", ".join(f"{x:.1f}" for x in d["crossovers_hz"])
            + " Hz"
        )
    typer.echo("")
    typer.echo(result.table())
    typer.echo("")
    typer.echo(f"wrote {len(written)} files to {out}")
