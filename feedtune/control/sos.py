"""Second-order-section cascades as a controller executes them.

Sections are rows ``[b0, b1, b2, a0, a1, a2]`` in powers of ``z^-1`` with ``a0 = 1`` (see
:func:`feedtune.io.gains.read_sos` for reading them from a gains file). :class:`SosCascade` runs one sample at a
time in transposed direct form II, the form the C header uses; :func:`sos_filter` runs a whole signal at once
(``scipy.signal.sosfilt``, the same recursion).
"""

from __future__ import annotations

import numpy as np


class SosCascade:
    """Cascaded second-order sections (``a0 = 1``), transposed direct form II, one sample at a time.

    Parameters
    ----------
    sos : array_like, shape (n_sections, 6)
        Normalised sections ``[b0, b1, b2, 1, a1, a2]``.
    """

    __slots__ = ("rows", "w")

    def __init__(self, sos) -> None:
        self.rows = [(float(r[0]), float(r[1]), float(r[2]), float(r[4]), float(r[5])) for r in np.asarray(sos)]
        self.w = [[0.0, 0.0] for _ in self.rows]

    def reset(self) -> None:
        """Zero the state (the filter at rest)."""
        for w in self.w:
            w[0] = w[1] = 0.0

    def step(self, x: float) -> float:
        """Filter one sample ``x`` and return the output (units of ``x`` times the cascade's gain)."""
        for (b0, b1, b2, a1, a2), w in zip(self.rows, self.w):  # noqa: B905 - equal lengths by construction
            y = b0 * x + w[0]
            w[0] = b1 * x - a1 * y + w[1]
            w[1] = b2 * x - a2 * y
            x = y
        return x


def sos_filter(sos: np.ndarray, x: np.ndarray) -> np.ndarray:
    """The cascade applied to the whole signal ``x`` from rest (``scipy.signal.sosfilt``)."""
    from scipy.signal import sosfilt

    return sosfilt(sos, x)
