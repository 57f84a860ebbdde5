"""Crossings, bands, peaks and disk margins of responses on a frequency grid, refined where a function is given.

Every function takes samples ``y`` on a strictly increasing grid ``freq_hz`` [Hz]; with ``fn`` (the same quantity
as a function of frequency) the grid result is refined by :func:`~feedtune.analysis.resolution.refine_roots` or
:func:`~feedtune.analysis.resolution.refine_peaks`, otherwise interpolated linearly in log frequency.

Disk margins (balanced, skew 0; Blight, Dailey and Gangsaas 1994; Seiler, Packard and Gahinet 2020, as python-control's
``disk_margins``): ``alpha = 1 / max_w |S - 1/2|`` for a SISO loop (``1 / max_w sigma_max(S - I/2)`` for a 2x2 loop,
the unstructured bound: no smaller than the loop-at-a-time structured one). The loop stays stable for every
simultaneous gain ``g`` and phase ``phi`` change inside the disk, in particular for gains in
``[(2 - alpha)/(2 + alpha), (2 + alpha)/(2 - alpha)]`` (the disk gain margin ``20 log10((2 + alpha)/(2 - alpha))``
dB) and phases up to ``2 atan(alpha / 2)`` (the disk phase margin, deg).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from .resolution import refine_peaks, refine_roots

Fn = Callable[[np.ndarray], np.ndarray] | None

CHATTER_REL = 0.03
"""Crossings closer than this relative frequency [-] form a cluster that may be measurement chatter."""
CHATTER_SIGMAS = 2.0
"""A cluster is merged when ``|L|`` stays within this many noise sigmas of 0 dB between its crossings [-]."""
PROOF_SIGMAS = CHATTER_SIGMAS
"""A margin measured on an FRF's lines meets its limit only when it does so by this many of its 1-sigma line
scatters (:func:`line_scatter_at`); within them the lines neither prove nor disprove it [-]."""


def crossings(freq_hz: np.ndarray, y: np.ndarray, level: float = 0.0, fn: Fn = None) -> np.ndarray:
    """Frequencies [Hz] where ``y`` crosses ``level`` (refined with ``fn`` when given)."""
    f = np.asarray(freq_hz, float)
    d = np.asarray(y, float) - level
    idx = np.flatnonzero(np.signbit(d[:-1]) != np.signbit(d[1:]))
    if idx.size == 0:
        return np.empty(0)
    if fn is not None:
        return refine_roots(lambda fq: fn(fq) - level, f[idx], f[idx + 1])
    lf = np.log(np.maximum(f, 1e-300))
    frac = d[idx] / (d[idx] - d[idx + 1])
    return np.exp(lf[idx] + frac * (lf[idx + 1] - lf[idx]))


def level_bands(freq_hz, y, level: float = 1.0, fn: Fn = None) -> list[list[float]]:
    """Intervals [Hz] where ``y > level``; edges interpolated in log frequency and log ``y`` (or refined by ``fn``)."""
    f = np.asarray(freq_hz, float)
    d = np.log(np.maximum(np.asarray(y, float), 1e-300)) - np.log(level)
    m = d > 0
    if not m.any():
        return []
    idx = np.flatnonzero(m[:-1] != m[1:])
    if fn is not None and idx.size:
        edges = refine_roots(lambda fq: np.log(np.maximum(fn(fq), 1e-300)) - np.log(level), f[idx], f[idx + 1])
    else:
        lf = np.log(np.maximum(f, 1e-300))
        with np.errstate(divide="ignore", invalid="ignore"):
            frac = np.clip(np.nan_to_num(d[idx] / (d[idx] - d[idx + 1]), nan=0.5), 0.0, 1.0)
        edges = np.exp(lf[idx] + frac * (lf[idx + 1] - lf[idx]))
    rising = m[idx + 1]
    starts = [float(x) for x in edges[rising]]
    ends = [float(x) for x in edges[~rising]]
    if m[0]:
        starts.insert(0, float(f[0]))
    if m[-1]:
        ends.append(float(f[-1]))
    return [[a, b] for a, b in zip(starts, ends, strict=True)]


def peak(freq_hz: np.ndarray, y: np.ndarray, fn: Fn = None, near: float = 0.9) -> tuple[float, float]:
    """Largest value of ``y`` and its frequency ``(f [Hz], y)``; with ``fn`` every local maximum above ``near``
    times the grid's maximum is refined and the largest refined one returned."""
    f = np.asarray(freq_hz, float)
    y = np.asarray(y, float)
    i = int(np.argmax(y))
    if fn is None or f.size < 3:
        return float(f[i]), float(y[i])
    inner = np.flatnonzero((y[1:-1] >= y[:-2]) & (y[1:-1] >= y[2:]) & (y[1:-1] >= near * y[i])) + 1
    if inner.size == 0:
        return float(f[i]), float(y[i])
    fp, yp = refine_peaks(fn, f[inner - 1], f[inner + 1])
    k = int(np.argmax(yp))
    if yp[k] >= y[i]:
        return float(fp[k]), float(yp[k])
    return float(f[i]), float(y[i])


