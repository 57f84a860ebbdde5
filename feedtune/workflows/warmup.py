"""feedtune's compiled kernels built ahead: ``feedtune warmup``, or the first command that needs them.

The twins' closed loops, the gains files' laws, the CSV row formatter and the Kalman filter's pass are compiled by
numba on first use and kept in the kernel cache (:mod:`feedtune._kernel_cache`: one folder per version of the
sources). Compiling them costs seconds each (the gantry's closed loop 8-9 s of CPU); loading them from the cache a
fraction of a second. So that a user never meets that cost unexplained, in the middle of a step named for something
else, :func:`compile_kernels` builds every kernel at once, side by side on the machine's cores (forked processes),
as the step ``compiling kernels (first run only, ~N s)``, and then leaves a stamp in the cache folder
(:func:`stamp_path`); :func:`kernels_ready` reads it. ``feedtune warmup`` runs it (after ``pip install``, or in a
container's build), and so do the commands that run a twin (``demo``, ``simulate``) when the stamp is missing.

Each kernel is compiled by the smallest run of the code that uses it, with the argument types a real run passes
(numba compiles one machine-code version per argument types): a 64-sample run of each twin with the controllers the
demos use (gains-file runtimes; the gantry also with its holding controllers), one CSV row, one Kalman pass.
"""

from __future__ import annotations

import json
import os
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

STAMP_NAME = "feedtune-kernels.json"
"""The stamp :func:`compile_kernels` leaves in the kernel cache folder."""

RUN_SAMPLES = 64
"""Samples of the twins' runs that compile their loops."""


def _ballscrew_twin() -> None:
    """The ball-screw twin's closed loop with a gains-file runtime (the law inlined), and the runtime's own step."""
    from ..machines.ballscrew.experiments import weak_controller
    from ..machines.ballscrew.twin import BallScrewTwin

    twin = BallScrewTwin()
    runtime = weak_controller(twin)
    twin.simulate(runtime, np.zeros(RUN_SAMPLES))
    runtime.reset()
    runtime.step(0.0, 0.0, 0.0)


def _gantry_runtimes():
    """A MIMO and an x-axis runtime read back from their gains documents (as the demo and ``simulate`` run them)."""
    from ..design.gantry_mimo import design_gantry_mimo
    from ..design.loopshape import design_loopshape
    from ..io.document import loads_document
    from ..machines import load_runtime
    from ..models.gantry import THESIS_GANTRY
    from .deliver import deliver

    mimo = design_gantry_mimo(THESIS_GANTRY, crossover_hz=60, pm_deg=40, damping_increase=5.9)
    axis = design_loopshape(THESIS_GANTRY, crossover_hz=130, pm_deg=35)
    out = []
    for name, design in (("mimo", mimo), ("axis", axis)):
        text = deliver(design, (), where=f"{name} (warm-up)").texts(name)[f"{name}.toml"]
        out.append(load_runtime(loads_document(text, "toml", name), name))
    return out


def _gantry_twin() -> None:
    """The gantry twin's closed loop with gains-file runtimes (their laws inlined) and the runtimes' own steps."""
    from ..machines.gantry.twin import GantryTwin

    gantry, axis = _gantry_runtimes()
    GantryTwin().simulate(gantry, axis, np.zeros(RUN_SAMPLES))
    for runtime, args in ((gantry, (0.0, 0.0, 0.0, 0.0)), (axis, (0.0, 0.0))):
        runtime.reset()
        runtime.step(*args)


def _gantry_holding() -> None:
    """The gantry twin's closed loop with the holding controllers of its FRF and mass runs."""
    from ..machines.gantry.experiments import AxisHoldingController, HoldingController
    from ..machines.gantry.twin import GantryTwin

    twin = GantryTwin()
    twin.simulate(HoldingController.for_twin(twin), AxisHoldingController.for_twin(twin), np.zeros(RUN_SAMPLES))


