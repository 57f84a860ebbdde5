"""The fleet history: a folder of Parquet files, one row per axis per measurement (pyarrow, an optional extra).

Layout of ``H.parquet/`` (a Parquet *dataset*: ``pyarrow.parquet.read_table("H.parquet")`` and
``pandas.read_parquet("H.parquet")`` read it whole):

* ``part-<time>-<run>-<n>.parquet``: rows, each file written whole (temporary name, then one rename:
  :mod:`feedtune.io.atomic`) by the process that runs the fleet, every :data:`BATCH_ROWS` finished tasks or
  :data:`BATCH_SECONDS` seconds, and at the end. A run killed at any instant leaves only whole files: the rows of the
  tasks finished since the last file are lost and computed again by the next run.
* ``_lock``: the process writing it (``host pid``); a second run on the same history is refused while that process
  lives.
* ``_proposals/``: re-tuned gains files (``fleet run --retune``).

Names starting with ``_`` or ``.`` (temporary files) are not part of the dataset.

Appending is idempotent: a run plans only the measurements whose key (:func:`feedtune.fleet.manifest.measurement_key`:
the axis and its files' SHA-256) is not in the history yet, so re-running the same files writes nothing, and no key
is ever written twice.

Every column, its type, unit and meaning is in :data:`COLUMNS` (and docs/fleet.md); units of identified parameters are
written with ``U`` for the axis' command unit (``input_unit``; ``force_unit`` for the friction fit) and the
position unit of the model (rad).
"""

from __future__ import annotations

import contextlib
import os
import socket
import time
import uuid
from collections.abc import Iterable, Iterator, Sequence
from pathlib import Path

from ..errors import DataError, UsageError

BATCH_ROWS = 64
"""Rows per part file (at most)."""
BATCH_SECONDS = 10.0
"""A part file is written at least this often while tasks finish [s]."""
PROPOSALS = "_proposals"
LOCK = "_lock"

