"""``feedtune export``: gains files in target formats."""

from __future__ import annotations

from pathlib import Path

import typer

from .common import FORCE_OPTION, JSON_OPTION, print_json

app = typer.Typer(rich_markup_mode=None, help="Export gains files for real-time targets.", no_args_is_help=True)


@app.command("c")
def export_c(
    gains_file: Path = typer.Argument(..., help="Gains file (.toml or .json) from 'feedtune design'."),
    out: Path = typer.Option(None, "--out", "-o", help="Header to write (default: GAINS with suffix .h)."),
    prefix: str = typer.Option("ft", "--prefix", help="Prefix of the C identifiers."),
    force: bool = FORCE_OPTION,
    as_json: bool = JSON_OPTION,
) -> None:
    """Write a self-contained C header that runs the controller sample by sample."""
    from ..export.c_header import c_header
    from ..io import atomic_write_text, read_document

    doc = read_document(gains_file)
    text = c_header(doc, prefix=prefix, where=str(gains_file))
    target = out or gains_file.with_suffix(".h")
    atomic_write_text(target, text, force=force)
    if as_json:
        print_json({"kind": "c_header", "out": str(target), "prefix": prefix, "bytes": len(text.encode())})
    else:
        typer.echo(f"wrote {target}")
