"""Checks every command gets before its own code runs (:func:`install`): its number options finite, its output
files writable.

* **Numbers.** A ``nan``, ``inf`` or ``1e400`` given to any option that takes a number (one value or several) is a
  usage error naming the option, whatever the option means: no feedtune option takes a non-finite value.
* **Options that need another** (:data:`REQUIRES`: ``--friction-band`` without ``--friction``) are usage errors.
* **Outputs.** Every output option (``--out``, ``--frf-out``, ``--curve-out``; a ``FILE``, or a ``DIR`` or
  ``FOLDER`` for the demo's and a simulated fleet's folder) is checked before the work starts (:func:`check_outputs`):
  an existing file without ``--force``, a missing or read-only folder, a name too long for the file system, and with
  ``--force`` a device or FIFO, are refused at once, not after a two-minute search. A ``.toml`` document is written
  with its ``.json`` twin: both are checked. Outputs a command derives from others (``simulate frf``'s
  ``OUT_frf.csv``) are checked by the command with :func:`check_outputs`. The writers check again when they publish
  (atomically and exclusively, :mod:`feedtune.io.atomic`), so a file another process creates meanwhile is not
  replaced either.
* **Provenance.** While the command runs, the documents it writes record its command line (as run: a project file's
  arguments filled in), the project file and the SHA-256 of every input file (its ``Path`` arguments and options
  other than outputs) in ``created_by`` (:mod:`feedtune.io.provenance`; :func:`run_record`).
"""

from __future__ import annotations

import functools
import inspect
import math
import os
from collections.abc import Iterable
from pathlib import Path

OUTPUT_PARAMETERS = ("out", "frf_out", "curve_out")
"""Parameter names of output options (their metavar says ``FILE`` or ``DIR``)."""

REQUIRES = {"friction_band": "friction"}
"""Options that mean something only with another: ``{parameter: the parameter it needs}``."""

DOCUMENT_COMMANDS = ("identify ", "design ", "tune", "prefilter")
"""Commands whose ``--out`` (and ``--curve-out``) is a document: ``.toml`` (with its ``.json`` twin) or ``.json``."""


def document_outputs(path: str | os.PathLike[str]) -> list[Path]:
    """The files writing a document to ``path`` creates: ``x.toml`` and its JSON twin ``x.json``, else ``path``."""
    p = Path(path)
    return [p, p.with_suffix(".json")] if p.suffix.lower() == ".toml" else [p]


def check_outputs(force: bool, *paths: str | os.PathLike[str] | None, folder: bool = False) -> None:
    """Refuse, before any work, outputs that cannot be written (see the module docstring); None entries are skipped.

    Parameters
    ----------
    force : bool
        ``--force``: existing regular files may be replaced.
    *paths : path-like or None
        The output files (a ``.toml`` with its ``.json`` twin) or, with ``folder``, output folders.
    folder : bool
        The paths are folders written whole (:func:`feedtune.workflows.files.check_out_dir`).
    """
    from ..io.atomic import ensure_writable

    for path in paths:
        if path is None:
            continue
        if folder:
            from ..workflows.files import check_out_dir

            check_out_dir(path, force)
            continue
        for p in document_outputs(path):
            ensure_writable(p, force)


def _labels(callback) -> dict[str, tuple[str, str | None]]:
    """``{parameter: (option name, metavar)}`` of a command's typer options."""
    import typer.models

    out = {}
    for p in inspect.signature(callback).parameters.values():
        info = p.default
        if isinstance(info, typer.models.ParameterInfo):
            decls = [d for d in (getattr(info, "param_decls", None) or ()) if str(d).startswith("--")]
            out[p.name] = (decls[0] if decls else "--" + p.name.replace("_", "-"), getattr(info, "metavar", None))
    return out


def _numbers(value) -> Iterable[float]:
    if isinstance(value, bool):
        return ()
    if isinstance(value, float):
        return (value,)
    if isinstance(value, (list, tuple)):
        return tuple(v for v in value if isinstance(v, float))
    return ()


