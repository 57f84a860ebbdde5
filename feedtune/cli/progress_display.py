"""How the command line shows :mod:`feedtune.progress`: always on stderr, so ``--json`` output on stdout stays clean.

On a terminal (:class:`TerminalReporter`): one live line per open step or task (spinner, label, a bar when the amount
of work is known, the task's note such as a search's best figure so far, elapsed time), redrawn ten times a second
below everything printed; a finished step leaves one line with its wall time, and at the end the live lines are
erased, so the last lines on the screen are what the command printed (its summary and the paths it wrote). Whatever
the command prints while the display runs (its stdout and stderr lines, warnings) goes above the live lines: the
display erases them, lets the line through and draws them again below it, so nothing is glued to a bar and no
printed line is erased. Otherwise (a pipe, a CI log): one plain line per step still running a second after it
started (:class:`PlainReporter`). ``--quiet``: nothing.
"""

from __future__ import annotations

import os
import sys
import threading
import time
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
        timer = threading.Timer(self.delay_s, self._write, args=(line,))
        timer.daemon = True
        timer.start()
        self.pending.append(timer)

    def advance(self, units: int) -> None:
        """Nothing: a log file holds no bars."""

    def note(self, text: str) -> None:
        """Nothing: a log file holds no live figures."""

    def finish(self, label: str, seconds: float) -> None:
        """Cancel the line of a step that ended before its delay."""
        if self.pending:
            timer = self.pending.pop()
            if timer is not None:
                timer.cancel()


SPINNER = "⠋⠙⠹⠸⠼⠴⠦⠧⠇⠏"
"""Spinner frames on a terminal that writes UTF-8 (``|/-\\`` otherwise)."""
BAR_WIDTH = 30
"""Characters of a task's bar."""
REFRESH_S = 0.1
"""Time between two redraws of the live lines [s]."""
DONE_DEPTH = 2
"""Finished steps and tasks nested at most this deep leave their ``done`` line (deeper ones vanish)."""

_ERASE_LINE = "\r\x1b[2K"
_UP = "\x1b[1A"
_HIDE_CURSOR, _SHOW_CURSOR = "\x1b[?25l", "\x1b[?25h"


class _Live:
    """One open step or task on the live display."""

    __slots__ = ("done", "label", "note", "t0", "total")

    def __init__(self, label: str, total: int | None):
        self.label, self.total, self.done, self.note, self.t0 = label, total, 0, "", time.monotonic()


class TerminalReporter:
    """The live display on a terminal ``stream`` (module docstring).

    Parameters
    ----------
    stream : TextIO
        The terminal (stderr).
    width : int, optional
        Columns of the terminal (default: as the terminal says, else 80); every live line is cut to fit one row.
    """

    def __init__(self, stream: TextIO, width: int | None = None):
        self.stream = stream
        self.width = width
        self.open: list[_Live] = []
        self.drawn = 0  # live lines on the screen now
        self.lock = threading.RLock()
        self.frame = 0
        self.spinner = SPINNER if _writes_utf8(stream) else "|/-\\"
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self.closing = False

    # ------------------------------------------------------------------ the Reporter protocol
    def start(self, label: str, total: int | None) -> None:
        """A live line for ``label`` (with a bar when ``total`` is known)."""
        with self.lock:
            self.open.append(_Live(label, total))
            self._redraw()

    def advance(self, units: int) -> None:
        """Move the bar of the innermost task."""
        with self.lock:
            if self.open:
                self.open[-1].done += units

    def note(self, text: str) -> None:
        """Show ``text`` after the innermost task's label (a search's best figure so far)."""
        with self.lock:
            if self.open:
                self.open[-1].note = text

    def finish(self, label: str, seconds: float) -> None:
        """Remove the task's live line; a step or task not nested deeper than :data:`DONE_DEPTH` leaves
        ``done label  1.2 s`` above the display."""
        with self.lock:
            depth = len(self.open) - 1
            live = self.open.pop() if self.open else None
            if depth < DONE_DEPTH and not self.closing:
                extra = f"  ({live.note})" if live is not None and live.note else ""
                self.print_above(f"{'  ' * depth}done {label}  {seconds:.1f} s{extra}\n", self.stream)
            else:
                self._redraw()

    # ------------------------------------------------------------------ drawing
    def begin(self) -> None:
        """Hide the cursor and start redrawing the live lines every :data:`REFRESH_S`."""
        self._write(_HIDE_CURSOR)
        self._thread = threading.Thread(target=self._run, name="feedtune-progress", daemon=True)
        self._thread.start()

    def end(self) -> None:
        """Stop redrawing, erase the live lines and show the cursor again."""
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=1.0)
        with self.lock:
            self._erase()
            self.open.clear()
            self._write(_SHOW_CURSOR)

    def print_above(self, text: str, target: TextIO) -> None:
        """Write ``text`` (whole lines) to ``target`` above the live lines: erase them, write, draw them again."""
        with self.lock:
            self._erase()
            try:
                target.write(text)
                target.flush()
            except (OSError, ValueError):
                pass
            self._redraw()

    def _run(self) -> None:
        while not self._stop.wait(REFRESH_S):
            with self.lock:
                self.frame += 1
                self._redraw()

    def _erase(self) -> None:
        if self.drawn:
            self._write(_ERASE_LINE + (_UP + _ERASE_LINE) * self.drawn)
            self.drawn = 0

    def _redraw(self) -> None:
        lines = [self._line(i, live) for i, live in enumerate(self.open)]
        out = (_ERASE_LINE + (_UP + _ERASE_LINE) * self.drawn) if self.drawn else ""
        out += "".join(line + "\n" for line in lines)
        self.drawn = len(lines)
        self._write(out)

    def _columns(self) -> int:
        if self.width:
            return self.width
        try:
            return os.get_terminal_size(self.stream.fileno()).columns
        except (AttributeError, OSError, ValueError):
            return 80

    def _line(self, depth: int, live: _Live) -> str:
        elapsed = int(time.monotonic() - live.t0)
        clock = f"{elapsed // 60}:{elapsed % 60:02d}"
        parts = [f"{'  ' * depth}{self.spinner[self.frame % len(self.spinner)]} {live.label}"]
        if live.total:
            frac = min(max(live.done / live.total, 0.0), 1.0)
            full = round(frac * BAR_WIDTH)
            parts.append("━" * full + "╺" * (full < BAR_WIDTH) + " " * max(BAR_WIDTH - full - 1, 0)
                         if self.spinner is SPINNER else "#" * full + "-" * (BAR_WIDTH - full))
            parts.append(f"{min(live.done, live.total)}/{live.total}")
        if live.note:
            parts.append(live.note)
        line = "  ".join(parts)
        room = self._columns() - len(clock) - 3
        if len(line) > room:  # one row each: a wrapped line would leave a stale row behind
            line = line[:max(room - 1, 0)] + "…" if self.spinner is SPINNER else line[:max(room, 0)]
        return f"{line}  {clock}"

    def _write(self, text: str) -> None:
        if not text:
            return
        try:
            self.stream.write(text)
            self.stream.flush()
        except (OSError, ValueError):  # a closed terminal: progress is never worth an error
            pass


