"""Report figures: matplotlib (Agg canvas, no pyplot state), labelled axes with units, log-frequency axes in Hz.

Every function takes plain arrays (results the other packages computed) and returns a
``matplotlib.figure.Figure``; nothing is computed here beyond unit scaling and plot decimation. Long time
series are reduced to a min/max envelope per pixel column (:func:`envelope`) and spectra to the maximum per
logarithmic bin (:func:`log_envelope`), so peaks stay visible while the images stay small.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

WIDTH_IN = 9.0
"""Figure width [in]; at :data:`DPI` this is 900 pixels, readable on a laptop screen."""
ROW_HEIGHT_IN = 2.6
"""Height of one row of axes [in]."""
DPI = 100
"""Resolution of the embedded PNG images [dots per inch]."""
TITLE_IN = 0.35
"""Space above the axes for a figure title [in]."""
PIXEL_COLUMNS = 900
"""Columns of the min/max envelope of a time series (one per pixel of a full-width axis)."""
PALETTE = ("#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e", "#8c564b", "#e377c2", "#17becf")
"""Colours given to controllers/runs in order of appearance."""


@dataclass(frozen=True)
class Curve:
    """One line of a figure: x, y (complex for frequency responses), label and style."""

    x: np.ndarray
    y: np.ndarray
    label: str
    color: str = PALETTE[0]
    style: str = "-"
    width: float = 1.3


# ------------------------------------------------------------------------------------------ helpers
def new_figure(rows: int, cols: int = 1, *, height: float = ROW_HEIGHT_IN, width: float = WIDTH_IN,
               sharex: bool = False):
    """A Figure with an Agg canvas and its axes array (shape (rows, cols)), constrained layout."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    total_h = height * rows + TITLE_IN
    fig = Figure(figsize=(width, total_h), dpi=DPI)
    FigureCanvasAgg(fig)
    axes = fig.subplots(rows, cols, squeeze=False, sharex=sharex)
    # fixed margins in inches (constrained layout costs more than drawing the figure)
    fig.subplots_adjust(left=0.85 / width, right=1 - 0.2 / width, bottom=0.55 / total_h,
                        top=1 - (TITLE_IN + 0.25) / total_h, hspace=0.62 / max(height - 0.62, 0.5),
                        wspace=0.95 / max(width / cols - 0.95, 0.5))
    for ax in axes.flat:
        ax.grid(True, which="major", alpha=0.3, linewidth=0.6)
        ax.tick_params(labelsize=8.5)
    return fig, axes


def envelope(x: np.ndarray, y: np.ndarray, columns: int = PIXEL_COLUMNS) -> tuple[np.ndarray, np.ndarray]:
    """Min/max envelope of ``y(x)`` with ``columns`` bins: 2 points per bin, in time order within a bin.

    Series of at most ``4 * columns`` points are returned unchanged. The extremes of every bin are kept, so a
    one-sample peak is still drawn.

    Examples
    --------
    >>> x = np.arange(10_000.0); y = np.zeros_like(x); y[5_000] = 1.0
    >>> xe, ye = envelope(x, y, 100)
    >>> xe.size, float(ye.max())
    (200, 1.0)
    """
    x = np.asarray(x, float)
    y = np.asarray(y, float)
    n = x.size
    if n <= 4 * columns:
        return x, y
    per = int(np.ceil(n / columns))
    pad = per * columns - n
    yp = np.concatenate([y, np.full(pad, y[-1])]).reshape(columns, per)
    xp = np.concatenate([x, np.full(pad, x[-1])]).reshape(columns, per)
    i_min, i_max = yp.argmin(axis=1), yp.argmax(axis=1)
    first = np.minimum(i_min, i_max)
    second = np.maximum(i_min, i_max)
    rows = np.arange(columns)
    xe = np.column_stack([xp[rows, first], xp[rows, second]]).ravel()
    ye = np.column_stack([yp[rows, first], yp[rows, second]]).ravel()
    return xe, ye


