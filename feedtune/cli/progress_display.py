"""How the command line shows :mod:`feedtune.progress`: always on stderr, so ``--json`` output on stdout stays clean.

On a terminal: a live rich display (spinner, bar when the amount of work is known, elapsed time) that leaves one line
per finished step. Otherwise (a pipe, a CI log): one plain line per step still running a second after it started.
``--quiet``: nothing.
"""

from __future__ import annotations

import sys
from contextlib import contextmanager
from typing import TextIO

import typer

QUIET_OPTION = typer.Option(False, "--quiet", "-q", help="Show no progress on stderr (warnings and errors still show).")


class PlainReporter:
    """One line on ``stream`` per step or task still running ``delay_s`` after it started:
    ``feedtune: tuning MC-PPC ...``.

    Steps that end sooner print nothing, so quick commands (and errors found in the first second) keep stderr to
    the warnings and the one error line; long work still says what it is doing while it does it.
    """

    def __init__(self, stream: TextIO, delay_s: float = 1.0):
        self.stream = stream
        self.delay_s = delay_s
        self.pending: list = []

    def _write(self, line: str) -> None:
        try:
            self.stream.write(line)
            self.stream.flush()
        except (OSError, ValueError):  # a closed stderr: progress is never worth an error
            pass

    def start(self, label: str, total: int | None) -> None:
        """Write the line of a starting step (with its number of units when known), after ``delay_s``."""
        extra = f" ({total})" if total else ""
        line = f"feedtune: {label}{extra} ...\n"
        if self.delay_s <= 0:
            self._write(line)
            self.pending.append(None)
            return
        import threading

        timer = threading.Timer(self.delay_s, self._write, args=(line,))
        timer.daemon = True
        timer.start()
        self.pending.append(timer)

    def advance(self, units: int) -> None:
        """Nothing: a log file holds no bars."""

    def finish(self, label: str, seconds: float) -> None:
        """Cancel the line of a step that ended before its delay."""
        if self.pending:
            timer = self.pending.pop()
            if timer is not None:
                timer.cancel()


class RichReporter:
    """A live display on a terminal's stderr; a finished step stays as one line with its wall time [s]."""

    def __init__(self, progress):
        self.progress = progress
        self.tasks: list = []

    def start(self, label: str, total: int | None) -> None:
        """Add a spinner (and a bar when ``total`` is known) for ``label``."""
        self.tasks.append(self.progress.add_task(label, total=total))

    def advance(self, units: int) -> None:
        """Move the bar of the innermost task."""
        if self.tasks:
            self.progress.advance(self.tasks[-1], units)

    def finish(self, label: str, seconds: float) -> None:
        """Remove the task's live line and leave ``label  1.2 s`` above the display."""
        if self.tasks:
            self.progress.remove_task(self.tasks.pop())
        indent = "  " * len(self.tasks)
        self.progress.console.print(f"{indent}[green]done[/green] {label}  [dim]{seconds:.1f} s[/dim]",
                                    highlight=False, markup=True)


@contextmanager
def shown(quiet: bool = False, stream: TextIO | None = None, delay_s: float = 1.0):
    """Install the command line's progress reporter for the work inside the block (see the module docstring)."""
    from .. import progress

    if quiet:
        with progress.reporting(None):
            yield
        return
    stream = sys.stderr if stream is None else stream
    if not _is_terminal(stream):
        with progress.reporting(PlainReporter(stream, delay_s)):
            yield
        return
    from rich.console import Console
    from rich.progress import BarColumn, Progress, SpinnerColumn, TextColumn, TimeElapsedColumn

    console = Console(file=stream, stderr=stream is sys.stderr)
    columns = (SpinnerColumn(), TextColumn("{task.description}"), BarColumn(), TimeElapsedColumn())
    with Progress(*columns, console=console, transient=True) as live, progress.reporting(RichReporter(live)):
        yield


def _is_terminal(stream: TextIO) -> bool:
    try:
        return stream.isatty()
    except (AttributeError, ValueError):
        return False


def show_progress(quiet: bool) -> None:
    """Show the progress of the running command until it ends (:func:`shown` tied to the command's context)."""
    from .envelope import _context

    ctx = _context()
    if ctx is not None:
        ctx.with_resource(shown(quiet))
