"""``feedtune analyze``: frequency-domain analysis of a gains file (and, later, of logs)."""

from __future__ import annotations

from pathlib import Path

import typer

from .common import JSON_OPTION, print_json


def analyze(
    gains_file: Path = typer.Argument(..., help="Gains file (.toml or .json) from 'feedtune design'."),
    frf: Path = typer.Option(None, "--frf", help="Measured FRF (x1/u, x2/u) for the measured and discrete cases."),
    quantity: str = typer.Option(None, "--quantity", help="Quantity of the --frf file if not in its metadata."),
    as_json: bool = JSON_OPTION,
) -> None:
    """Loop, margins, Ms, rejection band, Nyquist stability, disturbance and tracking of a design."""
    from ..analysis.ballscrew import analyze_ballscrew, closed_loop_poles
    from ..design.gains import law_from_document
    from ..io import read_document
    from .design_cmd import _summary
    from .frf_options import read_optional_frf

    doc = read_document(gains_file)
    law, model, kind = law_from_document(doc, str(gains_file))
    measured = read_optional_frf(frf, quantity)
    analysis = analyze_ballscrew(law, model, measured).to_dict()
    gains = {k: (v["value"] if isinstance(v, dict) else v) for k, v in doc["gains"].items()}
    if "ppi_gains" in doc:
        gains.update({k: (v["value"] if isinstance(v, dict) else v) for k, v in doc["ppi_gains"].items()})
    poles = closed_loop_poles(law, model)
    result = {
        "kind": kind,
        "gains": gains,
        "closed_loop_poles": [[float(p.real), float(p.imag)] for p in poles],
        "analysis": analysis,
    }
    if as_json:
        print_json(result)
    else:
        _summary(result)
