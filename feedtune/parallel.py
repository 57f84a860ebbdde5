"""Independent steps of a demo run side by side on the machine's cores: forked worker processes, results pickled back.

A demo's tuners (the ball screw's MC-PPC and P-PI, the gantry's MIMO, PIDs and x axis) do not depend on each other;
on a machine with several cores each group of them runs in a process forked from the caller (the inputs, the
imported modules and the compiled kernels are inherited, nothing is imported or compiled again), and the results
come back through a pipe. The results are those of the serial run: the same functions on the same inputs.

Only where asked for: the ``FEEDTUNE_JOBS`` environment variable (``auto``: one process per usable core; ``N``: at
most N) — the command line sets ``auto`` unless the user set it; a library caller (a notebook kernel with threads of
its own) runs serially unless it sets the variable. Serial also when fork is not available (Windows, macOS'
default), with one usable core, inside a worker already, or with ``FEEDTUNE_JOBS=1``. An error in a worker is raised
again in the caller; when the caller is interrupted its workers are terminated. Workers report no progress
(:mod:`feedtune.progress`): the caller's step covers them.

Two ways to share the work: :func:`run_groups` with groups fixed beforehand (:func:`plan` balances them by an
expected cost), and :func:`run_queue`, where every process takes the next job from a shared queue as soon as it is
free (the report's figures, whose costs are not known beforehand).
"""

from __future__ import annotations

import os
import pickle
import signal
import sys
from collections.abc import Callable, Sequence

JOBS_ENV = "FEEDTUNE_JOBS"
"""Environment variable capping the worker processes (1: serial)."""

_IN_WORKER = False


