"""Where a fleet's tasks run: local worker processes (``concurrent.futures``) or a Dask distributed cluster.

Both take the same task function and the same picklable task values and hand the results back as they finish, so a
fleet run is the same whichever runs it. No scheduling of our own: a ``ProcessPoolExecutor`` or a Dask
``Client`` decides which worker takes which task; the engine only keeps a window of submitted tasks
(:data:`WINDOW_PER_WORKER` per worker), so the memory of pending results stays bounded however large the fleet.

* Local (default): ``jobs`` processes started by a fork server (Linux; spawned elsewhere) that has imported the
  fleet's modules once, so a worker starts in milliseconds and inherits no threads of the caller (pyarrow's). Each
  worker sets ``OPENBLAS_NUM_THREADS=1`` (and the MKL/BLIS/vecLib spellings) and ``FEEDTUNE_JOBS=1``, and ends when
  the process running the fleet is gone (:func:`_watch`), so killing a run leaves no orphans. ``jobs=1`` runs every
  task in this process.
* Dask: ``scheduler`` is the address of a running ``distributed`` scheduler (``tcp://host:8786``); every worker needs
  this feedtune installed and the manifest's files at the same paths (a shared file system).

A worker that dies (a crash, the kernel's out-of-memory killer) is replaced; its tasks are given out again once, and
a task that loses a worker twice comes back as failed (:class:`TaskFailed`): the run records it for this run only,
and the next run tries it again.
"""

from __future__ import annotations

import os
import sys
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass

from ..errors import UsageError

WINDOW_PER_WORKER = 4
"""Tasks submitted ahead per worker: enough to keep every worker busy, few enough to bound pending results."""
PRELOAD = ("pandas", "scipy.optimize", "scipy.signal", "scipy.linalg", "scipy.interpolate", "jsonschema",
           "threadpoolctl", "feedtune.fleet.task", "feedtune.fleet.forecast", "feedtune.fleet.retune",
           "feedtune.identify.ballscrew", "feedtune.identify.rigid", "feedtune.machines.certificate",
           "feedtune.machines.ballscrew.gains_analysis", "feedtune.analysis.ballscrew", "feedtune.io",
           "feedtune.io.gains", "feedtune.io.gains_schema")
"""Modules the fork server imports once for all local workers (what a task imports: about 1 s of CPU per worker
otherwise)."""
BLAS_VARIABLES = ("OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "BLIS_NUM_THREADS", "VECLIB_MAXIMUM_THREADS",
                  "OMP_NUM_THREADS")
MAX_LOST = 2
"""A task whose worker died this many times is given up for this run."""


@dataclass(frozen=True)
class TaskFailed:
    """A task the engine could not finish (its worker died :data:`MAX_LOST` times, or the cluster lost it)."""

    message: str


def _failure(exc: BaseException) -> str:
    return f"{type(exc).__name__}: {' '.join(str(exc).split())}"


def _call(fn: Callable, item):
    """``fn(item)`` in this process; an exception comes back as a :class:`TaskFailed` (one task, not the run)."""
    try:
        return fn(item)
    except Exception as exc:
        return TaskFailed(_failure(exc))


def available_cores() -> int:
    """Cores this process may use (its CPU affinity where the platform says)."""
    try:
        return max(len(os.sched_getaffinity(0)), 1)
    except (AttributeError, OSError):
        return max(os.cpu_count() or 1, 1)


def _init_worker(run_pid: int) -> None:
    """Local worker start: one BLAS thread, no forked helpers, and a watch on the run's process (:func:`_watch`)."""
    for name in BLAS_VARIABLES:
        os.environ[name] = "1"
    os.environ["FEEDTUNE_JOBS"] = "1"
    import threading

    threading.Thread(target=_watch, args=(run_pid,), name="feedtune-fleet-watch", daemon=True).start()


def _watch(pid: int) -> None:
    """End this worker when the process running the fleet is gone (killed with SIGKILL, it cannot stop its workers;
    an idle worker would wait for a task forever and keep the fork server alive). Waits on a pidfd where Linux has
    one, else looks every second."""
    import time

    try:
        import select

        fd = os.pidfd_open(pid)
        select.select([fd], [], [])
    except (AttributeError, OSError):
        while True:
            try:
                os.kill(pid, 0)
            except ProcessLookupError:
                break
            except OSError:
                pass
            time.sleep(1.0)
    os._exit(1)


