"""TOML documents with a JSON twin: the model and gains files.

Conventions (see ``docs/formats.md``):

* Every physical number carries its unit as a *quantity* ``{"value": 0.001858, "unit": "V/(rad/s^2)"}``,
  written inline in TOML: ``m1 = { value = 0.001858, unit = "V/(rad/s^2)" }``.
* ``schema = "feedtune.<kind>/<major>[.<minor>]"`` names the document type and version.
* ``x.toml`` is written together with ``x.json`` holding the same content (both or neither).
* Floats are written with full precision (``repr``). TOML has ``inf``/``nan``; JSON has not, so in JSON
  non-finite numbers are the strings ``"inf"``, ``"-inf"`` and ``"nan"``, and :func:`read_document` turns
  exactly these strings back into floats.
* ``None`` values are omitted (TOML has no null).
"""

from __future__ import annotations

import json
import math
import os
import re
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from ..budget import file_size
from ..errors import DataError, FeedtuneNote
from ..quantity import _NONFINITE_STRINGS, is_quantity, quantity, value_of  # noqa: F401 (re-exported)
from ._table import read_bytes
from .atomic import atomic_outputs
from .document_limits import check_size, check_text, check_tree, parse_json_int

_BARE_KEY = re.compile(r"^[A-Za-z0-9_-]+$")
_SCHEMA_RE = re.compile(r"^(?P<prefix>[A-Za-z0-9_.-]+)/(?P<major>\d+)(?:\.(?P<minor>\d+))?$")


def strip_none(d: object) -> object:
    """``d`` without the None entries of its dicts and lists, recursively (TOML has no null)."""
    if isinstance(d, dict):
        return {k: strip_none(v) for k, v in d.items() if v is not None}
    if isinstance(d, list):
        return [strip_none(v) for v in d if v is not None]
    return d


DOCUMENT_KINDS = {"feedtune.model": "a model file, written by feedtune identify",
                  "feedtune.gains": "a gains file, written by feedtune design or tune",
                  "feedtune.mass": "a mass document, written by feedtune identify mass",
                  "feedtune.friction_curve": "a friction curve document, written by feedtune identify friction",
                  "feedtune.report": "a report's data",
                  "feedtune.project": "a project file (feedtune.toml), written by feedtune project init"}
"""What each document type is, in words, for messages about a file of the wrong kind."""


_NOTED: set = set()
"""``(file, schema)`` pairs whose newer minor version was noted already (one note per file and run)."""


class NewerMinorVersion(FeedtuneNote):
    """A document of a newer minor version of its schema: read, its entries this feedtune does not know ignored."""


def require_schema(doc: Mapping[str, object], schema_prefix: str, where: str,
                   supported_major: int = 1, written: str | None = None) -> tuple[int, int]:
    """Check ``doc["schema"]`` is ``"<schema_prefix>/<major>[.<minor>]"`` with a major version we read.

    A newer minor version (``feedtune.model/1.2`` where this feedtune writes ``feedtune.model/1.1``) only adds
    optional entries: it is read, with a :class:`NewerMinorVersion` note. Another major version, older or newer,
    is refused; a document of another type says what it is (:data:`DOCUMENT_KINDS`) and what is expected.

    Parameters
    ----------
    doc : mapping
        The document.
    schema_prefix : str
        E.g. ``"feedtune.model"``.
    where : str
        File name for messages.
    supported_major : int
        The major version this feedtune reads; minor versions only add optional entries.
    written : str, optional
        The schema this feedtune writes (``"feedtune.model/1.1"``; default ``<prefix>/<supported_major>``): a newer
        minor version draws the note.

    Returns
    -------
    (major, minor) : tuple of int
    """
    import warnings

    schema = doc.get("schema")
    if not isinstance(schema, str):
        expected = f"{schema_prefix}/{supported_major}"
        raise DataError(f"{where}: no 'schema' entry; expected schema = \"{expected}\" "
                        f"({DOCUMENT_KINDS.get(schema_prefix, schema_prefix)})")
    m = _SCHEMA_RE.match(schema.strip())
    if not m:
        raise DataError(f"{where}: schema {schema!r} is not of the form '{schema_prefix}/<version>'")
    if m.group("prefix") != schema_prefix:
        found = m.group("prefix")
        raise DataError(f"{where}: this is {DOCUMENT_KINDS.get(found, 'a ' + found + ' document')} ({found}); "
                        f"expected {DOCUMENT_KINDS.get(schema_prefix, schema_prefix)} ({schema_prefix})")
    major, minor = int(m.group("major")), int(m.group("minor") or 0)
    if major != supported_major:
        newer = "a newer" if major > supported_major else "an older"
        raise DataError(f"{where}: {schema} comes from {newer} feedtune; this feedtune reads "
                        f"{schema_prefix}/{supported_major}")
    w = _SCHEMA_RE.match(written or f"{schema_prefix}/{supported_major}")
    ours = int(w.group("minor") or 0) if w else 0
    if minor > ours and (where, schema) not in _NOTED:
        _NOTED.add((where, schema))
        warnings.warn(NewerMinorVersion(f"{where}: {schema} comes from a newer feedtune (this one writes "
                                        f"{schema_prefix}/{supported_major}.{ours}); read, its entries this "
                                        "feedtune does not know are ignored"), stacklevel=2)
    return major, minor


