"""Property-based fuzzing of every reader and document loader (issue 14): byte-level mutations of a valid file of
each format are read or refused with feedtune's own error, never a crash (tests/fuzz_inputs.py). A few hundred
examples per reader here; ``python benchmarks/fuzz_readers.py`` runs thousands."""

from __future__ import annotations

import random

import pytest
from fuzz_inputs import mutate, readers, run_one
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

EXAMPLES = 200
NAMES = ["frf csv", "frf uff", "frf mat", "log csv", "log mat", "log mdf", "model toml", "model json", "gains runtime",
         "gains analysis", "mass"]


@pytest.fixture(scope="module")
def formats(examples_dir, tmp_path_factory):
    return readers(examples_dir, tmp_path_factory.mktemp("valid"))


@pytest.mark.parametrize("name", [pytest.param(n, marks=pytest.mark.slow) if n == "log mdf" else n for n in NAMES])
def test_mutated_files_are_read_or_refused_with_feedtunes_own_error(name, formats, tmp_path_factory):
    if name not in formats:
        pytest.skip(f"{name}: its optional extra is not installed")
    suffix, valid, read = formats[name]
    folder = tmp_path_factory.mktemp("fuzz")
    examples = {"gains analysis": EXAMPLES // 4, "log mdf": 10}.get(name, EXAMPLES)  # slow ones: fewer

    @settings(max_examples=examples, deadline=None, derandomize=True,
              suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
    @given(seed=st.integers(min_value=0, max_value=2**32 - 1))
    def check(seed):
        path = folder / f"case{suffix}"
        path.write_bytes(mutate(valid, random.Random(seed)))
        crash = run_one(read, path)
        assert crash is None, crash

    check()
