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


def run_groups(groups: Sequence[Sequence[tuple[str, Callable[[], object]]]]) -> dict[str, object]:
    """Run the named jobs of every group; each group in a process of its own (the first in the caller).

    Parameters
    ----------
    groups : sequence of sequence of (str, callable)
        Jobs as ``(name, fn)``; the jobs of one group run one after the other, the groups side by side.

    Returns
    -------
    dict
        ``{name: fn()}`` over every job.
    """
    groups = [list(g) for g in groups if g]
    if len(groups) <= 1 or usable_cores() <= 1 or not _can_fork():
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


def _unpack(pid: int, data: bytes) -> dict:
    if not data:
        raise RuntimeError(f"a worker process ({pid}) ended without a result")
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
