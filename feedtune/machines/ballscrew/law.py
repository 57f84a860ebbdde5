"""The ball-screw feedback law written once (docs/gains.md), for the runtime and the compiled twin loop.

:func:`feedback_step` is the per-sample state feedback of eq. 3.5 -- backward-difference velocities, backward-Euler
integral of the table error, the gains ``Kx1, Kx2, Kv1, Kv2, Ki2`` -- followed by the filter pack (second-order
sections, transposed direct form II). :class:`~feedtune.machines.ballscrew.runtime.GainsRuntime` calls it once per
``step`` and the twin's closed loop (:mod:`feedtune.machines.ballscrew.twin`) calls the same function inside its
compiled kernel; the references, the feedforward and the pre-filter are the runtime's vectorised paths in both. The C
header (:mod:`feedtune.export.c_ballscrew`) writes the same operations and is checked against them sample by sample.

State vector ``st``: ``[started, e1_prev, e2_prev, ie2, w0_0, w1_0, w0_1, w1_1, ...]`` (the last two per section).
"""

from __future__ import annotations

import numpy as np

ST_STARTED, ST_E1, ST_E2, ST_IE2 = range(4)
ST_FILTERS = 4
"""Index of the first filter-pack state in ``st``."""


def state_size(n_sections: int) -> int:
    """Length of the state vector of a law with ``n_sections`` filter-pack sections."""
    return ST_FILTERS + 2 * n_sections


def feedback_step(st, g, fp, nsec, fs, e1, e2):
    """The command of the feedback path [command unit] for the errors ``e1 = x1r - x1``, ``e2 = x2r - x2`` [rad].

    Parameters
    ----------
    st : array
        The state (module docstring), updated.
    g : array
        ``Kx1, Kx2`` [V/rad], ``Kv1, Kv2`` [V/(rad/s)], ``Ki2`` [V/(rad s)].
    fp : array
        The filter pack's normalised sections, flat (``6 nsec``).
    nsec : int
        Number of sections.
    fs : float
        Sample rate [Hz].
    e1, e2 : float
        Motor-side and table-side errors [rad].
    """
    if st[ST_STARTED] == 0.0:
        st[ST_E1] = e1
        st[ST_E2] = e2
        st[ST_STARTED] = 1.0
    de1 = (e1 - st[ST_E1]) * fs
    de2 = (e2 - st[ST_E2]) * fs
    st[ST_IE2] += e2 / fs
    st[ST_E1] = e1
    st[ST_E2] = e2
    x = g[0] * e1 + g[1] * e2 + g[2] * de1 + g[3] * de2 + g[4] * st[ST_IE2]
    for s in range(nsec):
        o = 6 * s
        w = ST_FILTERS + 2 * s
        y = fp[o] * x + st[w]
        st[w] = fp[o + 1] * x - fp[o + 4] * y + st[w + 1]
        st[w + 1] = fp[o + 2] * x - fp[o + 5] * y
        x = y
    return x


def compiled_feedback():
    """:func:`feedback_step` compiled by numba (once per process, cached on disk)."""
    from ...sim.engine import compiled

    return compiled(feedback_step)


def new_state(n_sections: int) -> np.ndarray:
    """A state vector at rest."""
    return np.zeros(state_size(n_sections))