# ------------------------------------------------------------------------------------------ normalising
def _plain(value: object, path: str) -> object:
    """Convert numpy scalars/arrays and tuples to plain Python; drop None entries of dicts."""
    if isinstance(value, Mapping):
        out = {}
        for k, v in value.items():
            if not isinstance(k, str):
                raise DataError(f"document key {k!r} at {path or 'top level'} is not a string")
            if v is not None:
                out[k] = _plain(v, f"{path}.{k}" if path else k)
        return out
    if isinstance(value, np.ndarray):
        value = value.tolist()
    if isinstance(value, (list, tuple)):
        items = []
        for n, v in enumerate(value):
            if v is None:
                raise DataError(f"document entry {path}[{n}] is None; lists cannot hold missing values")
            items.append(_plain(v, f"{path}[{n}]"))
        return items
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    if isinstance(value, (int, np.integer)):
        return int(value)
    if isinstance(value, (float, np.floating)):
        return float(value)
    if isinstance(value, str):
        return value
    if isinstance(value, complex):
        raise DataError(f"document entry {path} is complex; store real and imaginary parts separately")
    raise DataError(f"document entry {path} has unsupported type {type(value).__name__}")


# ------------------------------------------------------------------------------------------ TOML emitter
def _key(k: str) -> str:
    return k if _BARE_KEY.match(k) else _string(k)


def _string(s: str) -> str:
    return json.dumps(s, ensure_ascii=False).replace("\x7f", "\\u007f")


def _float(x: float) -> str:
    if math.isnan(x):
        return "nan"
    if math.isinf(x):
        return "inf" if x > 0 else "-inf"
    return repr(x)