def check_numbers(kwargs: dict, labels: dict[str, tuple[str, str | None]]) -> None:
    """UsageError naming the first option whose number is NaN or infinite (``1e400`` parses to inf)."""
    from ..errors import UsageError

    for name, value in kwargs.items():
        for v in _numbers(value):
            if not math.isfinite(v):
                option = labels.get(name, ("--" + name.replace("_", "-"), None))[0]
                raise UsageError(f"{option} expects a finite number, got {v!r}")


def _input_parameters(callback) -> tuple[str, ...]:
    """The names of a command's parameters that take input paths (annotated ``Path`` or ``list[Path]``; outputs
    aside)."""
    out = []
    for p in inspect.signature(callback).parameters.values():
        if "Path" in str(p.annotation) and p.name not in OUTPUT_PARAMETERS and not p.name.endswith("_out"):
            out.append(p.name)
    return tuple(out)


def _input_files(kwargs: dict, names: tuple[str, ...]) -> list[str]:
    """The input paths of a command's keyword arguments; an FRF of pieces (``a.csv:x1/u+b.csv:x2/u``) gives its
    files (:func:`~feedtune.cli.frf_options.parse_frf_argument`)."""
    from ..errors import UsageError
    from .frf_options import parse_frf_argument

    out = []
    for name in names:
        value = kwargs.get(name)
        for v in value if isinstance(value, (list, tuple)) else [value]:
            if v is None:
                continue
            text = str(v)
            try:
                out += [str(piece.path) for piece in parse_frf_argument(text)]
            except UsageError:  # not an FRF argument after all: the command's own check names it
                out.append(text)
    return out


def run_record(inputs: list[str]):
    """How to make the record of the running command (:func:`feedtune.io.provenance.command_record`): its command
    line and project file as :func:`feedtune.cli.main.run` left them in the root context (``obj``), else
    ``sys.argv`` (or, under another program's runner, the command's path)."""
    import sys

    from .envelope import _context
    from .project_args import command_text

    ctx = _context()
    obj = ctx.find_root().obj if ctx is not None else None
    obj = obj if isinstance(obj, dict) else {}
    if obj.get("command"):
        command = obj["command"]
    elif ctx is not None and ctx.find_root().info_name != "feedtune":  # run by another program (a test's runner)
        command = ctx.command_path
    else:
        command = command_text(sys.argv[1:])

    def make() -> dict:
        from ..io.provenance import command_record

        return command_record(command, inputs, project=obj.get("project"))

    return make


def guarded(callback, path: str = ""):
    """``callback`` (the command ``path``) with the checks of the module docstring run first."""
    if getattr(callback, "_feedtune_guarded", False):
        return callback
    labels = _labels(callback)
    documents = path.startswith(DOCUMENT_COMMANDS)
    inputs = _input_parameters(callback)

    def option(name: str) -> str:
        return labels.get(name, ("--" + name.replace("_", "-"), None))[0]

    @functools.wraps(callback)
    def command(*args, **kwargs):
        from ..errors import UsageError

        check_numbers(kwargs, labels)
        for name, needed in REQUIRES.items():
            if kwargs.get(name) is not None and name in labels and kwargs.get(needed) is None:
                raise UsageError(f"{option(name)} needs {option(needed)}")
        force = bool(kwargs.get("force", False))
        for name in OUTPUT_PARAMETERS:
            value = kwargs.get(name)
            if isinstance(value, (str, os.PathLike)):
                if documents and Path(value).suffix.lower() not in (".toml", ".json"):
                    raise UsageError(f"{option(name)} {value}: documents are written as .toml (with a .json twin) "
                                     "or .json")
                check_outputs(force, value, folder=labels.get(name, ("", None))[1] in ("DIR", "FOLDER"))
        from ..io.provenance import recording

        with recording(run_record(_input_files(kwargs, inputs))):
            return callback(*args, **kwargs)

    command._feedtune_guarded = True
    return command


def install(app) -> None:
    """Put :func:`guarded` around every command of the Typer app ``app`` and its sub-apps (idempotent)."""
    from .help_text import iter_commands

    for path, info in iter_commands(app):
        info.callback = guarded(info.callback, path)
