"""A measured plant continued where its lines prove nothing: above the noise of a channel, and above the FRF.

Per channel of a measured plant (:mod:`feedtune.frf_quality`): the lines from where the channel turns to noise
at the top are replaced by the model times the roll-off identified on the channel's top trustworthy octave
(:func:`feedtune.models.rolloff.fit_rolloff` on the ratio measured / model); and every channel is continued above the
FRF's last line, up to the Nyquist frequency of the controller, by the same product. The verdict then covers the whole
contour (the Nyquist count closes at ``fs / 2``) and says what it assumes there (:meth:`BandEdge.assumptions`):
measured lines where they prove something, the identified continuation elsewhere.

The continuation is tabulated on log-spaced points (:data:`POINTS_PER_DECADE`, plus points around the model's lightly
damped poles and zeros there) that the analysis interpolates like lines; it carries no scatter.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..frf_quality import line_errors, trust_of
from ..models.rolloff import Rolloff, fit_rolloff, fitted_band
from .resolution import feature_points

POINTS_PER_DECADE = 100
"""Density of the continuation above the FRF's last line."""
MIN_POINTS = 24
"""Fewest points of a continuation above the FRF."""
NYQUIST_SLACK = 0.999
"""An FRF whose last line reaches this fraction of ``fs / 2`` is not continued above it."""


@dataclass(frozen=True)
class BandEdge:
    """Where a measured plant case rests on its lines and where on the continuation (module docstring).

    Attributes
    ----------
    channels : tuple of str
        The channels, in the plant's order.
    trust : tuple of LineTrust
        Each channel's line errors and noise start.
    rolloffs : tuple of Rolloff
        Each channel's roll-off, fitted on its top trustworthy octave.
    lines : int
        Number of the FRF's lines at the start of the case's grid (the continuation above them follows).
    last_line_hz : float
        The FRF's last line [Hz].
    extended_to_hz : float or None
        Top of the continuation above the FRF [Hz] (None: not continued).
    """

    channels: tuple
    trust: tuple
    rolloffs: tuple
    lines: int
    last_line_hz: float
    extended_to_hz: float | None

    @property
    def valid_to_hz(self) -> float:
        """The top of the band where every channel is measured and trustworthy [Hz]."""
        return float(min(t.band_top_hz for t in self.trust))

    @property
    def valid_from_hz(self) -> float:
        """The bottom of the band where every channel is measured and trustworthy [Hz]."""
        return float(max(t.band_bottom_hz for t in self.trust))

    @property
    def noise_from_hz(self) -> float | None:
        """The lowest noise start over the channels [Hz], or None."""
        starts = [t.noise_from_hz for t in self.trust if t.noise_from_hz is not None]
        return float(min(starts)) if starts else None

    def _distinct(self) -> list[tuple]:
        """``(name, trust, rolloff)`` of each channel once: a plant layout may hold one measured channel twice (a
        cascade's ``[x1/u, xp/u]`` with the position loop on the motor encoder), the same lines and the same fit."""
        seen: dict = {}
        for name, t, r in zip(self.channels, self.trust, self.rolloffs, strict=True):
            seen.setdefault(name, (name, t, r))
        return list(seen.values())

    def assumptions(self) -> list[str]:
        """One line per channel that rests on its continuation somewhere below the case's top: where and on what."""
        out = []
        for name, t, r in self._distinct():
            lo = t.noise_from_hz if t.noise_from_hz is not None else self.last_line_hz
            if (t.noise_from_hz is None and self.extended_to_hz is None) or r.structure == "none":
                continue
            where = (f"from {t.noise_from_hz:.4g} Hz (where its lines turn to noise)" if t.noise_from_hz is not None
                     else f"above {lo:.4g} Hz (the FRF's last line)")
            out.append(f"{name} {where}: {r.describe()}")
        for name, t, _ in self._distinct():
            if t.noise_below_hz is not None:
                out.append(f"{name} up to {t.noise_below_hz:.4g} Hz (where its lines are noise): the model, scaled to "
                           f"its lines at {t.band_bottom_hz:.4g} Hz")
        return out

    def to_dict(self) -> dict:
        """JSON-ready summary (units in the keys)."""
        return {"valid_to_hz": self.valid_to_hz, "valid_from_hz": self.valid_from_hz,
                "noise_from_hz": self.noise_from_hz, "last_line_hz": self.last_line_hz,
                "extended_to_hz": self.extended_to_hz,
                "channels": [{"channel": n, **t.to_dict(), "rolloff": r.to_dict()} for n, t, r in self._distinct()],
                "assumes": self.assumptions()}


def continuation_grid(last_hz: float, fs: float, features=None) -> np.ndarray:
    """The points above ``last_hz`` [Hz] up to ``fs / 2`` (included) of a continuation; empty when the FRF reaches
    ``NYQUIST_SLACK * fs / 2``."""
    top = fs / 2
    if not last_hz < NYQUIST_SLACK * top:
        return np.empty(0)
    n = max(MIN_POINTS, int(np.ceil(np.log10(top / last_hz) * POINTS_PER_DECADE)))
    g = np.logspace(np.log10(last_hz), np.log10(top), n + 1)[1:]
    if features is not None and np.size(features):
        g = np.union1d(g, feature_points(features, last_hz, top))
    g[-1] = top
    return g[g > last_hz]


