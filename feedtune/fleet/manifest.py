"""The fleet manifest: which axes a plant has, their installed gains and limits, and their measurements with dates.

Two spellings of the same content (docs/fleet.md):

* ``fleet.toml``: ``[defaults]`` (any axis key, inherited), then one ``[[axis]]`` table per axis with its
  ``[[axis.measurement]]`` tables (``date``, ``frf`` = a file or a list, ``log`` = an optional reversal log);
* a CSV file with one row per measurement: ``machine, axis, gains, date, frf`` and optionally ``structure, limits,
  log, report, log_position, log_input`` (several FRF files of one measurement separated by ``;``); the axis columns
  must agree on every row of an axis.

Paths are relative to the manifest's folder. Nothing is read but the manifest here; the files' digests
(:func:`file_digest`) are taken when a run plans its tasks.
"""

from __future__ import annotations

import datetime as _dt
import hashlib
import math
import re
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

from ..analysis.limits import Limits, limits_profile
from ..errors import DataError

SCHEMA = "feedtune.fleet/1"
STRUCTURES = ("ballscrew",)
"""Plant structures a fleet run identifies and certifies (the 2-mass fit of ``identify ballscrew``)."""

AXIS_KEYS = frozenset({"machine", "axis", "structure", "gains", "limits", "report", "frf_options", "log_options",
                       "identify", "measurement"})
OPTION_TABLES = ("frf_options", "log_options", "identify")
LIMIT_KEYS = ("ms_max", "pm_min_deg", "gm_min_db", "disk_margin_min")
FRF_OPTION_KEYS = frozenset({"quantity", "freq_var", "channels", "coherence", "columns", "skip_rows", "scale"})
"""Keyword arguments of :func:`feedtune.io.read_frf` a manifest may give (``[axis.frf_options]``)."""
LOG_READ_KEYS = frozenset({"mapping", "fs", "time", "scale", "units", "skip_rows"})
"""Keyword arguments of :func:`feedtune.io.read_log` a manifest may give (``[axis.log_options]``)."""
LOG_FIT_KEYS = frozenset({"position", "input", "velocity_threshold", "cutoff_hz"})
"""Settings of :func:`feedtune.identify.rigid.fit_rigid` (``position``, ``input`` = its ``force`` column; the
symmetric law: one Coulomb level to trend)."""
IDENTIFY_KEYS = frozenset({"band_hz", "channels", "lead_m_per_rad", "fit_delay"})
"""Keyword arguments of :func:`feedtune.identify.ballscrew.fit_ballscrew` (``[axis.identify]``)."""
DEFAULT_LOG_FIT = {"position": "x", "input": "u"}
CSV_COLUMNS = ("machine", "axis", "structure", "gains", "limits", "report", "date", "frf", "log", "log_position",
               "log_input")
_SLUG = re.compile(r"[^A-Za-z0-9._-]+")


@dataclass(frozen=True)
class Measurement:
    """One measurement of an axis.

    Attributes
    ----------
    date : datetime.datetime
        When it was taken (a date alone is midnight).
    frfs : tuple of Path
        FRF files (``x1/u``, ``x2/u``), absolute.
    log : Path or None
        A reversal log for the rigid-body friction fit, absolute.
    """

    date: _dt.datetime
    frfs: tuple[Path, ...]
    log: Path | None = None

    @property
    def files(self) -> tuple[Path, ...]:
        """Every file of the measurement, FRFs first."""
        return self.frfs + ((self.log,) if self.log is not None else ())


@dataclass(frozen=True)
class AxisEntry:
    """One axis of the fleet with its measurements (oldest first).

    Attributes
    ----------
    machine, axis : str
        Names; ``machine/axis`` is the axis' identity (:attr:`id`).
    structure : str
        Plant structure (``ballscrew``).
    gains : Path
        The installed gains file.
    limits : Limits
        The policy its certificate is checked under.
    measurements : tuple of Measurement
    report : str or None
        A link to the axis' own report (as written in the manifest).
    frf_options, log_options, identify : dict
        Reader and fit settings (module constants list the keys).
    """

    machine: str
    axis: str
    structure: str
    gains: Path
    limits: Limits
    measurements: tuple[Measurement, ...]
    report: str | None = None
    frf_options: dict = field(default_factory=dict)
    log_options: dict = field(default_factory=dict)
    identify: dict = field(default_factory=dict)

    @property
    def id(self) -> str:
        """``machine/axis``."""
        return f"{self.machine}/{self.axis}"

    @property
    def slug(self) -> str:
        """The identity as a file-name part (``machine_axis``, other characters as ``-``)."""
        return _SLUG.sub("-", f"{self.machine}_{self.axis}")