def log_envelope(f: np.ndarray, y: np.ndarray, columns: int = PIXEL_COLUMNS) -> tuple[np.ndarray, np.ndarray]:
    """The largest ``y`` per logarithmic frequency bin (``f > 0`` only), for spectra on log axes.

    Spectra with at most ``2 * columns`` positive frequencies are returned unchanged (without ``f <= 0``).
    """
    f = np.asarray(f, float)
    y = np.asarray(y, float)
    keep = f > 0
    f, y = f[keep], y[keep]
    if f.size <= 2 * columns:
        return f, y
    edges = np.logspace(np.log10(f[0]), np.log10(f[-1]), columns + 1)
    idx = np.clip(np.searchsorted(edges, f, side="right") - 1, 0, columns - 1)
    order = np.lexsort((-y, idx))  # by bin, largest first within a bin
    first = np.r_[True, idx[order][1:] != idx[order][:-1]]
    pick = np.sort(order[first])
    return f[pick], y[pick]


def _phase_locator():
    from matplotlib.ticker import MaxNLocator

    return MaxNLocator(nbins=6, steps=[1, 1.8, 3.6, 4.5, 9, 10])  # multiples of 45, 90, 180, 360 deg


def _phase_limits(ax, trusted: list) -> None:
    """Phase axis limits from the model and the measured points with coherence >= 0.5 (unwrapped noise of
    low-coherence lines would otherwise stretch the axis over thousands of degrees)."""
    values = np.concatenate([np.asarray(t, float) for t in trusted]) if trusted else np.empty(0)
    if values.size:
        lo, hi = float(values.min()), float(values.max())
        ax.set_ylim(90 * np.floor(lo / 90) - 45, 90 * np.ceil(hi / 90) + 45)


def _legend(ax, **kw) -> None:
    handles, _ = ax.get_legend_handles_labels()
    if handles:
        ax.legend(fontsize=8, loc=kw.pop("loc", "best"), framealpha=0.85, **kw)


def _plain_log_labels(axis) -> None:
    """Tick labels ``1, 10, 100`` instead of mathtext ``10^k`` (clearer in Hz, and no mathtext parsing); no
    minor ticks (matplotlib builds an object per tick, the main cost of drawing), their grid lines are drawn
    by :func:`finish_figure` instead."""
    from matplotlib.ticker import FuncFormatter, NullLocator

    axis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))
    axis.set_minor_locator(NullLocator())


def _minor_log_grid(ax) -> None:
    """Grid lines at 2..9 x 10^k inside the x limits of a log-x axes, as one line collection."""
    lo, hi = ax.get_xlim()
    if not (lo > 0 and hi > lo):
        return
    decades = np.arange(np.floor(np.log10(lo)), np.ceil(np.log10(hi)) + 1)
    pos = (np.arange(2, 10)[None, :] * 10.0 ** decades[:, None]).ravel()
    pos = pos[(pos > lo) & (pos < hi)]
    ax.vlines(pos, 0, 1, transform=ax.get_xaxis_transform(), colors="0.5", linewidths=0.5, alpha=0.3, zorder=0)
    ax.set_xlim(lo, hi)


def finish_figure(fig) -> None:
    """Last touches before saving (once per figure): the minor grid of the log-frequency axes."""
    if getattr(fig, "_feedtune_finished", False):
        return
    for ax in fig.axes:
        if ax.get_xscale() == "log":
            _minor_log_grid(ax)
    fig._feedtune_finished = True


def _freq_axis(ax) -> None:
    ax.set_xscale("log")
    _plain_log_labels(ax.xaxis)
    ax.set_xlabel("frequency [Hz]")


def _db(h: np.ndarray) -> np.ndarray:
    return 20.0 * np.log10(np.maximum(np.abs(h), 1e-300))


def _phase_deg(h: np.ndarray) -> np.ndarray:
    return np.rad2deg(np.unwrap(np.angle(h)))


def _phase_wrapped(h: np.ndarray) -> np.ndarray:
    return np.rad2deg(np.angle(h))


def _phase_aligned(h: np.ndarray) -> np.ndarray:
    """Unwrapped phase [deg] shifted by whole turns so that it starts in (-270, 90] (a double integrator
    reads -180 deg), the same branch for measured and model curves."""
    p = _phase_deg(h)
    if not p.size:
        return p
    return p - 360.0 * np.ceil((p[0] - 90.0) / 360.0)


