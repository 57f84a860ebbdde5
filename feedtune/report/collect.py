"""Classify the report's input files by their content: model, gains, FRF or log (and which kind of run).

Rules (see ``docs/report.md``):

* ``.toml`` / ``.json``: a feedtune document; ``schema = "feedtune.model/1"`` is a model file,
  ``"feedtune.gains/1"`` a gains file, ``"feedtune.friction_curve/1"`` (kind ``friction_curve``, from
  ``feedtune identify friction --curve-out``) a friction curve. The summary JSON of ``feedtune demo`` is
  recognised and listed.
  When both ``x.toml`` and its JSON twin ``x.json`` hold the same document, the JSON twin is not used twice.
* ``.csv`` / ``.txt``: an FRF when its header row has a ``freq_hz`` column, else a log.
* ``.mat``: an FRF when :func:`feedtune.io.read_frf` accepts it, else a log.
* ``.uff`` / ``.unv`` / ``.uff58``: FRF; ``.mf4`` / ``.mdf``: log; ``.xml`` named on the command line: an
  auto-servo-tuning export's FRF.
* FRFs the caller has read already (``frfs``: the command line's ``FILE:OUT/IN`` pieces joined with ``+``, each
  merged into one FRF) are taken as they are.
* Logs: the kind of run comes from ``meta["experiment"]`` (written by the twin: ``track``, ``cut``,
  ``ropesnap``, ``frf``), else from a ``--log-kind NAME=KIND`` override, else from the columns
  (``x_ref, y_ref`` -> contour, ``x_ref`` -> track, ``v_hat, d_hat`` -> friction, ``r, u`` -> frf,
  ``t_release_s`` in the metadata -> ropesnap).
* A folder means every file in it (not recursive); files with other extensions (``.html``, ``.pdf``, ``.h``)
  are ignored. A file named on the command line that cannot be read or classified is an error naming it;
  a file in a folder is skipped with a warning, or is an error with ``strict=True``.
"""

from __future__ import annotations

import os
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path

from ..errors import DataError, UsageError

LOG_KINDS = ("track", "cut", "ropesnap", "contour", "friction", "frf", "mass")
"""Kinds of run a log can hold (``frf`` excitation and gantry ``mass`` runs are listed, not analysed)."""
EXPERIMENT_ALIASES = {"axis_mass": "mass"}
"""Twin experiment names that are another name of a kind of :data:`LOG_KINDS`."""
DOCUMENT_EXTENSIONS = (".toml", ".json")
TABLE_EXTENSIONS = (".csv", ".txt")
MAT_EXTENSIONS = (".mat",)
UFF_EXTENSIONS = (".uff", ".unv", ".uff58")
XML_EXTENSIONS = (".xml",)
"""FRFs of auto-servo-tuning exports: read when named, not looked for in folders (other XML files are common)."""
MDF_EXTENSIONS = (".mf4", ".mdf")
KNOWN_EXTENSIONS = DOCUMENT_EXTENSIONS + TABLE_EXTENSIONS + MAT_EXTENSIONS + UFF_EXTENSIONS + MDF_EXTENSIONS
SNIFF_LINES = 200
"""Lines read from the top of a CSV file to find its header row."""


@dataclass(frozen=True)
class ModelInput:
    """A model file: ``kind`` (``ballscrew``, ``gantry``, ``friction``, ``rigid``...), its document and the
    model object (None when this feedtune cannot build that kind; ``note`` says why)."""

    path: Path
    kind: str
    doc: dict
    model: object | None
    note: str = ""


@dataclass(frozen=True)
class GainsInput:
    """A gains file: machine ``kind`` (``ballscrew``, ``gantry``, ``axis``), ``controller`` and document."""

    path: Path
    kind: str
    controller: str
    doc: dict


@dataclass(frozen=True)
class FrfInput:
    """A measured FRF."""

    path: Path
    frf: object


@dataclass(frozen=True)
class LogInput:
    """A log with the kind of run it holds, where that kind came from (``meta``, ``option``, ``columns``) and
    whether it was named on the command line (False: found in a folder)."""

    path: Path
    kind: str
    log: object
    kind_from: str
    named: bool = True


@dataclass(frozen=True)
class OtherInput:
    """A recognised file the report lists (the demo's summary.json) or uses as supplementary data (a gantry
    mass-distribution document, ``schema = "feedtune.mass/1"``, kept in ``doc``)."""

    path: Path
    description: str
    doc: dict | None = None


@dataclass(frozen=True)
class FrictionCurveInput:
    """A friction curve document (``schema = "feedtune.friction_curve/1"``, ``kind = "friction_curve"``, written by
    ``feedtune identify friction --curve-out``): the law fitted per direction, its points and curve, validated."""

    path: Path
    doc: dict