# (name, type, unit, meaning); type names of pyarrow: string, float64, bool, timestamp, list
COLUMNS: tuple[tuple[str, str, str, str], ...] = (
    ("key", "string", "-", "the measurement's key: SHA-256 of the axis and its files' digests (32 hex digits)"),
    ("axis_id", "string", "-", "machine/axis"),
    ("machine", "string", "-", "machine name"),
    ("axis", "string", "-", "axis name"),
    ("structure", "string", "-", "plant structure (ballscrew)"),
    ("measured_at", "timestamp", "s", "date and time of the measurement (from the manifest)"),
    ("frf_files", "string", "-", "FRF files, ';'-separated, relative to the manifest"),
    ("log_file", "string", "-", "reversal log, relative to the manifest"),
    ("frf_digests", "string", "-", "SHA-256 of each FRF file, ';'-separated"),
    ("log_digest", "string", "-", "SHA-256 of the log"),
    ("gains_file", "string", "-", "installed gains file certified"),
    ("gains_digest", "string", "-", "its SHA-256"),
    ("controller", "string", "-", "the installed controller (ppi, mcppc)"),
    ("limits", "string", "-", "the limits policy, e.g. 'textbook: Ms <= 2.5, PM >= 30 deg, GM >= 6 dB'"),
    ("feedtune_version", "string", "-", "version that wrote the row"),
    ("verdict", "string", "-", "ok (every limit on every FRF), fails, or error (no certificate)"),
    ("error", "string", "-", "what failed, per stage (FRF, identify, certificate, friction); null when nothing"),
    ("warnings", "list", "-", "warnings of the fits"),
    ("violations", "list", "-", "violated limits, each prefixed with its FRF"),
    ("input_unit", "string", "-", "the drive's command unit U of the FRFs (V, A, N, N*m)"),
    ("lead_m_per_rad", "float64", "m/rad", "screw lead of the model (table travel per screw radian)"),
    ("m1", "float64", "U/(rad/s^2)", "motor-side inertia (eq. 3.1)"),
    ("m1_std", "float64", "U/(rad/s^2)", "its standard deviation"),
    ("m2", "float64", "U/(rad/s^2)", "table-side inertia"),
    ("m2_std", "float64", "U/(rad/s^2)", "its standard deviation"),
    ("b1", "float64", "U/(rad/s)", "motor-side viscous damping"),
    ("b1_std", "float64", "U/(rad/s)", "its standard deviation"),
    ("b2", "float64", "U/(rad/s)", "table-side viscous damping"),
    ("b2_std", "float64", "U/(rad/s)", "its standard deviation"),
    ("k", "float64", "U/rad", "axial stiffness"),
    ("k_std", "float64", "U/rad", "its standard deviation"),
    ("c", "float64", "U/(rad/s)", "nut damping"),
    ("c_std", "float64", "U/(rad/s)", "its standard deviation"),
    ("delay_s", "float64", "s", "equivalent delay fitted beside the model"),
    ("delay_s_std", "float64", "s", "its standard deviation"),
    ("mode_hz", "float64", "Hz", "first axial mode of the fitted model"),
    ("mode_zeta", "float64", "-", "its damping ratio"),
    ("real_pole_hz", "float64", "Hz", "real pole (viscous friction over total inertia)"),
    ("band_lo_hz", "float64", "Hz", "fitted band, low end"),
    ("band_hi_hz", "float64", "Hz", "fitted band, high end"),
    ("nrmse_motor", "float64", "-", "relative complex fit error of the motor-side channel (x1/u)"),
    ("nrmse_table", "float64", "-", "relative complex fit error of the table-side channel (x2/u)"),
    ("cert_ok", "bool", "-", "the installed gains meet every limit on every FRF of the measurement"),
    ("stable", "bool", "-", "stable (Nyquist) in every analysis case on every FRF"),
    ("first_crossover_hz", "float64", "Hz", "lowest first crossover over the FRFs"),
    ("ms", "float64", "-", "highest peak sensitivity over the FRFs"),
    ("ms_freq_hz", "float64", "Hz", "where it peaks"),
    ("pm_deg", "float64", "deg", "smallest |phase margin| over every crossover of every FRF"),
    ("gm_db", "float64", "dB", "smallest |gain margin|"),
    ("disk_margin", "float64", "-", "smallest balanced disk margin"),
    ("active_limit", "string", "-", "the limit closest to binding (ms, pm_deg, gm_db, disk_margin, band_top)"),
    ("active_value", "float64", "-", "its value (unit of the limit: -, deg, dB)"),
    ("active_bound", "float64", "-", "the limit"),
    ("active_slack", "float64", "-", "how far inside the limit, relative to it (negative: violated)"),
    ("force_unit", "string", "-", "command unit of the friction fit"),
    ("position_unit", "string", "-", "position unit of the friction fit (m or rad)"),
    ("mass", "float64", "U/(P/s^2)", "rigid-body inertia of the friction fit (IDIM-LS; P the position unit)"),
    ("mass_std", "float64", "U/(P/s^2)", "its standard deviation"),
    ("viscous", "float64", "U/(P/s)", "viscous friction"),
    ("viscous_std", "float64", "U/(P/s)", "its standard deviation"),
    ("coulomb", "float64", "U", "Coulomb friction"),
    ("coulomb_std", "float64", "U", "its standard deviation"),
    ("offset", "float64", "U", "constant force (gravity, cable drag)"),
    ("offset_std", "float64", "U", "its standard deviation"),
    ("friction_error_pct", "float64", "%", "relative error of the friction fit"),
)


def require_pyarrow():
    """``pyarrow``, or a UsageError saying how to install it."""
    try:
        import pyarrow
    except ImportError:
        raise UsageError("the fleet history is Parquet: install pyarrow (pip install 'feedtune[fleet]')") from None
    return pyarrow


