"""CSV log writing and reading speed and peak memory (issue 11).

Run by hand: ``python benchmarks/bench_io.py [--rows N] [--runs N]``. A twin-like log (time and 7 signals of
full-precision doubles, default 1.2 M rows, about 190 MB) is written with ``feedtune.io.write_log_csv`` and read back
with ``feedtune.io.read_log``. Anchors measured in the same run: writing the same bytes with one ``write`` call, the
``DataFrame.to_csv`` the writer replaced and ``np.savetxt``; reading the same file with ``pandas.read_csv`` (C
engine). Each read runs in a fresh process, feedtune's and pandas' runs alternating (a machine whose load changes
during the run slows both alike); the best time of each is compared. Peak memory is the growth of the peak resident
set over the process' size after the imports, printed as a multiple of the file size. Targets (issue 11): writing at
>= 50 MB/s, reading in no more time than ``pandas.read_csv`` with at most 2x the file size of memory.
"""

from __future__ import annotations

import argparse
import os
import resource
import subprocess
import sys
import tempfile

import numpy as np
from timing import best_of


def _log(rows: int):
    from feedtune.log import Log

    rng = np.random.default_rng(0)
    t = np.arange(rows) / 20000.0
    names = ["x1", "x2", "u", "r", "e", "v1", "v2"]
    scales = [1e-2, 1e-2, 3.0, 1e-2, 1e-6, 0.5, 0.5]
    sig = {n: np.cumsum(rng.normal(size=rows)) * s * 1e-3 for n, s in zip(names, scales, strict=True)}
    return Log(t, sig, {n: "rad" for n in names}, {"source": "bench"})


READER = r"""
import sys, time
import numpy as np, pandas as pd
from feedtune.io import read_log

def hwm():
    # peak resident set of this process [bytes] (VmHWM starts afresh at exec, unlike ru_maxrss)
    for line in open("/proc/self/status"):
        if line.startswith("VmHWM:"):
            return int(line.split()[1]) * 1024

path, how = sys.argv[1], sys.argv[2]
base = hwm()
t0 = time.perf_counter()
if how == "feedtune":
    log = read_log(path)
else:
    df = pd.read_csv(path, comment="#", engine="c")
dt = time.perf_counter() - t0
print(dt, hwm() - base)
"""


def _read_once(path: str, how: str) -> tuple[float, float]:
    """Time [s] and peak memory growth [bytes] of one read in a fresh process."""
    run = subprocess.run([sys.executable, "-c", READER, path, how], capture_output=True, text=True, check=True)
    dt, mem = map(float, run.stdout.split())
    return dt, mem


def _read(path: str, runs: int) -> dict[str, tuple[float, float]]:
    """Best time and least peak memory of ``runs`` reads each by feedtune and pandas, alternating."""
    vals: dict[str, list[tuple[float, float]]] = {"feedtune": [], "pandas": []}
    for _ in range(runs):
        for how in vals:
            vals[how].append(_read_once(path, how))
    return {how: (min(v[0] for v in rs), min(v[1] for v in rs)) for how, rs in vals.items()}


def main() -> None:
    import pandas as pd

    from feedtune.io import write_log_csv
    from feedtune.io.log_csv import log_to_csv_text

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rows", type=int, default=1_200_000)
    ap.add_argument("--runs", type=int, default=3, help="timed runs of each write and read (the best counts)")
    args = ap.parse_args()
    log = _log(args.rows)
    with tempfile.TemporaryDirectory() as d:
        path = os.path.join(d, "log.csv")
        text = log_to_csv_text(log)
        data = text.encode()
        mb = len(data) / 1e6

        def write_feedtune():
            write_log_csv(log, path, force=True)

        def write_raw():
            with open(os.path.join(d, "raw.csv"), "wb") as fh:
                fh.write(data)

        frame = pd.DataFrame({"t": log.t, **log.signals})
        t_ft = best_of(write_feedtune, args.runs)
        with open(path, "rb") as fh:
            same = fh.read() == data
        t_raw = best_of(write_raw, args.runs)
        t_pd = best_of(lambda: frame.to_csv(os.path.join(d, "pd.csv"), index=False, lineterminator="\n"), 1)
        t_np = best_of(lambda: np.savetxt(os.path.join(d, "np.csv"), frame.to_numpy(), delimiter=",", fmt="%.17g"), 1)
        print(f"log: {args.rows} rows x {1 + len(log.signals)} columns, {mb:.1f} MB of CSV; written file "
              f"{'identical to' if same else 'DIFFERENT FROM'} log_to_csv_text")
        print(f"write: feedtune {mb / t_ft:.1f} MB/s ({t_ft:.2f} s); anchors: one write() {mb / t_raw:.0f} MB/s, "
              f"DataFrame.to_csv {mb / t_pd:.1f} MB/s (x{t_pd / t_ft:.2f} slower than feedtune), np.savetxt %.17g "
              f"{mb / t_np:.1f} MB/s (x{t_np / t_ft:.2f})")
        reads = _read(path, args.runs)
        (r_ft, m_ft), (r_pd, m_pd) = reads["feedtune"], reads["pandas"]
        size = len(data)
        print(f"read: feedtune {mb / r_ft:.0f} MB/s ({r_ft:.2f} s), pandas.read_csv C engine {mb / r_pd:.0f} MB/s "
              f"({r_pd:.2f} s): feedtune/pandas time {r_ft / r_pd:.2f}")
        print(f"read peak memory over the process after imports: feedtune {m_ft / size:.2f} x the file size, "
              f"pandas {m_pd / size:.2f} x")
    print(f"(max RSS of this process {resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024:.0f} MB)")


if __name__ == "__main__":
    main()
