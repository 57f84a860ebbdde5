"""What made a document: the ``created_by`` of every document feedtune writes, and the record a command sets for it.

``created_by`` is the one home of a document's provenance. A document built by the library alone says which feedtune
wrote it (``created_by = "feedtune 0.1.0"`` in gains files; model files have none). A document a command writes
(through :func:`feedtune.io.write_document`, the one writer of documents) carries a table instead, filled from the
record the command line sets while the command runs (:func:`recording`)::

    [created_by]
    feedtune = "0.1.0"
    command = "feedtune tune ppi model.toml --frf m70.csv --out gains.toml"   # as run (a project's filled in)
    project = "feedtune.toml"                                                 # when a project file gave arguments
    project_sha256 = "..."
    date = "2026-11-28T23:59:59Z"                                             # UTC
    [[created_by.inputs]]                                                     # every input file, in order
    file = "model.toml"
    sha256 = "..."                                                            # of the file's bytes

The digests are the SHA-256 of the files' bytes, as a certificate's FRF digests (:func:`feedtune.io.
gains_certificate.file_sha256`): ``sha256sum FILE`` recomputes them. ``created_by`` lies outside the gains digest
(:data:`feedtune.io.gains_certificate.UNCERTIFIED_SECTIONS`): re-running a command does not change a certificate.
"""

from __future__ import annotations

import contextlib
import os
from collections.abc import Callable, Iterable, Iterator, Mapping
from contextvars import ContextVar
from pathlib import Path

_RECORD: ContextVar[list | None] = ContextVar("feedtune_provenance", default=None)
"""``[record or None, how to make it]`` of the running command (the record is made when first needed: the inputs'
digests are read only when a document is written)."""

MAX_FOLDER_FILES = 500
"""Files of one input folder whose digests are recorded (a report's folder of runs); beyond, the folder is named
with ``files`` (its count) and no digests."""


def input_digests(paths: Iterable[str | os.PathLike[str]]) -> list[dict]:
    """``[{"file": path as given, "sha256": hex}]`` of every input file, in order, each once; a folder gives one
    entry per regular file under it (sorted; at most :data:`MAX_FOLDER_FILES`, else ``{"file", "files"}``). Paths
    that do not exist are left out (the command itself names them)."""
    from .gains_certificate import file_sha256

    out: list[dict] = []
    seen: set[str] = set()

    def add(p: Path) -> None:
        key = os.path.normpath(str(p))
        if key not in seen:
            seen.add(key)
            out.append({"file": str(p), "sha256": file_sha256(p)})

    for raw in paths:
        p = Path(raw)
        if p.is_dir():
            files = sorted(f for f in p.rglob("*") if f.is_file() and not f.is_symlink())
            if len(files) > MAX_FOLDER_FILES:
                out.append({"file": str(p), "files": len(files)})
                continue
            for f in files:
                add(f)
        elif p.is_file():
            add(p)
    return out


def command_record(command: str, inputs: Iterable[str | os.PathLike[str]] = (), *,
                   project: str | os.PathLike[str] | None = None) -> dict:
    """The record of a command's run (module docstring): its command line, its project file and their digests,
    the date (UTC); ``feedtune`` is added when a document is stamped."""
    import time

    from .gains_certificate import file_sha256

    record: dict = {"command": command}
    if project is not None:
        record["project"] = str(project)
        record["project_sha256"] = file_sha256(project)
    record["date"] = time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime())
    record["inputs"] = input_digests(inputs)
    return record


@contextlib.contextmanager
def recording(record: Mapping | Callable[[], Mapping] | None) -> Iterator[None]:
    """Within the block, every document :func:`feedtune.io.write_document` writes carries ``record`` in its
    ``created_by`` (:func:`stamped`); a callable makes the record when a document first needs it (:func:`
    command_record` reads every input file); None: no record (library use)."""
    if record is None:
        holder = None
    elif callable(record):
        holder = [None, record]
    else:
        holder = [dict(record), None]
    token = _RECORD.set(holder)
    try:
        yield
    finally:
        _RECORD.reset(token)


def current() -> dict | None:
    """The record of the running command (:func:`recording`), None outside one."""
    holder = _RECORD.get()
    if holder is None:
        return None
    if holder[0] is None:
        holder[0] = dict(holder[1]())
    return holder[0]


def created_by(record: Mapping | None = None) -> dict | str:
    """The ``created_by`` of a document: ``{"feedtune": version, **record}`` for a command's record (default: the
    running command's), else the plain ``"feedtune VERSION"``."""
    from .. import __version__

    record = current() if record is None else record
    return f"feedtune {__version__}" if not record else {"feedtune": __version__, **record}


def stamped(doc: Mapping) -> dict:
    """``doc`` with the running command's ``created_by`` (after ``schema`` and ``kind``, replacing any older one);
    ``doc`` unchanged outside a command."""
    if current() is None:
        return dict(doc)
    out: dict = {}
    for k, v in doc.items():
        if k != "created_by":
            out[k] = v
        if k == "kind" or (k == "schema" and "kind" not in doc):
            out["created_by"] = created_by()
    if "created_by" not in out:
        out = {"created_by": created_by(), **out}
    return out


def created_by_text(doc: Mapping) -> str:
    """``created_by`` as one line: ``feedtune 0.1.0`` (a string as stored), or ``feedtune 0.1.0: COMMAND``."""
    value = doc.get("created_by")
    if isinstance(value, Mapping):
        head = f"feedtune {value.get('feedtune', '?')}"
        return f"{head}: {value['command']}" if value.get("command") else head
    return "feedtune" if value is None else str(value)


__all__ = ["command_record", "created_by", "created_by_text", "current", "input_digests", "recording", "stamped"]
