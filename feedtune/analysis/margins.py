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

import numpy as np

from .resolution import refine_peaks, refine_roots

Fn = Callable[[np.ndarray], np.ndarray] | None

CHATTER_REL = 0.03
"""Crossings closer than this relative frequency [-] form a cluster that may be measurement chatter."""
CHATTER_SIGMAS = 2.0
"""A cluster is merged when ``|L|`` stays within this many noise sigmas of 0 dB between its crossings [-]."""


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


def merge_chatter(crossings_hz: np.ndarray, freq_hz: np.ndarray, deviation: np.ndarray, noise: np.ndarray | None,
                  what: str = "crossovers", unit: str = "dB") -> tuple[np.ndarray, list[dict]]:
    """Merge crossing clusters that measurement scatter explains (kept crossings [Hz], merged records).

    Crossings closer than :data:`CHATTER_REL` to their neighbour form a cluster. A cluster is chatter when the crossing
    quantity ``deviation`` (``20 log10 |L|`` [dB] for crossovers, the angle of ``-L`` [deg] for phase crossovers)
    stays between its first and last crossing within :data:`CHATTER_SIGMAS` times the measured scatter ``noise`` (same
    unit; :func:`~feedtune.analysis.resolution.noise_db`) of 0: an odd cluster is then one crossing (its first), an
    even one a touch without a net crossing. Without ``noise`` (a loop that is not measured) nothing is merged.
    """
    wc = np.asarray(crossings_hz, float)
    if noise is None or wc.size < 2:
        return wc, []
    f = np.asarray(freq_hz, float)

    def measure(c: list[float]) -> tuple[float, float]:
        sel = (f >= c[0]) & (f <= c[-1])
        excursion = float(np.max(np.abs(deviation[sel]))) if sel.any() else 0.0
        sigma = float(np.max(noise[sel])) if sel.any() else float(np.interp(c[0], f, noise))
        return excursion, sigma

    return settle_clusters(wc, measure, what, unit)


def settle_clusters(crossings_hz: np.ndarray, measure: Callable[[list[float]], tuple[float, float]], what: str,
                    unit: str) -> tuple[np.ndarray, list[dict]]:
    """The rule of :func:`merge_chatter` on sorted crossings [Hz], ``measure(cluster)`` giving the cluster's
    ``(excursion, scatter)`` in ``unit`` (one home for the clustering and the verdict; the analysis reads the
    deviation and the scatter its own way)."""
    wc = np.asarray(crossings_hz, float)
    clusters, cur = [], [wc[0]]
    for x in wc[1:]:  # a handful of crossings
        if x <= cur[-1] * (1 + CHATTER_REL):
            cur.append(x)
        else:
            clusters.append(cur)
            cur = [x]
    clusters.append(cur)
    kept, merged = [], []
    for c in clusters:
        if len(c) == 1:
            kept.append(c[0])
            continue
        excursion, sigma = measure(c)
        if excursion <= CHATTER_SIGMAS * sigma:
            keep = c[0] if len(c) % 2 else None
            if keep is not None:
                kept.append(keep)
            merged.append({"of": what, "freq_hz": [float(x) for x in c], "kept_hz": keep, "excursion": excursion,
                           "scatter": sigma, "unit": unit})
        else:
            kept.extend(c)
    return np.array(kept, float), merged


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
