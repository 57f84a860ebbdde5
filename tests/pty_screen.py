"""Run a command on a pseudo-terminal and keep what a user would see: the screen of a terminal emulator (pyte)."""

from __future__ import annotations

import os
import select
import subprocess
import sys
import time
from dataclasses import dataclass, field


@dataclass
class TerminalRun:
    """A finished run on a pseudo-terminal.

    Attributes
    ----------
    code : int
        Exit code.
    lines : list of str
        The lines of the final screen and its scrollback, trailing blanks stripped, blank lines at the end dropped.
    first_output_s : float or None
        Seconds from the start to the first visible character on the terminal.
    seconds : float
        Wall time of the run [s].
    snapshots : list of (float, str)
        ``(seconds, screen text)`` each time new output arrived (for what was shown while it ran).
    """

    code: int
    lines: list[str]
    first_output_s: float | None
    seconds: float
    snapshots: list = field(default_factory=list)

    def first_seen(self, shows) -> float | None:
        """Seconds from the start to the first screen for which ``shows(screen text)`` is true (None: never)."""
        return next((t for t, text in self.snapshots if shows(text)), None)

    def tail(self, n: int) -> list[str]:
        """The last ``n`` non-blank lines of the final screen."""
        return [x for x in self.lines if x.strip()][-n:]


def run_on_terminal(args: list[str], cwd=None, env=None, columns: int = 120, rows: int = 40,
                    timeout_s: float = 600.0) -> TerminalRun:
    """Run ``args`` with stdin, stdout and stderr on one pseudo-terminal of ``columns`` x ``rows``; emulate the
    terminal (cursor moves, line erases, colours dropped) and return its final screen with the scrollback."""
    import pty

    import pytest

    pyte = pytest.importorskip("pyte")  # a terminal emulator (test extra)

    screen = pyte.HistoryScreen(columns, rows, history=5000)
    stream = pyte.ByteStream(screen)
    master, slave = pty.openpty()
    import fcntl
    import struct
    import termios

    fcntl.ioctl(slave, termios.TIOCSWINSZ, struct.pack("HHHH", rows, columns, 0, 0))
    full_env = {**os.environ, "TERM": "xterm-256color", "COLUMNS": str(columns), "LINES": str(rows),
                **(env or {})}
    full_env.pop("NO_COLOR", None)
    t0 = time.perf_counter()
    proc = subprocess.Popen(args, stdin=slave, stdout=slave, stderr=slave, cwd=cwd, env=full_env,
                            close_fds=True, start_new_session=True)
    os.close(slave)
    first = None
    snapshots = []
    while True:
        ready, _, _ = select.select([master], [], [], 0.05)
        if ready:
            try:
                data = os.read(master, 65536)
            except OSError:  # EIO: the child closed the terminal
                data = b""
            if not data:
                break
            stream.feed(data)
            now = time.perf_counter() - t0
            text = "\n".join(screen.display)
            if first is None and text.strip():
                first = now
            snapshots.append((now, text))
        elif proc.poll() is not None:
            # drain what is left
            try:
                while select.select([master], [], [], 0.1)[0]:
                    data = os.read(master, 65536)
                    if not data:
                        break
                    stream.feed(data)
            except OSError:
                pass
            break
        if time.perf_counter() - t0 > timeout_s:
            proc.kill()
            break
    code = proc.wait()
    os.close(master)
    history = ["".join(ch.data for ch in line.values()) if isinstance(line, dict) else
               "".join(line[x].data for x in sorted(line)) for line in screen.history.top]
    lines = [x.rstrip() for x in [*history, *screen.display]]
    while lines and not lines[-1]:
        lines.pop()
    return TerminalRun(code, lines, first, time.perf_counter() - t0, snapshots)


def feedtune_command(*args: str) -> list[str]:
    """``python -m feedtune ARGS`` with this interpreter."""
    return [sys.executable, "-m", "feedtune", *map(str, args)]
