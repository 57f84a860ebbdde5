"""The project file ``feedtune.toml``: one axis, the files that describe it, and the options of the commands run on it.

A folder with a ``feedtune.toml`` is a project: ``feedtune tune``, ``feedtune analyze`` and ``feedtune report`` run
there without arguments (or anywhere with ``--project PATH``) take their arguments from it, so the last result is
reproduced by the same words (docs/formats.md, "Project file")::

    schema = "feedtune.project/1"

    [axis]                      # the files, named once
    name = "x axis"
    model = "model.toml"        # tune's MODEL
    frf = ["m70.csv", "m100.csv", "m130.csv"]   # --frf of tune and analyze; report inputs
    gains = "gains.toml"        # tune's --out, analyze's GAINS; a report input
    logs = ["track.csv"]        # report inputs

    [limits]                    # --limits (profile), --ms-max, --pm-min, --gm-min, --gm-low-min, --dm-min
    profile = "textbook"
    ms_max = 2.0

    [tune]                      # any argument or option of the command, by name (STRUCTURE: structure)
    structure = "ppi"
    filters = "own"

    [analyze]
    check = true

    [report]
    out = "report.html"
    pdf = true

Paths are relative to the folder of the project file. This module reads, checks (a JSON Schema, draft 2020-12:
:data:`PROJECT_JSON_SCHEMA`) and writes the file; which command option a key fills is the command line's business
(:mod:`feedtune.cli.project_args`), which checks the keys of the command sections against the command's options.
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path

from ..errors import DataError
from .document import read_document, require_schema
from .schema_common import check_finite, check_schema

PROJECT_FILE = "feedtune.toml"
"""The project file's name in a folder (``feedtune tune`` without arguments looks for it in the current folder)."""

PROJECT_SCHEMA = "feedtune.project"
PROJECT_SCHEMA_MAJOR = 1

COMMAND_SECTIONS = ("tune", "analyze", "report")
"""The commands a project file holds options for (one section each)."""

LIMIT_KEYS = ("profile", "ms_max", "pm_min", "gm_min", "gm_low_min", "dm_min")
"""The keys of ``[limits]``: the limits profile and the options that change one limit of it."""

_PATH = {"type": "string", "minLength": 1}
_PATHS = {"type": "array", "items": _PATH}
_SCALAR = {"anyOf": [{"type": "string"}, {"type": "number"}, {"type": "boolean"}]}
_OPTION = {"anyOf": [_SCALAR, {"type": "array", "items": _SCALAR}]}
_COMMAND = {"type": "object", "additionalProperties": _OPTION}

PROJECT_JSON_SCHEMA: dict = {
    "$schema": "https://json-schema.org/draft/2020-12/schema",
    "title": "feedtune project file (feedtune.toml)",
    "type": "object",
    "required": ["schema"],
    "additionalProperties": False,
    "properties": {
        "schema": {"type": "string"},
        "axis": {
            "type": "object", "additionalProperties": False,
            "properties": {"name": {"type": "string"}, "description": {"type": "string"}, "model": _PATH,
                           "frf": _PATHS, "gains": _PATH, "logs": _PATHS},
        },
        "limits": {
            "type": "object", "additionalProperties": False,
            "properties": {"profile": {"type": "string"}, **{k: {"type": "number"} for k in LIMIT_KEYS[1:]}},
        },
        **{name: _COMMAND for name in COMMAND_SECTIONS},
    },
}
"""What a project file may hold (the command sections' keys are checked against the command's options by the
command line)."""


@dataclass(frozen=True)
class Project:
    """A project file as read: the axis' files (resolved against the file's folder), its limits and the options of
    each command, as written.

    Attributes
    ----------
    path : Path
        The project file.
    name : str or None
        ``[axis] name``.
    model, gains : Path or None
        ``[axis] model`` and ``gains``, resolved.
    frf, logs : tuple of Path
        ``[axis] frf`` and ``logs``, resolved, in order.
    limits : dict
        ``[limits]`` as written (``profile`` and the single limits).
    commands : dict
        ``{command: {key: value}}`` of the command sections, as written (paths not resolved: :meth:`resolve`).
    """

    path: Path
    name: str | None = None
    model: Path | None = None
    frf: tuple[Path, ...] = ()
    gains: Path | None = None
    logs: tuple[Path, ...] = ()
    limits: dict = field(default_factory=dict)
    commands: dict = field(default_factory=dict)

    @property
    def folder(self) -> Path:
        """The folder the project's paths are relative to."""
        return self.path.parent

    def resolve(self, value: str | os.PathLike[str]) -> Path:
        """A path of the project file: as written when absolute, else relative to the project's folder."""
        p = Path(os.path.expanduser(str(value)))
        return p if p.is_absolute() else self.folder / p

    def section(self, command: str) -> dict:
        """The options of ``command`` (``tune``, ``analyze``, ``report``) as written; empty when there are none."""
        return dict(self.commands.get(command, {}))

    def files(self) -> list[Path]:
        """Every file of ``[axis]``: model, FRFs, gains, logs."""
        return [p for p in (self.model, *self.frf, self.gains, *self.logs) if p is not None]


