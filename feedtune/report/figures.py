"""Report figures: matplotlib (Agg canvas, no pyplot state), labelled axes with units, log-frequency axes in Hz.

Every function takes plain arrays (results the other packages computed) and returns a
``matplotlib.figure.Figure``; nothing is computed here beyond unit scaling and plot decimation. Long time
series are reduced to a min/max envelope per pixel column (:func:`envelope`) and spectra to the maximum per
logarithmic bin (:func:`log_envelope`), so peaks stay visible while the images stay small.

Legends sit in a band of their own between the title and the axes (:func:`new_figure` reserves it from the
labels), so they never cover a curve, the -1 point of a Nyquist plot or a marked crossover. A :class:`Curve` may
carry a ``mask``: its points outside the mask are not drawn (frequency-response lines of a measured FRF whose
coherence is too low to trust, see :mod:`feedtune.report.trust`).

Speed: figures are drawn once (Agg, :data:`DPI` dots per inch, whole-pixel sizes, fixed margins and axis-label
places instead of a constrained layout or ``bbox_inches="tight"``), with few major ticks and plain tick labels (no
mathtext). :func:`figure_png` finishes a figure for the report: no matplotlib tick object is built (the axes are
:class:`feedtune.report._agg.LightAxes`; the labels are plain texts and each grid one line, :func:`_light_ticks`;
the minor grid of log axes is one line too), the canvas keeps every text it rasterised for the next figures
(:mod:`feedtune.report._agg`) and the PNG is written with a fast filter and zlib level (:func:`encode_png`). The
picture is matplotlib's, texts placed at whole pixels.
"""

from __future__ import annotations

import math
import textwrap
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

WIDTH_IN = 9.0
"""Figure width [in]; at :data:`DPI` this is 900 pixels, readable on a laptop screen."""
ROW_HEIGHT_IN = 2.4
"""Height of one row of axes [in]."""
DPI = 100
"""Resolution of the embedded PNG images [dots per inch]."""
TITLE_IN = 0.32
"""Space above the axes for a figure title [in]."""
LEGEND_FONT = 7.5
"""Legend font size [pt]."""
LEGEND_ROW_IN = 0.17
"""Height of one legend row [in]."""
LEGEND_CHAR_IN = 0.058
"""Mean width of one legend character at :data:`LEGEND_FONT` [in] (DejaVu Sans)."""
LEGEND_WRAP = 44
"""Legend labels longer than this many characters are wrapped."""
NYQUIST_WIDTH_IN = 6.5
"""Width of the (square) Nyquist figures [in]."""
PIXEL_COLUMNS = 900
"""Columns of the min/max envelope of a time series (one per pixel of a full-width axis)."""
PALETTE = ("#0072B2", "#D55E00", "#009E73", "#CC79A7", "#E69F00", "#56B4E9")
"""Colours given to designs and their runs in order of appearance: the Okabe-Ito colours that stay apart for readers
with any common colour-vision deficiency (blue, vermillion, bluish green, reddish purple, orange, sky blue; their
yellow and black are left out: too faint on white, and black marks the reference lines). A seventh design reuses the
first colour with its own marker and width."""
WIDTH_SCALE = (2.2, 1.3, 0.85, 0.7, 0.6, 0.5)
"""Line width factor of the k-th colour: the first design drawn widest and each later one narrower and above it, so
curves that coincide stay visible side by side (one nested in the other) instead of the last hiding the others."""
MARKERS = ("o", "s", "^", "D", "v", "P")
"""Marker of the k-th colour on frequency-response curves, spaced along the curve and offset per design: each design
is told apart in print and without colour."""
MARKER_EVERY = 0.13
"""Distance between markers along a curve [fraction of the axes diagonal]."""
LEFT_IN, RIGHT_IN, BOTTOM_IN = 0.8, 0.2, 0.5
"""Fixed figure margins [in]."""
TICK_LABEL_PT, TICK_PAD_PT = 8.0, 3.0
"""Tick label font size and its distance from the axes [pt]."""
GRID_ALPHA, GRID_WIDTH = 0.3, 0.6
"""Opacity [-] and line width [pt] of the major grid."""


@dataclass(frozen=True)
class Curve:
    """One line of a figure: x, y (complex for frequency responses), label and style.

    ``mask`` (bool, same length as ``x``), when given, marks the points drawn; the others are left out (a gap).
    """

    x: np.ndarray
    y: np.ndarray
    label: str
    color: str = PALETTE[0]
    style: str = "-"
    width: float = 1.3
    mask: np.ndarray | None = None


# ------------------------------------------------------------------------------------------ layout
def wrap_label(label: str, chars: int = LEGEND_WRAP) -> str:
    """A legend label wrapped to lines of at most ``chars`` characters."""
    return "\n".join(textwrap.wrap(label, chars)) if len(label) > chars else label


