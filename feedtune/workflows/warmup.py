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


def stamp_path() -> Path:
    """The stamp in the kernel cache folder in use (``NUMBA_CACHE_DIR``, prepared when numba is first imported)."""
    import numba  # (feedtune prepares the cache folder and sets NUMBA_CACHE_DIR as numba is imported)

    return Path(os.environ.get("NUMBA_CACHE_DIR") or numba.config.CACHE_DIR) / STAMP_NAME


MACHINE_KERNELS = {
    "ballscrew": ("ball-screw twin", "CSV writer"),
    "gantry": ("gantry twin (gains files)", "gantry twin (holding controllers)", "CSV writer"),
}
"""The kernels a machine's twin runs (its closed loops, and the CSV writer of its logs)."""


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
    stamp = stamp_path()
    doc = _stamp()
    doc["kernels"] = {**doc.get("kernels", {}), **{k: round(v, 3) for k, v in seconds.items()}}
    doc["created"] = time.strftime("%Y-%m-%dT%H:%M:%S")
    tmp = stamp.with_name(f"{stamp.name}.{os.getpid()}.tmp")
    tmp.write_text(json.dumps(doc, indent=1))
    os.replace(tmp, stamp)
    return seconds


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


def ensure_kernels(names=None, processes: int | None = None) -> dict[str, float] | None:
    """:func:`compile_kernels` of those of ``names`` (default: all) not built yet (None when none is missing): what a
    command that runs a twin calls first, so that the compile is its own step, on every core, and never hidden in a
    step named for something else."""
    missing = [k for k in (KERNELS if names is None else names) if not kernels_ready([k])]
    return compile_kernels(missing, processes) if missing else None