def _inline(v: object) -> str:
    """A value written on one line (scalars, inline arrays, inline tables)."""
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        return _float(v)
    if isinstance(v, str):
        return _string(v)
    if isinstance(v, list):
        return "[" + ", ".join(_inline(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{ " + ", ".join(f"{_key(k)} = {_inline(x)}" for k, x in v.items()) + " }" if v else "{}"
    raise DataError(f"cannot write {type(v).__name__} to TOML")


def _is_table(v: object) -> bool:
    return isinstance(v, dict) and not is_quantity(v)


def _is_table_array(v: object) -> bool:
    return isinstance(v, list) and bool(v) and all(_is_table(x) for x in v)


def _value_lines(k: str, v: object) -> list[str]:
    """``key = value`` lines; lists of lists are written one row per line."""
    if isinstance(v, list) and v and all(isinstance(r, list) for r in v):
        return [f"{_key(k)} = ["] + [f"    {_inline(r)}," for r in v] + ["]"]
    return [f"{_key(k)} = {_inline(v)}"]


def _emit_table(table: dict, path: list[str], out: list[str]) -> None:
    for k, v in table.items():
        if not _is_table(v) and not _is_table_array(v):
            out.extend(_value_lines(k, v))
    for k, v in table.items():
        sub = [*path, _key(k)]
        if _is_table(v):
            if out:
                out.append("")
            out.append(f"[{'.'.join(sub)}]")
            _emit_table(v, sub, out)
        elif _is_table_array(v):
            for item in v:
                if out:
                    out.append("")
                out.append(f"[[{'.'.join(sub)}]]")
                _emit_table(item, sub, out)


def dumps_toml(doc: Mapping[str, object]) -> str:
    """Write a document as TOML: quantities inline, dicts as ``[tables]``, lists of dicts as ``[[arrays]]``.

    Floats keep full precision (``repr``; ``inf``/``nan`` as TOML ``inf``/``nan``), lists of lists are
    written one row per line, ``None`` values are omitted. ``tomllib.loads(dumps_toml(d)) == d`` for any
    document without ``None``.

    Examples
    --------
    >>> print(dumps_toml({"schema": "feedtune.model/1", "params": {"k": quantity(210.02, "V/rad")}}))
    schema = "feedtune.model/1"
    <BLANKLINE>
    [params]
    k = { value = 210.02, unit = "V/rad" }
    <BLANKLINE>
    """
    plain = _plain(dict(doc), "")
    lines: list[str] = []
    _emit_table(plain, [], lines)
    return "\n".join(lines) + "\n"


# --------------------------------------------------------------------------------------------------- JSON
def _json_safe(v: object) -> object:
    if isinstance(v, float) and not math.isfinite(v):
        return _float(v)
    if isinstance(v, dict):
        return {k: _json_safe(x) for k, x in v.items()}
    if isinstance(v, list):
        return [_json_safe(x) for x in v]
    return v


def _json_restore(v: object) -> object:
    if isinstance(v, str) and v in _NONFINITE_STRINGS:
        return _NONFINITE_STRINGS[v]
    if isinstance(v, dict):
        return {k: _json_restore(x) for k, x in v.items()}
    if isinstance(v, list):
        return [_json_restore(x) for x in v]
    return v


def dumps_json(doc: Mapping[str, object]) -> str:
    """The JSON twin: ``indent=2``, non-finite floats as the strings ``"inf"``, ``"-inf"``, ``"nan"``."""
    return json.dumps(_json_safe(_plain(dict(doc), "")), indent=2, allow_nan=False, ensure_ascii=False) + "\n"


# ------------------------------------------------------------------------------------------ write / read
def ensure_document_writable(path: str | os.PathLike[str], force: bool, *, json_twin: bool = True) -> None:
    """Check, before any long work, that :func:`write_document` may write ``path`` and, for a ``.toml`` file, its
    JSON twin beside it (UsageError naming the file that exists without ``force``)."""
    from .atomic import ensure_writable

    p = Path(path)
    ensure_writable(p, force)
    if json_twin and p.suffix.lower() == ".toml":
        ensure_writable(p.with_suffix(".json"), force)


def write_document(path: str | os.PathLike[str], doc: Mapping[str, object], *, force: bool = False,
                   json_twin: bool = True) -> list[Path]:
    """Write ``doc`` as ``x.toml`` plus its JSON twin ``x.json`` (both or neither), or as ``x.json`` only.

    Parameters
    ----------
    path : path-like
        ``.toml`` (writes TOML and, with ``json_twin``, the ``.json`` beside it) or ``.json`` (JSON only).
    doc : mapping
        The document (plain values, quantity dicts, nested dicts and lists). Written by a command, it carries the
        command's record in ``created_by`` (:func:`feedtune.io.provenance.stamped`).
    force : bool
        Replace existing files (both destinations are checked before anything is written).
    json_twin : bool
        Also write the JSON twin of a ``.toml`` file.

    Returns
    -------
    list of Path
        The files written.
    """
    from .provenance import stamped

    p = Path(path)
    ext = p.suffix.lower()
    doc = stamped(doc)  # a command's record in created_by (io/provenance.py)
    if ext == ".json":
        texts = {p: dumps_json(doc)}
    elif ext == ".toml":
        texts = {p: dumps_toml(doc)}
        if json_twin:
            texts[p.with_suffix(".json")] = dumps_json(doc)
    else:
        raise DataError(f"{p}: documents are written as .toml (with a .json twin) or .json")
    paths = list(texts)
    with atomic_outputs(paths, force=force) as temps:
        for tmp, text in zip(temps, texts.values(), strict=True):
            tmp.write_bytes(text.encode("utf-8"))
    return paths


def loads_document(text: str, fmt: str, where: str) -> dict:
    """Parse TOML or JSON text (``fmt`` ``"toml"`` or ``"json"``); syntax errors name the line. The limits of
    :mod:`feedtune.io.document_limits` (size, values, nesting, numbers) are checked before and after parsing."""
    check_text(text, fmt, where)
    if fmt == "toml":
        try:
            import tomllib
        except ModuleNotFoundError:  # Python 3.10
            import tomli as tomllib
        try:
            doc = tomllib.loads(text)
        except tomllib.TOMLDecodeError as exc:
            raise DataError(f"{where}: TOML syntax error: {' '.join(str(exc).split())}") from None
        except (ValueError, RecursionError) as exc:  # what check_text does not foresee: a parser limit
            raise DataError(f"{where}: not a readable TOML document ({' '.join(str(exc).split())[:120]})") from None
        check_tree(doc, where)
        return doc
    try:
        doc = json.loads(text, parse_int=parse_json_int)
    except json.JSONDecodeError as exc:
        raise DataError(f"{where}: JSON syntax error at line {exc.lineno}, column {exc.colno}: {exc.msg}") \
            from None
    except (ValueError, RecursionError) as exc:
        raise DataError(f"{where}: not a readable JSON document ({' '.join(str(exc).split())[:120]})") from None
    if not isinstance(doc, dict):
        raise DataError(f"{where}: a JSON document must be an object {{...}} at the top level")
    check_tree(doc, where)
    return _json_restore(doc)


def read_document(path: str | os.PathLike[str]) -> dict:
    """Read a ``.toml`` or ``.json`` document.

    Parameters
    ----------
    path : path-like
        The file.

    Returns
    -------
    dict
        The document; in JSON files the strings ``"inf"``, ``"-inf"``, ``"nan"`` become floats.

    Raises
    ------
    DataError
        Missing file, unknown extension, a syntax error (with its line number), or a document beyond the limits of
        :mod:`feedtune.io.document_limits` (size, nesting, numbers).
    """
    p = Path(path)
    ext = p.suffix.lower()
    if ext not in (".toml", ".json"):
        raise DataError(f"{p}: unknown document type {ext or '(no extension)'!r}; expected .toml or .json")
    check_size(file_size(p), str(p))  # before reading: a 10 GB file is not read to be refused
    raw = read_bytes(p)
    check_size(len(raw), str(p))
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError:
        raise DataError(f"{p}: not a UTF-8 text file") from None
    return loads_document(text, ext[1:], str(p))
