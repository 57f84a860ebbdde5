"""A fleet run: plan the manifest's measurements, run the new ones on an engine, append their rows, judge the drift,
and (optionally) propose re-tunes.

1. **Plan** (:func:`plan_fleet`): every file of every measurement and every installed gains file is hashed; the key
   of a measurement is the axis and its files' digests. A file that cannot be read leaves its measurement out of this
   run (reported, not written: the next run tries it again).
2. **Measure**: the measurements whose key is not in the history run as tasks
   (:func:`feedtune.fleet.task.run_measurement`) on the engine (:class:`feedtune.fleet.engine.Engine`); each finished
   row is queued and written in whole part files (:class:`feedtune.fleet.history.HistoryWriter`). Killed at any
   point, a run leaves whole files only, and the next run does exactly the measurements that have no row.
3. **Status** (:func:`feedtune.fleet.status.fleet_status`): trends, alarms and forecasts (the forecasts on the engine).
4. **Re-tune** (``retune``): for every red or amber axis whose newest measurement has a fit and no proposal yet, a
   certified re-tune (:mod:`feedtune.fleet.retune`) on the engine, written into the history's ``_proposals/``.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field, replace
from pathlib import Path

from .. import progress
from .engine import Engine, TaskFailed
from .history import PROPOSALS, HistoryWriter, history_keys
from .manifest import Manifest, Measurement, file_digest, measurement_key
from .task import MeasurementTask, TaskOutcome, run_measurement


@dataclass(frozen=True)
class Plan:
    """The manifest's measurements with their keys and tasks.

    Attributes
    ----------
    manifest : Manifest
    entries : list of (str, Measurement, str or None, MeasurementTask or None)
        ``(axis_id, measurement, key, task)``; key and task None when a file could not be read.
    unreadable : list of dict
        ``{"axis_id", "date", "error"}`` of those.
    """

    manifest: Manifest
    entries: list
    unreadable: list

    @property
    def keys(self) -> dict[str, str]:
        """``{key: axis_id}``."""
        return {key: axis_id for axis_id, _, key, _ in self.entries if key is not None}

    @property
    def tasks(self) -> list[MeasurementTask]:
        """Every readable measurement's task, in manifest order."""
        return [t for *_, t in self.entries if t is not None]

    def measurements(self, axis_id: str) -> list[tuple[Measurement, str | None]]:
        """``(measurement, key)`` of an axis, oldest first."""
        return [(m, key) for a, m, key, _ in self.entries if a == axis_id]

    def measurement(self, key: str) -> Measurement | None:
        """The measurement of a key."""
        return next((m for _, m, k, _ in self.entries if k == key), None)


def plan_fleet(manifest: Manifest) -> Plan:
    """Hash every file and build the tasks (module docstring, step 1)."""
    entries, unreadable = [], []
    with progress.task("hashing the manifest's files", total=len(manifest.axes)) as advance:
        for axis in manifest.axes:
            try:
                gains_digest = file_digest(axis.gains)
                gains_error = None
            except ValueError as exc:
                gains_digest, gains_error = None, f"gains: {exc}"
            for m in axis.measurements:
                try:
                    if gains_error:
                        raise ValueError(gains_error)
                    digests = {f"frf{i + 1}": file_digest(p) for i, p in enumerate(m.frfs)}
                    if m.log is not None:
                        digests["log"] = file_digest(m.log)
                except ValueError as exc:
                    entries.append((axis.id, m, None, None))
                    unreadable.append({"axis_id": axis.id, "date": m.date.isoformat(), "error": str(exc)})
                    continue
                key = measurement_key(axis.id, digests)
                task = MeasurementTask(
                    key, axis.id, axis.machine, axis.axis, axis.structure, m.date, tuple(str(p) for p in m.frfs),
                    tuple(manifest.relative(p) for p in m.frfs), None if m.log is None else str(m.log),
                    manifest.relative(m.log), str(axis.gains), manifest.relative(axis.gains), gains_digest,
                    axis.limits, digests, dict(axis.frf_options), dict(axis.log_options), dict(axis.identify))
                entries.append((axis.id, m, key, task))
            advance()
    return Plan(manifest, entries, unreadable)


@dataclass
class RunSummary:
    """What a run did (``fleet run --json``: docs/json.md).

    Attributes
    ----------
    engine : str
        Where the tasks ran.
    measurements : int
        In the manifest.
    already : int
        Already in the history (not run again).
    written : int
        Rows written by this run.
    data_errors : list of dict
        Rows written with an error (``axis_id``, ``date``, ``error``).
    not_written : list of dict
        Measurements left for the next run (a file that cannot be read, a lost worker).
    files : list of str
        Part files written.
    wall_s : float
        Wall time of the measurement tasks [s].
    task_cpu_s, task_wall_s : list of float
        Per task [s].
    workers : dict
        ``{worker: {"tasks", "peak_rss_mib"}}``.
    proposals : list of dict
        Re-tunes written (``axis_id``, ``file``) or refused (``axis_id``, ``error``).
    """

    engine: str = ""
    measurements: int = 0
    already: int = 0
    written: int = 0
    data_errors: list = field(default_factory=list)
    not_written: list = field(default_factory=list)
    files: list = field(default_factory=list)
    wall_s: float = 0.0
    task_cpu_s: list = field(default_factory=list)
    task_wall_s: list = field(default_factory=list)
    workers: dict = field(default_factory=dict)
    proposals: list = field(default_factory=list)

    def record(self, outcome: TaskOutcome) -> None:
        """Count a finished task."""
        self.task_cpu_s.append(outcome.cpu_s)
        self.task_wall_s.append(outcome.wall_s)
        w = self.workers.setdefault(outcome.worker, {"tasks": 0, "peak_rss_mib": 0.0})
        w["tasks"] += 1
        w["peak_rss_mib"] = max(w["peak_rss_mib"], outcome.peak_rss_mib)

    def to_dict(self) -> dict:
        """JSON-ready."""
        n = len(self.task_cpu_s)
        return {"engine": self.engine, "measurements": self.measurements, "already_in_history": self.already,
                "written": self.written, "data_errors": self.data_errors, "not_written": self.not_written,
                "files": self.files, "wall_s": self.wall_s,
                "tasks": {"count": n, "cpu_s": sum(self.task_cpu_s), "mean_cpu_s": sum(self.task_cpu_s) / n if n
                          else None, "mean_wall_s": sum(self.task_wall_s) / n if n else None},
                "workers": self.workers, "proposals": self.proposals}


