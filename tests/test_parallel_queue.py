"""The shared job queue of :func:`feedtune.parallel.run_queue`: every job run once, results in the order of the
jobs, the work taken by whichever process is free, errors raised in the caller."""

from __future__ import annotations

import os
import time

import pytest

from feedtune.parallel import run_queue


def _can_fork() -> bool:
    return hasattr(os, "fork")


def test_serial_queue_runs_every_job_in_order_here():
    seen = []
    got = run_queue([(f"j{i}", (lambda i=i: (i * i, os.getpid()))) for i in range(5)], processes=1,
                    after_each=seen.append)
    assert list(got) == [f"j{i}" for i in range(5)] and [v[0] for v in got.values()] == [0, 1, 4, 9, 16]
    assert {v[1] for v in got.values()} == {os.getpid()} and seen == list(got)


def test_queue_hands_each_job_to_one_process_and_a_free_process_takes_the_next(tmp_path):
    if not _can_fork():
        pytest.skip("no fork")
    started = tmp_path / "j1-started"
    journal = tmp_path / "journal.txt"

    def job(i):
        with open(journal, "a") as fh:
            fh.write(f"{os.getpid()} {i}\n")
        if i == 1:
            started.touch()
        if i == 0:  # waits for job 1: only a second process, taking the next job while this one is busy, ends it
            t_end = time.monotonic() + 20.0
            while not started.exists():
                assert time.monotonic() < t_end, "job 1 never started beside job 0"
                time.sleep(0.005)
        return i, os.getpid()

    seen = []
    got = run_queue([(f"j{i}", (lambda i=i: job(i))) for i in range(6)], processes=2, after_each=seen.append)
    assert list(got) == [f"j{i}" for i in range(6)] and [v[0] for v in got.values()] == list(range(6))
    lines = [line.split() for line in journal.read_text().splitlines()]
    assert sorted(int(i) for _, i in lines) == list(range(6))  # each job once
    pids = {v[1] for v in got.values()}
    assert len(pids) == 2 and os.getpid() in pids
    assert sorted(seen) == sorted(n for n, v in got.items() if v[1] == os.getpid())  # progress: this process only


def test_an_error_in_a_queued_job_is_raised_in_the_caller():
    def fail():
        raise ValueError("figure 3 cannot be drawn")

    jobs = [("a", lambda: 1), ("b", lambda: 2), ("c", fail), ("d", lambda: 4)]
    for n in (1, 2):
        with pytest.raises(ValueError, match="figure 3 cannot be drawn"):
            run_queue(jobs, processes=n)
