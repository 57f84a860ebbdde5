"""Resources bounded before they are spent, documents bounded before they are parsed, outputs that cannot be lost,
and interruption at any moment (issue 26).

* the memory budget (feedtune.budget): its setting, and a memory cap in a child process under which every
  budget case of the corpus is refused cleanly (nothing allocates more than its budget);
* document limits (feedtune.io.document_limits) and schema versions: nesting, digits, size, newer minor versions
  read with a note, other majors refused;
* outputs (feedtune.io.atomic): two writers of one file, one wins and the other fails cleanly; a name another process
  takes meanwhile is not replaced; --force never replaces a FIFO or a device; a full disk is named (ENOSPC);
* SIGINT in the first 0.4 s of a command: exit 130, ``feedtune: interrupted``, no traceback.
"""

from __future__ import annotations

import errno
import json
import multiprocessing
import os
import signal
import subprocess
import sys
import time
import warnings
from pathlib import Path

import pytest

from feedtune.budget import check_memory, memory_budget, parse_size
from feedtune.errors import DataError, FeedtuneNote, UsageError
from feedtune.io.atomic import atomic_output, atomic_write_text, ensure_writable, staged_folder
from feedtune.io.document import loads_document, read_document, require_schema


# ------------------------------------------------------------------------------------------ budget
def test_the_budget_is_set_by_the_environment(monkeypatch):
    monkeypatch.setenv("FEEDTUNE_MEMORY_BUDGET", "512M")
    assert memory_budget() == 512 << 20
    check_memory(500 << 20, "a table")
    with pytest.raises(UsageError, match=r"periods=9 .* would take 1 GiB of memory, more than the memory budget of "
                                         r"512 MiB \(FEEDTUNE_MEMORY_BUDGET"):
        check_memory(1 << 30, "periods=9 of a run", parameter="periods")
    with pytest.raises(DataError, match=r"big\.csv"):
        check_memory(1 << 30, "reading big.csv (1 GiB)", file="big.csv")
    monkeypatch.setenv("FEEDTUNE_MEMORY_BUDGET", "lots")
    with pytest.raises(UsageError, match="FEEDTUNE_MEMORY_BUDGET expects a size such as 800M"):
        memory_budget()
    assert parse_size("25%") > 0 and parse_size("2GiB") == 2 << 30


def test_the_budget_never_exceeds_what_the_address_space_limit_leaves():
    code = ("import resource, feedtune.budget as b\n"
            "resource.setrlimit(resource.RLIMIT_AS, (4 << 30, resource.RLIM_INFINITY))\n"
            "print(b.memory_budget())")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert 0 < int(out) < 0.8 * (4 << 30)


CAP_CHILD = r"""
import resource, sys, tempfile
from pathlib import Path
sys.path.insert(0, sys.argv[1])
from bad_input_corpus import all_cases, build_fixtures, classify, describe, run_case
tmp = Path(tempfile.mkdtemp())
fx = build_fixtures(tmp / "fx")
cases = [c for c in all_cases() if c.family in ("budget", "size", "nesting", "big number") and not c.slow]
run_case(cases[0], fx, tmp / "warm")  # the command line's imports before the cap
with open("/proc/self/statm") as fh:
    mapped = int(fh.read().split()[0]) * resource.getpagesize()
resource.setrlimit(resource.RLIMIT_AS, (mapped + (768 << 20), resource.RLIM_INFINITY))
bad = []
for case in cases:
    outcome = run_case(case, fx, tmp / "case")
    if classify(case, outcome) != "clean":
        bad.append(describe(case, outcome))
print(len(cases), "cases")
for b in bad:
    print("NOT CLEAN", b)
"""


@pytest.mark.slow
def test_no_input_allocates_more_than_its_budget_under_a_memory_cap(tmp_path):
    """Each budget case (sizes from options, files by their size, MAT variables by their declared shape, nesting and
    digits of documents) run under an address-space cap of 768 MiB above the process' size, with a budget of 256 MiB:
    every one is refused by name before it allocates (an allocation past the cap would be a MemoryError, an internal
    error or a different message)."""
    env = {**os.environ, "FEEDTUNE_MEMORY_BUDGET": "256M"}
    res = subprocess.run([sys.executable, "-c", CAP_CHILD, str(Path(__file__).parent)], capture_output=True,
                         text=True, env=env, timeout=600)
    assert res.returncode == 0, res.stderr[-2000:]
    assert "NOT CLEAN" not in res.stdout, res.stdout
    assert int(res.stdout.split()[0]) >= 30


