"""What the lines of a measured FRF can prove: their scatter, their error, and where an FRF turns to noise.

One home for the quality of an FRF's lines, used by the analysis (crossing clusters, the measured plant's
continuation: :mod:`feedtune.analysis.band_edge`) and by the identification (a fit leaves noise out).

:func:`noise_db` is the line-to-line scatter of a measured response.

A line's estimate ``G`` has a relative 1-sigma error ``eps`` (``|dG| / |G|``). Its 2-sigma disk ``|G' - G| <=
2 eps |G|`` holds the plant's value; once ``2 eps >= 1`` the disk holds the origin: the line says nothing of the phase
and bounds the magnitude only from above, so no crossing, margin or peak may be judged on it. The error of a line is
the larger of

* its scatter: the line-to-line roughness of ``20 log10 |G|`` (:func:`noise_db`
  without coherence: the running median over 21 lines of each line's distance from the cubic in log frequency through
  its two neighbours on either side, scaled to a second difference's, / (0.6745 sqrt 6)), converted to a
  relative error ``10^(sigma_dB / 20) - 1``, or that of its phase in rad (:func:`phase_scatter`), whichever is larger;
* when the FRF records how many spectra it averaged (``segments`` of an H1 estimate, ``periods_total`` minus
  ``transient_periods`` of a periodic one) and its coherence ``gamma^2``: the random error of an averaged H1
  estimate, ``sqrt((1 - gamma^2) / (2 n gamma^2))`` (Bendat and Piersol, *Random Data*, 4th ed., eq. 9.90), with ``n``
  the averages (overlapping Hann segments count as ``n / (1 + 2 c^2)``, ``c`` the window's correlation at the step).

Without the number of averages the coherence is not turned into an error (one average would condemn most lines of a
well-averaged estimate); the roughness, which the averaging lowers, speaks for itself.

**Where the FRF turns to noise**: the lowest line above which the running median over :data:`TRUST_WINDOW` lines of
``2 eps`` stays at or above 1 up to the last line, when that top stretch has at least :data:`MIN_NOISE_LINES` lines.
Above it the lines are neither proof nor disproof; the analysis continues the loop there with the model and the
roll-off identified below it (:mod:`feedtune.models.rolloff`), and says so. Untrustworthy lines inside the band (an
anti-resonance, a line the excitation missed) are kept: they belong to a feature the plant has, and the crossing rules
weigh their scatter (:func:`~feedtune.analysis.margins.settle_clusters`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

NOISE_BLOCK = 128
"""Lines per block of the dB magnitude and coherence floor (the analysis' per-line scatter reads the same blocks)."""

TRUST_WINDOW = 21
"""Lines of the running median that decides where the FRF turns to noise [-]."""
MIN_NOISE_LINES = 10
"""A noisy stretch at the top shorter than this [lines] is not cut (the last lines of any FRF are rougher)."""
MIN_NOISE_LINES_BELOW = 5
"""... and at the bottom (the few lines below a multisine's first excited line)."""
PROOF_LIMIT = 1.0
"""``2 eps`` at or above this [-]: the line's 2-sigma disk holds the origin (module docstring)."""


@dataclass(frozen=True)
class LineTrust:
    """Where an FRF channel's lines prove something (module docstring): a summary of its line errors.

    Attributes
    ----------
    lines : int
        Number of lines.
    first_line, trusted_lines : int
        The trustworthy lines are ``first_line .. trusted_lines - 1`` (all without noise at the ends).
    band_bottom_hz, band_top_hz : float
        The first and the last trustworthy line [Hz].
    noise_from_hz : float or None
        The first line of the noise at the top (None: trustworthy to the last line).
    noise_below_hz : float or None
        The last line of the noise at the bottom (None: trustworthy from the first line).
    averages : float or None
        Averages of the estimate the coherence rule used (None: not recorded).
    median_rel_error, noise_rel_error : float
        Median relative 1-sigma error of the trustworthy lines and of the noise at the ends (nan without) [-].
    """

    lines: int
    first_line: int
    trusted_lines: int
    band_bottom_hz: float
    band_top_hz: float
    noise_from_hz: float | None
    noise_below_hz: float | None
    averages: float | None
    median_rel_error: float
    noise_rel_error: float = float("nan")

    def describe(self) -> str | None:
        """One line on the noise at the ends, or None."""
        parts = []
        if self.noise_below_hz is not None:
            parts.append(f"up to {self.noise_below_hz:.4g} Hz")
        if self.noise_from_hz is not None:
            parts.append(f"from {self.noise_from_hz:.4g} Hz up")
        if not parts:
            return None
        n = self.lines - self.trusted_lines + self.first_line
        return (f"{' and '.join(parts)} the lines are noise (median relative error {self.noise_rel_error:.2g} over "
                f"{n} lines: their 2-sigma disks hold the origin)")

    def to_dict(self) -> dict:
        """JSON-ready summary."""
        return {"noise_from_hz": self.noise_from_hz, "noise_below_hz": self.noise_below_hz,
                "band_bottom_hz": self.band_bottom_hz, "band_top_hz": self.band_top_hz,
                "first_line": self.first_line, "trusted_lines": self.trusted_lines, "lines": self.lines,
                "averages": self.averages, "median_rel_error": self.median_rel_error,
                "noise_rel_error": None if not np.isfinite(self.noise_rel_error) else self.noise_rel_error}


def averages_of(meta: dict | None) -> float | None:
    """The number of averaged spectra an FRF records in its metadata, as an equivalent count (module docstring), or
    None."""
    meta = meta or {}
    try:
        if "segments" in meta:
            n = float(meta["segments"])
            overlap = float(meta.get("overlap", 0) or 0)
            return n / (1 + 2 * hann_step_correlation(overlap) ** 2) if n > 0 else None
        if "periods_total" in meta:
            n = float(meta["periods_total"]) - float(meta.get("transient_periods", 0) or 0)
            return n if n > 0 else None
    except (TypeError, ValueError):
        return None
    return None


def hann_step_correlation(overlap: float) -> float:
    """Correlation of two Hann windows shifted by ``1 - overlap`` of their length [-] (0 without overlap)."""
    if not 0 < overlap < 1:
        return 0.0
    n = 4096
    w = np.hanning(n)
    shift = round((1 - overlap) * n)
    return float(np.dot(w[shift:], w[:n - shift]) / np.dot(w, w))


def line_errors(freq_hz: np.ndarray, response: np.ndarray, coherence: np.ndarray | None = None,
                averages: float | None = None) -> np.ndarray:
    """The relative 1-sigma error ``eps`` [-] of every line (largest over channels; module docstring).

    Parameters
    ----------
    freq_hz : ndarray, shape (n,)
        The lines [Hz].
    response : ndarray, shape (..., n)
        The measured responses (channels on the leading axes).
    coherence : ndarray, optional
        Their coherence (same shape).
    averages : float, optional
        Averages of the estimate (:func:`averages_of`).
    """
    f = np.asarray(freq_hz, float)
    h = np.asarray(response, complex).reshape(-1, f.size)
    eps = np.maximum(10.0 ** (noise_db(f, h) / 20.0) - 1.0, phase_scatter(h))
    if coherence is not None and averages:
        g = np.clip(np.asarray(coherence, float).reshape(-1, f.size), 1e-6, 1.0)
        eps_c = np.max(np.sqrt((1.0 - g) / (2.0 * float(averages) * g)), axis=0)
        eps = np.maximum(eps, np.where(np.isfinite(eps_c), eps_c, 0.0))
    return eps


def trust_of(freq_hz: np.ndarray, rel_error: np.ndarray, averages: float | None = None) -> LineTrust:
    """:class:`LineTrust` from the lines [Hz] and their errors (:func:`line_errors`)."""
    f = np.asarray(freq_hz, float)
    eps = np.asarray(rel_error, float)
    lo, hi = trusted_span(eps)
    ends = np.r_[eps[:lo], eps[hi:]]
    return LineTrust(int(f.size), lo, hi, float(f[lo]), float(f[max(hi - 1, 0)]),
                     float(f[hi]) if hi < f.size else None, float(f[lo - 1]) if lo > 0 else None,
                     None if not averages else float(averages), float(np.median(eps[lo:hi])),
                     float(np.median(ends)) if ends.size else float("nan"))


def line_trust(freq_hz: np.ndarray, response: np.ndarray, coherence: np.ndarray | None = None,
               averages: float | None = None) -> LineTrust:
    """:class:`LineTrust` of an FRF (its channels together: the largest error of each line)."""
    return trust_of(freq_hz, line_errors(freq_hz, response, coherence, averages), averages)


def trusted_span(rel_error: np.ndarray) -> tuple[int, int]:
    """The trustworthy lines ``lo .. hi - 1`` between the noise at the ends of an FRF (module docstring).

    The noise at the top starts at the lowest line ``i`` that is untrustworthy, where the running median over
    :data:`TRUST_WINDOW` lines says untrustworthy, and above which (``i`` included) most lines are untrustworthy: a
    few good lines inside the noise (a harmonic, an accident of the estimate) do not end it. The noise at the bottom
    is the first stretch the running median calls untrustworthy (lines the excitation did not reach). Either stretch
    counts only with at least :data:`MIN_NOISE_LINES` (at the bottom :data:`MIN_NOISE_LINES_BELOW`) lines; an FRF
    noisy throughout keeps every line (nothing to set apart).
    """
    eps = np.asarray(rel_error, float)
    n = eps.size
    bad = 2.0 * eps >= PROOF_LIMIT
    if n < 2 * MIN_NOISE_LINES or not bad.any():
        return 0, n
    from scipy.ndimage import median_filter

    local = median_filter(bad.astype(float), size=TRUST_WINDOW, mode="nearest") >= 0.5
    good = np.flatnonzero(~local)
    if good.size == 0:  # noise throughout: nothing to set apart
        return 0, n
    body = int(good[0])  # where the trustworthy body of the FRF begins
    lo = body
    while lo < n and bad[lo]:
        lo += 1
    if lo < MIN_NOISE_LINES_BELOW:
        lo = 0
    cum = np.r_[0, np.cumsum(bad)]
    idx = np.arange(n)
    suffix = (cum[-1] - cum[:-1]) / (n - idx)  # share of untrustworthy lines in [i, n)
    top = np.flatnonzero(bad & local & (suffix >= 0.5) & (n - idx >= MIN_NOISE_LINES) & (idx > body))
    ends_in_noise = bad[-TRUST_WINDOW:].mean() >= 0.5  # not local[-1]: the edge padding repeats the last line
    hi = int(top[0]) if top.size and ends_in_noise else n
    if hi - lo < MIN_NOISE_LINES:
        return 0, n
    return lo, hi


def noise_start(freq_hz: np.ndarray, rel_error: np.ndarray) -> float | None:
    """The first line of the noise at the top of an FRF (:func:`trusted_span`) [Hz], or None."""
    f = np.asarray(freq_hz, float)
    hi = trusted_span(rel_error)[1]
    return float(f[hi]) if hi < f.size else None


# ------------------------------------------------------------------------------------------ scatter
def noise_db(freq_hz: np.ndarray, response: np.ndarray, coherence: np.ndarray | None = None,
             half_window: int = 10, averages: float | None = None) -> np.ndarray:
    """Measurement scatter of a measured response [dB, 1 sigma] per line (largest over leading axes).

    From the line-to-line roughness: the running median over ``2 half_window + 1`` lines of how far each line's
    ``20 log10 |H|`` lies from the cubic in log frequency through its two neighbours on either side
    (:func:`line_residuals`: a mass line, a spring or a resonance wider than a few lines reads no scatter, on any
    spacing of lines), scaled so that white scatter of ``sigma`` reads ``sigma`` (the median ignores the few lines of
    a resonance narrower than that). With a coherence ``gamma^2``, at least
    ``20 log10(1 + sqrt((1 - gamma^2) / (2 n gamma^2)))``, the H1 error of ``n`` averages (Bendat and Piersol, *Random
    Data*, eq. 9.90; ``n = averages``, one when not recorded).
    """
    f = np.asarray(freq_hz, float)
    h = np.asarray(response, complex).reshape(-1, f.size)
    db = _by_blocks(_db_rows, h)
    n = db.shape[-1]
    out = np.zeros(n)
    k, mid = ROUGHNESS_STENCIL, ROUGHNESS_STENCIL // 2
    if n >= k:
        x = line_axis(f)
        d2 = np.empty_like(db)  # the roughness of every line, the first and last mid lines repeating their neighbour's
        for a in range(0, n - k + 1, RESIDUAL_CHUNK):  # in chunks: its temporaries stay small on long FRFs
            b = min(a + RESIDUAL_CHUNK, n - k + 1)
            d2[:, a + mid:b + mid] = line_residuals([db[:, a + j:b + j] for j in range(k)],
                                                    [x[a + j:b + j] for j in range(k)])
        d2[:, :mid] = d2[:, mid:mid + 1]
        d2[:, n - mid:] = d2[:, n - mid - 1:n - mid]
        del db
        out = _d2_sigma(d2, half_window, "nearest")
    if coherence is not None:
        g = np.asarray(coherence, float).reshape(-1, n)
        out = np.maximum(out, _by_blocks(lambda rows: _coherence_floor_db(rows, averages), g))
    return out


def line_axis(freq_hz: np.ndarray, log_freq: np.ndarray | None = None) -> np.ndarray:
    """The axis the roughness is read on: ``log(freq_hz)`` when every line is above 0 Hz (``log_freq`` when given:
    the same, computed already), else the line index."""
    f = np.asarray(freq_hz, float)
    if f.size and f.min() > 0:
        return np.log(f) if log_freq is None else log_freq
    return np.arange(f.size, dtype=float)


ROUGHNESS_STENCIL = 5
"""Lines each roughness value reads: the middle one against the cubic through the two on either side [-]."""
RESIDUAL_CHUNK = 4096
"""Lines per chunk of :func:`noise_db`'s roughness (bounds its temporaries) [-]."""


def line_residuals(ys, xs) -> np.ndarray:
    """Roughness of the middle of :data:`ROUGHNESS_STENCIL` consecutive lines [dB], as a second difference's ``|d2|``.

    The middle value's distance from the cubic (in :func:`line_axis`) through the other four: a response that is a
    polynomial of up to third degree in log frequency over five lines (a mass line, a spring, a resonance wider than a
    few lines) reads no roughness, on any spacing of lines; scaled so that white scatter of ``sigma`` reads like the
    second difference of an even spacing (variance ``6 sigma^2``).

    Parameters
    ----------
    ys : sequence of 5 ndarray, each shape (rows, m)
        The dB values of the five lines of every stencil.
    xs : sequence of 5 ndarray, each shape (m,)
        Their positions on the axis.
    """
    mid = ROUGHNESS_STENCIL // 2
    others = [k for k in range(ROUGHNESS_STENCIL) if k != mid]
    x0 = np.asarray(xs[mid], float)
    r = np.array(ys[mid], float, copy=True)
    term = np.empty_like(r)
    sum_w2 = np.ones(x0.shape)
    for j in others:  # one Lagrange weight at a time, in place (this runs on every line of every FRF)
        w = np.ones(x0.shape)
        for k in others:
            if k != j:
                w *= (x0 - xs[k]) / (xs[j] - xs[k])
        np.multiply(w, ys[j], out=term)
        r -= term
        w *= w
        sum_w2 += w
    np.abs(r, out=r)
    np.divide(6.0, sum_w2, out=sum_w2)
    r *= np.sqrt(sum_w2, out=sum_w2)
    return r


def phase_scatter(response: np.ndarray, half_window: int = 10) -> np.ndarray:
    """Measurement scatter of the phase of a measured response [rad, 1 sigma] per line (largest over leading axes).

    The running median of ``|d2|``, the second difference of the phase wrapped to ``(-pi, pi]``, over
    ``2 half_window + 1`` lines, divided by ``0.6745 sqrt(6)``: for a small relative error it equals the scatter of
    ``ln |H|`` (both are one part of the same complex error). Pure noise has a uniform phase, ``|d2|`` a median of
    ``pi / 2`` and a scatter near 0.95 rad, where the magnitude's roughness alone (a log-Rayleigh variable, whose
    median difference is small) reads only half as much.
    """
    h = np.asarray(response, complex)
    h = h.reshape(-1, h.shape[-1])
    n = h.shape[-1]
    if n < 3:
        return np.zeros(n)
    ph = np.angle(h)
    d2 = np.abs(np.angle(np.exp(1j * (ph[:, :-2] - 2 * ph[:, 1:-1] + ph[:, 2:]))))
    d2 = np.pad(d2, ((0, 0), (1, 1)), mode="reflect")
    return _d2_sigma(d2, half_window, "mirror")


def _d2_sigma(d2: np.ndarray, half_window: int, mode: str) -> np.ndarray:
    """1-sigma scatter per line from ``|d2|`` (rows x lines, second differences): the running median over
    ``2 half_window + 1`` lines divided by ``0.6745 sqrt(6)`` (white scatter of ``sigma`` gives ``var d2 = 6 sigma^2``),
    the largest over rows."""
    from scipy.ndimage import median_filter

    # row by row: scipy's one-dimensional running median is ~8x faster than the 2-D filter of size (1, w)
    med = np.vstack([median_filter(row, size=2 * half_window + 1, mode=mode) for row in d2])
    return np.max(med, axis=0) / (0.6745 * np.sqrt(6.0))


def _by_blocks(fn: Callable[[np.ndarray], np.ndarray], rows: np.ndarray) -> np.ndarray:
    """``fn`` of the lines (last axis) of ``rows``, computed in blocks of :data:`NOISE_BLOCK` lines, the blocks
    :class:`LineNoise` computes on demand (the whole-array and the per-line scatter read the same values, bit for
    bit)."""
    n = rows.shape[-1]
    if n <= NOISE_BLOCK:
        return fn(rows)
    return np.concatenate([fn(rows[..., k:k + NOISE_BLOCK]) for k in range(0, n, NOISE_BLOCK)], axis=-1)


def _db_rows(h: np.ndarray) -> np.ndarray:
    """``20 log10 |h|`` of every line (rows x lines)."""
    with np.errstate(divide="ignore"):
        return 20 * np.log10(np.maximum(np.abs(h), 1e-300))


def _coherence_floor_db(g: np.ndarray, averages: float | None = None) -> np.ndarray:
    """The H1 error floor [dB] per line of ``averages`` averages (one when None) from the coherence rows ``g``
    (largest over rows)."""
    n = float(averages) if averages else 1.0
    with np.errstate(divide="ignore", invalid="ignore"):
        c = 20 * np.log10(1 + np.sqrt(np.clip(1 - g, 0, 1) / (2 * n * np.clip(g, 1e-6, 1))))
    return np.max(np.where(np.isfinite(c), c, 0.0), axis=0)
