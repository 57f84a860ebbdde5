"""The bad-input corpus of tests/bad_input_corpus.py as a table: cases per command and their classes (clean,
internal error, traceback, accepted bad, unclear, wrong code, wrote, hang), by hand:

    python benchmarks/bad_input_corpus.py [--root SRC] [--slow] [--only PREFIX] [--show CLASS] [--json FILE]

``--root SRC`` runs the corpus against the feedtune sources in SRC (e.g. ``git archive`` of an older commit unpacked
there) instead of the installed ones, to measure before and after a change. The process runs under a 6 GiB
address-space limit (a MemoryError then comes early instead of the machine swapping), each case with a time limit
(``hang`` after 30 s). ``--slow`` adds the cases of the slow set; ``--show CLASS`` prints those cases' command lines
and what they printed. Exit 1 when a case is not clean.
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from collections import Counter, defaultdict
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def _use_sources(root: Path) -> None:
    """Import feedtune from ``root`` instead of the (editable) installation."""
    sys.meta_path[:] = [f for f in sys.meta_path if "editable" not in type(f).__module__.lower()
                        and "editable" not in getattr(f, "__name__", "").lower()]
    sys.path.insert(0, str(root))
    for name in [m for m in sys.modules if m == "feedtune" or m.startswith("feedtune.")]:
        del sys.modules[name]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--root", type=Path)
    parser.add_argument("--slow", action="store_true")
    parser.add_argument("--only")
    parser.add_argument("--show", action="append", default=[])
    parser.add_argument("--json", type=Path)
    parser.add_argument("--time-limit", type=float, default=30.0)
    a = parser.parse_args(argv)
    try:
        import resource

        resource.setrlimit(resource.RLIMIT_AS, (6 << 30, resource.getrlimit(resource.RLIMIT_AS)[1]))
    except (ImportError, ValueError, OSError):
        pass
    if a.root is not None:
        _use_sources(a.root.resolve())
    sys.path.insert(0, str(ROOT / "tests"))
    from bad_input_corpus import CLASSES, all_cases, build_fixtures, classify, run_case

    import feedtune

    print(f"feedtune from {Path(feedtune.__file__).parent}", flush=True)
    table: dict[str, Counter] = defaultdict(Counter)
    shown: list[str] = []
    records = []
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        fx = build_fixtures(Path(tmp) / "fx")
        cases = [c for c in all_cases() if (a.slow or not c.slow) and (not a.only or c.command.startswith(a.only))]
        for i, case in enumerate(cases):
            outcome = run_case(case, fx, Path(tmp) / "case", a.time_limit)
            cls = classify(case, outcome)
            table[case.command][cls] += 1
            records.append({"command": case.command, "args": case.args, "family": case.family, "class": cls,
                            "code": outcome.code, "expected": case.code, "stderr": outcome.err[-400:]})
            if cls in a.show:
                shown.append(f"[{cls}] feedtune {case.command} {case.args[:150]}\n    expected {case.code} "
                             f"{case.culprit!r}; got {outcome.code}: {(outcome.escaped or outcome.err).strip()[:300]}")
            if (i + 1) % 100 == 0:
                print(f"  {i + 1} cases, {time.perf_counter() - t0:.0f} s", file=sys.stderr, flush=True)
    width = max(len(c) for c in table) + 2
    head = f"{'command':{width}s}{'cases':>6s}" + "".join(f"{c:>10s}" for c in CLASSES)
    print(head)
    total: Counter = Counter()
    for command in sorted(table):
        row = table[command]
        total.update(row)
        print(f"{command:{width}s}{sum(row.values()):6d}" + "".join(f"{row[c]:10d}" for c in CLASSES))
    print(f"{'total':{width}s}{sum(total.values()):6d}" + "".join(f"{total[c]:10d}" for c in CLASSES))
    print(f"({time.perf_counter() - t0:.0f} s)")
    for line in shown:
        print(line)
    if a.json:
        a.json.write_text(json.dumps(records, indent=1))
    return 0 if total["clean"] == sum(total.values()) else 1


if __name__ == "__main__":
    sys.exit(main())
