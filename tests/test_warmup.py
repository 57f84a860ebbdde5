"""The kernels compiled ahead (feedtune.workflows.warmup, ``feedtune warmup``): into the cache folder in use, recorded
in its stamp, loaded (not compiled again) by a later process."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

SCRIPT = """
import json, sys, time
from feedtune.workflows.warmup import ensure_kernels, kernels_ready, stamp_path
before = kernels_ready(["Kalman filter"])
first = ensure_kernels(["Kalman filter"], processes=1)
again = ensure_kernels(["Kalman filter"], processes=1)
print(json.dumps({"before": before, "first": first, "again": again, "ready": kernels_ready(["Kalman filter"]),
                  "all_ready": kernels_ready(), "stamp": str(stamp_path())}))
"""


def _run(cache: Path, code: str, **env_extra: str) -> dict:
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_CACHE_DIR"} | {"XDG_CACHE_HOME": str(cache)} | env_extra
    res = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=300)
    assert res.returncode == 0, res.stderr[-2000:]
    return json.loads(res.stdout.strip().splitlines()[-1]) | {"output": res.stdout + res.stderr}


@pytest.mark.slow  # two fresh interpreters and a compile: ~4 s on an idle 2-core machine
def test_ensure_kernels_compiles_once_into_a_fresh_cache_and_a_new_process_loads_it(tmp_path):
    out = _run(tmp_path, SCRIPT)
    assert out["before"] is False and out["ready"] is True and out["all_ready"] is False
    assert set(out["first"]) == {"Kalman filter"} and out["first"]["Kalman filter"] > 0
    assert out["again"] is None  # built already: nothing to do
    stamp = Path(out["stamp"])
    assert stamp.parent.is_relative_to(tmp_path / "feedtune" / "numba")  # the fresh cache folder, not the user's
    assert "Kalman filter" in json.loads(stamp.read_text())["kernels"]
    assert any(stamp.parent.rglob("*.nbi")), "numba wrote no cache index"
    # a new process finds it built and loads the machine code from the cache instead of compiling it (numba says
    # which: its cache debug lines; a time ratio is no proof for a kernel this small, whose load costs numba's own
    # start-up of some 0.4 s, comparable to its compile)
    loaded = _run(tmp_path, "import json\nfrom feedtune.workflows.warmup import _kalman, kernels_ready\n_kalman()\n"
                            "print(json.dumps({'ready': kernels_ready(['Kalman filter'])}))", NUMBA_DEBUG_CACHE="1")
    assert loaded["ready"] is True
    assert "[cache] data loaded from" in loaded["output"] and "[cache] data saved to" not in loaded["output"], loaded


def test_unknown_kernel_is_a_usage_error():
    from feedtune.errors import UsageError
    from feedtune.workflows.warmup import compile_kernels

    with pytest.raises(UsageError, match="unknown kernels"):
        compile_kernels(["no such kernel"])


BACKGROUND_SCRIPT = """
import json
import numpy as np
from feedtune.io import csv_text
from feedtune.workflows.warmup import ensure_kernels, kernels_ready
rng = np.random.default_rng(1)
columns = [rng.standard_normal(20000) * 10.0 ** rng.integers(-12, 12, 20000) for _ in range(3)]
import numba  # loaded, as in a demo: a table of 60000 cells takes the compiled kernel
handle = ensure_kernels(["CSV writer"], background=True)
pending = csv_text._PENDING.pending()
text = csv_text.csv_rows(columns)  # waits for the worker, then loads its kernel from the cache
seconds, failed = handle.wait()
print(json.dumps({"pending": pending, "repr": text.splitlines()[5] == ",".join(repr(float(c[5])) for c in columns),
                  "rows": len(text.splitlines()), "ready": kernels_ready(["CSV writer"]), "seconds": seconds,
                  "signatures": len(csv_text._row_kernel().signatures), "failed": failed}))
"""


@pytest.mark.slow  # the CSV writer's compile in a worker: ~2-4 s
def test_a_background_kernel_compiles_in_a_worker_and_its_first_use_loads_it_from_the_cache(tmp_path):
    out = _run(tmp_path, BACKGROUND_SCRIPT, NUMBA_DEBUG_CACHE="1")
    assert out["pending"] is True  # the worker compiles it while this process goes on
    assert out["repr"] and out["rows"] == 20000  # Python's repr of every number
    assert out["ready"] is True and set(out["seconds"]) == {"CSV writer"} and out["signatures"] == 1
    assert out["failed"] == []
    # this process did not compile the kernel a second time: it loaded the worker's from the cache
    assert "[cache] data loaded from" in out["output"], out["output"][-2000:]
    assert out["output"].count("[cache] data saved to") == 1  # the worker's save only


def test_a_forked_child_does_not_wait_for_its_parents_background_compile():
    """A forked worker (the demo's twin tests, a CSV writer in a child) holds a copy of the parent's pending future
    that nothing ends: its wait returns at once (it loads or compiles the kernel itself), the parent still waits."""
    import multiprocessing as mp
    from concurrent.futures import Future

    from feedtune._kernel_cache import PendingKernel

    pending = PendingKernel()
    never = Future()
    pending.set(never)
    child = mp.get_context("fork").Process(target=pending.wait)
    child.start()
    child.join(timeout=20)
    alive = child.is_alive()
    if alive:
        child.kill()
    assert not alive and child.exitcode == 0
    assert pending.pending()  # the parent's own future is still pending
