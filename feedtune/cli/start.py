"""The entry point of the ``feedtune`` console script and of ``python -m feedtune``: the interrupt handlers first,
then the command line.

Importing the command line (typer, rich, every command module) takes a few hundred milliseconds; a Ctrl-C in that time
used to end the process with a KeyboardInterrupt traceback. This module imports nothing heavy (``import feedtune``
itself is a few milliseconds: its names load on first use), installs the handlers of SIGINT and SIGTERM, and only
then imports :mod:`feedtune.cli.main`: an interrupt at any moment ends the command with ``feedtune: interrupted``
(exit 130) or ``feedtune: terminated`` (143), no traceback, and the ``finally`` blocks remove unfinished outputs.
"""

from __future__ import annotations

import os
import signal
import sys

BLAS_THREAD_VARIABLES = ("OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "BLIS_NUM_THREADS", "VECLIB_MAXIMUM_THREADS")
"""Set to 1 before numpy loads unless the user set them: feedtune's matrices are tiny (:mod:`feedtune.blas`)."""


class Signalled(BaseException):
    """SIGINT or SIGTERM, turned into an exception that the command-line framework does not swallow (typer turns
    KeyboardInterrupt into a silent exit 130), so that ``finally`` blocks remove temporary files."""

    def __init__(self, signum: int):
        super().__init__(signum)
        self.signum = signum


RECEIVED: list[int] = []
"""Signals received in this run: a library that swallows the exception (numba compiling inside a ctypes callback)
fails later with an error of its own, which is then reported as the interruption it is."""


def _on_signal(signum, frame):
    RECEIVED.append(signum)
    raise Signalled(signum)


def exit_signalled(signum: int):
    """Print ``feedtune: interrupted`` (SIGINT, exit 130) or ``feedtune: terminated`` (SIGTERM, 143) and exit."""
    interrupted = signum == signal.SIGINT
    try:
        sys.stderr.write(f"feedtune: {'interrupted' if interrupted else 'terminated'}\n")
        sys.stderr.flush()
    except (OSError, ValueError):
        pass
    sys.exit(130 if interrupted else 143)


def install_handlers() -> dict:
    """Set the process up for a command-line run: the BLAS thread variables, ``FEEDTUNE_JOBS``, SIGINT and SIGTERM
    raising :class:`Signalled`, SIGPIPE ending the process quietly. Returns the previous handlers
    (:func:`restore_handlers`)."""
    for name in BLAS_THREAD_VARIABLES:
        os.environ.setdefault(name, "1")
    os.environ.setdefault("FEEDTUNE_JOBS", "auto")  # independent steps side by side (feedtune.parallel)
    RECEIVED.clear()
    handlers = {sig: signal.getsignal(sig) for sig in (signal.SIGTERM, signal.SIGINT)}
    signal.signal(signal.SIGTERM, _on_signal)
    signal.signal(signal.SIGINT, _on_signal)
    if hasattr(signal, "SIGPIPE"):  # a closed stdout (a pipe into head) ends the process quietly, as for cat
        handlers[signal.SIGPIPE] = signal.getsignal(signal.SIGPIPE)
        signal.signal(signal.SIGPIPE, signal.SIG_DFL)
    return handlers


def restore_handlers(handlers: dict) -> None:
    """Put back the handlers :func:`install_handlers` replaced (a run in-process leaves its caller as it was)."""
    for sig, handler in handlers.items():
        signal.signal(sig, handler)


def main() -> None:
    """Entry point of the ``feedtune`` console script: the handlers, then :func:`feedtune.cli.main.run`."""
    handlers = install_handlers()
    try:
        from .main import run

        run()
    except Signalled as sig:  # during the imports, or anywhere run() does not handle it
        exit_signalled(sig.signum)
    finally:
        restore_handlers(handlers)