# ------------------------------------------------------------------------------------------ identification
def frf_figure(channels: Sequence[str], measured: dict, model: dict, coherence: dict, *, unit: str,
               title: str, band_hz: Sequence[float] | None = None, width: float = WIDTH_IN):
    """Measured vs model FRF per channel: magnitude [dB re 1 unit], phase [deg], coherence [-].

    Parameters
    ----------
    channels : sequence of str
        Channel names ``OUT/IN`` (one column each).
    measured, model : dict of str to (freq_hz, complex response)
        Curves per channel (a channel may be missing from either).
    coherence : dict of str to (freq_hz, coherence)
        Coherence per channel (missing channels get no coherence panel content).
    unit : str
        Unit of the response, e.g. ``"rad/V"``.
    band_hz : [lo, hi], optional
        Fit band, shaded.
    """
    rows = 3 if coherence else 2
    fig, axes = new_figure(rows, len(channels), height=2.3, width=width, sharex=True)
    for j, ch in enumerate(channels):
        mag, ph = axes[0, j], axes[1, j]
        trusted = []
        if ch in measured:
            f, h = measured[ch]
            p = _phase_aligned(h)
            if ch in model and np.array_equal(model[ch][0], f):
                # measured phase on the model's branch: model phase + wrapped difference (noise stays local)
                p = _phase_aligned(model[ch][1]) + np.rad2deg(np.angle(h / model[ch][1]))
            mag.plot(f, _db(h), color=PALETTE[0], lw=1.2, label="measured")
            ph.plot(f, p, color=PALETTE[0], lw=1.0, label="measured")
            good = coherence[ch][1] >= 0.5 if ch in coherence else np.ones(p.size, bool)
            trusted.append(p[good] if good.any() else p)
        if ch in model:
            f, h = model[ch]
            p = _phase_aligned(h)
            mag.plot(f, _db(h), color=PALETTE[1], lw=1.3, ls="--", label="model")
            ph.plot(f, p, color=PALETTE[1], lw=1.2, ls="--", label="model")
            trusted.append(p)
        _phase_limits(ph, trusted)
        mag.set_title(ch, fontsize=10)
        mag.set_ylabel(f"|{ch}| [dB re 1 {unit}]")
        ph.set_ylabel("phase [deg]")
        ph.yaxis.set_major_locator(_phase_locator())
        if rows == 3:
            ax = axes[2, j]
            if ch in coherence:
                f, c = coherence[ch]
                ax.plot(f, c, color=PALETTE[2], lw=1.0, label="coherence")
            ax.set_ylim(0, 1.05)
            ax.set_ylabel("coherence [-]")
        for ax in axes[:, j]:
            _freq_axis(ax)
            if band_hz is not None:
                ax.axvspan(band_hz[0], band_hz[1], color="0.85", alpha=0.5, lw=0)
        for ax in axes[:-1, j]:
            ax.set_xlabel("")
        _legend(mag, loc="lower left")
    fig.suptitle(title, fontsize=11)
    return fig


def friction_figure(curves: Sequence[Curve], scatter: Sequence[Curve], *, velocity_unit: str,
                    command_unit: str, title: str):
    """Stribeck friction curves ``d(v)`` and optional disturbance-estimate scatter ``(v, d)``."""
    fig, axes = new_figure(1, height=3.6)
    ax = axes[0, 0]
    for s in scatter:
        ax.plot(s.x, s.y, ".", ms=1.5, color=s.color, alpha=0.35, label=s.label, rasterized=True)
    for c in curves:
        ax.plot(c.x, c.y, c.style, color=c.color, lw=c.width, label=c.label)
    ax.axhline(0, color="0.4", lw=0.6)
    ax.axvline(0, color="0.4", lw=0.6)
    ax.set_xlabel(f"velocity [{velocity_unit}]")
    ax.set_ylabel(f"friction / disturbance [{command_unit}]")
    ax.set_title(title, fontsize=10)
    _legend(ax)
    return fig


def gantry_mass_figure(x: np.ndarray, side_masses: np.ndarray, inertia: np.ndarray, yaw_hz: np.ndarray, *,
                       mass_unit: str, inertia_unit: str, points: dict | None = None):
    """Mass distribution ``m1(x), m2(x)``, yaw inertia ``J(x)`` and yaw-mode frequency versus table position.

    ``points`` may hold per-position identified values: ``{"yaw_x", "yaw_hz"}`` [m, Hz] and ``{"mass_x", "m1",
    "m2"}`` [m, mass unit].
    """
    fig, axes = new_figure(1, 3, height=3.0)
    a, b, c = axes[0]
    a.plot(x, side_masses[:, 0], color=PALETTE[0], label="m1 (side 1)")
    a.plot(x, side_masses[:, 1], color=PALETTE[1], label="m2 (side 2)")
    a.set_ylabel(f"side mass [{mass_unit}]")
    b.plot(x, inertia, color=PALETTE[2], label="J(x)")
    b.set_ylabel(f"yaw inertia [{inertia_unit}]")
    c.plot(x, yaw_hz, color=PALETTE[3], label="model")
    points = points or {}
    if len(points.get("yaw_hz", ())):
        c.plot(points["yaw_x"], points["yaw_hz"], "o", color=PALETTE[4], label="identified per position")
    if len(points.get("m1", ())):
        a.plot(points["mass_x"], points["m1"], "o", color=PALETTE[0], mfc="none", label="m1 identified")
        a.plot(points["mass_x"], points["m2"], "s", color=PALETTE[1], mfc="none", label="m2 identified")
    c.set_ylabel("yaw mode [Hz]")
    for ax in (a, b, c):
        ax.set_xlabel("table position x [m]")
        _legend(ax)
    return fig


