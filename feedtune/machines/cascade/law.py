"""The drive cascade's law written once (:mod:`feedtune.control.cascade`, docs/cascade.md), for the runtime and the
compiled twin loop.

:func:`cascade_step` is one speed-loop sample of the cascade: the position loop every ``N`` samples (its speed
setpoint and current feedforward held in between), the speed PI, the current-setpoint filters (second-order sections,
transposed direct form II). :class:`~feedtune.machines.cascade.runtime.CascadeRuntime` calls it once per ``step``,
the twin's closed loop (:mod:`feedtune.machines.cascade.twin`) calls the same function inside its compiled kernel,
and the C header (:mod:`feedtune.export.c_cascade`) writes the same operations; the three are checked against each
other sample by sample (tests/test_cascade_law.py).

Arrays (built by :class:`CascadeLawData` from a gains document's numbers):

* ``par``: the numbers, in the order of the ``P_*`` offsets below;
* ``sos``: the filters' normalised sections ``[b0, b1, b2, 1, a1, a2]``, ``(n, 6)``; ``w``: their states ``(n, 2)``;
* ``st``: the scalar states, in the order of the ``S_*`` offsets.
"""

from __future__ import annotations

import numpy as np

(P_FS, P_FP, P_N, P_KP, P_KI_TS, P_KV, P_KVFF, P_JFF, P_LOAD, P_NSEC) = range(10)
"""Offsets in ``par``: speed-loop rate fs [Hz], position-loop rate fp [Hz], ``N`` (samples per position sample),
``Kp`` [U/(pos/s)], ``Kp Ts / Tn`` [U/pos] (0 without integral action), ``Kv`` [1/s], ``kv_ff`` [-], ``J_ff``
[U/(pos/s^2)], position on the load encoder (1) or the motor's (0), number of filter sections."""
PAR_SIZE = 10
(S_STARTED, S_COUNT, S_X1_PREV, S_INTEGRAL, S_SPEED_SET, S_CURRENT_FF, S_R_PREV, S_VR_PREV) = range(8)
"""Offsets in ``st``: started flag, speed samples since the last position sample, previous motor position [pos],
the PI's integral [U], the held speed setpoint [pos/s], the held current feedforward [U], the previous position
setpoint [pos], the previous setpoint velocity [pos/s]."""
STATE_SIZE = 8


def sos_run(sos, nsec, w, x):
    """One sample through ``nsec`` sections (transposed direct form II, as :class:`feedtune.control.sos.SosCascade`)."""
    for i in range(nsec):
        y = sos[i, 0] * x + w[i, 0]
        w[i, 0] = sos[i, 1] * x - sos[i, 4] * y + w[i, 1]
        w[i, 1] = sos[i, 2] * x - sos[i, 5] * y
        x = y
    return x


_sos = sos_run  # replaced by its compiled version when the law is compiled


def cascade_step(par, sos, w, st, r, x1, x2):
    """One speed-loop sample: position setpoint ``r`` [pos], motor encoder ``x1`` and load encoder ``x2`` [pos] ->
    the current setpoint [U] (applied ``delay_samples`` later by the target).

    On the first sample the previous motor position is the current one (speed 0) and the setpoint's velocity and
    acceleration are 0. The position loop runs on the first sample and every ``N``-th after it.
    """
    if st[S_STARTED] == 0.0:
        st[S_STARTED] = 1.0
        st[S_X1_PREV] = x1
        st[S_R_PREV] = r
        st[S_VR_PREV] = 0.0
        st[S_COUNT] = 0.0
    if st[S_COUNT] == 0.0:
        fp = par[P_FP]
        vr = (r - st[S_R_PREV]) * fp
        ar = (vr - st[S_VR_PREV]) * fp
        st[S_R_PREV] = r
        st[S_VR_PREV] = vr
        xp = x2 if par[P_LOAD] != 0.0 else x1
        st[S_SPEED_SET] = par[P_KV] * (r - xp) + par[P_KVFF] * vr
        st[S_CURRENT_FF] = par[P_JFF] * ar
    st[S_COUNT] += 1.0
    if st[S_COUNT] >= par[P_N]:
        st[S_COUNT] = 0.0
    v = (x1 - st[S_X1_PREV]) * par[P_FS]
    st[S_X1_PREV] = x1
    e = st[S_SPEED_SET] - v
    st[S_INTEGRAL] += par[P_KI_TS] * e
    u = par[P_KP] * e + st[S_INTEGRAL] + st[S_CURRENT_FF]
    return _sos(sos, int(par[P_NSEC]), w, u)


class CascadeLawData:
    """The arrays :func:`cascade_step` runs on.

    Parameters
    ----------
    fs : float
        Speed-loop rate [Hz].
    position_ratio : int
        ``N`` (the position loop at ``fs / N``).
    kp, tn_s, kv, kv_ff, inertia_ff : float
        The gains (:class:`~feedtune.control.cascade.CascadeLaw`; ``tn_s`` inf: no integral action).
    load : bool
        The position loop closes on the load encoder.
    sos : ndarray, shape (n, 6)
        The current-setpoint filters' sections, normalised.
    """

    def __init__(self, fs: float, position_ratio: int, kp: float, tn_s: float, kv: float, kv_ff: float,
                 inertia_ff: float, load: bool, sos) -> None:
        par = np.zeros(PAR_SIZE)
        par[P_FS], par[P_N] = fs, position_ratio
        par[P_FP] = fs / position_ratio
        par[P_KP], par[P_KI_TS] = kp, (0.0 if np.isinf(tn_s) else kp / (fs * tn_s))
        par[P_KV], par[P_KVFF], par[P_JFF] = kv, kv_ff, inertia_ff
        par[P_LOAD] = 1.0 if load else 0.0
        rows = np.asarray(sos, float).reshape(-1, 6)
        par[P_NSEC] = rows.shape[0]
        self.par = par
        self.sos = np.ascontiguousarray(rows if rows.size else np.zeros((1, 6)))
        self.w = np.zeros((max(rows.shape[0], 1), 2))
        self.st = np.zeros(STATE_SIZE)

    def reset(self) -> None:
        """Every state to rest."""
        self.w[:] = 0.0
        self.st[:] = 0.0

    def args(self) -> tuple:
        """The array arguments of :func:`cascade_step` before the signals."""
        return self.par, self.sos, self.w, self.st


_COMPILED: list = []


def compiled_step():
    """:func:`cascade_step` compiled by numba (once per process, cached on disk), its sections inlined."""
    if not _COMPILED:
        import numba

        global _sos
        _sos = numba.njit(cache=True, nogil=True, inline="always")(sos_run)
        _COMPILED.append(numba.njit(cache=True, nogil=True, inline="always")(cascade_step))
    return _COMPILED[0]


__all__ = ["PAR_SIZE", "STATE_SIZE", "CascadeLawData", "cascade_step", "compiled_step", "sos_run"]