class Engine:
    """Runs task functions on local processes or a Dask cluster (module docstring).

    Parameters
    ----------
    jobs : int, optional
        Local worker processes (default: the cores this process may use). Ignored with ``scheduler``.
    scheduler : str, optional
        Address of a Dask distributed scheduler.
    """

    def __init__(self, jobs: int | None = None, scheduler: str | None = None):
        if jobs is not None and (isinstance(jobs, bool) or int(jobs) != jobs or jobs < 1):
            raise UsageError(f"jobs must be a whole number >= 1, got {jobs!r}", parameter="jobs")
        self.scheduler = scheduler
        self.jobs = int(jobs) if jobs is not None else available_cores()
        self._client = None
        self._pool = None
        self._finished = 0
        if scheduler is not None:
            self._client = _dask_client(scheduler)

    # -------------------------------------------------------------------------------------- description
    @property
    def workers(self) -> int:
        """Workers that run tasks (Dask: those connected now)."""
        if self._client is not None:
            return max(len(self._client.scheduler_info().get("workers", {})), 1)
        return self.jobs

    def describe(self) -> str:
        """``2 local processes`` or ``Dask scheduler tcp://...: 2 workers``."""
        if self._client is not None:
            return f"Dask scheduler {self.scheduler}: {self.workers} worker{'s' * (self.workers != 1)}"
        return "this process" if self.jobs == 1 else f"{self.jobs} local processes"

    # -------------------------------------------------------------------------------------- running
    def map_unordered(self, fn: Callable, items: Iterable) -> Iterator[tuple[object, object]]:
        """``(item, fn(item))`` for every item, in the order they finish; ``fn(item)`` is a :class:`TaskFailed`
        when the engine could not run it. ``fn`` must be a module-level function (pickled by reference)."""
        items = list(items)
        if not items:
            return iter(())
        if self._client is not None:
            return self._dask(fn, items)
        if self.jobs == 1:
            return ((item, _call(fn, item)) for item in items)
        return self._local(fn, items)

    def _local(self, fn, items) -> Iterator[tuple[object, object]]:
        from concurrent.futures import FIRST_COMPLETED, wait
        from concurrent.futures.process import BrokenProcessPool

        lost = [0] * len(items)
        todo = list(range(len(items)))
        window = WINDOW_PER_WORKER * self.jobs
        while todo:
            pool = self._pool or self._new_pool()
            running: dict = {}
            broken: list[int] = []
            try:
                while todo or running:
                    while todo and len(running) < window:
                        i = todo.pop(0)
                        try:
                            running[pool.submit(fn, items[i])] = i
                        except BrokenProcessPool:
                            broken.append(i)
                            break
                    if not running:
                        break
                    done, _ = wait(running, return_when=FIRST_COMPLETED)
                    for fut in done:
                        i = running.pop(fut)
                        try:
                            result = fut.result()
                        except BrokenProcessPool:
                            broken.append(i)
                            continue
                        except Exception as exc:  # the task function raised (a bug) or its result did not pickle
                            result = TaskFailed(_failure(exc))
                        self._finished += 1
                        yield items[i], result
                    if broken:
                        break
            except BaseException:
                self.close()
                raise
            if broken or running:
                broken += list(running.values())
                self._discard_pool()
                if not self._finished and max(lost) >= 1:
                    from ..errors import DataError

                    raise DataError("the local worker processes died before finishing any task; a script that "
                                    "runs a fleet must start it under `if __name__ == \"__main__\":` (the workers "
                                    "import the script), and each worker needs memory for one measurement")
                for i in sorted(set(broken)):
                    lost[i] += 1
                    if lost[i] >= MAX_LOST:
                        yield items[i], TaskFailed(f"its worker process died {lost[i]} times (crash or out of memory)")
                    else:
                        todo.append(i)

    def _new_pool(self):
        import multiprocessing
        from concurrent.futures import ProcessPoolExecutor

        if sys.platform.startswith("linux"):
            ctx = multiprocessing.get_context("forkserver")
            ctx.set_forkserver_preload(list(PRELOAD))
        else:  # pragma: no cover - macOS, Windows
            ctx = multiprocessing.get_context("spawn")
        self._pool = ProcessPoolExecutor(max_workers=self.jobs, mp_context=ctx, initializer=_init_worker,
                                         initargs=(os.getpid(),))
        return self._pool

    def _discard_pool(self) -> None:
        pool, self._pool = self._pool, None
        if pool is not None:
            pool.shutdown(wait=False, cancel_futures=True)

    def _dask(self, fn, items) -> Iterator[tuple[object, object]]:
        import uuid

        from distributed import as_completed

        client = self._client
        window = WINDOW_PER_WORKER * self.workers
        todo = list(range(len(items)))
        run = uuid.uuid4().hex[:12]
        pending: dict = {}  # future -> item index
        ac = as_completed(loop=client.loop)

        def submit() -> None:
            while todo and len(pending) < window:
                i = todo.pop(0)
                fut = client.submit(fn, items[i], key=f"feedtune-fleet-{run}-{i}", pure=False)
                pending[fut] = i
                ac.add(fut)

        submit()
        try:
            for fut in ac:
                i = pending.pop(fut)
                try:
                    result = fut.result()
                except Exception as exc:  # KilledWorker, a lost connection: this task, not the run
                    result = TaskFailed(f"the Dask cluster could not run it: {_failure(exc)}")
                fut.release()
                yield items[i], result
                submit()
        finally:
            if pending:
                client.cancel(list(pending))

    def close(self) -> None:
        """Stop the local workers; disconnect from the cluster."""
        self._discard_pool()
        client, self._client = self._client, None
        if client is not None:
            client.close()

    def __enter__(self) -> Engine:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def _dask_client(address: str):
    """A ``distributed.Client`` connected to ``address``; UsageError naming the option when it cannot be."""
    try:
        from distributed import Client
    except ImportError:
        raise UsageError("scheduler needs dask distributed: install it (pip install 'feedtune[fleet]')",
                         parameter="scheduler") from None
    try:
        return Client(address, set_as_default=False, timeout="10s")
    except (OSError, TimeoutError, ValueError) as exc:
        raise UsageError(f"scheduler {address}: cannot connect ({' '.join(str(exc).split())})",
                         parameter="scheduler") from None