# ------------------------------------------------------------------------------------------ documents
@pytest.mark.parametrize("text, fmt, words", [
    ('{"a": ' + "[" * 100 + "]" * 100 + "}", "json", "nested more than 64 deep"),
    ("a = " + "[" * 100 + "]" * 100, "toml", "line 1: arrays or tables nested more than 64 deep"),
    ("a = " + "{b = " * 100 + "1" + "}" * 100, "toml", "nested more than 64 deep"),
    ("[" + ".".join(["t"] * 100) + "]\nb = 1\n", "toml", "a key of more than 64 dotted parts"),
    ('{"schema": "x", "m1": {"value": ' + "9" * 5001 + "}}", "json", "m1.value: integer with 5001 digits"),
    ("x = 1\nm1 = " + "9" * 400 + "\n", "toml", "line 2: m1: number with 400 digits"),
    ('{"a": [' + "1," * 300_000 + "1]}", "json", "300,000 values or more"),
])
def test_documents_beyond_the_limits_are_refused_before_parsing(text, fmt, words):
    with pytest.raises(DataError, match=words):
        loads_document(text, fmt, "d." + fmt)


def test_a_huge_document_is_not_read(tmp_path):
    big = tmp_path / "big.toml"
    with open(big, "wb") as fh:
        fh.truncate(1 << 30)
    t0 = time.perf_counter()
    with pytest.raises(DataError, match=r"big\.toml: 1 GiB, more than the 4 MiB a feedtune document"):
        read_document(big)
    assert time.perf_counter() - t0 < 1.0


def test_schema_versions(capsys, monkeypatch, tmp_path):
    with warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always")
        assert require_schema({"schema": "feedtune.model/1.2"}, "feedtune.model", "n.toml",
                              written="feedtune.model/1.1") == (1, 2)
        assert require_schema({"schema": "feedtune.model/1.1"}, "feedtune.model", "o.toml",
                              written="feedtune.model/1.1") == (1, 1)
    assert [issubclass(w.category, FeedtuneNote) for w in seen] == [True]
    assert "n.toml: feedtune.model/1.2 comes from a newer feedtune (this one writes feedtune.model/1.1)" in \
        str(seen[0].message)
    for schema in ("feedtune.model/0.9", "feedtune.model/2"):
        with pytest.raises(DataError, match=r"comes from an? (older|newer) feedtune"):
            require_schema({"schema": schema}, "feedtune.model", "m.toml")
    # the command line reads a gantry model of a newer minor version, with one note line
    from cli_run import run

    from feedtune.io import save_model
    from feedtune.models.gantry import THESIS_GANTRY

    save_model(tmp_path / "g.toml", THESIS_GANTRY)
    doc = json.loads((tmp_path / "g.json").read_text())
    doc["schema"], doc["notes"] = "feedtune.model/1.2", {"new": "an entry this feedtune does not know"}
    (tmp_path / "g12.json").write_text(json.dumps(doc))
    code, _, err = run(["design", "gantry", tmp_path / "g12.json", "--json"], capsys, monkeypatch)
    assert code == 0, err
    notes = [line for line in err.splitlines() if line.startswith("feedtune: note: ")]
    assert len(notes) == 1 and "feedtune.model/1.2 comes from a newer feedtune" in notes[0]


# ------------------------------------------------------------------------------------------ outputs
def _writer(path: str, barrier, results, k: int) -> None:
    """One of two processes writing ``path`` at once: both pass the existence check before either publishes."""
    try:
        with atomic_output(path) as tmp:
            tmp.write_text(f"writer {k}\n")
            barrier.wait(timeout=30)
        results.put((k, "ok"))
    except UsageError as exc:
        results.put((k, str(exc)))