# ------------------------------------------------------------------------------------------ design
def pole_map_figure(open_loop: np.ndarray, closed: Sequence[tuple[str, str, np.ndarray]], *, zoom_rad_s: float):
    """Open- and closed-loop poles in the s-plane [rad/s] (thesis Fig. 3.6): all poles and a zoom.

    ``closed`` holds ``(label, colour, poles)`` per controller.
    """
    fig, axes = new_figure(1, 2, height=3.8)
    for k, ax in enumerate(axes[0]):
        ax.plot(open_loop.real, open_loop.imag, "x", color="0.2", ms=8, mew=1.6, label="open loop (model)")
        for label, color, p in closed:
            ax.plot(p.real, p.imag, "o", mfc="none", color=color, ms=7, mew=1.4, label=f"closed loop, {label}")
        ax.axvline(0, color="0.4", lw=0.7)
        ax.axhline(0, color="0.4", lw=0.7)
        ax.set_xlabel("real part [rad/s]")
        ax.set_ylabel("imaginary part [rad/s]")
        if k == 1:
            ax.set_xlim(-zoom_rad_s, 0.1 * zoom_rad_s)
            ax.set_ylim(-zoom_rad_s, zoom_rad_s)
            ax.set_title(f"zoom: |s| < {zoom_rad_s / (2 * np.pi):.0f} Hz x 2 pi", fontsize=9)
        else:
            ax.set_title("all poles", fontsize=9)
    _legend(axes[0, 0], loc="upper left")
    return fig


def _mark_points(ax, xs, ys, color, marker="o") -> None:
    if len(xs):
        ax.plot(xs, ys, marker, color=color, ms=5, mfc="white", mew=1.3, zorder=5)


def loop_figure(curves: Sequence[Curve], crossovers: dict[str, Sequence[float]]):
    """Loop transfer ``L``: magnitude [dB] with the crossovers marked, and phase [deg] (Fig. 3.10a-b)."""
    fig, axes = new_figure(2, height=2.6, sharex=True)
    mag, ph = axes[0, 0], axes[1, 0]
    for c in curves:
        fx, m = log_envelope(c.x, np.abs(c.y))
        mag.plot(fx, _db(m), c.style, color=c.color, lw=c.width, label=c.label)
        ph.plot(c.x, _phase_deg(c.y), c.style, color=c.color, lw=c.width * 0.9)
        wc = crossovers.get(c.label, ())
        _mark_points(mag, list(wc), [0.0] * len(wc), c.color)
    mag.axhline(0, color="0.3", lw=0.8)
    ph.axhline(-180, color="0.3", lw=0.8, ls=":")
    mag.set_ylabel("|L| [dB]")
    ph.set_ylabel("phase of L [deg]")
    _freq_axis(mag)
    _freq_axis(ph)
    mag.set_xlabel("")
    lo = min(float(np.min(_db(c.y))) for c in curves)
    hi = max(float(np.max(_db(c.y))) for c in curves)
    mag.set_ylim(max(lo, -80.0) - 5, min(hi, 120.0) + 5)
    _legend(mag, loc="lower left")
    return fig