def legend_layout(labels: Sequence[str], width: float = WIDTH_IN) -> tuple[int, int, int]:
    """``(columns, rows, lines)`` of a legend band holding ``labels`` across a figure ``width`` [in] wide."""
    labels = [wrap_label(x) for x in dict.fromkeys(labels) if x]
    if not labels:
        return 0, 0, 0
    chars = max(len(line) for x in labels for line in x.split("\n"))
    col_in = chars * LEGEND_CHAR_IN + 0.5
    ncol = max(1, min(len(labels), int((width - 0.3) // col_in)))
    rows = math.ceil(len(labels) / ncol)
    lines = sum(max(x.count("\n") + 1 for x in labels[r * ncol:(r + 1) * ncol]) for r in range(rows))
    return ncol, rows, lines


def new_figure(rows: int, cols: int = 1, *, height: float = ROW_HEIGHT_IN, width: float = WIDTH_IN,
               sharex: bool = False, legend: Sequence[str] = (), width_ratios=None, span_last: bool = False):
    """A Figure with an Agg canvas and its axes array (shape (rows, cols)), fixed margins.

    Parameters
    ----------
    rows, cols : int
        Grid of axes.
    height, width : float
        Height of one row and figure width [in].
    sharex : bool
        Axes share their x axis.
    legend : sequence of str
        Labels the figure legend will hold (:func:`add_legend`): a band above the axes is reserved for them.
    width_ratios : sequence of float, optional
        Relative column widths.
    span_last : bool
        The last row is one axes across every column (``axes[-1, 0]``; the other cells of that row are None).
    """
    from matplotlib.figure import Figure

    from ._agg import Canvas, LightAxes

    _, _, lines = legend_layout(legend, width)
    top_in = TITLE_IN + (lines * LEGEND_ROW_IN + 0.12 if lines else 0.0)
    total_h = round((height * rows + top_in + 0.1) * DPI) / DPI  # whole pixels (texts reuse their bitmaps there)
    width = round(width * DPI) / DPI
    fig = Figure(figsize=(width, total_h), dpi=DPI)
    Canvas(fig)
    gs = fig.add_gridspec(rows, cols, left=LEFT_IN / width, right=1 - RIGHT_IN / width, bottom=BOTTOM_IN / total_h,
                          top=1 - (top_in + 0.12) / total_h, hspace=0.62 / max(height - 0.62, 0.5),
                          wspace=0.9 / max(width / cols - 0.9, 0.5), width_ratios=width_ratios)
    axes = np.empty((rows, cols), dtype=object)
    for r in range(rows):
        for c in range(cols):
            if span_last and r == rows - 1:
                if c == 0:
                    axes[r, 0] = fig.add_subplot(gs[r, :], axes_class=LightAxes)
                continue
            share = axes[0, c] if sharex and r > 0 and axes[0, c] is not None else None
            axes[r, c] = fig.add_subplot(gs[r, c], sharex=share, axes_class=LightAxes)
    for ax in axes.flat:
        if ax is not None:
            # a title at the fixed place (no tick label above the axes): matplotlib would otherwise measure the
            # x axis (creating its ticks) at every draw to move the title above any top tick label
            ax.set_title("", y=1.0)
            ax.grid(True, which="major", alpha=GRID_ALPHA, linewidth=GRID_WIDTH)
            ax.tick_params(labelsize=TICK_LABEL_PT, length=0, pad=TICK_PAD_PT)  # the grid marks the ticks
            ax.xaxis.set_major_locator(_locator(6))
            ax.yaxis.set_major_locator(_locator(5))
    fig._feedtune_legend_top = 1 - TITLE_IN / total_h
    fig._feedtune_width = width
    return fig, axes


def add_legend(fig, axes=None) -> None:
    """One legend for the figure in the band :func:`new_figure` reserved: the labelled lines of ``axes`` (default:
    every axes), each label once, in order of appearance.

    Drawn as plain lines and texts (a matplotlib Legend packs its boxes at draw time, a tenth of a figure's
    drawing time); the columns are as wide as :func:`legend_layout` estimates for the longest label."""
    handles, labels = [], []
    for ax in axes if axes is not None else fig.axes:
        if ax is None:
            continue
        for h, lb in zip(*ax.get_legend_handles_labels(), strict=True):
            if lb and lb not in labels:
                handles.append(h)
                labels.append(lb)
    if not handles:
        return
    width = getattr(fig, "_feedtune_width", WIDTH_IN)
    height = fig.get_figheight()
    ncol, _, _ = legend_layout(labels, width)
    wrapped = [wrap_label(x) for x in labels]
    chars = max(len(line) for x in wrapped for line in x.split("\n"))
    col_in = chars * LEGEND_CHAR_IN + 0.5
    x0 = max(0.15, (width - ncol * col_in) / 2)
    y = TITLE_IN + 0.04
    for r in range(0, len(wrapped), ncol):
        row = list(zip(handles[r:r + ncol], wrapped[r:r + ncol], strict=True))
        for c, (h, text) in enumerate(row):
            x = x0 + c * col_in
            _legend_handle(fig, h, x, y + LEGEND_ROW_IN / 2, width, height)
            fig.text((x + 0.36) / width, 1 - y / height, text, fontsize=LEGEND_FONT, va="top", ha="left",
                     linespacing=1.15)
        y += max(t.count("\n") + 1 for _, t in row) * LEGEND_ROW_IN


def _legend_handle(fig, h, x_in: float, y_in: float, width: float, height: float) -> None:
    """A legend key: a short line (and marker) in the style of ``h``, or a filled box for a patch."""
    from matplotlib.lines import Line2D
    from matplotlib.patches import Rectangle

    xs = [x_in / width, (x_in + 0.3) / width]
    yy = 1 - y_in / height
    if isinstance(h, Line2D):
        ls = h.get_linestyle()
        marker = h.get_marker()
        if ls not in ("None", "", " "):
            fig.add_artist(Line2D(xs, [yy, yy], transform=fig.transFigure, color=h.get_color(), linestyle=ls,
                                  linewidth=min(h.get_linewidth(), 2.0), alpha=h.get_alpha()))
        if marker not in (None, "None", "", " "):
            fig.add_artist(Line2D([sum(xs) / 2], [yy], transform=fig.transFigure, linestyle="None", marker=marker,
                                  color=h.get_color(), markerfacecolor=h.get_markerfacecolor(),
                                  markeredgecolor=h.get_markeredgecolor(), markersize=min(h.get_markersize(), 7),
                                  markeredgewidth=h.get_markeredgewidth(), alpha=h.get_alpha()))
        return
    face = h.get_facecolor() if hasattr(h, "get_facecolor") else "0.8"
    if hasattr(face, "ndim") and getattr(face, "ndim", 1) > 1:
        face = face[0]
    fig.add_artist(Rectangle((xs[0], yy - 0.05 / height), 0.3 / width, 0.1 / height, transform=fig.transFigure,
                             facecolor=face, edgecolor="none"))


def set_title(fig, title: str) -> None:
    """The figure title, left-aligned in the title band."""
    fig.text(LEFT_IN / getattr(fig, "_feedtune_width", WIDTH_IN), 1 - 0.06 / fig.get_figheight(), title,
             fontsize=10, weight="bold", va="top", ha="left")


def _labels(curves) -> list[str]:
    return [c.label for c in curves if c.label]


# ------------------------------------------------------------------------------------------ decimation
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
    NaN values (points left out) stay gaps: a bin keeps its largest finite value, or NaN when it has none.
    """
    f = np.asarray(f, float)
    y = np.asarray(y, float)
    keep = f > 0
    f, y = f[keep], y[keep]
    if f.size <= 2 * columns:
        return f, y
    edges = np.logspace(np.log10(f[0]), np.log10(f[-1]), columns + 1)
    idx = np.clip(np.searchsorted(edges, f, side="right") - 1, 0, columns - 1)
    key = np.where(np.isnan(y), np.inf, -y)  # NaN last within a bin
    order = np.lexsort((key, idx))  # by bin, largest first within a bin
    first = np.r_[True, idx[order][1:] != idx[order][:-1]]
    pick = np.sort(order[first])
    return f[pick], y[pick]


def log_decimate(f: np.ndarray, columns: int = PIXEL_COLUMNS) -> np.ndarray:
    """Indices of at most about ``2 * columns`` points of a log-frequency grid, evenly spread in log frequency
    (for phase curves, where a maximum per bin would distort wraps); every index for short grids."""
    f = np.asarray(f, float)
    if f.size <= 2 * columns or not np.all(f > 0):
        return np.arange(f.size)
    targets = np.logspace(np.log10(f[0]), np.log10(f[-1]), 2 * columns)
    return np.unique(np.clip(np.searchsorted(f, targets), 0, f.size - 1))


def _shown(c: Curve, values: np.ndarray) -> np.ndarray:
    """``values`` (derived from ``c.y``) with the points outside ``c.mask`` set to NaN."""
    values = np.asarray(values, float)
    if c.mask is None:
        return values
    return np.where(np.asarray(c.mask, bool), values, np.nan)


# ------------------------------------------------------------------------------------------ axes helpers
def _clipped(base):
    """``base`` (a matplotlib Locator) returning only the ticks inside the view: matplotlib builds a Tick (five
    artists) for every location a locator returns, drawn or not (figures shown in a notebook; the report's figures
    draw their ticks as plain texts, :func:`_light_ticks`)."""
    from ._agg import ClippedLocator

    return ClippedLocator(base)


def _locator(nbins: int = 5):
    from matplotlib.ticker import MaxNLocator

    return _clipped(MaxNLocator(nbins=nbins))


def _phase_locator():
    from matplotlib.ticker import MaxNLocator

    return _clipped(MaxNLocator(nbins=5, steps=[1, 1.8, 3.6, 4.5, 9, 10]))  # multiples of 45, 90, 180, 360 deg


def _phase_limits(ax, trusted: list) -> None:
    """Phase axis limits from the trusted curves only (unwrapped noise of low-coherence lines would otherwise
    stretch the axis over thousands of degrees)."""
    values = np.concatenate([np.asarray(t, float).ravel() for t in trusted]) if trusted else np.empty(0)
    values = values[np.isfinite(values)]
    if values.size:
        lo, hi = float(values.min()), float(values.max())
        ax.set_ylim(90 * np.floor(lo / 90) - 45, 90 * np.ceil(hi / 90) + 45)


def _plain_log_labels(axis) -> None:
    """Tick labels ``1, 10, 100`` instead of mathtext ``10^k`` (clearer, and no mathtext parsing); no minor
    ticks (matplotlib builds several artists per tick, the main cost of drawing); the minor grid of a log-x
    axis is drawn by :func:`finish_figure` as one line."""
    from matplotlib.ticker import FuncFormatter, LogLocator, NullLocator

    axis.set_major_locator(_clipped(LogLocator()))
    axis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))
    axis.set_minor_locator(NullLocator())


def _minor_log_grid(ax) -> None:
    """Grid lines at 2..9 x 10^k inside the x limits of a log-x axes, as one line (NaN-separated)."""
    from matplotlib.lines import Line2D

    lo, hi = ax.get_xlim()
    if not (lo > 0 and hi > lo):
        return
    decades = np.arange(np.floor(np.log10(lo)), np.ceil(np.log10(hi)) + 1)
    pos = (np.arange(2, 10)[None, :] * 10.0 ** decades[:, None]).ravel()
    pos = pos[(pos > lo) & (pos < hi)]
    if not pos.size:
        return
    xs = np.column_stack([pos, pos, np.full(pos.size, np.nan)]).ravel()
    ys = np.tile([0.0, 1.0, np.nan], pos.size)
    ax.add_artist(Line2D(xs, ys, transform=ax.get_xaxis_transform(), color="0.5", linewidth=0.5, alpha=0.3,
                         zorder=0))


XLABEL_IN, YLABEL_IN = 0.24, 0.56
"""Distance of the axis labels from the axes [in] (fixed: matplotlib would otherwise measure every tick label of
every axes and its siblings again to place them)."""


def _fix_label_positions(fig) -> None:
    """Axis labels at fixed places, also the empty ones (matplotlib would measure the spines, ticks included, to
    place an empty label)."""
    w_in, h_in = fig.get_size_inches()
    for ax in fig.axes:
        pos = ax.get_position()
        ax.xaxis.set_label_coords(0.5, -XLABEL_IN / max(pos.height * h_in, 1e-3))
        ax.yaxis.set_label_coords(-YLABEL_IN / max(pos.width * w_in, 1e-3), 0.5)


def _visible_ticks(axis) -> tuple[list, list, str]:
    """The major tick locations of ``axis`` inside its view (as matplotlib keeps them), their labels and the
    formatter's offset text."""
    locs = list(axis.get_majorticklocs())
    fmt = axis.major.formatter
    labels = fmt.format_ticks(locs)  # every location, as matplotlib does (the offset depends on them)
    offset = fmt.get_offset() if hasattr(fmt, "get_offset") else ""
    lo, hi = sorted(axis.get_view_interval())
    with np.errstate(all="ignore"):
        tr = axis.get_transform().transform(np.asarray([lo, hi, *locs], float).reshape(-1, 1)).ravel()
    a, b = sorted(tr[:2])
    tol = 1e-10 * (b - a)
    keep = [(v, lb) for v, t, lb in zip(locs, tr[2:], labels, strict=True)
            if np.isfinite(t) and a - tol <= t <= b + tol]
    return [v for v, _ in keep], [lb for _, lb in keep], offset


def _light_ticks(fig) -> None:
    """Tick labels and major grid of every axes drawn as plain artists: one text per label and one line per grid.

    matplotlib builds a Tick of five artists (two tick marks, a grid line, two labels) for every tick and draws
    each of them, about half of the drawing time of a report figure. Here the locations and labels are taken from
    the axis' own locator and formatter once the data limits are final, and drawn with the axis' own tick
    parameters (label size and colour, pad, grid style) where matplotlib would put them (its tick label transform);
    the axis is then left without ticks. The image is the same (texts at whole pixels); the figure is no longer
    zoomable (it is only saved). Tick marks are not drawn: the report's axes have none (length 0).
    """
    from matplotlib.font_manager import FontProperties
    from matplotlib.lines import Line2D
    from matplotlib.text import Text
    from matplotlib.ticker import NullLocator

    plans = []
    for ax in fig.axes:
        ax.apply_aspect()  # the final limits of an equal-aspect axes ("datalim")
        for axis in (ax.xaxis, ax.yaxis):
            shown = ax.get_visible() and ax.axison and axis.get_visible()
            plans.append((ax, axis, *(_visible_ticks(axis) if shown else ([], [], ""))))  # before any change
    for ax, axis, locs, labels, offset in plans:  # (the shared axes of a column share one locator)
        name = axis.axis_name
        params = axis.get_tick_params()
        axis.set_major_locator(NullLocator())
        axis.offsetText.set_visible(False)
        if not locs:
            continue
        if params.get("gridOn", False):
            pos = np.asarray(locs, float)
            across = np.tile([0.0, 1.0, np.nan], pos.size)
            along = np.column_stack([pos, pos, np.full(pos.size, np.nan)]).ravel()
            ax.add_artist(Line2D(
                *((along, across) if name == "x" else (across, along)),
                transform=ax.get_xaxis_transform("grid") if name == "x" else ax.get_yaxis_transform("grid"),
                color=params.get("grid_color", _rc("grid.color")),
                linestyle=params.get("grid_linestyle", _rc("grid.linestyle")),
                linewidth=params.get("grid_linewidth", _rc("grid.linewidth")),
                alpha=params.get("grid_alpha", _rc("grid.alpha")),
                zorder=1.5))  # where matplotlib draws its axes (rc axes.axisbelow = "line")
        if not params.get("labelbottom" if name == "x" else "labelleft", True):
            continue
        size = params.get("labelsize", _rc(f"{name}tick.labelsize"))
        color = params.get("labelcolor", _rc(f"{name}tick.labelcolor"))
        color = _rc(f"{name}tick.color") if color == "inherit" else color
        length = params.get("length", _rc(f"{name}tick.major.size"))
        pad = params.get("pad", _rc(f"{name}tick.major.pad")) + length * {"out": 1.0, "inout": 0.5}.get(
            params.get("direction", _rc(f"{name}tick.direction")), 0.0)
        trans, va, ha = ax.get_xaxis_text1_transform(pad) if name == "x" else ax.get_yaxis_text1_transform(pad)
        texts = [Text(v, 0.0, text, transform=trans, va=va, ha=ha, fontsize=size, color=color) if name == "x"
                 else Text(0.0, v, text, transform=trans, va=va, ha=ha, fontsize=size, color=color)
                 for v, text in zip(locs, labels, strict=True) if text]
        if offset:  # an offset or power of ten shared by the labels, where matplotlib puts it
            h_in = _axes_size_in(ax)[1]
            points = FontProperties(size=size).get_size_in_points()
            texts.append(Text(1.0, -(pad + 1.6 * points) / 72 / h_in, offset,
                              transform=ax.transAxes, va="top", ha="right", fontsize=size, color=color)
                         if name == "x" else
                         Text(0.0, 1.0 + 3.0 / 72 / h_in, offset, transform=ax.transAxes, va="bottom", ha="left",
                              fontsize=size, color=color))
        for t in texts:
            fig.add_artist(t, clip=False)  # figure-level, unclipped: 4 times cheaper to make than Axes.text
    for ax in fig.axes:
        ax.grid(False)


def _axes_size_in(ax) -> tuple[float, float]:
    w_in, h_in = ax.get_figure().get_size_inches()
    pos = ax.get_position()
    return max(pos.width * w_in, 1e-3), max(pos.height * h_in, 1e-3)


def _rc(key: str):
    import matplotlib as mpl

    return mpl.rcParams[key]


def finish_figure(fig) -> None:
    """Last touches before saving (once per figure): the minor grid of the log-frequency axes, fixed axis-label
    positions and light ticks (:func:`_light_ticks`)."""
    if getattr(fig, "_feedtune_finished", False):
        return
    for ax in fig.axes:
        if ax.get_xscale() == "log":
            _minor_log_grid(ax)
    _fix_label_positions(fig)
    _light_ticks(fig)
    fig._feedtune_finished = True


def _freq_axis(ax, label: bool = True) -> None:
    ax.set_xscale("log")
    _plain_log_labels(ax.xaxis)
    ax.set_xlabel("frequency [Hz]" if label else "")


def _log_y(ax) -> None:
    ax.set_yscale("log")
    _plain_log_labels(ax.yaxis)


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


def look_index(color: str) -> int | None:
    """The palette place of a design's colour (its width and marker, :data:`WIDTH_SCALE`, :data:`MARKERS`); None for
    other colours (greys of reference lines)."""
    try:
        return PALETTE.index(color)
    except ValueError:
        return None


def draw_curve(ax, x, y, c: Curve, *, width: float | None = None, label: str | None = "", markers: bool = True):
    """One curve in its design's look: its colour, a width that nests it in the curves drawn before it
    (:data:`WIDTH_SCALE`, narrower ones on top) and, on solid lines when ``markers``, its marker every
    :data:`MARKER_EVERY` of the axes' diagonal, offset per design so that markers of coinciding curves do not
    cover each other."""
    k = look_index(c.color)
    lw = (c.width if width is None else width) * (1.0 if k is None else WIDTH_SCALE[k])
    kw = {"color": c.color, "lw": lw, "label": c.label if label == "" else label}
    if k is not None:
        kw["zorder"] = 2.0 + 0.05 * k
        if markers and c.style in ("-", "solid"):
            kw.update(marker=MARKERS[k], markevery=(0.02 + 0.023 * k, MARKER_EVERY), ms=4.2, mfc="white",
                      mew=1.0)
    return ax.plot(x, y, c.style, **kw)


DB_SPAN = 140.0
"""Decibels shown below the highest curve of a dB axis: a notch or the zero of a discrete filter at the Nyquist
frequency (-700 dB) would otherwise set the scale and flatten every curve that matters."""


def _db_span(ax) -> None:
    """The y axis of a dB plot limited to :data:`DB_SPAN` below its highest curve (only when the data reach lower)."""
    values = [np.asarray(line.get_ydata(), float) for line in ax.get_lines()]
    values = np.concatenate([v[np.isfinite(v)] for v in values]) if values else np.empty(0)
    if values.size and values.min() < values.max() - DB_SPAN:
        ax.set_ylim(values.max() - DB_SPAN, values.max() + 0.05 * DB_SPAN)


def _mark_points(ax, xs, ys, color, marker="o") -> None:
    if len(xs):
        ax.plot(xs, ys, marker, color=color, ms=5, mfc="white", mew=1.3, zorder=5)


def _nyquist_line(ax, fs_hz: float | None) -> None:
    if fs_hz:
        ax.axvline(fs_hz / 2, color="0.35", lw=0.8, ls="-.", label=f"Nyquist frequency {fs_hz / 2:g} Hz")


# ------------------------------------------------------------------------------------------ identification
def frf_figure(channels: Sequence[str], measured: dict, model: dict, coherence: dict, *, unit: str,
               title: str, band_hz: Sequence[float] | None = None, width: float = WIDTH_IN,
               coherence_min: float = 0.5):
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
    coherence_min : float
        Measured lines with a lower coherence [-] are drawn faint (and do not set the phase axis).
    """
    from matplotlib.ticker import FixedLocator

    rows = 3 if coherence else 2
    legend = ["measured"] + (["model"] if model else [])
    if coherence:
        legend += [f"measured, coherence < {coherence_min:g}", "coherence"]
    if band_hz is not None:
        legend.append("fit band")
    fig, axes = new_figure(rows, len(channels), height=2.1, width=width, sharex=True, legend=legend)
    for j, ch in enumerate(channels):
        mag, ph = axes[0, j], axes[1, j]
        trusted = []
        if ch in measured:
            f, h = measured[ch]
            p = _phase_aligned(h)
            if ch in model and np.array_equal(model[ch][0], f):
                # measured phase on the model's branch: model phase + wrapped difference (noise stays local)
                p = _phase_aligned(model[ch][1]) + np.rad2deg(np.angle(h / model[ch][1]))
            good = coherence[ch][1] >= coherence_min if ch in coherence else np.ones(p.size, bool)
            m_db = _db(h)
            if not good.all():
                mag.plot(f, m_db, color=PALETTE[0], lw=0.8, alpha=0.3, label=f"measured, coherence < {coherence_min:g}")
                ph.plot(f, p, color=PALETTE[0], lw=0.7, alpha=0.3)
            mag.plot(f, np.where(good, m_db, np.nan), color=PALETTE[0], lw=1.2, label="measured")
            ph.plot(f, np.where(good, p, np.nan), color=PALETTE[0], lw=1.0)
            trusted.append(p[good] if good.any() else p)
        if ch in model:
            f, h = model[ch]
            p = _phase_aligned(h)
            mag.plot(f, _db(h), color=PALETTE[1], lw=1.3, ls="--", label="model")
            ph.plot(f, p, color=PALETTE[1], lw=1.2, ls="--")
            trusted.append(p)
        _phase_limits(ph, trusted)
        mag.set_title(ch, fontsize=9.5)
        mag.set_ylabel(f"|{ch}| [dB re 1 {unit}]")
        mag.yaxis.set_major_locator(_locator())
        ph.set_ylabel("phase [deg]")
        ph.yaxis.set_major_locator(_phase_locator())
        if rows == 3:
            ax = axes[2, j]
            if ch in coherence:
                f, c = coherence[ch]
                ax.plot(f, c, color=PALETTE[2], lw=1.0, label="coherence")
                ax.axhline(coherence_min, color="0.4", lw=0.7, ls=":")
            ax.set_ylim(0, 1.05)
            ax.yaxis.set_major_locator(FixedLocator([0, 0.5, 1]))  # (set_yticks would build the ticks)
            ax.set_ylabel("coherence [-]")
        for ax in axes[:, j]:
            _freq_axis(ax, ax is axes[-1, j])
            if band_hz is not None:
                ax.axvspan(band_hz[0], band_hz[1], color="0.85", alpha=0.5, lw=0,
                           label="fit band" if ax is mag else None)
    set_title(fig, title)
    add_legend(fig)
    return fig


def friction_figure(curves: Sequence[Curve], scatter: Sequence[Curve], *, velocity_unit: str,
                    command_unit: str, title: str):
    """Stribeck friction curves ``d(v)`` and optional disturbance-estimate scatter ``(v, d)``."""
    fig, axes = new_figure(1, height=3.4, legend=_labels([*scatter, *curves]))
    ax = axes[0, 0]
    for s in scatter:
        ax.plot(s.x, s.y, ".", ms=1.5, color=s.color, alpha=0.35, label=s.label, rasterized=True)
    for c in curves:
        ax.plot(c.x, c.y, c.style, color=c.color, lw=c.width, label=c.label)
    ax.axhline(0, color="0.4", lw=0.6)
    ax.axvline(0, color="0.4", lw=0.6)
    ax.set_xlabel(f"velocity [{velocity_unit}]")
    ax.set_ylabel(f"friction / disturbance [{command_unit}]")
    set_title(fig, title)
    add_legend(fig)
    return fig


def gantry_mass_figure(x: np.ndarray, side_masses: np.ndarray, inertia: np.ndarray, yaw_hz: np.ndarray, *,
                       mass_unit: str, inertia_unit: str, points: dict | None = None):
    """Mass distribution ``m1(x), m2(x)``, yaw inertia ``J(x)`` and yaw-mode frequency versus table position.

    ``points`` may hold per-position identified values: ``{"yaw_x", "yaw_hz"}`` [m, Hz] and ``{"mass_x", "m1",
    "m2"}`` [m, mass unit].
    """
    points = points or {}
    legend = ["m1 (side 1)", "m2 (side 2)", "J(x)", "yaw mode, model"]
    if len(points.get("yaw_hz", ())):
        legend.append("yaw mode identified per position")
    if len(points.get("m1", ())):
        legend += ["m1 identified", "m2 identified"]
    fig, axes = new_figure(1, 3, height=2.8, legend=legend)
    a, b, c = axes[0]
    c.plot(x, yaw_hz, color=PALETTE[3], label="yaw mode, model")
    a.plot(x, side_masses[:, 0], color=PALETTE[0], label="m1 (side 1)")
    a.plot(x, side_masses[:, 1], color=PALETTE[1], label="m2 (side 2)")
    a.set_ylabel(f"side mass [{mass_unit}]")
    b.plot(x, inertia, color=PALETTE[2], label="J(x)")
    b.set_ylabel(f"yaw inertia [{inertia_unit}]")
    if len(points.get("yaw_hz", ())):
        c.plot(points["yaw_x"], points["yaw_hz"], "o", color=PALETTE[4], label="yaw mode identified per position")
    if len(points.get("m1", ())):
        a.plot(points["mass_x"], points["m1"], "o", color=PALETTE[0], mfc="none", label="m1 identified")
        a.plot(points["mass_x"], points["m2"], "s", color=PALETTE[1], mfc="none", label="m2 identified")
    c.set_ylabel("yaw mode [Hz]")
    for ax in (a, b, c):
        ax.set_xlabel("table position x [m]")
        ax.yaxis.set_major_locator(_locator(4))
    set_title(fig, "Gantry mass distribution and yaw mode versus table position")
    add_legend(fig)
    return fig


# ------------------------------------------------------------------------------------------ design
def pole_map_figure(open_loop: np.ndarray, closed: Sequence[tuple[str, str, np.ndarray]], *, zoom_rad_s: float):
    """Open- and closed-loop poles in the s-plane [rad/s] (thesis Fig. 3.6): all poles and a zoom.

    ``closed`` holds ``(label, colour, poles)`` per controller.
    """
    legend = ["open loop (model)"] + [f"closed loop, {label}" for label, _, _ in closed]
    fig, axes = new_figure(1, 2, height=3.4, legend=legend)
    for k, ax in enumerate(axes[0]):
        ax.plot(open_loop.real, open_loop.imag, "x", color="0.2", ms=8, mew=1.6, label="open loop (model)")
        for label, color, p in closed:
            k = look_index(color)
            ax.plot(p.real, p.imag, MARKERS[k] if k is not None else "o", mfc="none", color=color, ms=7, mew=1.4,
                    label=f"closed loop, {label}")
        ax.axvline(0, color="0.4", lw=0.7)
        ax.axhline(0, color="0.4", lw=0.7)
        ax.set_xlabel("real part [rad/s]")
        ax.set_ylabel("imaginary part [rad/s]")
        ax.xaxis.set_major_locator(_locator(4))
        if k == 1:
            ax.set_xlim(-zoom_rad_s, 0.1 * zoom_rad_s)
            ax.set_ylim(-zoom_rad_s, zoom_rad_s)
            ax.set_title(f"zoom: |s| < 2 pi x {zoom_rad_s / (2 * np.pi):.0f} Hz", fontsize=9)
        else:
            ax.set_title("all poles", fontsize=9)
    set_title(fig, "Poles")
    add_legend(fig)
    return fig


def loop_figure(curves: Sequence[Curve], crossovers: dict[str, Sequence[float]], *, title: str = "Loop transfer L"):
    """Loop transfer ``L``: magnitude [dB] with the crossovers marked, and phase [deg] (Fig. 3.10a-b)."""
    fig, axes = new_figure(2, height=2.3, sharex=True, legend=_labels(curves))
    mag, ph = axes[0, 0], axes[1, 0]
    lo, hi = np.inf, -np.inf
    trusted = []
    for c in curves:
        fx, m = log_envelope(c.x, _shown(c, np.abs(c.y)))
        draw_curve(mag, fx, _db(m), c)
        idx = log_decimate(c.x)
        p = _shown(c, _phase_deg(c.y))[idx]
        draw_curve(ph, c.x[idx], p, c, width=c.width * 0.9, label=None)
        trusted.append(p)
        wc = crossovers.get(c.label, ())
        _mark_points(mag, list(wc), [0.0] * len(wc), c.color)
        finite = _db(m)[np.isfinite(m)]
        if finite.size:
            lo, hi = min(lo, float(finite.min())), max(hi, float(finite.max()))
    mag.axhline(0, color="0.3", lw=0.8)
    ph.axhline(-180, color="0.3", lw=0.8, ls=":")
    mag.set_ylabel("|L| [dB]")
    ph.set_ylabel("phase of L [deg]")
    _phase_limits(ph, trusted)
    ph.yaxis.set_major_locator(_phase_locator())
    _freq_axis(mag, False)
    _freq_axis(ph)
    if np.isfinite(lo):
        mag.set_ylim(max(lo, -80.0) - 5, min(hi, 120.0) + 5)
    set_title(fig, title)
    add_legend(fig)
    return fig


def nyquist_figure(curves: Sequence[Curve], ms: dict[str, float], *, title: str = "Nyquist plot of L"):
    """Nyquist plot of ``L`` near -1 with the circle ``|1 + L| = 1/Ms`` of every controller (Fig. 3.10c-d)."""
    legend = [*_labels(curves), *(f"|1+L| = 1/Ms, {c.label}" for c in curves if ms.get(c.label)), "|L| = 1", "-1"]
    fig, axes = new_figure(1, height=4.6, width=NYQUIST_WIDTH_IN, legend=legend)
    ax = axes[0, 0]
    th = np.linspace(0, 2 * np.pi, 181)
    for c in curves:
        draw_curve(ax, _shown(c, c.y.real), _shown(c, c.y.imag), c)
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
    set_title(fig, title)
    add_legend(fig)
    return fig


def sensitivity_figure(curves: Sequence[Curve], peaks: dict[str, tuple[float, float]],
                       ms_limit: float | None = None, *, title: str = "Sensitivity |S|"):
    """Sensitivity magnitude ``|S|`` [dB] with each ``Ms`` marked (Fig. 3.11)."""
    labels = [c.label + (f" (Ms {peaks[c.label][1]:.3g} at {peaks[c.label][0]:.4g} Hz)" if c.label in peaks else "")
              for c in curves]
    fig, axes = new_figure(1, height=3.0, legend=labels + ([f"Ms limit {ms_limit:.3g}"] if ms_limit else []))
    ax = axes[0, 0]
    top = 0.0
    for c, label in zip(curves, labels, strict=True):
        fx, m = log_envelope(c.x, _shown(c, np.abs(c.y)))
        if c.label in peaks:
            f0, ms = peaks[c.label]
            _mark_points(ax, [f0], [20 * np.log10(ms)], c.color)
        draw_curve(ax, fx, _db(m), c, label=label)
        finite = _db(m)[np.isfinite(m)]
        if finite.size:
            top = max(top, float(finite.max()))
    ax.set_ylim(-60.0, top + 6.0)
    ax.axhline(0, color="0.3", lw=0.8)
    if ms_limit:
        ax.axhline(20 * np.log10(ms_limit), color="0.3", lw=0.8, ls="--", label=f"Ms limit {ms_limit:.3g}")
    _freq_axis(ax)
    ax.set_ylabel("|S| [dB]")
    set_title(fig, title)
    add_legend(fig)
    return fig


def magnitude_figure(curves: Sequence[Curve], *, ylabel: str, scale: float = 1.0, db: bool = False,
                     phase: bool = False, loglog: bool = True, title: str = ""):
    """Magnitude (and optionally phase) of frequency responses, e.g. ``x2/d2`` or ``x2/x_r``."""
    from matplotlib.ticker import FixedLocator

    fig, axes = new_figure(2 if phase else 1, height=2.5, sharex=True, legend=_labels(curves))
    ax = axes[0, 0]
    for c in curves:
        fx, m = log_envelope(c.x, _shown(c, np.abs(c.y) * scale))
        draw_curve(ax, fx, _db(m) if db else m, c)
    if loglog and not db:
        _log_y(ax)
    if db:
        _db_span(ax)
    _freq_axis(ax, not phase)
    ax.set_ylabel(ylabel)
    if phase:
        ph = axes[1, 0]
        for c in curves:
            idx = log_decimate(c.x)
            draw_curve(ph, c.x[idx], _shown(c, _phase_wrapped(c.y))[idx], c, width=c.width * 0.9, label=None)
        ph.set_ylabel("phase [deg]")
        ph.set_ylim(-185, 185)
        ph.yaxis.set_major_locator(FixedLocator([-180, -90, 0, 90, 180]))
        _freq_axis(ph)
    set_title(fig, title)
    add_legend(fig)
    return fig


def controller_figure(paths: Sequence[Curve], filters: Sequence[Curve], *, unit: str, fs_hz: float | None,
                      title: str):
    """Bode plot of a controller's feedback paths (left, [dB re 1 ``unit``]) and of its filter pack (right, [dB]).

    ``paths`` and ``filters`` hold complex responses on a frequency grid [Hz]; the Nyquist frequency ``fs/2`` is
    marked.
    """
    legend = [*_labels(paths), *_labels(filters)] + ([f"Nyquist frequency {fs_hz / 2:g} Hz"] if fs_hz else [])
    fig, axes = new_figure(2, 2, height=2.1, sharex=True, legend=legend)
    for col, curves, mag_label in ((0, paths, f"|K| [dB re 1 {unit}]"), (1, filters, "|filter pack| [dB]")):
        mag, ph = axes[0, col], axes[1, col]
        trusted = []
        for c in curves:
            mag.plot(c.x, _db(c.y), c.style, color=c.color, lw=c.width, label=c.label)
            p = _phase_deg(c.y)
            ph.plot(c.x, p, c.style, color=c.color, lw=c.width * 0.9)
            trusted.append(p)
        for ax in (mag, ph):
            _nyquist_line(ax, fs_hz)
            _freq_axis(ax, ax is ph)
        mag.set_ylabel(mag_label)
        mag.yaxis.set_major_locator(_locator(5))
        ph.set_ylabel("phase [deg]")
        _phase_limits(ph, trusted)
        ph.yaxis.set_major_locator(_phase_locator())
    axes[0, 0].set_title("controller (discrete, as executed)", fontsize=9)
    axes[0, 1].set_title("filter pack (discrete)", fontsize=9)
    set_title(fig, title)
    add_legend(fig)
    return fig


# ------------------------------------------------------------------------------------------ time domain
@dataclass(frozen=True)
class TimePanel:
    """One row of a time figure: its y label and curves (x in s).

    ``own_scale``: when the largest peak of some curves dwarfs the others' (:data:`DWARF_RATIO`), the smaller ones are
    drawn again in a row of their own, at their scale (:func:`dwarf_split`)."""

    ylabel: str
    curves: Sequence[Curve]
    own_scale: bool = False


DWARF_RATIO = 4.0
"""A curve whose peak is below this fraction of the largest peak of its panel is dwarfed: it gets a row at its own
scale."""


def dwarf_split(curves: Sequence[Curve]) -> tuple[list[Curve], list[Curve]]:
    """``(all, dwarfed)``: the dwarfed curves are those whose peak ``|y|`` is below ``1 / DWARF_RATIO`` of the
    largest (none when every curve is within that ratio).

    Examples
    --------
    >>> t = np.linspace(0, 1, 5)
    >>> big, small = Curve(t, 385 * np.sin(t), "PID"), Curve(t, 6 * np.sin(t), "MIMO")
    >>> [c.label for c in dwarf_split([big, small])[1]]
    ['MIMO']
    """
    peaks = [float(np.nanmax(np.abs(c.y), initial=0.0)) for c in curves]
    top = max(peaks, default=0.0)
    small = [c for c, p in zip(curves, peaks, strict=True) if top > 0 and p * DWARF_RATIO < top]
    return list(curves), small


@dataclass(frozen=True)
class Window:
    """A zoomed time window [s] shown beside the whole run, with a short title."""

    title: str
    t0: float
    t1: float


def _unit_of(label: str) -> str:
    """``"tracking error [µm]"`` -> ``"[µm]"`` (the zoom axes beside a labelled one); other labels unchanged."""
    return "[" + label.rsplit("[", 1)[1] if "[" in label else label


def _plot_time(ax, c: Curve, t0: float | None = None, t1: float | None = None, columns: int = PIXEL_COLUMNS):
    x, y = np.asarray(c.x, float), np.asarray(c.y, float)
    if t0 is not None:
        i0, i1 = np.searchsorted(x, [t0, t1])
        x, y = x[max(i0 - 1, 0):i1 + 1], y[max(i0 - 1, 0):i1 + 1]
    x, y = envelope(x, y, columns)
    draw_curve(ax, x, y, c, width=c.width * 0.8, markers=False)


def time_figure(panels: Sequence[TimePanel], windows: Sequence[Window], spectrum: Sequence[Curve], *,
                time_label: str, spectrum_label: str, title: str, spectrum_loglog: bool = False):
    """Time-domain runs (Fig. 3.15, 3.14, 4.17): each panel over the whole run (left) and in the zoomed
    ``windows`` beside it (the windows are shaded on the whole-run axes), and a spectrum across the bottom.

    Panels without curves are left out; so is the spectrum when it has no curve.
    """
    split = []
    for p in panels:
        if not p.curves:
            continue
        split.append(p)
        small = dwarf_split(p.curves)[1] if p.own_scale else []
        if small:  # the dwarfed curves again, at their own scale
            split.append(TimePanel(f"the smaller {_unit_of(p.ylabel)}", small))
    panels = split
    rows = len(panels) + (1 if spectrum else 0)
    cols = 1 + len(windows)
    legend = list(dict.fromkeys(c.label for p in panels for c in p.curves if c.label))
    legend += [c.label for c in spectrum if c.label and c.label not in legend]
    fig, axes = new_figure(rows, cols, height=2.0, legend=legend, span_last=bool(spectrum) and cols > 1,
                           width_ratios=[1.45] + [1.0] * len(windows) if windows else None)
    whole_cols = PIXEL_COLUMNS // (1 + len(windows))
    zoom_cols = max(200, PIXEL_COLUMNS // (2 + len(windows)))
    for r, panel in enumerate(panels):
        ax = axes[r, 0]
        for c in panel.curves:
            _plot_time(ax, c, columns=whole_cols)
        for w in windows:
            ax.axvspan(w.t0, w.t1, color="0.88", lw=0, zorder=0)
        ax.set_ylabel(panel.ylabel)
        ax.set_xlabel(time_label)
        ax.yaxis.set_major_locator(_locator(4))
        ax.xaxis.set_major_locator(_locator(5 if windows else 8))
        if r == 0 and windows:
            ax.set_title("whole run (zoom windows shaded)", fontsize=8.5)
        for k, w in enumerate(windows, start=1):
            zx = axes[r, k]
            for c in panel.curves:
                _plot_time(zx, c, w.t0, w.t1, columns=zoom_cols)
            zx.set_xlim(w.t0, w.t1)
            zx.set_ylabel(_unit_of(panel.ylabel))
            zx.set_xlabel(time_label)
            zx.xaxis.set_major_locator(_locator(3))
            zx.yaxis.set_major_locator(_locator(4))
            if r == 0:
                zx.set_title(w.title, fontsize=8)
    if spectrum:
        ax = axes[-1, 0]
        for c in spectrum:
            x, y = log_envelope(c.x, c.y)
            draw_curve(ax, x, y, c, width=c.width * 0.9, markers=False)
        _freq_axis(ax)
        if spectrum_loglog:
            _log_y(ax)
        ax.set_ylabel(spectrum_label)
    set_title(fig, title)
    add_legend(fig)
    return fig


def contour_figure(paths: Sequence[tuple[str, str, np.ndarray, np.ndarray, np.ndarray, np.ndarray]],
                   errors: Sequence[Curve], *, title: str):
    """x-y path against its reference and the contour error versus time (Fig. 4.20-4.22).

    ``paths`` holds ``(label, colour, x_ref, y_ref, x, y)`` [m]; ``errors`` the contour error [µm] vs t [s], drawn as
    magnitudes on a log axis when one run's error dwarfs another's (:func:`dwarf_split`).
    """
    fig, axes = new_figure(1, 2, height=3.6, legend=["reference"] + [p[0] for p in paths])
    ax, ae = axes[0]
    for i, (label, color, xr, yr, x, y) in enumerate(paths):
        if i == 0:
            ax.plot(xr * 1e3, yr * 1e3, color="0.2", lw=1.0, ls="--", label="reference")
        draw_curve(ax, x * 1e3, y * 1e3, Curve(x, y, label, color, "-", 1.0), markers=False)
    ax.set_xlabel("x [mm]")
    ax.set_ylabel("y [mm]")
    ax.set_aspect("equal", adjustable="datalim")
    dwarfed = bool(dwarf_split(errors)[1])  # one run's error dwarfs another's: magnitudes on a log axis show both
    for c in errors:
        t, e = envelope(c.x, np.abs(c.y) if dwarfed else c.y, PIXEL_COLUMNS // 2)
        draw_curve(ae, t, e, c, width=0.8, markers=False)
    ae.set_xlabel("time [s]")
    ae.set_ylabel("|contour error| [µm]" if dwarfed else "contour error [µm]")
    if dwarfed:
        _log_y(ae)
    set_title(fig, title)
    add_legend(fig)
    return fig


# ------------------------------------------------------------------------------------------ output
PNG_LEVEL = 1
"""zlib level of the PNG images (1: fastest; the pictures are mostly flat colour and compress well anyway)."""


def encode_png(rgba: np.ndarray, dpi: float = DPI) -> bytes:
    """A PNG file (8-bit RGBA, every row "up"-filtered) of an ``(height, width, 4)`` uint8 image.

    The "up" filter (each row minus the one above) turns the long horizontal runs of a plot into zeros; with zlib
    at :data:`PNG_LEVEL` this is several times faster than Pillow's adaptive filtering, for a similar size.

    Examples
    --------
    >>> import io; from PIL import Image
    >>> img = np.random.default_rng(1).integers(0, 256, (5, 7, 4), dtype=np.uint8)
    >>> bool((np.asarray(Image.open(io.BytesIO(encode_png(img)))) == img).all())
    True
    """
    import struct
    import zlib

    img = np.ascontiguousarray(rgba, dtype=np.uint8)
    h, w = img.shape[:2]
    flat = img.reshape(h, w * 4)
    raw = np.empty((h, w * 4 + 1), np.uint8)
    raw[:, 0] = 2  # filter type "up"
    raw[:1, 1:] = flat[:1]
    np.subtract(flat[1:], flat[:-1], out=raw[1:, 1:])

    def chunk(kind: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))

    ppm = round(dpi / 0.0254)
    return b"".join([b"\x89PNG\r\n\x1a\n", chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 6, 0, 0, 0)),
                     chunk(b"pHYs", struct.pack(">IIB", ppm, ppm, 1)),
                     chunk(b"IDAT", zlib.compress(raw, PNG_LEVEL)), chunk(b"IEND", b"")])


def figure_png(fig) -> bytes:
    """The figure as PNG bytes at :data:`DPI` (drawn once on its Agg canvas, encoded by :func:`encode_png`)."""
    finish_figure(fig)
    canvas = fig.canvas
    if fig.dpi != DPI or not hasattr(canvas, "buffer_rgba"):
        import io

        buf = io.BytesIO()
        fig.savefig(buf, format="png", dpi=DPI, pil_kwargs={"compress_level": PNG_LEVEL})
        return buf.getvalue()
    canvas.draw()
    return encode_png(np.asarray(canvas.buffer_rgba()), DPI)


# ------------------------------------------------------------------------------------------ MIMO
def singular_value_figure(curves: Sequence[tuple], *, ylabel: str, peaks: dict | None = None,
                          level_db: float | None = 0.0, ms_limit: float | None = None, title: str = ""):
    """Upper (solid) and lower (dashed) singular values [dB] of 2x2 responses (thesis Figs. 4.13-4.15).

    ``curves`` holds ``(label, colour, freq_hz, sigma_max, sigma_min)`` or, with the points to draw,
    ``(label, colour, freq_hz, sigma_max, sigma_min, mask)``; ``peaks`` ``{label: (f, value)}`` marks a peak such
    as ``Ms``.
    """
    labels = []
    for item in curves:
        upper = f"{item[0]}, upper"
        if peaks and item[0] in peaks:
            upper += f" (max {peaks[item[0]][1]:.3g} at {peaks[item[0]][0]:.4g} Hz)"
        labels += [upper, f"{item[0]}, lower"]
    fig, axes = new_figure(1, height=3.0, legend=labels + ([f"Ms limit {ms_limit:.3g}"] if ms_limit else []))
    ax = axes[0, 0]
    for k, item in enumerate(curves):
        label, color, f, hi, lo = item[:5]
        mask = item[5] if len(item) > 5 else None
        probe = Curve(f, hi, label, color, mask=mask)
        fx, h = log_envelope(f, _shown(probe, hi))
        if peaks and label in peaks:
            f0, v = peaks[label]
            _mark_points(ax, [f0], [20 * np.log10(v)], color)
        draw_curve(ax, fx, _db(h), Curve(f, hi, labels[2 * k], color, "-", 1.5))
        fl, low = log_envelope(f, _shown(probe, lo))
        draw_curve(ax, fl, _db(low), Curve(f, lo, labels[2 * k + 1], color, "--", 1.0))
    if level_db is not None:
        ax.axhline(level_db, color="0.3", lw=0.8)
    if ms_limit:
        ax.axhline(20 * np.log10(ms_limit), color="0.3", lw=0.8, ls=":", label=f"Ms limit {ms_limit:.3g}")
    _db_span(ax)
    _freq_axis(ax)
    ax.set_ylabel(ylabel)
    set_title(fig, title)
    add_legend(fig)
    return fig


def det_nyquist_figure(curves: Sequence[Curve], *, title: str = "MIMO Nyquist plot of det(I + L)"):
    """MIMO Nyquist plot: ``det(I + L)`` around the origin (thesis Fig. 4.13 right)."""
    fig, axes = new_figure(1, height=4.6, width=NYQUIST_WIDTH_IN, legend=[*_labels(curves), "origin",
                                                                         "|det(I + L)| = 1"])
    ax = axes[0, 0]
    for c in curves:
        draw_curve(ax, _shown(c, c.y.real), _shown(c, c.y.imag), c)
    ax.plot([0], [0], "+", color="k", ms=12, mew=2, label="origin")
    th = np.linspace(0, 2 * np.pi, 181)
    ax.plot(np.cos(th), np.sin(th), color="0.6", lw=0.7, ls="--", label="|det(I + L)| = 1")
    ax.set_xlim(-3, 5)
    ax.set_ylim(-4, 4)
    ax.set_aspect("equal", adjustable="box")
    ax.set_xlabel("Re det(I + L) [-]")
    ax.set_ylabel("Im det(I + L) [-]")
    set_title(fig, title)
    add_legend(fig)
    return fig


def objective_figure(edges: np.ndarray, front: np.ndarray, chosen: tuple[float, float], *, gain_label: str,
                     title: str):
    """The tuner's edges in the plane of both objectives: integral gain against the guaranteed first crossover.

    ``edges`` and ``front`` are ``(n, 2)`` arrays of ``(first crossover [Hz], integral gain)`` (every shape's edge the
    tuner recorded; the Pareto front, drawn as a staircase), ``chosen`` the design in the gains file.
    """
    legend = ["edge of a shape (limits met)", "Pareto front", "chosen design"]
    fig, axes = new_figure(1, 1, height=3.2, legend=legend)
    ax = axes[0, 0]
    if edges.size:
        ax.plot(edges[:, 0], edges[:, 1], "o", mfc="none", color="0.45", ms=5, mew=1.0,
                label="edge of a shape (limits met)")
    if front.size:
        f = front[np.argsort(front[:, 0])]
        ax.plot(f[:, 0], f[:, 1], "-o", color=PALETTE[0], ms=4, lw=1.3, drawstyle="steps-post", label="Pareto front")
    ax.plot([chosen[0]], [chosen[1]], "*", color=PALETTE[1], ms=13, label="chosen design")
    ax.set_xlabel("guaranteed first crossover [Hz]")
    ax.set_ylabel(gain_label)
    set_title(fig, title)
    add_legend(fig)
    return fig
