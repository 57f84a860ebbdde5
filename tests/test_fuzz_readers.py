"""Property-based fuzzing of every reader and document loader (issues 14 and 26): byte-level mutations of a valid file
of each format (bit flips, cuts, repeats, and tokens: non-finite numbers, nesting bombs, integers beyond the float
range, NULs, encodings; tests/fuzz_inputs.py) are read or refused with feedtune's own error, never another exception.
A few hundred examples per reader in the fast set; the slow set runs :func:`long_examples`, a budget of CPU time shared
by all readers: :data:`DEFAULT_FUZZ_SECONDS` unless the environment variable ``FEEDTUNE_FUZZ_SECONDS`` sets another
(``FEEDTUNE_FUZZ_SECONDS=660`` for the 11-minute run of issue 26; ``python benchmarks/fuzz_readers.py N`` prints the
counts per reader and error type)."""

from __future__ import annotations

import os
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


def _fuzz(name: str, formats, folder, examples: int, lowest_seed: int) -> None:
    """``examples`` mutations of reader ``name``'s valid file, each read or refused with feedtune's own error."""
    if name not in formats:
        pytest.skip(f"{name}: its optional extra is not installed")
    suffix, valid, read = formats[name]

    @settings(max_examples=examples, deadline=None, derandomize=True, database=None,
              suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
    @given(seed=st.integers(min_value=lowest_seed, max_value=lowest_seed + 2**32 - 1))
    def check(seed):
        path = folder / f"case{suffix}"
        path.write_bytes(mutate(valid, random.Random(seed)))
        crash = run_one(read, path)
        assert crash is None, crash

    check()


@pytest.mark.parametrize("name", [pytest.param(n, marks=pytest.mark.slow) if n == "log mdf" else n for n in NAMES])
def test_mutated_files_are_read_or_refused_with_feedtunes_own_error(name, formats, tmp_path_factory):
    examples = {"gains analysis": EXAMPLES // 4, "log mdf": 10}.get(name, EXAMPLES)  # slow ones: fewer
    _fuzz(name, formats, tmp_path_factory.mktemp("fuzz"), examples, 0)


EXAMPLES_PER_MINUTE = {"frf csv": 10_000, "frf uff": 12_000, "frf mat": 15_000, "log csv": 15_000, "log mat": 16_000,
                       "log mdf": 90, "model toml": 16_000, "model json": 22_000, "gains runtime": 7_500,
                       "gains analysis": 7_500, "mass": 28_000}
"""Examples of each reader in a minute of CPU on this project's 2-core machine (measured 2-8 ms an example, an MDF
file 0.66 s: every MDF read starts a crash probe in a child)."""

DEFAULT_FUZZ_SECONDS = 90.0
"""CPU time of the slow fuzz run over all readers by default [s]: within the slow set's share of CI's time."""


def long_examples(name: str) -> int:
    """Examples of reader ``name`` in the slow run: its share (one in :data:`NAMES`) of ``FEEDTUNE_FUZZ_SECONDS``
    (default :data:`DEFAULT_FUZZ_SECONDS`), never fewer than the fast set's."""
    text = os.environ.get("FEEDTUNE_FUZZ_SECONDS", "")
    try:
        seconds = float(text) if text.strip() else DEFAULT_FUZZ_SECONDS
    except ValueError:
        raise pytest.UsageError(f"FEEDTUNE_FUZZ_SECONDS must be a number of seconds, got {text!r}") from None
    share = max(seconds, 0.0) / len(NAMES) / 60.0
    return max(10 if name == "log mdf" else EXAMPLES, round(EXAMPLES_PER_MINUTE[name] * share))


@pytest.mark.slow
@pytest.mark.parametrize("name", NAMES)
def test_long_fuzz_of_every_reader(name, formats, tmp_path_factory):
    _fuzz(name, formats, tmp_path_factory.mktemp("fuzz_long"), long_examples(name), 2**32)