@dataclass(frozen=True)
class Skipped:
    """A file left out, with the reason (``warning`` False for expected cases such as JSON twins)."""

    path: Path
    reason: str
    warning: bool = True


@dataclass(frozen=True)
class Inputs:
    """The classified inputs, each list in command-line (then file-name) order."""

    models: list = field(default_factory=list)
    gains: list = field(default_factory=list)
    frfs: list = field(default_factory=list)
    logs: list = field(default_factory=list)
    others: list = field(default_factory=list)
    skipped: list = field(default_factory=list)
    curves: list = field(default_factory=list)

    def logs_of(self, *kinds: str) -> list[LogInput]:
        """Logs of the given kinds."""
        return [x for x in self.logs if x.kind in kinds]

    def is_empty(self) -> bool:
        """True when nothing usable was found."""
        return not (self.models or self.gains or self.frfs or self.logs or self.curves)

    def to_dict(self) -> dict:
        """JSON-ready list of the files and what they were taken for."""
        return {
            "models": [{"file": str(m.path), "kind": m.kind, "note": m.note} for m in self.models],
            "gains": [{"file": str(g.path), "kind": g.kind, "controller": g.controller} for g in self.gains],
            "frfs": [{"file": str(f.path), "channels": list(f.frf.channels)} for f in self.frfs],
            "logs": [{"file": str(x.path), "kind": x.kind, "kind_from": x.kind_from, "n_samples": int(x.log.n)}
                     for x in self.logs],
            "others": [{"file": str(o.path), "description": o.description} for o in self.others],
            "curves": [{"file": str(c.path), "kind": c.doc.get("kind"), "law": c.doc.get("law"),
                        "directions": list(c.doc.get("directions") or [])} for c in self.curves],
            "skipped": [{"file": str(s.path), "reason": s.reason} for s in self.skipped],
        }


# ------------------------------------------------------------------------------------------ expansion
def expand_paths(paths: Iterable[str | os.PathLike[str]]) -> list[tuple[Path, bool]]:
    """``(file, named)`` pairs: files as given (``named`` True) and the files of given folders (False).

    Raises
    ------
    DataError
        A path does not exist.
    """
    out: list[tuple[Path, bool]] = []
    seen: set[Path] = set()
    for raw in paths:
        p = Path(raw)
        if not p.exists():
            raise DataError(f"{p}: no such file or folder")
        if p.is_dir():
            members = sorted(q for q in p.iterdir() if q.is_file() and not q.name.startswith("."))
            items = [(q, False) for q in members if q.suffix.lower() in KNOWN_EXTENSIONS]
        else:
            items = [(p, True)]
        for q, named in items:
            key = q.resolve()
            if key not in seen:
                seen.add(key)
                out.append((q, named))
    return out


# ------------------------------------------------------------------------------------------ documents
def _is_demo_summary(doc: Mapping) -> bool:
    return isinstance(doc, Mapping) and {"comparison", "identified", "designs"} <= set(doc)


def _model_input(path: Path, doc: dict) -> ModelInput:
    """Build the model a model document describes (a kind this feedtune cannot build is kept with a note)."""
    from ..io import load_model

    kind = str(doc.get("kind", ""))
    try:
        model = load_model(path)
    except DataError as exc:
        if "not a known model kind" in str(exc):
            return ModelInput(path, kind, doc, None, f"model kind {kind!r} is not known to this feedtune")
        raise
    return ModelInput(path, kind, doc, model)


def _classify_document(path: Path) -> ModelInput | GainsInput | OtherInput | FrictionCurveInput:
    from ..io import read_document
    from ..io.friction_curve_file import FRICTION_CURVE_SCHEMA, check_friction_curve

    doc = read_document(path)
    if _is_demo_summary(doc):
        return OtherInput(path, "summary of feedtune demo (the report recomputes its numbers from the logs)")
    schema = doc.get("schema") if isinstance(doc, Mapping) else None
    if not isinstance(schema, str):
        raise DataError(f"{path}: not a feedtune model or gains file (no 'schema' entry)")
    prefix, _, version = schema.partition("/")
    if prefix == "feedtune.mass":
        return OtherInput(path, "gantry mass distribution per table position (shown with the gantry model)", doc)
    if prefix == FRICTION_CURVE_SCHEMA:
        return FrictionCurveInput(path, check_friction_curve(doc, str(path)))
    if prefix not in ("feedtune.model", "feedtune.gains"):
        raise DataError(f"{path}: schema {schema!r} is neither a model (feedtune.model/1) nor a gains file "
                        "(feedtune.gains/1)")
    if version.split(".")[0] != "1":
        raise DataError(f"{path}: schema {schema!r} is not supported; this feedtune reads version 1")
    if prefix == "feedtune.model":
        return _model_input(path, doc)
    kind = str(doc.get("kind", ""))
    if not kind:
        raise DataError(f"{path}: gains file has no 'kind' entry (ballscrew, gantry or axis)")
    return GainsInput(path, kind, str(doc.get("controller", "")), doc)