def usable_cores() -> int:
    """Cores this process may use for worker processes: its CPU affinity where the platform says, capped by
    ``FEEDTUNE_JOBS``; 1 when that variable is not set."""
    try:
        n = len(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        n = os.cpu_count() or 1
    cap = os.environ.get(JOBS_ENV, "").strip().lower()
    if not cap:  # not asked for (see the module docstring)
        return 1
    if cap != "auto":
        try:
            n = min(n, max(int(cap), 1))
        except ValueError:
            n = 1
    return max(n, 1)


def _can_fork() -> bool:
    return hasattr(os, "fork") and sys.platform.startswith("linux") and not _IN_WORKER


def run_groups(groups: Sequence[Sequence[tuple[str, Callable[[], object]]]],
               processes: int | None = None) -> dict[str, object]:
    """Run the named jobs of every group; each group in a process of its own (the first in the caller).

    Parameters
    ----------
    groups : sequence of sequence of (str, callable)
        Jobs as ``(name, fn)``; the jobs of one group run one after the other, the groups side by side.
    processes : int, optional
        Processes the caller allows (default :func:`usable_cores`, which is 1 unless ``FEEDTUNE_JOBS`` asks for
        more); 1 runs every group here, one after the other. A caller that decided for itself (the report counts
        the idle cores) passes its number.

    Returns
    -------
    dict
        ``{name: fn()}`` over every job.
    """
    groups = [list(g) for g in groups if g]
    allowed = usable_cores() if processes is None else processes
    if len(groups) <= 1 or allowed <= 1 or not _can_fork():
        return {name: fn() for g in groups for name, fn in g}
    children: list[tuple[int, object]] = []  # (pid, pipe to read), until reaped
    results: dict[str, object] = {}
    try:
        for g in groups[1:]:
            children.append(_fork(g))
        for name, fn in groups[0]:
            results[name] = fn()
        while children:
            pid, src = children[0]
            data = src.read()  # an interruption here leaves the worker listed: it is stopped below
            src.close()
            os.waitpid(pid, 0)
            children.pop(0)
            results.update(_unpack(pid, data))
    finally:
        for pid, src in children:  # the caller failed or was interrupted: its workers are not needed any more
            _stop(pid, src)
    return results


QUEUE_MAX_JOBS = 4096
"""Most jobs :func:`run_queue` hands out through its pipe (4 bytes each, written before any worker starts: they
must fit in the pipe's buffer, 64 KiB on Linux)."""


def run_queue(jobs: Sequence[tuple[str, Callable[[], object]]], processes: int | None = None, *,
              after_each: Callable[[str], None] | None = None) -> dict[str, object]:
    """Run the named jobs on ``processes`` processes (this one and forked workers), each process taking the next
    job not yet taken as soon as it is free: jobs of unequal cost end up evenly spread without a cost estimate.

    The job numbers are written into a pipe before the workers are forked; every process reads one number (4
    bytes: a read that small is atomic, no two processes get the same job) until the pipe is empty. Serially (one
    process allowed, no fork) this process takes every job in order. Put the costliest jobs first where known:
    the last job taken decides when the slowest process ends.

    Parameters
    ----------
    jobs : sequence of (str, callable)
        ``(name, fn)``; names unique.
    processes : int, optional
        Processes in all (default :func:`usable_cores`); see :func:`run_groups`.
    after_each : callable, optional
        Called with the job's name after each job done in this process (not in the workers): progress.

    Returns
    -------
    dict
        ``{name: fn()}`` over every job, in the order of ``jobs``.
    """
    import struct

    jobs = list(jobs)
    n = max(1, min(usable_cores() if processes is None else processes, len(jobs)))
    if n <= 1 or not _can_fork():
        out = {}
        for name, fn in jobs:
            out[name] = fn()
            if after_each is not None:
                after_each(name)
        return out
    if len(jobs) > QUEUE_MAX_JOBS:
        raise ValueError(f"run_queue takes at most {QUEUE_MAX_JOBS} jobs in several processes, got {len(jobs)}")
    me = os.getpid()
    r, w = os.pipe()
    try:
        os.write(w, b"".join(struct.pack("<I", i) for i in range(len(jobs))))
    finally:
        os.close(w)  # before any fork: the workers see the end of the queue once it is empty

    def take() -> dict[str, object]:
        out = {}
        while len(got := os.read(r, 4)) == 4:
            name, fn = jobs[struct.unpack("<I", got)[0]]
            out[name] = fn()
            if after_each is not None and os.getpid() == me:
                after_each(name)
        return out

    try:
        parts = run_groups([[(f"queue {k}", take)] for k in range(n)], processes=n)
    finally:
        os.close(r)
    done = {name: value for part in parts.values() for name, value in part.items()}
    return {name: done[name] for name, _ in jobs}


def plan(jobs: Sequence[tuple[str, Callable[[], object], float]], processes: int | None = None) -> list[list]:
    """Jobs ``(name, fn, expected cost)`` put into ``processes`` groups (default: the usable cores) of about equal
    cost, the costliest first (longest-processing-time rule); the order within a group is the jobs' order."""
    n = max(1, min(usable_cores() if processes is None else processes, len(jobs)))
    loads = [0.0] * n
    members: list[list[int]] = [[] for _ in range(n)]
    for i in sorted(range(len(jobs)), key=lambda i: -jobs[i][2]):
        k = loads.index(min(loads))
        loads[k] += jobs[i][2]
        members[k].append(i)
    return [[(jobs[i][0], jobs[i][1]) for i in sorted(m)] for m in members if m]


def _fork(group: list) -> tuple[int, object]:
    r, w = os.pipe()
    pid = os.fork()
    if pid == 0:  # worker: run, send, leave without the caller's exit handlers
        global _IN_WORKER
        _IN_WORKER = True
        os.close(r)
        code = 0
        try:
            try:
                signal.signal(signal.SIGINT, signal.SIG_DFL)
                signal.signal(signal.SIGTERM, signal.SIG_DFL)
                with _silent():  # the caller's progress display covers the workers
                    payload = ("ok", {name: fn() for name, fn in group})
            except BaseException as exc:  # every failure goes back to the caller
                payload = ("error", exc)
            try:
                data = pickle.dumps(payload, protocol=pickle.HIGHEST_PROTOCOL)
            except Exception as exc:  # e.g. an unpicklable exception
                data = pickle.dumps(("error", RuntimeError(f"worker result not picklable: {exc!r}")))
            with os.fdopen(w, "wb") as out:
                out.write(data)
        except BaseException:
            code = 1
        finally:
            os._exit(code)
    os.close(w)
    return pid, os.fdopen(r, "rb")


def _silent():
    """A context in which :mod:`feedtune.progress` reports nothing."""
    from .progress import reporting

    return reporting(None)


class WorkerLostError(RuntimeError):
    """A worker process ended without sending a result (killed, or out of memory)."""


def _unpack(pid: int, data: bytes) -> dict:
    if not data:
        raise WorkerLostError(f"a worker process ({pid}) ended without a result")
    status, value = pickle.loads(data)
    if status == "error":
        raise value
    return value


def _stop(pid: int, src) -> None:
    """End and reap a worker that has not been reaped."""
    try:
        os.kill(pid, signal.SIGTERM)
    except ProcessLookupError:
        pass
    src.close()
    try:
        os.waitpid(pid, 0)
    except ChildProcessError:
        pass
