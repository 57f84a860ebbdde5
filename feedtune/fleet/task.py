"""One task of a fleet run: an axis' measurement identified, the installed gains re-certified on its FRFs, its
friction fitted from its reversal log; the result is one history row.

The task is a plain function of a picklable :class:`MeasurementTask`, so local worker processes and a Dask cluster
run the same code on the same inputs (the library calls of ``feedtune identify ballscrew``, ``feedtune analyze
GAINS --frf`` and ``feedtune identify rigid``, never the command line). It runs with one BLAS thread
(:mod:`feedtune.blas`) and without forked helpers of its own (``FEEDTUNE_JOBS=1``): the engine decides the
parallelism.

A stage that fails on the data (a fit that does not converge, an FRF without ``x2/u``, a gains file of the wrong
kind) leaves its columns empty and its message in ``error``; the row is still written, so the fleet goes on and a
re-run of the same files does not repeat it. A failure of the machine rather than the data (a file that cannot be
read, memory) makes the task *transient*: reported in the run, not written, tried again by the next run.
"""

from __future__ import annotations

import contextlib
import datetime as _dt
import os
import time
from collections.abc import Iterator
from dataclasses import dataclass, field

from ..analysis.limits import Limits
from .snapshot import MODEL_PARAMETERS

TRANSIENT = (OSError, MemoryError)
"""Failures of the machine, not of the data: the task is tried again by the next run (not written)."""

FRICTION_PARAMS = ("mass", "viscous", "coulomb", "offset")


@dataclass(frozen=True)
class MeasurementTask:
    """Everything one task needs (picklable; paths absolute, names as the manifest writes them).

    Attributes
    ----------
    key : str
        The history key (:func:`feedtune.fleet.manifest.measurement_key`).
    axis_id, machine, axis, structure : str
    date : datetime.datetime
    frfs, frf_names : tuple of str
        FRF files (absolute) and their names as recorded.
    log, log_name : str or None
        Reversal log.
    gains, gains_name, gains_digest : str
        Installed gains file, its recorded name and SHA-256.
    limits : Limits
    digests : dict
        ``{"frf1": ..., "log": ...}`` SHA-256 of every file.
    frf_options, log_options, identify : dict
        Reader and fit settings from the manifest.
    """

    key: str
    axis_id: str
    machine: str
    axis: str
    structure: str
    date: _dt.datetime
    frfs: tuple[str, ...]
    frf_names: tuple[str, ...]
    log: str | None
    log_name: str | None
    gains: str
    gains_name: str
    gains_digest: str
    limits: Limits
    digests: dict = field(default_factory=dict)
    frf_options: dict = field(default_factory=dict)
    log_options: dict = field(default_factory=dict)
    identify: dict = field(default_factory=dict)


@dataclass(frozen=True)
class TaskOutcome:
    """What a task returns: the row, whether it is written, and what it cost.

    Attributes
    ----------
    key : str
    row : dict
        The history row (:data:`feedtune.fleet.history.COLUMNS`).
    transient : bool
        A failure of the machine (module docstring): not written.
    cpu_s : float
        CPU time of the task in its process [s].
    wall_s : float
        Wall time of the task [s].
    peak_rss_mib : float
        The worker process' peak resident memory so far [MiB].
    worker : str
        The process that ran it (``host:pid``).
    """

    key: str
    row: dict
    transient: bool
    cpu_s: float
    wall_s: float
    peak_rss_mib: float
    worker: str


@contextlib.contextmanager
def worker_settings() -> Iterator[None]:
    """One BLAS thread and no forked helpers inside a task (restored after it)."""
    from ..blas import single_threaded_blas
    from ..parallel import JOBS_ENV

    before = os.environ.get(JOBS_ENV)
    os.environ[JOBS_ENV] = "1"
    try:
        with single_threaded_blas():
            yield
    finally:
        if before is None:
            os.environ.pop(JOBS_ENV, None)
        else:
            os.environ[JOBS_ENV] = before


def peak_rss_mib() -> float:
    """This process' peak resident memory [MiB] (0 where the platform does not say)."""
    try:
        import resource
        import sys

        peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
        return peak / (1024 * 1024) if sys.platform == "darwin" else peak / 1024
    except (ImportError, OSError):  # pragma: no cover - Windows
        return 0.0


def worker_name() -> str:
    """``host:pid`` of this process."""
    import socket

    return f"{socket.gethostname()}:{os.getpid()}"


def timed(key: str, fn, *args) -> TaskOutcome:
    """Run ``fn(*args) -> (row, transient)`` under :func:`worker_settings` and measure it."""
    wall, cpu = time.perf_counter(), time.process_time()
    with worker_settings():
        row, transient = fn(*args)
    return TaskOutcome(key, row, transient, time.process_time() - cpu, time.perf_counter() - wall, peak_rss_mib(),
                       worker_name())


# ------------------------------------------------------------------------------------------ the measurement task
def run_measurement(task: MeasurementTask) -> TaskOutcome:
    """Identify, re-certify and fit friction for one measurement (module docstring); never raises for the data."""
    return timed(task.key, _measurement_row, task)


