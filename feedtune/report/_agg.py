"""The matplotlib classes of the report figures: an Agg canvas that keeps rendered texts, and axes that build no
tick before one is drawn.

Imported lazily (by :func:`feedtune.report.figures.new_figure`): importing this module imports matplotlib.

* :class:`Canvas` / :class:`Renderer`: tick labels, axis labels and legend entries repeat across the figures
  ("frequency [Hz]", "100", "phase [deg]"); matplotlib lays out and rasterises each of them glyph by glyph at every
  draw. This renderer places every plain text at a whole pixel, rasterises it once (recording the coverage bitmaps
  matplotlib's renderer would blend) and blends the recorded bitmaps at every later use, in this figure or another.
  The pixels do not depend on which figure drew a text first, so figures drawn in several processes are
  byte-identical. Text metrics are kept likewise. Mathtext, TeX and canvases of a fractional pixel height take
  matplotlib's own path.
* :class:`LightAxes`: matplotlib builds one major and one minor tick (five artists each) for each axis of a new
  axes, only to apply the clip path and tick parameters to them. Here the parameters are stored (as matplotlib
  stores them for the ticks it builds later) and a tick is built when an axis draws one: a report figure, whose
  ticks are drawn as plain texts and lines (:func:`feedtune.report.figures.finish_figure`), builds none.
"""

from __future__ import annotations

from contextlib import contextmanager

import numpy as np
from matplotlib import axis as maxis
from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg, RendererAgg
from matplotlib.ticker import Locator

TEXT_CACHE_SIZE = 4096
"""Rendered texts (and text metrics) kept for reuse; a cache is emptied when it holds more."""
_TEXT_IMAGES: dict = {}
_TEXT_METRICS: dict = {}
_FONT_HEIGHTS: dict = {}


def _remember(cache: dict, key, value):
    if len(cache) >= TEXT_CACHE_SIZE:
        cache.clear()
    cache[key] = value
    return value


def _font_key(prop) -> tuple:
    """What a rendered text depends on in a ``FontProperties`` (the fields matplotlib hashes)."""
    return (tuple(prop.get_family()), prop.get_slant(), prop.get_variant(), prop.get_weight(), prop.get_stretch(),
            prop.get_size(), prop.get_file(), prop.get_math_fontfamily())


class _NotRecordedError(Exception):
    pass


class _Recorder:
    """Stands in for the Agg core while a text is rasterised: keeps the bitmaps instead of blending them."""

    def __init__(self):
        self.calls = []

    def draw_text_image(self, image, x, y, angle, gc):
        self.calls.append((np.array(image, dtype=np.uint8, copy=True), x, y, angle))

    def __getattr__(self, name):  # anything else (e.g. mathtext boxes): not recorded, matplotlib draws the text
        raise _NotRecordedError(name)


class Renderer(RendererAgg):
    """Agg renderer that blends a text it has seen before from the bitmaps recorded the first time."""

    def draw_text(self, gc, x, y, s, prop, angle, ismath=False, mtext=None):
        if ismath or not float(self.height).is_integer():
            return super().draw_text(gc, x, y, s, prop, angle, ismath=ismath, mtext=mtext)
        extra = ()
        if mtext is not None:
            extra = (tuple(mtext.get_fontfeatures() or ()) if hasattr(mtext, "get_fontfeatures") else None,
                     mtext.get_language() if hasattr(mtext, "get_language") else None)
        key = (s, _font_key(prop), float(angle), bool(gc.get_antialiased()), float(self.dpi), extra)
        xi, yi = round(x), round(y)  # whole pixels: the bitmaps then do not depend on where the text is
        images = _TEXT_IMAGES.get(key)
        if images is None:
            real, rec = self._renderer, _Recorder()
            self._renderer = rec
            try:
                super().draw_text(gc, xi, yi, s, prop, angle, ismath=ismath, mtext=mtext)
                images = tuple((img, px - xi, py - yi, a) for img, px, py, a in _merged(rec.calls))
            except Exception:  # e.g. boxes (_NotRecordedError): matplotlib draws this text every time
                images = ()
            finally:
                self._renderer = real
            _remember(_TEXT_IMAGES, key, images)
        if not images:  # nothing to blend, or a text the recorder could not take: matplotlib draws it
            return super().draw_text(gc, x, y, s, prop, angle, ismath=ismath, mtext=mtext)
        for img, dx, dy, a in images:
            self._renderer.draw_text_image(img, xi + dx, yi + dy, a, gc)

    def get_text_width_height_descent(self, s, prop, ismath):
        if ismath:
            return super().get_text_width_height_descent(s, prop, ismath)
        key = (s, _font_key(prop), float(self.dpi))
        got = _TEXT_METRICS.get(key)
        if got is None:
            got = _remember(_TEXT_METRICS, key, super().get_text_width_height_descent(s, prop, ismath))
        return got

    def _get_font_height_metrics(self, prop):
        """``(ascent, descent, line gap)`` [px] of the font, as matplotlib's text layout computes them (it asks a
        renderer that has this method; the answer is kept here instead of read from the font for every text)."""
        key = (_font_key(prop), float(self.dpi))
        got = _FONT_HEIGHTS.get(key)
        if got is None:
            got = _remember(_FONT_HEIGHTS, key, _font_height_metrics(prop, self.dpi))
        return got