# ------------------------------------------------------------------------------------------ tables
def csv_is_frf(path: Path) -> bool:
    """True when the header row (first line that is neither empty nor a ``#`` comment) has ``freq_hz``."""
    try:
        with open(path, encoding="utf-8", errors="replace") as fh:
            for _, line in zip(range(SNIFF_LINES), fh, strict=False):
                s = line.strip()
                if not s or s.startswith("#"):
                    continue
                fields = [f.strip().strip('"').lower() for f in s.replace(";", ",").replace("\t", ",").split(",")]
                return "freq_hz" in fields
    except OSError as exc:
        raise DataError(f"{path}: cannot read ({exc.strerror or exc})") from None
    return False


def _read_log_input(path: Path, log_kinds: Mapping[str, str], log_reader=None) -> LogInput:
    from ..io import read_log

    log = (log_reader or read_log)(path)
    kind, origin = log_kind(log, path, log_kinds)
    return LogInput(path, kind, log, origin)


def _classify_table(path: Path, log_kinds: Mapping[str, str], log_reader=None) -> FrfInput | LogInput:
    from ..io import read_frf

    if csv_is_frf(path):
        return FrfInput(path, read_frf(path))
    return _read_log_input(path, log_kinds, log_reader)


def _classify_mat(path: Path, log_kinds: Mapping[str, str], log_reader=None) -> FrfInput | LogInput:
    from ..io import read_frf

    try:
        return FrfInput(path, read_frf(path))
    except DataError as frf_error:
        try:
            return _read_log_input(path, log_kinds, log_reader)
        except DataError as log_error:
            raise DataError(f"{path}: neither an FRF ({_tail(frf_error, path)}) nor a log "
                            f"({_tail(log_error, path)})") from None


def _tail(exc: Exception, path: Path) -> str:
    """The message without a leading ``path:``."""
    msg = str(exc)
    return msg[len(str(path)) + 2:] if msg.startswith(f"{path}: ") else msg


def classify_file(path: Path, log_kinds: Mapping[str, str] | None = None, log_reader=None):
    """Read one file and return what it is (ModelInput, GainsInput, FrfInput, LogInput or OtherInput).

    ``log_reader(path)`` reads a log (default :func:`feedtune.io.read_log`; the command line passes one with its
    log options, ``--map`` and so on, for the logs named on it).

    Raises
    ------
    DataError
        The file cannot be read, or its content is none of the above (message names the file).
    """
    log_kinds = log_kinds or {}
    ext = path.suffix.lower()
    if ext in DOCUMENT_EXTENSIONS:
        return _classify_document(path)
    if ext in TABLE_EXTENSIONS:
        return _classify_table(path, log_kinds, log_reader)
    if ext in MAT_EXTENSIONS:
        return _classify_mat(path, log_kinds, log_reader)
    if ext in UFF_EXTENSIONS or ext in XML_EXTENSIONS:
        from ..io import read_frf

        return FrfInput(path, read_frf(path))
    if ext in MDF_EXTENSIONS:
        return _read_log_input(path, log_kinds, log_reader)
    raise DataError(f"{path}: not a file feedtune reports on; expected model or gains files (.toml, .json), "
                    f"FRFs (.csv, .mat, .uff, .xml) or logs (.csv, .mat, .mf4)")


# ------------------------------------------------------------------------------------------ logs
def log_kind(log, path: Path, log_kinds: Mapping[str, str]) -> tuple[str, str]:
    """``(kind, origin)`` of a log: from an override, the twin's ``experiment`` metadata, or the columns."""
    override = log_kinds.get(path.name, log_kinds.get(str(path)))
    if override is not None:
        return override, "option"
    experiment = str(log.meta.get("experiment", "")).strip().lower()
    experiment = EXPERIMENT_ALIASES.get(experiment, experiment)
    if experiment in LOG_KINDS:
        return experiment, "meta"
    kind = kind_from_columns(set(log.signals), log.meta)
    if kind is None:
        raise DataError(f"{path}: cannot tell which run this log holds (columns {', '.join(log.signals)}); "
                        f"pass log_kinds={path.name}=KIND with KIND one of {', '.join(LOG_KINDS)}",
                        parameter="log_kinds")
    return kind, "columns"


def kind_from_columns(columns: set[str], meta: Mapping) -> str | None:
    """The kind of run suggested by a log's column names (and a release time in its metadata), or None."""
    if {"x_ref", "y_ref"} <= columns:
        return "contour"
    if "x_ref" in columns:
        return "track"
    if {"v_hat", "d_hat"} <= columns:
        return "friction"
    if "t_release_s" in meta:
        return "ropesnap"
    if {"r", "u"} <= columns:
        return "frf"
    return None


