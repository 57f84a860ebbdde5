"""Progress of long work: the library names its steps, the caller decides whether and how they are shown.

Library code that can take more than a second or two announces what it does::

    from feedtune import progress

    progress.step("tuning MC-PPC")                 # a named step; the previous one ends
    with progress.task("rendering figures", total=12) as advance:
        for fig in figures:
            render(fig)
            advance()                              # one unit of the task done

Nothing is shown unless a reporter is installed with :func:`reporting` (the command line installs one that writes
to stderr: a live display on a terminal, plain lines otherwise, nothing with ``--quiet``). Notebooks and scripts stay
silent by default. Reporters are held in a :class:`contextvars.ContextVar`, so threads and nested calls do not mix.
"""

from __future__ import annotations

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


def active() -> bool:
    """True when a reporter is installed (e.g. to skip preparing labels that cost time to build)."""
    return _REPORTER.get() is not None
