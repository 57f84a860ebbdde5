"""Where to evaluate a loop so that its figures do not depend on the frequency grid.

A loop is known either as samples on a grid (arrays) or as a function that can be evaluated at any frequency of
its band: the parts known exactly (models, controllers, hold, delay) anywhere, a measured FRF between its lines by
the interpolation of :func:`interpolate_frf` (log magnitude and unwrapped phase, linear in log frequency). Figures
taken from a function are exact for that function; figures taken from samples are refused when the samples do not
resolve the loop.

Resolution rules, checked on every scalar loop ``l`` the analysis reads (``L`` for a SISO loop; the centre-of-mass
loop and ``det(I + L) - 1`` for a 2x2 loop), between every two neighbouring frequencies:

* winding: the angle of ``1 + l`` changes by at most :data:`WINDING_STEP_DEG` (the Nyquist count unwraps it);
* near ``|l| = 1`` (``NEAR_LOW <= |l| <= NEAR_HIGH`` at either end): the angle of ``l`` changes by at most
  :data:`PHASE_STEP_DEG` and ``|l|`` by at most :data:`MAGNITUDE_STEP_DB` (crossovers, margins and ``|S|`` peaks);
* around every lightly damped pole or zero (damping below :data:`FEATURE_ZETA`) of the exactly known parts,
  :data:`FEATURE_POINTS` points over ``f_n exp(+-FEATURE_SPAN zeta)``: a pole-zero pair between two grid lines has
  no net phase change across the interval and is otherwise invisible.

With a function (:func:`resolve`), every interval that breaks a rule is split (:data:`SPLIT` log-spaced points)
until none does, at most :data:`MAX_ROUNDS` times; a loop still unresolved then (it passes through ``-1``) is
refused with :class:`ResolutionError`. Crossings of a level are then bracketed to a relative width of about 1e-9
(:func:`refine_roots`) and peaks zoomed to about 1e-6 (:func:`refine_peaks`); the SISO analysis does the same for
all crossings and peaks of all its loops in joint rounds (:func:`feedtune.analysis.loop.analyze_loops`). With
samples only (:func:`check_samples`), a grid that breaks a rule by more than :data:`SAMPLE_SLACK` times is refused.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np

from ..errors import DataError
from ..frf_quality import (
    NOISE_BLOCK,
    ROUGHNESS_STENCIL,
    _coherence_floor_db,
    _db_rows,
    line_axis,
    line_residuals,
    noise_db,
)

WINDING_STEP_DEG = 20.0
"""Largest change of the angle of ``1 + l`` between neighbouring frequencies [deg]."""
PHASE_STEP_DEG = 10.0
"""Largest change of the angle of ``l`` between neighbouring frequencies where ``|l|`` is near 1 [deg]."""
MAGNITUDE_STEP_DB = 1.0
"""Largest change of ``|l|`` between neighbouring frequencies where ``|l|`` is near 1 [dB]."""
NEAR_LOW, NEAR_HIGH = 0.25, 4.0
"""``|l|`` range [-] counted as near 1 (within 12 dB)."""
FEATURE_ZETA = 0.2
"""Poles and zeros with less damping [-] get extra points around them."""
FEATURE_SPAN = 10.0
"""Half width of the extra points around a lightly damped root, in units of its damping (log frequency) [-]."""
FEATURE_POINTS = 40
"""Extra points per lightly damped root (an even number: the undamped frequency itself is not evaluated)."""
SPLIT = 4
"""Points inserted into an unresolved interval per round."""
MAX_ROUNDS = 14
"""Subdivision rounds before an unresolved loop is refused."""
SAMPLE_SLACK = 3.0
"""Samples breaking a rule by more than this factor are refused (samples cannot be refined)."""


class ResolutionError(DataError):
    """The frequency grid does not resolve the loop (the message names the interval)."""


# ------------------------------------------------------------------------------------------ features
def lightly_damped(roots, dt: float | None = None, zeta_max: float = FEATURE_ZETA) -> np.ndarray:
    """Natural frequency [Hz] and damping [-] of the lightly damped roots, shape ``(k, 2)``.

    Parameters
    ----------
    roots : array_like of complex
        Poles or zeros: in ``s`` [rad/s] (``dt`` None) or in ``z`` (discrete, sample time ``dt`` [s]).
    dt : float, optional
        Sample time [s] of discrete roots (mapped to ``s = ln(z) / dt``; roots at ``z = 0`` are skipped).
    zeta_max : float
        Roots with damping below this [-] are returned (roots at the origin are not).
    """
    r = np.atleast_1d(np.asarray(roots, complex))
    if dt is not None:
        r = r[np.abs(r) > 1e-12]
        r = np.log(r) / dt
    wn = np.abs(r)
    keep = wn > 0
    r, wn = r[keep], wn[keep]
    zeta = -r.real / wn
    sel = (np.abs(zeta) < zeta_max) & (r.imag >= 0)
    return np.column_stack([wn[sel] / (2 * np.pi), zeta[sel]]) if sel.any() else np.empty((0, 2))


def feature_points(features, lo_hz: float, hi_hz: float) -> np.ndarray:
    """Extra frequencies [Hz] around lightly damped roots ``features`` (``(k, 2)``: Hz, damping) in ``[lo, hi]``."""
    feats = np.asarray(features, float).reshape(-1, 2)
    if feats.size == 0:
        return np.empty(0)
    span = np.clip(FEATURE_SPAN * np.maximum(np.abs(feats[:, 1]), 1e-5), 1e-4, 1.0)
    k = (np.arange(FEATURE_POINTS) + 0.5) / FEATURE_POINTS * 2 - 1  # symmetric, 0 excluded
    pts = (feats[:, :1] * np.exp(span[:, None] * k[None, :])).ravel()
    return pts[(pts > lo_hz) & (pts < hi_hz)]


# ------------------------------------------------------------------------------------------ rules
def _pair_steps(l0: np.ndarray, l1: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Per interval from ``l0`` to ``l1``: winding and phase steps [deg], magnitude step [dB], near-|l|=1 flag."""
    with np.errstate(divide="ignore", invalid="ignore"):
        a0, a1 = np.abs(l0), np.abs(l1)
        wind = np.abs(np.angle((1.0 + l1) / (1.0 + l0), deg=True))
        phase = np.abs(np.angle(l1 / l0, deg=True))
        mag = np.abs(20 * np.log10(a1 / a0))
    lo, hi = np.minimum(a0, a1), np.maximum(a0, a1)
    near = (lo <= NEAR_HIGH) & (hi >= NEAR_LOW)
    return np.nan_to_num(wind, nan=360.0), np.nan_to_num(phase, nan=360.0), np.nan_to_num(mag, nan=1e3), near