def disk_margins(alpha: float) -> tuple[float, float]:
    """Disk gain margin [dB] and disk phase margin [deg] of a balanced disk margin ``alpha`` [-] (module docstring)."""
    if not np.isfinite(alpha) or alpha >= 2:
        return float("inf"), 90.0
    return float(20 * np.log10((2 + alpha) / (2 - alpha))), float(np.degrees(2 * np.arctan(alpha / 2)))


@dataclass(frozen=True)
class ClusterEvidence:
    """What a cluster of crossings rests on (:func:`settle_clusters`).

    Attributes
    ----------
    excursion : float
        Largest ``|deviation|`` of the crossing quantity from its level between the first and the last crossing
        (dB for crossovers, deg for phase crossovers).
    scatter : float
        Largest 1-sigma measurement scatter there (same unit).
    smooth : str or None
        The verdict of a smooth fit of the FRF's lines around the cluster (:func:`smooth_verdict`): ``"excludes"``
        (the fit stays on the side of the cluster's ends, more than :data:`CHATTER_SIGMAS` standard errors from the
        level, over the whole cluster: the plant does not cross there), ``"confirms"`` (the fit crosses),
        ``"undecided"``, or None (too few lines for a fit).
    """

    excursion: float
    scatter: float
    smooth: str | None = None


SMOOTH_LINES = 10
"""Lines on each side of a cluster that the smooth fit of :func:`smooth_verdict` takes at most besides the cluster's
own."""
SMOOTH_WINDOWS = (10, 7, 5, 3)
"""Half widths [lines] of the windows :func:`smooth_verdict` tries, widest first."""
SMOOTH_AGREE = 2
"""Windows (the widest that describe their lines) whose fits must all exclude a crossing for :func:`smooth_verdict` to
exclude it [-]."""
SMOOTH_MAX_CHI2 = 2.0
"""A smooth fit whose reduced chi-square exceeds this [-] does not describe the lines: a narrower window is tried."""


