"""docs/real_data.md says what the commands print: every command block of the page is run on the real data (skipped
without them), and each line of its ``output`` blocks, and each number in code font in its text, must be in what the
commands of its section printed. The expected text lives in the page, not here: change the output, change the page.
"""

from __future__ import annotations

import glob
import re
import shlex
from pathlib import Path

import pytest
from cli_run import run

pytestmark = pytest.mark.slow

REPO = Path(__file__).resolve().parents[1]
DOC = REPO / "docs" / "real_data.md"
FENCE = re.compile(r"^```(\w*)\n(.*?)^```", re.S | re.M)
NUMBER_SPAN = re.compile(r"`(-?\d[^`]*)`")
"""A span in code font that starts with a number: a figure as a command prints it (``61.1 Hz``, ``5.25-8.5 ms``)."""
POINTS = re.compile(r"speed \((\d+) points\)")


def _sections() -> list[tuple[str, str]]:
    parts = re.split(r"^## ", DOC.read_text(encoding="utf-8"), flags=re.M)[1:]
    return [(p.splitlines()[0], p) for p in parts]


def _commands(block: str) -> list[tuple[list[str], bool]]:
    """The ``feedtune`` commands of a block (continuation lines joined) and whether each is commented ``# fails``."""
    out = []
    for line in block.replace("\\\n", " ").splitlines():
        line = line.strip()
        if not line.startswith("feedtune "):
            continue
        code, _, comment = line.partition("  #")
        words = shlex.split(code, comments=True)
        out.append((words[1:], comment.strip().startswith("fails")))
    return out


def _expand(arg: str, real: str) -> list[str]:
    """``$R`` replaced by the data folder, and a data path with ``*`` globbed as the shell would."""
    path = arg.replace("$R", real)
    return sorted(glob.glob(path)) if arg.startswith("$R") and "*" in arg else [path]


def _squash(text: str) -> str:
    return " ".join(text.split())


SECTIONS = _sections()


def test_the_page_has_its_sections_and_checks():
    titles = [t for t, _ in SECTIONS]
    assert len(titles) == 7 and any("Klipper" in t for t in titles) and any("ODrive" in t for t in titles)
    for title, text in SECTIONS:
        blocks = FENCE.findall(text)
        assert any(kind == "" and "feedtune " in body for kind, body in blocks), title
        assert any(kind == "output" for kind, _ in blocks), title


@pytest.mark.parametrize("title", [t for t, _ in SECTIONS])
def test_every_printed_line_and_number_of_the_page_is_printed(title, real_data_dir, tmp_path, capsys, monkeypatch):
    text = dict(SECTIONS)[title]
    monkeypatch.chdir(tmp_path)
    (tmp_path / "examples").symlink_to(REPO / "examples")
    real = str(real_data_dir)
    printed = []
    for kind, body in FENCE.findall(text):
        if kind != "":
            continue
        for args, fails in _commands(body):
            args = [b for a in args for b in _expand(a, real)]
            code, out, err = run(args, capsys, monkeypatch)
            assert (code != 0) == fails, (args, code, err[-2000:])
            printed.append(out + err)
    seen = _squash("\n".join(printed))
    for kind, body in FENCE.findall(text):
        if kind == "output":
            for line in body.splitlines():
                assert _squash(line.replace("$R", real)) in seen, (title, line)
    prose = FENCE.sub("", text)
    for span in NUMBER_SPAN.findall(prose):
        assert _squash(span) in seen, (title, span)
    for count in POINTS.findall(prose):  # the friction curve's points, in the file the command wrote
        import tomllib

        doc = tomllib.loads((tmp_path / "rack_friction.toml").read_text(encoding="utf-8"))
        assert len(doc["points"]["velocity"]) == int(count)