def _same_channel(k: int, names: tuple, h: np.ndarray, coh: np.ndarray | None, models: list,
                  m_ext: np.ndarray | None) -> int | None:
    """An earlier row of the plant that is row ``k`` again (the same name, lines, coherence and model), or None."""
    for j in range(k):
        if (names[j] == names[k] and np.array_equal(h[j], h[k]) and (coh is None or np.array_equal(coh[j], coh[k]))
                and np.array_equal(models[j], models[k]) and (m_ext is None or np.array_equal(m_ext[j], m_ext[k]))):
            return j
    return None


def continue_plant(lines_hz: np.ndarray, response: np.ndarray, model_plant, fs: float, *,
                   coherence: np.ndarray | None = None, averages: float | None = None, features=None,
                   channels: tuple | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray | None, BandEdge]:
    """The measured plant continued (module docstring).

    Parameters
    ----------
    lines_hz : ndarray, shape (n,)
        The FRF's lines [Hz].
    response : ndarray, shape (..., n)
        The measured plant (channels on the leading axes).
    model_plant : callable
        ``model_plant(f)`` -> the model in the same layout.
    fs : float
        Controller sample rate [Hz] (the continuation ends at ``fs / 2``).
    coherence : ndarray, optional
        Coherence of the channels (same shape as ``response``).
    averages : float, optional
        Averages of the estimate (:func:`~feedtune.frf_quality.averages_of`).
    features : ndarray, shape (k, 2), optional
        Lightly damped roots of the model (Hz, damping): points around them above the FRF.
    channels : tuple of str, optional
        Channel names (default ``ch0``, ``ch1``, ...).

    Returns
    -------
    (freq_hz, response, coherence, BandEdge)
        The grid (the lines, then the continuation above them), the plant on it (continued channels replaced from
        their noise start), the coherence on it (1 where continued; None without one) and the record.
    """
    f = np.asarray(lines_hz, float)
    h = np.asarray(response, complex)
    shape = h.shape[:-1]
    h2 = h.reshape(-1, f.size)
    coh2 = None if coherence is None else np.asarray(coherence, float).reshape(-1, f.size)
    names = tuple(channels) if channels is not None else tuple(f"ch{i}" for i in range(h2.shape[0]))
    f_ext = continuation_grid(float(f[-1]), fs, features)
    errors = [line_errors(f, h2[k], None if coh2 is None else coh2[k], averages) for k in range(h2.shape[0])]
    trusts = [trust_of(f, e, averages) for e in errors]
    cut = [t.trusted_lines for t in trusts]
    if not f_ext.size and all(n == f.size for n in cut) and all(t.first_line == 0 for t in trusts):
        # nothing to continue: the lines as they are
        edge = BandEdge(names, tuple(trusts), tuple(Rolloff("none", 1.0 + 0j, 0.0) for _ in names), int(f.size),
                        float(f[-1]), None)
        return f, h, coherence, edge
    grid = np.concatenate([f, f_ext])
    out = np.empty((h2.shape[0], grid.size), complex)
    out[:, :f.size] = h2
    coh_out = None
    if coh2 is not None:
        coh_out = np.ones((h2.shape[0], grid.size))
        coh_out[:, :f.size] = coh2
    m_ext = np.asarray(model_plant(f_ext), complex).reshape(-1, f_ext.size) if f_ext.size else None
    rolloffs: list[Rolloff] = []
    models: list[np.ndarray] = []
    for k, (eps, n_ok) in enumerate(zip(errors, cut, strict=True)):
        band = np.flatnonzero(fitted_band(f[:n_ok], float(f[n_ok - 1])))
        need = np.r_[band, np.arange(n_ok, f.size)]  # the model where it is fitted to and where it replaces lines
        m_need = np.asarray(model_plant(f[need]), complex).reshape(-1, need.size)[k]
        models.append(m_need)
        twin = _same_channel(k, names, h2, coh2, models, m_ext)
        if twin is not None:  # one channel held twice in the layout (a cascade's x1/u as x1 and xp): fitted once
            out[k] = out[twin]
            if coh_out is not None:
                coh_out[k] = coh_out[twin]
            rolloffs.append(rolloffs[twin])
            continue
        with np.errstate(divide="ignore", invalid="ignore"):
            ratio = h2[k, band] / m_need[:band.size]
        r = fit_rolloff(f[band], ratio, eps[band])
        if n_ok < f.size:
            out[k, n_ok:f.size] = m_need[band.size:] * r.response(f[n_ok:])
            if coh_out is not None:
                coh_out[k, n_ok:f.size] = 1.0
        lo = trusts[k].first_line
        if lo:  # noise at the bottom: the model, scaled to the channel's first trustworthy octave
            octave = np.arange(lo, max(int(np.searchsorted(f, 2.0 * f[lo], "right")), lo + 3))
            m_lo = np.asarray(model_plant(f[np.r_[:lo, octave]]), complex).reshape(-1, lo + octave.size)[k]
            with np.errstate(divide="ignore", invalid="ignore"):
                ratio = h2[k, octave] / m_lo[lo:]
            c = complex(np.mean(ratio[np.isfinite(ratio)])) if np.isfinite(ratio).any() else 1.0 + 0j
            out[k, :lo] = c * m_lo[:lo]
            if coh_out is not None:
                coh_out[k, :lo] = 1.0
        if f_ext.size:
            out[k, f.size:] = m_ext[k] * r.response(f_ext)
        rolloffs.append(r)
    edge = BandEdge(names, tuple(trusts), tuple(rolloffs), int(f.size), float(f[-1]),
                    float(f_ext[-1]) if f_ext.size else None)
    return grid, out.reshape(*shape, grid.size), None if coh_out is None else coh_out.reshape(*shape, grid.size), edge
