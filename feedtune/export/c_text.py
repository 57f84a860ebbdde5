"""Text from a gains file that goes into a C header: only ever inside a ``/* ... */`` comment, and unable to leave
it (:func:`comment_text`).

A gains file is data a user may have received from anyone; its strings (``created_by``, names, units, the sources of
a certificate) are copied into the header's comments, and the header is compiled into firmware. A string holding
``*/`` would end the comment and put the rest of the string into the code (``created_by = "x */ int y = 1; /*"``
defined a variable in the firmware); ``??/`` followed by a line end is a trigraph line splice under ``-std=c99``; a
backslash at a line's end splices the next line; bidirectional-override characters make the code read differently
from what compiles (Trojan Source). So every string of the document is rewritten (:func:`comment_safe`) before an
emitter sees it, and the emitters put only such text and numbers into the header.
"""

from __future__ import annotations

import unicodedata

MAX_CHARS = 200
"""Longest text copied from a document into a comment [characters]; longer text is cut with ``...``."""

_BREAKS = (("*/", "* /"), ("/*", "/ *"), ("//", "/ /"), ("??", "? ?"))


def comment_text(value: object, limit: int = MAX_CHARS) -> str:
    """``value`` as one line of printable text that cannot end a C comment, start one, splice lines or reorder what
    a reader sees: control, format (bidirectional overrides), private-use, unassigned and line/paragraph-separator
    characters and backslashes become spaces, ``*/``, ``/*``, ``//`` and ``??`` are broken apart, runs of white space
    become one space, and the text is cut to ``limit`` characters.

    Examples
    --------
    >>> comment_text("feedtune */ int ft_injected = 42; /*")
    'feedtune * / int ft_injected = 42; / *'
    >>> comment_text("V\\n#define X 1\\x00 \\\\")
    'V #define X 1'
    """
    out = []
    for ch in str(value):
        cat = unicodedata.category(ch)
        out.append(" " if ch == "\\" or cat[0] == "C" or cat in ("Zl", "Zp") else ch)
    text = " ".join("".join(out).split())
    while any(a in text for a, _ in _BREAKS):
        for a, b in _BREAKS:
            text = text.replace(a, b)
    if len(text) > limit:
        text = text[:limit - 3].rstrip() + "..."
        text = text.replace("*/", "* /")  # the cut cannot create one, but keep the rule local
    return text


def comment_safe(node):
    """A copy of a document whose every string (keys too) is :func:`comment_text` (numbers and structure kept)."""
    if isinstance(node, dict):
        return {comment_text(k) if isinstance(k, str) else k: comment_safe(v) for k, v in node.items()}
    if isinstance(node, list):
        return [comment_safe(v) for v in node]
    if isinstance(node, str):
        return comment_text(node)
    return node
