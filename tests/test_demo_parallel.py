"""The demos' independent twin runs side by side (forked workers, :mod:`feedtune.parallel`) give what running them one
by one gives: the same rows and byte-identical log texts, in the same order. A run that depended on what ran before
it in the same process (a controller runtime not reset, a shared random generator) would differ here."""

from __future__ import annotations

import os

import pytest
from test_export_c_kinds import AXIS, MIMO, PID

from feedtune.machines import load_runtime
from feedtune.machines.gantry.twin import GantryTwin
from feedtune.parallel import usable_cores
from feedtune.workflows import gantry_demo


def _gantry_tests(monkeypatch, jobs: str):
    monkeypatch.setenv("FEEDTUNE_JOBS", jobs)
    runtimes = {"mimo": load_runtime(MIMO, "mimo.toml"), "pid": load_runtime(PID, "pid.toml"),
                "pid_own": load_runtime(PID, "pid_own.toml"), "axis": load_runtime(AXIS, "axis.toml")}
    texts: dict = {}
    rows = gantry_demo._tests(GantryTwin(None), runtimes, 3, "auto", ("200mm_s",), "200mm", ("circle",), texts)
    return rows, texts


def test_gantry_twin_tests_side_by_side_equal_the_serial_run(monkeypatch):
    if not hasattr(os, "fork"):
        pytest.skip("no fork on this platform: the runs are serial anyway")
    monkeypatch.setenv("FEEDTUNE_JOBS", "auto")
    if usable_cores() < 2:
        pytest.skip("one usable core: the runs are serial anyway")
    serial_rows, serial_texts = _gantry_tests(monkeypatch, "1")
    rows, texts = _gantry_tests(monkeypatch, "auto")
    assert rows == serial_rows
    assert list(texts) == list(serial_texts)  # same files, same order
    assert all(texts[k] == serial_texts[k] for k in texts)
    assert [r["test"] for r in rows] == ["rope snap 57 N", "track 200mm/s", "circle 200mm"]
    assert len(texts) == 9 and all(len(t) > 1000 for t in texts.values())