@dataclass(frozen=True)
class Manifest:
    """A fleet: its name, the manifest file and every axis (in the manifest's order)."""

    path: Path
    name: str
    axes: tuple[AxisEntry, ...]

    @property
    def folder(self) -> Path:
        """The manifest's folder (relative paths start there)."""
        return self.path.parent

    def axis(self, axis_id: str) -> AxisEntry:
        """The axis called ``machine/axis``."""
        for a in self.axes:
            if a.id == axis_id:
                return a
        raise DataError(f"{self.path}: no axis {axis_id!r}")

    def relative(self, path: Path | None) -> str | None:
        """A path as the history records it: relative to the manifest's folder where it is inside it."""
        if path is None:
            return None
        try:
            return path.relative_to(self.folder).as_posix()
        except ValueError:
            return path.as_posix()


# ------------------------------------------------------------------------------------------ reading
def load_manifest(path) -> Manifest:
    """Read a fleet manifest (``.toml`` or ``.csv``, module docstring).

    Raises
    ------
    DataError
        Unreadable file, a missing or malformed key (named with its axis and measurement), a repeated axis, a
        measurement listed twice.
    """
    p = Path(path)
    suffix = p.suffix.lower()
    if suffix == ".toml":
        from ..io.document import read_document

        return _from_document(p, read_document(p))
    if suffix == ".csv":
        return _from_csv(p)
    raise DataError(f"{p}: a fleet manifest is a .toml or .csv file, got {suffix or '(no extension)'!r}")


def _from_document(path: Path, doc: Mapping) -> Manifest:
    schema = doc.get("schema", SCHEMA)
    if schema != SCHEMA:
        raise DataError(f"{path}: schema {schema!r}; this feedtune reads {SCHEMA}")
    unknown = set(doc) - {"schema", "name", "defaults", "axis"}
    if unknown:
        raise DataError(f"{path}: unknown top-level key(s) {', '.join(sorted(unknown))}; expected name, defaults, "
                        "axis")
    defaults = doc.get("defaults", {})
    if not isinstance(defaults, Mapping):
        raise DataError(f"{path}: [defaults] must be a table")
    _check_keys(defaults, AXIS_KEYS - {"measurement", "machine", "axis"}, f"{path}: [defaults]")
    axes = doc.get("axis")
    if not isinstance(axes, list) or not axes:
        raise DataError(f"{path}: no [[axis]] tables; a fleet lists at least one axis")
    entries = []
    for n, raw in enumerate(axes, 1):
        if not isinstance(raw, Mapping):
            raise DataError(f"{path}: [[axis]] number {n} must be a table")
        merged = {**defaults, **raw}
        for key in OPTION_TABLES:  # an axis' option table adds to the defaults' (its keys win)
            if isinstance(defaults.get(key), Mapping) and isinstance(raw.get(key), Mapping):
                merged[key] = {**defaults[key], **raw[key]}
        entries.append(_axis(path, merged, f"{path}: axis {n}"))
    return _checked(Manifest(path.resolve(), str(doc.get("name") or path.stem), tuple(entries)))


def _axis(path: Path, raw: Mapping, where: str) -> AxisEntry:
    _check_keys(raw, AXIS_KEYS, where)
    machine, axis = _text(raw, "machine", where), _text(raw, "axis", where)
    where = f"{path}: axis {machine}/{axis}"
    structure = str(raw.get("structure", "ballscrew"))
    if structure not in STRUCTURES:
        raise DataError(f"{where}: structure {structure!r} is not run by a fleet yet; expected "
                        f"{' or '.join(STRUCTURES)}")
    folder = path.resolve().parent
    measurements = raw.get("measurement")
    if not isinstance(measurements, list) or not measurements:
        raise DataError(f"{where}: no [[axis.measurement]] tables")
    items = [_measurement(folder, m, f"{where}, measurement {k}") for k, m in enumerate(measurements, 1)]
    report = raw.get("report")
    return AxisEntry(machine, axis, structure, _file(folder, _text(raw, "gains", where)),
                     _limits(raw.get("limits"), f"{where}: limits"), tuple(sorted(items, key=lambda m: m.date)),
                     None if report is None else str(report),
                     _options(raw.get("frf_options"), FRF_OPTION_KEYS, f"{where}: frf_options"),
                     _log_options(raw.get("log_options"), f"{where}: log_options"),
                     _options(raw.get("identify"), IDENTIFY_KEYS, f"{where}: identify"))


