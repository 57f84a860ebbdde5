"""The tuning objective in the report: where the chosen design lies among the edges the tuner found.

A tuned gains file records its objective (``design.objective``), the winner's integral gain
(``design.integral_gain``) and first crossover, every shape's edge when the tuner searched a fixed list of shapes
(``design.per_shape``: MC-PPC, gantry MIMO) and, under the ``pareto`` objective, the front of both figures
(``design.pareto_front``). :func:`objective_block` draws them: integral gain against the guaranteed first
crossover, the front and the chosen design.
"""

from __future__ import annotations

from collections.abc import Mapping
from functools import partial

import numpy as np

from .content import FigureBlock
from .figures import objective_figure


def _points(entries) -> np.ndarray:
    pts = [(float(e["first_crossover_hz"]), float(e["integral_gain"])) for e in entries or []
           if isinstance(e, Mapping) and e.get("first_crossover_hz") is not None
           and e.get("integral_gain") is not None]
    return np.array(pts, float).reshape(-1, 2)


def front_of(points: np.ndarray) -> np.ndarray:
    """The points no other beats in both coordinates (first crossover and integral gain), by rising crossover."""
    keep = [i for i, (x, g) in enumerate(points)
            if not np.any((points[:, 0] >= x) & (points[:, 1] >= g) & ((points[:, 0] > x) | (points[:, 1] > g)))]
    return points[sorted(keep, key=lambda i: points[i, 0])]


def objective_block(name: str, label: str, design: Mapping | None) -> FigureBlock | None:
    """The figure of one tuned design (None when its gains file records no edges or no integral gain)."""
    if not isinstance(design, Mapping) or not isinstance(design.get("integral_gain"), Mapping):
        return None
    edges = _points(design.get("per_shape"))
    front = _points(design.get("pareto_front"))
    if not edges.size and not front.size:
        return None
    if not front.size:
        front = front_of(edges)
    g = design["integral_gain"]
    chosen = (float(design.get("first_crossover_hz", np.nan)), float(g["value"]))
    fig = partial(objective_figure, edges, front, chosen, gain_label=f"integral gain {g['name']} [{g['unit']}]",
                  title=f"Objective of {label}: {design.get('objective', '-')}")
    return FigureBlock(f"design-objective-{name}",
                       f"{label}: the integral gain (low-frequency stiffness against a force) against the guaranteed "
                       "first crossover at the edge of every shape the tuner searched (the largest scale meeting the "
                       "limits), the Pareto front of both, and the chosen design; objective "
                       f"{design.get('objective_rule') or design.get('objective', '-')}.", fig)