def schema():
    """The history's pyarrow schema (every column nullable; ``unit`` and ``description`` in each field's
    metadata)."""
    pa = require_pyarrow()
    types = {"string": pa.string(), "float64": pa.float64(), "bool": pa.bool_(), "timestamp": pa.timestamp("s"),
             "list": pa.list_(pa.string())}
    return pa.schema([pa.field(name, types[kind], metadata={"unit": unit, "description": text})
                      for name, kind, unit, text in COLUMNS],
                     metadata={"schema": "feedtune.fleet-history/1"})


def rows_table(rows: Sequence[dict]):
    """A pyarrow table of history rows (missing keys are null; NaN floats are null)."""
    import math

    pa = require_pyarrow()
    clean = [{k: (None if isinstance(v, float) and math.isnan(v) else v) for k, v in r.items()} for r in rows]
    return pa.Table.from_pylist(clean, schema=schema())


# ------------------------------------------------------------------------------------------ the folder
def history_path(path) -> Path:
    """The history folder; DataError when ``path`` is a file."""
    p = Path(path)
    if p.exists() and not p.is_dir():
        raise DataError(f"{p}: a fleet history is a folder of Parquet files, and this is a file")
    return p


def part_files(path) -> list[Path]:
    """The history's part files (not ``_``/``.`` names), sorted."""
    p = history_path(path)
    if not p.is_dir():
        return []
    return sorted(f for f in p.glob("*.parquet") if not f.name.startswith(("_", ".")))


def read_history(path, columns: Sequence[str] | None = None):
    """Every row of a history as a pyarrow table, sorted by axis, date and key (empty, with the schema, when the
    folder does not exist).

    Parameters
    ----------
    path : path-like
        The history folder.
    columns : sequence of str, optional
        Only these columns.
    """
    pa = require_pyarrow()
    import pyarrow.parquet as pq

    files = part_files(path)
    sch = schema()
    if columns is not None:
        unknown = [c for c in columns if c not in sch.names]
        if unknown:
            raise UsageError(f"unknown history column(s) {', '.join(unknown)}")
        sch = pa.schema([sch.field(c) for c in columns], metadata=sch.metadata)
    tables = []
    for f in files:
        try:
            t = pq.read_table(f, columns=[c for c in sch.names if c in pq.read_schema(f).names])
        except (OSError, pa.ArrowException) as exc:
            raise DataError(f"{f}: not a readable Parquet file ({' '.join(str(exc).split())})") from None
        tables.append(_conform(t, sch))
    table = pa.concat_tables(tables) if tables else sch.empty_table()
    if table.num_rows and {"axis_id", "measured_at", "key"} <= set(table.column_names):
        table = table.sort_by([("axis_id", "ascending"), ("measured_at", "ascending"), ("key", "ascending")])
    return table


def _conform(table, sch):
    """``table`` with the schema's columns in its order (missing ones null: parts of an older feedtune)."""
    pa = require_pyarrow()
    cols = [table.column(f.name).cast(f.type) if f.name in table.column_names else pa.nulls(table.num_rows, f.type)
            for f in sch]
    return pa.Table.from_arrays(cols, schema=sch)


def history_keys(path) -> set[str]:
    """The keys already in the history."""
    table = read_history(path, columns=["key"])
    return set(table.column("key").to_pylist())