def _measurement(folder: Path, raw, where: str) -> Measurement:
    if not isinstance(raw, Mapping):
        raise DataError(f"{where}: must be a table with date and frf")
    _check_keys(raw, {"date", "frf", "log"}, where)
    frf = raw.get("frf")
    names = [frf] if isinstance(frf, str) else frf
    if not isinstance(names, list) or not names or not all(isinstance(x, str) and x.strip() for x in names):
        raise DataError(f"{where}: frf must be a file name or a list of file names")
    log = raw.get("log")
    if log is not None and not (isinstance(log, str) and log.strip()):
        raise DataError(f"{where}: log must be a file name")
    return Measurement(_date(raw.get("date"), f"{where}: date"), tuple(_file(folder, x) for x in names),
                       None if log is None else _file(folder, log))


def _from_csv(path: Path) -> Manifest:
    import csv
    import io

    try:
        text = path.read_bytes().decode("utf-8-sig")
    except FileNotFoundError:
        raise DataError(f"{path}: file not found") from None
    except OSError as exc:
        raise DataError(f"{path}: cannot read ({exc.strerror or exc})") from None
    except UnicodeDecodeError:
        raise DataError(f"{path}: not a UTF-8 text file") from None
    reader = csv.DictReader(io.StringIO(text))
    header = [h.strip() for h in reader.fieldnames or []]
    missing = [c for c in ("machine", "axis", "gains", "date", "frf") if c not in header]
    if missing:
        raise DataError(f"{path}: missing column(s) {', '.join(missing)}; a fleet CSV has one row per measurement "
                        f"with columns {', '.join(CSV_COLUMNS)}")
    unknown = [c for c in header if c not in CSV_COLUMNS]
    if unknown:
        raise DataError(f"{path}: unknown column(s) {', '.join(unknown)}; expected {', '.join(CSV_COLUMNS)}")
    axes: dict[tuple[str, str], dict] = {}
    for row_no, row in enumerate(reader, 2):
        row = {(k or "").strip(): (v or "").strip() for k, v in row.items()}
        if not any(row.values()):
            continue
        where = f"{path}: row {row_no}"
        key = (_text(row, "machine", where), _text(row, "axis", where))
        axis_part = {k: row.get(k, "") for k in ("structure", "gains", "limits", "report", "log_position",
                                                 "log_input")}
        entry = axes.setdefault(key, {"first_row": row_no, **axis_part, "measurement": []})
        for k, v in axis_part.items():
            if v != entry[k]:
                raise DataError(f"{where}: column {k} is {v!r} for axis {key[0]}/{key[1]}, but {entry[k]!r} on row "
                                f"{entry['first_row']}; the axis columns must agree on every row of an axis")
        frfs = [x.strip() for x in row.get("frf", "").split(";") if x.strip()]
        entry["measurement"].append({"date": row.get("date", ""), "frf": frfs, "log": row.get("log") or None,
                                     "_row": row_no})
    if not axes:
        raise DataError(f"{path}: no rows; a fleet CSV has one row per measurement")
    entries = []
    for (machine, axis), e in axes.items():
        raw: dict = {"machine": machine, "axis": axis, "gains": e["gains"],
                     "measurement": [{k: v for k, v in m.items() if k != "_row" and v not in (None, "")}
                                     for m in e["measurement"]]}
        for k in ("structure", "limits", "report"):
            if e[k]:
                raw[k] = e[k]
        log_fit = {k: e[f"log_{k}"] for k in ("position", "input") if e.get(f"log_{k}")}
        if log_fit:
            raw["log_options"] = log_fit
        entries.append(_axis(path, raw, f"{path}: axis {machine}/{axis} (row {e['first_row']})"))
    return _checked(Manifest(path.resolve(), path.stem, tuple(entries)))


# ------------------------------------------------------------------------------------------ values
def _check_keys(raw: Mapping, allowed, where: str) -> None:
    unknown = sorted(set(raw) - set(allowed))
    if unknown:
        raise DataError(f"{where}: unknown key(s) {', '.join(unknown)}; expected {', '.join(sorted(allowed))}")