def nyquist_figure(curves: Sequence[Curve], ms: dict[str, float]):
    """Nyquist plot of ``L`` near -1 with the circle ``|1 + L| = 1/Ms`` of every controller (Fig. 3.10c-d)."""
    fig, axes = new_figure(1, height=5.0, width=6.5)
    ax = axes[0, 0]
    th = np.linspace(0, 2 * np.pi, 361)
    for c in curves:
        ax.plot(c.y.real, c.y.imag, c.style, color=c.color, lw=c.width, label=c.label)
        if ms.get(c.label):
            r = 1.0 / ms[c.label]
            ax.plot(-1 + r * np.cos(th), r * np.sin(th), ":", color=c.color, lw=1.0,
                    label=f"|1+L| = 1/Ms, {c.label}")
    ax.plot(np.cos(th), np.sin(th), color="0.6", lw=0.7, ls="--", label="|L| = 1")
    ax.plot([-1], [0], "+", color="k", ms=12, mew=2, label="-1")
    ax.set_xlim(-4, 2)
    ax.set_ylim(-3, 3)
    ax.set_aspect("equal", adjustable="box")
    ax.set_xlabel("Re L [-]")
    ax.set_ylabel("Im L [-]")
    _legend(ax, loc="lower right")
    return fig


def sensitivity_figure(curves: Sequence[Curve], peaks: dict[str, tuple[float, float]],
                       ms_limit: float | None = None):
    """Sensitivity magnitude ``|S|`` [dB] with each ``Ms`` marked (Fig. 3.11)."""
    fig, axes = new_figure(1, height=3.4)
    ax = axes[0, 0]
    top = 0.0
    for c in curves:
        fx, m = log_envelope(c.x, np.abs(c.y))
        label = c.label
        if c.label in peaks:
            f0, ms = peaks[c.label]
            label += f" (Ms {ms:.3g} at {f0:.4g} Hz)"
            _mark_points(ax, [f0], [20 * np.log10(ms)], c.color)
        ax.plot(fx, _db(m), c.style, color=c.color, lw=c.width, label=label)
        top = max(top, float(np.max(_db(m))))
    ax.set_ylim(-60.0, top + 6.0)
    ax.axhline(0, color="0.3", lw=0.8)
    if ms_limit:
        ax.axhline(20 * np.log10(ms_limit), color="0.3", lw=0.8, ls="--", label=f"Ms limit {ms_limit:.3g}")
    _freq_axis(ax)
    ax.set_ylabel("|S| [dB]")
    _legend(ax, loc="lower right")
    return fig


def magnitude_figure(curves: Sequence[Curve], *, ylabel: str, scale: float = 1.0, db: bool = False,
                     phase: bool = False, loglog: bool = True):
    """Magnitude (and optionally phase) of frequency responses, e.g. ``x2/d2`` or ``x2/x_r``."""
    fig, axes = new_figure(2 if phase else 1, height=2.8, sharex=True)
    ax = axes[0, 0]
    for c in curves:
        fx, m = log_envelope(c.x, np.abs(c.y) * scale)
        ax.plot(fx, _db(m) if db else m, c.style, color=c.color, lw=c.width, label=c.label)
    if loglog and not db:
        ax.set_yscale("log")
    _freq_axis(ax)
    ax.set_ylabel(ylabel)
    if phase:
        ph = axes[1, 0]
        for c in curves:
            ph.plot(c.x, _phase_wrapped(c.y), c.style, color=c.color, lw=c.width * 0.9)
        ph.set_ylabel("phase [deg]")
        ph.set_ylim(-185, 185)
        ph.set_yticks([-180, -90, 0, 90, 180])
        _freq_axis(ph)
        ax.set_xlabel("")
    _legend(ax, loc="lower left")
    return fig


# ------------------------------------------------------------------------------------------ time domain
def runs_figure(error: Sequence[Curve], command: Sequence[Curve], spectrum: Sequence[Curve], *,
                error_label: str, command_label: str, spectrum_label: str, title: str,
                spectrum_loglog: bool = False):
    """Time-domain runs (Fig. 3.15, 3.14, 4.17): error or displacement, control signal, spectrum.

    Panels without curves are left out.
    """
    panels = [p for p in (error, command, spectrum) if p]
    fig, axes = new_figure(len(panels), height=2.4)
    k = 0
    for curves, label, is_spec in ((error, error_label, False), (command, command_label, False),
                                   (spectrum, spectrum_label, True)):
        if not curves:
            continue
        ax = axes[k, 0]
        k += 1
        for c in curves:
            x, y = log_envelope(c.x, c.y) if is_spec else envelope(c.x, c.y)
            ax.plot(x, y, c.style, color=c.color, lw=c.width * (0.9 if is_spec else 0.8), label=c.label)
        if is_spec:
            _freq_axis(ax)
            if spectrum_loglog:
                ax.set_yscale("log")
        else:
            ax.set_xlabel("time [s]")
        ax.set_ylabel(label)
        _legend(ax, loc="upper right")
    fig.suptitle(title, fontsize=11)
    return fig