def parse_log_kinds(items: Iterable[str] | None) -> dict[str, str]:
    """``{file: kind}`` from ``NAME=KIND`` strings (``--log-kind``); UsageError for a malformed item."""
    out: dict[str, str] = {}
    for item in items or []:
        name, sep, kind = str(item).partition("=")
        kind = kind.strip().lower()
        if not sep or not name.strip():
            raise UsageError(f"log_kinds expects FILE=KIND, got {item!r}", parameter="log_kinds")
        if kind not in LOG_KINDS:
            raise UsageError(f"log_kinds {item}: kind must be one of {', '.join(LOG_KINDS)}", parameter="log_kinds")
        out[name.strip()] = kind
    return out


# ------------------------------------------------------------------------------------------ collection
def _drop_json_twins(items: list) -> tuple[list, list[Skipped]]:
    """Leave out ``x.json`` when ``x.toml`` holds the same document."""
    import json

    def same(a: dict, b: dict) -> bool:
        return a == b or json.dumps(a, sort_keys=True, default=str) == json.dumps(b, sort_keys=True, default=str)

    def doc_of(i):
        return getattr(i, "doc", None)

    by_stem = {(i.path.parent, i.path.stem): i for i in items
               if doc_of(i) is not None and i.path.suffix.lower() == ".toml"}
    kept, skipped = [], []
    for i in items:
        twin = by_stem.get((i.path.parent, i.path.stem)) if i.path.suffix.lower() == ".json" else None
        if twin is not None and doc_of(i) is not None and same(twin.doc, i.doc):
            skipped.append(Skipped(i.path, f"JSON twin of {twin.path.name} (same content)", warning=False))
        else:
            kept.append(i)
    return kept, skipped


def collect_inputs(paths: Iterable[str | os.PathLike[str]], *, log_kinds: Mapping[str, str] | None = None,
                   strict: bool = False, log_reader=None, frfs: Iterable[tuple[str, object]] = ()) -> Inputs:
    """Read and classify the report's input files (see the module docstring).

    Parameters
    ----------
    paths : iterable of path-like
        Files and folders, in the order given.
    log_kinds : mapping of str to str, optional
        ``{file name or path: kind}`` overrides of the kind of run of a log (kinds :data:`LOG_KINDS`).
    strict : bool
        Make an unreadable or unclassifiable file inside a folder an error (named files always are).
    log_reader : callable, optional
        ``log_reader(path)`` -> Log for the log files named in ``paths`` (a foreign log's column map, scales,
        units); logs found in folders are read as feedtune logs.
    frfs : iterable of (str, Frf)
        FRFs read already, with the name to show (e.g. one merged from a file per encoder).

    Returns
    -------
    Inputs

    Raises
    ------
    DataError
        A missing path, a named file that cannot be read or classified, or (``strict``) such a file in a
        folder; nothing usable among the inputs.
    UsageError
        A ``log_kinds`` entry that names no input file, or an unknown kind.
    """
    log_kinds = dict(log_kinds or {})
    for name, kind in log_kinds.items():
        if kind not in LOG_KINDS:
            raise UsageError(f"log_kinds {name}={kind}: kind must be one of {', '.join(LOG_KINDS)}",
                             parameter="log_kinds")
    given = [(Path(name), frf) for name, frf in frfs]
    files = expand_paths(paths)
    if not files and not given:
        shown = ", ".join(str(p) for p in paths) or "none"
        raise DataError(f"no input files in {shown}: give model, gains, FRF or log files, or a folder holding them")
    unmatched = set(log_kinds) - {p.name for p, _ in files} - {str(p) for p, _ in files}
    if unmatched:
        raise UsageError(f"log_kinds {sorted(unmatched)[0]}: no such file among the inputs", parameter="log_kinds")
    items, skipped = [], []
    for path, named in files:
        try:
            item = classify_file(path, log_kinds, log_reader if named else None)
            items.append(item if named or not isinstance(item, LogInput) else replace(item, named=False))
        except DataError as exc:
            if named or strict:
                raise
            skipped.append(Skipped(path, _tail(exc, path)))
    items, twins = _drop_json_twins(items)
    inputs = Inputs(
        models=[i for i in items if isinstance(i, ModelInput)],
        gains=[i for i in items if isinstance(i, GainsInput)],
        frfs=[i for i in items if isinstance(i, FrfInput)] + [FrfInput(p, f) for p, f in given],
        logs=[i for i in items if isinstance(i, LogInput)],
        others=[i for i in items if isinstance(i, OtherInput)],
        skipped=skipped + twins,
        curves=[i for i in items if isinstance(i, FrictionCurveInput)],
    )
    if inputs.is_empty():
        raise DataError("no model, gains, FRF or log file among the inputs "
                        f"({', '.join(str(p) for p in paths)})")
    return inputs
