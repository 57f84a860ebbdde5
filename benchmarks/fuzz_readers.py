"""The long fuzz run of every reader and document loader (issue 14), by hand:
``python benchmarks/fuzz_readers.py [EXAMPLES [READER]]`` (default 3000 per reader; MDF logs take ~0.5 s each:
every MDF read starts a crash probe in a child process; ``long``: the counts of the slow test,
tests/test_fuzz_readers.py's ``long_examples``: ``FEEDTUNE_FUZZ_SECONDS`` of CPU over all readers, default 90 s).

Byte-level mutations of a valid file of each format (tests/fuzz_inputs.py) must be read or refused with feedtune's
own error. Prints, per reader, the examples run, how many were read, refused and crashed, the distinct crash
signatures and the time per example, and exits 1 when anything crashed. A crash of a C extension ends the process
(exit 139): scipy's MAT v5 reader did on corrupted compressed variables (feedtune now walks the file's elements
first) and asammdf does on corrupt MDF4 files (feedtune now reads them once in a child process first).
"""

from __future__ import annotations

import random
import sys
import tempfile
import time
import warnings
from collections import Counter
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))


def main(examples: int = 3000, only: str | None = None) -> int:
    from fuzz_inputs import mutate, readers
    from test_fuzz_readers import long_examples

    from feedtune.errors import FeedtuneError

    crashed_total, total_examples, total_kinds = 0, 0, Counter()
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        for name, (suffix, valid, read) in readers(ROOT / "examples", tmp).items():
            if only and name != only:
                continue
            n = long_examples(name) if examples < 0 else examples
            counts, crashes, kinds = Counter(), Counter(), Counter()
            path = tmp / f"case{suffix}"
            t0 = time.perf_counter()
            for seed in range(n):
                path.write_bytes(mutate(valid, random.Random(seed)))
                try:
                    with warnings.catch_warnings():
                        warnings.simplefilter("ignore")
                        read(path)
                    counts["read"] += 1
                except FeedtuneError as exc:
                    counts["refused"] += 1
                    kinds[type(exc).__name__] += 1
                except Exception as exc:  # a crash of our code
                    counts["crashed"] += 1
                    kinds[type(exc).__name__] += 1
                    crashes[f"{type(exc).__name__}: {str(exc)[:80]}"] += 1
            dt = (time.perf_counter() - t0) / n
            crashed_total += counts["crashed"]
            print(f"{name:15s} {n:6d} examples: {counts['read']:5d} read, {counts['refused']:5d} refused, "
                  f"{counts['crashed']:3d} crashed ({1e3 * dt:.1f} ms each); exceptions: "
                  + ", ".join(f"{k} {v}" for k, v in kinds.most_common()), flush=True)
            for k, v in kinds.items():
                total_kinds[k] += v
            total_examples += n
            for sig, k in crashes.most_common(10):
                print(f"    {k:4d} x {sig}")
    print(f"total {total_examples} examples; exceptions: "
          + ", ".join(f"{k} {v}" for k, v in total_kinds.most_common()))
    return 1 if crashed_total else 0


if __name__ == "__main__":
    count = sys.argv[1] if len(sys.argv) > 1 else "3000"
    sys.exit(main(-1 if count == "long" else int(count), sys.argv[2] if len(sys.argv) > 2 else None))