def _steps(l: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Per interval: winding step [deg], phase step [deg], magnitude step [dB], near-|l|=1 flag."""
    return _pair_steps(l[:-1], l[1:])


def pair_unresolved(l0: np.ndarray, l1: np.ndarray, slack: float = 1.0) -> np.ndarray:
    """Boolean per interval from ``l0`` to ``l1`` (a scalar loop at both ends): a resolution rule is broken (by more
    than ``slack`` times)."""
    wind, phase, mag, near = _pair_steps(l0, l1)
    return (wind > slack * WINDING_STEP_DEG) | (near & ((phase > slack * PHASE_STEP_DEG)
                                                        | (mag > slack * MAGNITUDE_STEP_DB)))


def contour_steps(L: np.ndarray, a: np.ndarray, a1: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray,
                                                                          np.ndarray]:
    """The steps of :func:`_steps` of a whole contour, from what the analysis has anyway: ``a = |L|``,
    ``a1 = |1 + L|``, no arctangent over the whole contour.

    Returns ``(cos_wind, near, phase, mag)``: the cosine of the winding step of every interval (the angle between
    ``1 + L`` at its ends, from their dot product), the intervals where ``|L|`` is near 1 (indices) and their phase
    [deg] and magnitude [dB] steps (the only ones a rule reads).
    """
    x = L.real + 1.0
    y = L.imag
    cos_wind = x[:-1] * x[1:]
    tmp = x[:-1]  # x's memory serves the temporaries that follow
    cos_wind += np.multiply(y[:-1], y[1:], out=tmp)
    cos_wind /= a1[:-1]
    cos_wind /= a1[1:]
    near = np.minimum(a[:-1], a[1:], out=tmp) <= NEAR_HIGH
    near &= np.maximum(a[:-1], a[1:], out=tmp) >= NEAR_LOW
    del x, tmp
    i = np.flatnonzero(near)
    i1 = i + 1
    w = L[i]
    np.conjugate(w, out=w)
    phase = np.abs(np.angle(np.multiply(L[i1], w, out=w), deg=True))  # the angle of l1 conj(l0), in w's memory
    del w
    mag = np.abs(20 * np.log10(a[i1] / a[i]))
    return cos_wind, i, phase, mag


def rules_broken(steps: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray], slack: float = 1.0,
                 start: int = 0) -> np.ndarray:
    """Boolean per interval (from interval ``start`` on) of :func:`contour_steps`: a rule is broken by more than
    ``slack`` times (an undefined step, where ``L`` or ``1 + L`` is 0 or not finite, breaks it)."""
    cos_wind, near, phase, mag = steps
    bad = ~(cos_wind[start:] >= np.cos(np.radians(min(slack * WINDING_STEP_DEG, 180.0))))
    sel = near >= start
    hit = near[sel][~((phase[sel] <= slack * PHASE_STEP_DEG) & (mag[sel] <= slack * MAGNITUDE_STEP_DB))]
    bad[hit - start] = True
    return bad


def unresolved(loops: Sequence[np.ndarray], slack: float = 1.0) -> np.ndarray:
    """Boolean per interval: some loop breaks a resolution rule (by more than ``slack`` times)."""
    bad = None
    for l in loops:
        wind, phase, mag, near = _steps(np.asarray(l, complex))
        b = (wind > slack * WINDING_STEP_DEG) | (near & ((phase > slack * PHASE_STEP_DEG)
                                                          | (mag > slack * MAGNITUDE_STEP_DB)))
        bad = b if bad is None else bad | b
    return bad


def _describe(f: np.ndarray, loops: Sequence[np.ndarray], i: int) -> str:
    l = np.asarray(loops[0], complex)
    for cand in loops:
        wind, *_ = _steps(np.asarray(cand, complex)[i:i + 2])
        if wind[0] > WINDING_STEP_DEG:
            l = np.asarray(cand, complex)
    wind, phase, mag, _ = _steps(l[i:i + 2])
    return (f"between {f[i]:.6g} and {f[i + 1]:.6g} Hz the loop's phase changes by {phase[0]:.0f} deg, its magnitude "
            f"by {mag[0]:.1f} dB and the angle of 1 + L by {wind[0]:.0f} deg")


def check_samples(freq_hz: np.ndarray, loops: Sequence[np.ndarray]) -> None:
    """Refuse samples that do not resolve the loops (module docstring; rules relaxed by :data:`SAMPLE_SLACK`).

    Raises
    ------
    ResolutionError
        Naming the first unresolved interval.
    """
    f = np.asarray(freq_hz, float)
    bad = unresolved(loops, SAMPLE_SLACK)
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise ResolutionError(
            f"the frequency grid does not resolve the loop: {_describe(f, loops, i)}; evaluate the loop on a finer "
            "grid or pass a function that evaluates it anywhere (evaluate=)")


# ------------------------------------------------------------------------------------------ refinement
def _merge(f: np.ndarray, R: np.ndarray, fn: np.ndarray, Rn: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    fa = np.r_[f, fn]
    order = np.argsort(fa, kind="stable")
    fa = fa[order]
    Ra = np.concatenate([R, Rn], axis=-1)[..., order]
    keep = np.r_[True, np.diff(fa) > 0]
    return fa[keep], Ra[..., keep]


def _split(f: np.ndarray, intervals: np.ndarray, n: int) -> np.ndarray:
    lo, hi = np.log(f[intervals]), np.log(f[intervals + 1])
    t = np.arange(1, n + 1) / (n + 1)
    return np.exp(lo[:, None] + (hi - lo)[:, None] * t[None, :]).ravel()


def resolve(freq_hz, evaluate: Callable[[np.ndarray], np.ndarray],
            loops: Callable[[np.ndarray], Sequence[np.ndarray]], features=None,
            known: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Grid and response on which the loops are resolved (module docstring).

    Parameters
    ----------
    freq_hz : array_like
        Base grid [Hz] (strictly increasing); its ends are the ends of the result.
    evaluate : callable
        ``evaluate(f)`` -> the response on ``f`` [Hz], frequency on the last axis.
    loops : callable
        ``loops(R)`` -> the scalar loops (complex arrays over frequency) to keep resolved, from a response block.
    features : array_like, shape (k, 2), optional
        Lightly damped roots of the exact parts (:func:`lightly_damped`).
    known : ndarray, optional
        ``evaluate(freq_hz)`` when the caller has it already (not evaluated again).

    Returns
    -------
    (ndarray, ndarray)
        The grid [Hz] and the response on it.

    Raises
    ------
    ResolutionError
        When the loop stays unresolved after :data:`MAX_ROUNDS` rounds.
    """
    f = np.asarray(freq_hz, float)
    extra = feature_points(features if features is not None else np.empty((0, 2)), f[0], f[-1])
    R = evaluate(f) if known is None else np.asarray(known)
    if extra.size:
        f, R = _merge(f, R, extra, evaluate(extra))
    for _ in range(MAX_ROUNDS + 1):
        bad = unresolved(loops(R))
        if not bad.any():
            return f, R
        split = bad & (f[1:] > f[:-1] * (1 + 1e-12))
        if not split.any() or _ == MAX_ROUNDS:
            break
        fn = _split(f, np.flatnonzero(split), SPLIT)
        f, R = _merge(f, R, fn, evaluate(fn))
    i = int(np.flatnonzero(bad)[0])
    raise ResolutionError(f"the loop cannot be resolved: {_describe(f, loops(R), i)} (it passes through or next to "
                          "-1 there)")


def root_rounds(f_lo: np.ndarray, f_hi: np.ndarray, rounds: int = 3, m: int = 16):
    """:func:`refine_roots` as a generator, for callers that evaluate several refinements in one call per round
    (:mod:`feedtune.analysis.mimo`): yields ``(frequencies [Hz], bracket of each)`` and is sent the real function's
    values there; returns the roots [Hz]. :func:`drive` runs it with one function."""
    lo = np.log(np.asarray(f_lo, float))
    hi = np.log(np.asarray(f_hi, float))
    if lo.size == 0:
        return np.empty(0)
    t = np.linspace(0.0, 1.0, m + 2)
    rows = np.arange(lo.size)
    per_point = np.repeat(rows, m + 2)
    for _ in range(rounds):
        x = lo[:, None] + (hi - lo)[:, None] * t[None, :]
        y = np.asarray((yield np.exp(x.ravel()), per_point)).reshape(x.shape)
        s = np.signbit(y)
        change = s[:, :-1] != s[:, 1:]
        j = np.where(change.any(axis=1), np.argmax(change, axis=1), 0)
        lo, hi = x[rows, j], x[rows, j + 1]
    ylo = np.asarray((yield np.exp(lo), rows))
    yhi = np.asarray((yield np.exp(hi), rows))
    with np.errstate(divide="ignore", invalid="ignore"):
        frac = np.where(ylo != yhi, ylo / (ylo - yhi), 0.5)
    return np.exp(lo + np.clip(frac, 0.0, 1.0) * (hi - lo))


def peak_rounds(f_lo: np.ndarray, f_hi: np.ndarray, rounds: int = 4, m: int = 16):
    """:func:`refine_peaks` as a generator (see :func:`root_rounds`): returns the frequencies [Hz] and values of the
    maxima."""
    lo = np.log(np.asarray(f_lo, float))
    hi = np.log(np.asarray(f_hi, float))
    if lo.size == 0:
        return np.empty(0), np.empty(0)
    t = np.linspace(0.0, 1.0, m + 2)
    rows = np.arange(lo.size)
    per_point = np.repeat(rows, m + 2)
    for _ in range(rounds):
        x = lo[:, None] + (hi - lo)[:, None] * t[None, :]
        y = np.asarray((yield np.exp(x.ravel()), per_point)).reshape(x.shape)
        j = np.argmax(y, axis=1)
        lo, hi = x[rows, np.maximum(j - 1, 0)], x[rows, np.minimum(j + 1, m + 1)]
    x = lo[:, None] + (hi - lo)[:, None] * t[None, :]
    y = np.asarray((yield np.exp(x.ravel()), per_point)).reshape(x.shape)
    j = np.argmax(y, axis=1)
    return np.exp(x[rows, j]), y[rows, j]


def drive(rounds, fn: Callable[[np.ndarray], np.ndarray]):
    """Run a :func:`root_rounds` or :func:`peak_rounds` generator with ``fn(f)`` (one call per round); its result."""
    try:
        f, _ = next(rounds)
        while True:
            f, _ = rounds.send(fn(f))
    except StopIteration as stop:
        return stop.value


def refine_roots(fn: Callable[[np.ndarray], np.ndarray], f_lo: np.ndarray, f_hi: np.ndarray,
                 rounds: int = 3, m: int = 16) -> np.ndarray:
    """Frequencies [Hz] where the real function ``fn`` changes sign, one per bracket ``[f_lo, f_hi]``.

    Every round evaluates ``m`` log-spaced interior points of all brackets in one call and keeps the first sub-bracket
    with a sign change; the root is finally interpolated linearly in log frequency (:func:`root_rounds`).
    """
    return drive(root_rounds(f_lo, f_hi, rounds, m), fn)


def refine_peaks(fn: Callable[[np.ndarray], np.ndarray], f_lo: np.ndarray, f_hi: np.ndarray,
                 rounds: int = 4, m: int = 16) -> tuple[np.ndarray, np.ndarray]:
    """Local maxima of the real function ``fn`` inside the brackets ``[f_lo, f_hi]``: frequencies [Hz] and values
    (:func:`peak_rounds`)."""
    return drive(peak_rounds(f_lo, f_hi, rounds, m), fn)


# ------------------------------------------------------------------------------------------ measured parts
INTERPOLATION = "log magnitude and unwrapped phase, linear in log frequency, between the FRF's lines"
"""How a measured response is evaluated between its lines (stated in the analysis output)."""
INTERPOLATION_TABLE_AFTER = 8
"""After this many requests, :class:`LineNoise` computes the scatter of every line at once and
:func:`interpolate_frf` every block of its tables (a search asks thousands of times; one analysis, a handful); both
ways give the same values, bit for bit."""


TABLE_BLOCK = 1024
"""Lines per block of the tables that the measured parts compute on first use (:func:`interpolate_frf`,
:class:`LineNoise`): a block is always computed whole, from the same lines, so that a value never depends on what
was asked before (numpy's vectorised log and angle may differ in the last bit between arrays of different lengths
or alignments), and a few refinement points cost a few blocks, not the whole FRF."""


def _blocks(cache: dict, n_lines: int, make: Callable[[int, int], np.ndarray], index: np.ndarray,
            next_line: bool = False, block: int = TABLE_BLOCK) -> tuple[np.ndarray, ...]:
    """Columns ``index`` (and with ``next_line`` also ``index + 1``) of a table over ``n_lines`` lines that is computed
    in blocks of ``block`` lines on first use (kept in ``cache``): ``make(start, stop)`` gives the table's columns for
    the lines ``start .. stop - 1``. With ``next_line`` each block holds one line more, so that both ends of an
    interval come from the block of its first line."""
    idx = np.asarray(index, int)
    blocks = idx // block
    if not blocks.size:
        keys = []
    elif blocks.min() == blocks.max():
        keys = [int(blocks[0])]
    else:
        keys = np.unique(blocks).tolist()
    for b in keys:
        if b not in cache:
            start = b * block
            cache[b] = make(start, min(start + block + int(next_line), n_lines))
    offsets = (0, 1) if next_line else (0,)
    if len(keys) == 1:
        j = idx - keys[0] * block
        return tuple(cache[keys[0]][..., j + o] for o in offsets)
    out = None
    for b in keys:
        sel = blocks == b
        j = idx[sel] - b * block
        parts = [cache[b][..., j + o] for o in offsets]
        if out is None:
            out = tuple(np.empty(parts[0].shape[:-1] + idx.shape, parts[0].dtype) for _ in offsets)
        for o, part in zip(out, parts, strict=True):
            o[..., sel] = part
    if out is None:  # no index
        empty = make(0, min(2, n_lines))[..., :0]
        return tuple(empty for _ in offsets)
    return out


def interpolate_frf(freq_hz: np.ndarray, response: np.ndarray) -> Callable[[np.ndarray], np.ndarray]:
    """A function evaluating the measured ``response`` (last axis over ``freq_hz`` [Hz] > 0) between its lines.

    :data:`INTERPOLATION`; exact on the lines (asked for the lines themselves, it returns the measured values
    without interpolating). Frequencies outside the lines are clamped to the end values. A point between lines ``i``
    and ``i + 1`` is interpolated from those two lines alone, the phase step between them wrapped as
    :func:`numpy.unwrap` wraps it (the unwrapped phase of the whole FRF differs from it by a multiple of ``2 pi``
    only); the lines' log frequencies, log magnitudes, angles and phase steps are tabulated in blocks of
    :data:`TABLE_BLOCK` lines where points are asked for. ``response`` is referenced, not copied: it must not be
    modified afterwards.
    """
    f = np.asarray(freq_hz, float)
    h = np.asarray(response, complex)
    shape = h.shape[:-1]
    h2 = h.reshape(-1, f.size)
    n, ch = f.size, h2.shape[0]
    tables: dict = {}
    state: dict = {"calls": 0, "stack": None}

    def wrapped(d: np.ndarray) -> np.ndarray:
        big = np.abs(d) >= np.pi  # np.unwrap's rule: only steps of at least pi are wrapped
        if big.any():
            dm = np.mod(d[big] + np.pi, 2 * np.pi) - np.pi
            dm[(dm == -np.pi) & (d[big] > 0)] = np.pi
            d[big] = dm
        return d

    def make(start: int, stop: int) -> np.ndarray:
        # rows: log frequency, log magnitude of each channel, angle of each channel, wrapped angle step to the next
        # line of each channel (0 after the block's last line)
        hb = h2[:, start:stop]
        out = np.zeros((1 + 3 * ch, stop - start))
        out[0] = np.log(f[start:stop])
        with np.errstate(divide="ignore"):
            out[1:1 + ch] = np.log(np.maximum(np.abs(hb), 1e-300))
        pa = out[1 + ch:1 + 2 * ch]
        pa[...] = np.angle(hb)
        out[1 + 2 * ch:, :-1] = wrapped(np.diff(pa, axis=-1))
        return out

    def evaluate(fq: np.ndarray) -> np.ndarray:
        fq = np.asarray(fq, float)
        if fq.shape == f.shape and (fq is f or np.array_equal(fq, f)):
            return h.copy()
        fc = np.minimum(np.maximum(fq.ravel(), f[0]), f[-1])
        x = np.log(fc)
        # the interval of each point (by frequency: the log is monotonic); both its ends from the same block
        i = np.searchsorted(f, fc) - 1
        np.minimum(np.maximum(i, 0), n - 2, out=i)
        state["calls"] += 1
        if state["stack"] is None and state["calls"] > INTERPOLATION_TABLE_AFTER:
            # asked often (a search): every block, stacked, read with one gather (the same blocks' values)
            nb = (n - 2) // TABLE_BLOCK + 1
            stack = np.zeros((nb, 1 + 3 * ch, TABLE_BLOCK + 1))
            for k in range(nb):
                blk = tables.get(k)
                if blk is None:
                    start = k * TABLE_BLOCK
                    blk = make(start, min(start + TABLE_BLOCK + 1, n))
                stack[k, :, :blk.shape[1]] = blk
            tables.clear()
            state["stack"] = stack
        if state["stack"] is not None:
            k, j = np.divmod(i, TABLE_BLOCK)
            a, b = state["stack"][k, :, j].T, state["stack"][k, :, j + 1].T
        else:
            a, b = _blocks(tables, n, make, i, next_line=True)
        t = (x - a[0]) / (b[0] - a[0])
        la, lb, p0, d = a[1:1 + ch], b[1:1 + ch], a[1 + ch:1 + 2 * ch], a[1 + 2 * ch:]
        mag = np.exp(la + t * (lb - la))
        ph = p0 + t * d
        out = np.empty(mag.shape, complex)  # exp(m + j p) from the real exponential, cosine and sine (faster)
        np.cos(ph, out=out.real)
        np.sin(ph, out=out.imag)
        out.real *= mag
        out.imag *= mag
        return out.reshape(*shape, fq.size)

    evaluate.fresh = True  # every call returns a new array
    evaluate.lines = (f, h)  # the lines and the measured values on them (read only)
    return evaluate


class LineNoise:
    """:func:`noise_db` of a measured response, computed per line on first use (array-like).

    The analysis reads the scatter only where crossings cluster and at the edges of ``|S| < 1`` bands, a few dozen
    lines of thousands: :meth:`lines` computes just those (the same arithmetic, hence the same values, as the whole
    array). ``numpy.asarray(noise)`` gives the whole array (computed once), so a :class:`LineNoise` stands wherever a
    ``noise_db`` array is accepted.

    Parameters
    ----------
    freq_hz : ndarray, shape (n,)
        The lines [Hz].
    response : ndarray, shape (..., n)
        The measured response (referenced, not copied).
    coherence : ndarray, optional
        Coherence of the channels (same shape as ``response``).
    half_window : int
        Half width of the running median [lines].
    averages : float, optional
        Averages of the estimate (:func:`~feedtune.frf_quality.averages_of`) for the coherence's error floor.
    """

    def __init__(self, freq_hz: np.ndarray, response: np.ndarray, coherence: np.ndarray | None = None,
                 half_window: int = 10, averages: float | None = None) -> None:
        self.freq_hz = np.asarray(freq_hz, float)
        self.averages = None if not averages else float(averages)
        self._h = np.asarray(response, complex).reshape(-1, self.freq_hz.size)
        self._coherence = None if coherence is None else np.asarray(coherence, float).reshape(-1, self.freq_hz.size)
        self._half = int(half_window)
        self._full: np.ndarray | None = None
        self._db: dict = {}  # blocks of the dB magnitude and of the coherence floor (:func:`_blocks`)
        self._coherence_db: dict = {}
        self._asked = 0

    @property
    def size(self) -> int:
        """Number of lines."""
        return int(self.freq_hz.size)

    @property
    def shape(self) -> tuple[int]:
        """``(n,)``."""
        return (self.size,)

    def __len__(self) -> int:
        return self.size

    def full(self) -> np.ndarray:
        """The scatter [dB] on every line (:func:`noise_db`), computed once."""
        if self._full is None:
            self._full = noise_db(self.freq_hz, self._h, self._coherence, self._half, self.averages)
            self._full.setflags(write=False)
        return self._full

    def line_axis(self) -> np.ndarray:
        """The axis the roughness is read on (:func:`~feedtune.frf_quality.line_axis`; computed once)."""
        ax = self.__dict__.get("_line_axis")
        if ax is None:
            ax = self.__dict__["_line_axis"] = line_axis(self.freq_hz, self.log_freq())
        return ax

    def log_freq(self) -> np.ndarray:
        """``log(freq_hz)`` of the lines (computed once; read only)."""
        lf = self.__dict__.get("_log_freq")
        if lf is None:
            lf = self.__dict__["_log_freq"] = np.log(self.freq_hz)
            lf.setflags(write=False)
        return lf

    def __array__(self, dtype=None, copy=None):
        out = self.full()
        return out.astype(dtype) if dtype is not None and np.dtype(dtype) != out.dtype else out.copy()

    def lines(self, index: np.ndarray) -> np.ndarray:
        """The scatter [dB] on the lines ``index`` (integers in ``[0, n)``)."""
        idx = np.asarray(index, int)
        self._asked += 1
        if self._full is None and (idx.size > self.size // 8 or self._asked > INTERPOLATION_TABLE_AFTER):
            self.full()  # most of the lines, or asked often (a search): the whole array once
        if self._full is not None or idx.size == 0:
            return self.full()[idx] if idx.size else np.empty(0)
        n, hw = self.size, self._half
        h = self._h

        def db_at(lines: np.ndarray) -> np.ndarray:  # the same dB values as the whole array's (bit for bit)
            return _blocks(self._db, n, lambda a, b: _db_rows(h[:, a:b]), lines, block=NOISE_BLOCK)[0]

        out = np.zeros(idx.shape)
        k = ROUGHNESS_STENCIL
        if n >= k:
            # the roughness d2[q] (line_residuals) of the dB magnitude at the lines q + k // 2, padded with the edge
            # values (index p of the padded row is d2[clip(p - k // 2, 0, n - k)]); median over the window, clamped at
            # the ends
            win = np.minimum(np.maximum(idx[..., None] + np.arange(-hw, hw + 1), 0), n - 1)
            q = np.minimum(np.maximum(win - k // 2, 0), n - k)
            q_lo, q_hi = int(q.min()), int(q.max())
            axis = self.line_axis()
            if q_hi - q_lo < 4 * q.size:  # the windows cover one stretch of lines: its roughness
                db = db_at(np.arange(q_lo, q_hi + k))
                x = axis[q_lo:q_hi + k]
                m = q_hi - q_lo + 1
                d2 = line_residuals([db[:, j:j + m] for j in range(k)], [x[j:j + m] for j in range(k)])
                vals = d2[:, q - q_lo]
            else:
                need = np.unique(q)
                lines = np.unique((need[:, None] + np.arange(k)).ravel())
                db = db_at(lines)
                pos = np.searchsorted(lines, need)
                d2 = line_residuals([db[:, pos + j] for j in range(k)], [axis[need + j] for j in range(k)])
                vals = d2[:, np.searchsorted(need, q)]  # rows x idx... x window
            med = np.partition(vals, hw, axis=-1)[..., hw]  # the median of the 2 hw + 1 values (numpy.median's)
            out = np.max(med, axis=0) / (0.6745 * np.sqrt(6.0))
        if self._coherence is not None:
            g = self._coherence
            floor = _blocks(self._coherence_db, n, lambda a, b: _coherence_floor_db(g[:, a:b], self.averages), idx,
                            block=NOISE_BLOCK)
            out = np.maximum(out, floor[0])
        return out