@dataclass(frozen=True)
class RunResult:
    """A run's summary and the fleet's status after it."""

    summary: RunSummary
    status: object


def run_fleet(manifest: Manifest, history, *, engine: Engine | None = None, retune: bool = False, status: bool = True,
              settings=None, horizon_weeks: float | None = None, batch_rows: int | None = None,
              batch_seconds: float | None = None) -> RunResult:
    """Run a fleet (module docstring).

    Parameters
    ----------
    manifest : Manifest
    history : path-like
        The history folder (created when missing).
    engine : Engine, optional
        Where the tasks run (default: local processes on every usable core).
    retune : bool
        Propose certified re-tunes for red and amber axes.
    status : bool
        Judge drift and forecast after the measurements (needed by ``retune``).
    settings : DriftSettings, optional
    horizon_weeks : float, optional
        How far ahead failures are forecast (default :data:`feedtune.fleet.status.HORIZON_WEEKS`).
    batch_rows, batch_seconds : optional
        Part-file batching (default :data:`feedtune.fleet.history.BATCH_ROWS`, ``BATCH_SECONDS``).

    Returns
    -------
    RunResult
    """
    from .history import BATCH_ROWS, BATCH_SECONDS
    from .status import HORIZON_WEEKS, fleet_status

    own_engine = engine is None
    engine = engine or Engine()
    summary = RunSummary(engine=engine.describe())
    plan = plan_fleet(manifest)
    summary.measurements = len(plan.entries)
    summary.not_written = list(plan.unreadable)
    fleet = None
    try:
        with HistoryWriter(history, batch_rows=batch_rows or BATCH_ROWS,
                           batch_seconds=BATCH_SECONDS if batch_seconds is None else batch_seconds) as writer:
            done = history_keys(history)
            todo = [t for t in plan.tasks if t.key not in done]
            summary.already = len(plan.tasks) - len(todo)
            start = time.perf_counter()
            try:
                with progress.task("measurements", total=len(todo)) as advance:
                    for task, outcome in engine.map_unordered(run_measurement, todo):
                        _take(summary, writer, task, outcome)
                        advance()
            finally:
                summary.wall_s = time.perf_counter() - start
                writer.flush()
                summary.written = writer.written_rows
                summary.files = [str(p) for p in writer.files]
            if status or retune:
                fleet = fleet_status(manifest, history, plan, engine, settings=settings,
                                     horizon_weeks=HORIZON_WEEKS if horizon_weeks is None else horizon_weeks)
            if retune and fleet is not None:
                fleet = _propose(fleet, manifest, history, plan, engine, summary)
    finally:
        if own_engine:
            engine.close()
    return RunResult(summary, fleet)


def _take(summary: RunSummary, writer: HistoryWriter, task: MeasurementTask, outcome) -> None:
    where = {"axis_id": task.axis_id, "date": task.date.isoformat()}
    if isinstance(outcome, TaskFailed):
        summary.not_written.append({**where, "error": outcome.message})
        return
    summary.record(outcome)
    if outcome.transient:
        summary.not_written.append({**where, "error": outcome.row.get("error")})
        return
    writer.add([outcome.row])
    if outcome.row.get("error"):
        summary.data_errors.append({**where, "error": outcome.row["error"]})


def _propose(fleet, manifest: Manifest, history, plan: Plan, engine: Engine, summary: RunSummary):
    """Re-tune the red and amber axes that have no proposal for their newest measurement (module docstring)."""
    from ..io import write_document
    from .retune import Proposal, run_retune
    from .snapshot import has_fit, snapshot
    from .status import _proposal, proposal_name

    tasks = []
    for a in fleet.axes:
        newest = a.newest
        if a.light not in ("red", "amber") or a.proposal is not None or newest is None:
            continue
        if not has_fit(newest):
            continue
        tasks.append(snapshot(manifest.axis(a.axis_id), manifest, newest, plan.measurement(newest["key"])))
    if not tasks:
        return fleet
    folder = Path(history) / PROPOSALS
    folder.mkdir(exist_ok=True)
    with progress.task("re-tunes", total=len(tasks)) as advance:
        for task, result in engine.map_unordered(run_retune, tasks):
            if isinstance(result, Proposal):
                entry = manifest.axis(task.axis_id)
                path = folder / proposal_name(entry.slug, task.key)
                write_document(path, result.doc)
                summary.proposals.append({"axis_id": task.axis_id, "file": f"{PROPOSALS}/{path.name}"})
            else:
                message = result.message if isinstance(result, TaskFailed) else str(result)
                summary.proposals.append({"axis_id": task.axis_id, "error": message})
            advance()
    axes = tuple(replace(a, proposal=_proposal(history, manifest.axis(a.axis_id), a.rows)) for a in fleet.axes)
    return replace(fleet, axes=axes)
