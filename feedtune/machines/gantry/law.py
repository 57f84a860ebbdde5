"""The gantry and x-axis control laws written once (docs/gantry_gains.md), for the runtime and the compiled twin loop.

Each law is a plain function over arrays and scalars that numba compiles (:func:`compiled_laws`); the runtimes
(:class:`~feedtune.machines.gantry.runtime.GantryRuntime`, :class:`~feedtune.machines.gantry.runtime.AxisRuntime`)
call the compiled function once per ``step``, and the twin's closed loop inlines the same functions into its compiled
kernel (:func:`compiled_inline`), so the law a target runs, the runtime and the simulation are one code. The C header
(:mod:`feedtune.export.c_gantry`) writes the same operations in C and is checked against the runtime sample by
sample.

Data layout (built by :func:`gantry_law_data` / :func:`axis_law_data` from a runtime):

* ``sos``: every filter's normalised sections ``[b0, b1, b2, 1, a1, a2]`` stacked, ``(n, 6)``;
* ``seg``: ``(n_filters, 2)`` first row and number of rows of each filter in ``sos`` (:data:`G_FILTERS`,
  :data:`A_FILTERS`);
* ``w``: ``(n, 2)`` states of the filter instances (:data:`G_STATES`: the gantry runs the filter pack, position and
  acceleration filters once per side);
* ``par``: gains and flags (:data:`G_PAR`, :data:`A_PAR`); ``st``: the scalar states (:data:`G_ST`, :data:`A_ST`).

The optional friction feedforward of both laws (``[friction_feedforward]``, :mod:`feedtune.control.friction`) is
eq. 2.1 with its viscous term ``Fv v`` (per direction) of the backward-difference velocity of the previewed reference,
linear through zero inside ``+-v_band`` (:func:`friction_command`, the formula of
:meth:`feedtune.models.friction.StribeckFriction.smoothed` of the whole curve). The gantry
law splits it between the drives as its inertia feedforward splits a rigid acceleration: ``u_i += alpha_i(x) d``
(``alpha_i m`` is the row sum of ``M(x)``).
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

G_FILTERS = ("filter_pack", "position", "acceleration", "lead", "prefilter_vel", "prefilter_acc", "prefilter_jerk",
             "prefilter_snap")
"""Filters of the gantry law, in the order of ``seg``."""
G_STATES = (0, 0, 1, 1, 2, 2, 3, 4, 5, 6, 7)
"""Filter of each state instance: h1, h2, pos1, pos2, acc1, acc2, lead, the four pre-filter terms."""
(GP_FS, GP_BETA, GP_KI, GP_KP1, GP_KD1, GP_KI1, GP_KP2, GP_KD2, GP_KI2, GP_MIMO, GP_PRE, GP_NCOL,
 GP_FRICTION) = range(13)
(FR_DC_POS, FR_DS_POS, FR_DC_NEG, FR_DS_NEG, FR_OMEGA_POS, FR_OMEGA_NEG, FR_V_BAND, FR_EDGE_POS, FR_EDGE_NEG,
 FR_VISC_POS, FR_VISC_NEG) = range(11)
"""Offsets of the friction feedforward's numbers in a ``par`` vector from its first (:func:`friction_command`):
levels dc+, ds+, dc-, ds- [U], Stribeck velocities omega+, omega- [m/s], band v_band [m/s], the friction at
+-v_band [U] (viscous term included), viscous coefficients Fv+, Fv- [U/(m/s)] (U the command unit)."""
FR_N = 11
GP_FR = 13
"""First friction number (:data:`FR_DC_POS` ..) in the gantry ``par`` vector."""
G_PAR = GP_FR + FR_N
"""Length of the gantry ``par`` vector: fs [Hz], beta, ki (MIMO), kp1, kd1, ki1, kp2, kd2, ki2 (PID), MIMO flag,
pre-filter flag, schedule columns used, friction flag, then the friction feedforward (:data:`FR_DC_POS` ..)."""
GS_STARTED, GS_E1, GS_E2, GS_IE1, GS_IE2, GS_R_PREV = range(6)
GS_ROW = 6
"""First entry of the schedule row in the gantry ``st`` vector."""
G_ST = GS_ROW + 13
"""Length of the gantry ``st`` vector: started, previous errors, integrals, previous previewed reference [m] (the
friction's velocity), then the schedule row (13)."""
A_FILTERS = ("controller", "position", "acceleration", "prefilter_vel", "prefilter_acc", "prefilter_jerk",
             "prefilter_snap")
"""Filters of the axis law, in the order of ``seg`` (one instance each)."""
AP_MASS, AP_KVEL, AP_KACC, AP_KJERK, AP_KSNAP, AP_PRE, AP_FS, AP_FRICTION = range(8)
AP_FR = 8
"""First friction number (:data:`FR_DC_POS` ..) in the axis ``par`` vector."""
(AP_DC_POS, AP_DS_POS, AP_DC_NEG, AP_DS_NEG, AP_OMEGA_POS, AP_OMEGA_NEG, AP_V_BAND, AP_EDGE_POS,
 AP_EDGE_NEG, AP_VISC_POS, AP_VISC_NEG) = range(AP_FR, AP_FR + FR_N)
A_PAR = AP_FR + FR_N
"""Length of the axis ``par`` vector: mass [U/(m/s^2)], pre-filter gains [s..s^4], pre-filter flag, fs [Hz], friction
flag, then the friction feedforward: levels dc+, ds+, dc-, ds- [U], Stribeck velocities omega+, omega- [m/s], band
v_band [m/s], the friction at +-v_band [U] and the viscous coefficients Fv+, Fv- [U/(m/s)] (U the command unit)."""
AS_STARTED, AS_R_PREV = range(2)
A_ST = 2
"""Length of the axis ``st`` vector: started flag, previous previewed reference [m] (the friction's velocity)."""


def sos_run(sos, first, count, w, wfirst, x):
    """One sample through ``count`` sections from row ``first`` of ``sos`` with states from row ``wfirst`` of
    ``w`` (transposed direct form II, as :class:`feedtune.control.sos.SosCascade`)."""
    for i in range(count):
        r = first + i
        s = wfirst + i
        y = sos[r, 0] * x + w[s, 0]
        w[s, 0] = sos[r, 1] * x - sos[r, 4] * y + w[s, 1]
        w[s, 1] = sos[r, 2] * x - sos[r, 5] * y
        x = y
    return x


_sos = sos_run  # the callees the laws use: replaced by their compiled versions when the laws are compiled


def schedule_row(sched_x, sched, ncol, x, row):
    """The schedule row at table position ``x`` [m] into ``row``: linear interpolation, clamped at the ends (the
    interval from the number of grid points ``<= x``; a NaN ``x`` uses the first row)."""
    nx = sched_x.size
    i = 0
    while i < nx and sched_x[i] <= x:
        i += 1
    if i == 0 or i == nx:
        j = 0 if i == 0 else nx - 1
        for c in range(ncol):
            row[c] = sched[j, c]
        return
    w = (x - sched_x[i - 1]) * (1.0 / (sched_x[i] - sched_x[i - 1]))
    for c in range(ncol):
        row[c] = sched[i - 1, c] + w * (sched[i, c] - sched[i - 1, c])


_row = schedule_row


def gantry_law_step(sos, seg, w, wofs, par, st, sched_x, sched, r, y1, y2, x, out):
    """One sample of the gantry law: reference ``r = y_r[k+P]``, encoders ``y1, y2`` [m], table ``x`` [m] ->
    ``out[0], out[1]`` = ``u1, u2`` [command unit].

    ``wofs[i]``: first state row of instance ``i`` of :data:`G_STATES`. With the friction flag, ``d = d(v_r)`` with
    ``v_r = (r - r_prev) fs`` [m/s] (0 on the first sample) is added to the commands as ``alpha1 d`` and ``alpha2 d``
    (``alpha_i`` of the schedule row at ``x``).
    """
    row = st[GS_ROW:]
    _row(sched_x, sched, int(par[GP_NCOL]), x, row)
    ra1 = r
    ra2 = r
    if par[GP_PRE] != 0.0:
        d0 = _sos(sos, seg[4, 0], seg[4, 1], w, wofs[7], r)
        d1 = _sos(sos, seg[5, 0], seg[5, 1], w, wofs[8], r)
        d2 = _sos(sos, seg[6, 0], seg[6, 1], w, wofs[9], r)
        d3 = _sos(sos, seg[7, 0], seg[7, 1], w, wofs[10], r)
        ra1 = r + row[5] * d0 + row[6] * d1 + row[7] * d2 + row[8] * d3
        ra2 = r + row[9] * d0 + row[10] * d1 + row[11] * d2 + row[12] * d3
    acc1 = _sos(sos, seg[2, 0], seg[2, 1], w, wofs[4], ra1)
    acc2 = _sos(sos, seg[2, 0], seg[2, 1], w, wofs[5], ra2)
    e1 = _sos(sos, seg[1, 0], seg[1, 1], w, wofs[2], ra1) - y1
    e2 = _sos(sos, seg[1, 0], seg[1, 1], w, wofs[3], ra2) - y2
    fr = 0.0
    if par[GP_FRICTION] != 0.0:
        v = (r - st[GS_R_PREV]) * par[GP_FS] if st[GS_STARTED] != 0.0 else 0.0
        st[GS_R_PREV] = r
        fr = _fric(par, GP_FR, v)
    if st[GS_STARTED] == 0.0:
        st[GS_E1] = e1
        st[GS_E2] = e2
        st[GS_STARTED] = 1.0
    fs = par[GP_FS]
    st[GS_IE1] = st[GS_IE1] + e1 / fs
    st[GS_IE2] = st[GS_IE2] + e2 / fs
    if par[GP_MIMO] != 0.0:
        a1 = row[0]
        a2 = row[1]
        v = _sos(sos, seg[3, 0], seg[3, 1], w, wofs[6], a1 * e1 + a2 * e2)
        dd = par[GP_BETA] * ((e1 - e2) - (st[GS_E1] - st[GS_E2])) * fs
        w1 = a1 * (v + dd + par[GP_KI] * st[GS_IE1])
        w2 = a2 * (v - dd + par[GP_KI] * st[GS_IE2])
    else:
        w1 = par[GP_KP1] * e1 + par[GP_KD1] * (e1 - st[GS_E1]) * fs + par[GP_KI1] * st[GS_IE1]
        w2 = par[GP_KP2] * e2 + par[GP_KD2] * (e2 - st[GS_E2]) * fs + par[GP_KI2] * st[GS_IE2]
    st[GS_E1] = e1
    st[GS_E2] = e2
    out[0] = _sos(sos, seg[0, 0], seg[0, 1], w, wofs[0], w1) + row[2] * acc1 + row[3] * acc2 + row[0] * fr
    out[1] = _sos(sos, seg[0, 0], seg[0, 1], w, wofs[1], w2) + row[3] * acc1 + row[4] * acc2 + row[1] * fr


def friction_command(par, f, v):
    """The friction feedforward ``d(v)`` [command unit] of the reference velocity ``v`` [m/s]: eq. 2.1 plus its
    viscous term outside ``+-v_band``, the straight line through zero to the band's edges inside; its numbers are
    ``par[f + FR_*]`` (:data:`FR_DC_POS` .., ``f`` = :data:`AP_FR` for the axis, :data:`GP_FR` for the gantry)."""
    a = abs(v)
    if a < par[f + FR_V_BAND]:
        return (par[f + FR_EDGE_POS] if v >= 0.0 else par[f + FR_EDGE_NEG]) * a / par[f + FR_V_BAND]
    if v > 0.0:
        return (par[f + FR_DC_POS] + (par[f + FR_DS_POS] - par[f + FR_DC_POS]) * math.exp(-a / par[f + FR_OMEGA_POS])
                + par[f + FR_VISC_POS] * v)
    return (par[f + FR_DC_NEG] + (par[f + FR_DS_NEG] - par[f + FR_DC_NEG]) * math.exp(-a / par[f + FR_OMEGA_NEG])
            + par[f + FR_VISC_NEG] * v)


def friction_par(friction) -> np.ndarray:
    """The :data:`FR_N` numbers of a :class:`~feedtune.control.friction.FrictionFeedforward` (command unit, m/s) in
    the order :data:`FR_DC_POS` .. :data:`FR_EDGE_NEG`."""
    f = friction.friction
    return np.array([f.dc_pos, f.ds_pos, f.dc_neg, f.ds_neg, f.omega_pos, f.omega_negative, friction.v_band,
                     *friction.edges(), *friction.viscous], dtype=float)


_fric = friction_command


def axis_law_step(sos, seg, w, par, st, r, x):
    """One sample of the x-axis law: reference ``r = x_r[k+P]`` and encoder ``x`` [m] -> ``u_x`` [command unit]
    (one state instance per filter: the states of filter ``i`` start at ``seg[i, 0]``; ``st``: :data:`A_ST`).

    With the friction flag, ``uff += d(v_r)`` with ``v_r = (r - r_prev) fs`` [m/s] (0 on the first sample)."""
    ra = r
    if par[AP_PRE] != 0.0:
        ra = (r + par[AP_KVEL] * _sos(sos, seg[3, 0], seg[3, 1], w, seg[3, 0], r)
              + par[AP_KACC] * _sos(sos, seg[4, 0], seg[4, 1], w, seg[4, 0], r)
              + par[AP_KJERK] * _sos(sos, seg[5, 0], seg[5, 1], w, seg[5, 0], r)
              + par[AP_KSNAP] * _sos(sos, seg[6, 0], seg[6, 1], w, seg[6, 0], r))
    uff = par[AP_MASS] * _sos(sos, seg[2, 0], seg[2, 1], w, seg[2, 0], r)
    if par[AP_FRICTION] != 0.0:
        v = (r - st[AS_R_PREV]) * par[AP_FS] if st[AS_STARTED] != 0.0 else 0.0
        st[AS_R_PREV] = r
        st[AS_STARTED] = 1.0
        uff += _fric(par, AP_FR, v)
    e = _sos(sos, seg[1, 0], seg[1, 1], w, seg[1, 0], ra) - x
    return _sos(sos, seg[0, 0], seg[0, 1], w, seg[0, 0], e) + uff


# ------------------------------------------------------------------------------------------ data
def _stack(sos: dict, names) -> tuple[np.ndarray, np.ndarray]:
    rows, seg, n = [], np.zeros((len(names), 2), dtype=np.int64), 0
    for i, name in enumerate(names):
        a = np.asarray(sos.get(name, np.zeros((0, 6))), float).reshape(-1, 6)
        seg[i] = n, a.shape[0]
        rows.append(a)
        n += a.shape[0]
    return np.ascontiguousarray(np.vstack(rows) if n else np.zeros((0, 6))), seg


class GantryLawData:
    """The arrays :func:`gantry_law_step` runs on, built from a gantry runtime's sections, gains, schedule and
    optional friction feedforward (a :class:`~feedtune.control.friction.FrictionFeedforward` [command unit, m/s]).

    Attributes
    ----------
    sos, seg, w, wofs, par, st, sched_x, sched : ndarray
        See the module docstring.
    """

    def __init__(self, controller: str, gains: dict, sos: dict, schedule_x, schedule, fs: float,
                 prefilter_on: bool, friction=None) -> None:
        self.sos, self.seg = _stack(sos, G_FILTERS)
        counts = [int(self.seg[f, 1]) for f in G_STATES]
        self.wofs = np.cumsum([0, *counts[:-1]]).astype(np.int64)
        self.w = np.zeros((max(sum(counts), 1), 2))
        par = np.zeros(G_PAR)
        par[GP_FS] = fs
        par[GP_BETA] = gains.get("beta", 0.0)
        par[GP_KI] = gains.get("ki", 0.0)
        for i, k in zip(range(GP_KP1, GP_KI2 + 1), ("kp1", "kd1", "ki1", "kp2", "kd2", "ki2"), strict=True):
            par[i] = gains.get(k, 0.0)
        par[GP_MIMO] = 1.0 if controller == "mimo" else 0.0
        par[GP_PRE] = 1.0 if prefilter_on else 0.0
        par[GP_NCOL] = 13 if prefilter_on else 5
        if friction is not None:
            par[GP_FRICTION] = 1.0
            par[GP_FR:GP_FR + FR_N] = friction_par(friction)
        self.par = par
        self.st = np.zeros(G_ST)
        self.sched_x = np.ascontiguousarray(schedule_x, float)
        sched = np.zeros((self.sched_x.size, 13))
        s = np.asarray(schedule, float)
        sched[:, : s.shape[1]] = s
        self.sched = sched
        self.out = np.zeros(2)

    def reset(self) -> None:
        """Every state to rest."""
        self.w[:] = 0.0
        self.st[:] = 0.0

    def args(self) -> tuple:
        """The array arguments of :func:`gantry_law_step` before the signals."""
        return self.sos, self.seg, self.w, self.wofs, self.par, self.st, self.sched_x, self.sched


class AxisLawData:
    """The arrays :func:`axis_law_step` runs on, built from an axis runtime.

    Parameters
    ----------
    sos : dict of ndarray
        The runtime's sections by name (:data:`A_FILTERS`).
    mass : float
        Feedforward mass [command unit/(m/s^2)].
    prefilter_gains : sequence of float
        ``k_vel .. k_snap`` [s .. s^4].
    prefilter_on : bool
        Whether the pre-filter runs.
    fs : float
        Sample rate [Hz] (the friction's velocity).
    friction : FrictionFeedforward, optional
        Friction feedforward [command unit, m/s].
    """

    def __init__(self, sos: dict, mass: float, prefilter_gains, prefilter_on: bool, fs: float = 1.0,
                 friction=None) -> None:
        self.sos, self.seg = _stack(sos, A_FILTERS)
        self.w = np.zeros((max(self.sos.shape[0], 1), 2))
        par = np.zeros(A_PAR)
        par[AP_MASS] = mass
        par[AP_KVEL:AP_KSNAP + 1] = prefilter_gains
        par[AP_PRE] = 1.0 if prefilter_on else 0.0
        par[AP_FS] = fs
        if friction is not None:
            par[AP_FRICTION] = 1.0
            par[AP_FR:AP_FR + FR_N] = friction_par(friction)
        self.par = par
        self.st = np.zeros(A_ST)

    def reset(self) -> None:
        """Every state to rest."""
        self.w[:] = 0.0
        self.st[:] = 0.0

    def args(self) -> tuple:
        """The array arguments of :func:`axis_law_step` before the signals."""
        return self.sos, self.seg, self.w, self.par, self.st


_LAWS: list = []


def compiled_inline(func: Callable) -> Callable:
    """``func`` compiled by numba (``njit(cache=True, nogil=True)``) and inlined into the compiled functions that call
    it (numba IR inlining, ``inline="always"``); called from Python it runs as compiled alone.

    A call between compiled functions passes every array as a structure of seven or more words, which costs as much
    as a second-order section: the twin's closed loop inlines the laws, their sections and the plant step.

    numba keys the twin loop's disk cache on ``twin.py`` alone, so feedtune's cache folder is named after a digest
    of all its sources (:func:`feedtune.kernel_cache_dir`): an edit here compiles the loop again. A fixed
    ``NUMBA_CACHE_DIR`` set by the user opts out of that (clear it after editing this module).
    """
    import numba

    return numba.njit(cache=True, nogil=True, inline="always")(func)


def compiled_laws() -> tuple:
    """``(gantry_law_step, axis_law_step)`` compiled by numba (once per process, cached on disk), inlined into the
    compiled twin loop that calls them, with the sections and the schedule inlined into them."""
    if not _LAWS:
        global _sos, _row, _fric
        _sos = compiled_inline(sos_run)
        _row = compiled_inline(schedule_row)
        _fric = compiled_inline(friction_command)
        _LAWS.extend([compiled_inline(gantry_law_step), compiled_inline(axis_law_step)])
    return tuple(_LAWS)
