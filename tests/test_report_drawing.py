"""How the report draws its figures fast without changing what they show: tick labels and grid drawn as plain
artists where matplotlib puts its own, no tick objects built, texts rasterised once and reused (the same pixels
whichever figure drew a text first), PNG encoding, and the same figure as matplotlib's where it is not finished."""

from __future__ import annotations

import io

import numpy as np
import pytest

pytest.importorskip("matplotlib")

from feedtune.report import _agg
from feedtune.report import figures as F  # noqa: N812


def _figure():
    """Two rows: a log-frequency magnitude and a linear phase with fixed ticks, a legend, labels with units."""
    from matplotlib.ticker import FixedLocator

    fig, axes = F.new_figure(2, sharex=True, legend=["L [-]"])
    f = np.logspace(-0.3, 3.2, 400)
    mag, ph = axes[0, 0], axes[1, 0]
    mag.plot(f, F._db(100 / f), label="L [-]")
    ph.plot(f, -90 - 60 * np.tanh(np.log10(f)))
    mag.set_ylabel("|L| [dB]")
    ph.set_ylabel("phase [deg]")
    F._freq_axis(mag, False)
    F._freq_axis(ph)
    ph.yaxis.set_major_locator(FixedLocator([-270, -180, -90, 0, 90]))  # some outside the view
    F.add_legend(fig)
    return fig


def _matplotlib_tick_labels(fig) -> list:
    """(text, x, y) [px] of every tick label matplotlib itself draws."""
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    out = []
    for ax in fig.axes:
        for axis in (ax.xaxis, ax.yaxis):
            for tick in axis._update_ticks():
                if tick.label1.get_visible() and tick.label1.get_text():
                    bb = tick.label1.get_window_extent(renderer)
                    out.append((tick.label1.get_text(), (bb.x0 + bb.x1) / 2, (bb.y0 + bb.y1) / 2))
    return sorted(out)


def test_tick_labels_and_grid_are_where_matplotlib_puts_them():
    ours = _figure()
    theirs = _figure()
    expected = _matplotlib_tick_labels(theirs)
    F.finish_figure(ours)
    ours.canvas.draw()
    renderer = ours.canvas.get_renderer()
    from matplotlib.text import Text

    got = sorted((t.get_text(), (bb.x0 + bb.x1) / 2, (bb.y0 + bb.y1) / 2)
                 for t in ours.artists if isinstance(t, Text) and t.get_fontsize() == F.TICK_LABEL_PT
                 for bb in [t.get_window_extent(renderer)])
    assert [g[0] for g in got] == [e[0] for e in expected] and len(got) >= 8
    assert "-270" not in [g[0] for g in got]  # a fixed tick outside the view is left out, as matplotlib does
    assert np.allclose([g[1:] for g in got], [e[1:] for e in expected], atol=0.51)  # whole pixels
    # one grid line per axis at the tick locations, in matplotlib's grid style
    ph = ours.axes[1]
    grid = [ln for ln in ph.get_lines() if ln.get_zorder() == 1.5]
    assert len(grid) == 2
    xs = np.asarray(grid[0].get_xdata(), float)
    assert set(xs[np.isfinite(xs)]) == {1.0, 10.0, 100.0, 1000.0}
    assert grid[0].get_alpha() == F.GRID_ALPHA and grid[0].get_linewidth() == F.GRID_WIDTH


def test_a_report_figure_builds_no_tick_object(monkeypatch):
    from matplotlib import axis as maxis

    built = []
    init = maxis.Tick.__init__

    def counting(self, *args, **kwargs):
        built.append(self)
        init(self, *args, **kwargs)

    import matplotlib

    monkeypatch.setattr(maxis.Tick, "__init__", counting)
    fig = _figure()
    png = F.figure_png(fig)
    assert png[:8] == b"\x89PNG\r\n\x1a\n"
    if tuple(int(p) for p in matplotlib.__version__.split(".")[:2]) >= (3, 11):
        assert not built  # (plain matplotlib builds 2 per axis, then one per label)
    else:  # before 3.11 an axis asks for its tick list when it draws, even an empty one: the first major and minor
        assert len(built) <= 2 * 2 * len(fig.axes)


def test_unfinished_figures_are_matplotlibs_own(monkeypatch):
    """A figure shown in a notebook (not finished for the report): matplotlib builds its ticks when it draws, the
    pixels equal those of the same figure made with matplotlib's Axes."""
    from matplotlib.axes import Axes

    light_axes = _agg.LightAxes
    light = _figure()
    monkeypatch.setattr(_agg, "LightAxes", Axes)
    plain = _figure()
    assert isinstance(light.axes[0], light_axes) and not isinstance(plain.axes[0], light_axes)
    light.canvas.draw()
    plain.canvas.draw()
    a, b = np.asarray(light.canvas.buffer_rgba()), np.asarray(plain.canvas.buffer_rgba())
    assert a.shape == b.shape and np.array_equal(a, b)


def test_a_text_has_the_same_pixels_whichever_figure_drew_it_first(monkeypatch):
    monkeypatch.setattr(_agg, "_TEXT_IMAGES", {})
    monkeypatch.setattr(_agg, "_TEXT_METRICS", {})
    cold = F.figure_png(_figure())  # every text rasterised here
    other, axes = F.new_figure(1, height=1.7, width=7.31)  # the same texts at other sub-pixel places
    axes[0, 0].plot([1, 1000], [-40, 60])
    axes[0, 0].set_ylabel("|L| [dB]")
    F._freq_axis(axes[0, 0])
    F.figure_png(other)
    monkeypatch.setattr(_agg, "_TEXT_IMAGES", {k: v for k, v in _agg._TEXT_IMAGES.items() if "phase" not in k[0]})
    warm = F.figure_png(_figure())  # most texts from the bitmaps of the other figure
    assert warm == cold


def test_png_encoding_is_lossless_and_readable():
    from PIL import Image

    fig = _figure()
    png = F.figure_png(fig)
    img = np.asarray(Image.open(io.BytesIO(png)))
    assert np.array_equal(img, np.asarray(fig.canvas.buffer_rgba()))
    assert Image.open(io.BytesIO(png)).info.get("dpi", (0, 0))[0] == pytest.approx(F.DPI, abs=0.1)