class HistoryWriter:
    """Appends rows to a history in whole part files (module docstring); a context manager holding the lock."""

    def __init__(self, path, *, batch_rows: int = BATCH_ROWS, batch_seconds: float = BATCH_SECONDS):
        require_pyarrow()
        self.path = history_path(path)
        self.batch_rows = int(batch_rows)
        self.batch_seconds = float(batch_seconds)
        self.pending: list[dict] = []
        self.written_rows = 0
        self.files: list[Path] = []
        self._last = time.monotonic()
        self._seq = 0
        self._run = f"{os.getpid()}{uuid.uuid4().hex[:6]}"
        self._locked = False

    def __enter__(self) -> HistoryWriter:
        parent = self.path.parent if str(self.path.parent) else Path(".")
        if not parent.is_dir():
            raise DataError(f"{self.path}: folder {parent} does not exist")
        self.path.mkdir(exist_ok=True)
        _take_lock(self.path / LOCK)
        self._locked = True
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        try:  # the finished rows are kept, also when the run fails or is interrupted
            if exc_type is None:
                self.flush()
            else:
                with contextlib.suppress(Exception):
                    self.flush()
        finally:
            if self._locked:
                with contextlib.suppress(OSError):
                    (self.path / LOCK).unlink()
                self._locked = False

    def add(self, rows: Iterable[dict]) -> None:
        """Queue rows; a part file is written when :attr:`batch_rows` are queued or :attr:`batch_seconds` passed."""
        self.pending.extend(rows)
        if len(self.pending) >= self.batch_rows or (
                self.pending and time.monotonic() - self._last >= self.batch_seconds):
            self.flush()

    def flush(self) -> Path | None:
        """Write the queued rows as one part file now (nothing when none are queued)."""
        self._last = time.monotonic()
        if not self.pending:
            return None
        import pyarrow.parquet as pq

        from ..io.atomic import atomic_output

        table = rows_table(self.pending)
        self._seq += 1
        name = f"part-{time.strftime('%Y%m%dT%H%M%S', time.gmtime())}-{self._run}-{self._seq:05d}.parquet"
        dest = self.path / name
        with atomic_output(dest, suffix=".parquet") as tmp:
            pq.write_table(table, tmp, compression="zstd")
            with open(tmp, "rb+") as fh:
                os.fsync(fh.fileno())
        self.written_rows += len(self.pending)
        self.files.append(dest)
        self.pending = []
        return dest


def _take_lock(lock: Path) -> None:
    """Create ``lock`` holding ``host pid``; refuse while another live process on this host holds it (a lock left by
    a killed process is taken over)."""
    me = f"{socket.gethostname()} {os.getpid()}"
    for _ in range(2):
        try:
            fd = os.open(lock, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o644)
        except FileExistsError:
            try:
                host, pid = lock.read_text(encoding="utf-8").split()
            except (OSError, ValueError):
                host, pid = "", "0"
            if host == socket.gethostname() and pid.isdigit() and not _alive(int(pid)):
                with contextlib.suppress(OSError):
                    lock.unlink()
                continue
            raise DataError(f"{lock.parent}: another fleet run (process {pid} on {host or 'unknown host'}) is writing "
                            f"this history; wait for it, or remove {lock} if that process is gone") from None
        with os.fdopen(fd, "w", encoding="utf-8") as fh:
            fh.write(me)
        return
    raise DataError(f"{lock}: cannot take the history's lock")  # pragma: no cover


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:
        return True
    return True


@contextlib.contextmanager
def history_lock(path) -> Iterator[Path]:
    """Hold a history's lock (for writers other than :class:`HistoryWriter`: the proposals)."""
    p = history_path(path)
    p.mkdir(exist_ok=True)
    _take_lock(p / LOCK)
    try:
        yield p
    finally:
        with contextlib.suppress(OSError):
            (p / LOCK).unlink()


FRICTION_COLUMNS = frozenset({"mass", "mass_std", "viscous", "viscous_std", "coulomb", "coulomb_std", "offset",
                              "offset_std"})


def unit_of(name: str, row: dict) -> str:
    """The unit of a column in a row: ``U`` replaced by the row's command unit (``input_unit``, ``force_unit`` for the
    friction fit) and ``P`` by its position unit."""
    unit = next((u for n, _, u, _ in COLUMNS if n == name), "-")
    if name in FRICTION_COLUMNS:
        command, position = row.get("force_unit") or "U", row.get("position_unit") or "P"
    else:
        command, position = row.get("input_unit") or "U", "rad"
    if unit.startswith("U"):
        unit = command + unit[1:]
    return unit.replace("(P/", f"({position}/")