def test_two_writers_of_one_file_one_wins_the_other_fails_cleanly(tmp_path):
    ctx = multiprocessing.get_context("fork")
    barrier, results = ctx.Barrier(2), ctx.Queue()
    target = tmp_path / "out.csv"
    procs = [ctx.Process(target=_writer, args=(str(target), barrier, results, k)) for k in (1, 2)]
    for p in procs:
        p.start()
    for p in procs:
        p.join(30)
    got = dict(results.get(timeout=5) for _ in procs)
    assert sorted(v == "ok" for v in got.values()) == [False, True], got
    winner = next(k for k, v in got.items() if v == "ok")
    loser = next(v for v in got.values() if v != "ok")
    assert "was created by another process while this command ran; it is not replaced" in loser
    assert target.read_text() == f"writer {winner}\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.csv"]  # no temporary file left


def test_a_folder_written_whole_is_not_replaced_by_a_second_writer(tmp_path):
    out = tmp_path / "demo"
    with pytest.raises(UsageError, match="written by another process while this command ran"):
        with staged_folder(out) as stage:
            (stage / "a.txt").write_text("mine")
            out.mkdir()
            (out / "theirs.txt").write_text("theirs")  # another writer finished first
    assert [p.name for p in out.iterdir()] == ["theirs.txt"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["demo"]


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no FIFOs")
def test_force_never_replaces_a_fifo_or_a_device(tmp_path):
    fifo = tmp_path / "pipe.csv"
    os.mkfifo(fifo)
    with pytest.raises(DataError, match=r"pipe\.csv is a FIFO; --force replaces only regular files"):
        atomic_write_text(fifo, "x", force=True)
    with pytest.raises(DataError, match="/dev/null is a character device"):
        ensure_writable("/dev/null", True)
    assert fifo.is_fifo()


@pytest.mark.parametrize("code, words", [(errno.ENOSPC, "no space left on device (ENOSPC)"),
                                         (errno.EDQUOT, "(EDQUOT)"), (errno.EIO, "(EIO)")])
def test_a_failed_write_is_named_with_the_path(tmp_path, code, words):
    target = tmp_path / "r.html"
    with pytest.raises(DataError, match=rf"cannot write {target}: .*{words.replace('(', '[(]').replace(')', '[)]')}"):
        with atomic_output(target):
            raise OSError(code, os.strerror(code))
    assert list(tmp_path.iterdir()) == []


def test_names_too_long_and_read_only_folders_are_named(tmp_path):
    with pytest.raises(DataError, match="ENAMETOOLONG"):
        ensure_writable(tmp_path / ("a" * 300 + ".csv"), False)
    if Path("/proc/sys").is_dir():
        with pytest.raises(DataError, match=r"cannot write /proc/sys/ft\.csv: .*\((EROFS|EACCES)\)"):
            ensure_writable("/proc/sys/ft.csv", False)


# ------------------------------------------------------------------------------------------ interruption
@pytest.mark.slow
@pytest.mark.parametrize("delay", [0.1, 0.15, 0.2, 0.3, 0.4])
def test_sigint_in_the_first_moments_exits_130_without_a_traceback(delay, tmp_path):
    """Before: a SIGINT in the first ~0.4 s (while the command line was imported, before its handler) ended the
    process by the signal or with a KeyboardInterrupt traceback. The console script's entry installs the handler
    before any heavy import (``import feedtune`` itself is a few ms), some 50 ms after the process starts (the
    interpreter's own start-up before it, which a signal ends as it ends any Python program)."""
    script = Path(sys.executable).with_name("feedtune")
    cmd = [str(script)] if script.exists() else [sys.executable, "-m", "feedtune"]
    t0 = time.perf_counter()  # the start-up up to the handler, on this machine at its load now
    subprocess.run([sys.executable, "-c", "import feedtune.cli.start"], check=True)
    ready = time.perf_counter() - t0
    p = subprocess.Popen([*cmd, "simulate", "frf", "-o", str(tmp_path / "s.csv")], stdout=subprocess.PIPE,
                         stderr=subprocess.PIPE, text=True)
    time.sleep(max(delay, 2.0 * ready))  # never inside the interpreter's own start-up on a loaded CI machine
    p.send_signal(signal.SIGINT)
    _, err = p.communicate(timeout=120)
    assert "Traceback" not in err, err
    assert p.returncode == 130 and err.strip().splitlines()[-1] == "feedtune: interrupted", (p.returncode, err)
    assert list(tmp_path.iterdir()) == []
