"""What a TOML or JSON document may be before it is parsed, and what its numbers may be after: the one home of the
limits every document reader applies (:func:`feedtune.io.document.read_document`, :func:`~feedtune.io.document.
loads_document`).

The parsers recurse on nested arrays and inline tables and parse every value: a file of ``[[[[...`` ends in a
RecursionError, a 5,000-digit integer in a ValueError or an OverflowError, and a 100 MB file of ``1,1,1,...`` in
minutes of parsing. So, before parsing (:func:`check_text`), a document must be at most :data:`MAX_BYTES` long,
hold at most :data:`MAX_ITEMS` values, nest at most :data:`MAX_DEPTH` brackets deep and write no number with more
than :data:`MAX_DIGITS` digits; after parsing (:func:`check_tree`), no table may nest deeper than :data:`MAX_DEPTH`
(TOML's dotted keys nest without brackets) and no integer may lie beyond the range of a float. Each refusal is one
line naming the file and the line or key. feedtune's own documents (models, gains files with their schedules,
filters and certificates, friction curves) are far inside these limits (the largest a few hundred kB).
"""

from __future__ import annotations

import re
import sys

from ..errors import DataError

MAX_BYTES = 4 << 20
"""Largest document [bytes] (parsed in about a second at most)."""
MAX_ITEMS = 250_000
"""Most values (counted as separators ``,``) a document may hold."""
MAX_DEPTH = 64
"""Deepest nesting of arrays and tables."""
MAX_DIGITS = 309
"""Most digits of a number's integer part: 1.8e308, the largest float, has 309."""

_TOKENS = re.compile(r'"""[\s\S]*?"""|\'\'\'[\s\S]*?\'\'\'|"(?:[^"\\\n]|\\.)*"|\'[^\'\n]*\'|#[^\n]*|[\[\]{}]'
                     r"|(?<![.\d])\d[\d_]{" + str(MAX_DIGITS) + ",}")


def check_size(size: int, where: str) -> None:
    """DataError when a document of ``size`` bytes is larger than :data:`MAX_BYTES`."""
    if size > MAX_BYTES:
        from ..budget import fmt_bytes

        raise DataError(f"{where}: {fmt_bytes(size)}, more than the {fmt_bytes(MAX_BYTES)} a feedtune document (model, "
                        "gains, mass, friction) may be; not read")


def _line_of(text: str, pos: int) -> int:
    return text.count("\n", 0, pos) + 1


def _key_before(text: str, pos: int, fmt: str) -> str:
    """The key a value at ``pos`` belongs to, for messages (the ``key =`` of its TOML line, the last ``"key":`` before
    it in JSON), or ``""``."""
    start = text.rfind("\n", 0, pos) + 1
    if fmt == "toml":
        head = text[start:pos]
        return head.split("=", 1)[0].strip() if "=" in head else ""
    found = re.findall(r'"((?:[^"\\]|\\.)*)"\s*:', text[max(0, pos - 400):pos])
    return found[-1] if found else ""


def check_text(text: str, fmt: str, where: str) -> None:
    """Refuse, before parsing, a document too long, with too many values, nested too deep or holding a number too
    long to be a float (see the module docstring). ``fmt`` is ``"toml"`` or ``"json"``."""
    check_size(len(text), where)
    items = text.count(",")
    if items > MAX_ITEMS:
        raise DataError(f"{where}: holds {items:,} values or more, more than the {MAX_ITEMS:,} a feedtune document "
                        "may hold; not read")
    if fmt == "toml":  # dotted keys nest without brackets: [a.b.c] and a.b.c = 1
        m = _DOTTED.search(text) if text.count(".") >= MAX_DEPTH else None
        if m is not None:
            raise DataError(f"{where}: line {_line_of(text, m.start())}: a key of more than {MAX_DEPTH} dotted parts, "
                            f"tables nested more than {MAX_DEPTH} deep; not read")
    depth = 0
    for m in _TOKENS.finditer(text):
        token = m.group()
        c = token[0]
        if c in "[{":
            depth += 1
            if depth > MAX_DEPTH:
                raise DataError(f"{where}: line {_line_of(text, m.start())}: arrays or tables nested more than "
                                f"{MAX_DEPTH} deep; not read")
        elif c in "]}":
            depth -= 1
        elif c.isdigit() and fmt == "toml":  # JSON's integers go through parse_json_int, which check_tree names
            digits = len(token.replace("_", ""))
            key = _key_before(text, m.start(), fmt)
            raise DataError(f"{where}: line {_line_of(text, m.start())}{': ' + key if key else ''}: number with "
                            f"{digits} digits, beyond the range of a float (at most {MAX_DIGITS} digits)")


_DOTTED = re.compile(r"(?:[\w-]+[ \t]*\.[ \t]*){" + str(MAX_DEPTH) + "}")
"""A key of more than :data:`MAX_DEPTH` dotted bare parts (``[a.b.c...]``, ``a.b.c... = 1``)."""


class HugeInteger(str):
    """An integer too long to convert (a JSON parser hook returns it; :func:`check_tree` names its key)."""


def parse_json_int(text: str) -> int | HugeInteger:
    """``int(text)``, or :class:`HugeInteger` for more than :data:`MAX_DIGITS` digits (``json.loads(parse_int=)``)."""
    digits = len(text.lstrip("-"))
    return HugeInteger(text) if digits > MAX_DIGITS else int(text)


def key_path(parts) -> str:
    """``a.b[0].c`` from the parts of a key path."""
    out = ""
    for p in parts:
        out += f"[{p}]" if isinstance(p, int) else (f".{p}" if out else str(p))
    return out


def check_tree(doc, where: str) -> None:
    """Refuse, after parsing, a document nesting deeper than :data:`MAX_DEPTH` or holding an integer beyond the range
    of a float, naming the key (an iterative walk: no recursion however deep the input)."""
    stack = [(doc, ())]
    while stack:
        node, parts = stack.pop()
        if len(parts) > MAX_DEPTH:
            raise DataError(f"{where}: {key_path(parts[:8])}...: tables nested more than {MAX_DEPTH} deep; not read")
        if isinstance(node, dict):
            stack.extend((v, (*parts, k)) for k, v in node.items())
        elif isinstance(node, list):
            stack.extend((v, (*parts, i)) for i, v in enumerate(node))
        elif isinstance(node, HugeInteger) or (isinstance(node, int) and not isinstance(node, bool)
                                               and node.bit_length() > sys.float_info.max_exp):
            n = len(str(node).lstrip("-")) if isinstance(node, HugeInteger) else len(str(abs(node)))
            raise DataError(f"{where}: {key_path(parts) or 'document'}: integer with {n} digits, beyond the range of "
                            "a float")
