"""CLI conventions: ``--version`` and ``python -m feedtune``."""

from __future__ import annotations

import subprocess
import sys

from feedtune import __version__


def test_version_and_python_dash_m():
    for module in ("feedtune", "feedtune.cli.main"):
        res = subprocess.run([sys.executable, "-m", module, "--version"], capture_output=True, text=True, check=False)
        assert res.returncode == 0 and res.stdout.strip() == f"feedtune {__version__}", res
    res = subprocess.run([sys.executable, "-m", "feedtune", "nope"], capture_output=True, text=True, check=False)
    assert res.returncode == 2 and "nope" in res.stderr


def test_a_signal_swallowed_by_a_library_is_still_reported_as_the_interruption(monkeypatch, capsys):
    """numba compiling inside a ctypes callback swallows the exception SIGINT raises and then fails with a
    RuntimeError of its own: the run must end as interrupted (130), not as an internal error."""
    import os
    import signal

    import pytest

    import feedtune.cli.main as cli

    def swallowing_app(**kwargs):
        try:
            os.kill(os.getpid(), signal.SIGINT)  # the handler main() installed raises inside this try
        except BaseException:  # what the library does
            pass
        raise RuntimeError("no compiled object yet")

    monkeypatch.setattr(cli, "_command", lambda: swallowing_app)
    with pytest.raises(SystemExit) as exc:
        cli.main()
    assert exc.value.code == 130
    assert capsys.readouterr().err.strip().splitlines()[-1] == "feedtune: interrupted"