def _csv_rows() -> None:
    """The CSV writer's row formatter."""
    from ..io.csv_text import format_float_rows

    format_float_rows(np.zeros((2, 3)))


def _kalman() -> None:
    """The Kalman filter's compiled pass (friction identification)."""
    from ..identify.kalman import _filter_pass

    _filter_pass()(np.eye(3), np.zeros((3, 2)), np.zeros(4), np.zeros(4), np.empty((3, 4)))


KERNELS: dict[str, tuple[Callable[[], None], float]] = {
    "gantry twin (gains files)": (_gantry_twin, 9.0),
    "gantry twin (holding controllers)": (_gantry_holding, 6.0),
    "ball-screw twin": (_ballscrew_twin, 6.0),
    "CSV writer": (_csv_rows, 4.0),
    "Kalman filter": (_kalman, 0.8),
}
"""``{name: (compile function, CPU seconds to compile it)}``, the costliest first (the seconds measured on a 2-core
machine of 2026; they only estimate the step's duration)."""

MODULES: dict[str, tuple[str, ...]] = {
    "gantry twin (gains files)": ("feedtune.machines.gantry.twin", "feedtune.machines", "feedtune.design.gantry_mimo",
                                  "feedtune.design.loopshape", "feedtune.workflows.deliver"),
    "gantry twin (holding controllers)": ("feedtune.machines.gantry.twin", "feedtune.machines.gantry.experiments"),
    "ball-screw twin": ("feedtune.machines.ballscrew.twin", "feedtune.machines.ballscrew.experiments"),
    "CSV writer": ("numba", "feedtune.io.csv_text"),
    "Kalman filter": ("numba", "feedtune.identify.kalman"),
}
"""The modules each kernel's compile imports (numba and the libraries under them): :func:`compile_kernels` imports
them before it forks its workers, so that the workers inherit them instead of importing them each (the command that
compiles the kernels goes on to use them: nothing is imported twice)."""


def stamp_path() -> Path:
    """The stamp in the kernel cache folder in use (``NUMBA_CACHE_DIR``, prepared when numba is first imported)."""
    import numba  # (feedtune prepares the cache folder and sets NUMBA_CACHE_DIR as numba is imported)

    return Path(os.environ.get("NUMBA_CACHE_DIR") or numba.config.CACHE_DIR) / STAMP_NAME


MACHINE_KERNELS = {
    "ballscrew": ("ball-screw twin", "CSV writer"),
    "gantry": ("gantry twin (gains files)", "gantry twin (holding controllers)", "CSV writer"),
}
"""The kernels a machine's twin runs (its closed loops, and the CSV writer of its logs)."""

BACKGROUND_KERNELS = ("CSV writer", "gantry twin (gains files)")
"""Kernels a first run need not wait for before it starts (:func:`ensure_kernels` with ``background``): they
compile in a worker process beside the run's own work, and their first use waits for them there and loads them from
the cache (:func:`feedtune.io.csv_text.set_kernel_pending`: the CSV writer, first used once the FRF is measured;
:func:`feedtune.machines.gantry.twin.set_kernel_pending`: the gantry twin's loop with gains-file runtimes, first
run after the measurements and the tuning)."""


def _hook(name: str) -> Callable | None:
    """How the users of a background kernel learn of its compile (a function taking its future, or None when it
    is done): :data:`BACKGROUND_KERNELS`."""
    if name == "CSV writer":
        from ..io.csv_text import set_kernel_pending

        return set_kernel_pending
    if name == "gantry twin (gains files)":
        from ..machines.gantry.twin import set_kernel_pending as gantry_pending

        return gantry_pending
    return None


def _stamp() -> dict:
    try:
        stamp = json.loads(stamp_path().read_text())
    except (OSError, ValueError):
        return {}
    return stamp if isinstance(stamp, dict) and isinstance(stamp.get("kernels"), dict) else {}


def kernels_ready(names=None) -> bool:
    """True when :func:`compile_kernels` has built the kernels ``names`` (default: all of :data:`KERNELS`) into the
    cache folder in use."""
    return set(KERNELS if names is None else names) <= set(_stamp().get("kernels", {}))


