"""Progress of long work: the library names its steps, the caller decides whether and how they are shown.

Library code that can take more than a second or two announces what it does::

    from feedtune import progress

    progress.step("tuning MC-PPC")                 # a named step; the previous one ends
    with progress.task("rendering figures", total=12) as advance:
        for fig in figures:
            render(fig)
            advance()                              # one unit of the task done
    progress.note("best Ki2 3.5e4 so far")         # a live figure shown beside the innermost task
    progress.done()                                # the open step ends (before printing a summary)

Nothing is shown unless a reporter is installed with :func:`reporting` (the command line installs one that writes
to stderr: a live display on a terminal, plain lines otherwise, nothing with ``--quiet``). Notebooks and scripts stay
silent by default. Reporters are held in a :class:`contextvars.ContextVar`, so threads and nested calls do not mix.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from contextvars import ContextVar
from typing import Protocol


class Reporter(Protocol):
    """What a progress display implements (:mod:`feedtune.cli.progress_display` holds the command line's)."""

    def start(self, label: str, total: int | None) -> None:
        """A step or task named ``label`` begins; ``total`` units when known."""

    def advance(self, units: int) -> None:
        """``units`` more units of the current task are done."""

    def note(self, text: str) -> None:
        """Show ``text`` beside the innermost step or task (e.g. a search's best figure so far)."""

    def finish(self, label: str, seconds: float) -> None:
        """The step or task ``label`` ended after ``seconds`` [s] of wall time."""


_REPORTER: ContextVar[Reporter | None] = ContextVar("feedtune_progress_reporter", default=None)
_OPEN_STEP: ContextVar[tuple[str, float] | None] = ContextVar("feedtune_progress_open_step", default=None)


def _close_open_step(reporter: Reporter) -> None:
    open_step = _OPEN_STEP.get()
    if open_step is not None:
        label, t0 = open_step
        reporter.finish(label, time.perf_counter() - t0)
        _OPEN_STEP.set(None)


@contextmanager
def reporting(reporter: Reporter | None) -> Iterator[None]:
    """Show the progress of the work done inside the block with ``reporter`` (``None``: silence)."""
    token = _REPORTER.set(reporter)
    step_token = _OPEN_STEP.set(None)
    try:
        yield
    finally:
        if reporter is not None:
            _close_open_step(reporter)
        _OPEN_STEP.reset(step_token)
        _REPORTER.reset(token)


def step(label: str) -> None:
    """Announce that the step ``label`` starts; the step announced before it (if any) ends here."""
    reporter = _REPORTER.get()
    if reporter is None:
        return
    _close_open_step(reporter)
    reporter.start(label, None)
    _OPEN_STEP.set((label, time.perf_counter()))


def done() -> None:
    """End the step announced last (if any), e.g. before the command prints its summary."""
    reporter = _REPORTER.get()
    if reporter is not None:
        _close_open_step(reporter)


def note(text: str) -> None:
    """Show ``text`` beside the innermost step or task while it runs (a search's best figure so far and the number
    of candidates judged); a reporter that shows no live figures ignores it."""
    reporter = _REPORTER.get()
    if reporter is not None and hasattr(reporter, "note"):
        reporter.note(text)


@contextmanager
def task(label: str, total: int | None = None) -> Iterator[Callable[[int], None]]:
    """A task of ``total`` units inside the current step; yields ``advance(units=1)`` to call as units finish."""
    reporter = _REPORTER.get()
    if reporter is None:
        yield _ignore
        return
    t0 = time.perf_counter()
    reporter.start(label, total)
    try:
        yield lambda units=1: reporter.advance(units)
    finally:
        reporter.finish(label, time.perf_counter() - t0)


def _ignore(units: int = 1) -> None:
    return None


NOTE_EVERY_S = 0.2
"""Least time between two updates of a search's live figures [s] (a search judges thousands of candidates)."""


class Meter:
    """The live figures of a search: the candidates judged and the best figure of those that passed (see
    :func:`search`).

    Parameters
    ----------
    advance : callable, optional
        The task's ``advance`` (counts the candidates).
    """

    def __init__(self, advance: Callable[[int], None] = _ignore):
        self.advance = advance
        self.count = 0
        self.best: float | None = None
        self.figure, self.unit = "", ""
        self._shown = 0.0

    def judged(self, n: int = 1) -> None:
        """``n`` more candidates judged."""
        self.count += n
        self.advance(n)
        self._show()

    def passed(self, value: float) -> None:
        """A candidate that meets the limits, with its value of the figure the search maximises."""
        if self.best is None or value > self.best:
            self.best = float(value)
        self._show()

    def text(self) -> str:
        """``"1520 candidates judged, best Ki2 3.501e+04 V/(rad s)"``."""
        best = "" if self.best is None else f", best {self.figure} {self.best:.5g} {self.unit}".rstrip()
        return f"{self.count} candidates judged{best}"

    def _show(self, force: bool = False) -> None:
        now = time.perf_counter()
        if force or now - self._shown >= NOTE_EVERY_S:
            self._shown = now
            note(self.text())


@contextmanager
def search(label: str) -> Iterator[Meter]:
    """A task ``label`` for a search over candidates: yields a :class:`Meter`; the reporter shows the number of
    candidates judged and the best figure so far (and keeps them on the task's line when it ends). Inside another
    search (a tuner run by another, e.g. per filter candidate) it yields that search's meter and opens no task."""
    outer = _METER.get()
    if outer is not None:
        yield outer
        return
    with task(label) as advance:
        meter = Meter(advance)
        token = _METER.set(meter)
        try:
            yield meter
        finally:
            _METER.reset(token)
            if _REPORTER.get() is not None:
                meter._show(force=True)


def tasked(label: str) -> Callable:
    """Decorator: the function runs as the :func:`task` ``label`` (library functions that take seconds: an FRF
    estimate, a friction fit)."""
    return _running(task, label)


def searching(label: str) -> Callable:
    """Decorator: the function runs as :func:`search` ``label`` (its checks report through :func:`judged`)."""
    return _running(search, label)


def _running(context: Callable, label: str) -> Callable:
    """Decorator: the function runs inside ``context(label)``."""
    import functools

    def wrap(fn):
        @functools.wraps(fn)
        def run(*args, **kwargs):
            with context(label):
                return fn(*args, **kwargs)
        return run
    return wrap


def figure(name: str, unit: str = "") -> None:
    """Name the figure the running search maximises (``"Ki2"``, ``"V/(rad s)"``; ``"first crossover"``, ``"Hz"``)."""
    meter = _METER.get()
    if meter is not None:
        meter.figure, meter.unit = name, unit


def judged(value: float | None = None) -> None:
    """One candidate judged by the running search (:func:`search`; nothing outside one): its value of the figure
    (:func:`figure`) when it meets the limits, None when it does not."""
    meter = _METER.get()
    if meter is not None:
        meter.judged()
        if value is not None and math.isfinite(value):
            meter.passed(value)


_METER: ContextVar[Meter | None] = ContextVar("feedtune_progress_meter", default=None)


def active() -> bool:
    """True when a reporter is installed (e.g. to skip preparing labels that cost time to build)."""
    return _REPORTER.get() is not None