def _measurement_row(task: MeasurementTask) -> tuple[dict, bool]:
    from .. import __version__

    row: dict = {
        "key": task.key, "axis_id": task.axis_id, "machine": task.machine, "axis": task.axis,
        "structure": task.structure, "measured_at": task.date, "frf_files": ";".join(task.frf_names),
        "log_file": task.log_name,
        "frf_digests": ";".join(v for k, v in sorted(task.digests.items()) if k.startswith("frf")),
        "log_digest": task.digests.get("log"), "gains_file": task.gains_name, "gains_digest": task.gains_digest,
        "limits": task.limits.describe(), "feedtune_version": __version__,
    }
    errors: list[str] = []
    warnings: list[str] = []
    transient = False

    def stage(name: str, fn) -> None:
        nonlocal transient
        try:
            fn()
        except TRANSIENT as exc:
            transient = True
            errors.append(f"{name}: {_one_line(exc)}")
        except Exception as exc:  # a failure of one axis is a row, never the end of the fleet
            errors.append(f"{name}: {_one_line(exc)}")

    frfs: list = []

    def read_frfs() -> None:
        from ..io import read_frf

        frfs.extend(read_frf(p, **task.frf_options) for p in task.frfs)

    stage("FRF", read_frfs)
    if frfs:
        stage("identify", lambda: _identify(task, frfs, row, warnings))
        stage("certificate", lambda: _certify(task, frfs, row))
    if task.log is not None:
        stage("friction", lambda: _friction(task, row, warnings))
    row["verdict"] = "error" if row.get("cert_ok") is None else ("ok" if row["cert_ok"] else "fails")
    row["error"] = "; ".join(errors) or None
    row["warnings"] = [str(w) for w in dict.fromkeys(warnings)]
    row.setdefault("violations", [])
    return row, transient


def _one_line(exc: BaseException) -> str:
    from ..errors import FeedtuneError

    text = " ".join(str(exc).split())
    return text if isinstance(exc, FeedtuneError) else f"{type(exc).__name__}: {text}"


def _identify(task: MeasurementTask, frfs: list, row: dict, warnings: list) -> None:
    from ..identify.ballscrew import fit_ballscrew

    options = dict(task.identify)
    if options.get("band_hz") is not None:
        options["band_hz"] = tuple(options["band_hz"])
    fit = fit_ballscrew(frfs, **options)
    model = fit.model
    row["input_unit"] = model.input_unit
    row["lead_m_per_rad"] = float(model.lead_m_per_rad)
    for name in MODEL_PARAMETERS:
        row[name] = float(getattr(model, name))
        row[f"{name}_std"] = float(fit.std.get(name, float("nan")))
    row["delay_s"], row["delay_s_std"] = float(fit.delay_s), float(fit.delay_std_s)
    modes = fit.modes
    row["mode_hz"] = float(modes[0].freq_hz) if modes else None
    row["mode_zeta"] = float(modes[0].zeta) if modes else None
    row["real_pole_hz"] = float(fit.real_pole_hz)
    row["band_lo_hz"], row["band_hi_hz"] = (float(b) for b in fit.band_hz)
    channels = list(fit.fit)
    row["nrmse_motor"] = float(fit.fit[channels[0]]["nrmse"]) if channels else None
    row["nrmse_table"] = float(fit.fit[channels[1]]["nrmse"]) if len(channels) > 1 else None
    warnings.extend(f"identify: {w}" for w in fit.warnings)


def _certify(task: MeasurementTask, frfs: list, row: dict) -> None:
    from ..io import read_document
    from ..machines.certificate import certify

    doc = read_document(task.gains)
    row["controller"] = str(doc.get("controller") or doc.get("kind"))
    cert = certify(doc, task.gains_name, list(zip(task.frf_names, frfs, strict=True)), task.limits)
    row.update(certificate_columns(cert))


def certificate_columns(cert) -> dict:
    """The certificate's worst case as history columns (``cert_ok`` ... ``active_slack``, ``violations``)."""
    worst = cert.worst()
    peak = max(cert.frfs, key=lambda c: float(c.metrics.ms))
    active = worst.get("active_limit") or {}
    return {"cert_ok": bool(cert.ok), "stable": bool(worst["stable"]),
            "first_crossover_hz": worst["first_crossover_hz"], "ms": worst["ms"],
            "ms_freq_hz": float(peak.metrics.ms_freq_hz), "pm_deg": worst["pm_deg"], "gm_db": worst["gm_db"],
            "disk_margin": worst["disk_margin"], "active_limit": active.get("name"),
            "active_value": active.get("value"), "active_bound": active.get("limit"),
            "active_slack": active.get("slack"),
            "violations": [f"{c.name}: {v}" for c in cert.frfs for v in c.check.violations]}


def _friction(task: MeasurementTask, row: dict, warnings: list) -> None:
    from ..identify.rigid import fit_rigid
    from ..io import read_log
    from .manifest import LOG_READ_KEYS

    opts = task.log_options
    log = read_log(task.log, **{k: v for k, v in opts.items() if k in LOG_READ_KEYS})
    fit = fit_rigid(log, force=opts["input"], position=opts["position"],
                    velocity_threshold=opts.get("velocity_threshold"), cutoff_hz=opts.get("cutoff_hz"))
    if "coulomb" not in fit.values:
        from ..errors import DataError

        raise DataError(f"{task.log_name}: the log moves one way only: Coulomb friction and offset cannot be "
                        "separated")
    row["force_unit"], row["position_unit"] = fit.force_unit, fit.position_unit
    for name in FRICTION_PARAMS:
        row[name] = float(fit.values[name])
        row[f"{name}_std"] = float(fit.std[name])
    row["friction_error_pct"] = float(fit.relative_error_pct)
    warnings.extend(f"friction: {w}" for w in fit.warnings)
