"""Which controller is better in each figure of a comparison (smaller error, shorter settling), and the verdict
sentence that names every figure the baseline wins: one rule for the demos' tables and the report.

A comparison is a list of rows ``{"test": name, CONTROLLER: {figure: value}, ...}`` with the figures of
:data:`FIGURE_LABELS` (``max_um``, ``rms_um`` of tracking, cutting and contour runs, ``peak_um`` and
``settling_time_s`` of rope snaps; None where a run did not settle). A figure counts when either controller has it;
one that only one controller has (the other did not settle) is won by that one; values within :data:`TIE` of each
other are a tie.
"""

from __future__ import annotations


def reduction_pct(a: float, b: float) -> float:
    """``100 (1 - a / b)`` [%]: how much smaller ``a`` is than ``b``."""
    return 100.0 * (1.0 - a / b) if b else float("nan")


FIGURE_LABELS = {"max_um": "max", "rms_um": "RMS", "peak_um": "peak", "settling_time_s": "settling time"}
"""The figures of a comparison row (smaller is better) and their names in sentences."""
TIE = 0.005
"""Two values closer than this fraction of the larger are a tie [-]."""


def better_per_figure(rows: list, a: str = "mcppc", b: str = "ppi") -> list[tuple[str, str, str | None]]:
    """``(test, figure, better)`` for every figure of every row: the label of the controller with the smaller
    value (``None`` for a tie within 0.5 % or a missing value)."""
    out = []
    for row in rows:
        if a not in row or b not in row:
            continue
        for key in FIGURE_LABELS:
            if key not in row[a] and key not in row[b]:
                continue
            x, y = row[a].get(key), row[b].get(key)
            if x is None or y is None:
                better = a if y is None and x is not None else b if x is None and y is not None else None
            elif abs(x - y) <= TIE * max(abs(x), abs(y)):
                better = None
            else:
                better = a if x < y else b
            out.append((row["test"], FIGURE_LABELS[key], better))
    return out


def verdict_line(rows: list, proposal: tuple[str, str] = ("mcppc", "MC-PPC"),
                 baseline: tuple[str, str] = ("ppi", "P-PI")) -> str:
    """One sentence: how many figures each controller wins (``(key, label)`` of the proposal and the baseline), and
    which ones the baseline wins."""
    per = better_per_figure(rows, proposal[0], baseline[0])
    a = [f"{t} {k}" for t, k, w in per if w == proposal[0]]
    b = [f"{t} {k}" for t, k, w in per if w == baseline[0]]
    ties = len(per) - len(a) - len(b)
    text = f"{proposal[1]} is better in {len(a)} of {len(per)} figures, {baseline[1]} in {len(b)}"
    text += f", {ties} tie(s) within 0.5 % or both missing" if ties else ""
    return text + (f"; {baseline[1]} is better in: {', '.join(b)}." if b else ".")
