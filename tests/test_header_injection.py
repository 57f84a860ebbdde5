"""Nothing a gains file says can become code in the C header (issue 26): every string of a gains document of every
kind, given ``*/``, ``//``, line breaks, ``#define``, a trigraph splice, a backslash, NUL and a bidirectional override,
either is refused with one line naming the file or reaches the header only inside a comment.

The oracle is the C preprocessor, not feedtune: ``gcc -fpreprocessed -dD -E -P`` removes the comments of a header
without expanding anything, so a header from an injected document must give exactly the code of the header of the
clean document; the injected header must compile under ``-std=c99 -Wall -Wextra -Werror`` (trigraphs on), define no
external symbol (``nm``) and no macro the clean header does not. Before: a ``created_by`` of ``feedtune */ int
ft_injected_created = 42; /*`` exported with exit 0 and compiled into a global variable.
"""

from __future__ import annotations

import copy
import shutil
import subprocess

import pytest

from feedtune.control.filters import FilterPack, Notch
from feedtune.design.gantry_mimo import design_gantry_mimo
from feedtune.design.loopshape import design_loopshape
from feedtune.design.mcppc import design_mcppc
from feedtune.errors import DataError
from feedtune.export.c_header import c_header
from feedtune.export.c_text import comment_text
from feedtune.io.gains import gains_document, with_friction_feedforward
from feedtune.io.gantry_gains import axis_gains_document, gantry_gains_document
from feedtune.models import THESIS_TABLE_3_1
from feedtune.models.friction import StribeckFriction
from feedtune.models.gantry import THESIS_GANTRY

GCC = shutil.which("gcc")
NM = shutil.which("nm")
needs_gcc = pytest.mark.skipif(GCC is None or NM is None, reason="gcc and nm not installed")

PAYLOAD = ("feedtune */ int ft_injected_%d = 42; /* // \n#define FT_INJECTED_%d 1\n */ int ft_spliced_%d; ??/\n"
           "// x \\\n int ft_continued_%d; \x00 \u202e int ft_bidi_%d; \r\n#include <stdio.h>\n")


def _documents() -> dict[str, dict]:
    bs_friction = StribeckFriction(0.05, 0.09, -0.06, -0.1, 2.0, 3.0, command_unit="V", velocity_unit="rad/s")
    ballscrew = with_friction_feedforward(
        gains_document(design_mcppc(THESIS_TABLE_3_1, filters=FilterPack([Notch(420.0, 0.55, 0.7)], 2000.0))),
        bs_friction)
    friction = StribeckFriction(0.3, 0.5, -0.35, -0.55, 2e-3, 3e-3, command_unit="V", velocity_unit="m/s")
    gantry = gantry_gains_document(design_gantry_mimo(THESIS_GANTRY).with_friction(friction, v_band=2e-4))
    axis = axis_gains_document(design_loopshape(0.6977, crossover_hz=130, pm_deg=35).with_friction(
        StribeckFriction(0.05, 0.09, -0.06, -0.1, 2e-3, 3e-3, command_unit="V", velocity_unit="m/s"),
        v_band=2e-4))
    docs = {"ballscrew": ballscrew, "gantry": gantry, "axis": axis}
    for d in docs.values():
        d["notes"] = {"comment": "a note", "sources": ["bench.csv", "run 2"], "x */ int ft_key; /*": "key"}
    return docs


DOCS = _documents()


def _strings(node, path=()):
    """Paths of every string value of a document."""
    if isinstance(node, dict):
        for k, v in node.items():
            yield from _strings(v, (*path, k))
    elif isinstance(node, list):
        for i, v in enumerate(node):
            yield from _strings(v, (*path, i))
    elif isinstance(node, str):
        yield path


def _set(doc, path, value):
    node = doc
    for k in path[:-1]:
        node = node[k]
    node[path[-1]] = value


def _get(doc, path):
    for k in path:
        doc = doc[k]
    return doc


def _code(header: str) -> str:
    """The header without its comments (the preprocessor's view, see the module docstring)."""
    res = subprocess.run([GCC, "-std=c99", "-fpreprocessed", "-dD", "-E", "-P", "-x", "c", "-"], input=header,
                         capture_output=True, text=True, check=True)
    return res.stdout


