"""What each line of a measured FRF can prove, and where the FRF turns to noise.

A line's estimate ``G`` has a relative 1-sigma error ``eps`` (``|dG| / |G|``). Its 2-sigma disk ``|G' - G| <=
2 eps |G|`` holds the plant's value; once ``2 eps >= 1`` the disk holds the origin: the line says nothing of the phase
and bounds the magnitude only from above, so no crossing, margin or peak may be judged on it. The error of a line is
the larger of

* its scatter: the line-to-line roughness of ``20 log10 |G|`` (:func:`~feedtune.analysis.resolution.noise_db`
  without coherence: the running median of the second difference over 21 lines / (0.6745 sqrt 6)), converted to a
  relative error ``10^(sigma_dB / 20) - 1``;
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

from dataclasses import dataclass

import numpy as np

TRUST_WINDOW = 21
"""Lines of the running median that decides where the FRF turns to noise [-]."""
MIN_NOISE_LINES = 10
"""A noisy stretch at the top shorter than this [lines] is not cut (the last lines of any FRF are rougher)."""
PROOF_LIMIT = 1.0
"""``2 eps`` at or above this [-]: the line's 2-sigma disk holds the origin (module docstring)."""


@dataclass(frozen=True)
class LineTrust:
    """Where an FRF channel's lines prove something (module docstring): a summary of its line errors.

    Attributes
    ----------
    lines : int
        Number of lines.
    trusted_lines : int
        Lines below the noise at the top (all without it).
    band_top_hz : float
        The last trustworthy line [Hz].
    noise_from_hz : float or None
        The first line of the noise at the top (None: trustworthy to the last line).
    averages : float or None
        Averages of the estimate the coherence rule used (None: not recorded).
    median_rel_error, noise_rel_error : float
        Median relative 1-sigma error of the trustworthy lines and of the noise (nan without noise) [-].
    """

    lines: int
    trusted_lines: int
    band_top_hz: float
    noise_from_hz: float | None
    averages: float | None
    median_rel_error: float
    noise_rel_error: float = float("nan")

    def describe(self) -> str | None:
        """One line on the noise at the top, or None."""
        if self.noise_from_hz is None:
            return None
        return (f"from {self.noise_from_hz:.4g} Hz up the lines are noise (median relative error "
                f"{self.noise_rel_error:.2g} over {self.lines - self.trusted_lines} lines: their 2-sigma disks hold "
                "the origin)")

    def to_dict(self) -> dict:
        """JSON-ready summary."""
        return {"noise_from_hz": self.noise_from_hz, "band_top_hz": self.band_top_hz,
                "trusted_lines": self.trusted_lines, "lines": self.lines, "averages": self.averages,
                "median_rel_error": self.median_rel_error,
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
    from .resolution import noise_db

    f = np.asarray(freq_hz, float)
    eps = 10.0 ** (noise_db(f, np.asarray(response, complex).reshape(-1, f.size)) / 20.0) - 1.0
    if coherence is not None and averages:
        g = np.clip(np.asarray(coherence, float).reshape(-1, f.size), 1e-6, 1.0)
        eps_c = np.max(np.sqrt((1.0 - g) / (2.0 * float(averages) * g)), axis=0)
        eps = np.maximum(eps, np.where(np.isfinite(eps_c), eps_c, 0.0))
    return eps


def trust_of(freq_hz: np.ndarray, rel_error: np.ndarray, averages: float | None = None) -> LineTrust:
    """:class:`LineTrust` from the lines [Hz] and their errors (:func:`line_errors`)."""
    f = np.asarray(freq_hz, float)
    eps = np.asarray(rel_error, float)
    start = noise_start(f, eps)
    n_ok = f.size if start is None else int(np.searchsorted(f, start, "left"))
    return LineTrust(int(f.size), n_ok, float(f[max(n_ok - 1, 0)]), start, None if not averages else float(averages),
                     float(np.median(eps[:n_ok])) if n_ok else float("nan"),
                     float(np.median(eps[n_ok:])) if n_ok < f.size else float("nan"))


def line_trust(freq_hz: np.ndarray, response: np.ndarray, coherence: np.ndarray | None = None,
               averages: float | None = None) -> LineTrust:
    """:class:`LineTrust` of an FRF (its channels together: the largest error of each line)."""
    return trust_of(freq_hz, line_errors(freq_hz, response, coherence, averages), averages)


def noise_start(freq_hz: np.ndarray, rel_error: np.ndarray) -> float | None:
    """The first line of the noise at the top of an FRF (module docstring) [Hz], or None."""
    f = np.asarray(freq_hz, float)
    bad = 2.0 * np.asarray(rel_error, float) >= PROOF_LIMIT
    if f.size < MIN_NOISE_LINES or not bad[-1]:
        return None
    from scipy.ndimage import median_filter

    med = median_filter(bad.astype(float), size=TRUST_WINDOW, mode="nearest") >= 0.5
    ok = np.flatnonzero(~med)
    start = 0 if ok.size == 0 else int(ok[-1]) + 1
    if f.size - start < MIN_NOISE_LINES:
        return None
    # the noisy stretch starts at its first untrustworthy line (the median's edge is a few lines off)
    while start > 0 and bad[start - 1]:
        start -= 1
    while start < f.size and not bad[start]:
        start += 1
    if start == 0 or f.size - start < MIN_NOISE_LINES:
        return None if start else float(f[0])
    return float(f[start])
