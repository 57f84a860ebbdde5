"""``.plot()`` of the value types: thin adapters from a value to the report's figure functions.

Every function returns a ``matplotlib.figure.Figure`` drawn by :mod:`feedtune.report.figures` (Agg canvas, no
pyplot state; a notebook shows the returned figure, ``fig.savefig`` writes it). Nothing is computed here beyond
picking curves from results already computed; matplotlib and the report are imported when a figure is drawn.

Examples
--------
>>> import numpy as np
>>> from feedtune.models import THESIS_TABLE_3_1
>>> fig = plot_model(THESIS_TABLE_3_1, np.logspace(0, 3, 50))
>>> [ax.get_ylabel() for ax in fig.axes[:2]]
['|x1/u| [dB re 1 rad/V]', '|x2/u| [dB re 1 rad/V]']
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from .display import frf_unit, register_facade

LOOP_KINDS = ("loop", "nyquist", "sensitivity", "tracking", "disturbance")
"""What :func:`plot_analysis` draws: ``L`` (magnitude and phase), the Nyquist plot of ``L`` (MIMO: ``det(I + L)``),
``|S|`` (MIMO: singular values), the tracking response and the disturbance response."""

RUN_SIGNALS = {
    "track": ("x_ref", "e2", "u"),
    "ropesnap": ("x2", "e2", "u", "d2"),
    "cut": ("x_ref", "e2", "u"),
    "frf": ("r", "u", "x1", "x2"),
}
"""Signals :func:`plot_run` draws for an experiment kind (those the log has); other kinds: the first four."""


def _figures():
    from .report import figures

    return figures


# ------------------------------------------------------------------------------------------ FRFs and models
def plot_frf(frf, channels: Sequence[str] | None = None, *, model=None, title: str | None = None):
    """Magnitude [dB re 1 unit], phase [deg] and coherence [-] per channel (``report.figures.frf_figure``).

    Parameters
    ----------
    frf : Frf
    channels : sequence of str, optional
        Channels ``"OUT/IN"`` (default all).
    model : object, optional
        An :class:`~feedtune.frf.Frf` or a model with ``frf(freq_hz, quantity)``, drawn dashed.
    title : str, optional
        Figure title (default the FRF's source).
    """
    fig_mod = _figures()
    channels = list(channels or frf.channels)
    for ch in channels:
        frf.index(ch)  # DataError naming the channels that exist
    measured = {ch: (frf.freq_hz, frf.channel(ch)) for ch in channels}
    coherence = {}
    for ch in channels:
        c = frf.channel_coherence(ch)
        if c is not None and np.isfinite(c).any():
            coherence[ch] = (frf.freq_hz, c)
    modelled = {}
    if model is not None:
        other = model if hasattr(model, "channels") else model.frf(frf.freq_hz, quantity=frf.quantity)
        other = other.as_quantity(frf.quantity)
        modelled = {ch: (other.freq_hz, other.channel(ch)) for ch in channels if other.has(ch)}
    width = max(fig_mod.WIDTH_IN, 3.3 * len(channels))
    return fig_mod.frf_figure(channels, measured, modelled, coherence, unit=frf_unit(frf),
                              title=title or frf.source, width=width)


def default_model_grid(model) -> np.ndarray:
    """Frequencies [Hz] to draw a model on: 0.1 to 10 times its modes (0.5 Hz to 5 kHz without one)."""
    modes = []
    for name in ("modes", "yaw_mode"):
        fn = getattr(model, name, None)
        if fn is None:
            continue
        try:
            got = fn() if name == "modes" else [fn(0.0)]
        except TypeError:
            got = [fn()]
        modes += [m.freq_hz for m in got]
    if not modes:
        return np.logspace(np.log10(0.5), np.log10(5000.0), 800)
    return np.logspace(np.log10(min(modes) / 30), np.log10(max(modes) * 20), 800)


def plot_model(model, freq_hz=None, *, frf=None, x: float = 0.0, title: str | None = None):
    """A model's frequency response, with a measured FRF when given; a friction or rigid-body model's friction
    curve.

    Parameters
    ----------
    model : BallScrewModel, GantryModel, GantryModelAtX, RigidBodyModel or StribeckFriction
    freq_hz : array_like, optional
        Grid [Hz] (default the FRF's, else :func:`default_model_grid`).
    frf : Frf, optional
        Measurement drawn solid, the model dashed on its grid.
    x : float
        Table position [m] of a :class:`~feedtune.models.gantry.GantryModel`.
    title : str, optional
    """
    if hasattr(model, "force") or hasattr(model, "friction"):
        return plot_friction(model, title=title)
    if freq_hz is None:
        freq_hz = frf.freq_hz[frf.freq_hz > 0] if frf is not None else default_model_grid(model)
    f = np.asarray(freq_hz, float)
    try:
        modelled = model.frf(f, x=x)
    except TypeError:
        modelled = model.frf(f)
    name = title or type(model).__name__
    if frf is None:
        fig_mod = _figures()
        channels = modelled.channels
        curves = {ch: (modelled.freq_hz, modelled.channel(ch)) for ch in channels}
        width = max(fig_mod.WIDTH_IN, 3.3 * len(channels))
        return fig_mod.frf_figure(channels, {}, curves, {}, unit=frf_unit(modelled), title=name, width=width)
    channels = [ch for ch in frf.channels if modelled.has(ch)]
    return plot_frf(frf, channels or None, model=modelled, title=title or f"{frf.source} and {name}")


def plot_friction(model, velocity=None, *, title: str | None = None):
    """Friction ``d(v)`` [command unit] over velocity of a Stribeck/friction law or a rigid-body model
    (``report.figures.friction_figure``).

    Parameters
    ----------
    velocity : array_like, optional
        Velocities [velocity unit] (default +-10 Stribeck velocities, or +-1 unit/s for a rigid-body model).
    """
    fig_mod = _figures()
    if hasattr(model, "force") and hasattr(model, "omega_pos"):
        reach = 10 * model.characteristic_speed or 1.0
        evaluate, unit, vunit = model.force, model.command_unit, model.velocity_unit
    else:
        reach = 1.0
        evaluate, unit, vunit = model.friction, model.command_unit, model.velocity_unit
    v = np.linspace(-reach, reach, 801) if velocity is None else np.asarray(velocity, float)
    curve = fig_mod.Curve(v, np.asarray(evaluate(v), float), type(model).__name__)
    return fig_mod.friction_figure([curve], [], velocity_unit=vunit, command_unit=unit,
                                   title=title or f"{type(model).__name__}: friction")


# ------------------------------------------------------------------------------------------ analyses
def _case_items(analysis, cases):
    items = [(n, c) for n, c in analysis.cases.items() if c is not None and (cases is None or n in cases)]
    if cases is not None:
        missing = [n for n in cases if n not in analysis.cases]
        if missing:
            from .errors import UsageError

            raise UsageError(f"cases: no case {missing[0]!r}; cases: {', '.join(analysis.cases)}",
                             parameter="cases")
    return items


def plot_analysis(analysis, kind: str = "loop", *, cases: Sequence[str] | None = None):
    """One figure of every case of an analysis (or of one case): see :data:`LOOP_KINDS`.

    Parameters
    ----------
    analysis : BallScrewAnalysis, GantryAnalysis, AxisAnalysis, or one of their cases
    kind : str
        ``loop``, ``nyquist``, ``sensitivity``, ``tracking`` or ``disturbance``.
    cases : sequence of str, optional
        Cases to draw (default every case with a result).
    """
    from .errors import UsageError

    if kind not in LOOP_KINDS:
        raise UsageError(f"kind must be one of {', '.join(LOOP_KINDS)}, got {kind!r}", parameter="kind")
    items = [(analysis.name, analysis)] if hasattr(analysis, "metrics") else _case_items(analysis, cases)
    if not items:
        raise UsageError("no case to draw: every requested case needs an FRF the analysis was not given")
    fig_mod = _figures()
    if np.ndim(items[0][1].L) == 3:
        return _plot_mimo(fig_mod, items, kind)
    curves = []
    for i, (name, case) in enumerate(items):
        color = fig_mod.PALETTE[i % len(fig_mod.PALETTE)]
        y = {"loop": case.L, "nyquist": case.L, "sensitivity": case.S, "tracking": case.tracking,
             "disturbance": case.disturbance}[kind]
        if y is not None:
            curves.append((name, case, fig_mod.Curve(case.freq_hz, y, name, color)))
    if not curves:
        raise UsageError(f"no case has a {kind} response (the disturbance is computed on the model cases only)")
    plain = [c for _, _, c in curves]
    if kind == "loop":
        return fig_mod.loop_figure(plain, {n: case.metrics.crossovers_hz for n, case, _ in curves})
    if kind == "nyquist":
        return fig_mod.nyquist_figure(plain, {n: case.metrics.ms for n, case, _ in curves})
    if kind == "sensitivity":
        return fig_mod.sensitivity_figure(plain, {n: (case.metrics.ms_freq_hz, case.metrics.ms)
                                                  for n, case, _ in curves})
    if kind == "tracking":
        return fig_mod.magnitude_figure(plain, ylabel="|x / x_r| [-]", phase=True)
    unit = "m/V" if hasattr(items[0][1], "to_dict") and "disturbance_min_real_m_per_V" in items[0][1].to_dict() \
        else "rad/V"
    return fig_mod.magnitude_figure(plain, ylabel=f"|x / d| [{unit}]")


def _plot_mimo(fig_mod, items, kind: str):
    """Singular values of ``L``, ``S`` or ``S G`` and the Nyquist plot of ``det(I + L)`` of gantry cases."""
    from .errors import UsageError

    colors = fig_mod.PALETTE
    if kind == "nyquist":
        curves = []
        for i, (name, case) in enumerate(items):
            L = case.L
            det = (1 + L[0, 0]) * (1 + L[1, 1]) - L[0, 1] * L[1, 0]
            curves.append(fig_mod.Curve(case.freq_hz, det, name, colors[i % len(colors)]))
        return fig_mod.det_nyquist_figure(curves)
    if kind == "tracking":
        curves = [fig_mod.Curve(c.freq_hz, c.tracking, n, colors[i % len(colors)]) for i, (n, c) in enumerate(items)]
        return fig_mod.magnitude_figure(curves, ylabel="|ybar / y_r| [-]", phase=True)
    key = {"loop": "L", "sensitivity": "S", "disturbance": "SG"}[kind]
    label = {"L": "sigma(L) [dB]", "S": "sigma(S) [dB]", "SG": "sigma(S G) [dB re 1 m/V]"}[key]
    rows, peaks = [], {}
    for i, (name, case) in enumerate(items):
        sv = case.singular_values()
        if key not in sv:
            raise UsageError(f"case {name!r} has no {key}")
        hi, lo = sv[key]
        rows.append((name, colors[i % len(colors)], case.freq_hz, hi, lo))
        if key == "S":
            peaks[name] = (case.metrics.ms_freq_hz, case.metrics.ms)
    return fig_mod.singular_value_figure(rows, ylabel=label, peaks=peaks or None,
                                         level_db=0.0 if key != "SG" else None)


# ------------------------------------------------------------------------------------------ time domain
def plot_log(log, signals: Sequence[str] | None = None, *, title: str | None = None):
    """Signals over time [s], one panel each, units on the axes (min/max envelope per pixel column).

    Parameters
    ----------
    log : Log
    signals : sequence of str, optional
        Signals (default the first 8).
    title : str, optional
    """
    fig_mod = _figures()
    names = list(signals) if signals is not None else list(log.signals)[:8]
    for n in names:
        log.get(n)  # DataError naming the signals that exist
    if not names:
        from .errors import DataError

        raise DataError(f"{log.source}: no signal to draw")
    fig, axes = fig_mod.new_figure(len(names), height=1.9, sharex=True)
    for k, n in enumerate(names):
        ax = axes[k, 0]
        t, y = fig_mod.envelope(log.t, log[n])
        ax.plot(t, y, color=fig_mod.PALETTE[k % len(fig_mod.PALETTE)], lw=0.9, label=n)
        ax.set_ylabel(f"{n} [{log.units.get(n) or '-'}]")
    axes[-1, 0].set_xlabel("time [s]")
    fig.suptitle(title or log.source, fontsize=11)
    return fig


def plot_run(result, signals: Sequence[str] | None = None, *, title: str | None = None):
    """An experiment's log: the signals of :data:`RUN_SIGNALS` for its kind (or ``signals``)."""
    log = result.log
    if signals is None:
        wanted = RUN_SIGNALS.get(result.kind)
        signals = [s for s in wanted if s in log] if wanted else list(log.signals)[:4]
        signals = signals or list(log.signals)[:4]
    trip = " (tripped)" if getattr(result.run, "tripped", False) else ""
    return plot_log(log, signals, title=title or f"{result.kind} run{trip}")


# ------------------------------------------------------------------------------------------ controllers
def plot_law(law, freq_hz=None, *, title: str | None = None):
    """The feedback paths of a ball-screw law, continuous (dashed) and discrete: ``|K1|``, ``|K2|`` and phase
    (``report.figures.magnitude_figure``); ``K1`` in V/rad on the rotary error, ``K2`` on the table error."""
    fig_mod = _figures()
    nyq = law.fs / 2
    f = np.logspace(np.log10(0.5), np.log10(nyq * 0.999), 600) if freq_hz is None else np.asarray(freq_hz, float)
    curves = []
    for i, (name, cont, disc) in enumerate((("K1", law.K1(), law.K1d()), ("K2", law.K2(), law.K2d()))):
        color = fig_mod.PALETTE[i]
        curves.append(fig_mod.Curve(f, cont.freqresp(f), f"{name} continuous", color, "--"))
        curves.append(fig_mod.Curve(f, disc.freqresp(f), f"{name} discrete", color))
    fig = fig_mod.magnitude_figure(curves, ylabel="|K| [command unit/rad]", phase=True)
    if title:
        fig.suptitle(title, fontsize=11)
    return fig


# the value types' .plot()/.to_control()/.from_control() reach these through display.facade()
for _fn in (
    plot_frf, plot_model, plot_friction, plot_analysis, plot_log, plot_run, plot_law,
):
    register_facade(_fn.__name__, _fn)
del _fn