def smooth_verdict(x: np.ndarray, y: np.ndarray, sigma: np.ndarray, lo: float, hi: float, side: float
                   ) -> str | None:
    """Whether the lines ``(x, y)`` (``x`` log frequency, increasing; ``y`` the deviation from the level, 1-sigma
    scatter ``sigma``) show ``y`` crossing 0 between ``lo`` and ``hi`` (log frequency) or staying on ``side`` (+1 or
    -1).

    A quadratic in ``x`` is fitted by weighted least squares to the lines from :data:`SMOOTH_WINDOWS` lines below
    ``lo`` to as many above ``hi``, the widest window whose fit describes its lines (reduced chi-square at most
    :data:`SMOOTH_MAX_CHI2`: the curve is smooth at that scale) first. The fit and its standard error are evaluated
    over ``[lo, hi]``: ``"excludes"`` when ``side * fit > CHATTER_SIGMAS * error`` everywhere there in each of the
    :data:`SMOOTH_AGREE` widest windows whose fits describe their lines (a wide window's quadratic may pass over a
    narrow dip the plant has, a mode's notch: the next narrower window must agree), ``"confirms"`` when the widest
    such fit reaches the other side, else ``"undecided"`` (also when no window's fit describes its lines). None with
    fewer than 6 lines.
    """
    x, y = np.asarray(x, float), np.asarray(y, float)
    s = np.maximum(np.asarray(sigma, float), 1e-12)
    ok = np.isfinite(x) & np.isfinite(y) & np.isfinite(s)
    x, y, s = x[ok], y[ok], s[ok]
    if x.size < 6:
        return None
    i0 = int(np.searchsorted(x, lo, "left"))
    i1 = int(np.searchsorted(x, hi, "right"))
    xe = np.linspace(lo, hi, 9)
    verdicts = []
    for half in SMOOTH_WINDOWS:
        a, b = max(i0 - half, 0), min(i1 + half, x.size)
        if b - a < 6:
            continue
        xw, yw, sw = x[a:b], y[a:b], s[a:b]
        mid, scale = 0.5 * (xw[0] + xw[-1]), max(0.5 * (xw[-1] - xw[0]), 1e-12)
        A = np.vander((xw - mid) / scale, 3) / sw[:, None]
        coef, *_ = np.linalg.lstsq(A, yw / sw, rcond=None)
        chi2 = float(np.sum((A @ coef - yw / sw) ** 2) / max(xw.size - 3, 1))
        if not chi2 <= SMOOTH_MAX_CHI2:
            continue
        cov = np.linalg.pinv(A.T @ A) * max(chi2, 1.0)
        X = np.vander((xe - mid) / scale, 3)
        fit = X @ coef
        err = np.sqrt(np.maximum(np.einsum("ij,jk,ik->i", X, cov, X), 0.0))
        if np.all(side * fit > CHATTER_SIGMAS * err):
            verdicts.append("excludes")
        else:
            verdicts.append("confirms" if np.any(side * fit < 0) else "undecided")
    if not verdicts:
        return "undecided"
    if all(v == "excludes" for v in verdicts[:SMOOTH_AGREE]):
        return "excludes"
    return verdicts[0] if verdicts[0] != "excludes" else "undecided"


def merge_chatter(crossings_hz: np.ndarray, values, freq_hz: np.ndarray, deviation: np.ndarray,
                  noise: np.ndarray | None, what: str = "crossovers", unit: str = "dB",
                  lines: np.ndarray | None = None) -> tuple[np.ndarray, list, list[dict]]:
    """:func:`settle_clusters` of crossings of a loop sampled on ``freq_hz`` (kept crossings [Hz], their margins,
    the merged clusters' records).

    ``deviation`` is the crossing quantity on ``freq_hz`` (``20 log10 |L|`` [dB] for crossovers, the angle of ``-L``
    [deg] for phase crossovers), ``noise`` its measured 1-sigma scatter (same unit; None: not measured, nothing is
    merged), ``values`` the margins at the crossings and ``lines`` the points of ``freq_hz`` that are an FRF's lines
    (boolean mask; default: every point), the data of the smooth fit.
    """
    wc = np.asarray(crossings_hz, float)
    values = list(values)
    if noise is None or wc.size < 2:
        return wc, values, []
    f = np.asarray(freq_hz, float)
    dev = np.asarray(deviation, float)
    sig = np.asarray(noise, float)
    line_idx = np.flatnonzero(np.ones(f.size, bool) if lines is None else lines)

    def measure(c: list[float]) -> ClusterEvidence:
        sel = (f >= c[0]) & (f <= c[-1])
        excursion = float(np.max(np.abs(dev[sel]))) if sel.any() else 0.0
        sigma = float(np.max(sig[sel])) if sel.any() else float(np.interp(c[0], f, sig))
        return ClusterEvidence(excursion, sigma, _smooth_of(f, dev, sig, line_idx, c))

    return settle_clusters(wc, values, measure, what, unit)