def _text(raw: Mapping, key: str, where: str) -> str:
    v = raw.get(key)
    if not isinstance(v, str) or not v.strip():
        raise DataError(f"{where}: {key} must be a non-empty text")
    return v.strip()


def _file(folder: Path, name: str) -> Path:
    p = Path(name.strip()).expanduser()
    return p if p.is_absolute() else folder / p


def _date(value, where: str) -> _dt.datetime:
    """A TOML date or date-time, or an ISO 8601 text; time zones are dropped (local plant time)."""
    if isinstance(value, _dt.datetime):
        return value.replace(tzinfo=None, microsecond=0)
    if isinstance(value, _dt.date):
        return _dt.datetime(value.year, value.month, value.day)
    if isinstance(value, str) and value.strip():
        try:
            return _date(_dt.datetime.fromisoformat(value.strip().replace("Z", "+00:00")), where)
        except ValueError:
            pass
    raise DataError(f"{where}: expected a date such as 2025-01-06 or 2025-01-06T08:30, got {value!r}")


def _limits(value, where: str) -> Limits:
    """A profile name, or a table ``{profile, ms_max, pm_min_deg, gm_min_db, disk_margin_min}``."""
    if value is None or value == "":
        return limits_profile("textbook")
    if isinstance(value, str):
        return _profile(value, where)
    if not isinstance(value, Mapping):
        raise DataError(f"{where}: expected a profile name (textbook, thesis) or a table of limits")
    _check_keys(value, {"profile", *LIMIT_KEYS}, where)
    base = _profile(value.get("profile", "textbook"), where)
    given = {}
    for k in LIMIT_KEYS:
        v = value.get(k)
        if v is not None and (isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v)):
            raise DataError(f"{where}: {k} must be a number, got {v!r}")
        given[k] = v
    try:
        return base.override(**given)
    except ValueError as exc:
        raise DataError(f"{where}: {exc}") from None


def _profile(name, where: str) -> Limits:
    try:
        return limits_profile(str(name))
    except ValueError as exc:
        raise DataError(f"{where}: {exc}") from None


def _options(value, allowed, where: str) -> dict:
    if value is None:
        return {}
    if not isinstance(value, Mapping):
        raise DataError(f"{where}: must be a table")
    _check_keys(value, allowed, where)
    return dict(value)


def _log_options(value, where: str) -> dict:
    opts = {**DEFAULT_LOG_FIT, **_options(value, LOG_READ_KEYS | LOG_FIT_KEYS, where)}
    for k in ("position", "input"):
        if not isinstance(opts[k], str) or not opts[k]:
            raise DataError(f"{where}: {k} must be a column name")
    return opts


def _checked(m: Manifest) -> Manifest:
    seen: dict[str, int] = {}
    for n, a in enumerate(m.axes, 1):
        if a.id in seen:
            raise DataError(f"{m.path}: axis {a.id} is listed twice (axes {seen[a.id]} and {n}); one [[axis]] per "
                            "axis")
        seen[a.id] = n
        files: dict[tuple[Path, ...], _dt.datetime] = {}
        for meas in a.measurements:
            if meas.files in files:
                raise DataError(f"{m.path}: axis {a.id}: the measurements of {files[meas.files]:%Y-%m-%d} and "
                                f"{meas.date:%Y-%m-%d} list the same files")
            files[meas.files] = meas.date
    return m


# ------------------------------------------------------------------------------------------ digests
DIGEST_CHUNK = 1 << 20


def file_digest(path: Path) -> str:
    """SHA-256 of a file's bytes (hex); DataError naming the file when it cannot be read."""
    h = hashlib.sha256()
    try:
        with open(path, "rb") as fh:
            while chunk := fh.read(DIGEST_CHUNK):
                h.update(chunk)
    except FileNotFoundError:
        raise DataError(f"{path}: file not found") from None
    except OSError as exc:
        raise DataError(f"{path}: cannot read ({exc.strerror or exc})") from None
    return h.hexdigest()


def measurement_key(axis_id: str, digests: dict[str, str]) -> str:
    """The history key of a measurement: SHA-256 of the axis identity and its files' digests by role (``frf1``,
    ``frf2``, ``log``), 32 hex digits. The same files give the same key, whatever their names or dates."""
    text = "\n".join([axis_id, *(f"{role}={d}" for role, d in sorted(digests.items()))])
    return hashlib.sha256(text.encode("utf-8")).hexdigest()[:32]