def estimate_s(names=None, processes: int | None = None) -> float:
    """Wall time [s] :func:`compile_kernels` is expected to take for ``names`` on ``processes`` cores (default: those
    usable)."""
    from ..parallel import usable_cores

    names = list(KERNELS if names is None else names)
    n = max(1, min(usable_cores() if processes is None else processes, len(names)))
    loads = [0.0] * n
    for c in sorted((KERNELS[k][1] for k in names), reverse=True):
        loads[loads.index(min(loads))] += c
    return max(loads) + 1.0  # the workers' start


def compile_kernels(names=None, processes: int | None = None) -> dict[str, float]:
    """Compile the kernels ``names`` (default: every one of :data:`KERNELS`) into the kernel cache, side by side on
    ``processes`` processes (default: the usable cores, :func:`feedtune.parallel.usable_cores`), and record them in
    the stamp.

    Returns
    -------
    dict
        ``{kernel: seconds}`` of wall time each took (loading it from the cache when it was there already).
    """
    from .. import progress
    from ..errors import UsageError

    names = list(KERNELS if names is None else names)
    unknown = [k for k in names if k not in KERNELS]
    if unknown:
        raise UsageError(f"unknown kernels {unknown}; known: {', '.join(KERNELS)}")
    names.sort(key=lambda k: -KERNELS[k][1])  # the costliest first: the last one taken decides the end

    label = f"compiling kernels (first run only, ~{estimate_s(names, processes):.0f} s)"
    with progress.task(label, total=len(names)) as advance:
        seconds = _compile_in_workers(names, processes, advance)
    _write_stamp(seconds)
    return seconds


def _preload(names) -> None:
    """Import the modules of the kernels ``names`` (:data:`MODULES`) here, before the workers are forked: they
    inherit them instead of importing them each."""
    import importlib

    for module in dict.fromkeys(m for k in names for m in MODULES.get(k, ())):
        importlib.import_module(module)


def _compile_one(name: str) -> float:
    """Compile one kernel (in a worker process, silently); its wall time [s]."""
    from .. import progress

    t0 = time.perf_counter()
    with progress.reporting(None):
        KERNELS[name][0]()
    return time.perf_counter() - t0


def _compile_in_workers(names: list[str], processes: int | None, advance) -> dict[str, float]:
    """``{kernel: seconds}``: every kernel compiled in worker processes (this one stays free to show the progress:
    numba holds the interpreter while it compiles), ``advance()`` called as each ends."""
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor, as_completed

    from ..parallel import usable_cores

    n = max(1, min(usable_cores() if processes is None else processes, len(names)))
    methods = multiprocessing.get_all_start_methods()
    if "fork" in methods:
        _preload(names)
    context = multiprocessing.get_context("fork" if "fork" in methods else None)
    seconds = {}
    pool = ProcessPoolExecutor(n, mp_context=context, initializer=_worker_signals)
    try:
        futures = {pool.submit(_compile_one, k): k for k in names}
        for done in as_completed(futures):
            seconds[futures[done]] = done.result()
            advance()
    finally:  # interrupted: the workers (ended by the same signal) are not waited for
        pool.shutdown(wait=not (len(seconds) < len(names)), cancel_futures=True)
    return {k: seconds[k] for k in names}


def _worker_signals() -> None:
    """A worker ends at once on SIGINT or SIGTERM (the command line's own handlers are the caller's)."""
    import signal

    signal.signal(signal.SIGINT, signal.SIG_DFL)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)