def _smooth_of(f: np.ndarray, dev: np.ndarray, sig: np.ndarray, line_idx: np.ndarray, c: list[float]
               ) -> str | None:
    """:func:`smooth_verdict` of the cluster ``c`` [Hz] from the lines ``line_idx`` of the contour ``f`` (deviation
    ``dev`` and scatter ``sig`` on it): :data:`SMOOTH_LINES` lines on each side; the side is that of the contour's
    point below the cluster."""
    lf = f[line_idx]
    j0 = max(int(np.searchsorted(lf, c[0], "left")) - SMOOTH_LINES, 0)
    j1 = min(int(np.searchsorted(lf, c[-1], "right")) + SMOOTH_LINES, lf.size)
    pick = line_idx[j0:j1]
    below = max(int(np.searchsorted(f, c[0], "left")) - 1, 0)
    side = 1.0 if dev[below] >= 0 else -1.0
    return smooth_verdict(np.log(f[pick]), dev[pick], sig[pick], float(np.log(c[0])), float(np.log(c[-1])), side)


def settle_clusters(crossings_hz: np.ndarray, values, measure: Callable[[list[float]], ClusterEvidence], what: str,
                    unit: str) -> tuple[np.ndarray, list, list[dict]]:
    """Settle the clusters of sorted crossings [Hz] that measurement scatter may have made (one home for the rule).

    Crossings closer than :data:`CHATTER_REL` to their neighbour form a cluster; ``measure(cluster)`` gives its
    :class:`ClusterEvidence`, ``values`` are the margins at the crossings (phase margins [deg] or gain margins [dB]).
    A cluster whose excursion exceeds :data:`CHATTER_SIGMAS` times the scatter is real: every crossing is kept.
    Otherwise the scatter explains it, and

    * an odd cluster (one net crossing, place unknown within the cluster) is one crossing: at its first member's
      frequency (the lowest the plant may cross at: a bandwidth read from it is never claimed past the plant's) with
      the worst of the members' margins (closest to 0), recorded in the merged list;
    * an even cluster (a touch: the loop comes to the level and goes back, or dips through it) is dropped only when
      the smooth fit of the lines around it excludes a crossing (``smooth == "excludes"``): a dip the plant has is
      kept whenever the lines cannot rule it out. A dropped cluster is recorded with the margins it held.

    Returns the kept crossings [Hz], their margins and the records (``of``, ``freq_hz``, ``margins``, ``kept_hz``,
    ``kept_margin``, ``worst_at_hz``, ``excursion``, ``scatter``, ``smooth``, ``unit``).
    """
    wc = np.asarray(crossings_hz, float)
    values = [float(v) for v in values]
    if wc.size < 2:
        return wc, values, []
    clusters, cur = [], [0]
    for i in range(1, wc.size):  # a handful of crossings
        if wc[i] <= wc[cur[-1]] * (1 + CHATTER_REL):
            cur.append(i)
        else:
            clusters.append(cur)
            cur = [i]
    clusters.append(cur)
    kept_f: list[float] = []
    kept_v: list[float] = []
    merged: list[dict] = []
    for c in clusters:
        freqs, vals = [float(wc[i]) for i in c], [values[i] for i in c]
        if len(c) == 1:
            kept_f.append(freqs[0])
            kept_v.append(vals[0])
            continue
        ev = measure(freqs)
        if ev.excursion > CHATTER_SIGMAS * ev.scatter or (len(c) % 2 == 0 and ev.smooth != "excludes"):
            kept_f.extend(freqs)
            kept_v.extend(vals)
            continue
        k = min(range(len(vals)), key=lambda j: abs(vals[j]))  # the worst member
        record = {"of": what, "freq_hz": freqs, "margins": vals, "excursion": ev.excursion, "scatter": ev.scatter,
                  "smooth": ev.smooth, "unit": unit, "worst_at_hz": freqs[k]}
        if len(c) % 2:
            kept_f.append(freqs[0])
            kept_v.append(vals[k])
            record |= {"kept_hz": freqs[0], "kept_margin": vals[k]}
        else:
            record |= {"kept_hz": None, "kept_margin": None}
        merged.append(record)
    return np.array(kept_f, float), kept_v, merged


NEAR_CHUNK = 4096
"""Lines scanned at a time by :func:`near_misses` (its memory does not grow with the FRF)."""


