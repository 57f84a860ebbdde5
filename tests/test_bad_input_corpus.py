"""The standing corpus of bad inputs (issue 26, tests/bad_input_corpus.py): every case ends with the exit code of
docs/conventions.md, exactly one ``feedtune: error:`` line on stderr naming the culprit, and nothing written.

The cases run in this process through the command line's ``main`` (a few ms each); the few that need more (an MDF
reader's crash probe in a child process) are in the slow set. ``python benchmarks/bad_input_corpus.py`` prints the
same corpus as a table of classes per command, for this tree or another (``--root``).
"""

from __future__ import annotations

import pytest
from bad_input_corpus import _listing, all_cases, build_fixtures, classify, describe, run_case

CASES = all_cases()


@pytest.fixture(scope="module")
def fixtures(tmp_path_factory):
    fx = build_fixtures(tmp_path_factory.mktemp("corpus_fixtures"))
    before = _listing(fx)
    yield fx
    assert _listing(fx) == before, "a case wrote into (or changed) the shared fixtures"


@pytest.mark.parametrize("case", [pytest.param(c, id=c.id, marks=[pytest.mark.slow] if c.slow else [])
                                  for c in CASES])
def test_bad_input_is_refused_in_one_line_naming_it(case, fixtures, tmp_path):
    if any(name.endswith(".mf4") for name, _ in case.files):
        pytest.importorskip("asammdf", reason="MDF files need the mdf extra (pip install '.[mdf]')")
    outcome = run_case(case, fixtures, tmp_path / "case")
    assert classify(case, outcome) == "clean", describe(case, outcome)


def test_the_corpus_covers_every_command_and_family():
    from feedtune.cli.help_text import iter_commands
    from feedtune.cli.main import app

    commands = {path for path, _ in iter_commands(app)}
    covered = {c.command for c in CASES}
    assert commands <= covered, sorted(commands - covered)
    assert len(CASES) >= 500
    families = {c.family for c in CASES}
    assert {"budget", "nesting", "big number", "non-finite", "wrong kind", "output", "frf file", "log file",
            "schema", "parser", "name"} <= families, sorted(families)