class _Above:
    """A text stream that writes its whole lines above the live display (stdout or stderr while it runs)."""

    def __init__(self, reporter: TerminalReporter, target: TextIO):
        self._reporter = reporter
        self._target = target
        self._partial = ""

    def write(self, text: str) -> int:
        self._partial += text
        if "\n" in self._partial:
            head, _, self._partial = self._partial.rpartition("\n")
            self._reporter.print_above(head + "\n", self._target)
        return len(text)

    def flush(self) -> None:
        """Whole lines are written as they come; a partial line waits for its end (or the end of the display)."""

    def finish(self) -> None:
        """Write a partial line left at the end."""
        if self._partial:
            self._reporter.print_above(self._partial, self._target)
            self._partial = ""

    def isatty(self) -> bool:
        return self._target.isatty()

    def fileno(self) -> int:
        return self._target.fileno()

    def writable(self) -> bool:
        return True

    @property
    def encoding(self) -> str:
        return getattr(self._target, "encoding", "utf-8")

    @property
    def errors(self) -> str | None:
        return getattr(self._target, "errors", "strict")

    def __getattr__(self, name):
        return getattr(self._target, name)


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
    reporter = TerminalReporter(stream)
    redirected = _same_terminal_streams(stream)  # {"stdout": stream, ...} printing to the display's terminal
    proxies = {name: _Above(reporter, target) for name, target in redirected.items()}
    for name, proxy in proxies.items():
        setattr(sys, name, proxy)
    reporter.begin()
    try:
        with progress.reporting(reporter):
            try:
                yield
            finally:  # a step still open when the command ends leaves no line below what the command printed
                reporter.closing = True
    finally:
        for name, target in redirected.items():
            if getattr(sys, name) is proxies[name]:
                setattr(sys, name, target)
        reporter.end()
        for proxy in proxies.values():
            proxy.finish()


def _same_terminal_streams(stream: TextIO) -> dict[str, TextIO]:
    """``sys.stdout`` and ``sys.stderr`` where they write to the terminal of ``stream`` (their lines must go above
    the live display)."""
    out = {}
    try:
        here = os.fstat(stream.fileno())
    except (AttributeError, OSError, ValueError):
        return out
    for name in ("stdout", "stderr"):
        target = getattr(sys, name)
        try:
            st = os.fstat(target.fileno())
        except (AttributeError, OSError, ValueError):
            continue
        if target.isatty() and (st.st_rdev, st.st_dev) == (here.st_rdev, here.st_dev):
            out[name] = target
    return out


def _writes_utf8(stream: TextIO) -> bool:
    return "utf" in (getattr(stream, "encoding", "") or "").lower()


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