def _font_height_metrics(prop, dpi: float) -> tuple:
    """What ``matplotlib.text.Text._get_layout`` reads from the font's OS/2 or hhea table (None: it measures)."""
    try:
        from matplotlib.font_manager import fontManager, get_font

        font = get_font(fontManager._find_fonts_by_props(prop))
        for table_name, gap_key, ascent_key, descent_key in (
                ("OS/2", "sTypoLineGap", "sTypoAscender", "sTypoDescender"), ("hhea", "lineGap", "ascent", "descent")):
            table = font.get_sfnt_table(table_name)
            if table is None:
                continue
            scale = 1 / font.get_sfnt_table("head")["unitsPerEm"] * prop.get_size_in_points() * dpi / 72
            return table[ascent_key] * scale, -table[descent_key] * scale, table[gap_key] * scale
    except Exception:  # another matplotlib: let it measure
        pass
    return None, None, None


def _merged(calls: list) -> list:
    """The glyph bitmaps of one text (``(coverage, x, bottom y, 0)``, rows downwards) as one bitmap: one blend
    instead of one per glyph. Where the antialiased edges of two glyphs overlap the larger coverage is kept (the
    sequential blends would give ``1 - (1 - a)(1 - b)``: a difference of a few levels in a few edge pixels).
    Rotated bitmaps (older matplotlib) are kept as they are."""
    if len(calls) < 2 or any(a != 0 for _, _, _, a in calls):
        return calls
    left = min(x for _, x, _, _ in calls)
    top = min(y - img.shape[0] for img, _, y, _ in calls)
    right = max(x + img.shape[1] for img, x, _, _ in calls)
    bottom = max(y for _, _, y, _ in calls)
    out = np.zeros((bottom - top, right - left), np.uint8)
    for img, x, y, _ in calls:
        r0, c0 = y - img.shape[0] - top, x - left
        view = out[r0:r0 + img.shape[0], c0:c0 + img.shape[1]]
        np.maximum(view, img, out=view)
    return [(out, left, bottom, 0)]


class Canvas(FigureCanvasAgg):
    """Agg canvas drawing with :class:`Renderer` on a buffer of whole pixels."""

    def get_renderer(self, *args, **kwargs):
        w, h = self.get_width_height(physical=True)  # whole pixels, as the Agg buffer
        key = w, h, self.figure.dpi
        if getattr(self, "_lastKey", None) != key or not isinstance(getattr(self, "renderer", None), Renderer):
            self.renderer = Renderer(w, h, self.figure.dpi)
            self._lastKey = key
        return self.renderer


@contextmanager
def _ticks_left_unbuilt(axis):
    """Inside the block, the tick lists matplotlib has not built yet read as empty (and are not built)."""
    unbuilt = [n for n in ("majorTicks", "minorTicks") if n not in vars(axis)]
    for n in unbuilt:
        setattr(axis, n, [])
    try:
        yield
    finally:
        for n in unbuilt:
            if n in vars(axis) and not vars(axis)[n]:
                delattr(axis, n)  # lazy again


class _LightAxisMixin:
    """Clip path and tick parameters stored for the ticks built later, instead of building the first ticks to
    apply them to."""

    def set_clip_path(self, path, transform=None):
        self._light_clip = (path, transform)
        with _ticks_left_unbuilt(self):
            super().set_clip_path(path, transform)

    def set_tick_params(self, which="major", reset=False, **kwargs):
        with _ticks_left_unbuilt(self):
            super().set_tick_params(which=which, reset=reset, **kwargs)

    def _get_tick(self, major):
        tick = super()._get_tick(major)
        clip = getattr(self, "_light_clip", None)
        if clip is not None:
            tick.set_clip_path(*clip)
        return tick


class LightXAxis(_LightAxisMixin, maxis.XAxis):
    """An x axis whose ticks are built when drawn."""


class LightYAxis(_LightAxisMixin, maxis.YAxis):
    """A y axis whose ticks are built when drawn."""


class LightAxes(Axes):
    """Axes whose two axes build their ticks when drawn (:class:`LightXAxis`, :class:`LightYAxis`)."""

    def _init_axis(self):
        super()._init_axis()
        # the same objects, made light before anything builds a tick (the classes add no state of their own)
        self.xaxis.__class__ = LightXAxis
        self.yaxis.__class__ = LightYAxis

    def clear(self):
        super().clear()
        for spine in self.spines.values():
            spine.get_position()  # places the spine (matplotlib does it when the first ticks are built)


class ClippedLocator(Locator):
    """``base`` (a matplotlib Locator) returning only the ticks inside the view (matplotlib builds a tick for
    every location a locator returns, drawn or not)."""

    def __init__(self, base):
        self.base = base

    def set_axis(self, axis):
        super().set_axis(axis)
        self.base.set_axis(axis)

    def __call__(self):
        lo, hi = sorted(self.axis.get_view_interval())
        tol = 1e-9 * max(abs(lo), abs(hi), 1e-300)
        return [v for v in self.base() if lo - tol <= v <= hi + tol]

    def tick_values(self, vmin, vmax):
        return self.base.tick_values(vmin, vmax)

    def view_limits(self, vmin, vmax):
        return self.base.view_limits(vmin, vmax)