def ensure_kernels(names=None, processes: int | None = None, *, background: bool = False):
    """:func:`compile_kernels` of those of ``names`` (default: all) not built yet (None when none is missing): what a
    command that runs a twin calls first, so that the compile is its own step, on every core, and never hidden in a
    step named for something else.

    With ``background``, the kernels of :data:`BACKGROUND_KERNELS` among them compile in a worker process while
    the caller goes on (their first use waits for them and loads them from the cache), and a lone kernel left to
    wait for compiles in this process (no worker to start, nothing to load from the cache after);
    the caller must :meth:`Background.wait` for the returned handle at its end. Returns ``{kernel: seconds}`` of the
    kernels waited for (None when none was missing), or with ``background`` the :class:`Background` handle (None
    when nothing compiles behind)."""
    missing = [k for k in (KERNELS if names is None else names) if not kernels_ready([k])]
    if not background:
        return compile_kernels(missing, processes) if missing else None
    behind = [k for k in missing if k in BACKGROUND_KERNELS and _hook(k) is not None]
    now = [k for k in missing if k not in behind]
    handle = Background.start(behind) if behind else None
    if len(now) == 1:
        _compile_here(now[0])
    elif now:
        compile_kernels(now, processes)
    return handle


def _compile_here(name: str) -> float:
    """Compile one kernel in this process, as the step ``compiling kernels``, and stamp it; its wall time [s]."""
    from .. import progress

    t0 = time.perf_counter()
    with progress.task(f"compiling kernels (first run only, ~{KERNELS[name][1] / 2:.0f} s)", total=1) as advance:
        with progress.reporting(None):
            KERNELS[name][0]()
        advance()
    seconds = time.perf_counter() - t0
    _write_stamp({name: seconds})
    return seconds


def _write_stamp(seconds: dict[str, float]) -> None:
    """Add ``{kernel: seconds}`` to the stamp in the cache folder (atomically replaced)."""
    stamp = stamp_path()
    doc = _stamp()
    doc["kernels"] = {**doc.get("kernels", {}), **{k: round(v, 3) for k, v in seconds.items()}}
    doc["created"] = time.strftime("%Y-%m-%dT%H:%M:%S")
    tmp = stamp.with_name(f"{stamp.name}.{os.getpid()}.tmp")
    tmp.write_text(json.dumps(doc, indent=1))
    os.replace(tmp, stamp)


class Background:
    """Kernels compiling in worker processes while this one goes on (:func:`ensure_kernels` with ``background``):
    their first use waits for them (:data:`BACKGROUND_KERNELS`)."""

    def __init__(self, pool, futures: dict) -> None:
        self._pool, self._futures = pool, futures

    @classmethod
    def start(cls, names: list[str]) -> Background:
        """Start compiling ``names`` in one worker process each (forked: the modules are inherited)."""
        import multiprocessing
        from concurrent.futures import ProcessPoolExecutor

        methods = multiprocessing.get_all_start_methods()
        context = multiprocessing.get_context("fork" if "fork" in methods else None)
        _preload(names)
        pool = ProcessPoolExecutor(len(names), mp_context=context, initializer=_worker_signals)
        futures = {k: pool.submit(_compile_one, k) for k in names}
        for k, f in futures.items():
            _hook(k)(f)
        return cls(pool, futures)

    def wait(self) -> tuple[dict[str, float], list[str]]:
        """Wait for every kernel (at the caller's end) and stamp those compiled: ``({kernel: seconds}, failures)``,
        one line per kernel whose worker failed (its users compiled it themselves; the caller's work stands)."""
        seconds, failed = {}, []
        try:
            for k, f in self._futures.items():
                try:
                    seconds[k] = f.result()
                except Exception as exc:  # a worker killed or failing: nothing the caller made depends on it
                    failed.append(f"the background compile of kernel {k} failed ({type(exc).__name__}: {exc}); "
                                  "it was compiled where it was used")
        finally:
            for k in self._futures:
                _hook(k)(None)
            self._pool.shutdown(wait=True, cancel_futures=True)
        if seconds:
            _write_stamp(seconds)
        return seconds, failed

    def cancel(self) -> None:
        """Stop waiting (the caller failed or was interrupted): the workers are not waited for."""
        for k in self._futures:
            _hook(k)(None)
        self._pool.shutdown(wait=False, cancel_futures=True)