def contour_figure(paths: Sequence[tuple[str, str, np.ndarray, np.ndarray, np.ndarray, np.ndarray]],
                   errors: Sequence[Curve], *, title: str):
    """x-y path against its reference and the contour error versus time (Fig. 4.20-4.22).

    ``paths`` holds ``(label, colour, x_ref, y_ref, x, y)`` [m]; ``errors`` the contour error [µm] vs t [s].
    """
    fig, axes = new_figure(1, 2, height=4.0)
    ax, ae = axes[0]
    for i, (label, color, xr, yr, x, y) in enumerate(paths):
        if i == 0:
            ax.plot(xr * 1e3, yr * 1e3, color="0.2", lw=1.0, ls="--", label="reference")
        ax.plot(x * 1e3, y * 1e3, color=color, lw=1.0, label=label)
    ax.set_xlabel("x [mm]")
    ax.set_ylabel("y [mm]")
    ax.set_aspect("equal", adjustable="datalim")
    _legend(ax)
    for c in errors:
        t, e = envelope(c.x, c.y)
        ae.plot(t, e, color=c.color, lw=0.8, label=c.label)
    ae.set_xlabel("time [s]")
    ae.set_ylabel("contour error [µm]")
    _legend(ae)
    fig.suptitle(title, fontsize=11)
    return fig


# ------------------------------------------------------------------------------------------ output
def figure_png(fig) -> bytes:
    """The figure as PNG bytes at :data:`DPI`."""
    import io

    finish_figure(fig)
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=DPI, pil_kwargs={"compress_level": 4})
    return buf.getvalue()


# ------------------------------------------------------------------------------------------ MIMO
def singular_value_figure(curves: Sequence[tuple[str, str, np.ndarray, np.ndarray, np.ndarray]], *, ylabel: str,
                          peaks: dict | None = None, level_db: float | None = 0.0, ms_limit: float | None = None):
    """Upper (solid) and lower (dashed) singular values [dB] of 2x2 responses (thesis Figs. 4.13-4.15).

    ``curves`` holds ``(label, colour, freq_hz, sigma_max, sigma_min)``; ``peaks`` ``{label: (f, value)}``
    marks a peak such as ``Ms``.
    """
    fig, axes = new_figure(1, height=3.4)
    ax = axes[0, 0]
    for label, color, f, hi, lo in curves:
        fx, h = log_envelope(f, hi)
        upper = f"{label}, upper"
        if peaks and label in peaks:
            f0, v = peaks[label]
            upper += f" (max {v:.3g} at {f0:.4g} Hz)"
            _mark_points(ax, [f0], [20 * np.log10(v)], color)
        ax.plot(fx, _db(h), "-", color=color, lw=1.5, label=upper)
        fl, low = log_envelope(f, lo)
        ax.plot(fl, _db(low), "--", color=color, lw=1.0, label=f"{label}, lower")
    if level_db is not None:
        ax.axhline(level_db, color="0.3", lw=0.8)
    if ms_limit:
        ax.axhline(20 * np.log10(ms_limit), color="0.3", lw=0.8, ls=":", label=f"Ms limit {ms_limit:.3g}")
    _freq_axis(ax)
    ax.set_ylabel(ylabel)
    _legend(ax, loc="lower left")
    return fig


def det_nyquist_figure(curves: Sequence[Curve]):
    """MIMO Nyquist plot: ``det(I + L)`` around the origin (thesis Fig. 4.13 right)."""
    fig, axes = new_figure(1, height=5.0, width=6.5)
    ax = axes[0, 0]
    for c in curves:
        ax.plot(c.y.real, c.y.imag, c.style, color=c.color, lw=c.width, label=c.label)
    ax.plot([0], [0], "+", color="k", ms=12, mew=2, label="origin")
    th = np.linspace(0, 2 * np.pi, 361)
    ax.plot(np.cos(th), np.sin(th), color="0.6", lw=0.7, ls="--", label="|det(I + L)| = 1")
    ax.set_xlim(-3, 5)
    ax.set_ylim(-4, 4)
    ax.set_aspect("equal", adjustable="box")
    ax.set_xlabel("Re det(I + L) [-]")
    ax.set_ylabel("Im det(I + L) [-]")
    _legend(ax, loc="lower right")
    return fig