def near_misses(lines_hz: np.ndarray, deviation_at: Callable[[np.ndarray], np.ndarray],
                sigma_at: Callable[[np.ndarray], np.ndarray], crossings_hz, bound: float) -> list[dict]:
    """Where the measured loop comes to the level within its scatter without crossing it, and the lines cannot rule
    out that the plant crosses there (a dip the noise hid).

    ``deviation_at(index)`` is the crossing quantity at the FRF's lines ``lines_hz[index]`` [Hz] (``20 log10 |L|``
    [dB], or the angle of ``-L`` [deg]) and ``sigma_at(index)`` its 1-sigma scatter there; ``bound`` bounds
    :data:`CHATTER_SIGMAS` times the scatter of any line judged (lines farther from the level are not looked at
    again). Every run of lines within :data:`CHATTER_SIGMAS` sigma of the level that holds no crossing (none within
    :data:`CHATTER_REL` of it) is a candidate at its line closest to the level; :func:`smooth_verdict` of the lines
    around that line decides: unless the fit excludes a crossing there, it is a possible crossing. ``crossings_hz``
    are the crossings kept and those of the clusters already settled (a run around them is decided). Returns
    ``[{"index", "freq_hz", "gap", "scatter", "smooth"}]`` (``index`` into the lines).
    """
    f = np.asarray(lines_hz, float)
    n = f.size
    cand = [k + np.flatnonzero(np.abs(deviation_at(np.arange(k, min(k + NEAR_CHUNK, n)))) <= bound)
            for k in range(0, n, NEAR_CHUNK)]
    idx = np.concatenate(cand) if cand else np.empty(0, int)
    if idx.size == 0:
        return []
    near = idx[np.abs(deviation_at(idx)) <= CHATTER_SIGMAS * np.asarray(sigma_at(idx), float)]
    if near.size == 0:
        return []
    x = np.asarray(crossings_hz, float)
    breaks = np.flatnonzero(np.diff(near) != 1) + 1
    out = []
    for run in np.split(near, breaks):  # runs of consecutive lines
        a, b = int(run[0]), int(run[-1])
        if x.size and np.any((x >= f[a] / (1 + CHATTER_REL)) & (x <= f[b] * (1 + CHATTER_REL))):
            continue
        k = int(run[np.argmin(np.abs(deviation_at(run)))])
        w = np.arange(max(k - SMOOTH_LINES, 0), min(k + SMOOTH_LINES + 1, n))
        dev, sig = deviation_at(w), np.asarray(sigma_at(w), float)
        side = 1.0 if np.median(dev) >= 0 else -1.0  # the side the loop stays on (not the one line's)
        lf = np.log(f[w])
        j = k - int(w[0])
        verdict = smooth_verdict(lf, dev, sig, lf[max(j - 1, 0)], lf[min(j + 1, w.size - 1)], side)
        if verdict != "excludes":
            out.append({"index": k, "freq_hz": float(f[k]), "gap": float(dev[j]), "scatter": float(sig[j]),
                        "smooth": verdict})
    return out


def prune_bands(bands: list[list[float]], freq_hz: np.ndarray, excess: np.ndarray, sigma: np.ndarray | None
                ) -> list[list[float]]:
    """Drop the bands, and then the gaps between bands, that measurement scatter explains.

    ``excess`` is ``1/|S| - 1`` on ``freq_hz`` (positive inside a ``|S| < 1`` band) and ``sigma`` its scatter (1 sigma,
    same grid): a band whose largest ``excess / sigma`` stays below :data:`CHATTER_SIGMAS` is dropped, and a gap whose
    largest ``-excess / sigma`` does joins its neighbours. Without ``sigma`` (not measured) the bands are returned.
    """
    if sigma is None or not bands:
        return bands
    f = np.asarray(freq_hz, float)
    with np.errstate(over="ignore", divide="ignore"):
        z = np.asarray(excess, float) / np.maximum(np.asarray(sigma, float), 1e-300)

    def strongest(lo, hi, sign):
        sel = (f >= lo) & (f <= hi)
        return float(np.max(sign * z[sel])) if sel.any() else 0.0

    return keep_and_join(bands, strongest)