def find_project(folder: str | os.PathLike[str] = ".") -> Path | None:
    """``folder/feedtune.toml`` when it exists (a file or anything else: reading it says what is wrong), else None."""
    p = Path(folder) / PROJECT_FILE
    return p if os.path.lexists(p) else None


def read_project(path: str | os.PathLike[str]) -> Project:
    """Read and check a project file.

    Raises
    ------
    DataError
        One line naming the file and the key, and what was expected: not TOML, not a project file, a key of the
        wrong type or unknown, a path of ``[axis]`` that is not a file.
    """
    p = Path(path)
    doc = read_document(p)
    require_schema(doc, PROJECT_SCHEMA, str(p), PROJECT_SCHEMA_MAJOR)
    check_finite(doc, [], str(p))
    check_schema(doc, PROJECT_JSON_SCHEMA, str(p))
    axis = doc.get("axis", {})
    project = Project(p, axis.get("name"), commands={k: dict(doc[k]) for k in COMMAND_SECTIONS if k in doc},
                      limits=dict(doc.get("limits", {})))
    resolved = {
        "model": project.resolve(axis["model"]) if "model" in axis else None,
        "gains": project.resolve(axis["gains"]) if "gains" in axis else None,
        "frf": tuple(project.resolve(f) for f in axis.get("frf", [])),
        "logs": tuple(project.resolve(f) for f in axis.get("logs", [])),
    }
    for key in ("model", "frf", "logs"):  # inputs: they must be there (gains may be the output of tune)
        for i, f in enumerate(resolved[key] if isinstance(resolved[key], tuple) else (resolved[key],)):
            if f is not None and not f.is_file():
                where = f"axis.{key}" + (f"[{i}]" if key != "model" else "")
                raise DataError(f"{p}: {where}: {f} is not a file (paths are relative to the project's folder "
                                f"{project.folder})")
    return replace(project, **resolved)


def project_document(*, name: str | None = None, model: str | None = None, frf: Sequence[str] = (),
                     gains: str | None = None, logs: Sequence[str] = (), limits: Mapping | None = None,
                     commands: Mapping[str, Mapping] | None = None) -> dict:
    """A project file's content (module docstring) from paths as they are to be written (relative to the project's
    folder) and the sections' values; checked against :data:`PROJECT_JSON_SCHEMA`."""
    axis = {k: v for k, v in (("name", name), ("model", model), ("frf", list(frf) or None), ("gains", gains),
                              ("logs", list(logs) or None)) if v is not None}
    doc: dict = {"schema": f"{PROJECT_SCHEMA}/{PROJECT_SCHEMA_MAJOR}"}
    if axis:
        doc["axis"] = axis
    if limits:
        doc["limits"] = dict(limits)
    for k in COMMAND_SECTIONS:
        if commands and commands.get(k):
            doc[k] = dict(commands[k])
    unknown = sorted(set(commands or {}) - set(COMMAND_SECTIONS))
    if unknown:
        raise DataError(f"project: no section [{unknown[0]}]; the sections of commands are "
                        f"{', '.join(COMMAND_SECTIONS)}")
    check_schema(doc, PROJECT_JSON_SCHEMA, "project")
    return doc


def write_project(path: str | os.PathLike[str], doc: Mapping, *, force: bool = False) -> Path:
    """Write a project file (TOML, all or nothing; an existing file is replaced only with ``force``)."""
    from .atomic import atomic_write_text
    from .document import dumps_toml

    header = ("# feedtune project file: 'feedtune tune', 'feedtune analyze' and 'feedtune report' run in this "
              "folder\n# without arguments take them from here (paths relative to this file; docs/formats.md).\n")
    return atomic_write_text(path, header + dumps_toml(doc), force=force)


def relative_to(path: str | os.PathLike[str], folder: str | os.PathLike[str]) -> str:
    """``path`` (as given, relative to the current folder) as written in a project file in ``folder``: relative to
    it where possible (POSIX separators), else absolute."""
    absolute = os.path.abspath(path)
    try:
        rel = os.path.relpath(absolute, os.path.abspath(folder))
    except ValueError:  # another drive (Windows)
        return absolute
    return Path(rel).as_posix()


__all__ = ["COMMAND_SECTIONS", "LIMIT_KEYS", "PROJECT_FILE", "PROJECT_JSON_SCHEMA", "Project", "find_project",
           "project_document", "read_project", "relative_to", "write_project"]