def _injected(kind: str) -> tuple[dict, list, list]:
    """The document of ``kind`` with the payload appended to every string the runtime accepts it in (one string at
    a time decides), the accepted and the refused string paths."""
    clean = DOCS[kind]
    accepted, refused = [], []
    for k, path in enumerate(_strings(clean)):
        doc = copy.deepcopy(clean)
        _set(doc, path, _get(doc, path) + PAYLOAD.replace("%d", str(k)))
        try:
            c_header(doc, where="g.toml")
        except DataError as exc:
            assert "\n" not in str(exc) and str(exc).startswith("g.toml"), exc
            refused.append(path)
            continue
        accepted.append((path, k))
    doc = copy.deepcopy(clean)
    for path, k in accepted:
        _set(doc, path, _get(doc, path) + PAYLOAD.replace("%d", str(k)))
    return doc, [p for p, _ in accepted], refused


@needs_gcc
@pytest.mark.parametrize("kind", ["ballscrew", "gantry", "axis"])
def test_injected_strings_stay_in_comments_and_define_nothing(kind, tmp_path):
    doc, accepted, refused = _injected(kind)
    assert ("created_by",) in accepted and ("notes", "comment") in accepted  # the free text: exported
    assert ("kind",) in refused  # the checked names: refused by the runtime, one line naming the file
    for precision in ("double", "float"):
        clean = c_header(DOCS[kind], where="g.toml", precision=precision, u_max=10.0,
                         warning="fails */ #define X")
        header = c_header(doc, where="g.toml", precision=precision, u_max=10.0, warning="fails */ #define X")
        assert "ft_injected" in header  # the text is there, in comments
        assert _code(header) == _code(clean)
        h = tmp_path / f"{kind}_{precision}.h"
        h.write_text(header)
        src = tmp_path / f"{kind}_{precision}.c"
        src.write_text(f'#include "{h.name}"\nvoid ft_use(ft_state *s) {{ ft_init(s); }}\n')
        obj = tmp_path / f"{kind}_{precision}.o"
        subprocess.run([GCC, "-std=c99", "-Wall", "-Wextra", "-Werror", "-Wno-unused-function", "-c", str(src),
                        "-o", str(obj)], check=True, capture_output=True, text=True, cwd=tmp_path)
        listing = subprocess.run([NM, "--defined-only", "-g", str(obj)], capture_output=True, text=True,
                                 check=True).stdout
        symbols = [line.split()[-1] for line in listing.splitlines() if line.strip()]
        assert symbols == ["ft_use"], listing  # the translation unit's own function only: the header is static
        macros = {line.split()[1].split("(")[0] for line in _code(header).splitlines() if line.startswith("#define")}
        clean_macros = {line.split()[1].split("(")[0] for line in _code(clean).splitlines()
                        if line.startswith("#define")}
        assert macros == clean_macros and not any("INJECTED" in m for m in macros)


def test_the_command_line_exports_the_injected_file_safely(tmp_path, capsys, monkeypatch):
    """``feedtune export c`` on a file whose free text (``created_by``, notes, sources) carries the payload: exit 0,
    the text in comments only (the command line's own reading and checking path)."""
    from cli_run import run

    from feedtune.io import write_document

    doc = copy.deepcopy(DOCS["ballscrew"])
    for k, path in enumerate([("created_by",), ("notes", "comment"), ("notes", "sources", 0)]):
        _set(doc, path, _get(doc, path) + PAYLOAD.replace("%d", str(k)))
    write_document(tmp_path / "g.toml", doc)
    code, _, err = run(["export", "c", tmp_path / "g.toml", "-o", tmp_path / "g.h", "--allow-unstable"], capsys,
                       monkeypatch)
    assert code == 0, err
    header = (tmp_path / "g.h").read_text()
    assert "ft_injected_0" in header and "\x00" not in header and "\u202e" not in header
    if GCC is not None:
        assert _code(header) == _code(c_header(DOCS["ballscrew"], where="g.toml"))


@pytest.mark.parametrize("text, safe", [
    ("a */ b", "a * / b"), ("a /* b", "a / * b"), ("a // b", "a / / b"), ("a ??/", "a ? ?/"), ("*//*", "* / / *"),
    ("a\nb\rc\x00d\u2028e\u202ef", "a b c d e f"), ("back\\slash", "back slash"), ("***///", "*** / / /"),
])
def test_comment_text_breaks_every_comment_token(text, safe):
    out = comment_text(text)
    assert out == safe
    for token in ("*/", "/*", "//", "??", "\\", "\n"):
        assert token not in out