def keep_and_join(bands: list[list[float]], strongest) -> list[list[float]]:
    """The pruning rule of :func:`prune_bands`, given ``strongest(lo, hi, sign)``, the largest ``sign * excess /
    sigma`` between ``lo`` and ``hi`` [Hz]: bands whose strongest excess stays below :data:`CHATTER_SIGMAS` are
    dropped, then neighbours whose gap's strongest shortfall does are joined."""
    kept = [b for b in bands if strongest(b[0], b[1], 1.0) >= CHATTER_SIGMAS]
    out: list[list[float]] = []
    for b in kept:
        if out and strongest(out[-1][1], b[0], -1.0) < CHATTER_SIGMAS:
            out[-1] = [out[-1][0], b[1]]
        else:
            out.append(list(b))
    return out


NEGLIGIBLE_LOOP = 1e-6
"""Phase crossovers where ``|L|`` is below this [-] (gain margins above 120 dB, e.g. a discrete loop's at ``fs/2``
where it is rounding noise) are not listed."""


def phase_crossovers(freq_hz: np.ndarray, L: np.ndarray, fn: Callable[[np.ndarray], np.ndarray] | None = None
                     ) -> np.ndarray:
    """Frequencies [Hz] where the angle of ``L`` is 180 deg (``Im L`` changes sign with ``Re L < 0``), where
    ``|L| >= NEGLIGIBLE_LOOP``."""
    f = np.asarray(freq_hz, float)
    L = np.asarray(L, complex)
    im = L.imag / np.maximum(np.abs(L), 1e-300)
    big = np.abs(L) >= NEGLIGIBLE_LOOP
    idx = np.flatnonzero((np.signbit(im[:-1]) != np.signbit(im[1:])) & (L.real[:-1] + L.real[1:] < 0)
                         & (big[:-1] | big[1:]))
    if idx.size == 0:
        return np.empty(0)
    if fn is not None:
        def g(fq):
            v = fn(fq)
            return v.imag / np.maximum(np.abs(v), 1e-300)

        return refine_roots(g, f[idx], f[idx + 1])
    frac = im[idx] / (im[idx] - im[idx + 1])
    return np.exp(np.log(f[idx]) + frac * (np.log(f[idx + 1]) - np.log(f[idx])))


def interp_complex(freq_hz: np.ndarray, h: np.ndarray, f0: np.ndarray) -> np.ndarray:
    """``h`` at ``f0`` [Hz] by log magnitude and unwrapped phase, linear in log frequency."""
    lf = np.log(freq_hz)
    mag = np.interp(np.log(f0), lf, np.log(np.maximum(np.abs(h), 1e-300)))
    ph = np.interp(np.log(f0), lf, np.unwrap(np.angle(h)))
    return np.exp(mag + 1j * ph)


def line_scatter_at(lines_hz: np.ndarray, scatter_of: Callable[[np.ndarray], np.ndarray], at_hz, top_hz: float
                    ) -> list[float]:
    """The 1-sigma scatter [dB] of a measured response at the frequencies ``at_hz`` [Hz]: linear in log frequency
    between the two lines around each (``scatter_of(indices)`` of the lines ``lines_hz``, increasing); 0 below the
    first line and above ``top_hz`` (the last line the FRF proves), where the figures rest on the model or the
    fitted roll-off and not on the lines (the assumption is stated by the band edge, not quantified here)."""
    f0 = np.asarray(lines_hz, float)
    at = np.asarray(at_hz, float).ravel()
    out = np.zeros(at.size)
    inside = (at >= f0[0]) & (at <= min(float(top_hz), float(f0[-1])))
    if inside.any():
        x = at[inside]
        j = np.clip(np.searchsorted(f0, x, "right") - 1, 0, max(f0.size - 2, 0))
        k = np.minimum(j + 1, f0.size - 1)
        idx = np.unique(np.r_[j, k])
        sig = np.zeros(f0.size)
        sig[idx] = np.asarray(scatter_of(idx), float)
        lf = np.log(f0)
        t = np.where(k > j, (np.log(x) - lf[j]) / np.where(k > j, lf[k] - lf[j], 1.0), 0.0)
        out[inside] = sig[j] + t * (sig[k] - sig[j])
    return [float(v) for v in out]
